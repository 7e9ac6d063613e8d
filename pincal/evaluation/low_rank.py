r"""The value of an information criterion after swapping one configuration of a plan for every
candidate of a pool at once (docs/method.md §7.2): low-rank (Woodbury) updates of the inverse
information matrix.

Swapping configuration i (rows Jᵢ) for candidate c (rows J_c, r rows each) changes the posterior
information by a rank-2r term, M' = M + U C Uᵀ with U = [J_cᵀ, Jᵢᵀ] and C = diag(I, −I). With
the capacitance H = C⁻¹ + Uᵀ M⁻¹ U (2r×2r), Sherman–Morrison–Woodbury gives

    M'⁻¹ = M⁻¹ − M⁻¹ U H⁻¹ Uᵀ M⁻¹,       det M' / det M = (−1)^r det H,

so every candidate is scored from a few batched 2r×2r operations — no P×P inversion. The
criterion says what its value is from them (:meth:`~pincal.evaluation.criterion.Criterion.exchange_values`):
D from the determinant ratio, the weighted traces from tr(W M'⁻¹) = tr(W M⁻¹) − ⟨Q, H⁻¹Q⟩ with
Q = Uᵀ M⁻¹ J0ᵀ, E and cond from the eigenvalues of M' itself. An accepted swap updates M⁻¹ the same
way; :meth:`InformationExchange.resync` recomputes it from M to keep rounding from drifting.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.linalg import cho_solve

from pincal.evaluation.information import factor

LOG_MIN_RATIO = np.log(1e-12)
"""Swaps that shrink det M by more than this factor are taken as singular."""


def inverse(M: np.ndarray, rows: int, m: int) -> np.ndarray:
    """M⁻¹ by a Cholesky factor (raises SingularPlan)."""
    L = factor(M, rows, m)
    return cho_solve((L, True), np.eye(len(M)))


def capacitance(S_cc: np.ndarray, A: np.ndarray, Ji: np.ndarray, Ai: np.ndarray) -> np.ndarray:
    """(N, 2r, 2r) the Woodbury capacitance matrices of swapping configuration i (rows Ji, Ai =
    Ji M⁻¹) for each candidate c (S_cc = J_c M⁻¹ J_cᵀ, A = J_c M⁻¹): their determinants are the
    ratios det M'/det M, and they solve the updates of M⁻¹ and of the weighted traces."""
    N, r, _ = A.shape
    H = np.empty((N, 2 * r, 2 * r))
    H[:, :r, :r] = S_cc + np.eye(r)
    H[:, :r, r:] = A @ Ji.T
    H[:, r:, :r] = np.swapaxes(H[:, :r, r:], 1, 2)
    H[:, r:, r:] = Ai @ Ji.T - np.eye(r)
    return H


@dataclass(frozen=True, eq=False)
class Swaps:
    """The candidate swaps of configuration i, for a criterion's
    :meth:`~pincal.evaluation.criterion.Criterion.exchange_values`.

    Attributes:
        cand: (n,) pool indices of the candidates scored (allowed, and leaving a regular plan).
        F: the criterion's value F before the swap.
        aux: what the criterion keeps of the plan (its weighted traces), or None.
        M: (P, P) the data's information matrix before the swap (no prior).
        Minv: (P, P) (M + Λ)⁻¹ before the swap.
        Ji: (r, P) the rows of configuration i.
        H: (N, 2r, 2r) the capacitance of every pool candidate (index it with ``cand``).
        logdet: (N,) log |det H| of every pool candidate: log det M'/det M.
        products: the criterion's :meth:`exchange_products` of every pool candidate.
        state: the exchange state (its pool's information matrices, on demand).
    """

    cand: np.ndarray
    F: float
    aux: object
    M: np.ndarray
    Minv: np.ndarray
    Ji: np.ndarray
    H: np.ndarray
    logdet: np.ndarray
    products: object
    state: InformationExchange


class InformationExchange:
    """The exchange state of an information criterion: M, (M + Λ)⁻¹ and F of a plan of pool
    configurations, kept up to date by Woodbury updates (see module doc and
    :class:`~pincal.evaluation.criterion.ExchangeState`).

    Args:
        criterion: the criterion.
        J_pool: (N, r, P) tip-frame Jacobians of the pool.
        index: (m,) pool indices of the plan (its posterior information must be regular).
    """

    def __init__(self, criterion, J_pool: np.ndarray, index: np.ndarray) -> None:
        self.criterion = criterion
        self.J_pool = J_pool
        self.index = np.array(index)
        N, self.r, self.P = J_pool.shape
        self.sign = (-1.0) ** self.r
        self.resync()

    @cached_property
    def pool_information(self) -> np.ndarray:
        """(N, P, P) J_cᵀJ_c of every pool candidate."""
        return np.einsum("nrp,nrs->nps", self.J_pool, self.J_pool)

    def resync(self) -> None:
        Jd = self.J_pool[self.index].reshape(-1, self.P)
        m = len(self.index)
        self.M = Jd.T @ Jd
        self.Minv = inverse(self.criterion.posterior(self.M), self.r, m)
        self.F, self.aux = self.criterion.exchange_exact(self.M, m)
        self.stale = True

    def _products(self) -> None:
        N, r, P = self.J_pool.shape
        flat = self.J_pool.reshape(N * r, P)
        self.A = (flat @ self.Minv).reshape(N, r, P)  # J_c M⁻¹
        self.S_cc = np.einsum("nrp,nsp->nrs", self.A, self.J_pool)
        self.products = self.criterion.exchange_products(self.J_pool, self.Minv)
        self.stale = False

    def scores(self, i: int, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.stale:
            self._products()
        Ji = self.J_pool[self.index[i]]
        Ai = Ji @ self.Minv
        H = capacitance(self.S_cc, self.A, Ji, Ai)
        sign, logdet = np.linalg.slogdet(H)
        ok = allowed & (sign * self.sign > 0) & (logdet > LOG_MIN_RATIO)
        cand = np.flatnonzero(ok)
        if not len(cand):
            self._last = None
            return cand, np.empty(0)
        swaps = Swaps(cand, self.F, self.aux, self.M, self.Minv, Ji, H, logdet, self.products, self)
        values, aux = self.criterion.exchange_values(swaps)
        self._last = (i, cand, values, aux, Ai, H)
        return cand, values

    def swap(self, i: int, best: int) -> None:
        last_i, cand, values, aux, Ai, H = self._last
        assert last_i == i
        c = int(cand[best])
        Ji = self.J_pool[self.index[i]]
        UtMinv = np.concatenate([self.A[c], Ai])  # Uᵀ M⁻¹, (2r, P)
        Minv = self.Minv - UtMinv.T @ np.linalg.solve(H[c], UtMinv)
        self.Minv = 0.5 * (Minv + Minv.T)
        self.M = self.M + self.J_pool[c].T @ self.J_pool[c] - Ji.T @ Ji
        self.index[i] = c
        self.F = float(values[best])
        if aux is not None:
            self.aux = aux[best]
        self.stale = True
