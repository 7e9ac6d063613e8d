"""What the CLI commands share: robot options, parsing of joint values, output."""

from __future__ import annotations

import argparse
import difflib
import importlib.util
import json
import os
import sys
import warnings
from collections.abc import Callable
from contextlib import contextmanager

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, joint_range, positive_sigma, sigma_note
from pincal.calibration.formats.robot_calibration import BAG_SUFFIXES, ROS_EXTRA
from pincal.cli._parameters import DEFAULT_PARAMS
from pincal.errors import BadArgument, BadConfiguration, MissingDependency, warn
from pincal.model.loading import load_robot
from pincal.model.robot import Robot
from pincal.optional import require
from pincal.outputs import check_output
from pincal.planning.constraints import load_constraints
from pincal.planning.plan import Plan
from pincal.viewing.plots import PLOT_EXTRA, figure_format

# NumPy's floating-point warnings, and the NaN of its reductions over nothing. In the CLI they
# raise: a computation that overflows stops with one line instead of printing a warning and going
# on with inf or NaN. Code that computes with inf on purpose says so with np.errstate.
FLOATING_POINT_WARNINGS = (
    r"(overflow|underflow|invalid value|divide by zero) encountered in"
    r"|Mean of empty slice|Degrees of freedom <= 0"
)


def trap_floating_point_warnings() -> None:
    """In the current warnings context, NumPy's floating-point RuntimeWarnings raise."""
    warnings.filterwarnings("error", message=FLOATING_POINT_WARNINGS, category=RuntimeWarning)


@contextmanager
def recorded_warnings():
    """``warnings.catch_warnings(record=True)`` (every warning recorded, to print later) in which
    NumPy's floating-point warnings still raise."""
    with warnings.catch_warnings(record=True) as records:
        warnings.simplefilter("always")
        trap_floating_point_warnings()
        yield records


# Options whose value may start with "-" (negative numbers): "--test-pose -45,20" is rewritten
# "--test-pose=-45,20" before argparse sees it; every other long option that takes one value is
# too (join_negative_values is given them from the parser), "--gravity -9.81,0,0" among them.
VALUE_OPTIONS = (
    "--test-pose",
    "--marker",
    "--base-pose",
    "--instrument",
    "--around",
    "--test-box",
    "--instrument-at",
    "--anchor",
    "--place-instrument",
)


# Options naming a file pincal writes ("figure": an image whose format is its suffix). Every other
# option or argument naming an existing file is an input, which no output may replace.
OUTPUT_OPTIONS = {
    "out": "file",
    "html": "file",
    "save_true": "file",
    "plot": "figure",
    "accuracy_plot": "figure",
    "campaign_plot": "figure",
    "placement_plot": "figure",
}


FIGURE_NOTE = '; needs matplotlib: pip install "pincal[plot]"'
"""Ends the help of every figure option (--plot, --accuracy-plot)."""


def check_outputs(args: argparse.Namespace, names: dict[str, str]) -> None:
    """Refuse, before any work, an option whose optional package is missing
    (:func:`check_optional_packages`) and warn of a value in the wrong unit
    (:func:`warn_about_units`); then refuse an output that is an input, another output, a folder or
    special file, in a missing or unwritable folder, or a figure of an unknown format.

    ``names`` maps each argument's dest to what the user typed ('--plan', 'ROBOT').
    """
    check_optional_packages(args, names)
    warn_about_units(args)
    values = vars(args)
    outputs = [(dest, values[dest]) for dest in OUTPUT_OPTIONS if values.get(dest) is not None]
    inputs = []
    for dest, value in values.items():
        if dest in OUTPUT_OPTIONS:
            continue
        for v in value if isinstance(value, list) else [value]:
            if isinstance(v, str) and os.path.isfile(v):
                inputs.append(("the robot's URDF" if dest == "robot" else f"the input {names[dest]}", v))
    for i, (dest, path) in enumerate(outputs):
        earlier = [(f"the output {names[d]}", p) for d, p in outputs[:i]]
        check_output(path, names[dest], inputs + earlier)
        if OUTPUT_OPTIONS[dest] == "figure":
            figure_format(path, f"{names[dest]} (a figure)")


GP_EXTRA = "pincal[gp]"
"""The pip requirement that brings scikit-learn (the residual model's fit)."""

XACRO_EXTRA = "pincal[xacro]"
"""The pip requirement that brings xacro (expanding .xacro robots and cells without ROS)."""


def check_optional_packages(args: argparse.Namespace, names: dict[str, str]) -> None:
    """Refuse, before any work, an option that needs a package pincal does not require: a figure
    (matplotlib, checked with the outputs' formats), ``--residual-model gp`` (scikit-learn), a
    scene (``show``, ``--html``: meshcat), a ``.xacro`` input (xacro) and a ROS bag input (``.db3``,
    ``.mcap``, ``.bag``: rosbags). One line names the option
    and the pip command, rather than an internal error after the work.

    Raises:
        MissingDependency: the package an option needs is not installed.
    """
    values = vars(args)
    for dest, kind in OUTPUT_OPTIONS.items():
        if kind == "figure" and values.get(dest) is not None:
            require("matplotlib.pyplot", f"{names[dest]} (a figure)", PLOT_EXTRA)
    if values.get("residual_model") == "gp":
        require("sklearn.gaussian_process", "--residual-model gp", GP_EXTRA)
    if values.get("command") == "show":
        require("meshcat", "pincal show", "meshcat")
    elif values.get("html") is not None:
        require("meshcat", f"{names['html']} (a meshcat scene)", "meshcat")
    for dest, value in values.items():
        for v in value if isinstance(value, list) else [value]:
            xacro = isinstance(v, str) and v.lower().endswith(".xacro") and os.path.isfile(v)
            if xacro and dest not in OUTPUT_OPTIONS:
                _require_xacro(f"{names.get(dest, dest)} {v}")
            bag = isinstance(v, str) and v.lower().endswith(BAG_SUFFIXES) and os.path.exists(v)
            if bag and dest not in OUTPUT_OPTIONS:
                require("rosbags", f"{names.get(dest, dest)} {v} (a ROS bag)", ROS_EXTRA)


SIGMA_LIKE_MILLIMETRES = 1e-3
"""A --sigma [m] from this up (1 mm per coordinate) looks like millimetres typed as metres."""


def warn_about_units(args: argparse.Namespace) -> None:
    """Warn of a value that looks typed in the wrong unit: ``--sigma`` of 1 mm or more (a laser
    tracker's 0.03 mm typed as ``--sigma 0.03`` is 30 mm)."""
    sigma = getattr(args, "sigma", None)
    if isinstance(sigma, float) and sigma >= SIGMA_LIKE_MILLIMETRES:
        warn(
            f"--sigma {sigma:g} is {fmt_length(sigma)} per coordinate, which looks like millimetres: "
            f"--sigma is in metres (a laser tracker's 0.03 mm is --sigma 3e-5)"
        )


def _require_xacro(feature: str) -> None:
    """MissingDependency naming ``feature`` when the xacro package cannot be found."""
    try:
        installed = importlib.util.find_spec("xacro") is not None
    except (ImportError, ValueError, AttributeError):  # sys.modules["xacro"] is None: absent
        installed = False
    if not installed:
        raise MissingDependency(
            f"{feature} is a xacro file: pincal expands it (without ROS) once the xacro package is "
            f'installed: pip install "{XACRO_EXTRA}"'
        )


def argument_names(parser: argparse.ArgumentParser) -> dict[str, str]:
    """{dest: '--option' or 'METAVAR'} of a (sub)command's arguments."""
    return {
        a.dest: a.option_strings[-1] if a.option_strings else str(a.metavar or a.dest.upper())
        for a in parser._actions
    }


def join_negative_values(argv: list[str], parser: argparse.ArgumentParser | None = None) -> list[str]:
    """Glue a long option that takes a value (those in VALUE_OPTIONS, and with ``parser`` every long
    option of it that takes one value) to a following value that starts with '-' and a digit or a
    point: argparse reads '-9.81,0,0' as an option, not as the value of '--gravity'."""
    takes_value = set(VALUE_OPTIONS)
    if parser is not None:
        takes_value |= {
            o for a in parser._actions if a.nargs is None for o in a.option_strings if o.startswith("--")
        }
    out: list[str] = []
    i = 0
    while i < len(argv):
        arg = argv[i]
        if arg in takes_value and i + 1 < len(argv):
            nxt = argv[i + 1]
            if len(nxt) > 1 and nxt[0] == "-" and (nxt[1].isdigit() or nxt[1] == "."):
                out.append(f"{arg}={nxt}")
                i += 2
                continue
        out.append(arg)
        i += 1
    return out


def add_command(
    sub: argparse._SubParsersAction, name: str, help: str, examples: str
) -> argparse.ArgumentParser:
    """A subcommand parser whose --help ends with ``examples`` (kept as written)."""
    parser = sub.add_parser(
        name,
        help=help,
        description=help + ".",
        epilog=examples,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.parse_known_args = _suggesting(parser)  # the subcommand parser refuses a near-miss
    return parser


def _suggesting(parser: argparse.ArgumentParser) -> Callable[..., tuple[argparse.Namespace, list[str]]]:
    """``parser.parse_known_args`` that refuses an unknown option close to one of the command's
    (``--markers``, ``--sigmas``) in one line naming it: ``unrecognized arguments: --markers
    0.1,0.05,0.2 (did you mean --marker?)``. Other leftovers go on to the top-level parser as
    argparse leaves them."""
    parse = parser.parse_known_args

    def parse_known_args(args=None, namespace=None):
        namespace, extras = parse(args, namespace)
        hints = [h for h in (close_option(parser, a) for a in extras) if h]
        if hints:
            parser.error(f"unrecognized arguments: {' '.join(extras)} ({'; '.join(hints)})")
        return namespace, extras

    return parse_known_args


def close_option(parser: argparse.ArgumentParser, arg: str) -> str:
    """``'did you mean --marker?'`` for an unknown option ``arg`` close to one of ``parser``'s
    (difflib's ratio ≥ 0.75), or ''."""
    if not arg.startswith("--"):
        return ""
    typed = arg.split("=", 1)[0]
    known = [o for a in parser._actions for o in a.option_strings if o.startswith("--")]
    close = difflib.get_close_matches(typed, known, n=1, cutoff=0.75)
    return f"did you mean {close[0]}?" if close and close[0] != typed else ""


def add_test_pose_argument(parser: argparse.ArgumentParser, required: bool = True) -> None:
    """--test-pose Q0, repeatable (parsed by :func:`test_poses_from_args`)."""
    parser.add_argument(
        "--test-pose",
        action="append",
        required=required,
        metavar="Q0",
        help="comma-separated joint values of a test pose; repeat for several",
    )


def add_robot_arguments(parser: argparse.ArgumentParser, params: bool = True) -> None:
    """ROBOT, --tip, --marker (and --params)."""
    parser.add_argument(
        "robot",
        metavar="ROBOT",
        help="URDF path, shipped robot (kr270, planar_2r) or example-robot-data name (ur10, panda, ...)",
    )
    parser.add_argument(
        "--tip",
        help="tip frame carrying the markers (default: the robot's one chain end, a hand rather than "
        "its fingers; 'pincal robots NAME' lists the candidates)",
    )
    parser.add_argument(
        "--root",
        metavar="LINK",
        help="link the chain starts from, held fixed in front of the instrument (default: the URDF's "
        "root link, or the floating body); not identify's --base, which adds base-frame parameters",
    )
    parser.add_argument(
        "--joint-range",
        action="append",
        metavar="NAME=LO,HI",
        help="range joint NAME moves in during the experiment, radians or metres (degrees with the "
        "command's --deg), "
        "replacing its URDF limits; continuous joints default to one turn, -pi,pi; repeatable",
    )
    parser.add_argument(
        "--package-dir",
        action="append",
        metavar="NAME=PATH",
        help="folder of ROS package NAME, for package://NAME/ mesh paths and a xacro's $(find NAME) "
        "(default: searched above the URDF); repeatable",
    )
    parser.add_argument(
        "--marker",
        action="append",
        metavar="X,Y,Z",
        help="measured point in the tip frame, metres; repeat for several (default: the tip origin)",
    )
    parser.add_argument(
        "--gravity",
        metavar="GX,GY,GZ",
        help="gravity in the robot's base frame [m/s^2], for joint compliance (default 0,0,-9.81: the "
        "base's -z; give it for a tilted, wall or ceiling mount)",
    )
    if params:
        parser.add_argument(
            "--params",
            metavar="SPEC",
            help="parameters: groups (offsets, lengths, full, base, markers, gains, compliance) and/or "
            f"names, comma-separated (default: the identifiable base set of {DEFAULT_PARAMS})",
        )


def add_output_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")


def add_progress_argument(parser: argparse.ArgumentParser) -> None:
    """--progress / --no-progress, the same on every command that can run for long (``args.progress``)."""
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="progress on stderr, never stdout: a bar on a terminal, else a line every few seconds "
        "(default: on; --no-progress for none)",
    )


def constraints_from_args(args: argparse.Namespace) -> tuple:
    """The constraints of --constraints FILE.yaml (none without it)."""

    return load_constraints(args.constraints) if args.constraints else ()


def parse_floats(text: str, what: str) -> list[float]:
    """Comma-separated numbers, or a clear error naming ``what``."""
    cells = [c.strip() for c in text.split(",")]
    try:
        values = [float(c) for c in cells]
    except ValueError:
        raise BadConfiguration(f"{what} {text!r}: expected comma-separated numbers") from None
    if not all(np.isfinite(values)):
        raise BadConfiguration(f"{what} {text!r}: values must be finite")
    return values


def robot_from_args(args: argparse.Namespace) -> Robot:
    markers = None
    if args.marker:
        markers = []
        for text in args.marker:
            xyz = parse_floats(text, "--marker")
            if len(xyz) != 3:
                raise BadConfiguration(f"--marker {text!r}: expected X,Y,Z (three numbers, metres)")
            markers.append(xyz)
    robot = load_robot(
        args.robot,
        tip=args.tip,
        markers=markers,
        root=args.root,
        joint_ranges=joint_ranges_from_args(args),
        package_dirs=dict(_name_value(text, "--package-dir", "NAME=PATH") for text in args.package_dir or ()),
    )
    gravity = getattr(args, "gravity", None)
    return robot if gravity is None else robot.with_gravity(parse_floats(gravity, "--gravity"))


def _name_value(text: str, option: str, form: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise BadArgument(f"{option} {text!r}: expected {form}")
    return name.strip(), value.strip()


def joint_ranges_from_args(args: argparse.Namespace) -> dict[str, tuple[float, float]]:
    """--joint-range NAME=LO,HI options as {joint: (lower, upper)} in radians or metres."""
    out: dict[str, tuple[float, float]] = {}
    for text in args.joint_range or ():
        name, value = _name_value(text, "--joint-range", "NAME=LO,HI")
        bounds = parse_floats(value, f"--joint-range {name}=")
        if len(bounds) != 2 or bounds[0] > bounds[1]:
            raise BadConfiguration(f"--joint-range {text!r}: expected NAME=LO,HI with LO <= HI")
        joint_range(bounds, f"--joint-range {text!r}:", BadConfiguration)  # as typed, before --deg
        lo, hi = np.radians(bounds) if getattr(args, "deg", False) else bounds
        out[name] = (float(lo), float(hi))
    return out


def parse_configuration(robot: Robot, text: str, degrees: bool, what: str) -> np.ndarray:
    """One configuration from 'v1,v2,...' (radians, or degrees), checked against limits."""
    values = parse_floats(text, what)
    if len(values) != robot.nq:
        raise BadConfiguration(
            f"{what} {text!r}: {len(values)} values, expected {robot.nq} ({', '.join(robot.joint_names)})"
        )
    q = robot.to_radians(values) if degrees else np.array(values)
    robot.check_limits(q[None, :], [f"{what} {text}"], degrees)
    return robot.configurations(q, what=what)[0]


def test_poses_from_args(robot: Robot, args: argparse.Namespace) -> np.ndarray:
    return np.array([parse_configuration(robot, t, args.deg, "--test-pose") for t in args.test_pose])


def read_plan(robot: Robot, path: str, degrees: bool, what: str = "plan") -> Plan:
    return Plan.from_csv(path, robot=robot, degrees=degrees, what=what)


def emit_json(payload: dict) -> None:
    json.dump(payload, sys.stdout, indent=2, allow_nan=False)
    sys.stdout.write("\n")


CONDITIONING_HELP = """\
Conditioning (every report, one number): the smallest eigenvalue of the information matrix JᵀJ
with its columns normalised (σ_min² of the Jacobian with unit columns): 1 when every parameter
moves the points independently, 0 for a singular plan, whatever the units. A design keeps its plan
above 1e-2 (--min-conditioning); a plan below 1e-3 is warned about as effectively singular, and
identification leaves at their nominal values the parameters the data separate below 1e-6."""

SIGMA_HELP = f"measurement noise per coordinate [m] (default {DEFAULT_SIGMA:g}: a laser tracker)"


def sigma_from_args(args: argparse.Namespace) -> tuple[float, str]:
    """(σ [m], how reports name it: ``σ = 0.030 mm (default: laser tracker)``)."""
    if args.sigma is None:
        return DEFAULT_SIGMA, sigma_note(DEFAULT_SIGMA, given=False)
    sigma = positive_sigma(args.sigma, "--sigma")
    return sigma, sigma_note(sigma)


def joint_units(robot: Robot, degrees: bool) -> str:
    """The units of a robot's joint values as written: 'degrees', 'radians', 'metres', or
    'degrees, metres for prismatic joints'."""
    angles = "degrees" if degrees else "radians"
    if np.all(robot.revolute):
        return angles
    return "metres" if not np.any(robot.revolute) else f"{angles}, metres for prismatic joints"


def fmt_length(metres: float) -> str:
    """A length for people: mm below one metre, with 4 significant digits."""
    return f"{metres * 1e3:.4g} mm" if abs(metres) < 1 else f"{metres:.4g} m"
