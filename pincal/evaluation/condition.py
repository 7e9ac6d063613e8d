r"""The condition number: F = ½ log(λ_max/λ_min) of M + Λ, the log of σ_max/σ_min of the stacked
Jacobian (see :mod:`pincal.evaluation.spectral`). Unlike D, A and E it does not change with the
scale of the plan, only with its shape."""

from __future__ import annotations

import numpy as np

from pincal.evaluation.criterion import singular_value_result
from pincal.evaluation.spectral import Spectral


class Condition(Spectral):
    """The condition number; reported as σ_max(J)/σ_min(J).

    Args:
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ, or None.
    """

    name = "cond"
    label = "cond"

    def from_extremes(self, lo_log: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return 0.5 * (np.log(np.abs(hi) + 1e-300) - lo_log)

    def gradient(self, w: np.ndarray, V: np.ndarray) -> np.ndarray:
        lo, hi = V[:, 0], V[:, -1]
        G = -np.outer(lo, lo) / w[0]
        return 0.5 * (G + np.outer(hi, hi) / w[-1])

    def from_singular_values(self, s: np.ndarray) -> float | np.ndarray:
        """σ_max/σ_min from the singular values of the stacked Jacobian (no prior): a float, or
        (k,) for the singular values (k, P) of k plans."""
        return singular_value_result(s[..., 0] / s[..., -1])
