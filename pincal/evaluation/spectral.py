r"""The shared arithmetic of the criteria of the extreme eigenvalues of M + Λ (E-optimality and
the condition number): their values after a swap of configurations come from the eigenvalues of
the swapped information matrix itself (no low-rank shortcut for an eigenvalue)."""

from __future__ import annotations

import numpy as np

from pincal.evaluation.criterion import Criterion, scaled_eigh
from pincal.evaluation.information import RCOND, factor


class Spectral(Criterion):
    """A criterion of λ_min and λ_max of M + Λ; subclasses give F from them
    (:meth:`from_extremes`) and its gradient weights (:meth:`extreme_weights`)."""

    def from_extremes(self, lo_log: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """F from log λ_min and λ_max."""
        raise NotImplementedError

    def gradient(self, w: np.ndarray, V: np.ndarray) -> np.ndarray:
        """∂F/∂M from the ascending eigenvalues w and eigenvectors V of M + Λ."""
        raise NotImplementedError

    def from_eigenvalues(self, w: np.ndarray) -> np.ndarray:
        """F from ascending eigenvalues (..., P) of M + Λ (inf where λ_min ≤ 0)."""
        w = np.asarray(w)
        lo = w[..., 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.log(np.where(lo > 0, lo, 1.0))
            F = self.from_extremes(logs, w[..., -1])
        return np.where(lo > RCOND * np.abs(w[..., -1]), F, np.inf)

    def value(self, M: np.ndarray, m: int) -> float:
        M = self.posterior(M)
        factor(M, self.rows, m)
        return float(self.from_eigenvalues(np.linalg.eigvalsh(M)))

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        M = self.posterior(M)
        factor(M, self.rows, m)
        w, V = np.linalg.eigh(M)
        return float(self.from_eigenvalues(w)), self.gradient(w, V)

    def report(self, F):
        return np.exp(F)

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        Ms = self.posterior(Ms)
        *_, singular = scaled_eigh(Ms, vectors=False)
        F = self.from_eigenvalues(np.linalg.eigvalsh(Ms))
        F[singular] = np.nan
        return F

    def exchange_values(self, swap) -> tuple[np.ndarray, None]:
        Mc = swap.M + swap.state.pool_information[swap.cand] - swap.Ji.T @ swap.Ji
        return self.from_eigenvalues(np.linalg.eigvalsh(self.posterior(Mc))), None
