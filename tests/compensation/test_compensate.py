"""Compensation: corrected joint commands put the tool where the nominal model says."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.compensation.compensate import TOLERANCE, compensate
from pincal.errors import BadArgument
from pincal.model.residual import ResidualModel


@pytest.fixture(scope="module")
def calibrated(kr270_marker):
    """A KR 270 with geometric errors, gains and compliances of published sizes."""
    params = kr270_marker.parameters("full,offsets,gains,compliance")
    rng = np.random.default_rng(7)
    values = np.zeros(len(params))
    for i, p in enumerate(params):
        if p.kind == "placement" or p.kind == "offset":
            values[i] = rng.normal(0, 1e-3)
        elif p.kind == "gain":
            values[i] = rng.normal(0, 5e-4)
        else:
            values[i] = rng.uniform(1e-7, 5e-7)
    moved = params.apply(values)
    return moved.replace(base=pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([2.0, 1.0, 0.5])))


def _tool(robot: pincal.Robot, q: np.ndarray, payload=None) -> tuple[np.ndarray, np.ndarray]:
    """Tool rotations and positions in the robot's base frame, through the robot's own points path."""
    return robot.replace(base=pin.SE3.Identity()).tip_poses(q, payload=payload)


def test_joint_targets_are_reached_under_the_payload(kr270_marker, calibrated):
    q = kr270_marker.random_configurations(12, 8, margin=0.2)
    result = compensate(calibrated, kr270_marker, q, payload=pincal.Payload(150.0, (0.0, 0.0, 0.3)))
    R_nom, p_nom = _tool(kr270_marker, q)
    R, p = _tool(calibrated, result.commands, payload=pincal.Payload(150.0, (0.0, 0.0, 0.3)))
    assert np.linalg.norm(p - p_nom, axis=1).max() < 1e-9
    angles = [np.linalg.norm(pin.log3(a @ b.T)) for a, b in zip(R, R_nom)]
    assert max(angles) < 1e-9
    assert result.converged and np.median(result.iterations) <= 4 and result.iterations.max() <= 8
    # Without compensation the tool would be millimetres off.
    _, p_raw = _tool(calibrated, q, payload=pincal.Payload(150.0, (0.0, 0.0, 0.3)))
    assert np.linalg.norm(p_raw - p_nom, axis=1).min() > 5e-4
    np.testing.assert_array_equal(result.targets, q)


def test_the_payload_changes_the_command(kr270_marker, calibrated):
    q = kr270_marker.random_configurations(3, 9, margin=0.2)
    empty = compensate(calibrated, kr270_marker, q).commands
    loaded = compensate(calibrated, kr270_marker, q, payload=270.0).commands
    assert np.abs(loaded - empty).max() > 1e-4  # 270 kg bends a KR 270 by a fraction of a milliradian


def test_cartesian_targets_keep_the_seed_orientation(kr270_marker, calibrated):
    seed = np.radians([10, -60, 70, 20, 40, -30])
    R0, p0 = _tool(kr270_marker, seed)
    path = p0 + np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0], [0.1, 0.02, -0.03], [0.1, 0.08, -0.05]])
    result = compensate(calibrated, kr270_marker, path, cartesian=True, init=seed, payload=50.0)
    R, p = _tool(calibrated, result.commands, payload=50.0)
    np.testing.assert_allclose(p, path, atol=1e-9)
    assert max(np.linalg.norm(pin.log3(r @ R0[0].T)) for r in R) < 1e-9
    # The nominal model's own solution reaches the same poses nominally.
    R_nom, p_nom = _tool(kr270_marker, result.targets)
    np.testing.assert_allclose(p_nom, path, atol=1e-9)
    with pytest.raises(BadArgument, match="seed"):
        compensate(calibrated, kr270_marker, path, cartesian=True)


def test_the_residual_model_mean_is_compensated(kr270_marker, calibrated):
    pytest.importorskip("sklearn")
    rng = np.random.default_rng(10)
    q_train = kr270_marker.random_configurations(40, 11)
    field = 5e-4 * np.column_stack([np.sin(q_train[:, 0]), np.cos(q_train[:, 1]), np.sin(q_train[:, 2])])
    model = ResidualModel.fit(
        q_train, field + rng.normal(0, 1e-5, field.shape), kr270_marker.revolute, seed=0
    )
    q = np.radians([[10, -60, 70, 20, 40, -30], [-30, -80, 100, -40, 60, 10], [60, -45, 30, 90, -50, 120]])
    result = compensate(calibrated, kr270_marker, q, residual_model=model)
    assert result.converged
    _, p_nom = _tool(kr270_marker, q)
    _, p = _tool(calibrated, result.commands)
    correction = model.mean(result.commands)[:, :3]  # the residual model is in the robot's base frame
    np.testing.assert_allclose(p + correction, p_nom, atol=1e-9)


def test_commands_beyond_the_limits_are_named(kr270_marker, calibrated):
    q = kr270_marker.random_configurations(2, 13, margin=0.2)
    q[1, 1] = kr270_marker.upper[1]  # A2 at its upper limit: a correction may push it beyond
    result = compensate(calibrated, kr270_marker, q)
    beyond = np.any(
        (result.commands > kr270_marker.upper + 1e-9) | (result.commands < kr270_marker.lower - 1e-9), axis=1
    )
    assert result.outside_limits == tuple(np.flatnonzero(beyond))


def test_bad_programs_are_refused(kr270_marker, calibrated):
    with pytest.raises(pincal.errors.BadConfiguration, match="target 0"):
        compensate(calibrated, kr270_marker, np.full(6, 10.0))
    with pytest.raises(BadArgument, match="same chain"):
        compensate(calibrated, pincal.load_robot("ur10"), np.zeros(6))
    with pytest.raises(BadArgument, match="Cartesian targets"):
        compensate(calibrated, kr270_marker, [["a", "b", "c"]], cartesian=True, init=np.zeros(6))


def test_tolerance_is_below_any_instrument():
    assert TOLERANCE <= 1e-9


def test_the_starting_configuration_is_init_and_seed_keeps_working_until_0_3(kr270_marker, calibrated):
    """``seed=`` is a random seed everywhere else in pincal: compensate's starting configuration
    is ``init=``; pincal 0.1's ``seed=`` gives the same commands, with a DeprecationWarning at the
    caller's line."""
    start = np.radians([10, -60, 70, 20, 40, -30])
    _, p0 = _tool(kr270_marker, start)
    path = p0 + np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0]])
    with pytest.warns(DeprecationWarning, match=r"compensate\(\): seed= is renamed init= ") as caught:
        old = compensate(calibrated, kr270_marker, path, cartesian=True, seed=start)
    assert caught[0].filename == __file__ and "pincal 0.3" in str(caught[0].message)
    new = compensate(calibrated, kr270_marker, path, cartesian=True, init=start)
    assert old.commands.tobytes() == new.commands.tobytes()
    with pytest.raises(TypeError, match="give init= only"):
        compensate(calibrated, kr270_marker, path, cartesian=True, seed=start, init=start)
