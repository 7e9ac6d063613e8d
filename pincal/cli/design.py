"""pincal design: the measurement plan that minimises ρ0 (or another criterion) at the test pose(s)."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

import numpy as np

from pincal.cli import COMMANDS
from pincal.cli._accuracy import (
    payload_centre_from_args,
    prior_from_args,
    report_accuracy,
    residual_model_from_args,
    split_line,
    task_payload_from_args,
    test_region_from_args,
)
from pincal.cli._common import (
    add_command,
    emit_json,
    fmt_length,
    joint_units,
    parse_floats,
    read_plan,
    recorded_warnings,
    robot_from_args,
    sigma_from_args,
)
from pincal.cli._design_options import EXAMPLES, add_design_options, search_from_args
from pincal.cli._design_options import add_design_arguments as add_design_arguments  # baseline's
from pincal.cli._instrument import error_from_args, measuring_from_args, with_sigma
from pincal.cli._parameters import params_from_args
from pincal.cli._plot import save_design_plot
from pincal.cli._safety import (
    safe_constraints_from_args,
)
from pincal.cli.campaign import (
    check_tradeoff_arguments,
    report_tradeoff,
)
from pincal.errors import BadArgument
from pincal.evaluation.test_pose import rho0_split
from pincal.instruments.error_model import Tracker
from pincal.instruments.image import Image
from pincal.instruments.instrument import Instrument
from pincal.model.statics import Payload
from pincal.planning import stopping as _stopping
from pincal.planning.baselines import random_plans
from pincal.planning.driver import design
from pincal.planning.options import Loads, Safety
from pincal.planning.placement import SCREEN, STEPS, Placement, place_instrument
from pincal.planning.plan import Plan
from pincal.planning.results import DesignResult, RandomPlans, dropped_line
from pincal.planning.safety import safety_margins
from pincal.viewing import plots

HELP = COMMANDS["design"].help


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "design", HELP, EXAMPLES)
    add_design_options(p)
    p.set_defaults(run=run)


def _starts_text(result: DesignResult) -> str:
    """How many starts ran: ``"16 starts (auto: 3 within 1 % of the best)"``."""
    if not result.adaptive:
        return f"{result.starts} starts"
    within = f"{result.matched} within {100 * _stopping.TOLERANCE:g} % of the best"
    return f"{result.starts} starts (auto: {within})"


def print_warnings(records: list) -> None:
    """Each warning recorded, once (a design, its baseline and its D-optimal plan may say the same)."""
    for message in dict.fromkeys(str(w.message) for w in records):
        print(f"pincal: warning: {message}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    sigma, sigma_text = sigma_from_args(args)
    measuring = measuring_from_args(args, robot_from_args(args), sigma if args.sigma is not None else None)
    robot = measuring.robot
    params, source = params_from_args(robot, args, measuring.instrument)
    sigma_text = measuring.text or sigma_text
    criterion = "test-pose-worst" if args.worst else args.criterion
    q0 = test_region_from_args(robot, args, required=criterion.lower().startswith("test"))
    prior = prior_from_args(args)
    constraints = safe_constraints_from_args(robot, args)  # with the safe defaults
    check_tradeoff_arguments(args, robot, q0)
    _check_search_arguments(args)
    taught = read_plan(robot, args.pool, args.deg) if args.pool else None
    pool = taught if taught is not None else args.pool_size
    options = _design_keywords(args, pool, prior, constraints, sigma, measuring.options)
    loads = _loads(args)
    residual = residual_model_from_args(robot, args.residual_model) if args.residual_model else None
    if loads is not None or residual is not None:
        _check_payload_design(args, residual is not None)
        options.update(loads=loads, residual_model=residual)
    placement = None
    if args.place_instrument is not None:
        placement = _placed(args, params, q0, criterion, options, taught, measuring.options)
        # the plan is measured by the placed instrument: the reports are of it, not of the default
        placed = placement.result.instrument
        measuring = replace(measuring, options=dict(measuring.options, instrument=placed))
        options = {k: v for k, v in options.items() if k != "sigma"} | {"instrument": placed}
    elif args.placement_plot or args.place_steps is not None or args.place_screen is not None:
        raise BadArgument(
            "--placement-plot, --place-steps and --place-screen go with --place-instrument X0,Y0,Z0,X1,Y1,Z1"
        )
    with recorded_warnings() as records:
        if placement is None:
            # --baseline's D-optimal plan is searched from the same starts, on the same workers
            with_d = args.baseline is not None and options["search"].method == "exchange"
            result = design(params, args.m, q0, criterion=criterion, with_d_optimal=with_d, **options)
        else:
            result = placement.result
        baseline = None
        if args.baseline is not None:
            baseline = _baseline(
                params, args, q0, criterion, taught, sigma, options, measuring.options, result.d_optimal
            )
        reference = None if baseline is None or baseline[1] is None else baseline[1].plan
        report = report_accuracy(
            args,
            params,
            result.plan,
            q0,
            sigma,
            prior,
            reference,
            constraints,
            pool,
            None if loads is None else loads.task_payload,
            residual,
            **measuring.options,
        )
        campaign = report_tradeoff(args, params, q0, result.plan, sigma, options)  # --campaign
        safety = safety_margins(robot, result.plan, constraints)  # warns of a pose colliding with itself
    if placement is not None and args.placement_plot:
        plots.save_figure(plots.placement_map(placement), args.placement_plot)
    _write_and_print(
        args, robot, params, source, result, baseline, report, sigma_text, safety, campaign, placement
    )
    print_warnings(records)  # last, where they are seen
    return 0


def _check_search_arguments(args: argparse.Namespace) -> None:
    """--worst with the test-pose criterion only; --pool or --pool-size, not both."""
    if args.worst and args.criterion not in ("test-pose", "test-pose-worst"):
        raise BadArgument(f"--worst applies to the test-pose criterion, not {args.criterion!r}")
    if args.pool and args.pool_size is not None:
        raise BadArgument("give --pool FILE.csv or --pool-size N, not both")


def _design_keywords(args: argparse.Namespace, pool, prior, constraints, sigma, measured: dict) -> dict:
    """The keywords of :func:`pincal.design` the command line gives (the loads apart): its search,
    its safety, the prior and what is measured (``measured``: the instrument's options)."""
    return dict(
        search=search_from_args(args, pool),
        safety=Safety(constraints=constraints, min_conditioning=args.min_conditioning),
        prior=prior,
        **with_sigma(sigma, measured),
    )


def _check_payload_design(args: argparse.Namespace, residual: bool) -> None:
    """What a design with --payloads/--task-payload/--residual-model does not take, said with why."""
    what = "--residual-model" if residual else "--payloads/--task-payload"
    refused = {
        "--baseline": (args.baseline is not None, "random plans carry no payloads"),
        "--method continuous": (args.method != "exchange", CONTINUOUS_WHY),
        "--polish": (bool(args.polish), CONTINUOUS_WHY),
    }
    if residual:
        refused["--accuracy-plot"] = (bool(args.accuracy_plot), "the plot has no residual model")
    given = [f"{name} ({why})" for name, (on, why) in refused.items() if on]
    if given:
        raise BadArgument(
            f"{what}: the design is an exchange over (configuration, payload) pairs; it does not take "
            + "; ".join(given)
        )


def _placed(args, params, q0, criterion: str, options: dict, taught, measured: dict) -> Placement:
    """The :class:`Placement` of --place-instrument (``options``: design()'s keywords, ``measured``
    the instrument's options)."""
    if args.baseline is not None or taught is not None or "loads" in options or "residual_model" in options:
        raise BadArgument(
            "--place-instrument designs over a generated pool: no --baseline, --pool, --payloads or "
            "--residual-model with it"
        )
    box = parse_floats(args.place_instrument, "--place-instrument")
    if len(box) != 6:
        raise BadArgument(
            f"--place-instrument {args.place_instrument!r}: expected X0,Y0,Z0,X1,Y1,Z1 (six numbers, metres)"
        )
    instrument = measured.get("instrument")
    if (
        instrument is not None
        and not isinstance(instrument.kind, Image)
        and error_from_args(args, None) is None
    ):
        instrument = Instrument(instrument.kind, Tracker())  # no error model given: a tracker is placed
    search, safety = options["search"], options["safety"]
    rest = dict(
        method=search.method, pool=search.pool, starts=search.starts, polish=search.polish,
        min_conditioning=safety.min_conditioning, prior=options["prior"], seed=search.seed,
        workers=search.workers, **{k: v for k, v in measured.items() if k == "orientation_length"},
    )  # fmt: skip
    tracker = None if instrument is None else instrument.error
    default_at = getattr(tracker, "at", None) if getattr(args, "instrument_at", None) else None
    screen = {None: SCREEN, "all": None}.get(args.place_screen, args.place_screen)
    with recorded_warnings() as records:
        placement = place_instrument(
            params, args.m, q0, (box[:3], box[3:]), criterion=criterion, instrument=instrument,
            constraints=safety.constraints, steps=args.place_steps or STEPS, default_at=default_at,
            screen=screen, progress=args.progress, **rest,
        )  # fmt: skip
    print_warnings(records)
    if not (
        isinstance(placement.result.instrument, Instrument)
        and isinstance(placement.result.instrument.error, Tracker)
    ):  # a camera: its fixture moved; the accuracy report would be of the nominal camera
        args.no_accuracy = True
    return placement


CONTINUOUS_WHY = "the continuous search cannot choose among discrete payloads"


def _loads(args: argparse.Namespace) -> Loads | None:
    """design()'s loads from --payloads, --task-payload, --payload-centre, or None."""
    task = task_payload_from_args(args)
    if args.payloads is None and task is None:
        return None
    centre = payload_centre_from_args(args)
    masses = [0.0] if args.payloads is None else parse_floats(args.payloads, "--payloads")
    return Loads(
        payloads=[Payload(kg, centre) for kg in masses],
        task_payload=task if task is not None else Payload(0.0, centre),
    )


def _baseline(
    params,
    args: argparse.Namespace,
    q0,
    criterion: str,
    taught,
    sigma: float,
    options: dict,
    measured: dict,
    d_optimal=None,
) -> tuple[RandomPlans, DesignResult | None]:
    """(random feasible plans, the D-optimal plan) of --baseline: the random plans drawn from the
    taught pool if any, the D-optimal plan designed with the same options as the plan (given:
    ``d_optimal``, searched with the plan from its starts)."""
    randoms = random_plans(
        params,
        args.m,
        args.baseline,
        q0,
        criterion=_rho0_criterion(criterion),
        prior=options["prior"],
        constraints=options["safety"].constraints,
        seed=args.seed,
        pool=taught,
        **with_sigma(sigma, measured),
    )
    if d_optimal is None:
        d_optimal = design(params, args.m, q0, criterion="D", **options)
    return randoms, d_optimal


def _write_and_print(
    args: argparse.Namespace,
    robot,
    params,
    source,
    result: DesignResult,
    baseline,
    report,
    sigma_text: str,
    safety=None,
    campaign=(None, None),
    placement: Placement | None = None,
) -> None:
    """--out, --plot, then the JSON object or the text report."""
    if args.out:
        result.plan.to_csv(args.out, degrees=args.deg)
    if args.plot:
        save_design_plot(args.plot, result, baseline)
    if args.json:
        payload = design_json(robot, params, result, baseline, args.out)
        payload["accuracy"] = None if report is None else report.as_dict()
        payload["rho0_split"] = _split(params, result, args)
        payload["safety"] = None if safety is None else safety.as_dict()
        if campaign[0] is not None:
            payload["campaign"] = {"time": campaign[0].total, "order": list(campaign[0].order)}
            payload["tradeoff"] = campaign[1].as_dict()
        payload["placement"] = None if placement is None else placement.as_dict()
        emit_json(payload)
    else:
        print_design(robot, params, source, result, args.deg, sigma_text, _split(params, result, args))
        if safety is not None:
            print("\n".join(safety.lines()))
        if campaign[0] is not None:
            print(f"this plan's campaign: {campaign[0].summary()}")
            print("\n".join(campaign[1].lines()))
        if placement is not None:
            print("\n".join(placement.lines()))
        if baseline is not None:
            print_baseline(baseline[0], baseline[1], pool=args.pool)
        if report is not None:
            print("\n".join(report.lines(degrees=args.deg)))
        if args.out:
            print(f"wrote {args.out} ({joint_units(robot, args.deg)})")
    sys.stdout.flush()


def _split(params, result: DesignResult, args: argparse.Namespace) -> dict | None:
    """ρ0² split into geometric and elastic parts (with gain or compliance parameters), or None."""
    if result.rho0 is None or not any(p.kind in ("gain", "compliance") for p in params):
        return None
    loads = _loads(args)
    task = None if loads is None else loads.task_payload
    return rho0_split(
        params, result.plan, test_region_from_args(params.robot, args), sigma=result.sigma, task_payload=task
    )


def _rho0_criterion(criterion: str) -> str:
    return "test-pose-worst" if criterion == "test-pose-worst" else "test-pose"


def design_json(robot, params, result: DesignResult, baseline, out: str | None) -> dict:
    payload = {
        "robot": robot.name,
        "tip": robot.tip,
        "markers": robot.markers.tolist(),
        "params": list(params.names),
        "n_params": len(params),
    }
    payload.update(result.as_dict())
    payload["out"] = out
    if baseline is not None:
        randoms, d_opt = baseline
        payload["baseline"] = {
            "random": randoms.as_dict(),
            "d_optimal": d_opt.rho0,
            "d_optimal_plan": d_opt.plan.q.tolist(),
        }
    return payload


def format_plan(robot, plan: Plan, degrees: bool) -> list[str]:
    """The plan as a table: joint names, each column's unit ([deg] or [rad]; [m] for a prismatic
    joint), one row per configuration."""
    values = robot.to_degrees(plan.q) if degrees else plan.q
    names = plan.joint_names
    units = [f"[{('deg' if degrees else 'rad') if r else 'm'}]" for r in robot.revolute]
    if plan.payload is not None:
        values, names = np.column_stack([values, plan.payload[:, 0]]), (*names, "payload")
        units.append("[kg]")
    width = max(10, *(len(n) for n in names))
    lines = ["  " + " ".join(f"{n:>{width}}" for n in names)]
    lines.append("  " + " ".join(f"{u:>{width}}" for u in units))
    lines += ["  " + " ".join(f"{v:>{width}.4f}" for v in row) for row in values]
    return lines


def print_design(
    robot,
    params,
    source: str,
    result: DesignResult,
    degrees: bool,
    sigma_text: str,
    split: dict | None = None,
) -> None:
    print(
        f"{robot.name}: {result.m} configurations designed for {result.criterion} ({result.method}, "
        f"{_starts_text(result)}, {result.continued} run to convergence, {result.time_s:.3g} s)"
    )
    print(f"{len(params)} parameters ({source}); {sigma_text}")
    if result.dropped:
        print(f"{dropped_line(result.dropped, result.starts)} (none of their random plans was regular)")
    if result.rho0_each is not None and result.rho0 is not None and len(result.rho0_each) > 1:
        agg = "worst" if result.criterion == "test-pose-worst" else "root mean square"
        print(
            f"rho0 over {len(result.rho0_each)} test poses ({agg}): {fmt_length(result.rho0)}  "
            f"({result.rho0:.6g} m)"
        )
        for i, r in enumerate(result.rho0_each[:10]):
            print(f"  test pose {i}: {fmt_length(r)}")
        if len(result.rho0_each) > 10:
            print(f"  ... ({len(result.rho0_each)} test poses in all; --json lists each)")
    elif result.rho0 is not None:
        print(f"rho0 at the test pose: {fmt_length(result.rho0)}  ({result.rho0:.6g} m)")
    if result.plan.payload is not None:
        print(result.message)
    if result.criterion == "test-pose-gp":
        print(f"expected error at the test pose with the residual model: {fmt_length(result.value)}")
    elif result.criterion not in ("test-pose", "test-pose-worst"):
        print(f"{result.criterion} = {result.value:.6g}")
    print(f"conditioning {result.conditioning:.3g}")
    if split is not None:
        print(split_line(split))
    print("plan:")
    for line in format_plan(robot, result.plan, degrees):
        print(line)


def print_baseline(randoms: RandomPlans, d_opt: DesignResult | None, pool: str | None = None) -> None:
    singular = f", {randoms.n_singular} singular" if randoms.n_singular else ""
    drawn = f" of the configurations of {pool}" if pool else ""
    if randoms.n_singular == randoms.n:
        print(
            f"baseline: all {randoms.n} random feasible plans{drawn} are singular (too few configurations "
            "to identify the parameters)"
        )
        return
    print(
        f"baseline, {randoms.n} random feasible plans{drawn}{singular}: rho0 min {fmt_length(randoms.min)}, "
        f"median {fmt_length(randoms.median)}, mean {fmt_length(randoms.mean)}, max {fmt_length(randoms.max)}"
    )
    if d_opt is not None and d_opt.rho0 is not None:
        print(f"baseline, D-optimal plan: rho0 {fmt_length(d_opt.rho0)}")
