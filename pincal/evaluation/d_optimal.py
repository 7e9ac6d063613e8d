r"""D-optimality: F = −log det(M + Λ) = log det (M + Λ)⁻¹, the log volume of the confidence
ellipsoid of the parameters (it mixes units when they mix lengths and angles).

After a swap of configurations, det M'/det M is the determinant of the Woodbury capacitance
(:mod:`pincal.evaluation.low_rank`): F' = F − log det H, no factorisation per candidate.
"""

from __future__ import annotations

import numpy as np

from pincal.evaluation.criterion import Criterion, scaled_eigh, singular_value_result
from pincal.evaluation.information import factor
from pincal.lapack import trtrs


class DOptimal(Criterion):
    """D-optimality (see module doc); reported as log det (M + Λ)⁻¹.

    Args:
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ, or None.
    """

    name = "D"
    label = "log det M⁻¹"

    def value(self, M: np.ndarray, m: int) -> float:
        L = factor(self.posterior(M), self.rows, m)
        return float(-2.0 * np.log(L.diagonal()).sum())

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        L = factor(self.posterior(M), self.rows, m)
        Linv = trtrs(L, np.eye(len(M)))
        return float(-2.0 * np.log(L.diagonal()).sum()), -(Linv.T @ Linv)

    def report(self, F):
        return F

    def from_singular_values(self, s: np.ndarray) -> float | np.ndarray:
        """log det M⁻¹ from the singular values of the stacked Jacobian (no prior): a float, or
        (k,) for the singular values (k, P) of k plans."""
        return singular_value_result(-2.0 * np.sum(np.log(s), axis=-1))

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        d, w, _, singular = scaled_eigh(self.posterior(Ms), vectors=False)
        F = -(2.0 * np.log(d).sum(axis=1) + np.log(np.where(singular[:, None], 1.0, w)).sum(axis=1))
        F[singular] = np.nan
        return F

    def exchange_values(self, swap) -> tuple[np.ndarray, None]:
        return swap.F - np.log(swap.ratio[swap.cand]), None
