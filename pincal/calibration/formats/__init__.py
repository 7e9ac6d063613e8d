"""Measurements in other tools' files: readers that make a
:class:`~pincal.calibration.measurements.MeasurementData` of FIGAROH's, ROS robot_calibration's,
industrial_calibration's and MoveIt Calibration's data, in pincal's conventions (metres, radians,
the robot's joints in its order by name), one module per tool and a registry of them
(:data:`FORMATS`). :func:`read_measurements` reads a file by its format's name or finds it from the
file (its suffix, its columns or keys).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pincal.calibration.formats import figaroh, industrial_calibration, moveit, robot_calibration
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadArgument, BadMeasurementData
from pincal.files import read_numeric_csv, read_yaml
from pincal.model.robot import Robot


@dataclass(frozen=True)
class Format:
    """A measurement file format.

    Attributes:
        name: its name (``--format``).
        tool: the tool that writes it, for messages and the README.
        reads: what it reads, in a few words.
        options: the keyword options its reader takes (besides the path and the robot).
    """

    name: str
    tool: str
    reads: str
    read: Callable[..., MeasurementData]
    options: tuple[str, ...] = ()


def _pincal(
    path: str | os.PathLike, robot: Robot, degrees: bool = False, millimetres: bool = False
) -> MeasurementData:
    return MeasurementData.from_csv(path, robot, degrees=degrees, millimetres=millimetres)


FORMATS: dict[str, Format] = {
    f.name: f
    for f in (
        Format("pincal", "pincal", "its measurement CSV", _pincal, ("degrees", "millimetres")),
        Format(
            figaroh.NAME,
            "FIGAROH",
            "the calibration CSV (or its configuration YAML): points, partial poses or poses",
            figaroh.read,
        ),
        Format(
            robot_calibration.NAME,
            "ROS robot_calibration",
            "CalibrationData messages (a ROS 1/2 bag or YAML): one sensor's points",
            robot_calibration.read,
            ("sensor",),
        ),
        Format(
            industrial_calibration.NAME,
            "ROS-Industrial industrial_calibration",
            "kinematic calibration observations (YAML): the target's poses in the camera frame",
            industrial_calibration.read,
        ),
        Format(
            moveit.NAME,
            "MoveIt Calibration",
            "hand-eye samples and their joint states (YAML): poses",
            moveit.read,
            ("joint_states", "mount"),
        ),
    )
}
"""The formats by name."""


def format_of(path: str | os.PathLike) -> str:
    """The name of a file's format: a ROS bag is robot_calibration's; a CSV is pincal's unless its
    columns are FIGAROH's; a YAML file by its keys.

    Raises:
        BadMeasurementData: a YAML file of none of the formats, a file of no known type.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if robot_calibration.is_bag(path):
        return robot_calibration.NAME
    if suffix in (".yaml", ".yml"):
        data = read_yaml(path, "measurement", BadMeasurementData, documents=True)
        assert isinstance(data, list)  # documents=True
        docs = [d for d in data if d is not None]
        first = docs[0] if len(docs) == 1 else docs
        for name, test in (
            (figaroh.NAME, figaroh.is_figaroh_yaml),
            (robot_calibration.NAME, robot_calibration.is_calibration_data),
            (industrial_calibration.NAME, industrial_calibration.is_observations),
            (moveit.NAME, moveit.is_samples),
        ):
            if test(first):
                return name
        hint = (
            ": these are MoveIt Calibration's joint states; give its samples file, with "
            "--joint-states for this one"
            if moveit.is_joint_states(first)
            else ""
        )
        raise BadMeasurementData(
            f"measurement file {str(path)!r}: a YAML file of no known format{hint} (expected a FIGAROH "
            f"configuration, robot_calibration CalibrationData messages, industrial_calibration "
            f"observations or MoveIt Calibration samples; --format {'|'.join(FORMATS)})",
            file=str(path),
        )
    if suffix == ".csv" or not suffix:
        try:
            header, _, _ = read_numeric_csv(path, what="measurement", error=BadMeasurementData)
        except BadMeasurementData:
            return "pincal"  # its own reader says what is wrong, naming the line
        return figaroh.NAME if figaroh.is_figaroh_csv(header) else "pincal"
    raise BadMeasurementData(
        f"measurement file {str(path)!r}: no format reads {suffix!r} files (.csv, .yaml, .db3, .mcap, "
        f".bag); --format {'|'.join(FORMATS)}",
        file=str(path),
    )


def read_measurements(
    path: str | os.PathLike, robot: Robot, format: str | None = None, **options: object
) -> MeasurementData:
    """The measurements in a file of any format (:data:`FORMATS`), for ``robot``.

    Args:
        path: the file (a ROS 2 bag: its folder or its .db3/.mcap file).
        robot: the robot measured: its joints (by name), tip and markers.
        format: the format's name; default: found from the file (:func:`format_of`).
        **options: the format's options: ``degrees``, ``millimetres`` (pincal's CSV); ``sensor``
            (robot_calibration); ``joint_states``, ``mount`` (moveit).

    Raises:
        BadArgument: an unknown format, or an option it does not take.
        BadMeasurementData: a bad file (naming the file, the line or key, and what was expected).
        MissingDependency: a ROS bag without ``rosbags`` (``pip install "pincal[ros]"``).
    """
    name = format_of(path) if format is None else format
    if name not in FORMATS:
        raise BadArgument(
            f"unknown measurement format {name!r}; valid: {', '.join(FORMATS)}",
            argument="format",
            value=name,
            valid=tuple(FORMATS),
        )
    chosen = FORMATS[name]
    given = {k: v for k, v in options.items() if v is not None and v is not False}
    extra = sorted(set(given) - set(chosen.options))
    if extra:
        raise BadArgument(
            f"{', '.join(extra)}: not an option of the {name} format ({chosen.tool}'s "
            f"{chosen.reads}); its options: {', '.join(chosen.options) or 'none'}",
            argument=extra[0],
        )
    return chosen.read(path, robot, **given)


__all__ = ["FORMATS", "Format", "format_of", "read_measurements"]
