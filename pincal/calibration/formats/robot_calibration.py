"""ROS robot_calibration's captured data (github.com/mikeferguson/robot_calibration, formerly
ros-planning): ``robot_calibration_msgs/CalibrationData`` messages, one per sample, as a bag (the
``/calibration_data`` topic its ``calibrate`` node records and reads with ``--from-bag``: ROS 2
``.db3``/``.mcap`` or ROS 1 ``.bag``, read by the pure-Python ``rosbags``, ``pincal[ros]``; no ROS
install) or as YAML (``ros2 topic echo /calibration_data`` output: messages separated by ``---``;
or a list of them).

Each message holds the robot's ``joint_states`` (``name``, ``position`` [rad or m]) and one
observation per sensor: ``sensor_name`` and ``features``, ``geometry_msgs/PointStamped`` points
[m] in the sensor's frame (``header.frame_id``). Read as pincal points: the features of one
sensor, a fixed instrument (a camera seeing the checkerboard on the gripper), feature k being the
robot's marker k; joints in the robot's order by name (the others left out).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pincal.calibration.formats._common import bad, by_name, key, mapping, number, numbers, sequence, text
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData
from pincal.files import read_yaml
from pincal.model.robot import Robot
from pincal.optional import require

NAME = "robot_calibration"
BAG_SUFFIXES = (".db3", ".mcap", ".bag")
"""The bags read through ``rosbags``: ROS 2 (SQLite, MCAP) and ROS 1."""
ROS_EXTRA = "pincal[ros]"
"""The pip requirement that brings rosbags (reading ROS bags without ROS)."""
MESSAGE = "robot_calibration_msgs/msg/CalibrationData"
DEFINITIONS = {
    "robot_calibration_msgs/msg/CalibrationData": (
        "sensor_msgs/JointState joint_states\nrobot_calibration_msgs/Observation[] observations\n"
    ),
    "robot_calibration_msgs/msg/Observation": (
        "string sensor_name\ngeometry_msgs/PointStamped[] features\n"
        "robot_calibration_msgs/ExtendedCameraInfo ext_camera_info\n"
        "sensor_msgs/PointCloud2 cloud\nsensor_msgs/Image image\n"
    ),
    "robot_calibration_msgs/msg/ExtendedCameraInfo": (
        "sensor_msgs/CameraInfo camera_info\nrobot_calibration_msgs/CameraParameter[] parameters\n"
    ),
    "robot_calibration_msgs/msg/CameraParameter": "string name\nfloat64 value\n",
}
"""The messages' definitions (robot_calibration_msgs/msg/*.msg), for bags that do not carry them."""


def is_bag(path: str | os.PathLike) -> bool:
    """A ROS bag: a bag file, or a ROS 2 bag's folder (``metadata.yaml``)."""
    path = Path(path)
    return path.suffix.lower() in BAG_SUFFIXES or (path.is_dir() and (path / "metadata.yaml").is_file())


def is_calibration_data(data: object) -> bool:
    """Parsed YAML that holds CalibrationData messages."""
    first = data[0] if isinstance(data, list) and data else data
    return isinstance(first, dict) and "joint_states" in first and "observations" in first


def read(path: str | os.PathLike, robot: Robot, sensor: str | None = None) -> MeasurementData:
    """The points one sensor measured at each sample.

    Args:
        path: a bag (file or ROS 2 bag folder) or a YAML file of CalibrationData messages.
        robot: the robot (its joints by name, one marker per feature).
        sensor: the observation's ``sensor_name`` (default: the only one; with several, it must
            be given).

    Raises:
        MissingDependency: a bag without rosbags installed.
        BadMeasurementData: a missing key, a sample without the sensor or with another number of
            features, features in different frames, an unknown sensor (naming file, sample and key).
    """
    if is_bag(path):
        messages = _from_bag(Path(path))
        place = f"robot_calibration bag {str(path)!r}"
    else:
        data = read_yaml(path, "robot_calibration data", BadMeasurementData, documents=True)
        assert isinstance(data, list)  # documents=True: one entry per YAML document
        messages = [m for doc in data if doc is not None for m in (doc if isinstance(doc, list) else [doc])]
        place = f"robot_calibration data file {str(path)!r}"
    if not messages:
        raise bad(place, f"no {MESSAGE} message", path)
    samples = [_sample(m, f"{place}, sample {i + 1}", path) for i, m in enumerate(messages)]
    sensors = sorted({s for _, _, seen in samples for s in seen})
    if sensor is None:
        if len(sensors) != 1:
            frames = {s: frame for _, _, seen in samples for s, (frame, _) in seen.items()}
            listed = ", ".join(f"{s} (features in {frames[s]!r})" for s in sensors) or "none"
            raise bad(
                place,
                f"observations of {len(sensors)} sensors: {listed}; say which one measured the points "
                f"from a fixed place: --sensor NAME (sensor=)",
                path,
            )
        sensor = sensors[0]
    elif sensor not in sensors:
        raise bad(
            place,
            f"no observation of sensor {sensor!r}; the sensors are {', '.join(sensors) or 'none'}",
            path,
        )
    q_rows: list[np.ndarray] = []
    points: list[np.ndarray] = []
    frame: str | None = None
    for i, (joints, positions, seen) in enumerate(samples):
        at = f"{place}, sample {i + 1}"
        if sensor not in seen:
            raise bad(at, f"no observation of sensor {sensor!r} (it has {', '.join(seen) or 'none'})", path)
        q_rows.append(by_name(joints, positions[None, :], robot, f"{at}, joint_states", path)[0])
        seen_frame, features = seen[sensor]
        if frame is None:
            frame = seen_frame
        if seen_frame != frame:
            raise bad(at, f"the features of {sensor!r} are in {seen_frame!r}, in {frame!r} before", path)
        if points and len(features) != len(points[0]):
            raise bad(at, f"{len(features)} features of {sensor!r}, {len(points[0])} in sample 1", path)
        points.append(features)
    q = np.array(q_rows)
    robot.check_limits(q, [f"{place}, sample {i + 1}" for i in range(len(q))], degrees=False)
    return MeasurementData(q, np.array(points), robot.joint_names, source=str(path))


def _sample(message: object, place: str, path: str | os.PathLike) -> tuple[list[str], np.ndarray, dict]:
    """(joint names, their positions, {sensor: (frame, (K, 3) features)}) of one message."""
    message = mapping(message, place, path, "a CalibrationData message (joint_states, observations)")
    states = mapping(
        key(message, "joint_states", place, path), f"{place}, joint_states", path, "a JointState"
    )
    names = sequence(
        key(states, "name", f"{place}, joint_states", path), f"{place}, joint_states.name", path, "names"
    )
    names = [text(n, f"{place}, joint_states.name", path) for n in names]
    positions = numbers(
        key(states, "position", f"{place}, joint_states", path),
        f"{place}, joint_states.position",
        path,
        len(names),
    )
    seen = {}
    observations = sequence(
        key(message, "observations", place, path), f"{place}, observations", path, "a list"
    )
    for k, observation in enumerate(observations):
        at = f"{place}, observations[{k}]"
        observation = mapping(observation, at, path, "an Observation (sensor_name, features)")
        name = text(key(observation, "sensor_name", at, path), f"{at}.sensor_name", path)
        features = sequence(
            key(observation, "features", at, path), f"{at}.features", path, "a list of points"
        )
        frames, xyz = set(), []
        for j, feature in enumerate(features):
            fat = f"{at}.features[{j}]"
            feature = mapping(feature, fat, path, "a PointStamped (header, point)")
            header = mapping(key(feature, "header", fat, path), f"{fat}.header", path, "a header")
            frames.add(text(key(header, "frame_id", f"{fat}.header", path), f"{fat}.header.frame_id", path))
            point = mapping(key(feature, "point", fat, path), f"{fat}.point", path, "a point (x, y, z)")
            xyz.append([number(key(point, c, f"{fat}.point", path), f"{fat}.point.{c}", path) for c in "xyz"])
        if len(frames) > 1:
            raise bad(at, f"features in several frames ({', '.join(sorted(frames))}), expected one", path)
        if xyz:
            seen[name] = (frames.pop(), np.array(xyz))
    return names, positions, seen


def _from_bag(path: Path) -> list[dict]:
    """The CalibrationData messages of a bag, as the mappings ``ros2 topic echo`` prints."""
    require("rosbags", f"reading the ROS bag {str(path)!r}", ROS_EXTRA)
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text_ in DEFINITIONS.items():
        store.register(get_types_from_msg(text_, name))
    folder = path.parent if path.is_file() and path.suffix.lower() in (".db3", ".mcap") else path
    if folder != path and not (folder / "metadata.yaml").is_file():
        raise bad(
            f"robot_calibration bag {str(path)!r}",
            "a ROS 2 bag is read from its folder, which holds metadata.yaml: not found",
            path,
        )
    try:
        with AnyReader([folder], default_typestore=store) as reader:
            connections = [c for c in reader.connections if c.msgtype == MESSAGE]
            if not connections:
                topics = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})) or "none"
                raise bad(
                    f"robot_calibration bag {str(path)!r}",
                    f"no {MESSAGE} topic (the calibrate node records /calibration_data); topics: {topics}",
                    path,
                )
            return [
                _as_dict(reader.deserialize(raw, c.msgtype))
                for c, _, raw in reader.messages(connections=connections)
            ]
    except AnyReaderError as exc:
        raise BadMeasurementData(
            f"robot_calibration bag {str(path)!r}: not a readable bag ({exc})", file=str(path)
        ) from None


def _as_dict(message: object) -> dict:
    """A deserialised CalibrationData as the YAML mappings the reader takes."""
    states = message.joint_states  # type: ignore[attr-defined]
    return {
        "joint_states": {"name": list(states.name), "position": [float(p) for p in states.position]},
        "observations": [
            {
                "sensor_name": o.sensor_name,
                "features": [
                    {
                        "header": {"frame_id": f.header.frame_id},
                        "point": {"x": float(f.point.x), "y": float(f.point.y), "z": float(f.point.z)},
                    }
                    for f in o.features
                ],
            }
            for o in message.observations  # type: ignore[attr-defined]
        ],
    }
