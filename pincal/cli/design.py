"""pincal design: the measurement plan that minimises ρ0 (or another criterion) at the test pose(s)."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from pincal.arguments import number
from pincal.cli import COMMANDS
from pincal.cli._accuracy import (
    REGION_HELP,
    add_region_arguments,
    add_report_arguments,
    add_task_payload_arguments,
    payload_centre_from_args,
    prior_from_args,
    report_accuracy,
    residual_model_from_args,
    split_line,
    task_payload_from_args,
    test_region_from_args,
)
from pincal.cli._common import (
    CONDITIONING_HELP,
    SIGMA_HELP,
    add_base_argument,
    add_command,
    add_output_arguments,
    add_progress_argument,
    add_robot_arguments,
    add_test_pose_argument,
    checked,
    count,
    emit_json,
    fmt_length,
    joint_units,
    params_from_args,
    parse_floats,
    read_plan,
    recorded_warnings,
    robot_from_args,
    seed_type,
    sigma_from_args,
    sigma_type,
)
from pincal.cli._instrument import INSTRUMENT_HELP, add_instrument_arguments, measuring_from_args
from pincal.cli._plot import add_plot_argument, save_design_plot
from pincal.cli._safety import (
    SAFETY_HELP,
    add_safety_arguments,
    add_self_collision_argument,
    safe_constraints_from_args,
)
from pincal.cli.campaign import (
    TRADEOFF_HELP,
    add_tradeoff_arguments,
    check_tradeoff_arguments,
    report_tradeoff,
)
from pincal.errors import BadArgument
from pincal.evaluation.test_pose import rho0_split
from pincal.instruments.error_model import Tracker
from pincal.instruments.instrument import Instrument
from pincal.model.statics import Payload
from pincal.planning import stopping as _stopping
from pincal.planning.baselines import random_plans
from pincal.planning.driver import METHODS, MIN_CONDITIONING, design
from pincal.planning.objectives import CRITERIA
from pincal.planning.options import grouped
from pincal.planning.placement import SCREEN, STEPS, Placement, place_instrument
from pincal.planning.plan import Plan
from pincal.planning.results import DesignResult, RandomPlans, dropped_line
from pincal.planning.safety import safety_margins
from pincal.viewing import plots

HELP = COMMANDS["design"].help
EXAMPLES = """\
examples:
  pincal design kr270 -m 12 --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2 --sigma 3e-5 \\
      --params lengths,offsets --out plan.csv --baseline 1000
  pincal design planar_2r -m 2 --test-pose=0.3,1.2 --params joint2.tx,tip.tx --json
  pincal design ur10 -m 12 --test-pose=0,-1.2,1.5,-1,-1.5,0 --method exchange --pool taught.csv
  pincal design kr270 -m 10 --test-pose=0,-90,90,0,45,0 --deg --constraints cell.yaml --starts 32
  pincal design kr270 -m 12 --test-pose=0,-60,60,0,45,0 --deg --around 10deg --marker 0.1,0.05,0.2 \\
      --sigma 3e-5 --out plan.csv                   # accurate over ±10°, not only at the test pose
  pincal design kr270 -m 12 --test-path weld.csv --deg --marker 0.1,0.05,0.2 --sigma 3e-5
  pincal design kr270 -m 6 --test-pose=0,-60,60,0,45,0 --deg --prior 1mm,1mrad --sigma 3e-5
  pincal design kr270 -m 15 --test-pose=0,-60,60,0,45,0 --deg --marker 0.1,0.05,0.2 \
      --params lengths,offsets,gains,joint_a2.compliance,joint_a3.compliance --payloads 0,135,270 \
      --task-payload 270 --payload-centre 0,0,0.25 --out plan.csv   # a payload per configuration
  pincal design ur10 -m 8 --test-pose=0,-1.2,1.5,-1,-1.5,0 --measure pose --sigma 1e-4 --sigma-rot 2e-3
  pincal design panda -m 20 --test-pose=0,-0.3,0,-2.2,0,2,0.8 --camera rig.yaml   # a camera and a grid
  pincal design kr270 -m 12 --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2 \
      --instrument tracker --instrument-at 4,0,1    # a tracker's radial/transverse error, 4 m away
  pincal design ur10 -m 12 --test-pose=0,-1.2,1.5,-1,-1.5,0 --marker 0.05,0.02,0.1 \
      --place-instrument 1.5,-2,0.75,9,2,0.75 --placement-plot placement.png   # where the tracker goes

Payloads (--payloads KG,KG,...; --task-payload KG; --payload-centre X,Y,Z): the exchange chooses a
payload for each configuration of a generated pool (--pool-size) or of your --pool; the plan CSV
carries payload columns, rho0 is under the task's payload, split into its geometric and elastic
parts, and the accuracy report (and --accuracy-plot) is under the task's payload too, next to a
payload-free D-optimal plan. Any --measure (poses, partial poses, distances, a camera) and
--instrument take payloads: each candidate's rows are the instrument's, weighted by its error
model, under its payload. {limits}.
--residual-model CAL.urdf: a top-up plan for the residual model of an earlier calibration; the
report gives its expected error at the test pose(s), and the accuracy table is of that expected
error (the residual model's variance included) for the plan and a D-optimal plan (no --pool or
--accuracy-plot with it). It measures points with one --sigma: the residual model is a Gaussian
process of the markers' positions, fitted to point residuals, and says nothing of orientations,
pixels or distances.

Criteria (--criterion): test-pose (rho0, root mean square over several --test-pose), test-pose-worst
(the worst test pose; --worst is the same), D, A, E, cond. Methods: exchange (the default: best m of
a pool of feasible configurations, then refined by the continuous search unless --no-polish; --pool
gives your own, e.g. taught poses, in the plan CSV format, and keeps the plan on them), continuous
(all joint values at once, from many random starts, the constraints kept by SLSQP).
--baseline N: rho0 of N random feasible plans (drawn from --pool when given, else within the joint
limits and --constraints) and of the D-optimal plan, next to the designed plan's.
--place-instrument X0,Y0,Z0,X1,Y1,Z1: choose the tracker's position in that box (instrument frame,
metres) together with the plan: a grid of --place-steps per axis (default 3), then the best
position's neighbours at half the step, each position screened by a quick design (2 exchange starts
over 500 of one pool's configurations it sees, no polish: a fraction of a second), then the best
--place-screen N (default 3) and the default position designed in full (8 exchange starts, the
best 2 polished for at most 150 iterations unless --starts is given: about 10 s of CPU each with
the line of sight); --place-screen all designs every position in full with the design's defaults
(27 + 6 on a 3-step box: an hour or more with the polish). At each position the plan is designed with the
tracker there (--instrument tracker, --tracker-sigma: its error; default the AT500's), under its
range (1 to
40 m), a 30-degree acceptance angle about the reflector's normal (the tip frame's z) and the line of
sight (nothing of the robot's collision geometry within 1 cm of the beam; unchecked, and said so,
when the URDF has none). With --camera (eye-to-hand), the camera is placed, aimed at the target at
the test pose, counting the target points in its field of view. The report (and JSON 'instrument_at',
'placement') gives the position chosen, rho0 there and at the default position (--instrument-at, or
the box's centre) and their factor; --placement-plot FILE.png maps rho0 over the box.
--base: the tracker measures in its own frame, so base.* are identified too (as 'identify --base').
--constraints FILE.yaml: joint_limits, workspace_box, half_space, visibility, line_of_sight,
self_collision, min_spacing (see pincal.planning.constraints.load_constraints for the layout).
--min-conditioning X: no plan whose conditioning is below X (default 1e-2, none with --prior); a
plan below 1e-3 is warned about whatever the floor, and so is a floor below 1e-3 that stops the
search.
{conditioning}

{safety}
{tradeoff}
{region}
Units: metres and radians; --deg reads test poses and --pool, and writes --out and prints the plan,
in degrees. The JSON plan is always in radians; rho0 is in metres for --sigma
(default 3e-5 m, a laser tracker; the report says which sigma it used).
"""
PAYLOAD_LIMITS = (
    "not supported with them: --baseline (random plans carry no payloads), --method continuous and "
    "--polish (the continuous search cannot choose among discrete payloads)"
)
EXAMPLES = (
    EXAMPLES.replace("{region}", REGION_HELP.rstrip())
    .replace("{conditioning}", CONDITIONING_HELP)
    .replace("{limits}", PAYLOAD_LIMITS[0].upper() + PAYLOAD_LIMITS[1:])
    .replace("{safety}", SAFETY_HELP.rstrip())
    .replace("{tradeoff}", TRADEOFF_HELP.rstrip())
)
EXAMPLES += "\n" + INSTRUMENT_HELP + "\n"


def add_design_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments design and baseline share: robot, parameters, m, test poses, constraints, noise,
    the pool of candidate configurations."""
    add_robot_arguments(p)
    add_base_argument(p)
    p.add_argument(
        "-m", type=count("-m"), required=True, metavar="M", help="number of configurations to measure"
    )
    add_test_pose_argument(p, required=False)
    add_region_arguments(p)
    p.add_argument("--constraints", metavar="FILE.yaml", help="workcell constraints (YAML)")
    add_safety_arguments(p)
    add_self_collision_argument(p)
    p.add_argument("--sigma", type=sigma_type(), default=None, help=SIGMA_HELP)
    p.add_argument(
        "--deg", action="store_true", help="joint values in degrees (test poses, pool, plan output)"
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="seed of every random choice (default 0)")
    p.add_argument(
        "--pool",
        metavar="FILE.csv",
        help="candidate configurations (plan CSV format, e.g. taught poses): plans are made of them, "
        "random baselines drawn from them",
    )


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "design", HELP, EXAMPLES)
    add_design_arguments(p)
    p.add_argument(
        "--criterion", default="test-pose", metavar="NAME", help=f"{', '.join(CRITERIA)} (default test-pose)"
    )
    p.add_argument(
        "--worst", action="store_true", help="with several test poses, minimise the worst (test-pose-worst)"
    )
    p.add_argument(
        "--method", default="exchange", metavar="NAME", help=f"{' or '.join(METHODS)} (default exchange)"
    )
    p.add_argument(
        "--pool-size",
        type=count("--pool-size"),
        metavar="N",
        help="random feasible candidates to draw (default 2000)",
    )
    p.add_argument(
        "--polish",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="exchange: refine the best plans with the continuous search (default: on, off with --pool)",
    )
    p.add_argument(
        "--starts",
        type=_starts_type,
        default=None,
        metavar="N|auto",
        help=f"number of starts, run exactly; default auto: batches of {_stopping.BATCH} until "
        f"{_stopping.AGREE} starts match the best within {100 * _stopping.TOLERANCE:g} %%, "
        f"at most {_stopping.CAP}",
    )
    p.add_argument(
        "--workers",
        type=count("--workers"),
        help="processes running the starts (default: all CPUs; 1: serial)",
    )
    p.add_argument(
        "--min-conditioning",
        type=checked("--min-conditioning", number, low=0.0, high=0.1, high_open=True),
        default=None,
        metavar="X",
        help=f"floor of the plan's conditioning (see below; default {MIN_CONDITIONING:g}, 0 with --prior)",
    )
    p.add_argument(
        "--out", metavar="PLAN.csv", help="write the plan (radians, degrees with --deg), atomically"
    )
    p.add_argument(
        "--baseline",
        type=count("--baseline"),
        metavar="N",
        help="also report N random feasible plans and the D-optimal plan",
    )
    add_progress_argument(p)
    p.add_argument(
        "--payloads",
        metavar="KG,KG,...",
        help="the payloads you can mount: a payload is chosen for each configuration (the plan CSV carries "
        "payload columns); an exchange over (configuration, payload) pairs",
    )
    add_task_payload_arguments(p)
    p.add_argument(
        "--residual-model",
        metavar="CAL.urdf",
        help="a top-up plan: the residual model of an earlier calibration (its sidecar) values measuring "
        "where the residual is correlated with the test pose's",
    )
    p.add_argument(
        "--place-instrument",
        metavar="X0,Y0,Z0,X1,Y1,Z1",
        help="choose the tracker's (or a fixed camera's) position in this box [m] with the plan",
    )
    p.add_argument(
        "--place-steps",
        type=count("--place-steps"),
        metavar="N",
        help=f"grid positions per axis of the --place-instrument box (default {STEPS})",
    )
    p.add_argument(
        "--place-screen",
        type=_screen_type,
        metavar="N|all",
        help=f"positions of the --place-instrument box designed in full after the screen (default {SCREEN}; "
        "all: every position, the exhaustive search)",
    )
    p.add_argument(
        "--placement-plot",
        metavar="FILE.png",
        help="save the map of rho0 against the instrument's position over the box (--place-instrument)",
    )
    add_plot_argument(p)
    add_report_arguments(p)
    add_tradeoff_arguments(p)
    add_instrument_arguments(p, test_pose=True)
    add_output_arguments(p)
    p.set_defaults(run=run)


def _starts_type(value: str) -> int | None:
    """--starts: a count, or ``auto`` (None: the adaptive number, :mod:`pincal.planning.stopping`)."""
    if value.strip().lower() == "auto":
        return None
    return count("--starts")(value)  # type: ignore[return-value]


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
    if args.worst and args.criterion not in ("test-pose", "test-pose-worst"):
        raise BadArgument(f"--worst applies to the test-pose criterion, not {args.criterion!r}")
    if args.pool and args.pool_size is not None:
        raise BadArgument("give --pool FILE.csv or --pool-size N, not both")
    taught = read_plan(robot, args.pool, args.deg) if args.pool else None
    pool = taught if taught is not None else args.pool_size
    progress = args.progress
    options = dict(
        method=args.method,
        pool=pool,
        starts=args.starts,
        polish=args.polish,
        min_conditioning=args.min_conditioning,
        prior=prior,
        constraints=constraints,
        sigma=sigma,
        seed=args.seed,
        workers=args.workers,
        progress=progress,
        **measuring.options,
    )
    loads = _payload_options(args)
    if args.residual_model:
        loads["residual_model"] = residual_model_from_args(robot, args.residual_model)
    if loads:
        _check_payload_design(args, loads)
        options.update(loads)
    placement = None
    if args.place_instrument is not None:
        placement, options = _placed(args, params, q0, criterion, options, taught, loads)
    elif args.placement_plot or args.place_steps is not None or args.place_screen is not None:
        raise BadArgument(
            "--placement-plot, --place-steps and --place-screen go with --place-instrument X0,Y0,Z0,X1,Y1,Z1"
        )
    with recorded_warnings() as records:
        if placement is None:
            # --baseline's D-optimal plan is searched from the same starts, on the same workers
            with_d = args.baseline is not None and options.get("method") == "exchange"
            result = design(
                params, args.m, q0, criterion=criterion, with_d_optimal=with_d, **grouped(options)
            )
        else:
            result = placement.result
        baseline = None
        if args.baseline is not None:
            baseline = _baseline(params, args, q0, criterion, taught, options, result.d_optimal)
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
            loads.get("task_payload"),
            loads.get("residual_model"),
            **measuring.options,
        )
        campaign = report_tradeoff(args, params, q0, result.plan, options)  # --campaign
        safety = safety_margins(robot, result.plan, constraints)  # warns of a pose colliding with itself
    if placement is not None and args.placement_plot:
        plots.save_figure(plots.placement_map(placement), args.placement_plot)
    _write_and_print(
        args, robot, params, source, result, baseline, report, sigma_text, safety, campaign, placement
    )
    print_warnings(records)  # last, where they are seen
    return 0


def _check_payload_design(args: argparse.Namespace, loads: dict) -> None:
    """What a design with --payloads/--task-payload/--residual-model does not take, said with why."""
    what = "--residual-model" if "residual_model" in loads else "--payloads/--task-payload"
    refused = {
        "--baseline": (args.baseline is not None, "random plans carry no payloads"),
        "--method continuous": (args.method != "exchange", CONTINUOUS_WHY),
        "--polish": (bool(args.polish), CONTINUOUS_WHY),
    }
    if "residual_model" in loads:
        refused["--accuracy-plot"] = (bool(args.accuracy_plot), "the plot has no residual model")
    given = [f"{name} ({why})" for name, (on, why) in refused.items() if on]
    if given:
        raise BadArgument(
            f"{what}: the design is an exchange over (configuration, payload) pairs; it does not take "
            + "; ".join(given)
        )


def _placed(args, params, q0, criterion: str, options: dict, taught, loads: dict):
    """(the :class:`Placement` of --place-instrument, the options of the rest of the command: its
    instrument where the placement put it)."""
    if args.baseline is not None or taught is not None or loads:
        raise BadArgument(
            "--place-instrument designs over a generated pool: no --baseline, --pool, --payloads or "
            "--residual-model with it"
        )
    box = parse_floats(args.place_instrument, "--place-instrument")
    if len(box) != 6:
        raise BadArgument(
            f"--place-instrument {args.place_instrument!r}: expected X0,Y0,Z0,X1,Y1,Z1 (six numbers, metres)"
        )
    kind, error = options.get("measure"), options.get("instrument")
    rest = {k: v for k, v in options.items() if k not in ("measure", "instrument", "constraints", "progress")}
    default_at = getattr(error, "at", None) if getattr(args, "instrument_at", None) else None
    screen = {None: SCREEN, "all": None}.get(args.place_screen, args.place_screen)
    with recorded_warnings() as records:
        placement = place_instrument(
            params, args.m, q0, (box[:3], box[3:]), criterion=criterion, measure=kind, instrument=error,
            constraints=options["constraints"], steps=args.place_steps or STEPS, default_at=default_at,
            screen=screen, progress=args.progress, **rest,
        )  # fmt: skip
    print_warnings(records)
    options = dict(options)
    if isinstance(placement.result.instrument, Instrument) and isinstance(
        placement.result.instrument.error, Tracker
    ):
        options["instrument"] = placement.result.instrument.error
    else:  # a camera: its fixture moved; the accuracy report would be of the nominal camera
        args.no_accuracy = True
    return placement, options


def _screen_type(value: str) -> int | str:
    """--place-screen: a count, or ``all``."""
    if value.strip().lower() == "all":
        return "all"
    return count("--place-screen")(value)  # type: ignore[return-value]  # an int


CONTINUOUS_WHY = "the continuous search cannot choose among discrete payloads"


def _payload_options(args: argparse.Namespace) -> dict:
    """design()'s payloads and task_payload from --payloads, --task-payload, --payload-centre."""
    task = task_payload_from_args(args)
    if args.payloads is None and task is None:
        return {}
    centre = payload_centre_from_args(args)
    masses = [0.0] if args.payloads is None else parse_floats(args.payloads, "--payloads")
    return {
        "payloads": [Payload(kg, centre) for kg in masses],
        "task_payload": task if task is not None else Payload(0.0, centre),
    }


def _baseline(
    params, args: argparse.Namespace, q0, criterion: str, taught, options: dict, d_optimal=None
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
        sigma=options["sigma"],
        prior=options["prior"],
        constraints=options["constraints"],
        seed=args.seed,
        pool=taught,
        **{k: options[k] for k in ("measure", "instrument", "orientation_length") if k in options},
    )
    if d_optimal is None:
        d_optimal = design(params, args.m, q0, criterion="D", **grouped(options))
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
    task = _payload_options(args).get("task_payload")
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
