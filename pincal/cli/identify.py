"""pincal identify: geometric errors from measurements, and the calibrated URDF."""

from __future__ import annotations

import argparse
from pathlib import Path

from pincal.calibration.identification import identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.urdf_export import export_urdf
from pincal.cli._common import (
    add_base_argument,
    add_command,
    add_output_arguments,
    add_robot_arguments,
    emit_json,
    parameters_with_base,
    positive,
    robot_from_args,
)
from pincal.errors import IdentificationFailed, OverwriteRefused

HELP = "identify the geometric errors from measurements and write the calibrated URDF"
EXAMPLES = """\
examples:
  pincal identify kr270 --data meas.csv --marker 0.1,0.05,0.2 --out kr270_calibrated.urdf
  pincal identify kr270 --data meas.csv --mm --deg --marker 0.1,0.05,0.2 --json
  pincal identify robots/kr270.urdf --data tracker.csv --base --marker 0.1,0.05,0.2 --out cal.urdf
  pincal identify planar_2r --data meas.csv --params joint2.tx,tip.tx

MEAS.csv: a header row, then one configuration per row: one column per joint, named as in the URDF
(radians; degrees with --deg), and the measured point(s): x,y,z for one marker or x0,y0,z0,x1,y1,z1,...
for several, in the order of --marker (metres; millimetres with --mm). Rows with a missing or
non-numeric cell, NaN, or a joint outside its limits are errors naming the line.
--base: the points are in the instrument's frame, not the robot base frame: the base placement
(base.*) is identified too, starting from a rigid fit, and the chain parameters it makes redundant
are dropped. --out writes the user's URDF with corrected joint origins (joint offsets folded into
them) and the tip's fixed joint corrected; markers and base are reported in an XML comment.
Estimates are errors relative to the nominal URDF (m, rad); text output shows mm and mrad.
Exit code 2 when the data cannot identify the parameters or the fit does not converge.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "identify", HELP, EXAMPLES)
    add_robot_arguments(p)
    p.add_argument("--data", required=True, metavar="MEAS.csv", help="the measurements (format below)")
    p.add_argument("--mm", action="store_true", help="measured coordinates are in millimetres")
    p.add_argument("--deg", action="store_true", help="joint values are in degrees")
    add_base_argument(p)
    p.add_argument(
        "--sigma",
        type=float,
        help="measurement noise per coordinate [m] for the standard errors (default: from the residuals)",
    )
    p.add_argument("--max-iterations", type=int, default=50, help="Gauss-Newton iterations (default 50)")
    p.add_argument("--out", metavar="CALIBRATED.urdf", help="write the calibrated URDF here")
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    robot = robot_from_args(args)
    params, source, dropped = parameters_with_base(robot, args)
    sigma = None if args.sigma is None else positive(args.sigma, "--sigma")
    positive(args.max_iterations, "--max-iterations")
    if args.out:
        for what, path in (("measurement file", args.data), ("robot's URDF", robot.urdf_path)):
            if path is not None and Path(args.out).resolve() == Path(path).resolve():
                raise OverwriteRefused(f"--out {args.out} is the {what}: choose another output path")
    data = MeasurementData.from_csv(args.data, robot, degrees=args.deg, millimetres=args.mm)
    result = identify(params, data, sigma=sigma, max_iterations=args.max_iterations)
    out = export_urdf(result, args.out) if args.out and result.success else None
    if args.json:
        payload = {"robot": robot.name, "tip": robot.tip, "params_source": source, **result.as_dict()}
        payload["dropped_for_base"] = dropped
        payload["out"] = str(out) if out else None
        emit_json(payload)
    if not result.success:
        raise IdentificationFailed(result)
    if args.json:
        return 0
    print(f"{robot.name}: {len(params)} parameters ({source}), {data.m} configurations from {args.data}")
    if dropped:
        print(f"dropped as redundant with the base frame: {', '.join(dropped)}")
    print(result.report())
    kinds = {q.kind for q in params}
    if "marker" in kinds:
        print(f"calibrated markers in {robot.tip} [m]: {result.robot.markers.tolist()}")
    if "base" in kinds:
        base = result.as_dict()["base"]
        print(f"robot base in the instrument frame: xyz {base['xyz']} m, rpy {base['rpy']} rad")
    if out:
        print(f"calibrated URDF written to {out}")
    return 0
