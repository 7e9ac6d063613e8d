"""ROS-Industrial industrial_calibration's kinematic calibration observations
(github.com/ros-industrial/industrial_calibration, ``examples/data/kinematic_calibration/
measurements.yaml``, read by ``examples/kinematic_calibration.cpp``).

A YAML mapping of observations, each keyed by its name (a time stamp) with ``target_joints`` (the
joint values of the chain that carries the target, in its order [rad or m]), ``camera_joints``
(those of the chain carrying the camera: empty for a fixed camera) and ``pose``, the target's pose
in the camera frame (``camera_to_target``: ``x, y, z`` [m], ``qw, qx, qy, qz``).

Read as pincal poses: the target frame's position and orientation in the camera's frame (a fixed
instrument), the orientation turned back by the target's constant rotation on the tool, found
from the data (:func:`~pincal.calibration.formats._common.turn_on_tool`), so that the measured
frame has the tip's axes as pincal's marker frame; ``target_joints`` are the robot's joints in its
order. A moving camera (``camera_joints`` not empty) is refused.
"""

from __future__ import annotations

import os

import numpy as np

from pincal.calibration.formats._common import (
    bad,
    key,
    mapping,
    numbers,
    pose_values,
    quaternion,
    sequence,
    turn_on_tool,
)
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData
from pincal.files import read_yaml
from pincal.instruments.pose import Pose
from pincal.model.robot import Robot

NAME = "industrial_calibration"


def is_observations(data: object) -> bool:
    """Parsed YAML that is a mapping of kinematic observations."""
    first = next(iter(data.values()), None) if isinstance(data, dict) and data else None
    return isinstance(first, dict) and "target_joints" in first and "pose" in first


def read(path: str | os.PathLike, robot: Robot) -> MeasurementData:
    """The target's poses in the camera frame, at the robot's joint values.

    Raises:
        BadMeasurementData: a missing key, joint values that are not one per robot joint, a moving
            camera, a quaternion that is not one (naming file and observation key).
    """
    data = read_yaml(path, "industrial_calibration observation", BadMeasurementData)
    place = f"industrial_calibration observation file {str(path)!r}"
    observations = mapping(data, place, path, "a mapping of observations (name: target_joints, pose)")
    if not observations:
        raise bad(place, "no observation", path)
    q, positions, rotations = [], [], []
    for name, observation in observations.items():
        at = f"{place}, key {name}"
        observation = mapping(observation, at, path, "an observation (target_joints, camera_joints, pose)")
        camera = sequence(observation.get("camera_joints", []) or [], f"{at}.camera_joints", path, "a list")
        if camera:
            raise bad(
                f"{at}.camera_joints",
                f"{len(camera)} camera joint(s): pincal's instrument is fixed (expected none)",
                path,
            )
        q.append(numbers(key(observation, "target_joints", at, path), f"{at}.target_joints", path))
        if len(q[-1]) != robot.nq:
            raise bad(
                f"{at}.target_joints",
                f"{len(q[-1])} values, expected one per joint of the robot in its order "
                f"({', '.join(robot.joint_names)})",
                path,
            )
        pose = mapping(
            key(observation, "pose", at, path), f"{at}.pose", path, "a pose (x, y, z, qw, qx, qy, qz)"
        )
        positions.append(numbers([pose.get(c) for c in "xyz"], f"{at}.pose (x, y, z)", path, 3))
        rotations.append(quaternion(pose, f"{at}.pose", path, ("qw", "qx", "qy", "qz")))
    qs = np.array(q)
    robot.check_limits(qs, [f"{place}, key {n}" for n in observations], degrees=False)
    R = np.array(rotations)
    try:
        X, _ = turn_on_tool(robot, qs, R)
    except BadMeasurementData as exc:
        raise bad(place, str(exc), path) from None
    values = pose_values(np.array(positions), R @ X.T)
    return MeasurementData(qs, values, robot.joint_names, source=str(path), kind=Pose())
