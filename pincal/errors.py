"""Exceptions raised by pincal.

Every error pincal raises on purpose derives from :class:`PincalError`. Messages say what was
wrong, what was expected and, where there is a finite list, the valid choices. The CLI prints
``str(error)`` on one line and exits with code 2.

Errors about what the caller gave (an argument, a name, joint values, a file's content) derive
from :class:`BadArgument`, which is also a ``ValueError``: ordinary Python code catches them, and
they carry what they name as attributes (``argument``, ``value``, ``valid``, ``file``, ``line``;
``joint`` for joint values; ``kind``, ``name`` for unknown names).

Warnings (:class:`PincalWarning`, :class:`DegenerateOptimumWarning`) are issued through
:func:`warn`, which names the caller's file and line (the first frame outside pincal), never a
pincal source line.
"""

from __future__ import annotations

import difflib
import os
import sys
import types
import warnings
from collections.abc import Iterable

__all__ = [
    "AmbiguousTip",
    "BadArgument",
    "BadConfiguration",
    "BadConstraint",
    "BadDHTable",
    "BadMeasurementData",
    "BadPlanFile",
    "CannotWrite",
    "DataCheckWarning",
    "DegenerateOptimum",
    "DegenerateOptimumWarning",
    "FloorUnreachable",
    "FrameNotFound",
    "IdentificationFailed",
    "Infeasible",
    "MissingDependency",
    "NoInertias",
    "OverwriteRefused",
    "PincalError",
    "PincalWarning",
    "RobotNotFound",
    "SingularPlan",
    "UnknownName",
    "UnknownParameter",
    "UnsupportedJoint",
    "UrdfError",
]


def _choices(valid: Iterable[str], limit: int = 30) -> str:
    valid = list(valid)
    shown = ", ".join(valid[:limit])
    return shown + (f", ... ({len(valid)} in all)" if len(valid) > limit else "")


def _close(name: str, valid: Iterable[str]) -> list[str]:
    return difflib.get_close_matches(name, list(valid), n=5, cutoff=0.5)


class PincalError(Exception):
    """Root of every error pincal raises on purpose."""


class BadArgument(PincalError, ValueError):
    """An argument or an input the caller gave that is not valid.

    Attributes:
        argument: the argument, option or input named (e.g. ``"sigma"``, ``"--trials"``), or None.
        value: the value given, or None.
        valid: what would be valid (a (low, high) range, the list of choices, a description), or
            None.
        file: the file the input came from, or None.
        line: its line number in ``file`` (1-based), or None.
    """

    argument: object
    value: object
    valid: object
    file: object
    line: int | None

    def __init__(
        self,
        message: str = "",
        *,
        argument: object = None,
        value: object = None,
        valid: object = None,
        file: object = None,
        line: int | None = None,
    ) -> None:
        super().__init__(message)
        for key, given in (
            ("argument", argument),
            ("value", value),
            ("valid", valid),
            ("file", file),
            ("line", line),
        ):
            if given is not None or not hasattr(self, key):  # a subclass may have set it already
                setattr(self, key, given)


class RobotNotFound(BadArgument):
    """A robot given by name is neither a file, a shipped robot nor an example-robot-data robot."""

    def __init__(self, name: str, valid: Iterable[str], reason: str = ""):
        self.name = name
        self.valid = sorted(valid)
        if reason:
            super().__init__(f"robot {name!r}: {reason}; give its URDF file instead")
            return
        close = _close(name, self.valid)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        super().__init__(
            f"unknown robot {name!r}: not a URDF file, a shipped robot or an example-robot-data "
            f"robot{hint} Valid names: {_choices(self.valid, 80)}"
        )


class UrdfError(PincalError):
    """A URDF file is missing, unreadable or not a valid robot description."""


class UnknownName(BadArgument):
    """A frame, joint, parameter or group name that the robot does not have."""

    def __init__(self, kind: str, name: str, valid: Iterable[str]):
        self.kind = kind
        self.name = name
        self.value = name
        self.valid = list(valid)
        close = _close(name, self.valid)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        super().__init__(f"unknown {kind} {name!r}{hint}; valid: {_choices(self.valid)}")


class FrameNotFound(UnknownName):
    """The requested tip frame is not in the model (or is not moved by any joint)."""

    def __init__(self, name: str, valid: Iterable[str], kind: str = "frame"):
        super().__init__(kind, name, valid)


class UnknownParameter(UnknownName):
    """A parameter name or group that the parameter space does not have."""

    def __init__(self, name: str, valid: Iterable[str]):
        super().__init__("parameter or group", name, valid)


class AmbiguousTip(BadArgument):
    """No tip was given and the robot's tree has several chain ends: the message lists them."""

    def __init__(self, robot: str, candidates: Iterable[str], note: str = ""):
        self.robot = robot
        self.candidates = list(candidates)
        if not self.candidates:
            super().__init__(f"{robot}: {note}no joint moves any frame, so there is no chain to calibrate")
            return
        super().__init__(
            f"{robot}: {note}{len(self.candidates)} chain ends, choose one with --tip FRAME "
            f"(tip=): {_choices(self.candidates, 12)}"
        )


class UnsupportedJoint(BadArgument):
    """A joint on the measured chain that is not a one-dof (revolute or prismatic) joint."""


class NoInertias(BadArgument):
    """A term that needs the links' masses (joint compliance: gravity torques) on a robot whose URDF
    gives its links none."""


class BadDHTable(BadArgument):
    """A Denavit–Hartenberg table that cannot be read as documented (the message names the key or row)."""


class BadConfiguration(BadArgument):
    """Joint values of the wrong shape, non-finite, non-numeric or outside the joint limits.

    Attributes:
        joint: the joint whose value is wrong, when one is (else None); ``value`` is its value
            and ``valid`` its (lower, upper) limits, in the unit of the message.
    """

    def __init__(self, message: str = "", *, joint: str | None = None, **data: object) -> None:
        self.joint = joint
        super().__init__(message, **data)  # type: ignore[arg-type]


class BadPlanFile(BadArgument):
    """A plan / configuration CSV file that cannot be read as documented."""


class SingularPlan(PincalError):
    """A plan whose information matrix is singular: the criterion is not finite.

    Attributes:
        n_params: number of parameters to identify.
        rows_per_configuration: measured coordinates per configuration (3 per marker).
        min_configurations: the fewest configurations that could identify ``n_params``.
        m: the number of configurations of the plan.
        rank: numerical rank of the information matrix.
        plan: which plan of a batch (its index), or None for one plan.
    """

    def __init__(
        self, n_params: int, rows_per_configuration: int, m: int, rank: int | None = None, why: str = ""
    ):
        self.plan: int | None = None
        self.n_params = n_params
        self.rows_per_configuration = rows_per_configuration
        self.min_configurations = -(-n_params // rows_per_configuration)
        self.m = m
        self.rank = rank
        if m < self.min_configurations:
            msg = (
                f"singular plan: {m} configuration(s) give {m * rows_per_configuration} measured "
                f"coordinates for {n_params} parameters; at least {self.min_configurations} "
                f"configurations are needed"
            )
        else:
            msg = (
                f"singular plan: the {m} configurations are degenerate (information matrix rank "
                f"{rank} < {n_params} parameters); choose more varied configurations (at least "
                f"{self.min_configurations} are needed) or fewer parameters"
            )
        self.reason = why or msg  # ``why``: the caller's own words for how the plan came to be
        super().__init__(self.reason)

    def of_plan(self, index: int) -> SingularPlan:
        """This error, naming plan ``index`` of a batch (``plan 3: singular plan: ...``)."""
        self.plan = index
        self.args = (f"plan {index}: {self.reason}",) + self.args[1:]
        return self


class BadMeasurementData(BadArgument):
    """Measurements that cannot be used as documented: a malformed CSV, columns that do not match
    the robot's joints or markers, or arrays of the wrong shape."""


class IdentificationFailed(PincalError):
    """An identification that did not produce a calibrated robot (rank deficient data, no
    convergence, an implausible result). ``result`` is the
    :class:`~pincal.calibration.identification.IdentificationResult`."""

    def __init__(self, result: object):
        self.result = result
        super().__init__(getattr(result, "message", "identification failed"))


class CannotWrite(PincalError, OSError):
    """An output file that cannot or will not be written: its folder is missing, permission is
    denied, the path is a folder or a special file (device, pipe, socket), or a figure's format is
    unknown."""


class OverwriteRefused(PincalError):
    """An output path that is one of the inputs (pincal never overwrites its inputs)."""


class BadConstraint(BadArgument):
    """A constraint with invalid values, or a constraints file that cannot be read."""


class Infeasible(PincalError):
    """No configuration (or no plan) satisfies the constraints."""


class FloorUnreachable(Infeasible):
    """No plan of m configurations reaches the conditioning floor: even the D-optimal plan found
    stays below it (``reached``)."""

    def __init__(self, m: int, floor: float, reached: float, for_data: bool = False):
        self.m, self.floor, self.reached = m, floor, reached
        if for_data:  # the default floor's lower bound: what identification asks of the data
            super().__init__(
                f"no plan of {m} configurations reaches the conditioning floor {floor:g} that identification "
                f"needs to separate every parameter (the D-optimal plan found reaches {reached:.3g}); add "
                "configurations or markers, or leave the weakest parameters out"
            )
            return
        super().__init__(
            f"no plan of {m} configurations reaches the conditioning floor {floor:g} (the D-optimal plan "
            f"found reaches {reached:.3g}); add configurations or lower min_conditioning"
        )


class DegenerateOptimum(PincalError):
    """No start ended on a regular plan: the criterion improves all the way to singular plans.

    Attributes:
        criterion: the criterion's name.
        m: the number of configurations.
        floor: the conditioning floor every start ended below.
    """

    def __init__(self, criterion: str, m: int, floor: float) -> None:
        self.criterion, self.m, self.floor = criterion, m, floor
        super().__init__(
            f"the {criterion} criterion would improve further as the {m} configurations approach a "
            "singular plan, so its infimum is not attained by a regular plan (with few configurations "
            "for many parameters, or a test pose at a singular limit such as a stretched arm); every "
            f"start ended below the conditioning floor {floor:g}: add configurations, move the test "
            "pose, or lower min_conditioning"
        )


class DegenerateOptimumWarning(PincalError, UserWarning):
    """The plan returned sits at the conditioning floor: the criterion would keep improving
    towards singular plans, so its infimum is not attained (a warning, under pincal's one root)."""


class PincalWarning(PincalError, UserWarning):
    """A note on input pincal accepts but changes or ignores (a locked zero-range joint, a
    floating base held fixed, mesh files that cannot be found); the CLI prints it on one
    ``pincal: warning: ...`` line."""


class MissingDependency(PincalError, ImportError):
    """An optional package that a feature needs is not installed (the message says how to get it)."""


class DataCheckWarning(PincalWarning):
    """The designed plan would not let the identification estimate every parameter: its data
    check (:mod:`pincal.evaluation.data_check`) would leave some at their nominal values."""


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep


def _in_pincal(filename: str) -> bool:
    return os.path.abspath(filename).startswith(_PACKAGE_DIR)


def _import_machinery(filename: str) -> bool:
    """A frame that ``warnings.warn`` does not count in ``stacklevel`` (importlib's bootstrap)."""
    return "importlib" in filename and "_bootstrap" in filename


def _outside_stacklevel() -> int:
    """The ``stacklevel`` that makes ``warnings.warn``, called by the function calling this one,
    name the first frame outside the pincal package (counted as ``warnings.warn`` counts: 1 is
    that function, importlib's frames are skipped); the outermost frame when every frame is
    pincal's (the CLI)."""
    frame: types.FrameType | None = sys._getframe(1)
    level = last = 1
    while frame is not None:
        name = frame.f_code.co_filename
        if not _import_machinery(name):
            if not _in_pincal(name):
                return level
            last, level = level, level + 1
        frame = frame.f_back
    return last


def warn(message: str, category: type[Warning] = PincalWarning) -> None:
    """Issue a warning attributed to the code that called pincal: its file and line are those of
    the first frame outside the pincal package, however deep inside pincal the warning is raised
    (``load_robot`` calling ``read_urdf`` calling the mesh check all point at the user's line).

    Every warning pincal issues goes through here. (Python 3.12's ``skip_file_prefixes`` does the
    same; this walk also runs on 3.10 and 3.11.)
    """
    warnings.warn(message, category, stacklevel=_outside_stacklevel())
