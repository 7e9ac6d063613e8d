"""pincal iso9283: the ISO 9283 pose characteristics of poses measured in cycles, before and after
calibration."""

from __future__ import annotations

import argparse

import numpy as np

from pincal.cli import COMMANDS
from pincal.cli._common import FIGURE_NOTE, add_command, add_output_arguments, emit_json
from pincal.compensation.calibration_file import load_calibration
from pincal.errors import BadArgument
from pincal.evaluation.ipa_iso_cubes import describe_cubes, read_ipa_iso_cubes
from pincal.evaluation.iso9283 import iso9283
from pincal.evaluation.pose_cycles import PoseCycles, read_pose_cycles
from pincal.evaluation.rigid_fit import RigidFit
from pincal.model.loading import load_robot
from pincal.viewing import plots

HELP = COMMANDS["iso9283"].help
EXAMPLES = """\
examples:
  pincal example cycles --out cycles.csv                 # an ISO test (yours instead)
  pincal iso9283 --data cycles.csv --mm --deg            # attained poses already in the robot's frame
  pincal iso9283 --data cycles.csv --mm --deg --fit-frame   # in an instrument's frame: best rigid fit
  pincal example iso_cubes --out measurements_iso_cubes.csv   # a slice of the public IPA UR10 set
  pincal iso9283 --data measurements_iso_cubes.csv --format ipa --test "cube 1" --json
  pincal iso9283 --data measurements_iso_cubes.csv --format ipa --robot ur10 \\
      --calibration ur10_cal.urdf --plot iso.png      # before and after calibration

CYCLES.csv: a header row, then one row per measured pose: pose (P1 ... P5), cycle, the commanded
position x_c,y_c,z_c and the attained one x,y,z (metres; millimetres with --mm); optionally the
orientations a_c,b_c,c_c and a,b,c (fixed-axis angles about x, y, z: R = Rz(c) Ry(b) Rx(a); radians,
degrees with --deg), a test column (several cubes in one file), and the joint readings at each
pose, one column per joint named as the robot's (radians; degrees with --deg) for --calibration.
--format ipa reads the IPA UR10 + Leica T-Mac ISO-cube series (ipa-robot-accuracy,
measurements_iso_cubes.csv): each cube's centre is P1 and four corners of a diagonal plane P2 ... P5,
consecutive repetitions of a cube its cycles; tracker coordinates, so --fit-frame is implied.

Reported per pose (ISO 9283 §7.2-7.3, n cycles): AP = |mean attained - commanded|, RP = l + 3 S_l
(l_j the distance of cycle j from the mean, S_l with n - 1); with orientations AP_a/b/c (mean
rotation from the commanded orientation about the commanded frame's x, y, z: log(R_c^T R)) and
RP_a/b/c = ±3 S; per pair of poses (--pair, default ISO's P2,P4) AD = mean distance - commanded
distance and RD = ±3 S_D. Repeatabilities need 2 cycles (ISO prescribes 30). Text in mm and
degrees; --json in metres and radians.
--fit-frame: the attained poses are in an instrument's frame: they are expressed in the commanded
frame by the best rigid fit of the attained positions onto the commanded ones over every row (and,
with orientations, the measured frame's constant rotation on the tool); the fit absorbs what is
constant in the errors.
--calibration CAL.urdf (written by 'pincal identify', with its sidecar; --robot names the nominal
robot): the poses after compensation, predicted from the recorded data (a robot cannot be re-run):
commanded + (measured - the calibrated model's pose at the same joint readings), the measured
poses expressed in the model's frame by the best rigid fit. Needs the joint readings.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "iso9283", HELP, EXAMPLES)
    p.add_argument("--data", required=True, metavar="CYCLES.csv", help="the poses measured in cycles")
    p.add_argument(
        "--format",
        choices=("csv", "ipa"),
        default="csv",
        help="csv: the layout below (default); ipa: the IPA ISO-cube series (';' and decimal commas)",
    )
    p.add_argument("--mm", action="store_true", help="positions in millimetres (csv)")
    p.add_argument("--deg", action="store_true", help="angles and joint readings in degrees (csv)")
    p.add_argument(
        "--fit-frame",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="express the attained poses in the commanded frame by the best rigid fit (default: off "
        "for csv, on for ipa)",
    )
    p.add_argument(
        "--test",
        action="append",
        metavar="NAME",
        help="report this test (a cube) only; repeat for several (the frame fit uses every row)",
    )
    p.add_argument(
        "--pair",
        action="append",
        metavar="A,B",
        help="two poses whose distance accuracy AD and repeatability RD are reported; repeat "
        "(default: P2,P4 when present, else every pair)",
    )
    p.add_argument(
        "--calibration",
        metavar="CAL.urdf",
        help="a calibrated URDF with its sidecar: also the characteristics after compensation",
    )
    p.add_argument("--robot", metavar="ROBOT", help="the nominal robot of --calibration (name or URDF path)")
    p.add_argument("--tip", help="its tip frame, if it has several chain ends")
    p.add_argument("--plot", metavar="FILE.png", help="save a figure of AP and RP pose by pose" + FIGURE_NOTE)
    add_output_arguments(p)
    p.set_defaults(run=run)


def _pairs(args: argparse.Namespace) -> list[tuple[str, str]] | None:
    if not args.pair:
        return None
    pairs = []
    for text in args.pair:
        names = [n.strip() for n in text.split(",")]
        if len(names) != 2 or not all(names) or names[0] == names[1]:
            raise BadArgument(f"--pair {text!r}: expected two different pose names A,B", argument="--pair")
        pairs.append((names[0], names[1]))
    return pairs


def _read(args: argparse.Namespace) -> tuple[PoseCycles, dict[str, str]]:
    if args.format == "ipa":
        if args.mm or args.deg:
            raise BadArgument(
                "--format ipa: the file says its units (mm and degrees measured): no --mm or --deg"
            )
        if args.fit_frame is False:
            raise BadArgument(
                "--format ipa: the T-Mac is measured in the tracker's frame: --no-fit-frame refused"
            )
        cycles = read_ipa_iso_cubes(args.data)
        return cycles, describe_cubes(cycles)
    return read_pose_cycles(args.data, millimetres=args.mm, degrees=args.deg), {}


def _fit_dict(fit: RigidFit) -> dict[str, object]:
    return {
        "rotation": fit.rotation.tolist(),
        "translation": fit.translation.tolist(),
        "tool_rotation": None if fit.tool_rotation is None else fit.tool_rotation.tolist(),
        "rms": fit.rms,
    }


def run(args: argparse.Namespace) -> int:
    pairs = _pairs(args)
    if args.calibration is None and (args.robot or args.tip):
        raise BadArgument("--robot and --tip name the nominal robot of --calibration: give --calibration")
    if args.calibration is not None and args.robot is None:
        raise BadArgument("--calibration: name the nominal robot with --robot (ur10, or its URDF)")
    read, descriptions = _read(args)
    fit_frame = args.format == "ipa" if args.fit_frame is None else args.fit_frame
    cycles, frame_fit = read.in_commanded_frame() if fit_frame else (read, None)
    after = after_fit = None
    if args.calibration is not None:
        deployed = load_calibration(args.calibration, load_robot(args.robot, tip=args.tip))
        after, after_fit = read.after_calibration(deployed.robot, deployed.residual_model)
    if args.test:
        cycles = cycles.select(args.test)
        after = None if after is None else after.select(args.test)
        descriptions = {t: d for t, d in descriptions.items() if t in args.test}
    before_report = iso9283(cycles, pairs)
    after_report = None if after is None else iso9283(after, pairs)
    if args.plot:
        series = (
            {"before": before_report}
            if after_report is None
            else {"before": before_report, "after": after_report}
        )
        plots.save_figure(plots.iso9283_characteristics(series), args.plot)
    if args.json:
        emit_json(
            {
                "data": args.data,
                "format": args.format,
                "tests": descriptions or None,
                "frame_fit": None if frame_fit is None else _fit_dict(frame_fit),
                "before": before_report.as_dict(),
                "calibration": args.calibration,
                "after_fit": None if after_fit is None else _fit_dict(after_fit),
                "after": None if after_report is None else after_report.as_dict(),
            }
        )
        return 0
    shown = f", {len(cycles.pose)} reported" if len(cycles.pose) != len(read.pose) else ""
    print(f"ISO 9283 pose characteristics of {args.data} ({len(read.pose)} poses measured{shown})")
    if frame_fit is not None:
        print(
            "best rigid fit of the attained positions onto the commanded ones: "
            f"RMS {frame_fit.rms * 1e3:.4f} mm"
        )
        if frame_fit.tool_rotation is not None:
            angle = np.degrees(np.arccos(np.clip((np.trace(frame_fit.tool_rotation) - 1) / 2, -1, 1)))
            print(f"the measured frame on the tool: a constant rotation of {angle:.3f} deg (fitted)")
    if after_report is not None:
        print("before calibration:")
    print("\n".join(before_report.lines(descriptions)))
    if after_report is not None and after_fit is not None:
        print(
            f"after calibration by {args.calibration} (predicted: commanded + what the calibrated model does "
            f"not explain at the joint readings; rigid fit onto the model: RMS {after_fit.rms * 1e3:.4f} mm):"
        )
        print("\n".join(after_report.lines(descriptions)))
    return 0
