"""Loading robots: URDF paths, shipped names, example-robot-data names, Pinocchio models."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import BadConfiguration, FrameNotFound, RobotNotFound, UnsupportedJoint, UrdfError
from tests.conftest import ROOT


def test_planar_geometry_matches_spec(planar):
    # docs/method.md §9.1: x = l1 cos q1 + l2 cos(q1+q2), l1 = 1, l2 = 0.8.
    q = np.array([[0.3, -1.1], [2.0, 0.4], [0.0, 0.0]])
    p = planar.points(q)[:, 0]
    x = np.cos(q[:, 0]) + 0.8 * np.cos(q.sum(1))
    y = np.sin(q[:, 0]) + 0.8 * np.sin(q.sum(1))
    np.testing.assert_allclose(p, np.column_stack([x, y, 0 * x]), atol=1e-15)
    assert planar.joint_names == ("joint1", "joint2")


def test_kr270_geometry_matches_spec(kr270):
    # docs/method.md §10: zeros = arm stretched along +x; flange at 0.35 + 1.15 + 1.2 + 0.24 in x,
    # 0.675 - 0.041 in z.
    # (all zeros is outside A2's limits, so the unchecked points is used for the geometry)
    p = kr270.points(np.zeros((1, 6)), check=False)[0, 0]
    np.testing.assert_allclose(p, [0.35 + 1.15 + 1.2 + 0.24, 0.0, 0.675 - 0.041], atol=1e-12)
    # A1 about -z: a positive A1 turns the arm towards -y.
    q = np.zeros((1, 6))
    q[0, 0] = 0.5
    assert kr270.points(q, check=False)[0, 0, 1] < 0
    # A2 about +y: lowering limit -140..-5 degrees.
    np.testing.assert_allclose(np.degrees(kr270.lower), [-185, -140, -120, -350, -122.5, -350])
    np.testing.assert_allclose(np.degrees(kr270.upper), [185, -5, 155, 350, 122.5, 350])
    np.testing.assert_allclose(
        np.degrees(kr270.model.velocityLimit), [105, 101, 107, 122, 113, 175], rtol=1e-12
    )


def test_tool0_z_along_a6(kr270):
    # tool0 follows the ROS-Industrial convention: z along A6 outwards (+x at zero).
    robot = pincal.load_robot("kr270", markers=[(0, 0, 0.1)])
    np.testing.assert_allclose(
        robot.points(np.zeros((1, 6)), check=False)[0, 0] - kr270.points(np.zeros((1, 6)), check=False)[0, 0],
        [0.1, 0, 0],
        atol=1e-12,
    )


@pytest.mark.parametrize("name,tip,nq", [("ur10", "tool0", 6), ("panda", "panda_hand", 7), ("ur5", None, 6)])
def test_example_robot_data_by_name(name, tip, nq):
    robot = pincal.load_robot(name, tip=tip)
    assert robot.nq == nq
    assert robot.urdf_path is not None and robot.urdf_path.is_file()


def test_shipped_robots_by_name_and_path():
    assert set(pincal.shipped_robots()) >= {"kr270", "planar_2r"}
    a = pincal.load_robot("kr270")
    b = pincal.load_robot(str(ROOT / "robots" / "kr270.urdf"))
    q = a.random_configurations(5, 0)
    np.testing.assert_array_equal(a.points(q), b.points(q))


def test_shipped_urdfs_state_provenance_and_units():
    for path in (ROOT / "robots").glob("*.urdf"):
        head = path.read_text()[:2000]
        assert "Provenance" in head and "Units" in head, path


def test_load_from_pinocchio_model_copies_it():
    model = pin.buildModelFromUrdf(str(ROOT / "robots" / "planar_2r.urdf"))
    before = pin.SE3(model.jointPlacements[2])
    robot = pincal.load_robot(model, tip="tip")
    params = robot.parameters("joint2.tx")
    params.apply([0.1])
    assert model.jointPlacements[2].isApprox(before)
    assert robot.model.jointPlacements[2].isApprox(before)
    assert robot.model is not model


def test_branches_are_locked(kr270):
    # panda has two finger joints; the chain to the hand has 7.
    robot = pincal.load_robot("panda", tip="panda_hand")
    assert "panda_finger_joint1" not in robot.joint_names


def test_unknown_robot_lists_close_matches():
    with pytest.raises(RobotNotFound, match="kr270"):
        pincal.load_robot("kr27")


def test_missing_and_malformed_urdf(tmp_path):
    with pytest.raises(UrdfError, match="does not exist"):
        pincal.load_robot(tmp_path / "nope.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'></robot")
    with pytest.raises(UrdfError, match="bad.urdf"):
        pincal.load_robot(bad)


def test_unknown_tip_lists_frames():
    with pytest.raises(FrameNotFound, match="tool0"):
        pincal.load_robot("kr270", tip="tool1")


def test_tip_fixed_to_base_is_refused():
    with pytest.raises(FrameNotFound, match="fixed to the base"):
        pincal.load_robot("kr270", tip="base_link")


def test_unsupported_joint(tmp_path):
    urdf = (
        (ROOT / "robots" / "planar_2r.urdf")
        .read_text()
        .replace('<joint name="joint2" type="revolute">', '<joint name="joint2" type="floating">')
    )
    path = tmp_path / "cont.urdf"
    path.write_text(urdf)
    with pytest.raises(UnsupportedJoint, match="joint2"):
        pincal.load_robot(path, tip="tip")


@pytest.mark.parametrize("markers", [[(1, 2)], "abc", [(0, np.nan, 0)]])
def test_bad_markers(markers):
    with pytest.raises(BadConfiguration):
        pincal.load_robot("planar_2r", markers=markers)


def test_configurations_validation(kr270):
    with pytest.raises(BadConfiguration, match="expected 6 joint values"):
        kr270.configurations(np.zeros(5))
    with pytest.raises(BadConfiguration, match="finite"):
        kr270.configurations([0, -1, 0, np.nan, 0, 0])
    with pytest.raises(
        BadConfiguration, match=r"joint_a2 = 0 is outside its limits \[-2.44346, -0.0872665\]"
    ):
        kr270.configurations(np.zeros(6))
    q = np.array([0.1, -1.0, 0.2, 0.0, 0.3, 0.0])
    out = kr270.configurations(q)
    out[0, 0] = 99.0
    assert q[0] == 0.1  # input untouched, output is a copy


def test_random_configurations_are_seeded_and_inside(kr270):
    a = kr270.random_configurations(50, 7)
    b = kr270.random_configurations(50, np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    assert np.all(a >= kr270.lower) and np.all(a <= kr270.upper)
    c = kr270.random_configurations(50, 7, margin=0.05)
    assert np.all(c >= kr270.lower + 0.05 - 1e-12) and np.all(c <= kr270.upper - 0.05 + 1e-12)
