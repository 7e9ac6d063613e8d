"""Safe by default on the command line: --joint-margin, --mount, --clearance and --self-collision, the
constraints with the safe defaults added, and the safety lines of a report."""

from __future__ import annotations

import argparse
import math
import re

from pincal.cli._common import constraints_from_args
from pincal.errors import BadArgument
from pincal.model.robot import Robot
from pincal.planning.constraints import DEFAULT_JOINT_LIMITS, MOUNTS, JointLimits, Mount, with_safety

SAFETY_HELP = """\
Safe by default: a plan keeps 2 degrees inside every joint limit (1 cm on prismatic joints, at most a
tenth of a joint's range; --joint-margin 0 keeps none), for a fixed-base robot the markers, the tip
and every link origin the joints move 5 cm above the plane it is mounted on (--mount floor; none for
a floating base), the robot 5 cm from every obstacle of a workcell (--clearance 5cm: the
uncalibrated robot's error and the marker's size; 0 keeps only what --constraints asks), and the
robot clear of itself when its URDF has collision geometry (design, next and baseline:
--self-collision off when collisions are checked elsewhere). The report names the smallest margin
to a limit, to the floor, to an obstacle and between two links, with the pose.
"""

SELF_COLLISION = ("on", "off")

_VALUE = re.compile(r"^\s*([0-9.eE+-]+)\s*([a-zµ]*)\s*$")
_ANGLES = {"deg": math.pi / 180, "rad": 1.0, "mrad": 1e-3}
_LENGTHS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3}


def add_safety_arguments(parser: argparse.ArgumentParser) -> None:
    """--joint-margin, --mount and --clearance."""
    parser.add_argument(
        "--joint-margin",
        metavar="ANGLE[,LENGTH]",
        help="kept inside every joint limit, e.g. 2deg, 0.05rad, 2deg,5mm (prismatic), 0 for none "
        "(default 2deg,1cm; a bare angle follows --deg)",
    )
    parser.add_argument(
        "--mount",
        metavar="PLANE",
        help=f"plane the robot is mounted on, kept below what the joints move: {', '.join(MOUNTS)} "
        "(z = 0 of the base frame, or none), or NX,NY,NZ,OFFSET (normal.p >= OFFSET, metres) "
        "(default floor; none for a floating base)",
    )
    parser.add_argument(
        "--clearance",
        metavar="LENGTH",
        help="kept from the mounting plane (markers, tip, link origins) and from every obstacle, "
        "e.g. 5cm, 20mm, 0.05 (metres), 0 for only what --constraints asks (default 5cm: the "
        "uncalibrated robot's error and the marker's size)",
    )


def add_self_collision_argument(parser: argparse.ArgumentParser) -> None:
    """--self-collision on|off (the commands that design: design, next, baseline)."""
    parser.add_argument(
        "--self-collision",
        choices=SELF_COLLISION,
        help="keep the robot's links apart (its URDF's collision geometry; on: the default when it "
        "has some), or off for a robot whose collisions are checked elsewhere (the report still "
        "names the two closest links, and says the design did not keep them apart)",
    )


def _number(
    token: str, units: dict[str, float], bare: float, what: str, option: str = "--joint-margin"
) -> float:
    match = _VALUE.match(token)
    try:
        value = float(match.group(1)) if match else math.nan
    except ValueError:
        value = math.nan
    unit = match.group(2) if match else ""
    if not (math.isfinite(value) and value >= 0) or (unit and unit not in units):
        raise BadArgument(
            f"{option} {what}{' ' if what else ''}{token.strip()!r}: expected a number ≥ 0 with a unit "
            f"({', '.join(units)})",
            argument=option,
            value=token,
        )
    return value * (units[unit] if unit else bare)


def parse_clearance(text: str) -> float:
    """``5cm``, ``20mm``, ``0.05`` (metres), ``0``: the clearance [m]."""
    return _number(str(text).lower(), _LENGTHS, 1.0, "", "--clearance")


def parse_joint_margin(text: str, degrees: bool) -> JointLimits:
    """``2deg``, ``2deg,5mm``, ``0.05`` (radians, degrees with --deg), ``0``: a JointLimits."""
    tokens = [t for t in str(text).split(",")]
    if len(tokens) not in (1, 2) or not all(t.strip() for t in tokens):
        raise BadArgument(
            f"--joint-margin {text!r}: expected ANGLE[,LENGTH], e.g. 2deg or 2deg,5mm (0: none)",
            argument="--joint-margin",
            value=text,
        )
    angle = _number(tokens[0].lower(), _ANGLES, math.pi / 180 if degrees else 1.0, "angle")
    if len(tokens) == 1:
        # One value is the angle; prismatic joints keep the default 1 cm, or none with 0.
        return JointLimits(angle, 0.0 if angle == 0 else DEFAULT_JOINT_LIMITS.prismatic)
    return JointLimits(angle, _number(tokens[1].lower(), _LENGTHS, 1.0, "length"))


def safe_constraints_from_args(robot: Robot, args: argparse.Namespace) -> tuple:
    """The constraints of --constraints with the safe defaults (or --joint-margin, --mount,
    --clearance, --self-collision) added."""
    constraints = constraints_from_args(args)
    margin = getattr(args, "joint_margin", None)
    mount = getattr(args, "mount", None)
    given = getattr(args, "clearance", None)
    limits = None if margin is None else parse_joint_margin(margin, getattr(args, "deg", False))
    plane = None if mount is None else Mount.parse(mount)
    clearance = None if given is None else parse_clearance(given)
    switch = getattr(args, "self_collision", None)
    itself = None if switch is None else switch == "on"
    try:
        return with_safety(robot, constraints, limits, plane, clearance=clearance, self_collision=itself)
    except BadArgument as exc:
        option = {
            "joint_margin": "--joint-margin",
            "clearance": "--clearance",
            "self_collision": "--self-collision",
        }.get(str(exc.argument), "--mount")
        raise BadArgument(
            f"{option} and the --constraints file both give it: keep one", argument=option
        ) from None
