r"""The value of an information criterion after swapping one configuration of a plan for every
candidate of a pool at once (docs/method.md §7.2): low-rank (Woodbury) algebra on 2r×2r blocks.

Swapping configuration i (rows Jᵢ) for candidate c (rows J_c, r rows each) changes the posterior
information by a rank-2r term, M' = M + U C Uᵀ with U = [J_cᵀ, Jᵢᵀ] and C = diag(I, −I). With
the capacitance H = C⁻¹ + Uᵀ M⁻¹ U (2r×2r), Sherman–Morrison–Woodbury gives

    M'⁻¹ = M⁻¹ − M⁻¹ U H⁻¹ Uᵀ M⁻¹,       det M' / det M = (−1)^r det H,

so every candidate is scored from a few 2r×2r operations — no P×P factorisation per candidate.
The plan's M + Λ = LLᵀ is factored exactly after every accepted swap, and the pool is kept in that
basis, Y_c = L⁻¹J_cᵀ (:class:`InformationExchange`): then J_c M⁻¹ J_cᵀ = Y_cᵀY_c, and the blocks of
H of a swap of configuration i are Gram products of Y_c and yᵢ = L⁻¹Jᵢᵀ. H is factored in blocks,
H = [[X, B], [Bᵀ, D − I]] with X = I + Y_cᵀY_c = L_cL_cᵀ (what adding candidate c alone does; it
depends on the plan, not on i, so L_c⁻¹ and det X are kept with the pool until the next swap),
B = Y_cᵀyᵢ, D = yᵢᵀyᵢ, V = L_c⁻¹B and the Schur complement D − I − VᵀV = −E: det M'/det M =
det X·det E, and a swap is regular exactly when E is positive definite (X always is). E is formed
from V, never from X⁻¹ itself: VᵀV stays accurate when X is ill-conditioned (a candidate that
multiplies det M by 1e6), where BᵀX⁻¹B would lose digits. For r ≤ 3, L_c⁻¹ is unrolled
(:func:`factor_inverse`) and E⁻¹ is the adjugate over the determinant (:func:`inverse`), so a
swap of configuration i costs one product of the pool with yᵢ (and the columns the criterion asks
for) and a few r×r products over the pool (:class:`Swaps`). The criterion says what its value is from them
(:meth:`~pincal.evaluation.criterion.Criterion.exchange_values`): D from the determinant ratio, a
weighted trace tr(W M'⁻¹) = tr(W M⁻¹) − tr(H⁻¹G) with G the 2r×2r blocks of Uᵀ M⁻¹WM⁻¹ U
(see :class:`~pincal.evaluation.weighted_trace.WeightedTrace`), E and cond from the eigenvalues of
M' itself.

Every stack of small matrices here is held entry by entry, (r, r, n) for n candidates: each entry
is one contiguous vector over the pool, so that a factorisation or a product of r×r matrices is a
few dozen vector operations for the whole pool, with no call per candidate.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pincal.evaluation.information import factor
from pincal.lapack import trtrs

MIN_RATIO = 1e-12
"""Swaps that shrink det M by more than this factor are taken as singular."""


# --------------------------------------------------------- stacks of small matrices, entry by entry
def gram(Y: np.ndarray) -> np.ndarray:
    """(r, r, n) the Gram matrices Y_cᵀY_c of every candidate c, for Y (P, r, n)."""
    r, n = Y.shape[1], Y.shape[2]
    out = np.empty((r, r, n))
    for a in range(r):
        row = np.einsum("pn,pbn->bn", Y[:, a], Y[:, a:])
        out[a, a:] = row
        out[a:, a] = row
    return out


def cholesky(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(L, ok): lower Cholesky factors of symmetric (r, r, n) X, entry by entry; ``ok`` is False
    where X is not positive definite (its L is then meaningless but finite)."""
    r, _, n = X.shape
    L = np.zeros_like(X)
    ok = np.ones(n, dtype=bool)
    for j in range(r):
        s = X[j, j] - _dot(L[j], L[j], j)
        good = s > 0
        ok &= good
        d = np.sqrt(np.where(good, s, 1.0))
        L[j, j] = d
        inv = 1.0 / d
        for i in range(j + 1, r):
            L[i, j] = (X[i, j] - _dot(L[i], L[j], j)) * inv
    return L, ok


def _dot(u: np.ndarray, v: np.ndarray, k: int) -> np.ndarray | float:
    """Σ_{l<k} u[l]·v[l] over the leading axis (0 for k = 0)."""
    if k == 0:
        return 0.0
    if k == 1:
        return u[0] * v[0]
    return np.einsum("kn,kn->n", u[:k], v[:k])


def lower_inverse(L: np.ndarray) -> np.ndarray:
    """L⁻¹ (lower triangular) of lower-triangular (r, r, n) L."""
    r = L.shape[0]
    Q = np.zeros_like(L)
    for i in range(r):
        inv = 1.0 / L[i, i]
        Q[i, i] = inv
        for j in range(i):
            acc = L[i, j] * Q[j, j]
            for k in range(j + 1, i):
                acc = acc + L[i, k] * Q[k, j]
            Q[i, j] = -acc * inv
    return Q


def factor_inverse(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(L⁻¹, det X, ok) of symmetric (r, r, n) X = LLᵀ (L its lower Cholesky factor), entry by
    entry; ``ok`` is False where X is not positive definite (L⁻¹ and det are then meaningless but
    finite). Up to r = 3 unrolled (the same arithmetic as :func:`cholesky` and
    :func:`lower_inverse`, in fewer vector operations)."""
    r = X.shape[0]
    if r > 3:
        L, ok = cholesky(X)
        return lower_inverse(L), np.prod(np.diagonal(L), axis=-1) ** 2, ok
    Q = np.zeros_like(X)
    q00, ok, det = _pivot(X[0, 0], True, 1.0)
    Q[0, 0] = q00
    if r == 1:
        return Q, det, ok
    l10 = X[1, 0] * q00
    q11, ok, det = _pivot(X[1, 1] - l10 * l10, ok, det)
    Q[1, 1] = q11
    Q[1, 0] = -l10 * q00 * q11
    if r == 2:
        return Q, det, ok
    l20 = X[2, 0] * q00
    l21 = (X[2, 1] - l20 * l10) * q11
    q22, ok, det = _pivot(X[2, 2] - l20 * l20 - l21 * l21, ok, det)
    Q[2, 2] = q22
    Q[2, 1] = -l21 * q11 * q22
    Q[2, 0] = -(l20 * q00 + l21 * Q[1, 0]) * q22
    return Q, det, ok


def _pivot(pivot: np.ndarray, ok, det) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One step of :func:`factor_inverse`: (1/√pivot, ok, det·pivot), a pivot that is not positive
    marking ``ok`` False and counting as 1 (so that every number stays finite)."""
    good = pivot > 0
    pivot = np.where(good, pivot, 1.0)
    return 1.0 / np.sqrt(pivot), ok & good, det * pivot


def product(A: np.ndarray, B: np.ndarray, transpose_a: bool = False) -> np.ndarray:
    """AB (or AᵀB) of (r, r, n) stacks, entry by entry; B may be (r, s) (the same for every n)."""
    if B.ndim == 2:
        return np.einsum("kan,kb->abn" if transpose_a else "akn,kb->abn", A, B)
    return np.einsum("kan,kbn->abn" if transpose_a else "akn,kbn->abn", A, B)


def inverse(E: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(E⁻¹, det E, ok) of symmetric (r, r, n) E, entry by entry; ``ok`` is False where E is not
    positive definite (its E⁻¹ and det are then meaningless but finite, the det 1). Up to r = 3 in
    closed form (the adjugate over the determinant; positive definite exactly when the leading
    minors are positive), beyond through Cholesky factors."""
    r = E.shape[0]
    if r > 3:
        K, ok = cholesky(E)
        Q = lower_inverse(K)
        det = np.prod(np.diagonal(K), axis=-1) ** 2
        np.putmask(det, ~ok, 1.0)
        return product(Q, Q, transpose_a=True), det, ok
    adj = np.empty_like(E)
    if r == 1:
        det = E[0, 0]
        ok = det > 0
        adj[0, 0] = 1.0
    elif r == 2:
        adj[0, 0], adj[1, 1] = E[1, 1], E[0, 0]
        adj[0, 1] = adj[1, 0] = -E[0, 1]
        det = E[0, 0] * E[1, 1] - E[0, 1] * E[0, 1]
        ok = (E[0, 0] > 0) & (det > 0)
    else:
        e00, e01, e02, e11, e12, e22 = E[0, 0], E[0, 1], E[0, 2], E[1, 1], E[1, 2], E[2, 2]
        adj[0, 0] = e11 * e22 - e12 * e12
        adj[0, 1] = adj[1, 0] = e02 * e12 - e01 * e22
        adj[0, 2] = adj[2, 0] = e01 * e12 - e02 * e11
        adj[1, 1] = e00 * e22 - e02 * e02
        adj[1, 2] = adj[2, 1] = e01 * e02 - e00 * e12
        adj[2, 2] = e00 * e11 - e01 * e01
        det = e00 * adj[0, 0] + e01 * adj[0, 1] + e02 * adj[0, 2]
        ok = (e00 > 0) & (adj[2, 2] > 0) & (det > 0)
    det = np.array(det)
    np.putmask(det, ~ok, 1.0)
    adj *= 1.0 / det
    return adj, det, ok


# ------------------------------------------------------------------------------ the swaps
@dataclass(frozen=True, eq=False)
class Swaps:
    """The candidate swaps of configuration i, for a criterion's
    :meth:`~pincal.evaluation.criterion.Criterion.exchange_values`.

    Every array over candidates holds the whole pool (entry by entry, (…, N)); ``cand`` says which
    of them count (allowed, and leaving a regular plan): a criterion indexes its values with it.
    In the blocks of the capacitance H = [[X, B], [Bᵀ, D − I]] (see module doc), X = L_cL_cᵀ,
    V = L_c⁻¹B, and the Schur complement of X is −E, E = I − D + VᵀV; E⁻¹ is ``Einv``.

    Attributes:
        cand: (n,) pool indices of the candidates scored.
        F: the criterion's value F before the swap.
        aux: what the criterion keeps of the plan (its weighted traces), or None.
        M: (P, P) the data's information matrix before the swap (no prior).
        L: (P, P) the lower Cholesky factor of M + Λ before the swap.
        Ji: (r, P) the rows of configuration i.
        yi: (P, r) L⁻¹Jᵢᵀ.
        V: (r, r, N) L_c⁻¹B of every pool candidate, B = Y_cᵀyᵢ = J_c M⁻¹ Jᵢᵀ.
        Einv: (r, r, N) E⁻¹ of every pool candidate (symmetric).
        projected: (r, s, N) L_c⁻¹Y_cᵀ times the criterion's own columns
            (:meth:`~pincal.evaluation.criterion.Criterion.exchange_columns`), or None.
        ratio: (N,) det M'/det M of each pool candidate.
        products: the criterion's :meth:`exchange_products` of every pool candidate.
        state: the exchange state (its pool's information matrices, on demand).
    """

    cand: np.ndarray
    F: float
    aux: object
    M: np.ndarray
    L: np.ndarray
    Ji: np.ndarray
    yi: np.ndarray
    V: np.ndarray
    Einv: np.ndarray
    projected: np.ndarray | None
    ratio: np.ndarray
    products: object
    state: InformationExchange

    def inverse_trace(self, G: np.ndarray) -> np.ndarray:
        """(N,) tr(E⁻¹G) of every pool candidate, for (r, r, N) G (symmetric or not)."""
        return trace_product(self.Einv, G)

    def inverse_form(self, s: np.ndarray) -> np.ndarray:
        """(c, N) sᵀE⁻¹s column by column, for s (r, c, N)."""
        return quadratic_form(self.Einv, s)


def trace_product(A: np.ndarray, G: np.ndarray) -> np.ndarray:
    """(n,) tr(AG) of (r, r, n) stacks."""
    return np.einsum("abn,ban->n", A, G)


def quadratic_form(A: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(c, n) sᵀAs column by column, for A (r, r, n) and s (r, c, n)."""
    return np.einsum("acn,acn->cn", s, product(A, s))


class InformationExchange:
    """The exchange state of an information criterion: M, the Cholesky factor L of M + Λ and F of a
    plan of pool configurations, and the pool in L's basis (see module doc and
    :class:`~pincal.evaluation.criterion.ExchangeState`). M and L are recomputed exactly from the
    plan after every swap: nothing drifts.

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
        self.columns = np.ascontiguousarray(J_pool.transpose(2, 1, 0)).reshape(self.P, -1)  # (P, r·N)
        self._exact()

    @cached_property
    def pool_information(self) -> np.ndarray:
        """(N, P, P) J_cᵀJ_c of every pool candidate."""
        return np.einsum("nrp,nrs->nps", self.J_pool, self.J_pool)

    def resync(self) -> None:
        """Nothing to do: M, L and F are recomputed from the plan after every swap."""

    def _exact(self) -> None:
        """M, L and F of the plan, exactly."""
        Jd = self.J_pool[self.index].reshape(-1, self.P)
        m = len(self.index)
        self.M = Jd.T @ Jd
        self.L = factor(self.criterion.posterior(self.M), self.r, m)
        self.F, self.aux = self.criterion.exchange_exact(self.M, m)
        self.stale = True

    def _products(self) -> None:
        """The pool in the plan's basis, Y_c = L⁻¹J_cᵀ, and what adding candidate c alone does:
        X_c = I + Y_cᵀY_c = L_cL_cᵀ, L_c⁻¹ and det X_c = det(M + J_cᵀJ_c)/det M."""
        N, r, P = len(self.J_pool), self.r, self.P
        self.Linv = trtrs(self.L, np.eye(P))
        self.Y = (self.Linv @ self.columns).reshape(P, r, N)  # L⁻¹J_cᵀ
        X = gram(self.Y)
        for j in range(r):
            X[j, j] += 1.0
        self.Q, self.det_x, self.ok_x = factor_inverse(X)
        self.products = self.criterion.exchange_products(self.Y, self.Linv, self.Q)
        self.stale = False

    def scores(self, i: int, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.stale:
            self._products()
        r, N = self.r, len(self.J_pool)
        yi = np.ascontiguousarray(self.Y[:, :, self.index[i]])  # (P, r)
        extra = self.criterion.exchange_columns(self.products, yi)
        rhs = yi.T if extra is None else np.concatenate([yi.T, extra.T])
        proj = (rhs @ self.Y.reshape(self.P, -1)).reshape(-1, r, N).transpose(1, 0, 2)  # Y_cᵀ[yᵢ, …]
        proj = product(self.Q, proj)  # L_c⁻¹Y_cᵀ[yᵢ, …]
        V = proj[:, :r]  # L_c⁻¹B, B = J_c M⁻¹ Jᵢᵀ
        E = product(V, V, transpose_a=True)  # I − D + VᵀV
        E -= (yi.T @ yi - np.eye(r))[:, :, None]
        Einv, det_e, ok_e = inverse(E)
        ratio = self.det_x * det_e  # det M'/det M = det X·det E
        regular = self.ok_x & ok_e & (ratio > MIN_RATIO)
        cand = np.flatnonzero(allowed & regular)
        self._last = None
        if not len(cand):
            return cand, np.empty(0)
        swaps = Swaps(
            cand,
            self.F,
            self.aux,
            self.M,
            self.L,
            self.J_pool[self.index[i]],
            yi,
            V,
            Einv,
            None if extra is None else proj[:, r:],
            ratio,
            self.products,
            self,
        )
        values, _ = self.criterion.exchange_values(swaps)
        self._last = (i, cand)
        return cand, values

    def swap(self, i: int, best: int) -> None:
        assert self._last is not None  # swap follows the scores() it names
        last_i, cand = self._last
        assert last_i == i
        self.index[i] = int(cand[best])
        self._exact()
