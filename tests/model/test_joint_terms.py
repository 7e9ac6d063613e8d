"""Joint gains and compliances as parameters: names, Jacobian columns, identifiability."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal

SOFT = {"ur10": [0, 4e-6, 6e-6, 2e-5, 2e-5, 2e-5], "kr270": [0, 2e-7, 3e-7, 1e-6, 1e-6, 1e-6]}
"""Joint compliances of typical published sizes [rad/(N·m)]: deflections of tenths of a milliradian."""

ELASTIC_SPEC = "full,offsets,gains,compliance"


@pytest.fixture(scope="module")
def robots():
    return {
        "ur10": pincal.load_robot("ur10", markers=[(0.03, -0.02, 0.1)]),
        "kr270": pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2), (-0.05, 0.1, 0.1)]),
        "panda": pincal.load_robot("panda", tip="panda_hand", markers=[(0.0, 0.04, 0.1)]),
    }


def _payloads(m: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.choice([0.0, 5.0, 20.0], m), rng.uniform(-0.1, 0.1, (m, 3))])


def _visible(J: np.ndarray) -> np.ndarray:
    norm = np.abs(J).max(axis=(0, 1))
    return norm > 1e-9 * norm.max()


def _column_errors(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per column, the largest difference relative to the column's largest entry."""
    return np.abs(a - b).max(axis=(0, 1)) / np.maximum(np.abs(b).max(axis=(0, 1)), 1e-300)


def test_names_units_groups_and_order(robots):
    robot = robots["ur10"]
    params = robot.parameters("compliance,gains,offsets")
    assert params.names[:6] == tuple(f"{j}.offset" for j in robot.joint_names)
    assert params.names[6:12] == tuple(f"{j}.gain" for j in robot.joint_names)
    assert params.names[12:] == tuple(f"{j}.compliance" for j in robot.joint_names)
    assert params.units[6:] == ("1",) * 6 + ("rad/(N·m)",) * 6
    assert "rail.gain" in pincal.load_robot("rail_arm").parameters("gains")  # a prismatic joint's too
    default = robot.parameters()
    assert not any(p.kind in ("gain", "compliance") for p in default)  # not in the default set


@pytest.mark.parametrize("key", ["ur10", "kr270", "panda"])
def test_analytic_columns_match_finite_differences(robots, key):
    robot = robots[key]
    params = robot.parameters(ELASTIC_SPEC)
    q = robot.random_configurations(5, 11)
    for payload in (None, _payloads(5, 12)):
        analytic = params.jacobian(q, payload=payload)
        fd = params.jacobian(q, method="fd", payload=payload)
        seen = _visible(analytic)
        assert _column_errors(analytic, fd)[seen].max() <= 1e-6
        assert np.abs(fd[:, :, ~seen]).max() <= 1e-9 * np.abs(fd).max()


def test_tip_rows_carry_the_same_information(robots):
    params = robots["kr270"].parameters("lengths,offsets,gains,compliance")
    q = robots["kr270"].random_configurations(6, 13)
    payload = _payloads(6, 14)
    Mw = pincal.evaluation.information_matrix(params.jacobian(q, frame="world", payload=payload))
    Mt = pincal.evaluation.information_matrix(params.jacobian(q, frame="tip", payload=payload))
    np.testing.assert_allclose(Mt, Mw, atol=1e-12 * np.abs(Mw).max())


def _gravity_stiffness_bound(robot: pincal.Robot, compliances: np.ndarray, q: np.ndarray, payload) -> float:
    """max over configurations of ‖C ∂τ/∂θ‖₂: how far the first-order columns may be from exact."""
    worst = 0.0
    for row, th in zip(pincal.model.statics.payload_rows(payload, len(q)), q):
        model = pin.Model(robot.model)
        if row[0] > 0:
            lever = model.frames[robot.tip_frame].placement.act(row[1:])
            model.inertias[robot.tip_joint] += pin.Inertia(row[0], lever, np.zeros((3, 3)))
        dg = pin.computeGeneralizedGravityDerivatives(model, model.createData(), th)
        worst = max(worst, float(np.linalg.norm(np.diag(compliances) @ dg, 2)))
    return worst


@pytest.mark.parametrize("key", ["ur10", "kr270"])
def test_columns_on_a_compliant_robot_are_first_order(robots, key):
    # Identification linearises at a compliant estimate: the columns there are exact up to the
    # factor (I - C ∂τ/∂θ)⁻¹, which differs from I by about ‖C ∂τ/∂θ‖.
    robot = robots[key]
    params = robot.parameters(ELASTIC_SPEC)
    c = np.array(SOFT[key])
    values = np.zeros(len(params))
    values[[params.index(f"{j}.compliance") for j in robot.joint_names]] = c
    values[[params.index(f"{j}.gain") for j in robot.joint_names]] = 5e-4
    soft = params.on(params.apply(values))
    q = robot.random_configurations(4, 15)
    payload = _payloads(4, 16)
    bound = _gravity_stiffness_bound(robot, c, q, payload)
    assert 1e-5 < bound < 1e-2  # the compliances are of realistic size
    analytic = soft.jacobian(q, payload=payload)
    fd = soft.jacobian(q, method="fd", payload=payload)
    seen = _visible(analytic)
    joint_terms = np.array([p.kind in ("offset", "gain", "compliance") for p in params])
    assert _column_errors(analytic, fd)[seen & joint_terms].max() <= 3 * bound
    # Geometric columns see the compliance only through second-order terms.
    assert _column_errors(analytic, fd)[seen & ~joint_terms].max() <= 3 * bound


@pytest.mark.parametrize("key", ["ur10", "kr270"])
def test_linear_prediction_against_the_nonlinear_static_solve(robots, key):
    # The deflection the compliance columns predict, J_c·c, against the points of the deflected
    # robot solved to convergence (θ = q + c ⊙ τ(θ, w)): they differ by second-order terms only.
    robot = robots[key]
    params = robot.parameters("compliance")
    c = np.array(SOFT[key])
    q = robot.random_configurations(8, 17)
    payload = _payloads(8, 18) * [10, 1, 1, 1] if key == "kr270" else _payloads(8, 18)
    exact = params.apply(c).points(q, payload=payload) - robot.points(q)
    linear = (params.jacobian(q, payload=payload) @ c).reshape(exact.shape)
    assert np.linalg.norm(exact, axis=-1).max() > 1e-4  # tenths of a millimetre and more
    bound = _gravity_stiffness_bound(robot, c, q, payload)
    assert np.abs(exact - linear).max() <= 2 * bound * np.abs(exact).max()


def test_scales_are_reference_torques(robots):
    robot = robots["kr270"]
    params = robot.parameters("offsets,gains,compliance")
    scales = params.scales
    np.testing.assert_array_equal(scales[:12], 1.0)
    tau = robot.joint_torques(robot.random_configurations(200, 0), check=False)
    np.testing.assert_allclose(scales[12:][1:5], np.sqrt(np.mean(tau**2, axis=0))[1:5])
    assert scales[12] == 1.0 and scales[17] == 1.0  # A1 (vertical) and A6 (balanced) never loaded
    # Scaled, the compliance columns are of the size of the offset columns.
    q = robot.random_configurations(20, 1)
    J = params.jacobian(q) / scales
    norms = np.linalg.norm(J.reshape(-1, len(params)), axis=0)
    offsets, compliances = norms[:6], norms[13:17]
    assert 0.1 < compliances.max() / offsets.max() < 10


def test_identifiability_explains_invisible_and_correlated_compliance(robots):
    robot = robots["kr270"]
    report = robot.parameters("lengths,offsets,gains,compliance").identifiable(payloads=[0, 100, 270])
    for joint in ("joint_a1", "joint_a6"):
        assert "gravity applies no torque on this joint" in report.dropped[f"{joint}.compliance"]
    assert set(report.separation) == {f"joint_a{i}.compliance" for i in (2, 3, 4, 5)}
    # A payload change separates A2's compliance from the upper arm's length (its own weight alone
    # makes them look alike).
    assert (
        report.separation_with_payloads["joint_a2.compliance"]
        > 1.5 * report.separation["joint_a2.compliance"]
    )
    text = report.report()
    assert "compliance separation" in text and "with the payloads given" in text
    assert "payloads=[0, 50, 100]" in robot.parameters("offsets,compliance").identifiable().report()


def test_a_joint_under_constant_load_has_a_redundant_compliance(tmp_path):
    # A vertical slide carries the same weight everywhere: its compliance acts like its offset.
    urdf = tmp_path / "lift.urdf"
    urdf.write_text(
        """<robot name="lift"><link name="base"/>
        <link name="column"><inertial><origin xyz="0 0 0.5"/><mass value="40"/>
          <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
        <link name="arm"><inertial><origin xyz="0.3 0 0"/><mass value="10"/>
          <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
        <link name="tool"/>
        <joint name="lift" type="prismatic"><parent link="base"/><child link="column"/>
          <axis xyz="0 0 1"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
        <joint name="turn" type="revolute"><parent link="column"/><child link="arm"/><origin xyz="0 0 1"/>
          <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
        <joint name="tool_joint" type="fixed"><parent link="arm"/><child link="tool"/>
          <origin xyz="0.6 0 0"/></joint>
        </robot>"""
    )
    robot = pincal.load_robot(urdf, tip="tool")
    params = robot.parameters("offsets,lift.compliance")
    assert params.units[-1] == "m/N"
    report = params.identifiable()
    assert report.dropped["lift.compliance"].startswith("redundant: equals")
    assert "gravity torque is the same, -490.5 N, in every configuration" in report.dropped["lift.compliance"]
