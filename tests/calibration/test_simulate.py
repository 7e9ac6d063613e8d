"""Simulation and Monte Carlo (pincal.simulate): the empirical error after calibration must match
the predicted ρ0 (docs/method.md §6.8) within its statistical error, and large errors must be flagged."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pincal
from pincal import PincalError, monte_carlo, random_errors, simulate_measurements


def _rho0_finite_differences(params, plan, q0, sigma: float) -> float:
    """ρ0 (root mean square over the test poses) from Jacobians by central finite differences on
    perturbed robots: an oracle independent of the analytic Jacobian and of the Cholesky kernel."""
    J = params.jacobian(plan, method="fd").reshape(-1, len(params))
    J0 = params.jacobian(q0, method="fd")  # (k, 3K, P)
    cov = sigma**2 * np.linalg.inv(J.T @ J)
    return float(np.sqrt(np.mean([np.trace(j @ cov @ j.T) for j in J0])))


def test_random_errors_are_reproducible_and_scaled(kr270_marker):
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    a = random_errors(params, error_std={"length": 1e-3, "angle": 2e-3}, seed=1)
    b = random_errors(params, error_std={"length": 1e-3, "angle": 2e-3}, seed=np.random.default_rng(1))
    c = random_errors(params, error_std={"length": 1e-3, "angle": 2e-3}, seed=2)
    np.testing.assert_array_equal(a.values, b.values)
    assert not np.allclose(a.values, c.values)
    only_lengths = random_errors(params, error_std={"length": 1e-3, "angle": 0.0}, seed=1)
    units = np.array(params.units)
    assert np.all(only_lengths.values[units == "rad"] == 0) and np.all(only_lengths.values[units == "m"] != 0)
    q = kr270_marker.random_configurations(5, 0)
    # The true robot is the nominal one with those errors: joint zero errors shift the joints
    # (oracle: the nominal robot at q + Δq), and the drawn errors have the asked spread.
    offsets = kr270_marker.parameters("offsets")
    shifted = random_errors(offsets, error_std={"length": 0.0, "angle": 1e-3}, seed=4)
    np.testing.assert_allclose(shifted.robot.points(q), kr270_marker.points(q + shifted.values), atol=1e-12)
    many = random_errors(
        kr270_marker.parameters("full,offsets"), error_std={"length": 1e-3, "angle": 2e-3}, seed=2
    )
    spread = {u: np.std(many.values[np.array(many.params.units) == u]) for u in ("m", "rad")}
    assert 0.7e-3 < spread["m"] < 1.3e-3 and 1.4e-3 < spread["rad"] < 2.6e-3  # ~40 draws each
    assert kr270_marker.joint_offsets.sum() == 0  # the nominal robot is untouched
    with pytest.raises(PincalError, match="'length'"):
        random_errors(params, error_std={"lenght": 1e-3})
    with pytest.raises(PincalError, match="error std 'length' must be a number of metres from 0"):
        random_errors(params, error_std={"length": -1.0, "angle": 0.0})


def test_simulated_noise_has_the_requested_sigma(kr270_marker):
    plan = kr270_marker.random_configurations(2000, 3)
    before = plan.copy()
    exact = simulate_measurements(kr270_marker, plan, 0.0)
    noisy = simulate_measurements(kr270_marker, plan, 3e-5, seed=4)
    again = simulate_measurements(kr270_marker, plan, 3e-5, seed=4)
    np.testing.assert_array_equal(plan, before)
    np.testing.assert_array_equal(exact.points, kr270_marker.points(plan))
    np.testing.assert_array_equal(noisy.points, again.points)
    noise = (noisy.points - exact.points).ravel()
    assert abs(noise.std() / 3e-5 - 1) < 0.03 and abs(noise.mean()) < 3e-5 * 4 / np.sqrt(noise.size)
    assert noisy.joint_names == kr270_marker.joint_names
    with pytest.raises(PincalError, match="sigma"):
        simulate_measurements(kr270_marker, plan, -1.0)


def test_monte_carlo_matches_the_planar_closed_form():
    """ρ0² = 2σ²(m − cos q20·S)/(m² − S²) (docs/method.md §9.3); the empirical RMS agrees within 3 s.e."""
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("joint2.tx,tip.tx")
    plan = robot.random_configurations(6, 3)
    q0 = np.array([0.3, 1.2])
    sigma = 3e-5
    mc = monte_carlo(params, plan, q0, sigma=sigma, trials=200, seed=5)
    m, S = len(plan), np.cos(plan[:, 1]).sum()
    exact = np.sqrt(2 * sigma**2 * (m - np.cos(q0[1]) * S) / (m**2 - S**2))
    assert mc.rho0_predicted == pytest.approx(exact, rel=1e-10)
    assert mc.rho0_empirical_se < 0.1 * mc.rho0_predicted  # the comparison means something
    assert abs(mc.rho0_empirical - mc.rho0_predicted) < 3 * mc.rho0_empirical_se
    assert not mc.nonlinear and "linear regime" in mc.note
    assert mc.trials == 200 and mc.failures == mc.local_minima == 0 and len(mc.errors) == 200
    assert mc.quantiles[0.5] < mc.quantiles[0.9] < mc.quantiles[0.99]
    assert np.all(mc.errors_before > 0)


def test_monte_carlo_matches_rho0_on_kr270(kr270_marker):
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    plan = kr270_marker.random_configurations(30, 3)
    q0 = np.radians([0, -90, 90, 0, 45, 0])
    mc = monte_carlo(params, plan, q0, sigma=3e-5, trials=200, seed=6)
    assert mc.rho0_predicted == pytest.approx(_rho0_finite_differences(params, plan, q0, 3e-5), rel=1e-5)
    assert mc.rho0_empirical_se < 0.1 * mc.rho0_predicted
    assert abs(mc.rho0_empirical - mc.rho0_predicted) < 3 * mc.rho0_empirical_se
    assert not mc.nonlinear and mc.failures == 0
    assert np.sqrt(np.mean(mc.errors_before**2)) > 30 * mc.rho0_empirical  # calibration pays
    summary = mc.as_dict()
    json.dumps(summary, allow_nan=False)
    assert {"rho0_predicted", "rho0_empirical", "trials", "quantiles", "nonlinear", "note"} <= set(summary)


def test_monte_carlo_with_several_test_poses_uses_the_mean(kr270_marker):
    params = kr270_marker.parameters("offsets,lengths").identifiable().identifiable
    plan = kr270_marker.random_configurations(20, 1)
    q0 = kr270_marker.random_configurations(3, 2)
    mc = monte_carlo(params, plan, q0, sigma=3e-5, trials=100, seed=1)
    assert mc.rho0_predicted == pytest.approx(_rho0_finite_differences(params, plan, q0, 3e-5), rel=1e-5)
    assert abs(mc.ratio - 1) < 3 * mc.ratio_se


def test_large_errors_are_reported_as_nonlinearity():
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("full,offsets").identifiable().identifiable
    plan = robot.random_configurations(6, 3)
    mc = monte_carlo(
        params, plan, [0.3, 1.2], sigma=3e-5, trials=60, seed=5, error_std={"length": 0.2, "angle": 1.0}
    )
    assert mc.nonlinear
    assert mc.error_std == {"length": 0.2, "angle": 1.0}  # the geometric errors drawn, not a tool length
    assert mc.failures + mc.local_minima > 0
    assert "nonlinearity" in mc.note and "did not converge" in mc.note


def test_monte_carlo_validates_its_arguments(kr270_marker):
    params = kr270_marker.parameters("offsets")
    plan = kr270_marker.random_configurations(10, 1)
    with pytest.raises(PincalError, match="sigma"):
        monte_carlo(params, plan, plan[0], sigma=0.0)
    with pytest.raises(PincalError, match="trials"):
        monte_carlo(params, plan, plan[0], sigma=1e-5, trials=1)
    with pytest.raises(pincal.errors.BadConfiguration, match="test pose"):
        monte_carlo(params, plan, [0, 0, 0, 0, 0, 0], sigma=1e-5)  # A2 = 0 is outside [-140°, -5°]
