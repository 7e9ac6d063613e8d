r"""The residual model at the size of real data: hyperparameters by the exact marginal likelihood of
a seeded subset, predictions from every point through inducing points (FITC), docs/method.md §11.5.

Everything here is in the units of the correlation: the kernel is s²·r(x, x') with
r = exp(−½‖x − x'‖²) on features already divided by their lengthscales, and ν = n²/s² the noise's
share. With m inducing points Z (a seeded subset of the training configurations), L Lᵀ = r(Z, Z)
and V = L⁻¹ r(Z, X) (m × n), FITC (Snelson & Ghahramani 2006; Quiñonero-Candela & Rasmussen 2005)
replaces the training covariance R + νI by VᵀV + Λ, Λ = diag(1 − ‖vᵢ‖² + ν): exact on the diagonal,
low rank off it. With B = I + V Λ⁻¹ Vᵀ = L_B L_Bᵀ and v* = L⁻¹ r(Z, x*), the predictions are

    mean(x*) = v*ᵀ B⁻¹ V Λ⁻¹ Y,        var(x*)/s² = 1 − ‖v*‖² + ‖L_B⁻¹ v*‖²,

and B is summed over blocks of training points: O(n m²) time, O(block·m + m²) memory, never an
n × n array. With Z every training point (m = n) it is the exact posterior.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from pincal.progress import Steps

# SciPy is imported on first use (scipy.linalg and scipy.optimize are slow to import), as in
# pincal.model.residual, which imports this module.

LENGTHSCALE_BOUNDS = (1e-2, 1e3)
"""Bounds of each feature's lengthscale [rad for a revolute joint's (cos, sin), m for a prismatic
joint]: from a hundredth of a radian to flat (both fits)."""

AMPLITUDE_BOUNDS = (1e-4, 1e2)
"""Bounds of s² over the mean square of the residuals (scikit-learn's, in the exact fit)."""

NOISE_BOUNDS = (1e-6, 10.0)
"""Bounds of n² over the mean square of the residuals."""

START = (1.0, 1.0, 0.1)
"""The first start: s², every ℓ and n² (over the mean square of the residuals)."""

EVALUATIONS = 200
"""Likelihood evaluations per start of the optimiser, at most."""

BLOCK = 2000
"""Training points per block of the FITC sums: the largest array is BLOCK × m."""

JITTER = 1e-8
"""Added to the diagonal of r(Z, Z) (the first try; ten times more until it factors)."""


def correlation(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """(a, b) exp(−½‖a − b‖²) between the rows of scaled features ``A`` and ``B``."""
    d2 = np.sum(A**2, axis=1)[:, None] + np.sum(B**2, axis=1)[None, :] - 2 * A @ B.T
    return np.exp(-0.5 * np.maximum(d2, 0.0))


def one_thread() -> Any:
    """A context of one BLAS thread, NumPy's and SciPy's (SciPy is imported first: a library
    loaded inside the context would not be limited). On a shared machine threads only contend
    (benchmarks/RESULTS.md, bench_residual: one thread against two)."""
    import scipy.linalg
    import scipy.optimize  # noqa: F401

    return threadpool_limits(limits=1, user_api="blas")


# ------------------------------------------------------------------ hyperparameters
def _negative_log_likelihood(theta: np.ndarray, X: np.ndarray, Y: np.ndarray) -> tuple[float, np.ndarray]:
    """−log p(Y | θ) of the p columns of Y (independent, one covariance) and its gradient in θ =
    (log s², log ℓ₁..ℓ_d, log n²), Rasmussen & Williams (2006) eqs. 2.30 and 5.9."""
    from scipy.linalg import cho_factor, cho_solve
    from scipy.linalg.lapack import dpotri

    n, p = Y.shape
    c, ell, w = np.exp(theta[0]), np.exp(theta[1:-1]), np.exp(theta[-1])
    A = X / ell
    Kf = c * correlation(A, A)
    K = Kf + w * np.eye(n)
    try:
        L = cho_factor(K, lower=True)
    except np.linalg.LinAlgError:
        return 1e25, np.zeros_like(theta)
    alpha = cho_solve(L, Y)
    value = 0.5 * np.sum(Y * alpha) + p * np.sum(np.log(np.diag(L[0]))) + 0.5 * n * p * np.log(2 * np.pi)
    inverse, info = dpotri(L[0], lower=True)  # K⁻¹ from its factor (the lower triangle)
    if info != 0:
        return 1e25, np.zeros_like(theta)
    inverse = np.tril(inverse) + np.tril(inverse, -1).T
    W = alpha @ alpha.T - p * inverse  # ∂ log p / ∂K = W / 2
    M = W * Kf
    grad = np.empty_like(theta)
    grad[0] = 0.5 * np.sum(M)
    # Σ_jk M_jk (a_ji − a_ki)² = 2 Σ_j a_ji² (M 1)_j − 2 a_iᵀ M a_i, per feature i
    grad[1:-1] = 0.5 * (2 * (A**2).T @ M.sum(axis=1) - 2 * np.einsum("ji,ji->i", A, M @ A))
    grad[-1] = 0.5 * w * np.trace(W)
    return value, -grad


def fit_hyperparameters(
    X: np.ndarray, Y: np.ndarray, rng: np.random.Generator, restarts: int, steps: Steps
) -> tuple[float, np.ndarray, float, float]:
    """(s², ℓ, n², log-likelihood) maximising the exact marginal likelihood of Y (n × p, in units
    of its root mean square) at features X: L-BFGS-B in the logarithms, from :data:`START` and
    ``restarts`` draws uniform in the logarithms of the bounds (as scikit-learn does)."""
    from scipy.optimize import minimize

    d = X.shape[1]
    bounds = np.log([AMPLITUDE_BOUNDS] + [LENGTHSCALE_BOUNDS] * d + [NOISE_BOUNDS])
    starts = [np.log([START[0]] + [START[1]] * d + [START[2]])]
    starts += [rng.uniform(bounds[:, 0], bounds[:, 1]) for _ in range(restarts)]
    best: tuple[float, np.ndarray] = (np.inf, starts[0])
    for k, theta0 in enumerate(starts):
        steps.stage(f"of the likelihood (start {k + 1} of {len(starts)}; at most)", EVALUATIONS)

        def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
            steps.advance()
            return _negative_log_likelihood(theta, X, Y)

        found = minimize(
            objective, theta0, jac=True, method="L-BFGS-B", bounds=bounds,
            options={"maxfun": EVALUATIONS, "maxiter": EVALUATIONS},
        )  # fmt: skip
        if found.fun < best[0]:
            best = (float(found.fun), found.x)
    steps.close()
    theta = best[1]
    return float(np.exp(theta[0])), np.exp(theta[1:-1]), float(np.exp(theta[-1])), -best[0]


# ------------------------------------------------------------------ the approximation
@dataclass(frozen=True, eq=False)
class Fitc:
    """The FITC posterior (see module doc), in units of the correlation.

    Attributes:
        Z: (m, d) the inducing points' scaled features.
        L: (m, m) lower Cholesky factor of r(Z, Z) + jitter.
        LB: (m, m) lower Cholesky factor of B = I + V Λ⁻¹ Vᵀ.
        weights: (m, p) L⁻ᵀ B⁻¹ V Λ⁻¹ Y: the mean at x* is r(x*, Z) @ weights.
        largest: the shape of the largest array the fit built (at most BLOCK × m).
    """

    Z: np.ndarray
    L: np.ndarray
    LB: np.ndarray
    weights: np.ndarray
    largest: tuple[int, int]

    @classmethod
    def build(cls, X: np.ndarray, Y: np.ndarray, Z: np.ndarray, nu: float, steps: Steps) -> Fitc:
        """The posterior of Y (n × p) at scaled features X, inducing points Z, noise share ν,
        summed ``BLOCK`` training points at a time (one step each)."""
        from scipy.linalg import solve_triangular

        m, n = len(Z), len(X)
        Kmm = correlation(Z, Z)
        jitter = JITTER
        while True:
            try:
                L = np.linalg.cholesky(Kmm + jitter * np.eye(m))
                break
            except np.linalg.LinAlgError:
                jitter *= 10
        B, c = np.eye(m), np.zeros((m, Y.shape[1]))
        blocks = range(0, n, BLOCK)
        steps.stage("of training configurations summed", len(blocks))
        largest = (0, 0)
        for start in blocks:
            V = solve_triangular(L, correlation(Z, X[start : start + BLOCK]), lower=True)
            largest = max(largest, V.shape)
            lam = nu + np.maximum(1.0 - np.sum(V**2, axis=0), 0.0)
            B += (V / lam) @ V.T
            c += (V / lam) @ Y[start : start + BLOCK]
            steps.advance()
        steps.close()
        LB = np.linalg.cholesky(B)
        inner = solve_triangular(LB, solve_triangular(LB, c, lower=True), lower=True, trans="T")
        return cls(Z, L, LB, solve_triangular(L, inner, lower=True, trans="T"), largest)

    def mean(self, Xs: np.ndarray) -> np.ndarray:
        """(k, p) the posterior mean at scaled features Xs (in Y's units), ``BLOCK`` at a time."""
        blocks = [correlation(Xs[i : i + BLOCK], self.Z) @ self.weights for i in range(0, len(Xs), BLOCK)]
        return np.concatenate(blocks) if blocks else np.zeros((0, self.weights.shape[1]))

    def variance(self, Xs: np.ndarray) -> np.ndarray:
        """(k,) the posterior variance of f at scaled features Xs, over s², ``BLOCK`` at a time."""
        from scipy.linalg import solve_triangular

        out = np.empty(len(Xs))
        for i in range(0, len(Xs), BLOCK):
            v = solve_triangular(self.L, correlation(self.Z, Xs[i : i + BLOCK]), lower=True)
            u = solve_triangular(self.LB, v, lower=True)
            out[i : i + BLOCK] = np.maximum(1.0 - np.sum(v**2, axis=0) + np.sum(u**2, axis=0), 0.0)
        return out
