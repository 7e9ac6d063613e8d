"""pincal show: a meshcat scene of a plan against the test pose (HTML file or live server), and
the plan's ρ0 against random plans as a figure."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time

import numpy as np

from pincal.arguments import positive_int, ratio
from pincal.cli import COMMANDS
from pincal.cli._accuracy import (
    REGION_HELP,
    add_region_arguments,
    add_report_arguments,
    add_task_payload_arguments,
    prior_from_args,
    report_accuracy,
    task_payload_from_args,
    test_poses_of,
    test_region_from_args,
)
from pincal.cli._common import (
    FIGURE_NOTE,
    SIGMA_HELP,
    add_command,
    add_output_arguments,
    add_robot_arguments,
    add_test_pose_argument,
    constraints_from_args,
    emit_json,
    fmt_length,
    parse_floats,
    read_plan,
    robot_from_args,
    sigma_from_args,
)
from pincal.cli._parameters import params_from_args
from pincal.cli._safety import add_safety_arguments, safe_constraints_from_args
from pincal.cli._types import checked, count, seed_type, sigma_type
from pincal.errors import BadArgument, BadConfiguration, warn
from pincal.evaluation.test_pose import rho0
from pincal.optional import require
from pincal.planning.baselines import random_plans
from pincal.planning.constraints import Visibility
from pincal.planning.safety import safety_margins
from pincal.viewing import plots

HELP = COMMANDS["show"].help
INSTRUMENT_RENAMED = (
    "show --instrument X,Y,Z is deprecated: write --instrument-at X,Y,Z (--instrument is what is measured, "
    "as in pincal design; --instrument X,Y,Z stops working in pincal 0.3)"
)
MAX_SHOWN_POSES = 500
"""Most poses a scene draws (a robot each, some 75 kB of the page and 10 ms): a plan of 250 000
poses ran for minutes towards a page of gigabytes."""
EXAMPLES = """\
examples:
  pincal show kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2 \\
      --sigma 3e-5 --html scene.html          # one self-contained file, opens offline
  pincal show kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2
                                              # starts a meshcat server; Ctrl-C to stop
  pincal show planar_2r --plan plan.csv --test-pose=0.3,1.2 --params joint2.tx,tip.tx \\
      --plot rho0.png --baseline 2000         # the plan's rho0 against 2000 random plans
  pincal show kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --around 10deg --marker 0.1,0.05,0.2 \\
      --sigma 3e-5 --error-cloud 500 --html scene.html   # where the plan leaves the robot accurate
  pincal show kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2 \\
      --params lengths,offsets,gains,compliance --task-payload 270 --payload-centre 0,0,0.25 --html scene.html

The scene: the robot at the test pose (opaque), one translucent numbered ghost per configuration
with its measured points, the 3-sigma ellipsoid of the predicted error at the test pose after
calibration (drawn larger than life by the stated factor), the instrument if --instrument-at is given;
with --error-cloud N, the measured point at N random configurations coloured by the predicted error
after calibration (green: smallest, red: largest, log scale). Of a region or path, the scene draws
its first configuration (the centre of --around); the report covers the whole region.
A plan with payload columns (from 'design --payloads') is measured under its payloads, and the test
pose(s), the error cloud and the report are taken under --task-payload KG (centre --payload-centre,
tip frame; default none), as evaluate and design take them: the same rho0.
"""
EXAMPLES += "\n" + REGION_HELP


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "show", HELP, EXAMPLES)
    add_robot_arguments(p)
    p.add_argument("--plan", required=True, metavar="PLAN.csv", help="the measurement configurations")
    add_test_pose_argument(p, required=False)
    add_region_arguments(p)
    p.add_argument(
        "--error-cloud",
        type=count("--error-cloud"),
        metavar="N",
        help="draw the measured point at N random configurations, coloured by the predicted error after "
        "calibration (green: smallest, red: largest)",
    )
    p.add_argument("--sigma", type=sigma_type(), default=None, help=SIGMA_HELP)
    p.add_argument("--deg", action="store_true", help="plan and test poses are in degrees")
    add_task_payload_arguments(p)
    p.add_argument(
        "--instrument-at",
        metavar="X,Y,Z",
        help="instrument position in the base frame [m] (default: the tracker of --constraints)",
    )
    # pincal 0.1's name of --instrument-at (--instrument is what is measured, in design): until 0.3
    p.add_argument("--instrument", metavar="X,Y,Z", help=argparse.SUPPRESS)
    p.add_argument(
        "--constraints",
        metavar="FILE.yaml",
        help="workcell constraints as for 'pincal design': the visibility constraint's tracker is drawn, "
        "and --plot's random plans respect them",
    )
    add_safety_arguments(p)
    p.add_argument(
        "--scale",
        type=checked("--scale", ratio),
        help="draw the error ellipsoid this many times larger than life (default: a visible size)",
    )
    p.add_argument(
        "--html",
        metavar="FILE.html",
        help="write the scene as one self-contained HTML file (without --html or --plot: start a "
        "meshcat server, print its URL and wait for Ctrl-C)",
    )
    p.add_argument(
        "--plot",
        metavar="FILE.png",
        help="save a figure of the plan's rho0 against random plans of the same size (needs --test-pose)"
        + FIGURE_NOTE,
    )
    p.add_argument(
        "--baseline",
        type=count("--baseline"),
        default=1000,
        metavar="N",
        help="random plans for --plot (default 1000)",
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="seed of the random plans (default 0)")
    p.add_argument(
        "--pool",
        metavar="FILE.csv",
        help="draw --plot's random plans from these configurations (plan CSV format, e.g. taught poses)",
    )
    add_report_arguments(p)
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from pincal.viewing.scene import scene

    sigma, sigma_text = sigma_from_args(args)
    _check_options(args)
    robot = robot_from_args(args)
    params, _ = params_from_args(robot, args)
    plan = read_plan(robot, args.plan, args.deg)
    if plan.m > MAX_SHOWN_POSES:
        raise BadArgument(
            f"--plan {args.plan}: {plan.m} poses; a scene draws the robot at each, at most "
            f"{MAX_SHOWN_POSES}: show a part of the plan",
            argument="--plan",
        )
    q0 = test_region_from_args(robot, args, required=False)
    prior = prior_from_args(args)
    task = task_payload_from_args(args)
    drawn, constraints, instrument = _scene_inputs(args, robot, q0)

    serve = not (args.html or args.plot)
    viewer = _start_server() if serve else "static"
    built = scene(
        params,
        plan,
        drawn,
        sigma=sigma,
        instrument_at=instrument,
        scale=args.scale,
        viewer=viewer,
        error_samples=args.error_cloud,
        prior=prior,
        task_payload=task,
    )
    report = report_accuracy(args, params, plan, q0, sigma, prior, task_payload=task)
    summary = _summary(robot.name, len(plan), sigma, built, report)
    summary["task_payload"] = None if task is None else task.row.tolist()
    safety = safety_margins(robot, plan, safe_constraints_from_args(robot, args))
    summary["safety"] = safety.as_dict()
    if args.html:
        built.save_html(args.html)
        summary["html"] = args.html
    if args.plot:
        summary["plot"] = args.plot
        summary["random_rho0"] = _plot_baseline(params, plan, q0, sigma, constraints, args)
    if serve:
        summary["url"] = built.viewer.url()

    try:
        if args.json:
            emit_json(summary)
        else:
            _print_summary(summary, sigma_text)
            print("\n".join(safety.lines()))
            if report is not None:
                print("\n".join(report.lines(degrees=args.deg)))
        sys.stdout.flush()
        while serve:  # until Ctrl-C; meshcat stops its server when pincal exits
            time.sleep(1.0)
    except KeyboardInterrupt:
        print("stopped", flush=True)
    return 0


def _check_options(args: argparse.Namespace) -> None:
    """Refuse options that cannot go together or are out of range (before the robot is loaded)."""
    if args.plot and not args.test_pose:
        raise BadArgument("--plot compares rho0 at the test pose: give --test-pose")
    if args.pool and not args.plot:
        raise BadArgument("--pool is where --plot draws its random plans: give --plot too")
    if args.plot and args.task_payload is not None:
        raise BadArgument(
            "--plot with --task-payload: the random plans it compares with carry no payloads; "
            "see the plan under its payload without --plot, or compare with 'pincal evaluate'"
        )


def _scene_inputs(args: argparse.Namespace, robot, q0) -> tuple:
    """(test poses drawn, constraints, instrument) of the scene: of a region or path, its first
    configuration (the centre); the instrument from --instrument, else the tracker of the
    constraints' visibility, else None (--instrument X,Y,Z, pincal 0.1's spelling, is warned of)."""
    if args.error_cloud is not None:
        positive_int(args.error_cloud, "--error-cloud")
    drawn = None if q0 is None else test_poses_of(robot, q0)
    drawn = drawn if drawn is None or isinstance(q0, np.ndarray) else drawn[:1]
    constraints = constraints_from_args(args)
    visible = [c for c in constraints if isinstance(c, Visibility)]
    instrument: Visibility | list[float] | None = visible[0] if visible else None
    at, flag = args.instrument_at, "--instrument-at"
    if args.instrument:
        if at:
            raise BadArgument("--instrument X,Y,Z is --instrument-at's old name: give --instrument-at only")
        at, flag = args.instrument, "--instrument"
        warn(INSTRUMENT_RENAMED)
    if at:
        instrument = parse_floats(at, flag)
        if len(instrument) != 3:
            raise BadConfiguration(f"{flag} {at!r}: expected X,Y,Z (three numbers, metres)")
    return drawn, constraints, instrument


def _summary(robot_name: str, m: int, sigma: float, built, report) -> dict:
    """The JSON summary of the scene and the accuracy report (html, plot, url filled in later)."""
    return {
        "robot": robot_name,
        "m": m,
        "sigma": sigma,
        "rho0": None if built.rho0 is None else built.rho0.tolist(),
        "ellipsoid_radii": None if built.ellipsoid_radii is None else built.ellipsoid_radii.tolist(),
        "ellipsoid_scale": built.ellipsoid_scale,
        "html": None,
        "plot": None,
        "url": None,
        "note": built.note,
        "accuracy": None if report is None else report.as_dict(),
        "error_cloud": None
        if built.error_values is None
        else {
            "n": len(built.error_values),
            "min": float(built.error_values.min()),
            "max": float(built.error_values.max()),
        },
    }


def _start_server():
    """A meshcat Visualizer on a new server; meshcat's own messages go to stderr."""

    meshcat = require("meshcat", "pincal show", "meshcat")
    with contextlib.redirect_stdout(sys.stderr):
        return meshcat.Visualizer()


def _plot_baseline(params, plan, q0: np.ndarray, sigma: float, constraints, args) -> dict:
    """Evaluate --baseline random feasible plans of the plan's size (as ``pincal baseline`` does),
    save the histogram; return their summary."""

    pool = read_plan(params.robot, args.pool, args.deg) if args.pool else None
    randoms = random_plans(
        params, len(plan), args.baseline, q0, sigma=sigma, constraints=constraints, seed=args.seed, pool=pool
    )
    if randoms.n_singular == randoms.n:
        raise BadArgument(
            f"none of the {randoms.n} random plans of {len(plan)} configurations is identifiable",
            argument="--baseline",
            value=randoms.n,
        )
    fig = plots.rho0_histogram(randoms.values, {"this plan": float(rho0(params, plan, q0, sigma=sigma))})
    plots.save_figure(fig, args.plot)
    return randoms.as_dict()


def _print_summary(s: dict, sigma_text: str) -> None:
    print(f"{s['robot']}: {s['m']} configurations, {sigma_text}")
    if s["task_payload"] is not None:
        mass, *centre = s["task_payload"]
        print(
            f"test pose(s) under the task's payload: {mass:g} kg at ({', '.join(f'{c:g}' for c in centre)}) m"
        )
    if s["rho0"] is not None:
        for k, (r, radii) in enumerate(zip(s["rho0"], s["ellipsoid_radii"], strict=True)):
            axes = ", ".join(fmt_length(a) for a in np.ravel(radii))
            print(
                f"test pose {k + 1}: rho0 = {fmt_length(r)}; 3-sigma ellipsoid semi-axes {axes}, "
                f"drawn x{s['ellipsoid_scale']:g}"
            )
    if s["note"]:
        print(s["note"])
    if s["html"]:
        print(f"wrote {s['html']}: one self-contained file, open it in any browser (no server needed)")
    if s["plot"]:
        b = s["random_rho0"]
        print(
            f"wrote {s['plot']}: rho0 against {b['n']} random feasible plans ({b['n_singular']} singular; "
            f"min {fmt_length(b['min'])}, "
            f"mean {fmt_length(b['mean'])}, max {fmt_length(b['max'])})"
        )
    if s["url"]:
        print(f"meshcat scene at {s['url']}  (Ctrl-C to stop)", flush=True)
