"""FIGAROH's calibration data: a CSV of measured marker poses and joint positions, and the
configuration YAML that describes it (github.com/thanhndv212/figaroh, ``calibration_tools.load_data``).

The CSV has one row per sample: for each marker i (1, 2, ...) the columns of the degrees of freedom
it measures among ``xi, yi, zi`` [m] and ``phixi, phiyi, phizi`` (roll, pitch, yaw [rad]: FIGAROH's
``pin.rpy.matrixToRpy``) of the marker frame, and one column per joint, named as in the URDF
[rad or m]. Other columns (a free-flyer's, other joints') are left out. The YAML's
``calibration`` section names the tool frame (``tool_frame``: the robot's tip), the markers
(``markers``, each with ``measure``: six booleans, x y z phix phiy phiz), the marker frame in the
tool frame (``tip_pose``: x, y, z, roll, pitch, yaw) and the CSV (``data_file``).

Read as pincal measurements: positions alone are points (some of them: a partial measurement), all
six a pose, position and orientation in the measuring frame (the marker frame turned back by
``tip_pose``'s rotation, to the tip's axes). An orientation is all of roll, pitch and yaw or none:
a part of them is no part of a rotation vector.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.calibration.formats._common import (
    bad,
    by_name,
    key,
    mapping,
    numbers,
    pose_values,
    sequence,
    text,
)
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData
from pincal.files import read_numeric_csv, read_yaml
from pincal.instruments.pose import Partial, Pose
from pincal.model.robot import Robot

NAME = "figaroh"
DOFS = ("x", "y", "z", "phix", "phiy", "phiz")
"""FIGAROH's measured degrees of freedom of a marker, in the order of ``measure``."""
_COLUMN = re.compile(r"^(x|y|z|phix|phiy|phiz)([1-9]\d*)$")


def is_figaroh_csv(header: list[str]) -> bool:
    """The columns are FIGAROH's: markers numbered from 1 (``x1``) or roll-pitch-yaw columns."""
    return any(_COLUMN.match(h) for h in header) and "x0" not in header and "x" not in header


def is_figaroh_yaml(data: object) -> bool:
    """The YAML is a FIGAROH configuration (a ``calibration`` section with markers)."""
    return (
        isinstance(data, dict)
        and isinstance(data.get("calibration"), dict)
        and "markers" in data["calibration"]
    )


def read(path: str | os.PathLike, robot: Robot) -> MeasurementData:
    """FIGAROH's data: the configuration YAML (its ``data_file``, relative to the YAML's folder or
    its parent, as FIGAROH's examples keep ``config/`` and ``data/`` side by side), or the CSV
    alone (its columns say what was measured; the marker frame has the tool frame's axes).

    Raises:
        BadMeasurementData: a missing key or column, a YAML that does not describe the CSV, a
            tool frame that is not the robot's tip, a part of an orientation (naming file and key
            or line).
    """
    if Path(path).suffix.lower() in (".yaml", ".yml"):
        config = _config(path, robot)
        return _read_csv(config["data"], robot, config)
    return _read_csv(Path(path), robot, None)


def _config(path: str | os.PathLike, robot: Robot) -> dict:
    """The CSV, the measured DoFs and the marker frame's rotation in the tool frame from a FIGAROH
    configuration YAML, checked against the robot."""
    data = read_yaml(path, "FIGAROH configuration", BadMeasurementData)
    place = f"FIGAROH configuration file {str(path)!r}"
    calibration = mapping(
        key(mapping(data, place, path, "a mapping with a 'calibration' section"), "calibration", place, path),
        f"{place}, key calibration",
        path,
        "a mapping",
    )
    tool = text(
        key(calibration, "tool_frame", f"{place}, key calibration", path),
        f"{place}, key calibration.tool_frame",
        path,
    )
    if tool != robot.tip:
        raise bad(
            f"{place}, key calibration.tool_frame",
            f"the markers are on {tool!r} but the robot's tip is {robot.tip!r}: give --tip {tool} "
            f"(tip={tool!r})",
            path,
        )
    markers = sequence(
        key(calibration, "markers", f"{place}, key calibration", path),
        f"{place}, key calibration.markers",
        path,
        "a list of markers",
    )
    if not markers:
        raise bad(f"{place}, key calibration.markers", "expected one marker or more", path)
    masks = []
    for k, marker in enumerate(markers):
        at = f"{place}, key calibration.markers[{k}]"
        measure = key(mapping(marker, at, path, "a mapping with 'measure'"), "measure", at, path)
        if not (
            isinstance(measure, list) and len(measure) == 6 and all(isinstance(b, bool) for b in measure)
        ):
            raise bad(f"{at}.measure", "expected six booleans (x, y, z, phix, phiy, phiz)", path)
        masks.append(tuple(d for d, b in zip(DOFS, measure) if b))
    turn = np.eye(3)
    if calibration.get("tip_pose") is not None:
        tip = numbers(calibration["tip_pose"], f"{place}, key calibration.tip_pose", path, 6)
        turn = pin.rpy.rpyToMatrix(*tip[3:])
    file = text(
        key(calibration, "data_file", f"{place}, key calibration", path),
        f"{place}, key calibration.data_file",
        path,
    )
    folder = Path(path).parent
    candidates = [folder / file, folder.parent / file]
    found = next((c for c in candidates if c.is_file()), None)
    if found is None:
        raise bad(
            f"{place}, key calibration.data_file",
            f"{file!r} is in neither {str(candidates[0])!r} nor {str(candidates[1])!r}",
            path,
        )
    return {"data": found, "masks": masks, "turn": turn, "source": place}


def _read_csv(path: Path, robot: Robot, config: dict | None) -> MeasurementData:
    header, rows, lines = read_numeric_csv(path, what="FIGAROH measurement", error=BadMeasurementData)
    place = f"FIGAROH measurement file {str(path)!r}"
    found: dict[int, list[str]] = {}
    for h in header:
        match = _COLUMN.match(h)
        if match:
            found.setdefault(int(match.group(2)), []).append(match.group(1))
    if config is not None:
        masks = config["masks"]
        expected = [f"{d}{k + 1}" for k, mask in enumerate(masks) for d in mask]
        missing = [c for c in expected if c not in header]
        if missing:
            raise bad(
                place,
                f"no column {', '.join(missing)}, which the markers' 'measure' in "
                f"{config['source']} says were measured",
                path,
            )
    else:
        if sorted(found) != list(range(1, len(found) + 1)):
            raise bad(
                place, "expected the markers' columns numbered 1, 2, ... (x1, y1, z1, phix1, ...)", path
            )
        masks = [tuple(d for d in DOFS if d in found[k]) for k in sorted(found)]
    if len(set(masks)) != 1:
        raise bad(
            place, "every marker must measure the same degrees of freedom (as FIGAROH reads them)", path
        )
    mask = masks[0]
    rotation = [d for d in mask if d.startswith("phi")]
    if rotation and len(rotation) != 3:
        raise bad(
            place,
            f"the orientation is measured by {', '.join(rotation)} alone: a part of roll, pitch and yaw "
            f"is no part of a rotation vector; measure all of phix, phiy, phiz or none",
            path,
        )
    joints = [h for h in header if not _COLUMN.match(h)]
    q = by_name(joints, rows[:, [header.index(h) for h in joints]], robot, place, path)
    K = len(masks)
    blocks = []
    for k in range(K):
        columns = rows[:, [header.index(f"{d}{k + 1}") for d in mask]]
        if rotation:
            turn = np.eye(3) if config is None else config["turn"]
            R = np.array([pin.rpy.rpyToMatrix(*r) @ turn.T for r in columns[:, -3:]])
            at = len(mask) - 3
            positions = np.zeros((len(rows), 3))
            positions[:, :at] = columns[:, :at]
            full = pose_values(positions, R)
            columns = np.hstack([columns[:, :at], full[:, 3:]])
        blocks.append(columns)
    values = np.hstack(blocks)
    lines_ = tuple(int(n) for n in lines)
    if mask == DOFS:
        kind: Pose | Partial | None = Pose()
    elif mask == ("x", "y", "z"):
        kind = None
        values = values.reshape(len(rows), K, 3)
    else:
        kind = Partial(tuple(d.replace("phi", "r") for d in mask))
    data = MeasurementData(q, values, robot.joint_names, lines_, str(path), kind=kind)
    robot.check_limits(q, data.labels(), degrees=False)
    return data
