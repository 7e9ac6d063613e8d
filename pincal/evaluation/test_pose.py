r"""How good a plan is: the test-pose criterion ρ0 and the classic criteria (SPEC §4).

With i.i.d. measurement noise of standard deviation σ per coordinate, least squares gives
cov(Π̂) = σ² M⁻¹ with M = Σᵢ JᵢᵀJᵢ = JᵀJ, the *information matrix* of the plan {q₁..q_m}
(J stacked over the configurations; 3 rows per marker per configuration).

* Test-pose criterion: the expected squared position error at the test pose q₀ after
  compensation, ρ0² = E‖g(q₀, Π̂) − g(q₀, Π)‖² = σ² trace(J₀ M⁻¹ J₀ᵀ), J₀ = J(q₀) [m²]. With several
  test poses, the mean of ρ0² (``aggregate="mean"``) or its largest value (``"worst"``).
* D: log det(M⁻¹) = −log det M;  A: trace(M⁻¹);  E: λ_max(M⁻¹) = 1/σ_min(J)².
* cond: σ_max(J)/σ_min(J), the condition number of the stacked Jacobian.
* Observability indices, with σ₁ ≥ … ≥ σ_P the singular values of J and m configurations:
  O1 = (σ₁σ₂⋯σ_P)^{1/P}/√m (Borm & Menq),  O2 = σ_P/σ₁ (inverse condition number),
  O3 = σ_P (smallest singular value),  O4 = σ_P²/σ₁ (noise amplification index).

D, A, E and cond are *lower is better*; O1–O4 are *higher is better*. D, A and E mix units when the
set mixes lengths and angles (m² and rad²); ρ0 never does: it is a distance.

A plan whose M is singular (too few configurations, or degenerate ones) has no finite criterion:
:class:`~pincal.errors.SingularPlan` is raised, naming the minimum number of configurations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dpotrf as _potrf
from scipy.linalg.lapack import dtrtrs as _trtrs

from .errors import PincalError, SingularPlan
from .jacobian import ZERO_COLUMN, JacobianEngine
from .parameters import ParameterSet

RCOND = 1e-14
"""A plan is singular when the Jacobi-scaled information matrix has a reciprocal condition
number below this (its stacked Jacobian, below its square root 1e-7)."""

AGGREGATES = ("mean", "worst", "each")


def information_matrix(J: np.ndarray) -> np.ndarray:
    """M = JᵀJ for a (m, 3K, P) or stacked (rows, P) parameter Jacobian."""
    J = np.asarray(J)
    J2 = J.reshape(-1, J.shape[-1])
    return J2.T @ J2


def _factor(M: np.ndarray, rows: int, m: int) -> np.ndarray:
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
    raise SingularPlan(len(M), rows, m, _rank(M))


def _rank(M: np.ndarray) -> int:
    d = np.sqrt(np.abs(np.diag(M)))
    zero = d <= ZERO_COLUMN * d.max()
    d[zero] = 1.0
    scaled = M / np.outer(d, d)
    scaled[zero, :] = scaled[:, zero] = 0.0
    w = np.linalg.eigvalsh(scaled)
    return int(np.sum(w > RCOND * max(w.max(), 1e-300)))


class TestPoseCriterion:
    """ρ0 at one or several test poses, compiled for repeated evaluation on many plans.

    J₀ is computed once; each call costs one forward-kinematics pass and one kinematic regressor
    per configuration, then a few dense operations on a P×P matrix. Not thread-safe (it holds a
    ``pinocchio.Data``): use one per thread or process.

    Args:
        params: the parameters identified.
        test_poses: (nq,) or (k, nq) test configuration(s) [rad or m].
        sigma: measurement noise standard deviation per coordinate [m].
        aggregate: ``"mean"`` (root of the mean ρ0² over test poses), ``"worst"`` (largest ρ0)
            or ``"each"`` (one ρ0 per test pose).
    """

    __test__ = False  # not a pytest class

    def __init__(
        self,
        params: ParameterSet,
        test_poses: object,
        sigma: float = 1.0,
        aggregate: str = "mean",
    ) -> None:
        if aggregate not in AGGREGATES:
            raise PincalError(f"unknown aggregate {aggregate!r}; valid: {', '.join(AGGREGATES)}")
        if not (np.isfinite(sigma) and sigma > 0):
            raise PincalError(f"sigma must be a positive number of metres, got {sigma!r}")
        self.params = params
        self.engine = JacobianEngine(params)
        self.test_poses = params.robot.configurations(test_poses, what="test pose")
        self.sigma = float(sigma)
        self.aggregate = aggregate
        J0 = self.engine.jacobian(self.test_poses, frame="tip")
        self.k = len(self.test_poses)
        self.J0T = np.ascontiguousarray(J0.reshape(-1, len(params)).T)  # (P, k·3K)

    @property
    def rows(self) -> int:
        """Measured coordinates per configuration (3 per marker)."""
        return self.engine.rows

    def rho0_squared_from_information(self, M: np.ndarray, m: int) -> np.ndarray:
        """(k,) ρ0² [m²] at each test pose for information matrix M of an m-configuration plan."""
        L = _factor(M, self.rows, m)
        X, _ = _trtrs(L, self.J0T, lower=1)
        return self.sigma**2 * np.einsum("ij,ij->j", X, X).reshape(self.k, -1).sum(axis=1)

    def from_information(self, M: np.ndarray, m: int):
        """ρ0 [m] (aggregated as asked) for an information matrix M of m configurations."""
        if self.aggregate == "mean":  # the hot path: one number, no per-pose split
            X, _ = _trtrs(_factor(M, self.rows, m), self.J0T, lower=1)
            return self.sigma * np.sqrt(np.einsum("ij,ij", X, X) / self.k)
        r2 = self.rho0_squared_from_information(M, m)
        if self.aggregate == "mean":
            return float(np.sqrt(r2.mean()))
        if self.aggregate == "worst":
            return float(np.sqrt(r2.max()))
        return np.sqrt(r2)

    def __call__(self, qs: np.ndarray):
        """ρ0 [m] of the plan ``qs`` ((m, nq), trusted: not checked against limits)."""
        J = self.engine.jacobian(qs, frame="tip").reshape(-1, self.J0T.shape[0])
        return self.from_information(J.T @ J, len(qs))


def rho0(
    params: ParameterSet,
    plan: object,
    test_pose: object,
    sigma: float = 1.0,
    aggregate: str = "mean",
):
    """Expected position error at the test pose(s) after calibrating with ``plan``.

    ρ0 = σ·sqrt(trace(J₀ M⁻¹ J₀ᵀ)) (see module doc): "after calibration, expect ±ρ0 at q₀".

    Args:
        params: the parameters identified (use an identifiable set).
        plan: (m, nq) configurations [rad or m] or a :class:`~pincal.Plan`.
        test_pose: (nq,) or (k, nq) test configuration(s).
        sigma: measurement noise standard deviation per coordinate [m]; ρ0 is proportional.
        aggregate: ``"mean"``, ``"worst"`` or ``"each"`` over several test poses.

    Returns:
        ρ0 [m]: a float, or a (k,) array for ``aggregate="each"``.

    Raises:
        SingularPlan: the plan cannot identify ``params`` (names the minimum m).
        BadConfiguration: a configuration or test pose of the wrong size or outside the limits.
    """
    qs = params.robot.configurations(plan)
    return TestPoseCriterion(params, test_pose, sigma, aggregate)(qs)


def position_covariance(
    params: ParameterSet, plan: object, test_pose: object, sigma: float = 1.0
) -> np.ndarray:
    """(k, 3K, 3K) predicted covariance σ² J₀ M⁻¹ J₀ᵀ of the measured points at each test pose,
    after calibration, in the instrument frame [m²]. Its trace is ρ0²."""
    qs = params.robot.configurations(plan)
    q0 = params.robot.configurations(test_pose, what="test pose")
    J = params.jacobian(qs, frame="tip")
    L = _factor(information_matrix(J), J.shape[1], len(qs))
    J0 = params.jacobian(q0, frame="world")  # (k, 3K, P)
    X = np.linalg.solve(L, J0.transpose(0, 2, 1))  # (k, P, 3K)
    return sigma**2 * np.einsum("kpi,kpj->kij", X, X)


@dataclass(frozen=True)
class Criteria:
    """The classic criteria of a plan (see module doc for the definitions).

    Attributes:
        log_det: D criterion, log det(M⁻¹) (lower is better).
        trace: A criterion, trace(M⁻¹) (lower is better).
        max_eig: E criterion, largest eigenvalue of M⁻¹ (lower is better).
        cond: condition number of the stacked Jacobian (lower is better, ≥ 1).
        O1: (σ₁⋯σ_P)^{1/P}/√m.   O2: σ_P/σ₁.   O3: σ_P.   O4: σ_P²/σ₁.  (higher is better)
        n_params: P.
        m: number of configurations.
    """

    log_det: float
    trace: float
    max_eig: float
    cond: float
    O1: float
    O2: float
    O3: float
    O4: float
    n_params: int
    m: int

    def as_dict(self) -> dict[str, float]:
        """The criteria by name (the keys of ``pincal evaluate --json``)."""
        return {k: getattr(self, k) for k in ("log_det", "trace", "max_eig", "cond", "O1", "O2", "O3", "O4")}


def criteria_from_jacobian(J: np.ndarray, m: int) -> Criteria:
    """Classic criteria of a stacked (rows, P) or (m, 3K, P) parameter Jacobian."""
    J = np.asarray(J)
    rows = J.shape[1] if J.ndim == 3 else J.shape[0] // max(m, 1)
    J2 = J.reshape(-1, J.shape[-1])
    n = J2.shape[1]
    _factor(J2.T @ J2, rows, m)  # raises SingularPlan like ρ0 does
    s = np.linalg.svd(J2, compute_uv=False)
    return Criteria(
        log_det=float(-2.0 * np.sum(np.log(s))),
        trace=float(np.sum(1.0 / s**2)),
        max_eig=float(1.0 / s[-1] ** 2),
        cond=float(s[0] / s[-1]),
        O1=float(np.exp(np.mean(np.log(s))) / np.sqrt(m)),
        O2=float(s[-1] / s[0]),
        O3=float(s[-1]),
        O4=float(s[-1] ** 2 / s[0]),
        n_params=n,
        m=m,
    )


def criteria(params: ParameterSet, plan: object) -> Criteria:
    """The classic criteria (D, A, E, cond, O1–O4) of ``plan`` for ``params``."""
    qs = params.robot.configurations(plan)
    return criteria_from_jacobian(params.jacobian(qs, frame="tip"), len(qs))
