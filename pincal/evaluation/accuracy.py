r"""Accuracy away from the test pose: the predicted error after calibration anywhere (docs/method.md §8.3).

After calibrating with a plan, the predicted position error at any configuration q is
ρ(q) = σ·sqrt(tr(J(q) C J(q)ᵀ)), C = (M + Λ)⁻¹ (Λ = σ²Σp⁻¹ with a prior, else 0): the test-pose
criterion evaluated elsewhere. A plan designed for one test pose keeps its promise there and may
be much worse a few degrees away; :func:`accuracy` says how much, at the test pose(s), over
±10° and ±20° neighbourhoods and over the whole workspace, next to a reference plan (the
D-optimal one in pincal's reports), so the trade-off is visible.

Here :func:`accuracy`; the rest in one module each: :class:`PredictedError` and :func:`worst_found`
(:mod:`.predicted_error`), the report (:mod:`.accuracy_report`), the configurations it covers
(:mod:`.accuracy_samples`), the error against the distance from the test pose
(:func:`error_profile`, :mod:`.error_profile`).
"""

from __future__ import annotations

import numpy as np

from pincal.deprecation import keywords_after, moved_from
from pincal.evaluation._accuracy_residual import with_residual_model
from pincal.evaluation.accuracy_report import AccuracyReport, ErrorSummary, PlanAccuracy
from pincal.evaluation.accuracy_samples import (
    NEIGHBOURHOOD_SAMPLES,
    NEIGHBOURHOODS,
    WORKSPACE_SAMPLES,
    sample_sets,
)
from pincal.evaluation.plans import blas_for, engine_for, plan_batch, plan_payloads
from pincal.evaluation.predicted_error import PredictedError, worst_found
from pincal.evaluation.prior import Prior
from pincal.evaluation.residual_criterion import check_points
from pincal.evaluation.test_pose_worst import TestPoseWorst
from pincal.instruments.given import keywords, measured, takes_instrument
from pincal.instruments.instrument import Instrument
from pincal.kept import REPORTS
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.statics import PayloadRows, payload_rows, repeated
from pincal.typing import PayloadLike, PlansLike, TestPoseLike

ORDER_0_1 = (
    "sigma", "prior", "compare", "neighbourhoods", "samples", "workspace", "seed", "task_payload",
    "residual_model", "measure", "instrument",
)  # fmt: skip
"""accuracy()'s keywords in pincal 0.1's order (what arguments by position after the third meant)."""


@keywords_after(3, ORDER_0_1)
@takes_instrument
def accuracy(
    params: ParameterSet,
    plan: PlansLike,
    test_pose: TestPoseLike,
    *,
    sigma: float | None = None,
    instrument: Instrument | None = None,
    prior: Prior | None = None,
    compare: dict[str, object] | None = None,
    neighbourhoods: tuple[float, ...] = NEIGHBOURHOODS,
    samples: int = NEIGHBOURHOOD_SAMPLES,
    workspace: int = WORKSPACE_SAMPLES,
    seed: int = 0,
    task_payload: PayloadLike = None,
    residual_model: ResidualModel | None = None,
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
        sigma: the shorthand for points measured with this noise per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`); not with ``instrument``.
        instrument: what the plans measure and how well (:class:`pincal.instruments.Instrument`,
            see :func:`pincal.rho0`); the report's σ is then its reference σ.
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
    """
    inst, sigma = measured(instrument, sigma)
    robot = params.robot
    batch, batched = plan_batch(params, plan)
    task = None if task_payload is None else payload_rows(task_payload, 1)  # the door: one row below
    if residual_model is not None:
        sets, poses, region = sample_sets(robot, test_pose, neighbourhoods, samples, workspace, seed)
        check_points(inst)
        return with_residual_model(
            params, batch, batched, plan, compare, sets, region, sigma, prior, task, residual_model
        )
    with blas_for(0):
        report = _report(
            params, test_pose, neighbourhoods, samples, workspace, seed, sigma, prior, task, inst
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
        shared = (params, sigma, prior, jacobians, region, at_test_poses, task, inst)
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


def _report(
    params, test_pose, neighbourhoods, samples, workspace, seed, sigma, prior, task_payload: PayloadRows, inst
):
    """(sets, test poses, region, the sets' tip-frame Jacobians, the test poses' criterion) of an
    accuracy report: computed once and kept (:data:`pincal.kept.REPORTS`, per thread) for the same
    parameter set, test pose array (its values), draws and σ, without a prior, a task payload or an
    instrument, and with an integer seed: a script that reports on many plans one
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
            key = (*values, sigma, limits)
            hash(key)
        except TypeError:  # an argument that is not a plain value: computed for the call
            key = None

    def build() -> tuple:
        sets, poses, region = sample_sets(robot, test_pose, neighbourhoods, samples, workspace, seed)
        jacobians = _set_jacobians(engine_for(params), sets, task_payload)
        # ρ0² at each test pose, split (TestPoseCriterion's per-pose criterion, on the test poses'
        # Jacobians just computed)
        information = None if prior is None else prior.information(params, float(sigma))
        at_test_poses = TestPoseWorst(
            jacobians[0][1], float(sigma), engine_for(params, inst).rows, information
        )
        return sets, poses, region, jacobians, at_test_poses

    return build() if key is None else REPORTS.get((params,), key, build)


def _set_jacobians(
    engine, sets: list[tuple[str, np.ndarray]], task_payload: PayloadRows
) -> list[tuple[str, np.ndarray]]:
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
        J = engine.jacobian(qs, frame="tip", payload=repeated(task_payload, len(qs))).copy()
        J.flags.writeable = False
        out.append((where, J))
    return out


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
            PredictedError(
                params,
                q,
                prior=prior,
                task_payload=task_payload,
                payload=load,
                checked=checked,
                **keywords(inst, sigma),
            )  # fmt: skip
            for _, q, load in group
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


__getattr__ = moved_from(
    __name__,
    {
        "pincal.evaluation.predicted_error": ("PredictedError", "WorstFound", "SquaredError", "worst_found"),
        "pincal.evaluation.accuracy_report": ("ErrorSummary", "PlanAccuracy", "AccuracyReport"),
        "pincal.evaluation.error_profile": ("ErrorProfile", "error_profile"),
        "pincal.evaluation.accuracy_samples": (
            "NEIGHBOURHOODS",
            "WORKSPACE_SAMPLES",
            "NEIGHBOURHOOD_SAMPLES",
            "PRISMATIC_PER_RADIAN",
            "sample_sets",
        ),
    },
)
"""Names that moved out of this module in 0.2 (it held the whole report)."""
