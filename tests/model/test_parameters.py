"""Parameter names, groups, and applying errors to a robot copy (docs/method.md §2 conventions)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import PincalError, UnknownParameter


def test_planar_lengths_are_dl1_dl2(planar):
    assert planar.parameters("lengths").names == ("joint2.tx", "tip.tx")
    assert planar.parameters("offsets").names == ("joint1.offset", "joint2.offset")


def test_kr270_lengths_are_the_six_dh_lengths(kr270):
    names = kr270.parameters("lengths").names
    assert names == ("joint_a1.tz", "joint_a2.tx", "joint_a3.tx", "joint_a4.tx", "joint_a4.tz", "tool0.tx")


def test_group_sizes(kr270_marker):
    r = kr270_marker
    assert len(r.parameters("full")) == 6 * 6 + 6
    assert len(r.parameters("offsets")) == 6
    assert len(r.parameters("base")) == 6
    assert len(r.parameters("markers")) == 3
    assert len(r.parameters("full,offsets,base,markers")) == 42 + 6 + 6 + 3


def test_canonical_order_and_dedup(kr270):
    a = kr270.parameters("tool0.tx,joint_a1.offset,offsets,joint_a1.offset")
    assert a.names[0] == "joint_a1.offset"
    assert a.names[-1] == "tool0.tx"
    assert len(a) == 7


def test_unknown_names(kr270):
    with pytest.raises(UnknownParameter, match="joint_a6.offset"):
        kr270.parameters("joint_a6.ofset")
    with pytest.raises(UnknownParameter, match="offsets"):
        kr270.parameters("offsetz")
    with pytest.raises(UnknownParameter):
        kr270.parameters("")


def test_apply_lengths_moves_tip_like_the_closed_form(planar):
    params = planar.parameters("lengths")
    moved = params.apply([0.01, -0.02])
    q = np.array([[0.4, 1.3]])
    x = 1.01 * np.cos(0.4) + 0.78 * np.cos(1.7)
    y = 1.01 * np.sin(0.4) + 0.78 * np.sin(1.7)
    np.testing.assert_allclose(moved.points(q)[0, 0], [x, y, 0], atol=1e-15)
    # the original is untouched
    np.testing.assert_allclose(planar.points(q)[0, 0, 0], np.cos(0.4) + 0.8 * np.cos(1.7), atol=1e-15)


def test_apply_offsets_adds_to_joint_values(planar):
    moved = planar.parameters("offsets").apply([0.1, -0.2])
    q = np.array([[0.4, 1.3]])
    np.testing.assert_allclose(moved.points(q), planar.points(q + [0.1, -0.2]), atol=1e-15)


def test_translation_is_in_parent_link_coordinates(tmp_path):
    # joint2's origin is rotated 90 degrees about z: its parent-coordinate tx moves along the
    # parent's x, not the joint frame's.
    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        (pincal.shipped_robots()["planar_2r"])
        .read_text()
        .replace(
            '<origin xyz="1.0 0 0" rpy="0 0 0"/>', '<origin xyz="1.0 0 0" rpy="0 0 1.5707963267948966"/>'
        )
    )
    robot = pincal.load_robot(urdf, tip="tip")
    q = np.zeros((1, 2))
    moved = robot.parameters("joint2.tx").apply([0.01])
    np.testing.assert_allclose(moved.points(q) - robot.points(q), [[[0.01, 0, 0]]], atol=1e-15)


def test_rotation_about_own_axes_and_marker_and_base(kr270_marker):
    r = kr270_marker
    q = r.random_configurations(3, 1)
    # base.tz shifts everything up
    up = r.parameters("base.tz").apply([0.002])
    np.testing.assert_allclose(
        up.points(q) - r.points(q), np.broadcast_to([0, 0, 0.002], (3, 1, 3)), atol=1e-14
    )
    # marker0.x moves the point along the tip frame's x
    moved = r.parameters("marker0.x").apply([0.001])
    data = r.model.createData()
    for qi in q:
        pin.framesForwardKinematics(r.model, data, qi)
        x_axis = data.oMf[r.tip_frame].rotation[:, 0]
        np.testing.assert_allclose(moved.points(qi)[0, 0] - r.points(qi)[0, 0], 0.001 * x_axis, atol=1e-14)


def test_apply_validates_values(planar):
    params = planar.parameters("lengths")
    with pytest.raises(PincalError, match="expected 2"):
        params.apply([1.0])
    with pytest.raises(PincalError, match="finite"):
        params.apply([1.0, np.inf])
    values = np.array([0.01, 0.02])
    params.apply(values)
    np.testing.assert_array_equal(values, [0.01, 0.02])


def test_select_and_on(kr270):
    full = kr270.parameters("full,offsets")
    sub = full.select("offsets")
    assert sub.names == kr270.parameters("offsets").names
    with pytest.raises(UnknownParameter):
        kr270.parameters("offsets").select("lengths")
    moved = full.apply(np.full(len(full), 1e-3))
    assert full.on(moved).robot is moved
    assert full.on(moved).names == full.names


def test_units(kr270):
    p = kr270.parameters("joint_a1.tx,joint_a1.rx,joint_a1.offset")
    assert p.units == ("m", "rad", "rad")


def test_tip_named_like_a_joint_gets_unique_names():
    robot = pincal.load_robot("kr270", tip="joint_a6")
    names = robot.parameters("full,offsets").names
    assert len(names) == len(set(names))
    assert "tip.tx" in names
