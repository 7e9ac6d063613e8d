"""pincal measure-sim: simulated measurements, to rehearse a calibration without hardware."""

from __future__ import annotations

import argparse

import numpy as np
import pinocchio as pin

from pincal.arguments import DEFAULT_SIGMA, MAX_ANGLE, check_lengths, generator, number
from pincal.calibration.synthetic import random_errors, simulate_measurements
from pincal.cli import COMMANDS
from pincal.cli._common import (
    SIGMA_HELP,
    add_command,
    add_robot_arguments,
    joint_ranges_from_args,
    joint_units,
    parse_floats,
    read_plan,
    robot_from_args,
)
from pincal.cli._instrument import (
    INSTRUMENT_HELP,
    add_instrument_arguments,
    error_from_args,
    instrument_from_args,
    kind_from_args,
    robot_with_fixtures,
)
from pincal.cli._parameters import params_from_args
from pincal.cli._types import seed_type, sigma_type
from pincal.cli.simulate import parse_error_std
from pincal.errors import BadArgument, BadConfiguration, UrdfError
from pincal.export.mjcf import export_mjcf, writes_mjcf
from pincal.export.urdf import export_urdf
from pincal.instruments.error_model import PerCoordinate
from pincal.instruments.instrument import Instrument
from pincal.instruments.point import Point
from pincal.model.loading import load_robot

HELP = COMMANDS["measure-sim"].help
EXAMPLES = """\
examples:
  pincal measure-sim kr270 --plan plan.csv --true kr270_true.urdf --sigma 3e-5 --out meas.csv \\
      --marker 0.1,0.05,0.2
  pincal measure-sim kr270 --plan plan.csv --error-std 1e-3,1e-3 --save-true true.urdf --sigma 3e-5 \\
      --out meas.csv --mm --marker 0.1,0.05,0.2 --seed 3
  pincal measure-sim kr270 --plan plan.csv --true true.urdf --sigma 3e-5 --out tracker.csv \\
      --base-pose=2.5,-1.0,0.2,0,0,1.2 --marker 0.1,0.05,0.2    # in an instrument's frame
  pincal measure-sim ur10 --plan plan.csv --error-std 1e-3,1e-3 --measure pose --sigma 1e-4 \
      --sigma-rot 2e-3 --out mocap.csv                           # motion capture: 6-D poses
  pincal measure-sim panda --plan plan.csv --error-std 1e-3,1e-3 --camera rig.yaml --out corners.csv
  pincal measure-sim kr270 --plan plan.csv --error-std 1e-3,1e-3 --instrument tracker \
      --instrument-at 3,0,1 --marker 0.1,0.05,0.2 --out tracker.csv   # a tracker's own error model

The "true" robot is TRUE.urdf (same joints as ROBOT) or, with --error-std LEN,ANG, ROBOT with
random errors of --params (std LEN metres, ANG radians; --save-true writes it as a URDF to compare
with the calibration). Points are measured at the plan's configurations with Gaussian noise --sigma
per coordinate (metres; 0 for exact points), in the robot base frame or, with --base-pose
X,Y,Z,ROLL,PITCH,YAW (metres, radians or degrees with --deg), in an instrument's frame.
MEAS.csv is what 'pincal identify' reads: joint columns (radians, degrees with --deg), then x,y,z
(or x0,y0,z0,x1,... for several markers) in metres, millimetres with --mm, or the columns of what
--measure says is measured (an image's points out of the camera's view are left empty).

{instrument}
"""
EXAMPLES = EXAMPLES.replace("{instrument}", INSTRUMENT_HELP)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "measure-sim", HELP, EXAMPLES)
    add_robot_arguments(p)
    p.add_argument("--plan", required=True, metavar="PLAN.csv", help="the configurations to measure")
    truth = p.add_mutually_exclusive_group(required=True)
    truth.add_argument("--true", metavar="TRUE.urdf", help="the 'real' robot, a URDF with the same joints")
    truth.add_argument("--error-std", metavar="LEN,ANG", help="or: ROBOT with random errors of this std")
    p.add_argument(
        "--save-true",
        metavar="TRUE.urdf",
        help="with --error-std: write the true robot as a URDF (MJCF for a MuJoCo robot)",
    )
    p.add_argument("--sigma", type=sigma_type(zero=True), default=None, help=SIGMA_HELP + "; 0: exact points")
    p.add_argument("--out", required=True, metavar="MEAS.csv", help="the measurement file to write")
    p.add_argument("--base-pose", metavar="X,Y,Z,R,P,Y", help="robot base in the instrument's frame")
    p.add_argument("--seed", type=seed_type(), default=0, help="random seed (default 0)")
    p.add_argument("--mm", action="store_true", help="write coordinates in millimetres")
    p.add_argument("--deg", action="store_true", help="plan (and written joint values) in degrees")
    add_instrument_arguments(p)
    p.set_defaults(run=run)


def _base_pose(text: str | None, degrees: bool) -> pin.SE3:
    if text is None:
        return pin.SE3.Identity()
    values = parse_floats(text, "--base-pose")
    if len(values) != 6:
        raise BadConfiguration(f"--base-pose {text!r}: expected X,Y,Z,ROLL,PITCH,YAW (six numbers)")
    check_lengths(values[:3], f"--base-pose {text!r}: translation", BadConfiguration)
    rpy = np.radians(values[3:]) if degrees else np.array(values[3:])
    for v in rpy:
        number(
            v, f"--base-pose {text!r}: an angle", -MAX_ANGLE, MAX_ANGLE, unit="rad", error=BadConfiguration
        )
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(values[:3]))


def run(args: argparse.Namespace) -> int:
    given = args.sigma
    sigma = DEFAULT_SIGMA if args.sigma is None else args.sigma
    if args.save_true and not args.error_std:
        raise BadArgument("--save-true needs --error-std (the true robot is then drawn at random)")
    robot = robot_with_fixtures(robot_from_args(args), args)
    kind = kind_from_args(args, robot)
    error = None if sigma == 0 and not args.instrument else error_from_args(args, given)
    plan = read_plan(robot, args.plan, args.deg)
    rng = generator(args.seed)
    if args.true:
        true_robot = load_robot(
            args.true,
            tip=robot.tip,
            markers=robot.markers,
            root=robot.root,
            joint_ranges=joint_ranges_from_args(args),
        ).replace(fixtures=robot.fixtures)
        if true_robot.joint_names != robot.joint_names:
            raise UrdfError(
                f"--true {args.true}: its chain to {robot.tip!r} has joints "
                f"{', '.join(true_robot.joint_names)}; "
                f"{robot.name} has {', '.join(robot.joint_names)}"
            )
        description = f"true robot {args.true}"
    else:
        params, source = params_from_args(robot, args, instrument_from_args(args, kind, given or None))
        heaviest = None if plan.payload is None else plan.payload[[int(np.argmax(plan.payload[:, 0]))]]
        truth = random_errors(params, error_std=parse_error_std(args.error_std), seed=rng, payload=heaviest)
        true_robot = truth.robot
        description = f"random errors of {len(params)} parameters ({source}), seed {args.seed}"
        if args.save_true:
            description += f", saved to {args.save_true}"
    measured = true_robot.replace(base=_base_pose(args.base_pose, args.deg))
    if (kind is None or isinstance(kind, Point)) and error is None:
        data = simulate_measurements(measured, plan, sigma, seed=rng)
    else:  # --sigma 0: exact values of what is measured
        exact = error is None and sigma == 0
        instrument = Instrument(kind or Point(), error or PerCoordinate(DEFAULT_SIGMA if exact else sigma))
        data = simulate_measurements(measured, plan, 0.0 if exact else None, seed=rng, instrument=instrument)
    data.to_csv(args.out, degrees=args.deg, millimetres=args.mm, robot=robot)
    if args.save_true:
        (export_mjcf if writes_mjcf(robot, args.save_true) else export_urdf)(true_robot, args.save_true)
    unit = "mm" if args.mm else "m"
    angles = joint_units(robot, args.deg)
    what = f"{data.n_markers} marker(s)" if data.is_points else data.measure.describe()
    units = set(data.measure.units(robot))  # the σ shown: of what is measured
    noise = f"noise {sigma:g} m" if error is None else f"noise {error.describe(units)}"
    lengths = "points" if data.is_points else "lengths"
    print(
        f"{args.out}: {data.m} configurations x {what}, {noise}, {description}; joints in {angles}, "
        f"{lengths} in {unit}"
    )
    return 0
