"""Designs that choose a payload for each configuration (docs/method.md §11.3).

Joint compliance shows only through the gravity torques, and under the arm's own weight it looks
much like the link lengths; a change of payload separates them. So a plan for a robot whose
compliances are identified chooses, with each configuration, one of the payloads the user can
mount: the exchange search runs over a pool of (configuration, payload) candidates, every feasible
configuration paired with every payload, their Jacobians taken under that payload, and picks the m
candidates that minimise the criterion, the test pose(s) taken under the task's payload. The plan
carries the chosen payloads (:attr:`~pincal.Plan.payload`, the payload columns of its CSV). The
continuous search does not choose among discrete payloads: this design is the exchange's alone
(over a generated pool; the starts and the conditioning floor as :func:`~pincal.design` sets them).

The same exchange designs with a residual model from an earlier campaign (``residual_model=``):
the criterion is then the expected error at the test pose(s) when the parameters and the residual
are estimated together (:class:`~pincal.evaluation.residual_criterion.ResidualCriterion`, tr Σ₀),
which values measuring where the residual is correlated with the test pose's: a top-up plan.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, positive_int, positive_sigma, seed_entropy
from pincal.errors import BadArgument, FloorUnreachable, PincalError, SingularPlan
from pincal.evaluation.classic import criteria_from_jacobian
from pincal.evaluation.data_check import MIN_DATA_CONDITIONING
from pincal.evaluation.information import conditioning
from pincal.evaluation.prior import Prior
from pincal.evaluation.registry import TEST_POSE_CRITERIA, criterion_name, make_criterion
from pincal.evaluation.residual_criterion import ResidualCriterion
from pincal.evaluation.test_pose import rho0_each
from pincal.instruments.instrument import Instrument, rows_engine, tool_rows
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.statics import payload_rows
from pincal.planning.constraints import AnyConstraint
from pincal.planning.exchange import fedorov
from pincal.planning.feasibility import Feasibility
from pincal.planning.objectives import checked_test_poses
from pincal.planning.plan import Plan
from pincal.planning.progress import Progress
from pincal.planning.results import DesignResult, StartRecord, dropped_line
from pincal.planning.search import Outcome, degenerate, every_start_failed
from pincal.planning.starts import pick
from pincal.typing import PayloadLike, SeedLike, TestPoseLike

MIN_CONDITIONING = 1e-2
"""The conditioning floor tried first (as :func:`~pincal.design`'s); it adapts down to half what a
D-optimal plan reaches, never below what identification asks of the data."""


def payload_rows_of(payloads: Sequence[PayloadLike]) -> np.ndarray:
    """(n, 4) rows [kg, x, y, z] of the payloads the user can mount (masses [kg] or Payloads)."""
    if isinstance(payloads, (str, bytes)) or not isinstance(payloads, Sequence) or not len(payloads):
        raise BadArgument(
            f"payloads must be a list of the masses [kg] (or Payloads) you can mount, got {payloads!r}",
            argument="payloads",
        )
    return np.vstack([payload_rows(p, 1) for p in payloads])


def design_with_payloads(
    params: ParameterSet,
    m: int,
    test_pose: TestPoseLike | None = None,
    payloads: Sequence[PayloadLike] = (0.0,),
    *,
    task_payload: PayloadLike = None,
    criterion: str = "test-pose",
    constraints: Iterable[AnyConstraint] = (),
    pool: int | np.ndarray = 1000,
    starts: int = 8,
    seed: SeedLike = 0,
    sigma: float = DEFAULT_SIGMA,
    prior: Prior | None = None,
    min_conditioning: float | None = None,
    residual_model: ResidualModel | None = None,
    instrument: Instrument | None = None,
    orientation_length: float | None = None,
    progress: bool = False,
) -> DesignResult:
    """The m (configuration, payload) pairs that minimise a criterion (see module doc).

    Args:
        params: the parameters to identify (an identifiable set, e.g. with ``gains`` and
            ``compliance``: ``identifiable(payloads=...)``).
        m: number of configurations.
        test_pose: where the robot works (as :func:`~pincal.design`).
        payloads: the payloads the user can mount (masses [kg] or :class:`~pincal.Payload`; 0 for
            none).
        task_payload: the payload at the test pose(s) (the task's load).
        criterion, constraints, starts, seed, sigma, prior, min_conditioning: as :func:`~pincal.design`.
        pool: number of random feasible configurations, each paired with every payload; or your
            own (n, nq) configurations (e.g. taught poses), the infeasible ones left out.
        residual_model: a residual model from an earlier campaign: the criterion is then the
            expected error with it (tr Σ₀, test-pose criterion only, no prior; points only).
        instrument: what the plan measures and how well (:class:`~pincal.instruments.Instrument`:
            poses, partial poses, distances, images; ``sigma`` is then its reference σ), or None:
            points with ``sigma``. Each candidate's rows are the instrument's whitened rows under
            its payload, as :func:`~pincal.design` takes them without payloads.
        orientation_length: L [m]: ρ0² also counts L² times the tool's expected squared
            orientation error at the test pose(s) (docs/method.md §13.3).
        progress: report the starts searched on stderr, with the best value so far (a bar on a
            terminal, else a line every few seconds).

    Returns:
        the design; its plan carries the payload of each configuration, and ρ0 is under the task's
        payload.
    """
    t0 = time.perf_counter()
    criterion = criterion_name(criterion)
    rows = payload_rows_of(payloads)
    sigma = positive_sigma(sigma) if instrument is None else instrument.reference
    if instrument is not None:
        instrument.kind.check(params.robot)
    information = None if prior is None else prior.information(params, sigma)
    m = positive_int(m, "m (number of configurations)")
    per_row = 3 * params.robot.n_markers if instrument is None else instrument.kind.size(params.robot)
    if information is None and m * per_row < len(params):
        raise SingularPlan(len(params), per_row, m)
    test_poses = checked_test_poses(params, test_pose, criterion)
    starts = positive_int(starts, "starts")
    entropy = seed_entropy(seed)
    sequence = np.random.SeedSequence(entropy)
    feasibility = Feasibility(params.robot, tuple(constraints))
    rng = np.random.default_rng(sequence.spawn(1)[0])
    if isinstance(pool, (int, np.integer)):
        size = positive_int(pool, "pool size", m)
        candidates = feasibility.sample(size, rng, minimum=m)
    else:
        candidates, _ = feasibility.feasible_pool(pool, m)
        size = len(candidates)
    if residual_model is not None and test_poses is not None and isinstance(pool, (int, np.integer)):
        # a generated pool also draws where the residual is correlated with the test pose's
        candidates = np.vstack([candidates, _near(params.robot, feasibility, test_poses, size // 4, rng)])
    q_pool = np.repeat(candidates, len(rows), axis=0)
    w_pool = np.tile(rows, (len(candidates), 1))
    engine = rows_engine(params, instrument)
    # The residual's covariance is isotropic in the world.
    frame = "tip" if residual_model is None else "world"
    J_pool = engine.jacobian(q_pool, frame=frame, payload=w_pool)
    J0 = None
    if test_poses is not None:
        task = payload_rows(task_payload, len(test_poses))
        if residual_model is None:
            J0 = tool_rows(engine, test_poses, orientation_length, payload=task)
        else:
            J0 = JacobianEngine(params).jacobian(test_poses, frame=frame, payload=task)
    if residual_model is None:
        objective = make_criterion(criterion, len(params), per_row, J0, sigma, information)
    else:
        if criterion != "test-pose" or prior is not None or J0 is None:
            raise BadArgument(
                "a residual model designs for the test-pose criterion, with a test pose and no prior"
            )
        assert test_poses is not None  # J0 is theirs
        objective = ResidualCriterion(residual_model, J0, test_poses, sigma, pool=q_pool)
    floor = _floor(min_conditioning, information)
    report = Progress(progress, criterion if residual_model is None else ResidualCriterion.name, objective)
    report.stage("searched", starts)
    outcomes, history, failed = [], [], []
    for i, child in enumerate(sequence.spawn(starts)):
        t = time.perf_counter()
        while True:
            try:
                start = pick(J_pool, q_pool, m, 0.0, np.random.default_rng(child), floor, information)
                break
            except FloorUnreachable as error:
                if min_conditioning is not None or floor <= MIN_DATA_CONDITIONING:
                    raise
                floor = max(error.reached / 2, MIN_DATA_CONDITIONING)
            except PincalError as error:  # a start that fails alone is dropped, as design() drops it
                if not degenerate(error):
                    raise
                start = None
                failed.append(error)
                history.append(Outcome.degenerate(i, error).record)
                break
        if start is None:
            report(None)
            continue
        out = fedorov(objective, J_pool, q_pool, start, floor=floor)
        outcomes.append((i, out))
        value = float(objective.report(out.F))
        history.append(StartRecord(i, value, None, out.sweeps, time.perf_counter() - t, True, True))
        report(out)
    report.close()
    if not outcomes:
        raise every_start_failed(failed, starts)
    winner, best = min(outcomes, key=lambda o: (o[1].F, o[0]))  # the first of equals, as argmin
    index = best.index
    plan = Plan.for_robot(params.robot, q_pool[index], w_pool[index])
    J = engine.jacobian(plan.q, frame="tip", payload=plan.payload)
    flat = J.reshape(-1, len(params))
    each = None
    if test_poses is not None:
        each = rho0_each(params, plan, test_poses, sigma=sigma, prior=prior, task_payload=task_payload,
                         measure=None if instrument is None else instrument.kind,
                         instrument=None if instrument is None else instrument.error,
                         orientation_length=orientation_length)  # fmt: skip
    rho0 = (
        None
        if each is None
        else float(each.max() if criterion == "test-pose-worst" else np.sqrt(np.mean(each**2)))
    )
    value = rho0 if criterion in TEST_POSE_CRITERIA and rho0 is not None else float(objective.report(best.F))
    if criterion not in TEST_POSE_CRITERIA and prior is None:
        value = float(criteria_from_jacobian(J, len(plan)).by_criterion(criterion))
    if residual_model is not None:  # the criterion minimised: the expected error with the residual model
        value = float(objective.report(best.F))
        criterion = ResidualCriterion.name
    elapsed = time.perf_counter() - t0
    masses = ", ".join(f"{w:g}" for w in rows[:, 0])
    loads = plan.payload if plan.payload is not None else np.zeros((len(plan), 4))  # it has one per row
    chosen = ", ".join(f"{int(np.sum(loads[:, 0] == w))} at {w:g} kg" for w in rows[:, 0])
    return DesignResult(
        plan=plan,
        value=value,
        criterion=criterion,
        rho0=rho0,
        rho0_each=each,
        sigma=sigma,
        method="exchange over (configuration, payload) pairs",
        starts=starts,
        continued=len(outcomes),
        seed=entropy,
        time_s=elapsed,
        history=tuple(history),
        pool_size=len(q_pool),
        pool_rejected=0,
        conditioning=float(conditioning(flat.T @ flat)),
        message=(
            f"exchange over {len(candidates)} configurations x payloads {masses} kg: best of {starts} "
            f"starts (start {winner}), {criterion} = {value:.6g} in {elapsed:.3g} s; payloads chosen: "
            f"{chosen}; conditioning floor {floor:.3g}"
            + (f"; {dropped_line(len(failed), starts)}" if failed else "")
        ),
        dropped=len(failed),
        prior=prior,
        instrument=instrument,
        orientation_length=orientation_length,
    )


NEAR = 0.3
"""Half-width [rad or m] of the box around the test poses a residual-model design also draws
candidates from (a quarter of the pool)."""


def _near(
    robot, feasibility: Feasibility, test_poses: np.ndarray, n: int, rng: np.random.Generator
) -> np.ndarray:
    """Up to n feasible configurations drawn around the test poses (within ±NEAR of one)."""
    centres = test_poses[rng.integers(len(test_poses), size=n)]
    qs = np.clip(centres + rng.uniform(-NEAR, NEAR, centres.shape), robot.lower, robot.upper)
    return qs[feasibility.feasible(qs)]


def _floor(min_conditioning: float | None, information: np.ndarray | None) -> float:
    if min_conditioning is None:
        return 0.0 if information is not None else MIN_CONDITIONING
    if isinstance(min_conditioning, bool) or not (0 <= min_conditioning < 0.1):
        raise BadArgument(f"min_conditioning must be a number in [0, 0.1), got {min_conditioning!r}")
    return float(min_conditioning)
