r"""Accuracy away from the test pose: the predicted error after calibration anywhere (docs/method.md §8.3).

After calibrating with a plan, the predicted position error at any configuration q is
ρ(q) = σ·sqrt(tr(J(q) C J(q)ᵀ)), C = (M + Λ)⁻¹ (Λ = σ²Σp⁻¹ with a prior, else 0): the test-pose
criterion evaluated elsewhere. A plan designed for one test pose keeps its promise there and may
be much worse a few degrees away; :func:`accuracy` says how much, at the test pose(s), over
±10° and ±20° neighbourhoods and over the whole workspace, next to a reference plan (the
D-optimal one in pincal's reports), so the trade-off is visible.

* :class:`PredictedError` — ρ(q) of one plan at any batch of configurations.
* :func:`worst_found` — the worst ρ over a region: the largest sampled value, then a local
  maximisation (L-BFGS-B over the region's unit cube) from the worst few samples. It is the worst
  *found*, a lower bound of the true maximum over a continuous region, with the pose where it is.
* :func:`error_profile` — median and 95th percentile of ρ against the joint-space distance
  max_j |q_j − q0_j| from the test pose (for a plot).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pincal.arguments import angle, generator, positive_int, positive_sigma
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument
from pincal.evaluation.information import factor
from pincal.evaluation.plans import blas_for, engine_for, plan_batch, plan_payloads
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import Neighbourhood, ResolvedRegion, resolve_test_poses, width_text
from pincal.evaluation.residual_criterion import ResidualCriterion, check_points
from pincal.evaluation.test_pose_worst import TestPoseWorst
from pincal.instruments.error_model import ErrorModel
from pincal.instruments.instrument import Instrument, optional_instrument
from pincal.instruments.kind import Kind
from pincal.lapack import trtrs
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.statics import payload_rows
from pincal.typing import ConfigurationsLike, PayloadLike, PlansLike, TestPoseLike

NEIGHBOURHOODS = (math.radians(10), math.radians(20))
"""Half-widths of the neighbourhoods every report covers [rad]."""

WORKSPACE_SAMPLES = 2000
"""Configurations drawn uniformly within the joint limits for the workspace statistics."""

NEIGHBOURHOOD_SAMPLES = 512
"""Configurations drawn in each neighbourhood."""

PRISMATIC_PER_RADIAN = 0.01 / math.radians(10)
"""How far a prismatic joint moves in the neighbourhoods and error profiles where a revolute
joint turns by one radian [m/rad]: 1 cm for 10°, unless the test region is a neighbourhood with a
length of its own (``around(q0, angle, length=...)``), whose ratio is then used."""


class PredictedError:
    """ρ(q) [m], the predicted position error after calibrating with ``plan``, at any q.

    Args:
        params: the parameters identified.
        plan: (m, nq) configurations or a Plan.
        sigma: measurement noise per coordinate [m].
        prior: the errors' prior, or None.
        task_payload: the load under which ρ(q) is asked (one for every q: a mass [kg] or a
            :class:`~pincal.Payload`), or None; the plan's own payloads (:attr:`Plan.payload`)
            enter its information.
        payload: the plan's payload rows (m, 4), instead of its own.
        instrument: what the plan measures and how well (its whitened rows; ``sigma`` is then its
            reference σ), or None: points with ``sigma``. ρ is the markers' position error.
        checked: ``plan`` is an (m, nq) array already checked against the joint limits (not
            checked again).

    Raises:
        SingularPlan: the plan cannot identify ``params`` (never with a prior on every parameter).
    """

    def __init__(
        self,
        params: ParameterSet,
        plan: ConfigurationsLike,
        sigma: float,
        prior: Prior | None = None,
        task_payload: PayloadLike = None,
        payload: PayloadLike = None,
        instrument: Instrument | None = None,
        checked: bool = False,
    ) -> None:
        self.params = params
        self.sigma = positive_sigma(sigma) if instrument is None else instrument.reference
        self.prior = prior
        self.task_payload = task_payload
        self.engine = engine_for(params)
        measured = engine_for(params, instrument)
        qs = np.asarray(plan) if checked else params.robot.configurations(plan)
        if payload is None:
            payload = getattr(plan, "payload", None)
        J = measured.jacobian(qs, frame="tip", payload=payload).reshape(-1, len(params))
        self.information = J.T @ J  # M, of the measurements alone
        self.m = len(qs)
        posterior = (
            self.information if prior is None else self.information + prior.information(params, self.sigma)
        )
        self.L = factor(posterior, measured.rows, self.m)

    def squared(self, qs: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """(n,) ρ² [m²] at configurations ``qs`` (trusted: within the limits)."""
        qs = np.atleast_2d(qs)
        out = np.empty(len(qs))
        for a in range(0, len(qs), chunk):
            n = len(qs[a : a + chunk])
            load = None if self.task_payload is None else payload_rows(self.task_payload, n)
            J = self.engine.jacobian(qs[a : a + chunk], frame="tip", payload=load)
            out[a : a + len(J)] = self.squared_at(J)
        return out

    def squared_at(self, J: np.ndarray) -> np.ndarray:
        """(n,) ρ² [m²] at configurations of tip-frame Jacobians J (n, r, P), computed once for
        every plan compared on them."""
        # Jᵀ as a Fortran-ordered view: LAPACK's own order, copied once by the call (not twice)
        X = trtrs(self.L, J.reshape(-1, J.shape[-1]).T)
        return self.sigma**2 * np.einsum("ij,ij->j", X, X).reshape(len(J), -1).sum(axis=1)

    def at_sets(self, jacobians: list[np.ndarray]) -> list[np.ndarray]:
        """ρ [m] at the configurations of each set of tip-frame Jacobians (n, r, P): the numbers
        of ``sqrt(squared_at(J))`` set by set (one triangular solve per set), the rest of the
        arithmetic in one pass over every set."""
        r = jacobians[0].shape[1]
        t = np.empty(r * sum(len(J) for J in jacobians))
        start = 0
        for J in jacobians:
            X = trtrs(self.L, J.reshape(-1, J.shape[-1]).T)
            np.einsum("ij,ij->j", X, X, out=t[start : start + X.shape[1]])
            start += X.shape[1]
        rho = np.sqrt(self.sigma**2 * t.reshape(-1, r).sum(axis=1))
        ends = np.cumsum([len(J) for J in jacobians]).tolist()
        return [rho[end - len(J) : end] for J, end in zip(jacobians, ends, strict=True)]

    def __call__(self, qs: np.ndarray) -> np.ndarray:
        """(n,) ρ [m] at configurations ``qs``."""
        return np.sqrt(self.squared(qs))


@dataclass(frozen=True)
class WorstFound:
    """The worst predicted error found over a region.

    Attributes:
        rho: the largest ρ found [m] (≥ every sampled value).
        pose: (nq,) the configuration where it was found [rad or m].
        sampled: the largest ρ among the region's samples [m].
        searched: a local maximisation ran (continuous region), else the samples are the region.
    """

    rho: float
    pose: np.ndarray
    sampled: float
    searched: bool

    def as_dict(self) -> dict:
        return {
            "rho": self.rho,
            "pose": self.pose.tolist(),
            "sampled": self.sampled,
            "searched": self.searched,
        }


class SquaredError(Protocol):
    """What :func:`worst_found` maximises: ρ²(q) at a batch of configurations (a
    :class:`PredictedError`, or a calibration's expected error)."""

    def squared(self, qs: np.ndarray) -> np.ndarray:
        """(n,) ρ² [m²] at the (n, nq) configurations ``qs``."""
        ...


@keywords_after(2)
def worst_found(predicted: SquaredError, region: ResolvedRegion, *, starts: int = 3) -> WorstFound:
    """The worst ρ over a region: sampled, then maximised locally from the ``starts`` worst
    samples (continuous regions). See the module doc."""
    starts = positive_int(starts, "starts", 0)
    r2 = predicted.squared(region.poses)
    best = int(np.argmax(r2))
    sampled = float(np.sqrt(r2[best]))
    if not region.continuous:
        return WorstFound(sampled, np.array(region.poses[best]), sampled, False)
    from scipy.optimize import minimize

    to_q, unit_samples = region.to_configuration, region.unit_samples
    assert to_q is not None and unit_samples is not None  # a continuous region
    scale = 1.0 / max(float(r2[best]), 1e-300)
    h = 1e-6
    shifts = np.vstack(
        [np.zeros(region.dimension), h * np.eye(region.dimension), -h * np.eye(region.dimension)]
    )

    def negative(u: np.ndarray) -> tuple[float, np.ndarray]:
        # −ρ²(u) and its central-difference gradient, the 2d + 1 configurations in one batch.
        points = np.clip(u + shifts, 0.0, 1.0)
        qs = [to_q(p) for p in points]
        if any(q is None for q in qs):
            return 0.0, np.zeros_like(u)
        f = -predicted.squared(np.array(qs)) * scale
        d = region.dimension
        return float(f[0]), (f[1 : d + 1] - f[d + 1 :]) / np.maximum(
            points[1 : d + 1] - points[d + 1 :], h
        ).diagonal()

    best_value, best_pose = float(r2[best]), np.array(region.poses[best])
    bounds = [(0.0, 1.0)] * region.dimension
    for s in np.argsort(r2)[::-1][:starts]:
        u0 = unit_samples[s]
        result = minimize(negative, u0, jac=True, method="L-BFGS-B", bounds=bounds, options={"maxiter": 50})
        q = to_q(result.x)
        if q is None:
            continue
        value = float(predicted.squared(q[None])[0])
        if value > best_value:
            best_value, best_pose = value, q
    return WorstFound(math.sqrt(best_value), best_pose, sampled, True)


def _order_statistics(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(median, 95th percentile, maximum) of each row of R (k, n), n ≥ 1, from one sort: NumPy's
    numbers (``numpy.median``: the middle value, or the mean of the middle two;
    ``numpy.percentile``'s linear interpolation at (n − 1)·0.95, in its arithmetic), for a
    fraction of the time of its quantile machinery."""
    S = np.sort(R, axis=1)
    n = S.shape[1]
    half = n // 2
    median = S[:, half] if n % 2 else (S[:, half - 1] + S[:, half]) / 2
    at = (n - 1) * 0.95
    below = math.floor(at)
    t = at - below
    a, b = S[:, below], S[:, min(below + 1, n - 1)]
    step = b - a
    p95 = b - step * (1 - t) if t >= 0.5 else a + step * t
    return median, p95, S[:, -1]


@dataclass(frozen=True)
class ErrorSummary:
    """Predicted errors over a set of configurations [m].

    Attributes:
        where: what the set is (``"test pose"``, ``"±10°"``, ``"region ±10°"`` (within 10° of the
            region's samples: up to 10° beyond its edge), ``"workspace"``, ...).
        n: configurations.
        rms: root mean square (the square root of the mean criterion).
        median, p95, max: of ρ over the set.
    """

    where: str
    n: int
    rms: float
    median: float
    p95: float
    max: float

    @classmethod
    def of(cls, where: str, rho: np.ndarray) -> ErrorSummary:
        return cls(
            where,
            len(rho),
            float(np.sqrt(np.mean(rho**2))),
            float(np.median(rho)),
            float(np.percentile(rho, 95)),
            float(rho.max()),
        )

    @classmethod
    def of_rows(cls, rows: list[tuple[str, np.ndarray]]) -> list[ErrorSummary]:
        """:meth:`of` each ``(where, ρ)`` of ``rows``, the same numbers, the rows of one length
        summarised together from one sort (:func:`_order_statistics`)."""
        out: list[ErrorSummary | None] = [None] * len(rows)
        by_length: dict[int, list[int]] = {}
        for i, (_, rho) in enumerate(rows):
            by_length.setdefault(len(rho), []).append(i)
        for n, which in by_length.items():
            if n == 1:  # one value r (one test pose): rms sqrt(r²/1), and r its median, p95 and max
                for i in which:
                    r = float(rows[i][1][0])
                    out[i] = cls(rows[i][0], 1, math.sqrt(r * r / 1), r, r, r)
                continue
            R = np.stack([rows[i][1] for i in which])
            # NumPy's mean: the pairwise sum along each row, then one division
            columns = (np.sqrt(np.add.reduce(R * R, axis=1) / n), *_order_statistics(R))
            for i, values in zip(which, zip(*(c.tolist() for c in columns)), strict=True):
                out[i] = cls(rows[i][0], n, *values)
        return out  # type: ignore[return-value]  # every row summarised

    def as_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass(frozen=True)
class PlanAccuracy:
    """Where one plan leaves the robot accurate.

    Attributes:
        name: ``"plan"``, ``"D-optimal"``, ...
        rows: the summaries at the test pose(s), over each neighbourhood and over the workspace.
        worst: the worst found over the test region (None for plain test poses).
        from_measurements, from_prior: rms ρ0 at the test pose(s) due to the measurement noise and
            due to the prior errors the plan leaves uncorrected [m] (their squares add up to the
            test-pose row's rms²); ``from_prior`` is 0 without a prior.
        from_residual_model: for a calibration's report
            (:meth:`~pincal.IdentificationResult.accuracy`), the rms at the test pose(s) of its
            residual model's posterior variance [m] (0 without a residual model;
            ``from_measurements`` is then its parameters' standard errors' part); None for a plan.
            Without a residual model, what the fitted model does not explain (the residual level
            beyond the instrument's noise, docs/method.md §11.6).
        unexplained: what ``from_residual_model`` is, in words.
    """

    name: str
    rows: tuple[ErrorSummary, ...]
    worst: WorstFound | None
    from_measurements: float
    from_prior: float
    from_residual_model: float | None = None
    unexplained: str = "the residual model's variance (what it cannot explain there)"

    def row(self, where: str) -> ErrorSummary:
        return next(r for r in self.rows if r.where == where)

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "rows": [r.as_dict() for r in self.rows],
            "worst_found": None if self.worst is None else self.worst.as_dict(),
            "from_measurements": self.from_measurements,
            "from_prior": self.from_prior,
            "from_residual_model": self.from_residual_model,
        }


@dataclass(frozen=True)
class AccuracyReport:
    """Predicted accuracy after calibration, at and away from the test pose(s), for a plan and
    the plans it is compared with (see :func:`accuracy`).

    Attributes:
        plans: one :class:`PlanAccuracy` per plan (the plan first).
        sigma: measurement noise per coordinate [m].
        prior: the prior, or None.
        before: rms error at the test pose(s) before calibration, predicted by the prior
            (sqrt of the mean tr(J₀ΣpJ₀ᵀ)) [m]; None without a (finite) prior.
        region: description of the test region (or ``"test pose"``).
        revolute: which joints are revolute (poses in degrees convert those only), or None: all.
    """

    plans: tuple[PlanAccuracy, ...]
    sigma: float
    prior: Prior | None
    before: float | None
    region: str
    revolute: tuple[bool, ...] | None = None
    residual_model: bool = False

    def as_dict(self) -> dict:
        return {
            "plans": [p.as_dict() for p in self.plans],
            "sigma": self.sigma,
            "prior": None if self.prior is None else self.prior.as_dict(),
            "before_calibration": self.before,
            "region": self.region,
            "residual_model": self.residual_model,
        }

    def _pose_text(self, pose: np.ndarray, degrees: bool) -> str:
        """'10, -50, 70 deg', or each value with its unit when some joints are prismatic."""
        angle_unit = "deg" if degrees else "rad"
        values = np.degrees(pose) if degrees else pose
        if self.revolute is None or all(self.revolute):
            return ", ".join(f"{v:.4g}" for v in values) + f" {angle_unit}"
        return ", ".join(
            f"{v:.4g} {angle_unit}" if r else f"{q:.4g} m" for v, q, r in zip(values, pose, self.revolute)
        )

    def lines(self, unit: str = "mm", degrees: bool = False) -> list[str]:
        """The report as text lines (a table: one column pair per plan); worst poses in radians,
        or degrees."""
        scale = {"mm": 1e3, "m": 1.0, "um": 1e6}[unit]
        names = [p.name for p in self.plans]
        head = f"  {'predicted error after calibration [' + unit + ']':<44}" + "".join(
            f"{n:>22}" for n in names
        )
        out = [head, f"  {'':<44}" + "".join(f"{'rms':>11}{'p95':>11}" for _ in names)]
        for i, row in enumerate(self.plans[0].rows):
            label = row.where + (" (median, p95)" if row.where == "workspace" else "")
            cells = []
            for p in self.plans:
                r = p.rows[i]
                first = r.median if row.where == "workspace" else r.rms
                cells.append(f"{first * scale:11.4g}{r.p95 * scale:11.4g}")
            out.append(f"  {label:<44}" + "".join(cells))
        for p in self.plans:
            if p.worst is not None:
                out.append(
                    f"  {p.name}: worst {'found' if p.worst.searched else 'of the test poses'} "
                    f"{p.worst.rho * scale:.4g} {unit} at q = {self._pose_text(p.worst.pose, degrees)}"
                )
        if self.residual_model:
            out.append(
                "  with the residual model of an earlier calibration: the expected error when the parameters "
                "and the residual are estimated together from each plan (its variance included)"
            )
        for p in self.plans:
            if p.from_residual_model is None:
                continue
            if p.from_residual_model > 0:
                out.append(
                    f"  {p.name}: at the test pose(s), {p.from_measurements * scale:.4g} {unit} rms from "
                    f"the parameters' standard errors and {p.from_residual_model * scale:.4g} {unit} "
                    f"from {p.unexplained}"
                )
            else:
                out.append(
                    f"  {p.name}: from the parameters' standard errors alone (no residual model, and the "
                    "residuals are within the noise: the fitted model explains the data)"
                )
        if self.prior is not None:
            p = self.plans[0]
            out.append(
                f"  prior {self.prior}: at the test pose(s), {p.from_measurements * scale:.4g} {unit} rms "
                f"from the measurements and {p.from_prior * scale:.4g} {unit} from the prior"
                + ("" if self.before is None else f" (before calibration: {self.before * scale:.4g} {unit})")
            )
        return out


def _prismatic_per_radian(test_pose: TestPoseLike) -> float:
    """[m/rad] the test region's own ratio of length to angle, else :data:`PRISMATIC_PER_RADIAN`."""
    if isinstance(test_pose, Neighbourhood) and test_pose.length is not None:
        angle = test_pose.angle
        if angle is not None and not isinstance(angle, np.ndarray):
            return test_pose.length / angle
    return PRISMATIC_PER_RADIAN


def _neighbourhood(
    robot, centers: np.ndarray, delta: np.ndarray, n: int, rng: np.random.Generator
) -> np.ndarray:
    """n configurations uniform in the boxes centres ± δ ((nq,) [rad or m]; a centre drawn per
    sample), clipped to the joint limits."""
    c = centers[rng.integers(len(centers), size=n)]
    return np.clip(c + rng.uniform(-delta, delta, c.shape), robot.lower, robot.upper)


def sample_sets(
    robot,
    test_pose: TestPoseLike,
    neighbourhoods: tuple[float, ...] = NEIGHBOURHOODS,
    samples: int = NEIGHBOURHOOD_SAMPLES,
    workspace: int = WORKSPACE_SAMPLES,
    seed: int = 0,
) -> tuple[list[tuple[str, np.ndarray]], np.ndarray, ResolvedRegion | None]:
    """The configurations an accuracy report covers (see :func:`accuracy`): ([(where, (n, nq)), ...]
    for the test pose(s), each neighbourhood and the workspace, the test poses, the resolved region
    or None)."""
    neighbourhoods = tuple(angle(d, "neighbourhoods (half-width)") for d in neighbourhoods)
    samples = positive_int(samples, "samples")
    workspace = positive_int(workspace, "workspace")
    poses, region = resolve_test_poses(robot, test_pose)
    rng = generator(seed)
    first = "test region" if region is not None else "test pose" if len(poses) == 1 else "test poses"
    sets = [(first, poses)]
    per_radian = _prismatic_per_radian(test_pose)
    revolute = robot.revolute
    prismatic = not revolute.all()
    labels, deltas = [], []
    for delta in neighbourhoods:
        # around each test pose: beyond a region's edge
        width = width_text(delta, delta * per_radian if prismatic else None)
        labels.append(f"region {width}" if region is not None else width)
        deltas.append(np.where(revolute, delta, delta * per_radian))
    if len(poses) > 1 or not deltas:
        sets.extend(
            (label, _neighbourhood(robot, poses, d, samples, rng)) for label, d in zip(labels, deltas)
        )
        sets.append(("workspace", robot.random_configurations(workspace, rng)))
        return sets, poses, region
    # One centre: choosing it draws nothing, so the boxes' and the workspace's uniform draws are
    # one call, and the numbers NumPy's uniform(-δ, δ) (-δ + (δ - (-δ))·u, clipped to the limits)
    # and Robot.random_configurations (lo + (hi - lo)·u over Robot.sampled_range) make of them.
    n = len(deltas) * samples
    u = rng.random((n + workspace, robot.nq))
    lower, upper = robot.lower, robot.upper
    delta_q = np.array(deltas)[:, None, :]
    boxes = np.clip(
        poses[0] + (-delta_q + (delta_q + delta_q) * u[:n].reshape(len(deltas), samples, -1)), lower, upper
    )
    sets.extend(zip(labels, boxes, strict=True))
    low, high = robot.sampled_range()
    sets.append(("workspace", low + (high - low) * u[n:]))
    return sets, poses, region


@keywords_after(3)
def accuracy(
    params: ParameterSet,
    plan: PlansLike,
    test_pose: TestPoseLike,
    *,
    sigma: float,
    prior: Prior | None = None,
    compare: dict[str, object] | None = None,
    neighbourhoods: tuple[float, ...] = NEIGHBOURHOODS,
    samples: int = NEIGHBOURHOOD_SAMPLES,
    workspace: int = WORKSPACE_SAMPLES,
    seed: int = 0,
    task_payload: PayloadLike = None,
    residual_model: ResidualModel | None = None,
    measure: Kind | None = None,
    instrument: ErrorModel | None = None,
) -> AccuracyReport | tuple[AccuracyReport, ...]:
    """Predicted error after calibrating with ``plan`` (and each plan of ``compare``), at the
    test pose(s), over neighbourhoods of them, and over the workspace; for a batch of plans
    ((k, m, nq) or a sequence of Plans), a tuple of k reports, the configurations' Jacobians
    computed once for all of them.

    Every plan is evaluated on the same configurations: the test poses (a region's samples),
    ``samples`` configurations uniform in each box q0 ± δ (a test pose drawn per sample, clipped to
    the joint limits), and ``workspace`` configurations uniform within the joint limits (revolute
    joints within ±π).

    Args:
        params: the parameters identified.
        plan: the plan (m, nq) or a Plan, or a batch of plans.
        test_pose: test pose(s) or a region/path (see :func:`pincal.rho0`).
        sigma: measurement noise per coordinate [m].
        prior: the errors' prior, or None.
        compare: ``{name: plan}`` to report next to it, e.g. ``{"D-optimal": d_plan}``.
        neighbourhoods: half-widths δ of the revolute joints [rad]; the prismatic joints move
            δ·:data:`PRISMATIC_PER_RADIAN` (or the test region's own ratio of length to angle).
        samples: configurations per neighbourhood.
        workspace: configurations over the workspace.
        seed: seed of the draws.
        task_payload: the task's load at every configuration reported on (with compliance
            parameters: ρ is asked under it, as :func:`pincal.rho0`'s ``task_payload``); each
            plan's own payloads (:attr:`Plan.payload`) enter its information.
        residual_model: a residual model from an earlier calibration: every row is then the
            expected error when the parameters and the residual are estimated together from the
            plan (sqrt tr Σ₀ at each configuration, docs/method.md §11.5), the residual model's
            variance included, and the worst found over a region searched on it; no prior.
        measure, instrument: what the plans measure and the instrument's error model (see
            :func:`pincal.rho0`); ``sigma`` is then the error model's reference σ.
    """
    sigma = positive_sigma(sigma)
    inst = optional_instrument(measure, instrument, sigma)
    sigma = sigma if inst is None else inst.reference
    robot = params.robot
    batch, batched = plan_batch(params, plan)
    if residual_model is not None:
        sets, poses, region = sample_sets(robot, test_pose, neighbourhoods, samples, workspace, seed)
        check_points(inst)
        return _with_residual_model(
            params, batch, batched, plan, compare, sets, region, sigma, prior, task_payload, residual_model
        )
    with blas_for(0):
        report = _report(
            params, test_pose, neighbourhoods, samples, workspace, seed, sigma, prior, task_payload, inst
        )
        _, poses, region, jacobians, at_test_poses = report
        loads = plan_payloads(plan, batch.shape)
        plans = [
            (q, None if loads is None else loads[i * len(q) : (i + 1) * len(q)]) for i, q in enumerate(batch)
        ]
        before = None
        if prior is not None and np.all(np.isfinite(prior.std(params))):
            J0 = jacobians[0][1]  # ρ² is unchanged by each pose's rotation to the tip frame
            before = float(np.sqrt(np.einsum("kip,p,kip->", J0, prior.std(params) ** 2, J0) / len(poses)))
        shared = (params, sigma, prior, jacobians, region, at_test_poses, task_payload, inst)
        compared = _plans_accuracy([(name, q, None) for name, q in (compare or {}).items()], *shared)
        reports = tuple(
            AccuracyReport(
                (accuracy,) + tuple(compared),
                float(sigma),
                prior,
                before,
                "test pose" if region is None else region.description,
                tuple(bool(r) for r in robot.revolute),
            )
            for accuracy in _plans_accuracy([("plan", q, load) for q, load in plans], *shared, checked=True)
        )
    return reports if batched else reports[0]


_LOCAL = threading.local()
_KEPT = 4
"""Accuracy reports' configurations kept per thread (the most recently used)."""


def _report(params, test_pose, neighbourhoods, samples, workspace, seed, sigma, prior, task_payload, inst):
    """(sets, test poses, region, the sets' tip-frame Jacobians, the test poses' criterion) of an
    accuracy report: computed once and kept (per thread, the :data:`_KEPT` most recently used) for
    the same parameter set, test pose array (its values), draws and σ, without a prior, a task
    payload or an instrument, and with an integer seed: a script that reports on many plans one
    call at a time pays for the report's configurations once. The kept Jacobians are read-only."""
    robot = params.robot
    key: tuple | None = None
    if (
        type(test_pose) is np.ndarray
        and test_pose.dtype == np.float64
        and type(seed) is int
        and prior is None
        and task_payload is None
        and inst is None
    ):
        try:
            limits = robot.model.lowerPositionLimit.tobytes() + robot.model.upperPositionLimit.tobytes()
            values = (test_pose.shape, test_pose.tobytes(), tuple(neighbourhoods), samples, workspace, seed)
            key = (id(params), *values, sigma, limits)
            hash(key)
        except TypeError:  # an argument that is not a plain value: computed for the call
            key = None
    kept = getattr(_LOCAL, "reports", None)
    if kept is None:
        kept = _LOCAL.reports = {}
    found = None if key is None else kept.pop(key, None)
    if found is None or found[0] is not params:
        sets, poses, region = sample_sets(robot, test_pose, neighbourhoods, samples, workspace, seed)
        jacobians = _set_jacobians(engine_for(params), sets, task_payload)
        # ρ0² at each test pose, split (TestPoseCriterion's per-pose criterion, on the test poses'
        # Jacobians just computed)
        information = None if prior is None else prior.information(params, float(sigma))
        at_test_poses = TestPoseWorst(
            jacobians[0][1], float(sigma), engine_for(params, inst).rows, information
        )
        found = (params, (sets, poses, region, jacobians, at_test_poses))
        if key is not None and len(kept) >= _KEPT:
            kept.pop(next(iter(kept)))
    if key is not None:
        kept[key] = found  # last: the most recently used
    return found[1]


def _set_jacobians(engine, sets: list[tuple[str, np.ndarray]], task_payload) -> list[tuple[str, np.ndarray]]:
    """[(where, (n, r, P) read-only tip-frame Jacobians)] of each set of configurations. For a
    plain set (:attr:`JacobianEngine.plain`: rigid, one marker), one pass over every set's
    configurations, each set a view of it (each configuration's Jacobian is its own forward
    kinematics and regressor: the same numbers as set by set, without three calls and copies);
    else set by set (a compliant robot's static solution is solved per batch)."""
    if getattr(engine, "plain", False):
        J = engine.jacobian(np.concatenate([qs for _, qs in sets]), frame="tip")
        J.flags.writeable = False  # kept: read by every later report
        ends = np.cumsum([len(qs) for _, qs in sets]).tolist()
        return [(where, J[end - len(qs) : end]) for (where, qs), end in zip(sets, ends, strict=True)]
    out = []
    for where, qs in sets:
        J = engine.jacobian(qs, frame="tip", payload=_loads(task_payload, len(qs))).copy()
        J.flags.writeable = False
        out.append((where, J))
    return out


def _with_residual_model(
    params, batch, batched, plan, compare, sets, region, sigma, prior, task_payload, model
) -> AccuracyReport | tuple[AccuracyReport, ...]:
    """:func:`accuracy` with a residual model: sqrt tr Σ₀ at every configuration of ``sets``."""
    if prior is not None:
        raise BadArgument("the expected error with a residual model takes no prior")
    robot = params.robot
    if len(model.revolute) != robot.nq:
        raise BadArgument(
            f"the residual model is over {len(model.revolute)} joints; the robot has {robot.nq}"
        )
    engine = engine_for(params)
    loads = plan_payloads(plan, batch.shape)

    def rows(q: np.ndarray, load: PayloadLike, name: str) -> PlanAccuracy:
        error = _ResidualError(
            engine, model, sigma, q, engine.jacobian(q, frame="world", payload=load), task_payload
        )
        out = tuple(ErrorSummary.of(where, np.sqrt(error.squared(qs))) for where, qs in sets)
        worst = None if region is None else worst_found(error, region)
        return PlanAccuracy(name, out, worst, out[0].rms, 0.0)

    with blas_for(sum(len(qs) for _, qs in sets)):
        compared = tuple(
            rows(robot.configurations(q), getattr(q, "payload", None), name)
            for name, q in (compare or {}).items()
        )
        reports = tuple(
            AccuracyReport(
                (rows(q, None if loads is None else loads[i * len(q) : (i + 1) * len(q)], "plan"),)
                + compared,
                float(sigma),
                None,
                None,
                "test pose" if region is None else region.description,
                tuple(bool(r) for r in robot.revolute),
                residual_model=True,
            )
            for i, q in enumerate(batch)
        )
    return reports if batched else reports[0]


class _ResidualError:
    """ρ²(q) = tr Σ₀ at any configurations after calibrating with one plan, the parameters and a
    residual model's residual estimated together (a :class:`SquaredError`, so that
    :func:`worst_found` searches it as it searches the geometric ρ²).

    Args:
        engine: the parameters' Jacobian engine.
        model: the residual model.
        sigma: the instrument's noise per coordinate [m].
        q: (m, nq) the plan; J: (m, r, P) its world-aligned rows (under its payloads).
        task_payload: the load under which ρ(q) is asked, or None.
    """

    def __init__(
        self, engine, model: ResidualModel, sigma: float, q: np.ndarray, J: np.ndarray, task_payload
    ):
        self.engine, self.model, self.sigma = engine, model, sigma
        self.q, self.J, self.task_payload = q, J, task_payload

    def squared(self, qs: np.ndarray) -> np.ndarray:
        """(n,) ρ² [m²] at the (n, nq) configurations ``qs``."""
        J_at = self.engine.jacobian(qs, frame="world", payload=_loads(self.task_payload, len(qs)))
        return np.maximum(ResidualCriterion(self.model, J_at, qs, self.sigma).each(self.J, self.q), 0.0)


def _loads(task_payload: PayloadLike, n: int) -> np.ndarray | None:
    """(n, 4) rows of the task's load at n configurations, or None."""
    return None if task_payload is None else payload_rows(task_payload, n)


SUMMARISED_TOGETHER = 64
"""Plans of a batch whose errors are summarised together (:meth:`ErrorSummary.of_rows`): a
median and a percentile cost a NumPy call each whatever the number of rows."""


def _plans_accuracy(
    named, params, sigma, prior, jacobians, region, at_test_poses, task_payload=None, inst=None, checked=False
) -> list[PlanAccuracy]:
    """The accuracy of each ``(name, plan, load)`` of ``named`` on the sets of configurations
    (their Jacobians given); ``load`` the plan's payload rows (None: its own, if it is a Plan);
    ``checked``: the plans are (m, nq) arrays checked against the joint limits."""
    out: list[PlanAccuracy] = []
    for a in range(0, len(named), SUMMARISED_TOGETHER):
        group = named[a : a + SUMMARISED_TOGETHER]
        predicted = [
            PredictedError(params, q, sigma, prior, task_payload, load, inst, checked) for _, q, load in group
        ]
        wheres, sets = zip(*jacobians)
        summaries = ErrorSummary.of_rows(
            [row for p in predicted for row in zip(wheres, p.at_sets(list(sets)))]
        )
        for i, ((name, _, _), p) in enumerate(zip(group, predicted, strict=True)):
            worst = None if region is None else worst_found(p, region)
            noise, bias = at_test_poses.split(p.information, p.m)
            rows = tuple(summaries[i * len(jacobians) : (i + 1) * len(jacobians)])
            out.append(
                PlanAccuracy(name, rows, worst, float(np.sqrt(noise.mean())), float(np.sqrt(bias.mean())))
            )
    return out


@dataclass(frozen=True)
class ErrorProfile:
    """Predicted error against the distance from the test pose, for one plan.

    Attributes:
        name: the plan's name.
        distance: (n,) joint-space distances max_j |q_j − q0_j| [rad] (a prismatic joint's
            distance counted in radians through :data:`PRISMATIC_PER_RADIAN`).
        median, p95: (n,) of ρ over configurations at that distance [m].
    """

    name: str
    distance: np.ndarray
    median: np.ndarray
    p95: np.ndarray

    def as_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}


@keywords_after(3)
def error_profile(
    params: ParameterSet,
    plans: Mapping[str, ConfigurationsLike],
    test_pose: TestPoseLike,
    *,
    sigma: float,
    prior: Prior | None = None,
    max_distance: float = math.radians(30),
    steps: int = 13,
    samples: int = 128,
    seed: int = 0,
    task_payload: PayloadLike = None,
    measure: Kind | None = None,
    instrument: ErrorModel | None = None,
) -> tuple[ErrorProfile, ...]:
    """Median and 95th percentile of ρ on shells at distance d = max_j |q_j − q0_j| from the test
    pose(s), for d in [0, max_distance] (``samples`` configurations per shell, the same for every
    plan; a test pose drawn per sample; clipped to the joint limits). ``measure`` and
    ``instrument`` as for :func:`accuracy`."""
    sigma = positive_sigma(sigma)
    inst = optional_instrument(measure, instrument, sigma)
    max_distance = angle(max_distance, "max_distance")
    steps = positive_int(steps, "steps", 2)
    samples = positive_int(samples, "samples")
    robot = params.robot
    poses, _ = resolve_test_poses(robot, test_pose)
    rng = generator(seed)
    distance = np.linspace(0.0, max_distance, steps)
    shells = []
    for d in distance:
        u = rng.uniform(-1.0, 1.0, (samples, robot.nq))
        u /= np.abs(u).max(axis=1, keepdims=True)
        centres = poses[rng.integers(len(poses), size=samples)]
        step = np.where(robot.revolute, d, d * _prismatic_per_radian(test_pose))
        shells.append(np.clip(centres + step * u, robot.lower, robot.upper))
    out = []
    for name, plan in plans.items():
        predicted = PredictedError(params, plan, sigma, prior, task_payload, instrument=inst)
        rho = np.array([np.sqrt(predicted.squared(s)) for s in shells])
        out.append(ErrorProfile(name, distance, np.median(rho, axis=1), np.percentile(rho, 95, axis=1)))
    return tuple(out)
