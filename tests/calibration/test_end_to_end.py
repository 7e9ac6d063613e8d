"""End to end on the KR 270 with an off-axis marker (docs/method.md §10): a "real" robot with ~1 mm / ~1 mrad
errors, measured by a laser tracker (σ = 0.03 mm) at a plan, identified, exported as a URDF; the
robot loaded from that URDF is as accurate as ρ0 predicts, at the test pose and elsewhere."""

from __future__ import annotations

import numpy as np
import pytest

import pincal

SIGMA = 3e-5
TEST_POSE = np.radians([0, -90, 90, 0, 45, 0])


def _rms(difference: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(difference**2, axis=-1))))


@pytest.mark.parametrize("seed", [1, 2])
def test_kr270_calibration_end_to_end(tmp_path, seed):
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    # The real robot has errors in *every* placement and offset, identifiable or not.
    truth = pincal.random_errors(
        robot.parameters("full,offsets"), error_std={"length": 1e-3, "angle": 1e-3}, seed=seed
    )
    plan = pincal.Plan.for_robot(robot, robot.random_configurations(30, 100 + seed, margin=0.05))

    measured = tmp_path / "meas.csv"
    pincal.simulate_measurements(truth.robot, plan, SIGMA, seed=200 + seed).to_csv(measured, millimetres=True)
    data = pincal.MeasurementData.from_csv(measured, robot, millimetres=True)
    result = pincal.identify(params, data)
    assert result.success, result.message
    assert result.residual_rms_before > 1e-3
    assert result.residual_rms_after < 2 * np.sqrt(3) * SIGMA

    out = pincal.export_urdf(result, tmp_path / "kr270_calibrated.urdf")
    calibrated = pincal.load_robot(out, markers=result.robot.markers)  # what the controller gets

    rho_test = pincal.rho0(params, plan, TEST_POSE, sigma=SIGMA)
    before = _rms(robot.points(TEST_POSE) - truth.robot.points(TEST_POSE))
    after = _rms(calibrated.points(TEST_POSE) - truth.robot.points(TEST_POSE))
    assert before > 1e-3  # millimetres before
    assert after < 3 * rho_test  # the level ρ0 predicts after

    validation = robot.random_configurations(100, 300 + seed)
    rho_validation = pincal.rho0(params, plan, validation, sigma=SIGMA, aggregate="mean")
    before = _rms(robot.points(validation) - truth.robot.points(validation))
    after = _rms(calibrated.points(validation) - truth.robot.points(validation))
    assert before > 1e-3
    assert 0.5 < after / rho_validation < 2.0
