"""pincal export: a calibration (CAL.urdf or CAL.xml and its sidecar) written in another format."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Callable
from pathlib import Path

from pincal.calibration.corrections import corrections_of, corrections_yaml, source_of
from pincal.cli import COMMANDS
from pincal.cli._common import add_command, add_output_arguments, emit_json
from pincal.compensation.calibration_file import DeployedCalibration, load_calibration, sidecar_tip
from pincal.errors import BadArgument, OverwriteRefused
from pincal.export.mjcf import export_mjcf
from pincal.export.ros import robot_calibration_text, ros2_control_text
from pincal.export.sdf import export_sdf
from pincal.export.urdf import export_urdf, sidecar_path
from pincal.export.xacro import corrections_path, export_xacro
from pincal.model.loading import load_robot
from pincal.outputs import atomic_write_text

HELP = COMMANDS["export"].help
EXAMPLES = """\
examples:
  pincal identify kr270 --data meas.csv --marker 0.1,0.05,0.2 --out cal.urdf
  pincal export cal.urdf --format mjcf --out cal_mujoco.xml      # the calibration for MuJoCo
  pincal export cal.urdf --format yaml --out cal.yaml            # corrections of the kr270's URDF
  pincal export cal.urdf --format ros2_control --out cal_offsets.xml
  pincal export cal.urdf --format sdf --out cal.sdf              # the calibration for Gazebo

For a xacro description that reads its joint origins from a kinematics YAML (ur_description does):
  pincal export cal.urdf --format xacro --out cal.urdf.xacro     # an overlay, the description unchanged

The calibration is a calibrated robot file and its sidecar (CAL.calibration.json: tip, markers,
base, gains, residual model, the description it was made from), as 'pincal identify --out' writes
them; --source names that description when the sidecar does not (older sidecars). Formats
(docs/method.md 5.8-5.10):
  urdf   the calibrated URDF (the source's own file, the corrected origins written in, joint
         offsets folded into them) and its sidecar, as 'pincal identify --out' writes it.
  yaml   the corrections of the unchanged source: per joint the calibrated origin (x y z roll
         pitch yaw) with the offset folded in ('kinematics'; ur_description's layout for a UR arm)
         and without it, the offset and the gain; the tool's joint, markers and base. Read by a
         xacro description through xacro.load_yaml (see xacro).
  xacro  an overlay: OUT includes your description unchanged and hands it BASE.corrections.yaml
         through the argument kinematics_params (and kinematics_parameters_file,
         kinematics_params_file); for a description that reads its joint origins from such a file,
         as UR's ur_description does ('ros2 launch ... kinematics_params:=BASE.corrections.yaml' works
         too). Expanded with xacro, it must reproduce the calibration to 1e-9 m at 100
         configurations, or nothing is written (a description with literal origins cannot be
         overridden by a wrapper: use urdf). A sidecar OUT.calibration.json beside it.
  ros2_control  the joint offsets as ros2_control transmissions (<offset>, and the factor on your
         <mechanical_reduction> for a gain) and as URDF <calibration rising="...">, to use with the
         origins without the offsets (yaml's joints.*.origin).
  robot_calibration  ROS robot_calibration's offsets file: JOINT: offset, and each origin's
         correction as JOINT_x/_y/_z, JOINT_a/_b/_c (angle-axis), origin' = origin * offset.
  mjcf   MuJoCo XML: every link a body (fixed links kept as bodies, unlike MuJoCo's own URDF import,
         which also drops <calibration>), hinges and slides with their limits as range, angles in
         radians, the markers as sites pincal_marker<k> on the tip, the base as the root body's
         placement; a sidecar OUT.calibration.json beside it. Read back with Pinocchio, it must
         reproduce the calibration's points to 1e-9 m before it is written (atomically, never
         over an input).
  sdf    SDFormat 1.9 (Gazebo): a <model>, every link and joint, each pose <pose relative_to=...>
         (a joint's to its parent link, a link's to its joint), joint offsets folded into the
         joint poses (SDF has no <calibration>), limits kept, the markers as <frame>s
         pincal_marker<k> attached to the tip, the base as the model's <pose>. Read back, its
         frames must reproduce the calibration's points to 1e-9 m before it is written (gains and
         compliances have no SDF element: in its comment, with a warning).
"""


def _mjcf(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    return export_mjcf(calibration.robot, out, source=calibration.urdf, sidecar_content=calibration.sidecar)


def _corrections(calibration: DeployedCalibration, source: str | None):
    path = source_of(calibration.sidecar, calibration.urdf, source)
    return corrections_of(calibration.robot, calibration.sidecar, path)


def _sdf(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    return export_sdf(calibration.robot, out, source=calibration.urdf)


def _urdf(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    given = (
        source_of(calibration.sidecar, calibration.urdf, source)
        if source or "source" in calibration.sidecar
        else None
    )
    written = export_urdf(
        calibration.robot,
        out,
        source_urdf=given if given is not None else calibration.urdf,
        write_sidecar=False,
    )
    content = dict(calibration.sidecar, urdf=written.name)
    atomic_write_text(sidecar_path(written), json.dumps(content, indent=2, allow_nan=False) + "\n")
    return written


def _yaml(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    return atomic_write_text(out, corrections_yaml(_corrections(calibration, source)))


def _xacro(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    return export_xacro(_corrections(calibration, source), out, calibration.sidecar)


def _ros2_control(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    return atomic_write_text(out, ros2_control_text(_corrections(calibration, source)))


def _robot_calibration(calibration: DeployedCalibration, out: Path, source: str | None) -> Path:
    return atomic_write_text(out, robot_calibration_text(_corrections(calibration, source)))


FORMATS: dict[str, Callable[[DeployedCalibration, Path, str | None], Path]] = {
    "mjcf": _mjcf,
    "robot_calibration": _robot_calibration,
    "ros2_control": _ros2_control,
    "sdf": _sdf,
    "urdf": _urdf,
    "xacro": _xacro,
    "yaml": _yaml,
}
"""``{format: writer}``: each writer takes the calibration
(:class:`~pincal.compensation.calibration_file.DeployedCalibration`), the output path and the
``--source`` given (or None), writes the file (and what goes with it) and returns the path
written."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "export", HELP, EXAMPLES)
    p.add_argument(
        "calibration", metavar="CAL.urdf", help="the calibrated robot file (its sidecar beside it)"
    )
    p.add_argument("--format", required=True, choices=sorted(FORMATS), help="the format to write")
    p.add_argument("--out", required=True, metavar="FILE", help="the file to write")
    p.add_argument(
        "--source",
        metavar="ROBOT.urdf",
        help="the URDF or xacro description the calibration was made from (default: the sidecar's "
        "'source'); the corrections are relative to it",
    )
    add_output_arguments(p)
    p.set_defaults(run=run)


def read_calibration(path: str | os.PathLike) -> DeployedCalibration:
    """The calibration ``path`` and its sidecar (:func:`~pincal.compensation.load_calibration`,
    for the chain to the sidecar's tip)."""
    side = sidecar_path(path)
    if not side.is_file():
        raise BadArgument(
            f"the calibration's sidecar {str(side)!r} is missing: 'pincal identify --out' writes it beside "
            "the calibrated file",
            argument="CAL.urdf",
        )
    return load_calibration(path, load_robot(path, tip=sidecar_tip(side)))


def run(args: argparse.Namespace) -> int:
    sidecar_written = args.format in WITH_SIDECAR
    if sidecar_written and sidecar_path(args.out).resolve() == sidecar_path(args.calibration).resolve():
        raise OverwriteRefused(
            f"--out {args.out} would write its sidecar over the calibration's own "
            f"({sidecar_path(args.calibration).name}): choose another name"
        )
    calibration = read_calibration(args.calibration)
    written = FORMATS[args.format](calibration, Path(args.out), args.source)
    robot = calibration.robot
    beside = [sidecar_path(written)] if sidecar_written else []
    if args.format == "xacro":
        beside.insert(0, corrections_path(written))
    if args.json:
        emit_json(
            {
                "format": args.format,
                "out": str(written),
                "sidecar": str(beside[-1]) if beside else None,
                "also": [str(path) for path in beside],
                "tip": robot.tip,
                "joints": list(robot.joint_names),
            }
        )
        return 0
    checked = CHECKED.get(args.format, "")
    also = f" and {', '.join(path.name for path in beside)}" if beside else ""
    print(f"wrote {written} ({args.format}){also}: {robot.name}, {robot.nq} joints to {robot.tip}{checked}")
    return 0


WITH_SIDECAR = ("mjcf", "urdf", "xacro")
"""The formats written with a sidecar beside them."""
CHECKED = {
    "mjcf": "; checked: it reproduces the calibration's points to 1e-9 m",
    "sdf": "; checked: its marker frames reproduce the calibration's points to 1e-9 m",
    "urdf": "; checked: it reproduces the calibration's points to 1e-9 m",
    "xacro": "; checked: expanded with xacro, it reproduces the calibration's points to 1e-9 m",
}
