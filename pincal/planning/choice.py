"""The choose stage of a design: the best usable start above the conditioning floor (warning when
the floor binds), and the :class:`~pincal.planning.results.DesignResult` built from it, its value
and ρ0 computed by the core's own functions."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pincal.errors import (
    DataCheckWarning,
    DegenerateOptimum,
    DegenerateOptimumWarning,
    Infeasible,
    warn,
)
from pincal.evaluation.classic import criteria_from_jacobian
from pincal.evaluation.data_check import MIN_DATA_CONDITIONING, DataCheck, check_parameters
from pincal.evaluation.registry import TEST_POSE_CRITERIA, make_criterion
from pincal.evaluation.residual_criterion import ResidualCriterion
from pincal.evaluation.test_pose import TestPoseCriterion, rho0_each
from pincal.instruments.given import keywords
from pincal.instruments.instrument import RowsEngine
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.planning import stopping as _stopping
from pincal.planning.plan import Plan
from pincal.planning.results import DesignResult, StartRecord, dropped_line
from pincal.planning.search import log_scale, plan_conditioning, values
from pincal.planning.settings import Outcome, Pool, Settings, dropped_count

SINGULAR_WARNING = 1e-3
"""A plan whose conditioning is below this is effectively singular: some parameter combinations
are barely measured, and the error away from the test pose(s) grows large (bench_floor: at 1e-3 the
error 10° away is 2.6–2.8× that at the test pose, at 1e-4 6.6–7.3×). It is said whatever the floor;
a floor above it that binds is the floor doing its job (said in the result's message only)."""


@dataclass(frozen=True)
class Choice:
    """The winning start and the history, with the starts that ended below the floor marked."""

    winner: int
    conditioning: float
    below_floor: int
    near_floor: bool
    history: tuple[StartRecord, ...]


# ---------------------------------------------------------------------------- choose
def choose(
    settings: Settings,
    params: ParameterSet,
    engine: JacobianEngine | RowsEngine,
    outcomes: tuple[Outcome, ...],
) -> Choice:
    """The best usable start above the conditioning floor.

    No plan below the floor is returned (the exchange can end there; the continuous search keeps
    above it). A winner near the floor means the criterion improves towards singular plans: say so.
    A winner below the identification's :data:`MIN_DATA_CONDITIONING` (a floor asked for can be
    lower) comes with a :class:`DataCheckWarning` naming the parameters identification from it would
    leave nominal.
    """
    floor, criterion = settings.floor, settings.criterion
    usable = [s for s, o in enumerate(outcomes) if o.usable and np.isfinite(o.F)]
    if not usable:
        raise Infeasible(
            f"none of the {len(outcomes)} starts ended in a feasible, regular plan; "
            "relax the constraints or add starts"
        )
    cond = {s: plan_conditioning(engine, _plan(outcomes[s]), outcomes[s].payload) for s in usable}
    regular = [s for s in usable if cond[s] > floor or floor <= 0]
    history = tuple(
        replace(o.record, message=f"below the conditioning floor {floor:g}; " + o.record.message)
        if s in cond and s not in regular
        else o.record
        for s, o in enumerate(outcomes)
    )
    if not regular:
        raise DegenerateOptimum(criterion, settings.m, floor)
    winner = min(regular, key=lambda s: (outcomes[s].F, s))
    if settings.prior is None and cond[winner] < MIN_DATA_CONDITIONING:  # only below a floor asked for
        best = outcomes[winner]
        check = identification_check(params, engine, _plan(best), settings.sigma, best.payload)
        if check.dropped:
            dropped = "; ".join(f"{name}: {why}" for name, why in check.dropped.items())
            warn(
                f"identification from this plan (sigma {settings.sigma * 1e3:.3g} mm) would leave "
                f"{len(check.dropped)} parameter(s) at their "
                f"nominal values ({dropped}); raise min_conditioning to {MIN_DATA_CONDITIONING:g} or more, "
                "add configurations or markers, or leave those parameters out",
                DataCheckWarning,
            )
    near_floor = floor > 0 and cond[winner] < 2 * floor  # within twice the floor: the floor binds
    where = "design for a neighbourhood or a path of where you work (pincal.around, TestPath)"
    if near_floor and floor < SINGULAR_WARNING:
        warn(
            f"the plan sits at the conditioning floor ({cond[winner]:.3g}; min_conditioning {floor:.3g}): "
            f"the {criterion} criterion keeps improving towards singular plans, so its infimum is not "
            f"attained, and the error away from the test pose(s) grows; {where}, add test poses around "
            f"where you work, or raise min_conditioning",
            DegenerateOptimumWarning,
        )
    elif cond[winner] < SINGULAR_WARNING:  # whatever the floor (0 with a prior)
        held = (
            "the prior holds the parameter combinations the plan barely measures: identify with the same "
            "prior (MAP), and expect the error away from the test pose(s) to stay near the prior's"
            if settings.prior is not None
            else "some parameter combinations are barely measured, and the error away from the test pose(s) "
            f"is large; {where}, or raise min_conditioning"
        )
        warn(
            f"the plan is effectively singular (conditioning {cond[winner]:.3g}): {held}",
            DegenerateOptimumWarning,
        )
    return Choice(winner, cond[winner], len(usable) - len(regular), near_floor, history)


def design_result(
    settings: Settings,
    params: ParameterSet,
    engine: JacobianEngine | RowsEngine,
    pooled: Pool,
    outcomes: tuple[Outcome, ...],
    choice: Choice,
    elapsed: float,
) -> DesignResult:
    """The design result of the winning start, its value and ρ0 computed by the core's functions."""
    s, best = settings, outcomes[choice.winner]
    q = _plan(best)
    plan = Plan.for_robot(params.robot, q, best.payload)
    value, rho0, rho0_each = _report(params, plan, s, engine.jacobian(q, frame="tip", payload=best.payload))
    criterion = s.criterion
    if s.residual_model is not None:  # the criterion minimised: the expected error with the model
        value, criterion = best.record.value, ResidualCriterion.name
    continued = sum(h.continued for h in choice.history)
    n_starts, dropped = len(outcomes), dropped_count(outcomes)
    matched = _stopping.matched(values(outcomes), log_scale(s))
    within = f"{matched} within {100 * _stopping.TOLERANCE:g} % of the best"
    message = (
        f"{s.method}: best of {n_starts} starts (start {choice.winner}"
        + (f"; adaptive: {within}" if s.adaptive else "")
        + f"), {continued} run to convergence, "
        f"{criterion} = {value:.6g} in {elapsed:.3g} s; conditioning floor {s.floor:.3g}"
        + _loads_text(s, plan)
        + (f"; {dropped_line(dropped, n_starts)}" if dropped else "")
        + (
            f"; {choice.below_floor} start(s) ended below the conditioning floor"
            if choice.below_floor
            else ""
        )
        + (
            "; the conditioning floor binds (the criterion alone would crowd the plan towards singular)"
            if choice.near_floor
            else ""
        )
    )
    return DesignResult(
        plan=plan,
        value=value,
        criterion=criterion,
        rho0=rho0,
        rho0_each=rho0_each,
        sigma=s.sigma,
        method=s.method + ("+polish" if s.polish else "") + (PAIRS if s.loaded else ""),
        starts=n_starts,
        continued=continued,
        seed=s.entropy,
        time_s=elapsed,
        history=choice.history,
        pool_size=len(pooled.candidates),
        pool_rejected=pooled.rejected,
        conditioning=choice.conditioning,
        message=message,
        dropped=dropped,
        matched=matched,
        adaptive=s.adaptive,
        prior=s.prior,
        instrument=s.measured,
        orientation_length=s.orientation_length,
    )


PAIRS = " over (configuration, payload) pairs"
"""Said of the method when the candidates carry payloads."""


def _loads_text(settings: Settings, plan: Plan) -> str:
    """The payloads offered and how many configurations chose each: "; payloads 0, 50 kg: 7 at 0 kg,
    5 at 50 kg" ("" without payloads)."""
    if settings.loads is None or plan.payload is None:
        return ""
    masses = settings.loads[:, 0]
    chosen = ", ".join(f"{int(np.sum(plan.payload[:, 0] == w))} at {w:g} kg" for w in masses)
    return f"; payloads {', '.join(f'{w:g}' for w in masses)} kg: {chosen}"


def _report(params, plan, settings: Settings, J) -> tuple[float, float | None, np.ndarray | None]:
    """(value, ρ0, ρ0 per test pose) of the final plan, from the core's own functions."""
    s = settings
    criterion, test_poses, sigma, prior = s.criterion, s.test_poses, s.sigma, s.prior
    rho0 = each = None
    if test_poses is not None and s.loads is not None:  # under the plan's payloads and the task's
        each = rho0_each(params, plan, test_poses, prior=prior, task_payload=s.task_payload,
                         orientation_length=s.orientation_length, **keywords(s.measured, sigma))  # fmt: skip
    elif test_poses is not None:
        each = TestPoseCriterion(
            params,
            test_poses,
            aggregate="each",
            prior=prior,
            orientation_length=s.orientation_length,
            **keywords(s.measured, sigma),
        )(plan.q)
    if each is not None:
        rho0 = float(each.max()) if criterion == "test-pose-worst" else float(np.sqrt(np.mean(each**2)))
    if criterion in TEST_POSE_CRITERIA:
        assert rho0 is not None  # the settings checked the test poses are given
        return rho0, rho0, each
    if prior is not None:  # the Bayesian classic criterion, as the search minimised it
        P = len(params)
        objective = make_criterion(
            criterion, P, J.shape[1], sigma=sigma, prior=prior.information(params, sigma)
        )
        flat = J.reshape(-1, P)
        return float(objective.report(objective.value(flat.T @ flat, len(plan)))), rho0, each
    c = criteria_from_jacobian(J, len(plan))
    return float(c.by_criterion(criterion)), rho0, each


def identification_check(
    params: ParameterSet,
    engine: JacobianEngine | RowsEngine,
    q: np.ndarray,
    sigma: float,
    payload: np.ndarray | None = None,
) -> DataCheck:
    """The data check :func:`pincal.identify` makes of one session's data measured at the plan q
    (under its payloads) with noise σ: which parameters it would identify
    (:func:`~pincal.evaluation.data_check.check_parameters`)."""
    J = engine.jacobian(q, frame="tip", payload=payload).reshape(-1, engine.n_params) / sigma
    return check_parameters(params, J.T @ J, len(q), sigma)


def _plan(outcome: Outcome) -> np.ndarray:
    """The (m, nq) plan a usable start ended at."""
    assert outcome.q is not None  # only a start dropped after screening has none
    return outcome.q
