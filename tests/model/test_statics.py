"""Gravity torques with a payload, the static deflection of compliant joints, payload rows."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import fsolve

import pincal
from pincal.errors import BadArgument, NoInertias
from pincal.model.statics import Payload, payload_rows

G = 9.81
L1, L2 = 1.0, 0.8
M1, R1, M2, R2 = 12.0, 0.45, 7.0, 0.35  # link masses [kg] and their centres along the links [m]

VERTICAL_2R = f"""<?xml version="1.0"?>
<robot name="vertical_2r">
  <link name="base_link"/>
  <link name="link1"><inertial><origin xyz="{R1} 0 0"/><mass value="{M1}"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.5" iyz="0" izz="0.5"/></inertial></link>
  <link name="link2"><inertial><origin xyz="{R2} 0 0"/><mass value="{M2}"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0.3"/></inertial></link>
  <link name="tip"/>
  <joint name="joint1" type="revolute"><parent link="base_link"/><child link="link1"/>
    <origin xyz="0 0 0"/><axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/>
  </joint>
  <joint name="joint2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="{L1} 0 0"/><axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="1" velocity="1"/>
  </joint>
  <joint name="tip_joint" type="fixed"><parent link="link2"/><child link="tip"/>
    <origin xyz="{L2} 0 0"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def vertical_2r(tmp_path_factory):
    """The planar 2-link arm with masses, in a vertical plane: gravity along -y."""
    path = tmp_path_factory.mktemp("robots") / "vertical_2r.urdf"
    path.write_text(VERTICAL_2R)
    return pincal.load_robot(path, tip="tip").with_gravity((0.0, -G, 0.0))


def closed_form_torques(q: np.ndarray, mass: float, centre: float) -> np.ndarray:
    """τ = -∂V/∂q of the vertical 2-link arm carrying ``mass`` at ``centre`` along link 2 past the tip."""
    q1, q12 = q[:, 0], q[:, 0] + q[:, 1]
    outer = M2 * R2 + mass * (L2 + centre)
    t2 = -G * outer * np.cos(q12)
    t1 = -G * (M1 * R1 + (M2 + mass) * L1) * np.cos(q1) + t2
    return np.column_stack([t1, t2])


def independent_torques(robot: pincal.Robot, theta: np.ndarray, payload: np.ndarray) -> np.ndarray:
    """τ at actual joint values by virtual work, without Pinocchio's gravity: the links' weight through
    the Jacobian of their centre of mass, the payload's through the Jacobian of its point."""
    model, data = robot.model, robot.model.createData()
    g = np.array(model.gravity.linear)
    mass = sum(model.inertias[j].mass for j in range(1, model.njoints))
    joint = robot.tip_joint
    lever = model.frames[robot.tip_frame].placement.act(payload[1:])  # in the tip joint's frame
    out = np.empty_like(theta)
    for i, th in enumerate(theta):
        J_com = pin.jacobianCenterOfMass(model, data, th)
        pin.computeJointJacobians(model, data, th)
        J = pin.getJointJacobian(model, data, joint, pin.LOCAL_WORLD_ALIGNED)
        r = data.oMi[joint].rotation @ lever
        J_p = J[:3] + np.cross(J[3:].T, r).T  # v + ω × r
        out[i] = mass * J_com.T @ g + payload[0] * J_p.T @ g
    return out


def test_gravity_torques_match_the_closed_form(vertical_2r):
    q = vertical_2r.random_configurations(20, 1)
    np.testing.assert_allclose(vertical_2r.joint_torques(q), closed_form_torques(q, 0.0, 0.0), atol=1e-10)
    loaded = vertical_2r.joint_torques(q, payload=Payload(5.0, (0.2, 0.0, 0.0)))
    np.testing.assert_allclose(loaded, closed_form_torques(q, 5.0, 0.2), atol=1e-10)


def test_gravity_torques_by_virtual_work(ur10, kr270_marker):
    for robot in (ur10, kr270_marker):
        q = robot.random_configurations(4, 2)
        payload = np.array([40.0, 0.05, -0.1, 0.2])
        expected = independent_torques(robot, q, payload)
        got = robot.joint_torques(q, payload=[payload])
        assert np.abs(got - expected).max() <= 1e-6 * np.abs(expected).max()


def test_payload_per_configuration(ur10):
    q = ur10.random_configurations(3, 3)
    rows = np.array([[0.0, 0, 0, 0], [10.0, 0, 0, 0.1], [5.0, 0.1, 0, 0]])
    each = np.vstack([ur10.joint_torques(qi, payload=Payload(r[0], tuple(r[1:]))) for qi, r in zip(q, rows)])
    np.testing.assert_allclose(ur10.joint_torques(q, payload=rows), each, atol=1e-12)
    np.testing.assert_allclose(
        ur10.joint_torques(q, payload=[0.0, 10.0, 5.0])[1], ur10.joint_torques(q[1], payload=10.0)[0]
    )


def test_gravity_direction_is_the_robots(vertical_2r, ur10):
    np.testing.assert_allclose(ur10.gravity, [0.0, 0.0, -9.81])
    q = ur10.random_configurations(3, 4)
    flipped = ur10.with_gravity((0.0, 0.0, 9.81))
    np.testing.assert_allclose(flipped.joint_torques(q), -ur10.joint_torques(q), atol=1e-9)
    np.testing.assert_allclose(ur10.gravity, [0.0, 0.0, -9.81])  # the caller's robot is unchanged
    # The horizontal planar arm under the default gravity: no torque at all.
    assert np.abs(vertical_2r.with_gravity((0, 0, -9.81)).joint_torques(q[:, :2] * 0.5)).max() < 1e-12
    for bad in ((0, 0), (0, 0, np.nan), (0, 0, -1e4), "down"):
        with pytest.raises(BadArgument, match="gravity"):
            ur10.with_gravity(bad)


def _independent_static_solve(robot: pincal.Robot, start: np.ndarray, c: np.ndarray, payload: np.ndarray):
    """(θ, equation): the root of θ - start - c ⊙ τ(θ, w) by scipy's fsolve on virtual-work torques."""

    def equation(th: np.ndarray) -> np.ndarray:
        return th - start - c * independent_torques(robot, th[None], payload)[0]

    root, *_ = fsolve(equation, start, xtol=1e-13, full_output=True)
    return root, equation


def test_static_solve_matches_an_independent_solve(ur10, kr270_marker):
    for robot, c in (
        (ur10, np.array([0, 4e-6, 6e-6, 2e-5, 2e-5, 0])),
        (kr270_marker, np.array([0, 2e-7, 3e-7, 1e-6, 1e-6, 1e-6])),
    ):
        elastic = robot.replace(
            joint_offsets=np.full(6, 1e-3), joint_gains=np.full(6, 5e-4), joint_compliances=c
        )
        payload = np.array([30.0, 0.05, 0.0, 0.15])
        q = robot.random_configurations(3, 5)
        theta = elastic.joint_values(q, payload=[payload])
        for qi, ti in zip(q, theta):
            root, equation = _independent_static_solve(robot, qi + 1e-3 + 5e-4 * qi, c, payload)
            assert np.abs(equation(ti)).max() < 1e-13  # pincal's θ solves the independent equation
            np.testing.assert_allclose(ti, root, atol=1e-11)
        deflection = np.abs(theta - (q + 1e-3 + 5e-4 * q)).max()
        assert deflection > 1e-4  # the compliances do bend the arm (by milliradians)


def test_a_gain_scales_the_joint_reading(kr270_marker):
    k = np.array([1e-3, -5e-4, 2e-4, 0.0, 1e-3, -1e-3])
    q = kr270_marker.random_configurations(5, 6)
    np.testing.assert_allclose(
        kr270_marker.replace(joint_gains=k).points(q),
        kr270_marker.points(q * (1 + k), check=False),
        atol=1e-14,
    )


def test_payload_only_matters_to_a_compliant_robot(ur10):
    q = ur10.random_configurations(3, 7)
    np.testing.assert_array_equal(ur10.points(q, payload=50.0), ur10.points(q))
    soft = ur10.replace(joint_compliances=[0, 1e-5, 1e-5, 1e-5, 1e-5, 0])
    sag = soft.points(q, payload=50.0) - soft.points(q)
    assert np.linalg.norm(sag, axis=-1).min() > 1e-3  # 50 kg on a soft UR10 sags by millimetres


def test_payload_rows_forms_and_errors():
    np.testing.assert_array_equal(payload_rows(None, 2), np.zeros((2, 4)))
    np.testing.assert_array_equal(payload_rows(3.0, 2), [[3, 0, 0, 0]] * 2)
    np.testing.assert_array_equal(payload_rows([1.0, 2.0], 2), [[1, 0, 0, 0], [2, 0, 0, 0]])
    np.testing.assert_array_equal(payload_rows(Payload(2.0, (0, 0, 0.1)), 1), [[2, 0, 0, 0.1]])
    np.testing.assert_array_equal(payload_rows([[2.0, 0, 0, 0.1]], 3), [[2, 0, 0, 0.1]] * 3)
    np.testing.assert_array_equal(payload_rows([Payload(1.0), Payload(2.0, (0.1, 0, 0))], 2)[:, 1], [0, 0.1])
    for bad, match in (
        (-1.0, "mass"),
        (np.nan, "mass"),
        (1e9, "mass"),
        ([1.0, 2.0, 3.0], "expected"),
        ("heavy", "payload must be"),
        (np.array([[1.0, np.inf, 0, 0], [1.0, 0, 0, 0]]), "centre"),
    ):
        with pytest.raises(BadArgument, match=match):
            payload_rows(bad, 2)
    with pytest.raises(BadArgument, match="mass"):
        Payload(-2.0)


def test_robots_without_masses_refuse_compliance(planar):
    with pytest.raises(NoInertias, match="planar_2r.*no mass.*<inertial>"):
        planar.parameters("compliance")
    with pytest.raises(NoInertias, match="compliance"):
        planar.parameters("offsets,joint1.compliance")
    assert len(planar.parameters("gains")) == 2  # gains need no masses


def test_kr270_masses_are_the_documented_estimate():
    robot = pincal.load_robot("kr270")
    assert robot.mass == pytest.approx(871.7)  # the moving links
    model = robot.model
    assert model.inertias[0].mass + robot.mass == pytest.approx(1099.9)  # with the base: KUKA's about 1.1 t
    # The arm stretched horizontally: A2 holds the links' moments about it, Σ mass × lever [kg·m].
    moment = (
        360.0 * 0.45
        + 198.8 * (1.15 + 0.25)
        + 16.2 * (2.35 - 0.15)
        + 32.0 * (2.35 + 0.06)
        + 2.7 * (2.35 + 0.22)
    )
    tau = robot.joint_torques(np.zeros((1, 6)), check=False)[0]
    assert abs(tau[1]) == pytest.approx(9.81 * moment, rel=1e-12)
    assert abs(tau[0]) < 1e-9  # A1 is vertical: never loaded
