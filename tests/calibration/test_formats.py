"""Other tools' data (pincal.calibration.formats): each reader gives the measurements the nominal
robot predicts from a small file in that tool's own layout (tests/data/<tool>/, written from its
documentation and examples: exact data of the UR10 at six configurations, its base 1.5 m away and
turned, the measured frame 5 cm out and 12 cm along the tool, turned 90° about its axis); the
formats are found from the files; identify takes them; bad files are one error naming the file
and the key or line."""

from __future__ import annotations

import shutil

import numpy as np
import pinocchio as pin
import pytest
import yaml

import pincal
from pincal.calibration.formats import FORMATS, format_of, read_measurements
from pincal.cli import main
from pincal.errors import BadArgument, BadMeasurementData
from pincal.instruments import Partial, Pose
from tests.conftest import ROOT

DATA = ROOT / "tests" / "data"
BASE = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([1.5, -0.4, 0.2]))
"""The robot's base in the instrument frame, as the fixtures were written."""
MARKER = (0.05, 0.0, 0.12)
FEATURES = [(0.02, 0.0, 0.1), (-0.02, 0.0, 0.1)]
MOVEIT = {"joint_states": DATA / "moveit" / "joint_states.yaml"}
pytestmark = pytest.mark.ur10(markers=[MARKER], base=BASE)  # the ur10 fixture (tests/conftest.py)


@pytest.mark.parametrize(
    ("path", "name", "options"),
    [
        ("figaroh/config/ur10_config.yaml", "figaroh", {}),
        ("industrial_calibration/measurements.yaml", "industrial_calibration", {}),
        ("moveit/samples.yaml", "moveit", MOVEIT),
    ],
)
def test_poses_are_the_robots(ur10, path, name, options):
    assert format_of(DATA / path) == name
    data = read_measurements(DATA / path, ur10, **options)
    assert isinstance(data.kind, Pose) and data.m == 6 and data.joint_names == ur10.joint_names
    error = Pose().difference(data.values, Pose().predict(ur10, data.q))
    assert np.abs(error).max() < 1e-8
    assert data.for_robot(ur10) is data


def test_figaroh_csv_alone_and_points():
    """The CSV alone says what was measured (its marker frame then has the tool's axes); position
    columns of two markers are points; other joints' columns are left out."""
    robot = pincal.load_robot("ur10").replace(base=BASE, markers=[MARKER, (-0.05, 0.02, 0.1)])
    data = read_measurements(DATA / "figaroh" / "data" / "points.csv", robot)
    assert data.is_points and data.points.shape == (6, 2, 3)
    assert np.abs(data.points - robot.points(data.q)).max() < 1e-8
    alone = read_measurements(DATA / "figaroh" / "data" / "calibration.csv", robot.replace(markers=[MARKER]))
    turned = read_measurements(
        DATA / "figaroh" / "config" / "ur10_config.yaml", robot.replace(markers=[MARKER])
    )
    assert np.allclose(alone.values[:, :3], turned.values[:, :3])
    R = pin.exp3(alone.values[0, 3:]).T @ pin.exp3(turned.values[0, 3:])
    assert np.isclose(abs(pin.log3(R)[2]), np.pi / 2)


def test_figaroh_partial_and_refused(tmp_path, ur10):
    """Some positions are a partial measurement; a part of roll-pitch-yaw is refused."""
    source = (DATA / "figaroh" / "data" / "calibration.csv").read_text().splitlines()
    header = source[0].split(",")

    def write(keep):
        rows = [[c for h, c in zip(header, line.split(",")) if h in keep] for line in source]
        path = tmp_path / "c.csv"
        path.write_text("\n".join(",".join(r) for r in rows) + "\n")
        return path

    joints = list(ur10.joint_names)
    data = read_measurements(write(["x1", "z1", *joints]), ur10, format="figaroh")
    assert data.kind == Partial(("x", "z")) and data.values.shape == (6, 2)
    with pytest.raises(BadMeasurementData, match="phix.*alone.*rotation vector"):
        read_measurements(write(["x1", "y1", "z1", "phix1", *joints]), ur10, format="figaroh")
    with pytest.raises(BadMeasurementData, match="no value for the robot's joint.*wrist_3_joint"):
        read_measurements(write(["x1", "y1", "z1", *joints[:-1]]), ur10, format="figaroh")


def test_figaroh_config_checks(tmp_path, ur10):
    shutil.copytree(DATA / "figaroh", tmp_path / "f")
    config = tmp_path / "f" / "config" / "ur10_config.yaml"
    with pytest.raises(BadMeasurementData, match="tool_frame.*robot's tip is 'ee_link': give --tip tool0"):
        read_measurements(config, pincal.load_robot("ur10", tip="ee_link"))
    text = config.read_text()
    config.write_text(text.replace("data/calibration.csv", "data/missing.csv"))
    with pytest.raises(BadMeasurementData, match="key calibration.data_file.*missing.csv"):
        read_measurements(config, ur10)
    config.write_text(text.replace("measure: [True, True, True, True, True, True]", "measure: [1, 1]"))
    with pytest.raises(BadMeasurementData, match=r"calibration.markers\[0\].measure: expected six booleans"):
        read_measurements(config, ur10)


def test_robot_calibration_yaml(ur10):
    robot = ur10.replace(markers=FEATURES)
    path = DATA / "robot_calibration" / "calibration_data.yaml"
    assert format_of(path) == "robot_calibration"
    with pytest.raises(BadMeasurementData, match="2 sensors: arm .*camera.*--sensor NAME"):
        read_measurements(path, robot)
    data = read_measurements(path, robot, sensor="camera")
    assert data.is_points and data.points.shape == (6, 2, 3)
    assert np.abs(data.points - robot.points(data.q)).max() < 1e-8
    with pytest.raises(BadMeasurementData, match="no observation of sensor 'head'"):
        read_measurements(path, robot, sensor="head")


def test_robot_calibration_bag(tmp_path, ur10):
    """A ROS 2 bag of the same messages (written by rosbags) reads as the YAML does, from its
    folder or its .db3 file."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from pincal.calibration.formats.robot_calibration import DEFINITIONS, MESSAGE

    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in DEFINITIONS.items():
        store.register(get_types_from_msg(text, name))
    T = store.types
    docs = [
        d for d in yaml.safe_load_all((DATA / "robot_calibration" / "calibration_data.yaml").read_text()) if d
    ]
    stamp = T["builtin_interfaces/msg/Time"](sec=0, nanosec=0)

    def header(frame):
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    info = T["sensor_msgs/msg/CameraInfo"](
        header("c"), 0, 0, "", np.zeros(0), np.zeros(9), np.zeros(9), np.zeros(12), 0, 0,
        T["sensor_msgs/msg/RegionOfInterest"](0, 0, 0, 0, False),
    )  # fmt: skip
    cloud = T["sensor_msgs/msg/PointCloud2"](header(""), 0, 0, [], False, 0, 0, np.zeros(0, np.uint8), False)
    image = T["sensor_msgs/msg/Image"](header(""), 0, 0, "", 0, 0, np.zeros(0, np.uint8))
    bag = tmp_path / "calibration_data"
    with Writer(bag, version=8) as writer:
        conn = writer.add_connection("/calibration_data", MESSAGE, typestore=store)
        for i, doc in enumerate(docs):
            js = doc["joint_states"]
            msg = T[MESSAGE](
                T["sensor_msgs/msg/JointState"](
                    header(""), js["name"], np.array(js["position"]), np.zeros(0), np.zeros(0)
                ),
                [
                    T["robot_calibration_msgs/msg/Observation"](
                        o["sensor_name"],
                        [
                            T["geometry_msgs/msg/PointStamped"](
                                header(f["header"]["frame_id"]), T["geometry_msgs/msg/Point"](**f["point"])
                            )
                            for f in o["features"]
                        ],
                        T["robot_calibration_msgs/msg/ExtendedCameraInfo"](info, []),
                        cloud,
                        image,
                    )
                    for o in doc["observations"]
                ],
            )
            writer.write(conn, i, store.serialize_cdr(msg, MESSAGE))
    robot = ur10.replace(markers=FEATURES)
    expected = read_measurements(DATA / "robot_calibration" / "calibration_data.yaml", robot, sensor="camera")
    for path in (bag, next(bag.glob("*.db3"))):
        assert format_of(path) == "robot_calibration"
        data = read_measurements(path, robot, sensor="camera")
        assert np.array_equal(data.points, expected.points) and np.array_equal(data.q, expected.q)


def test_moveit_eye_in_hand(tmp_path, ur10):
    """The camera on the hand: the target's poses in the camera frame are the camera's in the
    target's frame, inverted; the mount is found from the data (the other does not fit)."""
    samples = yaml.safe_load((DATA / "moveit" / "samples.yaml").read_text())
    for s in samples:  # the same numbers read the other way round: the camera on the hand
        T = np.reshape(s["object_wrt_sensor"], (4, 4))
        s["object_wrt_sensor"] = pin.SE3(T[:3, :3], T[:3, 3]).inverse().homogeneous.ravel().tolist()
    path = tmp_path / "samples.yaml"
    path.write_text(yaml.safe_dump(samples))
    data = read_measurements(path, ur10, **MOVEIT)
    assert np.abs(Pose().difference(data.values, Pose().predict(ur10, data.q))).max() < 1e-8
    told = read_measurements(path, ur10, mount="eye_to_hand", **MOVEIT)
    assert np.abs(Pose().difference(told.values, Pose().predict(ur10, told.q))).max() > 1e-3


@pytest.mark.parametrize(
    ("fixture", "edit", "message"),
    [
        (
            "industrial_calibration/measurements.yaml",
            lambda d: d[next(iter(d))]["target_joints"].pop(),
            r"key 1593701755.target_joints: 5 values, expected one per joint",
        ),
        (
            "industrial_calibration/measurements.yaml",
            lambda d: d[next(iter(d))]["pose"].pop("qw"),
            r"key 1593701755.pose: missing key 'qw'",
        ),
        (
            "industrial_calibration/measurements.yaml",
            lambda d: d[next(iter(d))].__setitem__("camera_joints", [0.1]),
            r"camera_joints: 1 camera joint\(s\): pincal's instrument is fixed",
        ),
        (
            "moveit/samples.yaml",
            lambda d: d[2]["object_wrt_sensor"].__setitem__(0, 3.0),
            r"sample 3.object_wrt_sensor: expected a rigid transform",
        ),
        (
            "moveit/samples.yaml",
            lambda d: d.pop(),
            r"joint states file .*key joint_values: 6 joint states for 5 samples",
        ),
        (
            "robot_calibration/calibration_data.yaml",
            lambda d: d[1]["observations"][0]["features"].pop(),
            r"sample 2: 1 features of 'camera', 2 in sample 1",
        ),
        (
            "robot_calibration/calibration_data.yaml",
            lambda d: d[0]["observations"][0]["features"][1]["point"].__setitem__("z", "far"),
            r"sample 1, observations\[0\].features\[1\].point.z: expected a number, got str 'far'",
        ),
    ],
)
def test_bad_files_name_the_key(tmp_path, ur10, fixture, edit, message):
    source = DATA / fixture
    docs = [d for d in yaml.safe_load_all(source.read_text()) if d is not None]
    data = docs if fixture.startswith("robot_calibration") else docs[0]
    edit(data)
    path = tmp_path / source.name
    if fixture.startswith("robot_calibration"):
        path.write_text("".join(yaml.safe_dump(d) + "---\n" for d in data))
    else:
        path.write_text(yaml.safe_dump(data))
    robot = ur10.replace(markers=FEATURES) if fixture.startswith("robot") else ur10
    options = {"sensor": "camera"} if fixture.startswith("robot") else MOVEIT if "moveit" in fixture else {}
    with pytest.raises(BadMeasurementData, match=message) as raised:
        read_measurements(path, robot, **options)
    assert str(path) in str(raised.value) or "joint states" in str(raised.value)


def test_options_and_registry(ur10):
    assert set(FORMATS) == {"pincal", "figaroh", "robot_calibration", "industrial_calibration", "moveit"}
    with pytest.raises(BadArgument, match="unknown measurement format 'vicon'; valid: pincal, figaroh"):
        read_measurements(DATA / "moveit" / "samples.yaml", ur10, format="vicon")
    with pytest.raises(BadArgument, match="sensor: not an option of the moveit format"):
        read_measurements(DATA / "moveit" / "samples.yaml", ur10, sensor="camera", **MOVEIT)
    with pytest.raises(BadArgument, match="hold no joint values: give the joint states"):
        read_measurements(DATA / "moveit" / "samples.yaml", ur10)
    with pytest.raises(BadMeasurementData, match="MoveIt Calibration's joint states; give its samples"):
        format_of(DATA / "moveit" / "joint_states.yaml")


def test_identify_takes_them(capsys):
    """pincal identify reads each format by its file, recovers the base, and refuses the CSV's
    unit options for them."""
    moveit = DATA / "moveit"
    argv = ["identify", "ur10", "--data", str(moveit / "samples.yaml"), "--joint-states"]
    argv += [
        str(moveit / "joint_states.yaml"),
        "--base",
        "--marker",
        "0.05,0,0.12",
        "--params",
        "base",
        "--json",
    ]
    assert main(argv) == 0
    bases = __import__("json").loads(capsys.readouterr().out)["bases"]
    assert np.allclose(bases[0]["xyz"], BASE.translation, atol=1e-6)
    config = str(DATA / "figaroh" / "config" / "ur10_config.yaml")
    assert main(["identify", "ur10", "--data", config, "--deg", "--base"]) == 2
    assert "--deg: for pincal's CSV" in capsys.readouterr().err
