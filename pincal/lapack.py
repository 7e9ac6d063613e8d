"""The few LAPACK routines pincal calls directly, loaded on first use.

scipy.linalg takes longer to import than the rest of pincal together; ``import pincal`` and
``pincal --help`` do not need it. Each function here resolves its routine once, then costs one
call more than calling LAPACK through scipy directly.
"""

from __future__ import annotations

import numpy as np

_ROUTINES: dict[str, object] = {}


def _routine(name: str, library: str = "lapack"):
    found = _ROUTINES.get(name)
    if found is None:
        from scipy.linalg import blas, lapack

        found = _ROUTINES[name] = getattr(lapack if library == "lapack" else blas, name)
    return found


def potrf(a: np.ndarray) -> tuple[np.ndarray, int]:
    """(L, info): the lower Cholesky factor of ``a`` (not modified), info ≠ 0 if it is not
    positive definite."""
    return _routine("dpotrf")(a, lower=1, clean=1, overwrite_a=0)


def trtrs(L: np.ndarray, b: np.ndarray, trans: int = 0) -> np.ndarray:
    """L⁻¹b (``trans`` 0) or L⁻ᵀb (1) for a lower-triangular L."""
    x, _ = _routine("dtrtrs")(L, b, lower=1, trans=trans)
    return x


def trsm(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """L⁻¹b for a lower-triangular L (no singularity check), by BLAS trsm: on one thread at the
    sizes of a plan, where OpenBLAS's trtrs splits even a 27×27 system over its threads (10× the
    time of the solve on two busy cores)."""
    return _routine("dtrsm", "blas")(1.0, L, b, lower=1)


def trsm_batch(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k, P, r) L_i⁻¹b for k lower-triangular L_i (k, P, P) and one b (P, r): one BLAS trsm per
    matrix (no singularity check), on Fortran-ordered views of one transposed copy of the stack;
    an LU solve of each (``numpy.linalg.solve``) took four times as long."""
    solve = _routine("dtrsm", "blas")
    transposed = np.ascontiguousarray(np.swapaxes(L, 1, 2))  # each [i].T is L_i in Fortran order
    right = np.asfortranarray(b)
    return np.array([solve(1.0, lower.T, right, lower=1) for lower in transposed])


def eigenvalues(a: np.ndarray) -> np.ndarray:
    """The eigenvalues, ascending, of a symmetric matrix ``a`` (its lower triangle read; not
    modified): LAPACK syevd as ``numpy.linalg.eigvalsh`` calls it, without NumPy's checks and
    batch machinery (their overhead is a sixth of the call for one 27×27 matrix)."""
    w, _, info = _routine("dsyevd")(a, compute_v=0, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"syevd did not converge (info {info})")
    return w


def cho_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """M⁻¹b from the lower Cholesky factor L of M."""
    x, _ = _routine("dpotrs")(L, b, lower=1)
    return x
