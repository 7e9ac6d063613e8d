r"""E-optimality: F = −log λ_min(M + Λ) = log λ_max((M + Λ)⁻¹), the log of the largest variance
of any unit combination of the parameters (see :mod:`pincal.evaluation.spectral`)."""

from __future__ import annotations

import numpy as np

from pincal.evaluation.criterion import singular_value_result
from pincal.evaluation.spectral import Spectral


class EOptimal(Spectral):
    """E-optimality; reported as λ_max((M + Λ)⁻¹).

    Args:
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ, or None.
    """

    name = "E"
    label = "λ_max(M⁻¹)"

    def from_extremes(self, lo_log: np.ndarray, hi: np.ndarray) -> np.ndarray:
        return -lo_log

    def gradient(self, w: np.ndarray, V: np.ndarray) -> np.ndarray:
        lo = V[:, 0]
        return -np.outer(lo, lo) / w[0]

    def from_singular_values(self, s: np.ndarray) -> float | np.ndarray:
        """λ_max(M⁻¹) from the singular values of the stacked Jacobian (no prior): a float, or
        (k,) for the singular values (k, P) of k plans."""
        return singular_value_result(1.0 / s[..., -1] ** 2)
