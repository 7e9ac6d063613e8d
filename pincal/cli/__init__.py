"""The ``pincal`` command line.

``main(argv)`` parses, runs one subcommand and returns its exit code: 0 on success, 2 on bad input
(a one-line ``pincal: error: ...`` on stderr, never a traceback), 130 on Ctrl-C, 143 on SIGTERM.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
import traceback
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from typing import NamedTuple, NoReturn

from pincal.blas import single_threaded  # light: threadpoolctl is imported on first use
from pincal.errors import PincalError
from pincal.version import __version__


class Command(NamedTuple):
    """A subcommand: the module that adds its parser and runs it, and its one line in --help."""

    module: str
    """The module, with ``add_parser(subparsers)`` (whose parser sets ``run``)."""
    help: str
    """What ``pincal --help`` says of it (the module's HELP)."""


COMMANDS: dict[str, Command] = {
    "params": Command(
        "pincal.cli.params",
        "list geometric parameters and report which are identifiable, and why not",
    ),
    "evaluate": Command(
        "pincal.cli.evaluate",
        "criteria of a measurement plan: rho0 at the test pose(s), D, A, E, cond, O1-O4",
    ),
    "design": Command(
        "pincal.cli.design",
        (
            "design a measurement plan: the m configurations that make the robot most accurate at the "
            "test pose(s)"
        ),
    ),
    "baseline": Command(
        "pincal.cli.baseline",
        (
            "rho0 at the test pose(s) over random feasible plans (min, median, mean, max), and the "
            "D-optimal plan's"
        ),
    ),
    "campaign": Command(
        "pincal.cli.campaign",
        "run a plan on a real cell: the quickest order from home and back, every move checked, the time",
    ),
    "next": Command(
        "pincal.cli.next_poses",  # not pincal.cli.next: it would hide the builtin next() here
        "from the measurements so far, the next poses to measure (or stop: the target is reached)",
    ),
    "simulate": Command(
        "pincal.cli.simulate",
        "Monte-Carlo simulation of a calibration with a plan: empirical vs predicted rho0",
    ),
    "measure-sim": Command(
        "pincal.cli.measure_sim",
        "simulate the measurements of a plan on a 'true' robot, to rehearse a calibration",
    ),
    "identify": Command(
        "pincal.cli.identify",
        "identify the geometric errors from measurements and write the calibrated URDF",
    ),
    "compensate": Command(
        "pincal.cli.compensate",
        (
            "corrected joint targets of a program, through a calibration (geometry, gains, compliance, "
            "residuals)"
        ),
    ),
    "iso9283": Command(
        "pincal.cli.iso9283",
        "ISO 9283 pose accuracy and repeatability (AP, RP, orientation, distance) from poses measured "
        "in cycles, before and after calibration",
    ),
    "show": Command(
        "pincal.cli.show",
        "see a plan: meshcat scene of the measurement poses and the test pose's error ellipsoid",
    ),
    "robots": Command(
        "pincal.cli.robots",
        "list the robots loadable by name (shipped URDFs and example-robot-data) and the chains each offers",
    ),
    "export": Command(
        "pincal.cli.export",
        "write a calibration (a calibrated URDF and its sidecar) in another format: MJCF for MuJoCo",
    ),
    "urdf-from-dh": Command(
        "pincal.cli.from_dh",
        "write the URDF of a robot given by a DH table (standard or modified convention)",
    ),
    "example": Command(
        "pincal.cli.example",
        "the input files the README and the --help examples use (a camera rig, a workcell, a program, ...)",
    ),
}
"""Every subcommand, in --help order. A subcommand's module (and what it imports: NumPy, Pinocchio,
SciPy) is imported only when that subcommand is parsed, so that ``pincal --help`` lists them all
in milliseconds. A new subcommand: a module with ``HELP = COMMANDS[name].help``, ``EXAMPLES`` and
``add_parser(subparsers)``, and its line here."""

DESCRIPTION = """\
pincal chooses the measurement configurations of a robot calibration so that the robot is most
accurate where you work (a test pose, the region around it, a path), evaluates plans, and calibrates.
"""

EPILOG = """\
a whole calibration, rehearsed on the shipped KUKA KR 270 (joint values in degrees):
  pincal params kr270 --marker 0.1,0.05,0.2
  pincal design kr270 -m 12 --test-pose=0,-60,60,0,45,0 --around 10deg --deg --marker 0.1,0.05,0.2 \\
      --baseline 1000 --out plan.csv
  pincal evaluate kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2 --sigma 3e-5
  pincal simulate kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2 --sigma 3e-5
  pincal show kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2 --sigma 3e-5 \\
      --html plan.html
  pincal measure-sim kr270 --plan plan.csv --deg --marker 0.1,0.05,0.2 --error-std 1e-3,1e-3 \\
      --sigma 3e-5 --out meas.csv
  pincal identify kr270 --data meas.csv --deg --marker 0.1,0.05,0.2 --holdout 0.2 --seed 0 \\
      --out kr270_calibrated.urdf
  pincal compensate kr270 --calibration kr270_calibrated.urdf --targets program.csv --deg --payload 120 \\
      --marker 0.1,0.05,0.2 --out corrected.csv       # the program's corrected joint targets
  pincal campaign kr270 --plan plan.csv --deg --marker 0.1,0.05,0.2 --out campaign.csv --html campaign.html
  pincal next kr270 --data meas.csv --plan plan.csv -k 3 --deg --marker 0.1,0.05,0.2 \\
      --test-pose=0,-60,60,0,45,0 --around 10deg --target 0.02mm --out next.csv
  pincal robots
  pincal urdf-from-dh ur5_dh --out ur5_dh.urdf     # a robot given by a DH table (UR5's ships with pincal)

Units: metres and radians; --deg reads and writes joint values in degrees. σ (--sigma, the
instrument's noise per coordinate) defaults to a laser tracker's 3e-5 m and every report states it.
Exit codes: 0 done, 2 bad input (one 'pincal: error:' line), 130 interrupted (Ctrl-C), 143 stopped
(SIGTERM), 1 a bug in pincal.
A command writes all of its outputs or none. Figures (--plot, --accuracy-plot) need matplotlib:
pip install "pincal[plot]"; xacro sources need the xacro package: pip install "pincal[xacro]".
'pincal COMMAND --help' describes each command; --json prints one JSON object for scripts.
"""


class Parser(argparse.ArgumentParser):
    """argparse with pincal's error format: one line ``pincal: error: ...`` naming the --help."""

    commands: Mapping[str, argparse.ArgumentParser]
    """The subcommands' parsers, by name (set by :func:`build_parser`)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"pincal: error: {message} (see '{self.prog} --help')\n")


def build_parser(commands: list[str] | None = None) -> Parser:
    """The parser of ``pincal``, with every subcommand listed; the options of those in ``commands``
    (default: all of them, importing every subcommand's module) are added, the others are parsed
    as their bare name only (``main`` adds the one it runs)."""
    parser = Parser(
        prog="pincal",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )

    parser.add_argument("--version", action="version", version=f"pincal {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, command in COMMANDS.items():
        if commands is None or name in commands:
            importlib.import_module(command.module).add_parser(sub)
        else:
            sub.add_parser(name, help=command.help)
    parser.commands = sub.choices  # {name: its parser}
    return parser


def command_named(argv: list[str]) -> str | None:
    """The subcommand ``argv`` runs: its first word that is not an option (pincal's own options,
    --help and --version, take no value)."""
    return next((arg for arg in argv if not arg.startswith("-")), None)


# What a NumPy floating-point warning raises in the CLI (trap_floating_point_warnings), or
# np.errstate(all="raise") in a caller.
NUMERIC_ERRORS = (RuntimeWarning, FloatingPointError)


def one_line(text: str) -> str:
    """``text`` with its line breaks (and the spaces around them) made single spaces."""
    return " ".join(part.strip() for part in text.strip().splitlines() if part.strip())


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Every warning on one line, without the source line Python would show."""
    print(f"pincal: warning: {one_line(str(message))}", file=sys.stderr)


class Stopped(BaseException):
    """SIGTERM (what a scheduler, systemd, a container or a CI timeout sends), raised in the main
    thread while a command runs: the command unwinds as from Ctrl-C (its worker processes killed,
    no output written) and exits with 143, 128 + SIGTERM."""


@contextmanager
def stopped_by_sigterm() -> Iterator[None]:
    """Inside: SIGTERM raises :class:`Stopped` in the main thread (a second one while unwinding is
    ignored); the previous handler is back after. The CLI's ``main`` alone does this: a library
    leaves its host program's handlers alone. In another thread (signals reach only the main
    thread's handlers), nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum: int, frame: object) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: let the first unwind
        raise Stopped()

    previous = signal.signal(signal.SIGTERM, stop)
    try:
        yield
    finally:
        # None: a handler not set from Python, which cannot be set back; the default then.
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def main(argv: list[str] | None = None) -> int:
    """Run the CLI on ``argv`` (default ``sys.argv[1:]``); return the exit code (``--help``,
    ``--version`` and usage errors raise ``SystemExit`` with it, as argparse does).

    Every output of a command is written all or nothing (:func:`pincal.outputs.all_or_nothing`): a
    command that fails leaves none of its outputs.

    0: done; 2: bad input or a refused output (one line ``pincal: error: ...`` on stderr); 130:
    interrupted (Ctrl-C); 143: stopped by SIGTERM (:func:`stopped_by_sigterm`); 1: a bug in pincal
    (one line ``pincal: internal error: ...`` naming where; set PINCAL_DEBUG=1 for the traceback),
    NumPy's floating-point warnings (overflow, invalid value, divide by zero) included: they raise
    rather than let inf or NaN through. Other warnings are printed as ``pincal: warning: ...`` lines.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    name = command_named(argv)
    parser = build_parser([name] if name in COMMANDS else [])
    if name not in COMMANDS:  # --help, --version, or a usage error: argparse exits
        parser.parse_args(argv)
        parser.error("give a COMMAND")
    # The subcommand's modules are imported now (by build_parser): so are the CLI's helpers.
    from pincal.cli._common import (
        argument_names,
        check_outputs,
        join_negative_values,
        trap_floating_point_warnings,
    )
    from pincal.outputs import all_or_nothing, guard_inputs

    # --help and usage errors exit here through SystemExit (0, or 2 after one line).
    args = parser.parse_args(join_negative_values(argv, parser.commands[name]))
    try:
        # BLAS on one thread: pincal's matrices are small, and a threaded BLAS's spinning threads
        # make the command's serial work (identifiability, sampling, baselines) several times
        # slower on a busy machine (pincal.blas); the design's parallelism is its worker processes.
        # SIGTERM unwinds the command as Ctrl-C does: the outputs' temporary files and the design's
        # worker processes go with it.
        with (
            stopped_by_sigterm(),
            guard_inputs(),
            all_or_nothing(),
            single_threaded(),
            warnings.catch_warnings(),
        ):
            warnings.showwarning = _show_warning
            trap_floating_point_warnings()  # an overflow is an internal error, not a warning and inf
            check_outputs(args, argument_names(parser.commands[args.command]))
            return args.run(args)
    except PincalError as exc:  # one line, whatever the message quotes (a parser's report)
        print(f"pincal: error: {one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pincal: interrupted", file=sys.stderr)
        return 130
    except Stopped:
        print("pincal: stopped (SIGTERM)", file=sys.stderr)
        return 143
    except BrokenPipeError:
        return 0
    except Exception as exc:
        if os.environ.get("PINCAL_DEBUG"):
            raise
        text = one_line(str(exc))[:300]
        kind = "NumPy floating-point error" if isinstance(exc, NUMERIC_ERRORS) else type(exc).__name__
        print(
            f"pincal: internal error: {kind}: {text}{_where(exc)} (a bug in pincal: "
            "please report it with the command line; PINCAL_DEBUG=1 shows the traceback)",
            file=sys.stderr,
        )
        return 1


def _where(exc: BaseException) -> str:
    """' in pincal/module.py:line (function)' for the innermost pincal frame of ``exc``, or ''."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    where = ""
    for frame in traceback.extract_tb(exc.__traceback__):
        if os.path.abspath(frame.filename).startswith(root + os.sep):
            path = os.path.relpath(frame.filename, os.path.dirname(root))
            where = f" in {path}:{frame.lineno} ({frame.name})"
    return where


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
