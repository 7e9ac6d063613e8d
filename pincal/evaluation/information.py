r"""The information matrix of a plan and its one numerical kernel (SPEC §4).

With i.i.d. measurement noise of standard deviation σ per coordinate, least squares gives
cov(Π̂) = σ² M⁻¹ with M = Σᵢ JᵢᵀJᵢ = JᵀJ, the *information matrix* of the plan {q₁..q_m}
(J stacked over the configurations; 3 rows per marker per configuration).

Every test of singularity, rank and conditioning in pincal goes through this module:
:func:`factor` (Cholesky with a scale-free singularity test), :func:`rank` and
:func:`conditioning` (smallest eigenvalue of the Jacobi-scaled M).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf as _potrf

from pincal.errors import SingularPlan
from pincal.model.jacobian import ZERO_COLUMN

RCOND = 1e-14
"""A plan is singular when the Jacobi-scaled information matrix has a reciprocal condition
number below this (its stacked Jacobian, below its square root 1e-7)."""


def information_matrix(J: np.ndarray) -> np.ndarray:
    """M = JᵀJ for a (m, 3K, P) or stacked (rows, P) parameter Jacobian."""
    J = np.asarray(J)
    J2 = J.reshape(-1, J.shape[-1])
    return J2.T @ J2


def factor(M: np.ndarray, rows: int, m: int) -> np.ndarray:
    """Lower Cholesky factor L of M (M = L Lᵀ).

    The test for singularity is scale-free: L_ii²/M_ii are the pivots of the Jacobi-scaled
    M/(d dᵀ), d = sqrt(diag M), whose reciprocal condition number their ratio estimates; and a
    column of J whose norm is below ZERO_COLUMN times the largest is a zero column (rounding
    noise, as for the offset of a joint whose axis passes through the measured point).

    Raises SingularPlan when M is singular or numerically so.
    """
    L, info = _potrf(M, lower=1, clean=1, overwrite_a=0)
    if info == 0:
        diag = M.diagonal()
        pivots = L.diagonal() ** 2 / diag
        if pivots.min() >= RCOND * pivots.max() and diag.min() >= ZERO_COLUMN**2 * diag.max():
            return L
    raise SingularPlan(len(M), rows, m, rank(M))


def rank(M: np.ndarray) -> int:
    d = np.sqrt(np.abs(np.diag(M)))
    zero = d <= ZERO_COLUMN * d.max()
    d[zero] = 1.0
    scaled = M / np.outer(d, d)
    scaled[zero, :] = scaled[:, zero] = 0.0
    w = np.linalg.eigvalsh(scaled)
    return int(np.sum(w > RCOND * max(w.max(), 1e-300)))


def conditioning(M: np.ndarray) -> float:
    """Smallest eigenvalue of the Jacobi-scaled information matrix D⁻¹MD⁻¹, D = diag(M)^½.

    It is σ_min² of the stacked Jacobian with unit columns: in (0, 1], 0 for a singular plan,
    unchanged by the units of the parameters.
    """
    d = np.sqrt(np.abs(np.diag(M)))
    d[d == 0] = 1.0
    return float(np.linalg.eigvalsh(M / np.outer(d, d))[0])
