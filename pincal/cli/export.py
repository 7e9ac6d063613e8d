"""pincal export: a calibration (CAL.urdf or CAL.xml and its sidecar) written in another format."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Callable
from pathlib import Path

from pincal.calibration.mjcf_export import export_mjcf
from pincal.calibration.urdf_export import sidecar_path
from pincal.cli import COMMANDS
from pincal.cli._common import add_command, add_output_arguments, emit_json
from pincal.compensation.calibration_file import DeployedCalibration, load_calibration
from pincal.errors import BadArgument, OverwriteRefused
from pincal.files import read_text
from pincal.model.loading import load_robot

HELP = COMMANDS["export"].help
EXAMPLES = """\
examples:
  pincal identify kr270 --data meas.csv --marker 0.1,0.05,0.2 --out cal.urdf
  pincal export cal.urdf --format mjcf --out cal_mujoco.xml      # the calibration for MuJoCo

The calibration is a calibrated robot file and its sidecar (CAL.calibration.json: tip, markers,
base, gains, residual model), as 'pincal identify --out' writes them. Formats:
  mjcf   MuJoCo XML: every link a body (fixed links kept as bodies, unlike MuJoCo's own URDF import,
         which also drops <calibration>), hinges and slides with their limits as range, angles in
         radians, the markers as sites pincal_marker<k> on the tip, the base as the root body's
         placement; a sidecar OUT.calibration.json beside it. Read back with Pinocchio, it must
         reproduce the calibration's points to 1e-9 m before it is written (atomically, never
         over an input).
"""


def _mjcf(calibration: DeployedCalibration, out: Path) -> Path:
    return export_mjcf(calibration.robot, out, source=calibration.urdf, sidecar_content=calibration.sidecar)


FORMATS: dict[str, Callable[[DeployedCalibration, Path], Path]] = {"mjcf": _mjcf}
"""``{format: writer}``: each writer takes the calibration
(:class:`~pincal.compensation.calibration_file.DeployedCalibration`) and the output path, writes
the file (and what goes with it) and returns the path written."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "export", HELP, EXAMPLES)
    p.add_argument(
        "calibration", metavar="CAL.urdf", help="the calibrated robot file (its sidecar beside it)"
    )
    p.add_argument("--format", required=True, choices=sorted(FORMATS), help="the format to write")
    p.add_argument("--out", required=True, metavar="FILE", help="the file to write")
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
    try:
        tip = json.loads(read_text(side, "sidecar", BadArgument)).get("tip")
    except (json.JSONDecodeError, AttributeError):
        raise BadArgument(f"{side}: not a pincal sidecar (a JSON object with a 'tip')") from None
    return load_calibration(path, load_robot(path, tip=tip if isinstance(tip, str) else None))


def run(args: argparse.Namespace) -> int:
    if sidecar_path(args.out).resolve() == sidecar_path(args.calibration).resolve():
        raise OverwriteRefused(
            f"--out {args.out} would write its sidecar over the calibration's own "
            f"({sidecar_path(args.calibration).name}): choose another name"
        )
    calibration = read_calibration(args.calibration)
    written = FORMATS[args.format](calibration, Path(args.out))
    robot = calibration.robot
    if args.json:
        emit_json(
            {
                "format": args.format,
                "out": str(written),
                "sidecar": str(sidecar_path(written)),
                "tip": robot.tip,
                "joints": list(robot.joint_names),
            }
        )
        return 0
    print(
        f"wrote {written} ({args.format}) and {sidecar_path(written).name}: {robot.name}, "
        f"{robot.nq} joints to {robot.tip}; checked: it reproduces the calibration's points to 1e-9 m"
    )
    return 0
