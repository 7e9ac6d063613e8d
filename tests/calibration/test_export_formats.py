"""pincal export in every format (issue 30, item 3): each file written is read back the way its
tool reads it (xacro expands the overlay; ur_description loads the YAML; ros2_control's transmission
and robot_calibration's offsets as their parsers read them) and reproduces the calibration's points."""

from __future__ import annotations

import json
import shutil
import warnings

import numpy as np
import pinocchio as pin
import pytest
import yaml
from lxml import etree

import pincal
from pincal import random_errors
from pincal.cli import main
from pincal.compensation.calibration_file import load_calibration
from pincal.errors import PincalWarning
from pincal.export.urdf import export_urdf, sidecar_path
from pincal.export.xacro import corrections_path
from pincal.model.urdf import expanded_text
from tests.conftest import ROOT

MARKERS = [(0.1, 0.02, 0.05), (-0.03, 0.08, 0.02)]
BASE = pin.SE3(pin.rpy.rpyToMatrix(0.01, -0.02, 0.3), np.array([1.5, -0.4, 0.2]))
ARM = """<?xml version="1.0"?>
<robot xmlns:xacro="http://wiki.ros.org/xacro" name="arm">
  <xacro:arg name="kinematics_params" default="${xacro.abs_filename('arm_kinematics.yaml')}"/>
  <xacro:property name="kin" value="${xacro.load_yaml('$(arg kinematics_params)')['kinematics']}"/>
  <xacro:macro name="origin" params="joint">
    <origin xyz="${kin[joint]['x']} ${kin[joint]['y']} ${kin[joint]['z']}"
            rpy="${kin[joint]['roll']} ${kin[joint]['pitch']} ${kin[joint]['yaw']}"/>
  </xacro:macro>
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><xacro:origin joint="j1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><xacro:origin joint="j2"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="j3" type="prismatic"><parent link="l2"/><child link="l3"/><xacro:origin joint="j3"/>
    <axis xyz="1 0 0"/><limit lower="0" upper="0.4" effort="1" velocity="1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="l3"/><child link="tool"/>
    <origin xyz="0.1 0 0.05" rpy="0 1.5707963267948966 0"/></joint>
</robot>
"""
ARM_KINEMATICS = """kinematics:
  j1: {x: 0, y: 0, z: 0.4, roll: 0, pitch: 0, yaw: 0}
  j2: {x: 0.05, y: 0, z: 0.1, roll: 0, pitch: 0, yaw: 0}
  j3: {x: 0.5, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}
"""
FORMATS = ("mjcf", "robot_calibration", "ros2_control", "sdf", "urdf", "xacro", "yaml")


def _calibrated(robot, seed=2, gains=True):
    """A calibration of ``robot``: every origin, offset and marker wrong, a base, gains."""
    truth = random_errors(
        robot.parameters("full,offsets,markers"), error_std={"length": 1e-2, "angle": 5e-2}, seed=seed
    ).robot
    rng = np.random.default_rng(seed)
    return truth.replace(
        base=BASE, joint_gains=rng.normal(0, 1e-3, robot.nq) if gains else np.zeros(robot.nq)
    )


def _max_error(a, b, n=100) -> float:
    qs = a.random_configurations(n, np.random.default_rng(5))
    return float(np.max(np.linalg.norm(a.points(qs) - b.points(qs), axis=-1)))


@pytest.fixture
def arm(tmp_path):
    """A xacro description that reads its joint origins from a kinematics YAML, its calibration
    (cal.urdf and sidecar) and the calibrated robot."""
    folder = tmp_path / "description"
    folder.mkdir()
    (folder / "arm.urdf.xacro").write_text(ARM)
    (folder / "arm_kinematics.yaml").write_text(ARM_KINEMATICS)
    robot = pincal.load_robot(folder / "arm.urdf.xacro", tip="tool", markers=MARKERS)
    truth = _calibrated(robot)
    urdf = export_urdf(truth, tmp_path / "cal.urdf")
    return folder / "arm.urdf.xacro", urdf, truth


def _with_origins(source, origins: dict, path):
    """The source's URDF with the joints' <origin> set to ``origins`` ({joint: {x..yaw}})."""
    root = etree.fromstring(expanded_text(source).encode())
    for joint in root.iter("joint"):
        values = origins.get(joint.get("name"))
        if values is not None:
            origin = joint.find("origin")
            origin.set("xyz", " ".join(repr(float(values[k])) for k in ("x", "y", "z")))
            origin.set("rpy", " ".join(repr(float(values[k])) for k in ("roll", "pitch", "yaw")))
    path.write_bytes(etree.tostring(root))
    return path


def test_every_format_is_offered_and_explained(capsys):
    from pincal.cli.export import FORMATS as WRITERS

    assert tuple(sorted(WRITERS)) == FORMATS
    with pytest.raises(SystemExit):
        main(["export", "--help"])
    text = capsys.readouterr().out
    for name in FORMATS:
        assert f"  {name}  " in text or f"  {name}   " in text, name
    assert "--source" in text


def test_xacro_overlay_reproduces_the_calibration(tmp_path, arm, cli):
    source, urdf, truth = arm
    before = source.read_bytes()
    out = tmp_path / "overlay" / "cal.urdf.xacro"
    out.parent.mkdir()
    code, said, _ = cli.run("export", str(urdf), "--format", "xacro", "--out", str(out))
    assert code == 0 and "expanded with xacro" in said
    assert source.read_bytes() == before  # the description is unchanged
    assert sorted(p.name for p in out.parent.iterdir()) == [
        "cal.corrections.yaml",
        "cal.urdf.calibration.json",
        "cal.urdf.xacro",
    ]
    text = out.read_text()
    assert "xacro:include" in text and "../description/arm.urdf.xacro" in text
    # xacro expands the wrapper (pincal loads a xacro file through xacro), the sidecar beside it
    nominal = pincal.load_robot(source, tip="tool")
    overlay = load_calibration(out, nominal).robot
    assert _max_error(truth, overlay) <= 1e-9
    assert _max_error(nominal.replace(markers=truth.markers), overlay) > 1e-3  # it did change
    kinematics = yaml.safe_load(corrections_path(out).read_text())["kinematics"]
    assert set(kinematics) == {"j1", "j2", "j3", "tool_joint"}


def test_xacro_overlay_of_ur_description(tmp_path):
    """A UR10e from ur_description (unchanged files): the overlay's YAML is ur_description's
    kinematics_params layout, and ur_description reads it as its own."""
    package = tmp_path / "ur_description"
    shutil.copytree(ROOT / "tests" / "data" / "ur_description", package)
    cell = tmp_path / "ur10e_cell.urdf.xacro"
    shutil.copy(ROOT / "tests" / "data" / "overlay" / "ur10e_cell.urdf.xacro", cell)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PincalWarning)  # the meshes are left out
        robot = pincal.load_robot(cell, tip="tool0", markers=MARKERS)
        truth = _calibrated(robot, seed=4)
        urdf = export_urdf(truth, tmp_path / "cal.urdf")
        assert (
            main(["export", str(urdf), "--format", "xacro", "--out", str(tmp_path / "cal.urdf.xacro")]) == 0
        )
        overlay = load_calibration(tmp_path / "cal.urdf.xacro", robot).robot
        assert _max_error(truth, overlay) <= 1e-9
        written = yaml.safe_load((tmp_path / "cal.corrections.yaml").read_text())
        kinematics = written["kinematics"]
        assert list(kinematics) == [
            "shoulder",
            "upper_arm",
            "forearm",
            "wrist_1",
            "wrist_2",
            "wrist_3",
            "hash",
        ]
        # as kinematics_params of ur_description itself: its default file replaced by ours
        shutil.copy(
            tmp_path / "cal.corrections.yaml", package / "config" / "ur10e" / "default_kinematics.yaml"
        )
        markers = json.loads(sidecar_path(tmp_path / "cal.urdf.xacro").read_text())["markers"]
        direct = pincal.load_robot(cell, tip="tool0", markers=markers).replace(
            base=BASE, joint_gains=truth.joint_gains
        )
        assert _max_error(truth, direct) <= 1e-9


def test_a_description_with_literal_origins_is_refused(tmp_path, cli):
    robot = pincal.load_robot("planar_2r", markers=MARKERS[:1])
    urdf = export_urdf(_calibrated(robot, gains=False), tmp_path / "cal.urdf")
    out = tmp_path / "cal.urdf.xacro"
    err = cli.fails("export", str(urdf), "--format", "xacro", "--out", str(out), match="kinematics YAML")
    assert "--format urdf" in err
    assert not out.exists() and not corrections_path(out).exists()


def test_yaml_round_trips(tmp_path, arm, cli):
    source, urdf, truth = arm
    out = tmp_path / "cal.yaml"
    code, said, err = cli.run("export", str(urdf), "--format", "yaml", "--out", str(out))
    assert code == 0, err
    written = yaml.safe_load(out.read_text())
    assert written["format"] == "pincal-corrections-1" and written["source"] == "arm.urdf.xacro"
    markers = np.array(written["markers"])
    base = written["base"]
    base = pin.SE3(
        pin.rpy.rpyToMatrix(base["roll"], base["pitch"], base["yaw"]), np.array([base[k] for k in "xyz"])
    )
    gains = np.array([written["joints"][n]["gain"] for n in truth.joint_names])
    # kinematics: the offsets folded in, no offset table
    folded = _with_origins(source, written["kinematics"], tmp_path / "folded.urdf")
    robot = pincal.load_robot(folded, tip="tool", markers=markers).replace(base=base, joint_gains=gains)
    assert _max_error(truth, robot) <= 1e-9
    # joints: the origins without the offsets, and the offsets apart
    origins = {name: joint["origin"] for name, joint in written["joints"].items()}
    origins["tool_joint"] = written["tool"]["origin"]
    apart = _with_origins(source, origins, tmp_path / "apart.urdf")
    offsets = np.array([written["joints"][n]["offset"] for n in truth.joint_names])
    robot = pincal.load_robot(apart, tip="tool", markers=markers)
    robot = robot.replace(base=base, joint_gains=gains, joint_offsets=offsets)
    assert _max_error(truth, robot) <= 1e-9
    np.testing.assert_allclose(offsets, truth.joint_offsets, atol=1e-15)
    np.testing.assert_allclose(gains, truth.joint_gains, atol=1e-15)


def test_ros2_control_offsets_as_its_parser_reads_them(tmp_path, arm, cli):
    """hardware_interface reads <transmission><joint><offset>/<mechanical_reduction>; SimpleTransmission
    gives joint = actuator / reduction + offset: with the origins without offsets, the readings
    through the transmission place the robot as the calibration does."""
    source, urdf, truth = arm
    out = tmp_path / "cal.ros2_control.xml"
    assert cli.run("export", str(urdf), "--format", "ros2_control", "--out", str(out))[0] == 0
    cli.run("export", str(urdf), "--format", "yaml", "--out", str(tmp_path / "cal.yaml"))
    root = etree.parse(str(out)).getroot()
    offsets, factors = {}, {}
    for joint in root.find("ros2_control").iter("joint"):
        offsets[joint.get("name")] = float(joint.findtext("offset"))
        factors[joint.get("name")] = float(joint.findtext("mechanical_reduction"))
    rising = {j.get("name"): float(j.find("calibration").get("rising")) for j in root.findall("joint")}
    assert list(offsets) == list(truth.joint_names) and rising == offsets
    written = yaml.safe_load((tmp_path / "cal.yaml").read_text())
    origins = {name: joint["origin"] for name, joint in written["joints"].items()}
    origins["tool_joint"] = written["tool"]["origin"]
    apart = pincal.load_robot(
        _with_origins(source, origins, tmp_path / "apart.urdf"), tip="tool", markers=truth.markers
    )
    qs = truth.random_configurations(100, np.random.default_rng(6))
    # the reading q: the actuator through the old reduction n; the new reduction n·factor
    joint = np.array([qs[:, k] / factors[n] + offsets[n] for k, n in enumerate(truth.joint_names)]).T
    points = apart.replace(base=truth.base).points(joint, check=False)
    assert float(np.max(np.abs(points - truth.points(qs)))) <= 1e-9


def _robot_calibration_urdf(source, offsets: dict, path):
    """robot_calibration's updateURDF: each frame's offset composed on the right of the joint's
    origin (x, y, z; a, b, c an angle-axis vector), each joint offset a <calibration rising>."""
    root = etree.fromstring(expanded_text(source).encode())
    rising = {}
    for joint in root.iter("joint"):
        name = joint.get("name")
        if name in offsets:
            rising[name] = offsets[name]
        if f"{name}_x" in offsets:
            element = joint.find("origin")
            xyz = [float(v) for v in element.get("xyz").split()]
            rpy = [float(v) for v in element.get("rpy").split()]
            origin = pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))
            change = pin.SE3(
                pin.exp3(np.array([offsets[f"{name}_{k}"] for k in "abc"])),
                np.array([offsets[f"{name}_{k}"] for k in "xyz"]),
            )
            origin = origin * change
            element.set("xyz", " ".join(repr(float(v)) for v in origin.translation))
            element.set("rpy", " ".join(repr(float(v)) for v in pin.rpy.matrixToRpy(origin.rotation)))
    path.write_bytes(etree.tostring(root))
    return path, rising


def test_robot_calibration_offsets_as_it_loads_them(tmp_path, arm, cli):
    source, urdf, truth = arm
    out = tmp_path / "calibration_offsets.yaml"
    assert cli.run("export", str(urdf), "--format", "robot_calibration", "--out", str(out))[0] == 0
    offsets = {}
    for line in out.read_text().splitlines():  # OptimizationOffsets::loadOffsetYAML: "name: value"
        parts = line.split()
        try:
            offsets[parts[0].removesuffix(":")] = float(parts[1])
        except (IndexError, ValueError):
            continue
    assert "#" not in offsets and "" not in offsets  # its comments are skipped by that reader
    assert {f"j1_{k}" for k in "xyzabc"} <= set(offsets) and "tool_joint_a" in offsets
    path, rising = _robot_calibration_urdf(source, offsets, tmp_path / "rc.urdf")
    robot = pincal.load_robot(path, tip="tool", markers=truth.markers)
    offsets = np.array([rising[n] for n in truth.joint_names])  # added to the reading (chain FK)
    robot = robot.replace(base=truth.base, joint_offsets=offsets, joint_gains=truth.joint_gains)
    assert _max_error(truth, robot) <= 1e-9


def test_urdf_and_mjcf_from_the_calibration(tmp_path, arm, cli):
    source, urdf, truth = arm
    for fmt, name in (("urdf", "again.urdf"), ("mjcf", "again.xml")):
        assert cli.run("export", str(urdf), "--format", fmt, "--out", str(tmp_path / name))[0] == 0
        again = load_calibration(tmp_path / name, pincal.load_robot(source, tip="tool")).robot
        assert _max_error(truth, again) <= 1e-9


def test_an_old_sidecar_needs_source(tmp_path, arm, cli):
    source, urdf, truth = arm
    side = sidecar_path(urdf)
    content = json.loads(side.read_text())
    del content["source"]
    side.write_text(json.dumps(content))
    cli.fails("export", str(urdf), "--format", "yaml", "--out", str(tmp_path / "c.yaml"), match="--source")
    code = cli.run(
        "export", str(urdf), "--format", "yaml", "--out", str(tmp_path / "c.yaml"), "--source", str(source)
    )
    assert code[0] == 0
