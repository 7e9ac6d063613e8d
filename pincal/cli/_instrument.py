"""What the CLI commands share about the instrument: what it measures (--measure, --anchor,
--camera) and how well (--sigma, --sigma-rot, --sigma-px, --instrument tracker, --instrument-at,
--tracker-sigma)."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from pincal.arguments import DEFAULT_SIGMA
from pincal.cli._common import parse_floats
from pincal.errors import BadArgument
from pincal.instruments.distance import Distance, anchors
from pincal.instruments.error_model import (
    DEFAULT_SIGMA_PX,
    DEFAULT_SIGMA_ROT,
    TRACKER_RADIAL,
    TRACKER_TRANSVERSE,
    ErrorModel,
    PerCoordinate,
    Tracker,
)
from pincal.instruments.instrument import Instrument, orientation_length_of
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.instruments.pose import Pose, partial_from_text
from pincal.instruments.rig import Rig, load_rig
from pincal.model.fixtures import Fixture
from pincal.model.robot import Robot

KINDS = ("point", "pose", "distance", "image")
"""Names --measure takes (beside the components of a partial pose)."""

INSTRUMENT_HELP = f"""\
What is measured (--measure): point (the default: x,y,z of each --marker), pose (x,y,z and qx,qy,qz,qw
or rx,ry,rz of each marker's frame: motion capture, a 6-DoF probe), the components of a pose measured
(z for a height gauge, x,y for a probe on a plane; per marker x,y/z), distance (d, d0,d1,...: draw-wires
or a ballbar from marker 0 to each --anchor X,Y,Z, the anchors identified with the robot) or image
(the pixels u0,v0,u1,... of a target's points seen by a camera: --camera RIG.yaml gives the camera's
intrinsics, its target and where both are, eye-in-hand or eye-to-hand; both placements are identified).
A data file's columns say what it holds. How well (--instrument): per coordinate, --sigma [m],
--sigma-rot [rad] (default {DEFAULT_SIGMA_ROT:g}), --sigma-px (default {DEFAULT_SIGMA_PX:g}); or
'--instrument tracker --instrument-at X,Y,Z': a laser tracker there, radial sigma a + b*d along its beam
and transverse c + e*d across it at distance d, --tracker-sigma A,B,C,E [m, m/m] (default half the
Leica AT500's MPE: {",".join(f"{v:g}" for v in TRACKER_RADIAL + TRACKER_TRANSVERSE)})."""


def add_instrument_arguments(
    parser: argparse.ArgumentParser, measure: bool = True, test_pose: bool = False
) -> None:
    """--measure (when ``measure``), --anchor, --camera, --sigma-rot, --sigma-px, --instrument,
    --instrument-at, --tracker-sigma; --orientation-length with ``test_pose``."""
    if test_pose:
        parser.add_argument(
            "--orientation-length",
            type=float,
            metavar="L",
            help="rho0 also counts the tool's orientation error at the test pose, times this lever [m]",
        )
    if measure:
        parser.add_argument(
            "--measure",
            metavar="KIND",
            help="what the instrument measures: point (default), pose, distance, image, or the components "
            "of a pose measured (z; x,y; per marker x,y/z)",
        )
    parser.add_argument(
        "--anchor",
        action="append",
        metavar="X,Y,Z",
        help="nominal position of a draw-wire's or ballbar's fixed end in the instrument frame [m], "
        "identified with the robot (distance measurements); repeat for several",
    )
    parser.add_argument(
        "--camera", metavar="RIG.yaml", help="a camera, its target and where they are (image measurements)"
    )
    parser.add_argument("--sigma-rot", type=float, metavar="RAD", help="orientation noise of poses [rad]")
    parser.add_argument("--sigma-px", type=float, metavar="PX", help="pixel noise of images [px]")
    parser.add_argument(
        "--instrument", metavar="NAME", help="the instrument's error model: tracker (at --instrument-at)"
    )
    parser.add_argument(
        "--instrument-at", metavar="X,Y,Z", help="the tracker's position in the instrument frame [m]"
    )
    parser.add_argument(
        "--tracker-sigma", metavar="A,B,C,E", help="tracker radial a + b*d, transverse c + e*d [m, m/m]"
    )


def rig_from_args(args: argparse.Namespace) -> Rig | None:
    """The camera rig of --camera, or None."""
    return load_rig(args.camera) if getattr(args, "camera", None) else None


def robot_with_fixtures(robot: Robot, args: argparse.Namespace) -> Robot:
    """``robot`` with the fixtures of --anchor and --camera (their nominal placements)."""
    fixtures: list[Fixture] = []
    if getattr(args, "anchor", None):
        points = [parse_floats(text, "--anchor") for text in args.anchor]
        if any(len(p) != 3 for p in points):
            raise BadArgument("--anchor: expected X,Y,Z (three numbers, metres)", argument="--anchor")
        fixtures += anchors(*points)
    rig = rig_from_args(args)
    if rig is not None:
        fixtures += rig.fixtures
    return robot.with_fixtures(*fixtures) if fixtures else robot


def kind_from_args(args: argparse.Namespace, robot: Robot) -> Kind | None:
    """The kind of --measure (with --anchor, --camera); None when nothing says (points, or a data
    file's columns)."""
    name = getattr(args, "measure", None)
    rig = rig_from_args(args)
    if name is None:
        name = "image" if rig is not None else "distance" if getattr(args, "anchor", None) else None
    if name is None:
        return None
    name = name.strip()
    if name == "point":
        return Point()
    if name == "pose":
        return Pose()
    if name == "distance":
        if not getattr(args, "anchor", None):
            raise BadArgument("--measure distance needs the anchors: --anchor X,Y,Z (one per draw-wire)")
        return Distance.to_anchors(len(args.anchor))
    if name == "image":
        if rig is None:
            raise BadArgument("--measure image needs the camera: --camera RIG.yaml")
        return rig.kind
    try:
        return partial_from_text(name)
    except BadArgument:
        raise BadArgument(
            f"--measure {name!r}: valid: {', '.join(KINDS)}, or components of a pose among x,y,z,rx,ry,rz "
            f"(z; x,y; per marker x,y/z)",
            argument="--measure",
            value=name,
        ) from None


def error_from_args(args: argparse.Namespace, sigma: float | None) -> ErrorModel | None:
    """The error model of --instrument, --sigma-rot, --sigma-px with the checked --sigma ``sigma``
    (None: not given); None when only --sigma (or nothing) is given (one σ per coordinate, as
    always)."""
    rig = rig_from_args(args)
    sigma_rot = _positive(getattr(args, "sigma_rot", None), "--sigma-rot", DEFAULT_SIGMA_ROT)
    sigma_px = _positive(
        getattr(args, "sigma_px", None), "--sigma-px", rig.pixel_sigma if rig else DEFAULT_SIGMA_PX
    )
    name = getattr(args, "instrument", None)
    if name is None:
        if getattr(args, "instrument_at", None) or getattr(args, "tracker_sigma", None):
            raise BadArgument(
                "--instrument-at and --tracker-sigma describe a tracker: add --instrument tracker"
            )
        if (
            getattr(args, "sigma_rot", None) is None
            and getattr(args, "sigma_px", None) is None
            and rig is None
        ):
            return None
        return PerCoordinate(DEFAULT_SIGMA if sigma is None else sigma, sigma_rot, sigma_px)
    if name.strip() != "tracker":
        raise BadArgument(f"--instrument {name!r}; valid: tracker", argument="--instrument", value=name)
    at = (0.0, 0.0, 0.0)
    if getattr(args, "instrument_at", None):
        xyz = parse_floats(args.instrument_at, "--instrument-at")
        if len(xyz) != 3:
            raise BadArgument(
                "--instrument-at: expected X,Y,Z (three numbers, metres)", argument="--instrument-at"
            )
        at = (xyz[0], xyz[1], xyz[2])
    radial, transverse = TRACKER_RADIAL, TRACKER_TRANSVERSE
    if getattr(args, "tracker_sigma", None):
        values = parse_floats(args.tracker_sigma, "--tracker-sigma")
        if len(values) != 4:
            raise BadArgument(
                "--tracker-sigma: expected A,B,C,E (radial a + b*d, transverse c + e*d; m, m/m)"
            )
        radial, transverse = (values[0], values[1]), (values[2], values[3])
    if sigma is not None:
        raise BadArgument(
            "--sigma is the per-coordinate model: with --instrument tracker give --tracker-sigma"
        )
    return Tracker(at, radial, transverse, sigma_rot)


NOISE_RANGE = (1e-12, 1e6)
"""What an orientation noise [rad] or a pixel noise [px] may be: beyond, whitening by it overflows
(--sigma-rot 1e-320 gave an internal error), and no instrument is that exact or that poor."""


def _positive(value: float | None, name: str, default: float) -> float:
    if value is None:
        return default
    low, high = NOISE_RANGE
    if not (np.isfinite(value) and low <= value <= high):
        raise BadArgument(
            f"{name} must be a positive number from {low:g} to {high:g}, got {value}",
            argument=name,
            value=value,
        )
    return float(value)


def instrument_from_args(args: argparse.Namespace, kind: Kind | None, sigma: float | None) -> Instrument:
    """The instrument: ``kind`` (points when None), the error model of the arguments with the
    checked --sigma ``sigma`` (None: not given; the default per coordinate)."""
    error = error_from_args(args, sigma)
    if error is None:
        error = PerCoordinate(DEFAULT_SIGMA if sigma is None else sigma)
    return Instrument(Point() if kind is None else kind, error)


@dataclass(frozen=True, eq=False)
class Measuring:
    """What a command's plan is measured with, from its arguments.

    Attributes:
        robot: the robot with the instrument's fixtures (--anchor, --camera).
        instrument: what is measured and how well (points with --sigma by default).
        options: ``instrument=`` and ``orientation_length=`` for the core's functions: empty for
            points with one σ and no orientation (their calls take ``sigma=``, as they always
            did: :func:`with_sigma`).
        text: the instrument in words for the report, or "" for points with one σ.
    """

    robot: Robot
    instrument: Instrument
    options: dict
    text: str


def measuring_from_args(args: argparse.Namespace, robot: Robot, sigma: float | None) -> Measuring:
    """The :class:`Measuring` of the instrument arguments, ``sigma`` the checked --sigma (or None)."""
    robot = robot_with_fixtures(robot, args)
    kind = kind_from_args(args, robot)
    error = error_from_args(args, sigma)
    instrument = instrument_from_args(args, kind, sigma)
    options: dict = {}
    if (kind is not None and not isinstance(kind, Point)) or error is not None:
        options["instrument"] = instrument
    length = getattr(args, "orientation_length", None)
    if length is not None:
        options["orientation_length"] = orientation_length_of(length)
    text = "" if instrument.is_default and not options else instrument.describe(robot)
    if length is not None:
        text += f"; rho0 counts the tool's orientation error times L = {length:g} m"
    return Measuring(robot, instrument, options, text.lstrip("; "))


def with_sigma(sigma: float, options: dict) -> dict:
    """The keywords of what is measured for the core's functions: a :class:`Measuring`'s
    ``options``, and ``sigma=`` (the checked --sigma, or the default) when they name no instrument
    (the core refuses both: an instrument's error model has its own σ)."""
    return dict(options) if "instrument" in options else dict(options, sigma=sigma)
