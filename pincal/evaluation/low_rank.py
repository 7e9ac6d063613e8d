r"""The value of an information criterion after swapping one configuration of a plan for every
candidate of a pool at once (docs/method.md §7.2): low-rank (Woodbury) updates of the inverse
information matrix.

Swapping configuration i (rows Jᵢ) for candidate c (rows J_c, r rows each) changes the posterior
information by a rank-2r term, M' = M + U C Uᵀ with U = [J_cᵀ, Jᵢᵀ] and C = diag(I, −I). With
the capacitance H = C⁻¹ + Uᵀ M⁻¹ U (2r×2r), Sherman–Morrison–Woodbury gives

    M'⁻¹ = M⁻¹ − M⁻¹ U H⁻¹ Uᵀ M⁻¹,       det M' / det M = (−1)^r det H,

so every candidate is scored from a few 2r×2r operations — no P×P inversion. H is factored in
blocks, entry by entry over the whole pool (:func:`swap_blocks`: H = [[X, B], [Bᵀ, D − I]],
X = J_c M⁻¹ J_cᵀ + I = LLᵀ, the Schur complement D − I − VᵀV = −KKᵀ with V = L⁻¹B), with no LAPACK
call per candidate: det M'/det M = det X·det(−Z), and a swap is regular exactly when both factors
exist. The criterion says what its value is from them
(:meth:`~pincal.evaluation.criterion.Criterion.exchange_values`): D from the determinant ratio, a
weighted trace tr(W M'⁻¹) = tr(W M⁻¹) − tr(H⁻¹G) with G the 2r×2r blocks of Uᵀ M⁻¹WM⁻¹ U
(:meth:`Blocks.trace`; column by column for several weights, :meth:`Blocks.quadratic`), E and cond
from the eigenvalues of M' itself. An accepted swap updates M⁻¹ the same way;
:meth:`InformationExchange.resync` recomputes it from M to keep rounding from drifting.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pincal.evaluation.information import factor
from pincal.lapack import cho_solve

LOG_MIN_RATIO = np.log(1e-12)
"""Swaps that shrink det M by more than this factor are taken as singular."""


def inverse(M: np.ndarray, rows: int, m: int) -> np.ndarray:
    """M⁻¹ by a Cholesky factor (raises SingularPlan)."""
    L = factor(M, rows, m)
    return cho_solve(L, np.eye(len(M)))


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


def small_cholesky(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(L, ok): lower Cholesky factors of a stack (n, r, r) of small symmetric matrices, entry by
    entry over the stack (no LAPACK call per matrix); ``ok`` is False where X is not positive
    definite (its L is then meaningless but finite)."""
    n, r, _ = X.shape
    L = np.zeros_like(X)
    ok = np.ones(n, dtype=bool)
    for j in range(r):
        s = X[:, j, j] - np.einsum("nk,nk->n", L[:, j, :j], L[:, j, :j])
        ok &= s > 0
        d = np.sqrt(np.where(s > 0, s, 1.0))
        L[:, j, j] = d
        for i in range(j + 1, r):
            L[:, i, j] = (X[:, i, j] - np.einsum("nk,nk->n", L[:, i, :j], L[:, j, :j])) / d
    return L, ok


def small_forward(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """L⁻¹B for stacks of small lower-triangular L (n, r, r) and right-hand sides B (n, r, c)."""
    Y = np.empty(np.broadcast_shapes(L.shape[:1] + B.shape[1:], B.shape))
    for i in range(L.shape[1]):
        row = B[:, i, :] if i == 0 else B[:, i, :] - np.einsum("nk,nkc->nc", L[:, i, :i], Y[:, :i, :])
        Y[:, i, :] = row / L[:, i, i, None]
    return Y


@dataclass(frozen=True, eq=False)
class Blocks:
    """The capacitance H = [[X, B], [Bᵀ, D − I]] of the candidate swaps in block-factored form:
    X = S_cc + I = LLᵀ (SPD), V = L⁻¹B, and the Schur complement Z = D − I − VᵀV = −KKᵀ, negative
    definite exactly when the swapped posterior information stays positive definite. Then
    det M'/det M = det X·det(−Z) and qᵀH⁻¹q = ‖L⁻¹a‖² − ‖K⁻¹(b − VᵀL⁻¹a)‖² for q = [a; b].

    Attributes:
        L: (n, r, r) Cholesky factors of X.
        V: (n, r, r) L⁻¹B.
        K: (n, r, r) Cholesky factors of −Z.
    """

    L: np.ndarray
    V: np.ndarray
    K: np.ndarray

    def trace(self, G_cc: np.ndarray, G_ci: np.ndarray, G_ii: np.ndarray) -> np.ndarray:
        """(n,) tr(H⁻¹G) for the symmetric G = [[G_cc, G_ci], [G_ciᵀ, G_ii]] of each candidate
        (G_cc, G_ci (n, r, r), G_ii (r, r)): with H = P·diag(I, Z)·Pᵀ, P = [[L, 0], [Vᵀ, I]],
        tr(H⁻¹G) = tr(X⁻¹G_cc) − tr((−Z)⁻¹·(R G_cc Rᵀ − R G_ci − (R G_ci)ᵀ + G_ii)), R = VᵀL⁻¹:
        a few r×r products per candidate, whatever the rank of the weight behind G."""
        r = self.L.shape[1]
        eye = np.broadcast_to(np.eye(r), self.L.shape)
        Li = small_forward(self.L, eye)
        Ki = small_forward(self.K, eye)
        R = np.swapaxes(self.V, 1, 2) @ Li
        RG = R @ G_ci
        low = R @ G_cc @ np.swapaxes(R, 1, 2) - RG - np.swapaxes(RG, 1, 2) + G_ii
        X_inv = np.swapaxes(Li, 1, 2) @ Li
        Z_inv = np.swapaxes(Ki, 1, 2) @ Ki  # (−Z)⁻¹
        return np.einsum("nij,nij->n", X_inv, G_cc) - np.einsum("nij,nij->n", Z_inv, low)

    def quadratic(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(n, c) qᵀH⁻¹q column by column, for q = [a; b], a (n, r, c) and b (r, c) or (n, r, c)."""
        y = small_forward(self.L, a)
        w = small_forward(self.K, b - np.einsum("nki,nkc->nic", self.V, y))
        return np.einsum("nrc,nrc->nc", y, y) - np.einsum("nrc,nrc->nc", w, w)


def swap_blocks(S_cc: np.ndarray, B: np.ndarray, D: np.ndarray) -> tuple[Blocks, np.ndarray, np.ndarray]:
    """(blocks, logdet, regular) of the capacitances with X = S_cc + I, off-diagonal blocks B
    (n, r, r) = J_c M⁻¹ Jᵢᵀ and D = Jᵢ M⁻¹ Jᵢᵀ: ``logdet`` = log det M'/det M, and ``regular``
    where M' stays positive definite and its determinant is above :data:`LOG_MIN_RATIO` of M's."""
    r = D.shape[0]
    eye = np.eye(r)
    L, ok_x = small_cholesky(S_cc + eye)
    V = small_forward(L, B)
    K, ok_z = small_cholesky(eye - D + np.einsum("nki,nkj->nij", V, V))
    diag = np.concatenate([np.diagonal(L, axis1=1, axis2=2), np.diagonal(K, axis1=1, axis2=2)], axis=1)
    with np.errstate(divide="ignore"):
        logdet = 2.0 * np.log(diag).sum(axis=1)
    regular = ok_x & ok_z & (logdet > LOG_MIN_RATIO)
    return Blocks(L, V, K), logdet, regular


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
        blocks: the capacitances of the candidates ``cand`` in block-factored form (their
            :meth:`Blocks.quadratic` updates a weighted trace).
        logdet: (n,) log det M'/det M of each candidate of ``cand``.
        products: the criterion's :meth:`exchange_products` of every pool candidate (index it
            with ``cand``).
        state: the exchange state (its pool's information matrices, on demand).
    """

    cand: np.ndarray
    F: float
    aux: object
    M: np.ndarray
    Minv: np.ndarray
    Ji: np.ndarray
    blocks: Blocks
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
        N, r, P = self.J_pool.shape
        Ji = self.J_pool[self.index[i]]
        Ai = Ji @ self.Minv
        B = (self.A.reshape(N * r, P) @ Ji.T).reshape(N, r, r)  # J_c M⁻¹ Jᵢᵀ
        blocks, logdet, regular = swap_blocks(self.S_cc, B, Ai @ Ji.T)
        ok = allowed & regular
        cand = np.flatnonzero(ok)
        self._last = None
        if not len(cand):
            return cand, np.empty(0)
        blocks = Blocks(blocks.L[cand], blocks.V[cand], blocks.K[cand])
        swaps = Swaps(
            cand, self.F, self.aux, self.M, self.Minv, Ji, blocks, logdet[cand], self.products, self
        )
        values, aux = self.criterion.exchange_values(swaps)
        self._last = (i, cand, values, aux, Ai)
        return cand, values

    def swap(self, i: int, best: int) -> None:
        assert self._last is not None  # swap follows the candidates() it names
        last_i, cand, values, aux, Ai = self._last
        assert last_i == i
        c = int(cand[best])
        Ji = self.J_pool[self.index[i]]
        H = capacitance(self.S_cc[c : c + 1], self.A[c : c + 1], Ji, Ai)[0]
        UtMinv = np.concatenate([self.A[c], Ai])  # Uᵀ M⁻¹, (2r, P)
        Minv = self.Minv - UtMinv.T @ np.linalg.solve(H, UtMinv)
        self.Minv = 0.5 * (Minv + Minv.T)
        self.M = self.M + self.J_pool[c].T @ self.J_pool[c] - Ji.T @ Ji
        self.index[i] = c
        self.F = float(values[best])
        if aux is not None:
            self.aux = aux[best]
        self.stale = True
