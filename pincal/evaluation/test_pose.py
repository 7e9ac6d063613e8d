r"""The test-pose criterion ρ0 (docs/method.md §6.2, §6.3, §8.4).

ρ0² = E‖g(q₀, Π̂) − g(q₀, Π)‖² = σ² trace(J₀ M⁻¹ J₀ᵀ), J₀ = J(q₀) [m²]: the expected squared position
error at the test pose q₀ after compensation. With several test poses, a path or a region (see
:mod:`pincal.evaluation.region`), the mean of ρ0² (``aggregate="mean"``, the V/I-optimal design) or
its largest value (``"worst"``). ρ0 is a distance: it never mixes units.

The mean over n test poses is σ² tr(M⁻¹A), A = (1/n) Σₖ J0ₖᵀJ0ₖ (P×P): A is computed once and
factored, A = FFᵀ with at most P columns (:func:`mean_weight_factor`), so that an evaluation costs
the same for n = 1 or n = 10 000.

With a prior (:class:`~pincal.Prior`, covariance Σp of the errors before calibration), the posterior
covariance is σ²(M + Λ)⁻¹, Λ = σ²Σp⁻¹, and ρ0² = σ² tr(J₀(M + Λ)⁻¹J₀ᵀ) (the Bayesian criterion):
finite for every plan, ρ0² without prior as Σp → ∞. It splits exactly into the part due to the
measurement noise, σ² tr(J₀CMCJ₀ᵀ), and the part of the prior errors the plan leaves uncorrected,
σ² tr(J₀CΛCJ₀ᵀ), with C = (M + Λ)⁻¹ (:meth:`TestPoseCriterion.split`).

The criterion a design minimises is :class:`TestPoseMean` (``test-pose``; the worst test pose is
:class:`~pincal.evaluation.test_pose_worst.TestPoseWorst`): F = log mean_k tr(J0k (M + Λ)⁻¹ J0kᵀ),
reported as ρ0 = σ·sqrt(exp F). :class:`TestPoseCriterion` and :func:`rho0` evaluate both on plans.

With joint compliances among the parameters, the test pose is taken under the task's load w₀
(``task_payload``): J₀ holds τ(θ₀, w₀), so ρ0 counts what the compliance estimate's uncertainty does
at the working load; a plan's own payloads (:attr:`Plan.payload`) enter its Jacobian likewise.
:func:`rho0_split` splits ρ0² into its geometric and elastic (gains and compliances) parts by the
blocks of the parameter covariance projected through J₀, and their cross term (docs/method.md §11.3).

A plan whose M is singular (too few configurations, or degenerate ones) has no finite criterion:
:class:`~pincal.errors.SingularPlan` is raised, naming the minimum number of configurations.
"""

from __future__ import annotations

import math

import numpy as np

from pincal.arguments import DEFAULT_SIGMA
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument
from pincal.evaluation.information import (
    factor,
    factor_batch,
    information_matrix,
    informations,
    solved_squares,
)
from pincal.evaluation.plans import SMALL, blas_for, engine_for, in_blocks, plan_batch, plan_payloads
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import TestRegion, resolve_test_poses
from pincal.evaluation.test_pose_worst import TestPoseWorst
from pincal.evaluation.weighted_trace import WeightedTrace
from pincal.instruments.given import keywords, measured, takes_instrument
from pincal.instruments.instrument import Instrument, orientation_length_of, tool_rows
from pincal.kept import CRITERIA
from pincal.lapack import trsm, trsm_batch
from pincal.model.parameters import ParameterSet
from pincal.model.statics import PayloadRows, payload_rows
from pincal.typing import ConfigurationsLike, PayloadLike, PlansLike, TestPoseLike

AGGREGATES = ("mean", "worst", "each")


def mean_weight_factor(J0: np.ndarray) -> np.ndarray:
    """(P, r) F with FFᵀ = A = (1/k) Σₖ J0ₖᵀJ0ₖ, r ≤ P, for (k, 3K, P) test-pose Jacobians:
    mean_k tr(J0ₖ M⁻¹ J0ₖᵀ) = tr(M⁻¹A) = ‖L⁻¹F‖² (M = LLᵀ), whatever k."""
    J0 = np.asarray(J0)
    k, P = len(J0), J0.shape[-1]
    W = J0.reshape(-1, P)
    if W.shape[0] <= P:
        return np.ascontiguousarray(W.T / np.sqrt(k))
    w, V = np.linalg.eigh(W.T @ W / k)
    keep = w > w[-1] * 1e-15
    return np.ascontiguousarray(V[:, keep] * np.sqrt(w[keep]))


class TestPoseMean(WeightedTrace):
    """The ``test-pose`` criterion: F = log mean_k tr(J0k (M + Λ)⁻¹ J0kᵀ), ρ0 = σ·sqrt(exp F) [m].

    The mean over k test poses is one weighted trace tr((M + Λ)⁻¹A) with A = FFᵀ
    (:func:`mean_weight_factor`, at most P columns): its cost does not grow with k.

    Args:
        J0: (k, r, P) tip-frame Jacobians at the test poses.
        sigma: measurement noise per coordinate [m] (ρ0 is proportional).
        rows: measured coordinates per configuration.
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹, or None.
    """

    name = "test-pose"

    def __init__(self, J0: np.ndarray, sigma: float, rows: int, prior: np.ndarray | None = None) -> None:
        super().__init__(mean_weight_factor(J0), 1, sigma, rows, prior)

    def aggregate(self, t: np.ndarray) -> np.ndarray:
        return t.mean(axis=-1)

    def gradient_weights(self, t: np.ndarray) -> tuple[float, np.ndarray]:
        return float(np.log(t.mean())), np.full(self.k, 1.0 / t.sum())

    def rho0(self, M: np.ndarray, m: int) -> float:
        """ρ0 [m], the root of the mean ρ0² over the test poses, for information M of m configurations."""
        x = trsm(factor(self.posterior(M), self.rows, m), self.J0T).ravel()
        return self.scale * math.sqrt(x @ x)


class TestPoseCriterion:
    """ρ0 at one or several test poses, compiled for repeated evaluation on many plans.

    J₀ is computed once; each call costs one forward-kinematics pass and one kinematic regressor
    per configuration, then a few dense operations on a P×P matrix. Not thread-safe (it holds a
    ``pinocchio.Data``): use one per thread or process.

    Args:
        params: the parameters identified.
        test_poses: (nq,) or (k, nq) test configuration(s) [rad or m], or a
            :class:`~pincal.evaluation.region.TestRegion` (its sample configurations).
        sigma: measurement noise standard deviation per coordinate [m], the shorthand for points
            (default :data:`~pincal.arguments.DEFAULT_SIGMA`; not with ``instrument``).
        aggregate: ``"mean"`` (root of the mean ρ0² over test poses), ``"worst"`` (largest ρ0)
            or ``"each"`` (one ρ0 per test pose).
        prior: the errors' prior (Bayesian criterion), or None.
        task_payload: the payload at the test pose(s) (a mass [kg], a :class:`~pincal.Payload`,
            or one per test pose); default none.
        instrument: what is measured and how well (:class:`~pincal.instruments.Instrument`): the plan's rows
            are its whitened rows and σ its reference σ; None: points with ``sigma``.
        orientation_length: L [m]: ρ0² also counts L² times the expected squared orientation
            error of the tool at the test poses [rad²] (docs/method.md §13.3); None: positions.
    """

    __test__ = False  # not a pytest class

    def __init__(
        self,
        params: ParameterSet,
        test_poses: TestPoseLike,
        sigma: float | None = None,
        aggregate: str = "mean",
        prior: Prior | None = None,
        task_payload: PayloadLike = None,
        instrument: Instrument | None = None,
        orientation_length: float | None = None,
    ) -> None:
        if aggregate not in AGGREGATES:
            raise BadArgument(f"unknown aggregate {aggregate!r}; valid: {', '.join(AGGREGATES)}")
        instrument, sigma = measured(instrument, sigma)  # the one door: not both
        self.params = params
        self.instrument = instrument
        self.orientation_length = orientation_length_of(orientation_length)
        self.engine = engine_for(params, instrument)
        self.test_poses, self.region = resolve_test_poses(params.robot, test_poses)
        self.sigma = float(sigma)
        self.aggregate = aggregate
        self.task_payload = payload_rows(task_payload, len(self.test_poses))
        J0 = tool_rows(engine_for(params), self.test_poses, self.orientation_length, self.task_payload)
        self.k = len(self.test_poses)
        self.prior = prior
        self.prior_information = None if prior is None else prior.information(params, self.sigma)
        rows = self.engine.rows
        self.mean = TestPoseMean(J0, self.sigma, rows, self.prior_information)
        self.per_pose = TestPoseWorst(J0, self.sigma, rows, self.prior_information)
        self.J0T = self.per_pose.J0T  # (P, k·3K)
        self.weight_factor = self.mean.J0T  # (P, ≤ P): the mean's one weighted trace

    @property
    def rows(self) -> int:
        """Measured coordinates per configuration (3 per marker)."""
        return self.engine.rows

    def posterior(self, M: np.ndarray) -> np.ndarray:
        """M + Λ (Λ = σ²Σp⁻¹ of the prior; M itself without one)."""
        return self.mean.posterior(M)

    def rho0_squared_from_information(self, M: np.ndarray, m: int) -> np.ndarray:
        """(k,) ρ0² [m²] at each test pose for information matrix M of an m-configuration plan."""
        return self.sigma**2 * self.per_pose.traces(M, m)

    def split(self, M: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
        """(k,) ρ0² [m²] due to the measurement noise and (k,) ρ0² due to the prior errors the plan
        leaves uncorrected; they add up to ρ0² (the second is 0 without a prior)."""
        return self.per_pose.split(M, m)

    def from_information(self, M: np.ndarray, m: int):
        """ρ0 [m] (aggregated as asked) for an information matrix M of m configurations."""
        if self.aggregate == "mean":  # one weighted trace, whatever the number of poses
            return self.mean.rho0(M, m)
        r2 = self.rho0_squared_from_information(M, m)
        if self.aggregate == "worst":
            return float(np.sqrt(r2.max()))
        return np.sqrt(r2)

    def __call__(self, qs: np.ndarray, payload: PayloadRows = None):
        """ρ0 [m] of the plan ``qs`` ((m, nq), trusted: not checked against limits) measured
        under ``payload`` ((m, 4) rows, one per configuration, as
        :func:`~pincal.model.statics.payload_rows` gives them; or None)."""
        J = self.engine.jacobian(qs, frame="tip", payload=payload).reshape(-1, self.J0T.shape[0])
        return self.from_information(J.T @ J, len(qs))

    def plans(self, qs: np.ndarray, payload: np.ndarray | None = None) -> np.ndarray:
        """ρ0 [m] of k plans ``qs`` ((k, m, nq), trusted): (k,), or (k, test poses) for ``"each"``.
        One Jacobian pass for every configuration, batched factorisations (see
        :mod:`pincal.evaluation.plans`); ``payload``: (k·m, 4) rows of their payloads, or None."""
        if qs.shape[0] == 1:
            return np.asarray(self(qs[0], payload), dtype=float)[None]
        return np.concatenate(in_blocks(self.engine, qs, payload, self._block))

    def _block(self, J: np.ndarray) -> np.ndarray:
        """:meth:`plans` for the Jacobians J (b, m·r, P) of b plans."""
        k, m = len(J), J.shape[1] // self.rows
        if self.aggregate == "mean":  # one weighted trace per plan
            squares = solved_squares(J, self.weight_factor, self.rows, m, self.prior_information)
            return self.sigma * np.sqrt(squares)
        L = factor_batch(self.posterior(informations(J)), self.rows, m)
        X = trsm_batch(L, self.J0T)
        squares = np.einsum("kpr,kpr->kr", X, X)
        each = self.sigma * np.sqrt(squares.reshape(k, self.k, -1).sum(axis=2))
        return each.max(axis=1) if self.aggregate == "worst" else each


ORDER_0_1 = ("sigma", "aggregate", "prior", "task_payload", "measure", "instrument", "orientation_length")
"""rho0()'s keywords in pincal 0.1's order (what arguments by position after the third meant)."""


@keywords_after(3, ORDER_0_1)
@takes_instrument
def rho0(
    params: ParameterSet,
    plan: PlansLike,
    test_pose: TestPoseLike,
    *,
    sigma: float | None = None,
    aggregate: str = "mean",
    prior: Prior | None = None,
    task_payload: PayloadLike = None,
    instrument: Instrument | None = None,
    orientation_length: float | None = None,
) -> float:
    """Expected position error at the test pose(s) after calibrating with ``plan``.

    ρ0 = σ·sqrt(trace(J₀ M⁻¹ J₀ᵀ)) (see module doc): "after calibration, expect ±ρ0 at q₀".

    Args:
        params: the parameters identified (use an identifiable set).
        plan: (m, nq) configurations [rad or m] or a :class:`~pincal.Plan`; or a batch of k
            plans, (k, m, nq) or a sequence of Plans: one ρ0 per plan, at near the cost of
            Pinocchio's own work (see :mod:`pincal.evaluation.plans`).
        test_pose: (nq,) or (k, nq) test configuration(s), or a region or path
            (:func:`pincal.around`, :class:`pincal.TestPath`, :func:`pincal.cartesian_box`).
        sigma: the shorthand for points measured with this noise per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`, a laser tracker's); ρ0 is proportional. Not
            with ``instrument``.
        aggregate: over several test poses, ``"mean"`` (root mean square) or ``"worst"``;
            :func:`rho0_each` gives one ρ0 per test pose.
        prior: the errors' prior (:class:`pincal.Prior`): ρ0 from the posterior covariance
            σ²(M + σ²Σp⁻¹)⁻¹, finite for every plan (σ must then be the real noise in metres).
        task_payload: the payload at the test pose(s) (matters with compliance parameters); the
            plan's own payloads are its :attr:`~pincal.Plan.payload`.
        instrument: what is measured and how well (:class:`pincal.instruments.Instrument`: a
            kind, ``Pose``, ``Partial``, ``Distance``, ``Image`` or points, with an error model,
            ``PerCoordinate`` or ``Tracker``): M = Σ JᵢᵀΣᵢ⁻¹Jᵢ of its whitened rows. ρ0 is still
            the error of the markers' positions at the test pose(s). Default: points, ``sigma``
            per coordinate.
        orientation_length: L [m]: add L² times the expected squared orientation error of the
            tool (ρ0² = E‖δp‖² + L²·E‖δθ‖²), for a user who works with the tool's orientation.

    Returns:
        ρ0 [m], a Python float; (k,) for a batch of plans.

    Raises:
        SingularPlan: the plan cannot identify ``params`` (names the minimum m); never with a
            prior on every parameter.
        BadConfiguration: a configuration or test pose of the wrong size or outside the limits.
    """
    if aggregate == "each":
        raise BadArgument(
            "rho0 is one number: pincal.evaluation.rho0_each gives one per test pose",
            argument="aggregate",
            value=aggregate,
            valid=("mean", "worst"),
        )
    inst, sigma = measured(instrument, sigma)
    return _evaluate(params, plan, test_pose, sigma, aggregate, prior, task_payload, inst, orientation_length)


@keywords_after(3, tuple(name for name in ORDER_0_1 if name != "aggregate"))
@takes_instrument
def rho0_each(
    params: ParameterSet,
    plan: PlansLike,
    test_pose: TestPoseLike,
    *,
    sigma: float | None = None,
    prior: Prior | None = None,
    task_payload: PayloadLike = None,
    instrument: Instrument | None = None,
    orientation_length: float | None = None,
) -> np.ndarray:
    """(n,) ρ0 [m] at each of n test poses, or (k, n) for a batch of k plans (arguments as
    :func:`rho0`)."""
    inst, sigma = measured(instrument, sigma)
    return _evaluate(params, plan, test_pose, sigma, "each", prior, task_payload, inst, orientation_length)


def _evaluate(
    params,
    plan,
    test_pose,
    sigma,
    aggregate,
    prior,
    task_payload=None,
    instrument=None,
    orientation_length=None,
):
    plain = instrument is None and orientation_length is None
    qs, batched = plan_batch(params, plan)
    payload = plan_payloads(plan, qs.shape)
    if plain and not batched and aggregate == "mean" and qs.shape[1] <= SMALL:
        # One small plan (see SMALL): the mean over any number of test poses is one weighted trace
        # against at most P columns, built once with the criterion.
        return float(_criterion(params, test_pose, sigma, aggregate, prior, task_payload)(qs[0], payload))
    with blas_for(qs.shape[0] * qs.shape[1]):
        if plain:
            criterion = _criterion(params, test_pose, sigma, aggregate, prior, task_payload)
        else:  # an instrument's criterion is built for the call
            criterion = TestPoseCriterion(
                params, test_pose, aggregate=aggregate, prior=prior, task_payload=task_payload,
                orientation_length=orientation_length, **keywords(instrument, sigma),
            )  # fmt: skip
        values = criterion.plans(qs, payload)
    if batched:
        return values
    return np.asarray(values[0], dtype=float) if aggregate == "each" else float(values[0])


@keywords_after(3)
def rho0_split(
    params: ParameterSet,
    plan: ConfigurationsLike,
    test_pose: ConfigurationsLike,
    *,
    sigma: float = DEFAULT_SIGMA,
    task_payload: PayloadLike = None,
) -> dict[str, float]:
    """ρ0² at the test pose(s) split by the kind of parameter whose uncertainty causes it.

    With C = σ²M⁻¹ in blocks g (geometric) and e (gains and compliances) and J₀ = [J₀g J₀e]:
    ρ0² = tr(J₀g Cgg J₀gᵀ) + tr(J₀e Cee J₀eᵀ) + 2 tr(J₀g Cge J₀eᵀ) (mean over the test poses).

    Returns:
        ``{"geometric", "elastic", "cross", "total"}`` [m²] (they add up to the total, ρ0²; the
        cross term may be negative).
    """
    qs = params.robot.configurations(plan)
    q0 = params.robot.configurations(test_pose, what="test pose")
    J = params.jacobian(qs, frame="tip", payload=getattr(plan, "payload", None))
    J0 = params.jacobian(q0, frame="tip", payload=task_payload).reshape(-1, len(params)) / np.sqrt(len(q0))
    L = factor(information_matrix(J), J.shape[1], len(qs))
    C = sigma**2 * np.linalg.solve(L.T, np.linalg.solve(L, np.eye(len(params))))
    elastic = np.array([p.kind in ("gain", "compliance") for p in params], dtype=bool)
    g, e = J0[:, ~elastic], J0[:, elastic]
    geometric = float(np.einsum("ij,jk,ik", g, C[np.ix_(~elastic, ~elastic)], g))
    flexible = float(np.einsum("ij,jk,ik", e, C[np.ix_(elastic, elastic)], e))
    cross = float(2 * np.einsum("ij,jk,ik", g, C[np.ix_(~elastic, elastic)], e))
    return {
        "geometric": geometric,
        "elastic": flexible,
        "cross": cross,
        "total": geometric + flexible + cross,
    }


@keywords_after(3)
def position_covariance(
    params: ParameterSet,
    plan: ConfigurationsLike,
    test_pose: ConfigurationsLike,
    *,
    sigma: float | None = None,
    task_payload: PayloadLike = None,
    instrument: Instrument | None = None,
) -> np.ndarray:
    """(k, 3K, 3K) predicted covariance σ² J₀ M⁻¹ J₀ᵀ of the measured points at each test pose,
    after calibration, in the instrument frame [m²]. Its trace is ρ0² (as :func:`rho0_each`
    gives it): a :class:`~pincal.Plan` is measured under its payloads, the test poses are taken
    under ``task_payload`` (a mass [kg], a :class:`~pincal.Payload`, or one per test pose). With
    ``instrument`` (an :class:`~pincal.instruments.Instrument`), M is the information of its
    whitened rows and σ its reference σ, as :class:`TestPoseCriterion` takes them; else points with
    ``sigma`` per coordinate [m] (default :data:`~pincal.arguments.DEFAULT_SIGMA`; not both)."""
    instrument, sigma = measured(instrument, sigma)
    qs = params.robot.configurations(plan)
    q0 = params.robot.configurations(test_pose, what="test pose")
    payload = getattr(plan, "payload", None)
    if instrument is None:
        J = params.jacobian(qs, frame="tip", payload=payload)
    else:
        J = engine_for(params, instrument).jacobian(qs, frame="tip", payload=payload)
    L = factor(information_matrix(J), J.shape[1], len(qs))
    task = None if task_payload is None else payload_rows(task_payload, len(q0))
    J0 = params.jacobian(q0, frame="world", payload=task)  # (k, 3K, P)
    X = np.linalg.solve(L, J0.transpose(0, 2, 1))  # (k, P, 3K)
    return sigma**2 * np.einsum("kpi,kpj->kij", X, X)


def _criterion(params, test_pose, sigma: float, aggregate, prior, task_payload) -> TestPoseCriterion:
    """The :class:`TestPoseCriterion` of these arguments (σ checked already), built once and kept
    (:data:`pincal.kept.CRITERIA`, per thread) for the same parameter set, test poses, σ,
    aggregate and task payload without a prior: a script that evaluates many plans one call at a
    time pays for J₀ and its factor once."""
    if prior is not None:
        return TestPoseCriterion(params, test_pose, sigma, aggregate, prior, task_payload)
    if type(test_pose) is np.ndarray and test_pose.dtype == np.float64 and task_payload is None:
        # The values as given: equal bytes are equal test poses, checked when first seen (a
        # changed array is a new key, so nothing kept goes stale).
        key: tuple = (test_pose.shape, test_pose.tobytes(), sigma, aggregate)
    elif isinstance(test_pose, TestRegion) and task_payload is None:
        # What the region is resolved from (its kind, values and the joint limits): a region
        # changed in place is a new key, an equal region made anew the same one.
        key = ("region", test_pose.keyed_resolve(params.robot)[0], sigma, aggregate)
    else:
        poses, _ = resolve_test_poses(params.robot, test_pose)  # checked, as the criterion would
        rows = payload_rows(task_payload, len(poses))
        key = (
            poses.shape,
            poses.tobytes(),
            sigma,
            aggregate,
            None if rows is None else rows.tobytes(),
            type(test_pose).__name__,
        )

    def build() -> TestPoseCriterion:
        with blas_for(0):  # J₀ of a region's samples is a large product
            return TestPoseCriterion(params, test_pose, sigma, aggregate, prior, task_payload)

    return CRITERIA.get((params,), key, build)
