"""Where the robot works and how accurate a plan leaves it there, for design, evaluate, show and
baseline: --around, --test-path, --test-box, --prior, and the accuracy report (issue 9)."""

from __future__ import annotations

import argparse
import math
import warnings

import numpy as np

from pincal.arguments import UNITS_TEXT, quantities
from pincal.arguments import angle as checked_angle
from pincal.arguments import length as checked_length
from pincal.cli._common import (
    FIGURE_NOTE,
    parse_configuration,
    parse_floats,
    read_plan,
    trap_floating_point_warnings,
)
from pincal.cli._instrument import with_sigma
from pincal.compensation.calibration_file import load_calibration
from pincal.errors import BadArgument, PincalError, SingularPlan
from pincal.evaluation.accuracy import accuracy
from pincal.evaluation.accuracy_report import AccuracyReport
from pincal.evaluation.error_profile import error_profile
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import TestPath, around, cartesian_box, resolve_test_poses
from pincal.model.statics import Payload
from pincal.planning.driver import design
from pincal.planning.options import Safety, Search
from pincal.viewing.plots import error_vs_distance, save_figure

REGION_HELP = """\
Where the robot works (any of design, evaluate, show, baseline):
  --test-pose Q0 [--test-pose Q1 ...]   one or several test poses
  --around 10deg                        the neighbourhood Q0 ± 10° of each joint (256 samples; with
                                        several --test-pose, of each); rho0 is then the rms over it;
  --around 10deg,2cm                    with prismatic joints: ± 2 cm for them (a length is needed)
  --test-path PATH.csv                  a path, plan CSV format (--deg applies), any length: the
                                        mean costs the same for 10 or 10 000 points
  --test-box X0,Y0,Z0,X1,Y1,Z1          configurations whose marker lies in this box [m, instrument
                                        frame] at the tool orientation of --test-pose (inverse
                                        kinematics from it: 256 targets, unreachable ones dropped)
  --prior 1mm,1mrad                     errors before calibration: the Bayesian criterion (design),
                                        rho0 split into measurements and prior; needs the real --sigma
Every report gives the predicted error at the test pose(s), over ±10° and ±20° around them (for
a region: around its samples, up to 10°/20° beyond its edge) and over the workspace (median, 95th
percentile), for the plan and a D-optimal plan of the same size (--no-accuracy: skip it);
--accuracy-plot FILE.png plots it against the distance from the test pose.
"""


def add_region_arguments(parser: argparse.ArgumentParser) -> None:
    """--around, --test-path, --test-box, --prior."""
    parser.add_argument(
        "--around",
        metavar="ANGLE[,LENGTH]",
        help="design/evaluate for the neighbourhood test pose ± ANGLE for each revolute joint and "
        "± LENGTH for each prismatic joint (e.g. 10deg, 0.17rad, 10deg,2cm; a bare number is the angle "
        "and follows --deg)",
    )
    parser.add_argument(
        "--test-path", metavar="PATH.csv", help="test configurations of a path (plan CSV format), any length"
    )
    parser.add_argument(
        "--test-box",
        metavar="X0,Y0,Z0,X1,Y1,Z1",
        help="test region: the marker in this box [m] at the tool orientation of --test-pose (by IK)",
    )
    parser.add_argument(
        "--prior",
        metavar="LEN,ANG",
        help="standard deviations of the errors before calibration, e.g. 1mm,1mrad (Bayesian criterion)",
    )


def add_report_arguments(parser: argparse.ArgumentParser) -> None:
    """--no-accuracy, --accuracy-plot."""
    parser.add_argument(
        "--no-accuracy",
        action="store_true",
        help="skip the report of the predicted error away from the test pose (and its D-optimal plan)",
    )
    parser.add_argument(
        "--accuracy-plot",
        metavar="FILE.png",
        help="save a plot of the predicted error against the distance from the test pose" + FIGURE_NOTE,
    )


def report_accuracy(
    args,
    params,
    plan,
    test_pose,
    sigma: float,
    prior,
    reference=None,
    constraints=(),
    pool=None,
    task_payload=None,
    residual_model=None,
    **measuring,
):
    """The accuracy report the command prints (None with --no-accuracy or without a test pose), and
    the --accuracy-plot saved; ``reference`` defaults to a D-optimal plan of the same size (without
    payloads); every plan is evaluated under its own payloads, the configurations reported on under
    ``task_payload``, and with ``residual_model`` the expected error with it."""
    if test_pose is None or args.no_accuracy:
        if args.accuracy_plot:
            raise BadArgument("--accuracy-plot needs a test pose or region, and no --no-accuracy")
        return None
    if reference is None:
        reference = d_optimal_plan(
            params, len(plan), constraints, pool, getattr(args, "seed", 0), **measuring
        )
    try:
        report = accuracy_report(
            params, plan, test_pose, sigma, prior, reference, task_payload=task_payload,
            residual_model=residual_model, **measuring,
        )  # fmt: skip
    except SingularPlan:
        if args.accuracy_plot:
            raise
        return None  # the command says the plan is singular its own way
    if args.accuracy_plot:
        plans = {"plan": plan} if reference is None else {"plan": plan, "D-optimal": reference}
        save_accuracy_plot(
            args.accuracy_plot, params, plans, test_pose, sigma, prior, task_payload, **measuring
        )
    return report


AROUND_VALID = (
    "expected an angle for the revolute joints and, for prismatic joints, a length, e.g. 10deg or "
    f"10deg,2cm ({UNITS_TEXT}; a bare number is the angle, in degrees with --deg, else radians)"
)


def parse_around(text: str, degrees: bool) -> tuple[float | None, float | None]:
    """(angle [rad] or None, length [m] or None) of --around '10deg', '10deg,2cm', '2cm', '0.17'
    (a bare number is the angle: degrees with --deg)."""
    found: dict[str, float] = {}
    for kind, value in quantities(text, "--around", AROUND_VALID):
        if kind is None:
            kind, value = "angle", math.radians(value) if degrees else value
        if kind in found:
            raise BadArgument(f"--around {text!r}: two {kind}s; {AROUND_VALID}", argument="--around")
        found[kind] = value
    where = f"--around {text!r}: the"
    angle = None if "angle" not in found else checked_angle(found["angle"], f"{where} angle")
    length = None if "length" not in found else checked_length(found["length"], f"{where} length")
    return angle, length


def test_region_from_args(robot, args: argparse.Namespace, required: bool = True):
    """The test pose(s) or region of the arguments: an (k, nq) array, a region or path, or None
    (none given and ``required`` is False)."""
    poses = [parse_configuration(robot, t, args.deg, "--test-pose") for t in args.test_pose or ()]
    if args.test_path:
        if poses or args.around or args.test_box:
            raise BadArgument(
                "--test-path is the test region: give it without --test-pose, --around, --test-box"
            )
        return TestPath(read_plan(robot, args.test_path, args.deg, what="test path").q)
    if not poses:
        if args.around or args.test_box:
            raise BadArgument("--around and --test-box need a --test-pose (the centre, the tool orientation)")
        if required:
            raise BadArgument("give a test pose (--test-pose Q0) or a path (--test-path PATH.csv)")
        return None
    if args.test_box:
        if args.around or len(poses) > 1:
            raise BadArgument("--test-box takes one --test-pose (its tool orientation), and no --around")
        box = parse_floats(args.test_box, "--test-box")
        if len(box) != 6:
            raise BadArgument(
                f"--test-box {args.test_box!r}: expected X0,Y0,Z0,X1,Y1,Z1 (six numbers, metres)"
            )
        return cartesian_box(box[:3], box[3:], reference=poses[0])
    if args.around:
        angle, length = parse_around(args.around, args.deg)
        if len(poses) == 1:
            return around(poses[0], angle, length=length)
        n = max(16, 256 // len(poses))
        return TestPath(
            np.vstack([around(q, angle, length=length, samples=n).resolve(robot).poses for q in poses])
        )
    return np.array(poses)


def add_task_payload_arguments(parser: argparse.ArgumentParser) -> None:
    """--task-payload, --payload-centre."""
    parser.add_argument(
        "--task-payload", type=float, metavar="KG", help="the task's payload at the test pose(s) (compliance)"
    )
    parser.add_argument(
        "--payload-centre",
        metavar="X,Y,Z",
        help="the payloads' centre of mass in the tip frame [m] (default 0)",
    )


def payload_centre_from_args(args: argparse.Namespace) -> tuple[float, float, float]:
    """--payload-centre as (x, y, z) [m] (the tip origin when not given)."""
    if args.payload_centre is None:
        return (0.0, 0.0, 0.0)
    values = parse_floats(args.payload_centre, "--payload-centre")
    if len(values) != 3:
        raise BadArgument(f"--payload-centre {args.payload_centre!r}: expected X,Y,Z (three numbers, metres)")
    return (values[0], values[1], values[2])


def task_payload_from_args(args: argparse.Namespace) -> Payload | None:
    """The --task-payload at --payload-centre, or None."""
    if args.task_payload is None:
        if args.payload_centre is not None and getattr(args, "payloads", None) is None:
            raise BadArgument("--payload-centre needs --task-payload (or --payloads)")
        return None
    return Payload(args.task_payload, payload_centre_from_args(args))


def split_line(split: dict) -> str:
    """ρ0² split into its causes (:func:`~pincal.evaluation.test_pose.rho0_split`), one line."""
    parts = {k: v * 1e6 for k, v in split.items()}
    return (
        f"rho0^2 under the task's payload, by cause [mm^2]: geometric {parts['geometric']:.3g}, elastic "
        f"(gains, compliance) {parts['elastic']:.3g}, their correlation {parts['cross']:+.3g}; "
        f"sum {parts['total']:.3g}"
    )


def residual_model_from_args(robot, urdf: str):
    """The residual model in the sidecar of calibration ``urdf`` (--residual-model; one line if it
    has none)."""
    deployed = load_calibration(urdf, robot)
    if deployed.residual_model is None:
        raise BadArgument(
            f"--residual-model {urdf}: its calibration has no residual model (identify it with "
            "--residual-model gp)"
        )
    return deployed.residual_model


def prior_from_args(args: argparse.Namespace) -> Prior | None:
    """The --prior, or None."""
    return Prior.parse(args.prior) if args.prior else None


def test_poses_of(robot, test_pose) -> np.ndarray:
    """(k, nq) configurations of test poses or a region (its samples)."""
    return resolve_test_poses(robot, test_pose)[0]


def d_optimal_plan(params, m: int, constraints=(), pool=None, seed: int = 0, **measuring: object):
    """A D-optimal plan of m configurations (exchange, 4 starts, no polish; the reports' reference),
    or None when there is none (too few configurations)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reference's own warnings are not the user's design's
        trap_floating_point_warnings()
        try:
            return design(
                params,
                m,
                criterion="D",
                search=Search(starts=4, seed=seed, pool=pool, workers=1, polish=False),
                safety=Safety(constraints=constraints),
                **_without_orientation(measuring),
            ).plan
        except PincalError:
            return None


def accuracy_report(
    params,
    plan,
    test_pose,
    sigma: float,
    prior,
    reference,
    seed: int = 0,
    task_payload=None,
    residual_model=None,
    **measuring: object,
) -> AccuracyReport:
    """The accuracy report of ``plan`` next to ``reference`` (the D-optimal plan, if any)."""
    compare = {} if reference is None else {"D-optimal": reference}
    report = accuracy(
        params,
        plan,
        test_pose,
        prior=prior,
        compare=compare,
        seed=seed,
        task_payload=task_payload,
        residual_model=residual_model,
        **with_sigma(sigma, _without_orientation(measuring)),
    )
    assert isinstance(report, AccuracyReport)  # one plan, one report
    return report


def save_accuracy_plot(
    path: str, params, plans: dict, test_pose, sigma: float, prior, task_payload=None, **measuring: object
) -> None:
    """The predicted error against the distance from the test pose, for each plan, saved."""
    profiles = error_profile(
        params, plans, test_pose, prior=prior, task_payload=task_payload,
        **with_sigma(sigma, _without_orientation(measuring)),
    )  # fmt: skip
    save_figure(error_vs_distance(profiles), path)


def _without_orientation(measuring: dict) -> dict:
    """The instrument's options without the test-pose criterion's orientation length (the
    position-only reports and the D-optimal reference do not take it)."""
    return {k: v for k, v in measuring.items() if k != "orientation_length"}
