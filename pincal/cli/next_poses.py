"""pincal next: from the measurements so far, the next poses to measure — or stop."""

from __future__ import annotations

import argparse
import math
import re
import sys

from pincal.adaptive.loop import AVOID_DISTANCE, next_poses
from pincal.arguments import DEFAULT_SIGMA, ratio
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.sanity import OUTLIER_SCORE
from pincal.cli import COMMANDS
from pincal.cli._accuracy import REGION_HELP, add_region_arguments, prior_from_args, test_region_from_args
from pincal.cli._common import (
    SIGMA_HELP,
    add_command,
    add_output_arguments,
    add_progress_argument,
    add_robot_arguments,
    add_test_pose_argument,
    emit_json,
    read_plan,
    recorded_warnings,
    robot_from_args,
)
from pincal.cli._instrument import (
    INSTRUMENT_HELP,
    add_instrument_arguments,
    error_from_args,
    kind_from_args,
    robot_with_fixtures,
)
from pincal.cli._parameters import add_base_argument, params_from_args
from pincal.cli._safety import (
    SAFETY_HELP,
    add_safety_arguments,
    add_self_collision_argument,
    safe_constraints_from_args,
)
from pincal.cli._types import checked, count, seed_type
from pincal.cli.design import print_warnings
from pincal.errors import BadArgument
from pincal.instruments.error_model import PerCoordinate
from pincal.instruments.instrument import Instrument
from pincal.planning.options import Safety, Search

HELP = COMMANDS["next"].help
EXAMPLES = f"""\
examples:
  pincal next kr270 --data measured.csv --plan plan.csv -k 3 --test-pose=0,-60,60,0,45,0 --around 10deg \\
      --deg --marker 0.1,0.05,0.2 --target 0.02mm --out next.csv
  pincal next kr270 --data measured.csv --plan plan.csv --deg --mm --base --test-path weld.csv --json
  pincal next kr270 --data measured.csv --plan plan.csv --deg --pool taught.csv -k 3 \\
      --test-pose=0,-60,60,0,45,0
  pincal next ur10 --data mocap.csv --measure pose --sigma 1e-4 --sigma-rot 2e-3 -k 2 \\
      --test-pose=0,-90,90,0,90,0 --around 10deg --deg

What it does, from --data (the measurement CSV, as 'pincal identify' reads it) and --plan (the poses
planned so far: those not in the data are unreachable, and the next poses keep
{math.degrees(AVOID_DISTANCE):g} degrees away from them):
  1. identifies the parameters, drops the rows beyond --reject robust sigma (default {OUTLIER_SCORE:g})
     as outliers and names them, re-estimates sigma from the residuals (unless --sigma is given or
     the data have uncertainty columns);
  2. predicts the error over the test region with the data so far (the measured poses' information,
     outliers left out);
  3. stops when it is below --target; otherwise designs the next -k poses that most reduce the
     criterion over the test region given what is already measured, and predicts the error after
     them. Measure them, add them to the data and the plan, and run it again.
Every measurement kind works (points, poses, partial poses, distances, images; read from the data's
columns, or --measure, as 'pincal identify' reads them): the data so far and the next poses are
measured with the data's instrument (--sigma per length, --sigma-rot, --sigma-px, or --instrument
tracker; sigma re-estimated when none is given), the predicted error is the markers' at the test
region whatever the instrument measures.
--target takes a length with a unit (0.02mm, 20um, 2e-5m; a bare number is metres).
--out writes the next poses (plan CSV; degrees with --deg); run 'pincal campaign' on them to order
and check the moves.

{{instrument}}

{SAFETY_HELP.rstrip()}

{REGION_HELP.rstrip()}
"""
EXAMPLES = EXAMPLES.replace("{instrument}", INSTRUMENT_HELP)

_LENGTH = re.compile(r"^\s*([0-9.eE+-]+)\s*(m|mm|um|µm|cm)?\s*$")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "next", HELP, EXAMPLES)
    add_robot_arguments(p)
    add_base_argument(p)
    p.add_argument("--data", required=True, metavar="MEASURED.csv", help="the measurements so far")
    p.add_argument(
        "--plan",
        metavar="PLAN.csv",
        help="the poses tried so far (the batches sent to the robot, not the poses still to run): "
        "those without data are taken as unreachable and the next poses keep away from them",
    )
    p.add_argument("-k", type=count("-k"), default=3, help="poses to choose next (default 3)")
    p.add_argument(
        "--pool",
        metavar="POOL.csv",
        help="choose the next poses among these configurations only (plan CSV: taught or measured poses; "
        "degrees with --deg), instead of a generated pool",
    )
    add_test_pose_argument(p, required=False)
    add_region_arguments(p)
    p.add_argument(
        "--target", metavar="LENGTH", help="stop when the predicted error is below this (e.g. 0.02mm)"
    )
    p.add_argument(
        "--sigma",
        type=float,
        default=None,
        help=SIGMA_HELP + " (per length for another kind); default: re-estimated from the data",
    )
    add_instrument_arguments(p)
    p.add_argument(
        "--deg", action="store_true", help="joint values in degrees (data, plan, test poses, --out)"
    )
    p.add_argument("--mm", action="store_true", help="measured coordinates are in millimetres")
    p.add_argument(
        "--reject",
        type=checked("--reject", ratio),
        default=OUTLIER_SCORE,
        metavar="K",
        help="outliers: rows beyond K robust sigma",
    )
    p.add_argument("--constraints", metavar="FILE.yaml", help="workcell constraints (YAML)")
    add_safety_arguments(p)
    add_self_collision_argument(p)
    p.add_argument(
        "--starts", type=count("--starts"), default=8, help="starts of the next design (default 8)"
    )
    p.add_argument(
        "--workers", type=count("--workers"), help="processes of the next design (default: all CPUs)"
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="seed of the next design (default 0)")
    p.add_argument("--out", metavar="NEXT.csv", help="write the next poses (plan CSV), atomically")
    add_progress_argument(p)
    add_output_arguments(p)
    p.set_defaults(run=run)


def parse_length(text: str, what: str) -> float:
    """A positive length from '0.02mm', '20um', '2e-5m' or a bare number of metres [m]."""
    match = _LENGTH.match(str(text))
    try:
        value = float(match.group(1)) if match else math.nan
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise BadArgument(f"{what} {text!r}: expected a positive length, e.g. 0.02mm, 20um or 2e-5 (metres)")
    assert match is not None  # no match gives a NaN value, refused above
    unit = (match.group(2) or "m").replace("µ", "u")
    return value * {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6}[unit]


def run(args: argparse.Namespace) -> int:
    robot = robot_with_fixtures(robot_from_args(args), args)
    target = None if args.target is None else parse_length(args.target, "--target")
    kind = kind_from_args(args, robot)
    data = MeasurementData.from_csv(args.data, robot, degrees=args.deg, millimetres=args.mm, kind=kind)
    error = error_from_args(args, args.sigma)
    measuring: dict = {"sigma": args.sigma}  # an error model has its own σ
    if error is not None:
        measuring = {"instrument": Instrument(data.measure, error)}
    # what the data's instrument identifies (its fixtures, --anchor or --camera, with the robot), as
    # identify's set: a point's identifiability would drop the anchors and leave their errors in σ
    measured = Instrument(data.measure, error or PerCoordinate(args.sigma or DEFAULT_SIGMA))
    params, source = params_from_args(robot, args, measured)
    plan = read_plan(robot, args.plan, args.deg) if args.plan else None
    pool = read_plan(robot, args.pool, args.deg, what="pool") if args.pool else None
    region = test_region_from_args(robot, args)
    prior = prior_from_args(args)
    constraints = safe_constraints_from_args(robot, args)
    with recorded_warnings() as records:
        result = next_poses(
            params,
            data,
            region,
            args.k,
            plan=plan,
            target=target,
            prior=prior,
            reject=args.reject,
            search=Search(
                starts=args.starts, seed=args.seed, workers=args.workers, pool=pool, progress=args.progress
            ),
            safety=Safety(constraints=constraints),
            **measuring,
        )
    if args.out and not result.stop:
        result.plan.to_csv(args.out, degrees=args.deg)
    if args.json:
        payload = {
            "robot": robot.name,
            "params": list(params.names),
            "out": None if result.stop else args.out,
        }
        payload.update(result.as_dict())
        emit_json(payload)
    else:
        print(f"{robot.name}: {len(params)} parameters ({source})")
        print("\n".join(result.lines(degrees=args.deg)))
        if args.out and not result.stop:
            print(f"wrote {args.out} ({'degrees' if args.deg else 'radians'})")
        elif args.out:
            print(f"{args.out} not written: nothing more to measure")
    sys.stdout.flush()
    print_warnings(records)
    return 0
