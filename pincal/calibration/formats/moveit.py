"""MoveIt Calibration's hand-eye samples (github.com/moveit/moveit_calibration, the RViz plugin's
"Save samples" and "Save joint states", ``handeye_control_widget.cpp``).

The samples YAML is a list of samples, each two 4x4 transforms written row by row [m]:
``effector_wrt_world`` (the end effector in the robot base frame) and ``object_wrt_sensor`` (the
target in the camera frame). The joint states YAML, saved at the same samples, has
``joint_names`` (the planning group's) and ``joint_values`` (one list per sample [rad or m]).
Sample i of one goes with sample i of the other.

Read as pincal poses of a frame on the tool in a fixed frame: with the camera on the hand
(``eye_in_hand``) the camera in the target's frame (the inverse of ``object_wrt_sensor``), with the
camera fixed (``eye_to_hand``) the target in the camera frame. The orientation is turned back by
the frame's constant rotation on the tool, found from the data, so that the measured frame has
the tip's axes as pincal's marker frame. The mount is not in the files: unless given, it is the one
whose relative turns agree with the robot's (the other does not, in general).
"""

from __future__ import annotations

import os

import numpy as np

from pincal.calibration.formats._common import (
    bad,
    by_name,
    homogeneous,
    key,
    mapping,
    numbers,
    pose_values,
    sequence,
    text,
    turn_on_tool,
)
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadArgument, BadMeasurementData
from pincal.files import read_yaml
from pincal.instruments.pose import Pose
from pincal.model.robot import Robot

NAME = "moveit"
MOUNTS = ("eye_in_hand", "eye_to_hand")
"""Where the camera is: on the robot's hand, or fixed in the cell."""
AGREEMENT = 0.05
"""The relative turns of the right mount agree with the robot's to this RMS [rad] (a nominal
model, a camera's pose estimates); the wrong mount's do not."""


def is_samples(data: object) -> bool:
    """Parsed YAML that is a list of hand-eye samples."""
    return (
        isinstance(data, list) and bool(data) and isinstance(data[0], dict) and "object_wrt_sensor" in data[0]
    )


def is_joint_states(data: object) -> bool:
    """Parsed YAML that is MoveIt Calibration's saved joint states."""
    return isinstance(data, dict) and "joint_names" in data and "joint_values" in data


def read(
    path: str | os.PathLike,
    robot: Robot,
    joint_states: str | os.PathLike | None = None,
    mount: str | None = None,
) -> MeasurementData:
    """The samples' poses at the joint values saved with them.

    Args:
        path: the samples YAML.
        robot: the robot (its joints by name).
        joint_states: the joint states YAML saved with the samples (required).
        mount: ``"eye_in_hand"`` or ``"eye_to_hand"``; default: found from the data.

    Raises:
        BadArgument: no joint states file, an unknown mount.
        BadMeasurementData: a missing key, a transform that is not rigid, joint states of another
            count of samples, data that fit neither mount (naming file, sample and key).
    """
    if joint_states is None:
        raise BadArgument(
            f"MoveIt Calibration samples {str(path)!r} hold no joint values: give the joint states "
            f"saved with them (--joint-states FILE.yaml, joint_states=)",
            argument="joint_states",
        )
    if mount is not None and mount not in MOUNTS:
        raise BadArgument(
            f"mount {mount!r}: expected one of {', '.join(MOUNTS)}", argument="mount", valid=MOUNTS
        )
    place = f"MoveIt Calibration samples file {str(path)!r}"
    samples = sequence(
        read_yaml(path, "MoveIt Calibration samples", BadMeasurementData), place, path, "a list of samples"
    )
    if not samples:
        raise bad(place, "no sample", path)
    seen = []
    for i, sample in enumerate(samples):
        at = f"{place}, sample {i + 1}"
        sample = mapping(sample, at, path, "a sample (effector_wrt_world, object_wrt_sensor)")
        key(sample, "effector_wrt_world", at, path)
        seen.append(homogeneous(key(sample, "object_wrt_sensor", at, path), f"{at}.object_wrt_sensor", path))
    q = _joint_values(joint_states, robot, len(samples))
    robot.check_limits(q, [f"{place}, sample {i + 1}" for i in range(len(q))], degrees=False)
    candidates = {
        "eye_in_hand": [s.inverse() for s in seen],  # the camera (on the hand) in the target's frame
        "eye_to_hand": seen,  # the target (on the hand) in the camera frame
    }
    fits = {}
    for name in (mount,) if mount else MOUNTS:
        poses = candidates[name]
        R = np.array([p.rotation for p in poses])
        try:
            X, misfit = turn_on_tool(robot, q, R)
        except BadMeasurementData as exc:
            raise bad(place, str(exc), path) from None
        fits[name] = (misfit, pose_values(np.array([p.translation for p in poses]), R @ X.T))
    if mount is None:
        good = [n for n in MOUNTS if fits[n][0] < AGREEMENT]
        if len(good) != 1:
            told = ", ".join(f"{n} {fits[n][0]:.3g} rad" for n in MOUNTS)
            raise bad(
                place,
                f"the samples' turns agree with the robot's for {len(good)} mounts (RMS misfit {told}, "
                f"expected below {AGREEMENT:g} for one): check the robot and its tip, or say where the "
                f"camera is (mount='eye_in_hand' or 'eye_to_hand')",
                path,
            )
        mount = good[0]
    return MeasurementData(q, fits[mount][1], robot.joint_names, source=str(path), kind=Pose())


def _joint_values(path: str | os.PathLike, robot: Robot, count: int) -> np.ndarray:
    """(count, nq) the joint values of MoveIt Calibration's joint states file, in the robot's order."""
    place = f"MoveIt Calibration joint states file {str(path)!r}"
    data = mapping(
        read_yaml(path, "MoveIt Calibration joint states", BadMeasurementData),
        place,
        path,
        "joint_names and joint_values",
    )
    names = [
        text(n, f"{place}, key joint_names", path)
        for n in sequence(
            key(data, "joint_names", place, path), f"{place}, key joint_names", path, "a list of names"
        )
    ]
    rows = sequence(
        key(data, "joint_values", place, path),
        f"{place}, key joint_values",
        path,
        "a list of joint value lists",
    )
    if len(rows) != count:
        raise bad(
            f"{place}, key joint_values",
            f"{len(rows)} joint states for {count} samples: expected the joint states saved with the samples",
            path,
        )
    values = np.array(
        [numbers(r, f"{place}, key joint_values[{i}]", path, len(names)) for i, r in enumerate(rows)]
    )
    return by_name(names, values, robot, f"{place}, key joint_names", path)
