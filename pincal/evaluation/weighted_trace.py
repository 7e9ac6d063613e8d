r"""Criteria that are weighted traces of the inverse posterior information: the shared arithmetic
of the test-pose criteria (mean and worst) and of A-optimality.

t_k = tr(Wk (M + Λ)⁻¹), Wk = J0kᵀJ0k, for k = 1..K weights given by their factors J0k (the test
poses' Jacobians; the identity for A), aggregated over k by the criterion (mean, maximum). With
M + Λ = LLᵀ, t_k = ‖L⁻¹J0kᵀ‖²_F: one triangular solve for every k at once. The value after a swap
of configurations is the Woodbury update tr(Wk M'⁻¹) = t_k − ⟨Q, H⁻¹Q⟩ (see
:mod:`pincal.evaluation.low_rank`).
"""

from __future__ import annotations

import numpy as np

from pincal.evaluation.criterion import Criterion, scaled_eigh
from pincal.evaluation.information import factor
from pincal.evaluation.low_rank import gram, product
from pincal.lapack import trtrs


class WeightedTrace(Criterion):
    """Weighted traces t_k = tr(J0k (M + Λ)⁻¹ J0kᵀ), aggregated over k (see module doc).

    F is the log of the aggregate; subclasses say how the traces are aggregated
    (:meth:`aggregate`) and weighted in the gradient (:meth:`gradient_weights`).

    Args:
        J0T: (P, R) the weights' factors, transposed and stacked over k groups of R/k columns.
        groups: k.
        scale: the reported value is scale·sqrt(aggregate) (σ for ρ0 [m]).
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ, or None.
    """

    def __init__(
        self, J0T: np.ndarray, groups: int, scale: float, rows: int, prior: np.ndarray | None = None
    ) -> None:
        super().__init__(rows, prior)
        self.J0T: np.ndarray = np.ascontiguousarray(J0T)
        self.k = groups
        self.scale = scale
        self.weight = self.J0T @ self.J0T.T if groups == 1 else None  # W = Σ J0kᵀJ0k

    # ------------------------------------------------------------ what subclasses say
    def aggregate(self, t: np.ndarray) -> np.ndarray:
        """The aggregate of traces (..., k) over k."""
        raise NotImplementedError

    def gradient_weights(self, t: np.ndarray) -> tuple[float, np.ndarray]:
        """(F, w): F and ∂F/∂t_k for the traces t (k,)."""
        raise NotImplementedError

    # -------------------------------------------------------------------- the value
    def _solve(self, M: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
        L = factor(self.posterior(M), self.rows, m)
        X = trtrs(L, self.J0T)
        return L, X

    def traces(self, M: np.ndarray, m: int) -> np.ndarray:
        """(k,) t_k = tr(J0k (M + Λ)⁻¹ J0kᵀ)."""
        _, X = self._solve(M, m)
        return np.einsum("ij,ij->j", X, X).reshape(self.k, -1).sum(axis=1)

    def from_traces(self, t: np.ndarray) -> np.ndarray:
        """F from traces (..., k) (the exact aggregate)."""
        agg = self.aggregate(np.asarray(t))
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(agg > 0, np.log(np.where(agg > 0, agg, 1.0)), np.inf)

    def value(self, M: np.ndarray, m: int) -> float:
        return float(self.from_traces(self.traces(M, m)))

    def value_and_gradient(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        L, X = self._solve(M, m)
        Y = trtrs(L, X, trans=1)  # (M + Λ)⁻¹ J0ᵀ
        t = np.einsum("ij,ij->j", X, X).reshape(self.k, -1).sum(axis=1)
        F, w = self.gradient_weights(t)
        cols = np.repeat(w, Y.shape[1] // self.k)
        return F, -(Y * cols) @ Y.T

    def report(self, F):
        return self.scale * np.sqrt(np.exp(F))

    def describe(self, value: float) -> str:
        return f"ρ0 {value * 1e3:.4g} mm"

    def split(self, M: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
        """(k,) scale²·t_k due to the measurements, scale²·t_k[CMC] with C = (M + Λ)⁻¹, and due to
        the prior the plan leaves uncorrected, scale²·t_k[CΛC]; they add up to scale²·t_k (the
        second is 0 without a prior)."""
        L = factor(self.posterior(M), self.rows, m)
        X = trtrs(L, self.J0T)
        Y = trtrs(L, X, trans=1)  # (M + Λ)⁻¹ J0ᵀ
        s2 = self.scale**2
        noise = s2 * np.einsum("ij,ij->j", Y, M @ Y).reshape(self.k, -1).sum(axis=1)
        if self.prior is None:
            return noise, np.zeros(self.k)
        bias = s2 * np.einsum("ij,ij->j", Y, self.prior @ Y).reshape(self.k, -1).sum(axis=1)
        return noise, bias

    # ------------------------------------------------------------------- in batches
    def batch_traces(self, Ms: np.ndarray) -> np.ndarray:
        """(n, k) traces for a stack of information matrices; NaN rows where M is singular."""
        d, w, V, singular = scaled_eigh(self.posterior(Ms))
        assert V is not None  # the vectors were asked for
        w = np.where(singular[:, None], 1.0, w)
        X = np.swapaxes(V, 1, 2) @ (self.J0T[None] / d[:, :, None])
        X /= np.sqrt(np.abs(w))[:, :, None]
        t = np.einsum("npr,npr->nr", X, X).reshape(len(Ms), self.k, -1).sum(axis=2)
        t[singular] = np.nan
        return t

    def batch_values(self, Ms: np.ndarray) -> np.ndarray:
        t = self.batch_traces(Ms)
        out = np.full(len(Ms), np.nan)
        ok = ~np.isnan(t[:, 0])
        out[ok] = self.from_traces(t[ok])
        return out

    # ---------------------------------------------------------------- the exchange
    def exchange_exact(self, M: np.ndarray, m: int) -> tuple[float, np.ndarray]:
        t = self.traces(M, m)
        return float(self.from_traces(t)), t

    def exchange_products(self, Y: np.ndarray, Linv: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, ...]:
        """Of every candidate c, from Y_c = L⁻¹J_cᵀ (P, r, N) and Q = L_c⁻¹ (r, r, N) (X_c = I + Y_cᵀY_c
        = L_cL_cᵀ), with Φ = L⁻¹J0ᵀ and Z_c = ΦᵀY_cL_c⁻ᵀ (R, r, N): for one weight W = J0ᵀJ0 (k = 1),
        (A, tr A, ΦΦᵀ) with A = Z_cᵀZ_c = L_c⁻¹ J_c CWC J_cᵀ L_c⁻ᵀ (r, r, N), C = (M + Λ)⁻¹, what
        adding c alone takes off the trace being tr A; for several, (Z_c as (r, R, N), the squared
        norms of its columns (R, N), Φ) (the update column by column)."""
        P, r, N = Y.shape
        Phi = Linv @ self.J0T  # L⁻¹J0ᵀ (P, R)
        Z = (Phi.T @ Y.reshape(P, -1)).reshape(-1, r, N).transpose(1, 0, 2)  # Y_cᵀΦ
        if self.k == 1:
            A = product(product(Q, gram(Z.transpose(1, 0, 2))), Q.transpose(1, 0, 2))
            return A, np.trace(A), Phi @ Phi.T
        Z = product(Q, Z)
        return Z, np.einsum("rcn,rcn->cn", Z, Z), Phi

    def exchange_columns(self, products, yi: np.ndarray) -> np.ndarray | None:
        """ΦΦᵀyᵢ (P, r) for one weight (the swaps' cross terms J_c CWC Jᵢᵀ come out of the state's
        product with the pool); nothing for several."""
        return products[2] @ yi if self.k == 1 else None

    def exchange_values(self, swap) -> tuple[np.ndarray, np.ndarray]:
        """F and the traces after each swap (inf where a trace would not stay positive).

        Swapping configuration i for candidate c takes tr A off a trace (adding c) and gives
        tr(E⁻¹G) back (removing i), G = UᵀΦΦᵀU with U = yᵢ − Y_cL_c⁻ᵀV (Jᵢ in the basis of the
        plan with c added): for one weight G = VᵀAV − 2VᵀC + yᵢᵀΦΦᵀyᵢ with C = L_c⁻¹Y_cᵀΦΦᵀyᵢ
        (under the trace against the symmetric E⁻¹ only G's symmetric part counts); for several,
        column by column sᵀE⁻¹s with s = ΦᵀU = Φᵀyᵢ − VᵀZ_c."""
        cand, yi, V = swap.cand, swap.yi, swap.V
        if self.k == 1:
            A, added, Psi = swap.products
            T = product(A, V)
            T -= 2.0 * swap.projected  # C
            G = product(V, T, transpose_a=True)
            G += (yi.T @ Psi @ yi)[:, :, None]
            red = (added - swap.inverse_trace(G))[cand][:, None]
        else:
            Z, added, Phi = swap.products
            s = (yi.T @ Phi)[:, :, None] - product(V, Z, transpose_a=True)
            q = (added - swap.inverse_form(s))[:, cand]  # (c, n)
            red = q.reshape(self.k, -1, len(cand)).sum(axis=1).T
        new_t = swap.aux - red
        values = self.from_traces(new_t)
        values[~np.all(new_t > 0, axis=1)] = np.inf
        return values, new_t
