"""Adaptive campaigns: from the measurements so far, the next poses to measure, or stop
(docs/method.md §12.4).

:func:`next_poses` takes the data measured so far (and the plan they were measured from) and

1. identifies the parameters from them (:func:`pincal.identify`, rows beyond ``reject`` robust σ
   dropped as outliers and named), and re-estimates σ from the residuals of the rows kept (unless
   given, or the data carry their own uncertainties); with too few rows kept for that, σ is
   *unknown*: never the instrument's default (docs/method.md §11.6);
2. names the planned poses that were not measured (unreachable, or not seen by the instrument);
3. predicts the error over the test region with the data so far: the information of the poses
   measured (outliers left out), F = Σ JᵢᵀJᵢ/σ², taken as a prior (:class:`MeasuredPrior`), with
   the Jacobians of the *fitted* robot (where the URDF puts the base does not matter), plus what
   the fitted model does not explain (the residual level beyond σ, 3K·u² per point:
   :attr:`~pincal.IdentificationResult.unexplained`); data of another kind than points (a pose,
   part of one, distances, pixels) are measured with their instrument (:mod:`.kinds`): F from its
   whitened rows, the next design with it;
4. stops when that prediction is known and below ``target``; otherwise designs the next ``k`` poses that most
   reduce the criterion over the test region *given what is already measured* (the design's prior is
   F plus the user's prior), kept away from the unreachable poses, and predicts the error after
   them.

A campaign run this way measures until the data say the target is reached, and spends each new
pose where the data so far are weakest: it reaches the target in fewer poses than a plan fixed in
advance when the noise, an outlier or an unreachable pose differ from what the plan assumed
(benchmarks/RESULTS.md, bench_adaptive).
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pincal.adaptive.kinds import of_data, own_rows, scaled
from pincal.adaptive.measured import MeasuredPrior
from pincal.arguments import DEFAULT_SIGMA, positive_int, positive_sigma
from pincal.calibration.identification import IdentificationResult, identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.sanity import OUTLIER_SCORE, Outlier
from pincal.deprecation import moved_keywords
from pincal.errors import BadArgument, DegenerateOptimumWarning, PincalError, SingularPlan
from pincal.evaluation.prior import Prior
from pincal.evaluation.test_pose import TestPoseCriterion
from pincal.instruments.given import keywords
from pincal.instruments.instrument import Instrument
from pincal.model.parameters import ParameterSet
from pincal.planning.constraints import AvoidPoses, with_safety
from pincal.planning.driver import design
from pincal.planning.options import Safety, Search, check_value, regroup
from pincal.planning.plan import Plan
from pincal.typing import ConfigurationsLike, TestPoseLike

MATCH_TOLERANCE = 1e-3
"""A planned pose counts as measured when a measured configuration is within this of it on every
joint [rad or m] (a robot reports where it stopped, not exactly what it was sent)."""

AVOID_DISTANCE = math.radians(10)
"""How far the next poses keep from the unreachable ones (joint space, Euclidean) [rad]."""


SIGMA_SOURCES = {
    "estimated": "re-estimated from the residuals of the rows kept",
    "given": "given",
    "data": "from the data's uncertainty columns",
    "unknown": "unknown: too few rows kept to estimate it (give --sigma, or measure more)",
}
"""Where the σ of a prediction comes from, in words."""


@dataclass(frozen=True, eq=False)
class NextPoses:
    """What :func:`next_poses` decided.

    Attributes:
        plan: the next configurations to measure (empty when ``stop``).
        stop: the predicted error over the test region is below the target with the data so far.
        predicted: the predicted error over the test region with the data so far [m] (root mean
            square over its samples; inf while the data cannot determine every parameter; NaN
            while σ is unknown): the parameters' part and what the model does not explain.
        predicted_after: the same after measuring ``plan`` too [m] (None when stopping or unknown).
        target: the target [m], or None.
        sigma: the σ used [m] (re-estimated or given; NaN when unknown).
        sigma_source: ``estimated``, ``given``, ``data`` (uncertainty columns) or ``unknown``.
        unexplained: the variance per coordinate the fitted model does not explain [m²], counted
            in both predictions (0 when the residuals are within σ; NaN when unknown).
        measured: configurations measured so far (rows of the data).
        used: those used (outliers left out).
        outliers: the rows dropped as outliers.
        unreachable: (u, nq) planned poses not measured.
        identification: the identification from the data so far, or None (too few data).
        message: one line: what to do next.
    """

    plan: Plan
    stop: bool
    predicted: float
    predicted_after: float | None
    target: float | None
    sigma: float
    sigma_source: str
    measured: int
    used: int
    outliers: tuple[Outlier, ...]
    unreachable: np.ndarray
    identification: IdentificationResult | None
    message: str
    unexplained: float = 0.0

    def as_dict(self) -> dict:
        def finite(v: float | None) -> float | None:
            return None if v is None or not math.isfinite(v) else float(v)

        return {
            "stop": self.stop,
            "next": self.plan.q.tolist(),
            "joint_names": list(self.plan.joint_names),
            "predicted": finite(self.predicted),
            "predicted_after": finite(self.predicted_after),
            "target": self.target,
            "sigma": finite(self.sigma),
            "sigma_source": self.sigma_source,
            "unexplained": finite(math.sqrt(self.unexplained)) if self.unexplained >= 0 else None,
            "measured": self.measured,
            "used": self.used,
            "outliers": [o.as_dict() for o in self.outliers],
            "unreachable": self.unreachable.tolist(),
            "identification": None
            if self.identification is None
            else {"status": self.identification.status, "message": self.identification.message},
            "message": self.message,
        }

    def lines(self, degrees: bool = False) -> list[str]:
        """The report (poses in degrees if asked)."""

        def mm(v: float | None) -> str:
            return "not yet determined" if v is None or not math.isfinite(v) else f"{v * 1e3:.4g} mm"

        out = [f"data so far: {self.measured} poses measured, {self.used} used"]
        for o in self.outliers:
            out.append(f"  outlier dropped: {o}")
        if len(self.unreachable):
            out.append(f"  planned but not measured (unreachable): {len(self.unreachable)} pose(s), avoided")
        if self.identification is not None:
            out.append(f"  identification: {self.identification.status}")
        source = SIGMA_SOURCES[self.sigma_source]
        out.append(f"  σ = {mm(self.sigma)} ({source})" if math.isfinite(self.sigma) else f"  σ {source}")
        if math.isfinite(self.unexplained) and self.unexplained > 0:
            whose = (
                " (beyond the default instrument's σ, a laser tracker's: give --sigma for yours)"
                if self.sigma_source == "estimated"
                else ""
            )
            out.append(
                f"  the fitted model leaves {mm(math.sqrt(self.unexplained))} per coordinate unexplained"
                f"{whose}, counted in the predictions"
            )
        target = "" if self.target is None else f" (target {mm(self.target)})"
        out.append(f"predicted error over the test region with the data so far: {mm(self.predicted)}{target}")
        if self.stop:
            out.append("stop: the predicted error is below the target with the data so far")
            return out
        if not math.isfinite(self.predicted) and self.sigma_source == "unknown":
            out.append("  no stop while the prediction cannot be made")
        out.append(f"next {len(self.plan)} poses, predicted error after them: {mm(self.predicted_after)}")
        revolute = np.asarray(self.plan.revolute, dtype=bool)
        values = self.plan.q if not degrees else np.where(revolute, np.degrees(self.plan.q), self.plan.q)
        for row in values:
            out.append("  " + " ".join(f"{v:10.4f}" for v in row))
        return out


def unmeasured(plan: np.ndarray, measured: np.ndarray, tolerance: float = MATCH_TOLERANCE) -> np.ndarray:
    """The rows of ``plan`` with no configuration of ``measured`` within ``tolerance`` on every joint."""
    if not len(plan):
        return np.zeros(0, dtype=bool)
    if not len(measured):
        return np.ones(len(plan), dtype=bool)
    gap = np.abs(plan[:, None, :] - measured[None, :, :]).max(axis=2)
    return gap.min(axis=1) > tolerance


@dataclass(frozen=True, eq=False)
class Assessment:
    """What the data so far say (steps 1 to 3 of the module doc).

    Attributes:
        identification: the identification, or None (too few data).
        used: (m,) the rows used (outliers left out).
        outliers: the rows dropped.
        sigma: the σ of the prediction [m] (NaN: unknown); sigma_source: where it came from.
        measured: the information of the rows used, as a prior, on the fitted robot (σ unknown:
            at the default σ, to rank the next poses by, never to predict with).
        unreachable: (u, nq) planned poses not measured.
        predicted: the predicted error over the test region with the data so far [m] (NaN: unknown).
        unexplained: the variance per coordinate the fitted model does not explain [m²].
        params: the parameters on the fitted robot (the nominal one without a fit).
        instrument: what the data measure and how well, at the σ of the prediction (its error
            model scaled to the σ re-estimated); None: points with one σ per coordinate.
    """

    identification: IdentificationResult | None
    used: np.ndarray
    outliers: tuple[Outlier, ...]
    sigma: float
    sigma_source: str
    measured: MeasuredPrior
    unreachable: np.ndarray
    predicted: float
    unexplained: float
    params: ParameterSet
    instrument: Instrument | None = None

    def with_unexplained(self, rho: float) -> float:
        """The predicted error [m] of a ρ [m] from the parameters' part: with what the model does not
        explain, sqrt(ρ² + 3K·u²) (3K: the markers' coordinates at the test pose, whatever the data
        measure); NaN while σ is unknown."""
        if self.sigma_source == "unknown" or not math.isfinite(self.unexplained):
            return math.nan
        return math.sqrt(rho**2 + 3 * self.params.robot.n_markers * self.unexplained)


def assess(
    params: ParameterSet,
    data: MeasurementData,
    test_pose: TestPoseLike,
    *,
    plan: ConfigurationsLike | None = None,
    sigma: float | None = None,
    prior: Prior | None = None,
    reject: float = OUTLIER_SCORE,
    instrument: Instrument | None = None,
) -> Assessment:
    """Identify from ``data``, re-estimate σ, drop outliers, name the unreachable planned poses and
    predict the error over the test region with the data so far (arguments as :func:`next_poses`)."""
    robot = params.robot
    if prior is not None and not isinstance(prior, Prior):
        raise BadArgument(f"prior must be a pincal.Prior, got {prior!r}", argument="prior")
    data = data.for_robot(robot)
    inst, given = of_data(instrument, sigma, data, robot)
    fit, used, outliers = _identified(params, data, given, prior, reject, inst)
    fitted = params.on(fit.robot) if fit is not None and fit.success else params
    unexplained = 0.0 if fit is None else fit.unexplained
    if data.sigma is not None and inst is None:  # points with their own σ
        noise, source = data.sigma[used], "data"
        value = float(np.median(data.sigma[used]))
    elif data.sigma is not None or data.covariance is not None:  # own_rows below says it
        noise, value, source = math.nan, math.nan, "data"
    elif given is not None:
        noise, source, value = given, "given", given
    elif fit is not None and fit.sigma_estimated and math.isfinite(fit.sigma) and fit.sigma > 0:
        noise = value = float(fit.sigma)
        source = "estimated"
    else:  # no degrees of freedom left to estimate σ: the prediction is unknown (method §11.6)
        noise, value, source, unexplained = DEFAULT_SIGMA, math.nan, "unknown", math.nan
    if inst is None:  # points with one σ per coordinate, as always
        measured = MeasuredPrior.from_measurements(fitted, data.q[used], noise, prior)
    elif source == "data":
        rows, value, inst = own_rows(fitted, data, used, inst if given is not None else None)
        measured = MeasuredPrior.from_rows(fitted, rows, prior)
    else:
        inst = scaled(inst, value) if source == "estimated" else inst
        measured = MeasuredPrior.from_instrument(fitted, data.q[used], inst, prior)
    planned = np.empty((0, robot.nq)) if plan is None else robot.configurations(plan, what="planned pose")
    missing = planned[unmeasured(planned, data.q)]
    a = Assessment(fit, used, outliers, value, source, measured, missing, math.nan, unexplained, fitted, inst)
    rho = _predicted(fitted, test_pose, DEFAULT_SIGMA if source == "unknown" else value, measured, inst)
    return replace(a, predicted=a.with_unexplained(rho))


NEXT_SEARCH = Search(starts=8, seed=0, workers=1)
"""How :func:`next_poses` searches by default: 8 starts, seed 0, in this process."""

FLAT_NEXT = (
    "constraints", "joint_margin", "mount", "clearance", "starts", "seed", "workers", "pool", "polish",
    "progress",
)  # fmt: skip
"""next_poses()'s flat keywords of pincal 0.1, now in ``search=`` and ``safety=``."""


@moved_keywords(
    FLAT_NEXT, functools.partial(regroup, function="next_poses", defaults={"search": NEXT_SEARCH})
)
def next_poses(
    params: ParameterSet,
    data: MeasurementData,
    test_pose: TestPoseLike,
    k: int = 3,
    *,
    plan: ConfigurationsLike | None = None,
    target: float | None = None,
    sigma: float | None = None,
    prior: Prior | None = None,
    reject: float = OUTLIER_SCORE,
    search: Search | None = None,
    safety: Safety | None = None,
    instrument: Instrument | None = None,
) -> NextPoses:
    """The next ``k`` poses to measure given the data so far, or stop (see the module doc).

    Args:
        params: the parameters identified (an identifiable set of the nominal robot).
        data: the measurements so far.
        test_pose: where the robot works: a test pose, several, a region or a path (as
            :func:`pincal.design` takes it); the predicted error is the root mean square over it.
        k: how many poses to choose next.
        plan: the poses planned so far (those not in ``data`` are unreachable and avoided), or None.
        target: stop when the predicted error over the test region is below this [m].
        sigma: the instrument's noise per coordinate [m] (per length for data of another kind than
            points, pincal's default σ of angles and pixels, as :func:`pincal.identify` takes it);
            default: re-estimated from the residuals of the rows kept (or the data's uncertainty
            columns); while too few rows are kept to estimate it, the prediction is unknown and
            the campaign does not stop. Not with ``instrument``.
        prior: the errors' prior before any measurement, or None.
        reject: rows beyond this many robust σ are outliers, dropped.
        search: how the next design is searched (:class:`pincal.Search`, as :func:`pincal.design`
            reads it); default :data:`NEXT_SEARCH`, 8 starts, seed 0, 1 worker.
        safety: the workcell and the safe defaults (the clearance from the floor and the
            obstacles, the robot clear of itself: :class:`pincal.Safety`, as for
            :func:`pincal.design`). The flat keywords of pincal 0.1 (``starts=``,
            ``constraints=``, ...) keep working until pincal 0.3, with a DeprecationWarning.
        instrument: what the data measure and how well (:class:`pincal.instruments.Instrument`
            of the data's kind: its error model weighs the data, makes σ known, measures the poses
            so far and the next ones); default: the data's kind (points, poses, partial poses,
            distances, images), one σ per unit (``sigma``, or re-estimated). Every kind works:
            the information of the poses so far and the next design are the instrument's whitened
            rows (:mod:`pincal.adaptive.kinds`).

    Raises:
        SingularPlan: ``k`` poses cannot complete what the data leave undetermined (the message
            names the minimum).
        BadArgument, BadMeasurementData, BadConfiguration: bad input.
    """
    robot = params.robot
    search = NEXT_SEARCH if search is None else search
    safety = Safety() if safety is None else safety
    check_value(search, Search, "search")
    check_value(safety, Safety, "safety")
    k = positive_int(k, "k (poses to choose next)")
    if target is not None:
        target = positive_sigma(target, "target")
    reject = positive_sigma(reject, "reject (robust sigma)")
    a = assess(
        params, data, test_pose, plan=plan, sigma=sigma, prior=prior, reject=reject, instrument=instrument
    )
    common: dict[str, Any] = dict(  # NextPoses' fields shared by both outcomes
        target=target, sigma=a.sigma, sigma_source=a.sigma_source, measured=data.m, used=int(a.used.sum()),
        outliers=a.outliers, unreachable=a.unreachable, identification=a.identification,
        unexplained=a.unexplained,
    )  # fmt: skip
    if target is not None and math.isfinite(a.predicted) and a.predicted <= target:
        empty = Plan(np.empty((0, robot.nq)), robot.joint_names, tuple(robot.revolute))
        message = (
            f"stop: the predicted error {a.predicted * 1e3:.4g} mm is below the target {target * 1e3:.4g} mm"
        )
        return NextPoses(empty, True, a.predicted, None, message=message, **common)
    noise = DEFAULT_SIGMA if a.sigma_source == "unknown" else a.sigma  # unknown: to rank poses by only
    _check_enough(a.params, a.measured, noise, k, data.measure.size(robot))
    avoid = (AvoidPoses(a.unreachable, AVOID_DISTANCE),) if len(a.unreachable) else ()
    cell = tuple(safety.constraints) + avoid
    cell = with_safety(robot, cell, safety.joint_margin, safety.mount, clearance=safety.clearance)
    with warnings.catch_warnings():
        # The next k poses alone need not determine every parameter: the data so far do the rest.
        warnings.simplefilter("ignore", DegenerateOptimumWarning)
        result = design(
            a.params,
            k,
            test_pose,
            prior=a.measured,
            safety=Safety(constraints=cell, min_conditioning=safety.min_conditioning),
            search=search,
            **keywords(a.instrument, noise),  # the data's instrument, or points with σ
        )
    rho0 = result.rho0
    assert rho0 is not None  # a design for a test pose reports its rho0
    after = a.with_unexplained(float(rho0))
    if math.isfinite(after):
        message = f"measure the next {k} poses (predicted error after them: {after * 1e3:.4g} mm)"
    else:
        message = (
            f"measure the next {k} poses (no prediction yet: too few rows kept to estimate sigma; "
            "give --sigma or measure more)"
        )
    return NextPoses(
        result.plan, False, a.predicted, after if math.isfinite(after) else None, message=message, **common
    )


def _identified(
    params: ParameterSet,
    data: MeasurementData,
    sigma: float | None,
    prior: Prior | None,
    reject: float,
    instrument: Instrument | None = None,
) -> tuple[IdentificationResult | None, np.ndarray, tuple[Outlier, ...]]:
    """(the identification from the data, or None when it cannot run; the rows used; the outliers).
    With an ``instrument`` (not points with one σ), its error model weighs the data when σ is given."""
    used = np.ones(data.m, dtype=bool)
    if data.m * data.row_size <= len(params):  # no residual left to judge σ or outliers by
        return None, used, ()
    weights: dict[str, Any] = {"sigma": sigma}
    if instrument is not None:
        weights = {"instrument": instrument if sigma is not None else None}
    try:
        fit = identify(params, data, prior=prior, reject=reject, sanity=False, **weights)
    except PincalError:
        return None, used, ()
    if fit.status == "rank_deficient":
        return None, used, ()
    rejected = tuple(fit.rejected)
    for o in rejected:
        used[o.row] = False
    return fit, used, rejected


def _predicted(
    params: ParameterSet,
    test_pose: TestPoseLike,
    sigma: float,
    measured: MeasuredPrior,
    instrument: Instrument | None = None,
) -> float:
    """The predicted error over the test region with the measured information only [m] (inf when it
    does not determine every parameter); an ``instrument``'s reference σ overrules ``sigma``."""
    criterion = TestPoseCriterion(
        params, test_pose, aggregate="mean", prior=measured, **keywords(instrument, sigma)
    )
    P = len(params)
    try:
        return float(criterion.from_information(np.zeros((P, P)), 0))
    except SingularPlan:
        return math.inf


def _check_enough(params: ParameterSet, measured: MeasuredPrior, sigma: float, k: int, rows: int) -> None:
    """Refuse a k that cannot complete what the data leave undetermined (``rows`` values per pose)."""
    info = measured.information(params, sigma)
    d = np.sqrt(np.maximum(np.diag(info), 1e-300))
    w = np.linalg.eigvalsh(info / np.outer(d, d)) if len(info) else np.zeros(0)
    rank = int(np.sum(w > 1e-10 * max(w.max(initial=0.0), 1e-300)))
    missing = len(params) - rank
    if missing > k * rows:
        need = -(-missing // rows)
        raise SingularPlan(
            len(params),
            rows,
            k,
            rank,
            why=f"the data so far determine {rank} of {len(params)} parameter combinations: the next poses "
            f"must bring {missing} more, at least {need} poses (k = {k} is too few)",
        )
