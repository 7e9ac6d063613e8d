"""pincal compensate: the corrected joint targets of a program, for a controller that cannot load a URDF."""

from __future__ import annotations

import argparse

import numpy as np

from pincal.cli import COMMANDS
from pincal.cli._common import (
    add_command,
    add_robot_arguments,
    emit_json,
    parse_configuration,
    parse_floats,
    robot_from_args,
)
from pincal.compensation.calibration_file import load_calibration
from pincal.compensation.compensate import compensate
from pincal.errors import BadArgument, BadPlanFile, warn
from pincal.files import column_mismatch, csv_header, read_numeric_csv
from pincal.model.statics import Payload
from pincal.outputs import atomic_write_text

HELP = COMMANDS["compensate"].help
EXAMPLES = """\
examples:
  pincal compensate kr270 --calibration kr270_cal.urdf --targets program.csv --deg --out corrected.csv
  pincal compensate kr270 --calibration kr270_cal.urdf --targets program.csv --deg --payload 120 \\
      --payload-centre 0,0,0.25 --out corrected.csv
  pincal compensate kr270 --calibration kr270_cal.urdf --targets points.csv --seed-pose=0,-60,60,0,45,0 \\
      --deg --out corrected.csv                          # Cartesian targets x,y,z

PROGRAM.csv holds the program's targets, one per row: either the chain's joints (radians, degrees
with --deg), the configurations the nominal model reaches them with; or the tool positions x,y,z in
the robot's base frame (metres, millimetres with --mm), the tool keeping the orientation it has at
--seed-pose (or at each row's own joint columns, given beside x,y,z). CORRECTED.csv gets the joint
commands whose actual tool pose, under the calibration (CAL.urdf with its sidecar
CAL.calibration.json: geometry, joint offsets, gains, compliances, gravity, residual model) and the
program's payload (--payload KG, its centre in the tool frame --payload-centre X,Y,Z metres), is the
nominal one: send these to the controller. Targets whose command leaves the joint limits, or that
are not reached (a singular configuration), are named in a warning.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "compensate", HELP, EXAMPLES)
    add_robot_arguments(p, params=False)
    p.add_argument(
        "--calibration", required=True, metavar="CAL.urdf", help="the calibrated URDF (with its sidecar)"
    )
    p.add_argument("--targets", required=True, metavar="PROGRAM.csv", help="the program's targets")
    p.add_argument(
        "--out", required=True, metavar="CORRECTED.csv", help="the corrected joint targets to write"
    )
    p.add_argument(
        "--payload", type=float, default=0.0, metavar="KG", help="the program's payload (default 0)"
    )
    p.add_argument("--payload-centre", metavar="X,Y,Z", help="its centre of mass in the tool frame [m]")
    p.add_argument("--seed-pose", metavar="Q", help="Cartesian targets: a configuration near the first one")
    p.add_argument("--deg", action="store_true", help="joint values (read and written) in degrees")
    p.add_argument("--mm", action="store_true", help="Cartesian targets in millimetres")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(run=run)


def _targets(robot, path: str, degrees: bool, millimetres: bool):
    """(targets, cartesian, seeds): joint targets, or tool positions with their per-row seeds (or None)."""
    header, rows, lines = read_numeric_csv(path, what="targets")
    names = robot.joint_names
    position = [c for c in ("x", "y", "z") if c in header]
    joints = [h for h in header if h not in ("x", "y", "z")]
    if position and len(position) != 3:
        raise BadPlanFile(
            f"targets file {path!r}: Cartesian targets need all of x,y,z, got {','.join(position)}"
        )
    if joints and column_mismatch(names, joints):
        raise BadPlanFile(
            f"targets file {path!r}: joint columns must be {','.join(names)}{column_mismatch(names, joints)}"
        )
    q = None
    if joints:
        q = rows[:, [header.index(n) for n in names]]
        q = robot.to_radians(q) if degrees else q
        robot.check_limits(q, [f"targets file {path!r}, line {n}" for n in lines], degrees)
    if not position:
        return q, False, None
    xyz = rows[:, [header.index(c) for c in ("x", "y", "z")]] / (1000.0 if millimetres else 1.0)
    return xyz, True, q


def run(args: argparse.Namespace) -> int:
    nominal = robot_from_args(args)
    deployed = load_calibration(args.calibration, nominal)
    targets, cartesian, seeds = _targets(nominal, args.targets, args.deg, args.mm)
    if cartesian and seeds is None:
        if args.seed_pose is None:
            raise BadArgument("Cartesian targets (x,y,z) need --seed-pose, or joint columns beside x,y,z")
        seeds = parse_configuration(nominal, args.seed_pose, args.deg, "--seed-pose")
    centre = (0.0, 0.0, 0.0)
    if args.payload_centre is not None:
        values = parse_floats(args.payload_centre, "--payload-centre")
        if len(values) != 3:
            raise BadArgument(f"--payload-centre {args.payload_centre!r}: expected X,Y,Z (three numbers)")
        centre = (values[0], values[1], values[2])
    payload = Payload(args.payload, centre)
    result = compensate(
        deployed.robot,
        nominal,
        targets,
        payload=payload,
        residual_model=deployed.residual_model,
        cartesian=cartesian,
        init=seeds,
    )
    commands = nominal.to_degrees(result.commands) if args.deg else result.commands
    rows = "".join(",".join(repr(float(v)) for v in row) + "\n" for row in commands)
    atomic_write_text(args.out, csv_header(nominal.joint_names) + rows)  # a name with a comma quoted
    _warn(result)
    summary = _summary(result, nominal, deployed, payload, cartesian, args)
    if args.json:
        emit_json(summary)
        return 0
    worst = summary["largest_correction"]
    terms = [t for t in ("gains", "compliance", "residual model") if summary["terms"][t]]
    reached = int(np.sum(result.position_error <= REACHED))
    print(
        f"{args.out}: {len(commands)} corrected {'Cartesian ' if cartesian else ''}targets through "
        f"{args.calibration} (geometry{''.join(', ' + t for t in terms)}), payload {payload.mass:g} kg; "
        f"largest correction {worst['value']:.4g} {worst['unit']} ({worst['joint']}, target "
        f"{worst['target']}); {reached} of {len(commands)} reached to 1 µm"
    )
    return 0


REACHED = 1e-6
"""A target is reached when the calibrated model puts the tool within this of it [m]."""


def _summary(result, nominal, deployed, payload, cartesian, args) -> dict:
    change = np.abs(nominal.to_degrees(result.corrections) if args.deg else result.corrections)
    i, j = np.unravel_index(int(np.argmax(change)), change.shape)
    unit = ("deg" if args.deg else "rad") if nominal.revolute[j] else "m"
    return {
        "targets": len(result.commands),
        "cartesian": cartesian,
        "payload_kg": payload.mass,
        "terms": {
            "gains": bool(deployed.robot.joint_gains.any()),
            "compliance": bool(deployed.robot.joint_compliances.any()),
            "residual model": deployed.residual_model is not None,
        },
        "largest_correction": {
            "joint": nominal.joint_names[j],
            "target": int(i),
            "value": float(change[i, j]),
            "unit": unit,
        },
        "position_error_max_m": float(result.position_error.max()),
        "not_reached": [int(k) for k in np.flatnonzero(result.position_error > REACHED)],
        "outside_limits": list(result.outside_limits),
        "out": args.out,
    }


def _warn(result) -> None:
    if result.outside_limits:
        rows = ", ".join(str(i) for i in result.outside_limits[:10])
        warn(
            f"{len(result.outside_limits)} corrected target(s) leave the joint limits (rows {rows}); "
            f"the controller will refuse them"
        )
    missed = np.flatnonzero(result.position_error > REACHED)
    if missed.size:
        rows = ", ".join(str(i) for i in missed[:10])
        warn(f"{missed.size} target(s) not reached to 1 µm (rows {rows}): near a singular configuration?")
