"""Robots as users bring them: trees, floating bases, grippers, continuous and zero-range joints,
xacro files, missing meshes (issue 11)."""

from __future__ import annotations

import json
import math
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.cli import main
from pincal.errors import AmbiguousTip, FrameNotFound, PincalWarning, UnsupportedJoint, UrdfError
from pincal.model.loading import chain_ends
from tests.support.urdfs import XACRO_ARM, joint_xml, tree_urdf, urdf


@pytest.fixture
def tree(tmp_path):
    def write(name="tree.urdf", **kwargs):
        path = tmp_path / name
        path.write_text(tree_urdf(**kwargs))
        return path

    return write


def test_default_tip_is_the_hand_not_a_finger(tree):
    robot = pincal.load_robot(tree())
    assert robot.tip == "tcp"
    assert robot.joint_names == ("a1", "a2", "a3", "a4")  # the fingers are locked


def hand_urdf() -> str:
    """A spine joint named like a finger ('middle_lumbar') under a 2-joint arm that ends in an
    anthropomorphic hand: a finger joint whose own link has a finger hanging on it (romeo's
    LHand -> LFinger11Link -> LFinger12) and fingers named as TIAGo's (hand_index_joint,
    hand_mrl_joint)."""
    links = [
        "pelvis",
        "middle_abdomen",
        "l1",
        "palm",
        "LFinger11Link",
        "LFinger12Link",
        "hand_index_link",
        "hand_index_flex_2_link",
        "hand_mrl_link",
    ]
    joints = [
        joint_xml("middle_lumbar_Z", "revolute", "pelvis", "middle_abdomen", "0 0 0.2"),
        joint_xml("a1", "revolute", "middle_abdomen", "l1", "0 0 0.3", axis="0 1 0"),
        joint_xml("wrist", "revolute", "l1", "palm", "0.4 0 0", axis="1 0 0"),
        joint_xml("LHand", "revolute", "palm", "LFinger11Link", "0.05 0 0", limits=(0, 1)),
        joint_xml("LFinger12", "revolute", "LFinger11Link", "LFinger12Link", "0.02 0 0", limits=(0, 1)),
        joint_xml("hand_index_joint", "revolute", "palm", "hand_index_link", "0.05 0.02 0", limits=(0, 1)),
        joint_xml(
            "hand_index_flex_2_joint",
            "revolute",
            "hand_index_link",
            "hand_index_flex_2_link",
            "0.02 0 0",
            limits=(0, 1),
        ),
        joint_xml("hand_mrl_joint", "revolute", "palm", "hand_mrl_link", "0.05 -0.02 0", limits=(0, 1)),
    ]
    return urdf("hand", links, joints)


def test_an_anthropomorphic_hand_is_one_end_its_fingers_locked(tmp_path):
    path = tmp_path / "hand.urdf"
    path.write_text(hand_urdf())
    robot = pincal.load_robot(path)
    assert robot.tip == "palm"  # neither a finger tip nor the spine's end
    assert robot.joint_names == ("middle_lumbar_Z", "a1", "wrist")
    (palm,) = [c for c in chain_ends(path).candidates if not c.finger]
    assert set(palm.hand) == {"LHand", "hand_index_joint", "hand_mrl_joint"}


def test_ambiguous_tip_lists_the_chain_ends_fingers_marked(tree):
    with pytest.raises(AmbiguousTip) as info:
        pincal.load_robot(tree(arm2=True))
    message = str(info.value)
    assert (
        "--tip" in message
        and "tcp (4 joints; hand: finger joints finger_left, finger_right locked)" in message
    )
    assert "b_tool (2 joints)" in message and "left_finger (5 joints; gripper finger)" in message
    assert pincal.load_robot(tree(arm2=True), tip="b_tool").joint_names == ("b1", "b2")


def test_root_picks_the_chain_and_points_are_in_the_root_frame(tree):
    path = tree()
    robot = pincal.load_robot(path, tip="tcp", root="l2")
    assert robot.joint_names == ("a3", "a4") and robot.root == "l2"
    # Oracle: the full tree's forward kinematics, the tip expressed in the root link's frame.
    full = pin.buildModelFromUrdf(str(path))
    data = full.createData()
    rng = np.random.default_rng(0)
    for q in robot.random_configurations(5, rng):
        qf = pin.neutral(full)
        qf[full.idx_qs[full.getJointId("a3")]] = q[0]
        qf[full.idx_qs[full.getJointId("a4")]] = q[1]
        pin.framesForwardKinematics(full, data, qf)
        tip = data.oMf[full.getFrameId("tcp", pin.BODY)]
        root = data.oMf[full.getFrameId("l2", pin.BODY)]
        np.testing.assert_allclose(robot.points(q)[0, 0], (root.inverse() * tip).translation, atol=1e-12)


def test_root_must_be_above_the_tip(tree):
    with pytest.raises(FrameNotFound, match="not above the tip"):
        pincal.load_robot(tree(arm2=True), tip="tcp", root="b1")


def test_floating_base_is_never_calibrated_and_is_said(tree):
    model = pin.buildModelFromUrdf(str(tree(continuous=False)), pin.JointModelFreeFlyer())
    with pytest.warns(PincalWarning, match="floating base"):
        robot = pincal.load_robot(model, tip="tcp")
    assert robot.joint_names == ("a1", "a2", "a3", "a4")
    with pytest.raises(UnsupportedJoint, match="continuous.*from its URDF"):
        pincal.load_robot(pin.buildModelFromUrdf(str(tree())), tip="tcp")
    fixed = pincal.load_robot(tree(continuous=False), tip="tcp")
    qs = fixed.random_configurations(4, 1)
    np.testing.assert_allclose(robot.points(qs), fixed.points(qs), atol=1e-12)


def test_floating_example_robot_data_robot_names_its_base():
    with pytest.raises(AmbiguousTip, match="floating base.*FL_FOOT"):
        pincal.load_robot("solo12")
    assert pincal.load_robot("solo12", tip="FL_FOOT").nq == 3


def test_continuous_joint_has_a_one_turn_range_that_can_be_set(tree):
    robot = pincal.load_robot(tree())
    j = robot.joint_names.index("a2")
    assert (robot.lower[j], robot.upper[j]) == (-np.pi, np.pi)
    robot = pincal.load_robot(tree(), joint_ranges={"a2": (-1.0, 3.0)})
    assert (robot.lower[j], robot.upper[j]) == (-1.0, 3.0)
    with pytest.raises(pincal.errors.UnknownName, match="a9"):
        pincal.load_robot(tree(), joint_ranges={"a9": (0, 1)})


def test_continuous_joint_through_params_design_identify_export(tree, tmp_path):
    robot = pincal.load_robot(tree(), markers=[(0.05, 0.02, 0.03)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    assert "a2.offset" in params.names
    m = -(-len(params) // 3) + 2
    result = pincal.design(
        params, m, test_pose=robot.random_configurations(1, 3), search=pincal.Search(starts=2, seed=1)
    )
    truth = pincal.random_errors(params, seed=4)
    data = pincal.simulate_measurements(truth, result.plan, sigma=0.0)
    fit = pincal.identify(params, data)
    assert fit.success
    np.testing.assert_allclose(fit.values, truth.values, atol=1e-8)
    out = pincal.export_urdf(fit, tmp_path / "calibrated.urdf")  # checks its own round trip to 1e-9 m
    assert 'type="continuous"' in out.read_text()


def test_zero_range_joint_is_locked_with_a_warning(tree):
    with pytest.warns(PincalWarning, match="a3.*zero range.*--joint-range"):
        robot = pincal.load_robot(tree(zero=True))
    assert robot.joint_names == ("a1", "a2", "a4")
    assert pincal.load_robot(tree(zero=True), joint_ranges={"a3": (-1, 1)}).nq == 4


def test_all_zero_range_is_refused_in_one_line(tmp_path, capsys):
    with pytest.raises(UnsupportedJoint, match="zero range"):
        pincal.load_robot("double_pendulum")
    assert main(["params", "double_pendulum"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("pincal: error:")
    assert (
        main(["params", "double_pendulum", "--joint-range", "joint1=-1,1", "--joint-range", "joint2=-1,1"])
        == 0
    )


def test_frames_sharing_a_name_load():
    robot = pincal.load_robot("so100")  # a link and a joint both named 'gripper'
    assert "gripper" not in robot.joint_names and robot.nq == 5


def test_xacro_is_expanded_by_the_xacro_package(tmp_path):
    """The expanded robot is the one the macro describes: points against a hand-written URDF."""
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(XACRO_ARM)
    robot = pincal.load_robot(path)
    plain = tmp_path / "plain.urdf"
    plain.write_text(
        '<robot name="plain"><link name="base"/><link name="l1"/><link name="l2"/><link name="tool0"/>'
        + joint_xml("j1", "revolute", "base", "l1", "0 0 0.4", limits=(-math.pi / 2, math.pi / 2))
        + joint_xml("j2", "revolute", "l1", "l2", "0.4 0 0", axis="0 1 0", limits=(-math.pi / 2, math.pi / 2))
        + joint_xml("t", "fixed", "l2", "tool0", "0.2 0 0")
        + "</robot>"
    )
    reference = pincal.load_robot(plain)
    qs = reference.random_configurations(10, 0)
    assert robot.joint_names == ("j1", "j2") and robot.tip == "tool0"
    np.testing.assert_allclose(robot.points(qs), reference.points(qs), atol=1e-12)
    np.testing.assert_allclose(robot.upper, np.full(2, math.pi / 2))


def test_xacro_find_resolves_packages_without_ros(tmp_path, capsys):
    """$(find NAME) (a ROS package lookup) resolves to a folder NAME above the xacro file, or to
    --package-dir NAME=PATH: vendor descriptions expand as checked out, without ROS."""
    package = tmp_path / "src" / "my_arm_description"
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text("<package><name>my_arm_description</name></package>")
    (package / "urdf" / "arm_macro.xacro").write_text(
        XACRO_ARM.replace('name="xarm"', 'name="macro"')
        .replace("<link", "<xacro:macro name='arm'><link", 1)
        .replace("</robot>", "</xacro:macro></robot>")
    )
    top = package / "urdf" / "arm.urdf.xacro"
    top.write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="xarm">'
        '<xacro:include filename="$(find my_arm_description)/urdf/arm_macro.xacro"/><xacro:arm/></robot>'
    )
    robot = pincal.load_robot(top)
    assert robot.joint_names == ("j1", "j2") and robot.tip == "tool0"
    moved = tmp_path / "elsewhere"
    (package.parent).rename(moved)
    top = moved / "my_arm_description" / "urdf" / "arm.urdf.xacro"
    assert pincal.load_robot(top).joint_names == ("j1", "j2")  # still above it
    renamed = moved / "checkout"
    (moved / "my_arm_description").rename(renamed)
    top = renamed / "urdf" / "arm.urdf.xacro"
    assert main(["params", str(top)]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"pincal: error: xacro cannot expand {str(top)!r}: $(find my_arm_description): package "
        "'my_arm_description' not found above arm.urdf.xacro; give --package-dir "
        "my_arm_description=PATH (package_dirs=)\n"
    )
    assert main(["params", str(top), "--package-dir", f"my_arm_description={renamed}"]) == 0
    assert "ament_index_python" not in sys.modules  # the stand-in index is gone after each expansion


def test_xacros_own_warnings_are_one_pincal_warning_line(tmp_path, capsys):
    """xacro prints its warnings on stderr itself (in colour, with a 'when processing' line)."""
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(
        XACRO_ARM.replace(
            '<xacro:property name="l" value="0.4"/>', '<xacro:property name="l" value="0.4" foo="1"/>'
        )
    )
    assert main(["params", str(path)]) == 0
    err = capsys.readouterr().err
    assert (
        err == "pincal: warning: xacro, expanding arm.urdf.xacro: xacro:property: unknown attribute(s): foo\n"
    )


def test_xacro_gives_the_command(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "xacro", None)  # the xacro package is not installed
    path = tmp_path / "arm.urdf.xacro"
    path.write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="a"><xacro:macro name="m"/></robot>'
    )
    with pytest.raises(UrdfError, match=r"xacro .*arm\.urdf\.xacro -o .*arm\.urdf"):
        pincal.load_robot(path)
    assert main(["params", str(path)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    saved = tmp_path / "saved.urdf"  # a xacro source saved as .urdf: urdfdom cannot read ${...}
    saved.write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="a"><xacro:property name="l" value="1"/>'
        '<link name="a"/><link name="b"/><joint name="j" type="revolute"><parent link="a"/>'
        '<child link="b"/><limit lower="${-l}" upper="1" effort="1" velocity="1"/></joint></robot>'
    )
    with pytest.raises(UrdfError, match=r"is a xacro file.*xacro .*saved\.urdf -o .*saved\.expanded\.urdf"):
        pincal.load_robot(saved)


def test_missing_mesh_is_one_warning_line(tree, tmp_path, capsys):
    path = tree(mesh="package://tree_description/meshes/l1.stl")
    assert main(["params", str(path)]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("pincal: warning: tree.urdf: 1 mesh file(s) not found")
    mesh = tmp_path / "pkg" / "meshes" / "l1.stl"
    mesh.parent.mkdir(parents=True)
    mesh.write_text("solid l1\nendsolid l1\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", PincalWarning)
        pincal.load_robot(path, package_dirs={"tree_description": str(tmp_path / "pkg")})
    assert main(["params", str(path), "--package-dir", f"tree_description={tmp_path / 'pkg'}"]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "text",
    [
        "",
        "<robot",
        "<notarobot/>",
        '<robot name="r"><link name="a"/><joint name="j" type="revolute"><parent link="a"/>'
        '<child link="b"/></joint></robot>',
        '<robot name="r"><link name="a"/></robot>',
    ],
)
def test_malformed_urdf_is_one_error_line(tmp_path, capsys, text):
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    assert main(["params", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("pincal: error:"), err


def test_robots_lists_the_chains_each_robot_offers(capsys):
    assert main(["robots", "--json"]) == 0
    chains = json.loads(capsys.readouterr().out)["chains"]
    assert chains["kr270"]["default_tip"] == "tool0" and not chains["kr270"]["floating"]
    panda = chains["panda"]
    assert panda["default_tip"] == "panda_hand_tcp"
    assert any(t["finger"] for t in panda["tips"]) and "panda_finger_joint1" in panda["tips"][0]["hand"]
    assert chains["talos"]["floating"] and chains["talos"]["default_tip"] is None
    assert not chains["cassie"]["loadable"] and "URDF" in chains["cassie"]["reason"]
    pendulum = chains["double_pendulum"]  # zero-range joints only
    assert not pendulum["loadable"] and "--joint-range" in pendulum["reason"]
    assert main(["robots", "talos", "--root", "torso_2_link"]) == 0
    out = capsys.readouterr().out
    assert "chains from torso_2_link" in out and "--tip gripper_left_base_link (7 joints" in out


def test_a_tool_frame_with_a_camera_hung_on_it_is_the_tip(tmp_path):
    """The Kinova Gen3 with vision: camera frames hang below end_effector_link on the last joint;
    the tool frame is the tip, not one of three camera frames."""
    links = [
        "base",
        "l1",
        "l2",
        "end_effector_link",
        "camera_link",
        "camera_color_frame",
        "camera_depth_frame",
    ]
    joints = [
        joint_xml("j1", "revolute", "base", "l1", "0 0 0.2"),
        joint_xml("j2", "revolute", "l1", "l2", "0.3 0 0", axis="0 1 0"),
        joint_xml("ee", "fixed", "l2", "end_effector_link", "0.1 0 0"),
        joint_xml("camera_module", "fixed", "end_effector_link", "camera_link", "0 0.05 0"),
        joint_xml("color", "fixed", "camera_link", "camera_color_frame", "0 0.01 0"),
        joint_xml("depth", "fixed", "camera_link", "camera_depth_frame", "0 -0.01 0"),
    ]
    path = tmp_path / "gen3_like.urdf"
    path.write_text(urdf("gen3_like", links, joints))
    assert pincal.load_robot(path).tip == "end_effector_link"
    assert pincal.load_robot(path, tip="camera_color_frame").tip == "camera_color_frame"


def test_chain_ends_are_listed_longest_first(tmp_path):
    """A humanoid's error lists its arms before its many short sensor chains (the list is cut)."""
    links = ["torso", "head", "camera", "a1", "a2", "a3", "hand", "leg", "sole"]
    joints = [
        joint_xml("neck", "revolute", "torso", "head", "0 0 0.5"),
        joint_xml("camera_joint", "fixed", "head", "camera", "0.1 0 0"),
        joint_xml("hip", "revolute", "torso", "leg", "0 0 -0.2"),
        joint_xml("ankle_fixed", "fixed", "leg", "sole", "0 0 -0.4"),
        joint_xml("s1", "revolute", "torso", "a1", "0 0.2 0.4"),
        joint_xml("s2", "revolute", "a1", "a2", "0 0.1 0", axis="0 1 0"),
        joint_xml("e1", "revolute", "a2", "a3", "0.3 0 0", axis="0 1 0"),
        joint_xml("w1", "fixed", "a3", "hand", "0.3 0 0"),
    ]
    path = tmp_path / "humanoid.urdf"
    path.write_text(urdf("humanoid", links, joints))
    ends = chain_ends(path).candidates
    assert [(c.frame, c.joints) for c in ends][0] == ("hand", 3)  # declared last
    assert sorted(c.frame for c in ends[1:]) == ["camera", "sole"]
    with pytest.raises(AmbiguousTip, match=r"--tip FRAME \(tip=\): hand \(3 joints\), "):
        pincal.load_robot(path)
