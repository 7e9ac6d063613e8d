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
H = [[X, B], [Bᵀ, D − I]] with X = Y_cᵀY_c + I = L_xL_xᵀ, V = L_x⁻¹B and the Schur complement
D − I − VᵀV = −KKᵀ (:func:`swap_blocks`): det M'/det M = det X·det(−Z), and a swap is regular
exactly when both factors exist. The criterion says what its value is from them
(:meth:`~pincal.evaluation.criterion.Criterion.exchange_values`): D from the determinant ratio, a
weighted trace tr(W M'⁻¹) = tr(W M⁻¹) − tr(H⁻¹G) with G the 2r×2r blocks of Uᵀ M⁻¹WM⁻¹ U
(:meth:`Blocks.trace`; column by column for several weights, :meth:`Blocks.quadratic`), E and cond
from the eigenvalues of M' itself.

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

LOG_MIN_RATIO = np.log(1e-12)
"""Swaps that shrink det M by more than this factor are taken as singular."""


# --------------------------------------------------------- stacks of small matrices, entry by entry
def gram(Y: np.ndarray, Z: np.ndarray | None = None) -> np.ndarray:
    """(r, s, n) the products Y_cᵀZ_c of every candidate c, for Y (P, r, n) and Z (P, s, n) (Z = Y:
    the Gram matrices, symmetric)."""
    r, n = Y.shape[1], Y.shape[2]
    if Z is None:
        out = np.empty((r, r, n))
        for a in range(r):
            for b in range(a + 1):
                out[a, b] = np.einsum("pn,pn->n", Y[:, a], Y[:, b])
                out[b, a] = out[a, b]
        return out
    out = np.empty((r, Z.shape[1], n))
    for a in range(r):
        for b in range(Z.shape[1]):
            out[a, b] = np.einsum("pn,pn->n", Y[:, a], Z[:, b])
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


def forward(L: np.ndarray, B: np.ndarray) -> np.ndarray:
    """L⁻¹B for lower-triangular (r, r, n) L and right-hand sides B (r, c, n) or (r, c) (the same
    for every candidate)."""
    r, n = L.shape[0], L.shape[2]
    Y = np.empty((r, B.shape[1], n))
    for i in range(r):
        row = B[i] if B.ndim == 3 else B[i][:, None]
        for k in range(i):
            row = row - L[i, k] * Y[k]
        Y[i] = row / L[i, i]
    return Y


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


def product(A: np.ndarray, B: np.ndarray, transpose_a: bool = False) -> np.ndarray:
    """AB (or AᵀB) of (r, r, n) stacks, entry by entry; B may be (r, s) (the same for every n)."""
    r = A.shape[0]
    s = B.shape[1]
    out = np.empty((r, s, A.shape[2]))
    for a in range(r):
        for b in range(s):
            acc = 0.0
            for k in range(r):
                left = A[k, a] if transpose_a else A[a, k]
                acc = acc + left * B[k, b]
            out[a, b] = acc
    return out


def lower_trace(Q: np.ndarray, G: np.ndarray) -> np.ndarray:
    """(n,) tr(Q G Qᵀ) for lower-triangular Q and symmetric G, (r, r, n) each."""
    r = Q.shape[0]
    total = np.zeros(Q.shape[2])
    for k in range(r):
        for a in range(k + 1):
            for b in range(k + 1):
                total = total + Q[k, a] * G[a, b] * Q[k, b]
    return total


# ------------------------------------------------------------------------- the swaps' blocks
@dataclass(frozen=True, eq=False)
class Blocks:
    """The capacitances H = [[X, B], [Bᵀ, D − I]] of the candidate swaps in block-factored form,
    entry by entry over the candidates (see module doc): X = LLᵀ (SPD), V = L⁻¹B and the Schur
    complement Z = D − I − VᵀV = −KKᵀ, negative definite exactly when the swapped posterior
    information stays positive definite. Then det M'/det M = det X·det(−Z) and
    qᵀH⁻¹q = ‖L⁻¹a‖² − ‖K⁻¹(b − VᵀL⁻¹a)‖² for q = [a; b].

    Attributes:
        L: (r, r, n) Cholesky factors of X.
        V: (r, r, n) L⁻¹B.
        K: (r, r, n) Cholesky factors of −Z.
    """

    L: np.ndarray
    V: np.ndarray
    K: np.ndarray

    def trace(self, G_cc: np.ndarray, G_ci: np.ndarray, G_ii: np.ndarray) -> np.ndarray:
        """(n,) tr(H⁻¹G) for the symmetric G = [[G_cc, G_ci], [G_ciᵀ, G_ii]] of each candidate
        (G_cc, G_ci (r, r, n), G_ii (r, r)): with H = P·diag(X, Z)·Pᵀ, P = [[I, 0], [BᵀX⁻¹, I]],
        tr(H⁻¹G) = tr(QG_ccQᵀ) − tr(Q_K·low·Q_Kᵀ), Q = L⁻¹, Q_K = K⁻¹ and
        low = VᵀAV − VᵀC − CᵀV + G_ii with A = QG_ccQᵀ, C = QG_ci: a few dozen vector
        operations over the candidates, whatever the rank of the weight behind G."""
        Q = lower_inverse(self.L)
        QG = product(Q, G_cc)
        A = product(QG, Q.transpose(1, 0, 2))  # Q G_cc Qᵀ
        C = product(Q, G_ci)
        VA = product(self.V, A, transpose_a=True)
        VC = product(self.V, C, transpose_a=True)
        r = self.L.shape[0]
        low = np.empty_like(A)
        for a in range(r):
            for b in range(a + 1):
                acc = G_ii[a, b] - VC[a, b] - VC[b, a]
                for k in range(r):
                    acc = acc + VA[a, k] * self.V[k, b]
                low[a, b] = low[b, a] = acc
        first = A[0, 0]
        for k in range(1, r):
            first = first + A[k, k]
        return first - lower_trace(lower_inverse(self.K), low)

    def quadratic(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(c, n) qᵀH⁻¹q column by column, for q = [a; b], a (r, c, n) and b (r, c) or (r, c, n)."""
        y = forward(self.L, a)
        r = self.L.shape[0]
        s = np.empty_like(y)
        for j in range(r):
            acc = b[j] if b.ndim == 3 else b[j][:, None]
            for k in range(r):
                acc = acc - self.V[k, j] * y[k]
            s[j] = acc
        w = forward(self.K, s)
        return np.einsum("rcn,rcn->cn", y, y) - np.einsum("rcn,rcn->cn", w, w)


def swap_blocks(S_cc: np.ndarray, B: np.ndarray, D: np.ndarray) -> tuple[Blocks, np.ndarray, np.ndarray]:
    """(blocks, logdet, regular) of the capacitances with X = S_cc + I, off-diagonal blocks B
    (r, r, n) = J_c M⁻¹ Jᵢᵀ and D (r, r) = Jᵢ M⁻¹ Jᵢᵀ: ``logdet`` = log det M'/det M, and ``regular``
    where M' stays positive definite and its determinant is above :data:`LOG_MIN_RATIO` of M's."""
    r = D.shape[0]
    X = S_cc.copy()
    for j in range(r):
        X[j, j] += 1.0
    L, ok_x = cholesky(X)
    V = forward(L, B)
    E = gram(V)  # VᵀV + I − D
    for a in range(r):
        for b in range(r):
            E[a, b] -= D[a, b]
        E[a, a] += 1.0
    K, ok_z = cholesky(E)
    det = L[0, 0] * K[0, 0]
    for j in range(1, r):
        det = det * L[j, j] * K[j, j]
    with np.errstate(divide="ignore"):
        logdet = 2.0 * np.log(det)
    regular = ok_x & ok_z & (logdet > LOG_MIN_RATIO)
    return Blocks(L, V, K), logdet, regular


@dataclass(frozen=True, eq=False)
class Swaps:
    """The candidate swaps of configuration i, for a criterion's
    :meth:`~pincal.evaluation.criterion.Criterion.exchange_values`.

    Every array over candidates holds the whole pool (entry by entry, (…, N)); ``cand`` says which
    of them count (allowed, and leaving a regular plan): a criterion indexes its values with it.

    Attributes:
        cand: (n,) pool indices of the candidates scored.
        F: the criterion's value F before the swap.
        aux: what the criterion keeps of the plan (its weighted traces), or None.
        M: (P, P) the data's information matrix before the swap (no prior).
        L: (P, P) the lower Cholesky factor of M + Λ before the swap.
        Ji: (r, P) the rows of configuration i.
        yi: (P, r) L⁻¹Jᵢᵀ.
        blocks: the capacitances of every pool candidate in block-factored form (their
            :meth:`Blocks.quadratic` updates a weighted trace).
        logdet: (N,) log det M'/det M of each pool candidate.
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
    blocks: Blocks
    logdet: np.ndarray
    products: object
    state: InformationExchange


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
        N = len(self.J_pool)
        self.Linv = trtrs(self.L, np.eye(self.P))
        self.Y = (self.Linv @ self.columns).reshape(self.P, self.r, N)  # L⁻¹J_cᵀ
        self.S_cc = gram(self.Y)
        self.products = self.criterion.exchange_products(self.Y, self.Linv)
        self.stale = False

    def scores(self, i: int, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.stale:
            self._products()
        r, N = self.r, len(self.J_pool)
        yi = np.ascontiguousarray(self.Y[:, :, self.index[i]])  # (P, r)
        B = (yi.T @ self.Y.reshape(self.P, -1)).reshape(r, r, N).transpose(1, 0, 2)  # J_c M⁻¹ Jᵢᵀ
        blocks, logdet, regular = swap_blocks(self.S_cc, B, yi.T @ yi)
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
            blocks,
            logdet,
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
