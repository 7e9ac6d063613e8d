r"""The information matrix of a plan and its one numerical kernel (docs/method.md §6.1, §6.6).

With i.i.d. measurement noise of standard deviation σ per coordinate, least squares gives
cov(Π̂) = σ² M⁻¹ with M = Σᵢ JᵢᵀJᵢ = JᵀJ, the *information matrix* of the plan {q₁..q_m}
(J stacked over the configurations; 3 rows per marker per configuration).

Every test of singularity, rank and conditioning in pincal goes through this module:
:func:`factor` (Cholesky with a scale-free singularity test), :func:`rank` and
:func:`conditioning` (smallest eigenvalue of the Jacobi-scaled M), :func:`condition_number`
(σ_max/σ_min of the column-scaled Jacobian), :func:`weakest` (the least determined parameter
combinations) and :func:`covariance_diagonal` (diag M⁻¹, or None for a singular M), all on
:func:`jacobi_scaled`. (The greedy choice of a base set among unit columns,
:func:`~pincal.model.base_parameters.independent_columns`, is the model stage's, so that the
model never imports this later stage.)
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from pincal.errors import SingularPlan
from pincal.lapack import potrf, trsm_batch
from pincal.model.jacobian import ZERO_COLUMN

RCOND = 1e-14
"""A plan is singular when the Jacobi-scaled information matrix has a reciprocal condition
number below this (its stacked Jacobian, below its square root 1e-7)."""


def information_matrix(J: np.ndarray) -> np.ndarray:
    """M = JᵀJ for a (m, 3K, P) or stacked (rows, P) parameter Jacobian."""
    J = np.asarray(J)
    J2 = J.reshape(-1, J.shape[-1])
    return J2.T @ J2


def informations(J: np.ndarray) -> np.ndarray:
    """(k, P, P) information matrices M = JᵀJ of k plans' Jacobians (k, m·r, P)."""
    return np.matmul(np.swapaxes(J, 1, 2), J)


def factor(M: np.ndarray, rows: int, m: int) -> np.ndarray:
    """Lower Cholesky factor L of M (M = L Lᵀ).

    The test for singularity is scale-free: L_ii²/M_ii are the pivots of the Jacobi-scaled
    M/(d dᵀ), d = sqrt(diag M), whose reciprocal condition number their ratio estimates; and a
    column of J whose norm is below ZERO_COLUMN times the largest is a zero column (rounding
    noise, as for the offset of a joint whose axis passes through the measured point).

    Raises SingularPlan when M is singular or numerically so.
    """
    L, info = potrf(M)
    if info == 0 and _regular(L.diagonal().tolist(), M.diagonal().tolist()):
        return L
    raise SingularPlan(len(M), rows, m, rank(M))


def _regular(lower: list[float], diag: list[float]) -> bool:
    """:func:`factor`'s test on the diagonals of a Cholesky factor and of its M, in plain floats
    (the same numbers as in NumPy: for one plan, a dozen NumPy calls on 27 numbers cost more than
    the factorisation)."""
    pivots = [a * a / b for a, b in zip(lower, diag)]
    return min(pivots) >= RCOND * max(pivots) and min(diag) >= ZERO_COLUMN**2 * max(diag)


def factor_batch(Ms: np.ndarray, rows: int, m: int) -> np.ndarray:
    """Lower Cholesky factors (k, P, P) of a stack of information matrices, with the singularity
    test of :func:`factor` for each.

    Raises:
        SingularPlan: for the first singular M, as :func:`factor` would, naming it
            (``plan i:``) when the stack holds more than one.
    """
    if len(Ms) == 1:  # one plan: LAPACK's factor without NumPy's batch machinery
        return factor(Ms[0], rows, m)[None]
    try:
        L = np.linalg.cholesky(Ms)
    except np.linalg.LinAlgError:
        L = None
    if L is not None and _all_regular(Ms, L):
        return L
    raise_singular(Ms, rows, m)
    raise SingularPlan(Ms.shape[-1], rows, m)  # pragma: no cover - Cholesky and factor disagree


def _all_regular(Ms: np.ndarray, L: np.ndarray) -> bool:
    """:func:`factor`'s test for every M of a stack (k, P, P), on the first P columns of their
    Cholesky factors L."""
    diag = np.diagonal(Ms, axis1=1, axis2=2)
    pivots = np.diagonal(L, axis1=1, axis2=2)[:, : Ms.shape[-1]] ** 2 / diag
    regular = (pivots.min(axis=1) >= RCOND * pivots.max(axis=1)) & (
        diag.min(axis=1) >= ZERO_COLUMN**2 * diag.max(axis=1)
    )
    return bool(regular.all())


BORDER = 1e150
"""The bordering block β·I of :func:`solved_squares`: far above ‖L⁻¹W‖² of any plan that passes
the singularity test (its Cholesky factor then stays real), far below overflow."""

BORDERED = 8
"""Columns of W up to which :func:`solved_squares` borders the matrices (one test pose's rows);
beyond, the factorisation of the larger bordered matrix costs more than the solves it saves."""


def solved_squares(
    J: np.ndarray, W: np.ndarray, rows: int, m: int, prior: np.ndarray | None = None
) -> np.ndarray:
    """(k,) ‖L_i⁻¹W‖²_F = tr(Wᵀ M_i⁻¹ W) for the information matrices M_i = J_iᵀJ_i (+ Λ, the
    prior's information, if given) = L_iL_iᵀ of a stack of Jacobians J (k, m·rows, P) and one W
    (P, r), with the singularity test of :func:`factor_batch`.

    One batched product writes each M_i into the leading block of a bordered matrix
    [[M_i, W], [Wᵀ, βI]] (β = :data:`BORDER`) and one batched Cholesky factorisation follows: the
    leading block of each factor is L_i and the block below it (L_i⁻¹W)ᵀ, so that no triangular
    solve runs plan by plan (r ≤ :data:`BORDERED`; else :func:`factor_batch` and one BLAS trsm per
    plan).

    Raises:
        SingularPlan: as :func:`factor_batch`.
    """
    k, P = J.shape[0], J.shape[-1]
    r = W.shape[1]
    if r <= BORDERED and k > 1:
        bordered = np.empty((k, P + r, P + r))
        Ms = np.matmul(np.swapaxes(J, 1, 2), J, out=bordered[:, :P, :P])
        if prior is not None:
            Ms += prior
        bordered[:, P:, :P] = W.T
        bordered[:, :P, P:] = W
        bordered[:, P:, P:] = BORDER * np.eye(r)
        try:
            L = np.linalg.cholesky(bordered)
        except np.linalg.LinAlgError:
            L = None
        if L is not None and _all_regular(Ms, L):
            X = L[:, P:, :P]
            return np.einsum("krp,krp->k", X, X)
    else:
        Ms = informations(J) if prior is None else informations(J) + prior
    X = trsm_batch(factor_batch(Ms, rows, m), W)
    return np.einsum("kpr,kpr->k", X, X)


def raise_singular(Ms: np.ndarray, rows: int, m: int, which: Iterable[int] | None = None) -> None:
    """Raise :class:`SingularPlan` for the first singular M of a stack (of the plans ``which``,
    default all), as :func:`factor` would, naming it (``plan i:``) when the stack holds more than
    one; return when none is."""
    for i in range(len(Ms)) if which is None else which:
        try:
            factor(Ms[i], rows, m)
        except SingularPlan as error:
            if len(Ms) > 1:
                error.of_plan(int(i))
            raise


def jacobi_scaled(M: np.ndarray, zero: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(d, D⁻¹MD⁻¹) for one (P, P) information matrix or a stack (n, P, P), D = diag(d),
    d = sqrt(diag M): M of the Jacobian with unit columns, free of the parameters' units.

    A column with d ≤ ``zero`` × max d is a zero column: its d is set to 1 and its row and
    column of the scaled matrix to 0.
    """
    d = np.sqrt(np.abs(np.diagonal(M, axis1=-2, axis2=-1)))
    null = d <= zero * d.max(axis=-1, keepdims=True)
    d[null] = 1.0
    scaled = M / (d[..., :, None] * d[..., None, :])
    if zero > 0 and null.any():
        scaled = np.where(null[..., :, None] | null[..., None, :], 0.0, scaled)
    return d, scaled


def rank(M: np.ndarray) -> int:
    """Numerical rank of M, from the eigenvalues of its Jacobi scaling (zero columns: rank 0)."""
    w = np.linalg.eigvalsh(jacobi_scaled(M, ZERO_COLUMN)[1])
    return int(np.sum(w > RCOND * max(w.max(), 1e-300)))


def condition_number(M: np.ndarray) -> float:
    """σ_max/σ_min of the column-scaled Jacobian, sqrt(λ_max/λ_min) of the Jacobi-scaled M:
    1 for orthogonal columns, unchanged by the parameters' units, ``inf`` when M is singular
    (rank below its size by the RCOND test of :func:`rank`)."""
    w = np.linalg.eigvalsh(jacobi_scaled(M, ZERO_COLUMN)[1])
    if w[0] <= RCOND * max(w[-1], 1e-300):
        return float("inf")
    return float(np.sqrt(w[-1] / w[0]))


def weakest(M: np.ndarray, count: int = 3) -> list[tuple[float, np.ndarray]]:
    """The ``count`` least determined directions of the column-scaled Jacobian, weakest first:
    ``(σ_i/σ_max, v_i)`` with v_i a unit vector of coefficients on the unit-scaled parameters
    (a combination Σ v_ij·Π_j/‖J_j‖ that moves the points by σ_i only)."""
    w, V = np.linalg.eigh(jacobi_scaled(M, ZERO_COLUMN)[1])
    top = max(w[-1], 1e-300)
    return [(float(np.sqrt(max(w[i], 0.0) / top)), V[:, i]) for i in range(min(count, len(w)))]


def covariance_diagonal(M: np.ndarray) -> np.ndarray | None:
    """diag(M⁻¹) by a Cholesky factor of the Jacobi-scaled M, or None when M is singular by the
    test of :func:`factor` (the standard errors are then σ·sqrt of it)."""
    norms = np.sqrt(np.abs(np.diag(M)))
    if norms.size == 0 or norms.min() <= ZERO_COLUMN * norms.max():
        return None
    d, scaled = jacobi_scaled(M)
    L, info = potrf(scaled)
    if info != 0 or L.diagonal().min() ** 2 < RCOND * L.diagonal().max() ** 2:
        return None
    Linv = np.linalg.inv(np.tril(L))
    return np.sum(Linv**2, axis=0) / d**2


def conditioning(M: np.ndarray) -> float:
    """Smallest eigenvalue of the Jacobi-scaled information matrix D⁻¹MD⁻¹, D = diag(M)^½.

    It is σ_min² of the stacked Jacobian with unit columns: in (0, 1], 0 for a singular plan,
    unchanged by the units of the parameters.
    """
    return float(np.linalg.eigvalsh(jacobi_scaled(M)[1])[0])
