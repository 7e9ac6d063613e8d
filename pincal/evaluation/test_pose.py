r"""The test-pose criterion ρ0 (SPEC §4, §5.1).

ρ0² = E‖g(q₀, Π̂) − g(q₀, Π)‖² = σ² trace(J₀ M⁻¹ J₀ᵀ), J₀ = J(q₀) [m²]: the expected squared position
error at the test pose q₀ after compensation. With several test poses, the mean of ρ0²
(``aggregate="mean"``) or its largest value (``"worst"``). ρ0 is a distance: it never mixes units.

A plan whose M is singular (too few configurations, or degenerate ones) has no finite criterion:
:class:`~pincal.errors.SingularPlan` is raised, naming the minimum number of configurations.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dtrtrs as _trtrs

from pincal.errors import PincalError
from pincal.evaluation.information import factor, information_matrix
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet

AGGREGATES = ("mean", "worst", "each")


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
        L = factor(M, self.rows, m)
        X, _ = _trtrs(L, self.J0T, lower=1)
        return self.sigma**2 * np.einsum("ij,ij->j", X, X).reshape(self.k, -1).sum(axis=1)

    def from_information(self, M: np.ndarray, m: int):
        """ρ0 [m] (aggregated as asked) for an information matrix M of m configurations."""
        if self.aggregate == "mean":  # the hot path: one number, no per-pose split
            X, _ = _trtrs(factor(M, self.rows, m), self.J0T, lower=1)
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
    L = factor(information_matrix(J), J.shape[1], len(qs))
    J0 = params.jacobian(q0, frame="world")  # (k, 3K, P)
    X = np.linalg.solve(L, J0.transpose(0, 2, 1))  # (k, P, 3K)
    return sigma**2 * np.einsum("kpi,kpj->kij", X, X)
