"""The error a calibration predicts for its own predictions: the parameters' standard errors and,
with a residual model, its posterior variance (issue 20: the residual model's variance is part of
every predicted error pincal reports)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pincal
from pincal.calibration.synthetic import SmoothField
from pincal.calibration.validation import holdout, kfold, validate
from pincal.evaluation.test_pose import rho0_each
from pincal.model.residual import ResidualModel, features

SIGMA = 1e-5


@pytest.fixture(scope="module")
def params(ur10):
    return ur10.parameters("full,offsets").identifiable().identifiable


@pytest.fixture(scope="module")
def field_data(ur10, params):
    truth = pincal.random_errors(params, seed=6)
    field = SmoothField.random(ur10, 3e-4, seed=7)  # 0.3 mm no parameter explains
    return pincal.simulate_measurements(
        truth, ur10.random_configurations(200, 8), SIGMA, seed=9, unmodelled=field
    )


@pytest.fixture(scope="module")
def with_gp(params, field_data):
    pytest.importorskip("sklearn")
    return holdout(params, field_data, 0.3, seed=1, sigma=SIGMA, residual_model="gp")


def test_expected_error_is_the_parameters_and_the_gp_variance_computed_independently(params, with_gp, ur10):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    result, _ = with_gp
    model = result.residual_model
    q = ur10.random_configurations(6, 21)
    # The parameters' part through finite-difference Jacobians and the result's covariance.
    J = params.jacobian(q, method="fd")
    parameters = np.einsum("mip,pr,mir->m", J, result.covariance, J)
    # The GP's through scikit-learn's own regressor at the same (fixed) hyperparameters.
    kernel = ConstantKernel(model.amplitude**2, "fixed") * RBF(model.lengthscales, "fixed") + WhiteKernel(
        model.noise**2, "fixed"
    )
    reference = GaussianProcessRegressor(kernel, alpha=0.0, optimizer=None).fit(
        features(model.inputs, ur10.revolute), model.residuals
    )
    _, std = reference.predict(features(q, ur10.revolute), return_std=True)
    variance = std[:, 0] ** 2 - model.noise**2
    expected = np.sqrt(parameters + 3 * variance)
    np.testing.assert_allclose(result.expected_error(q), expected, rtol=1e-5)
    assert np.all(3 * variance > parameters)  # on these data the residual model's part dominates


def test_without_a_residual_model_it_is_the_plans_rho0(params, ur10):
    # Data without an unmodelled field, σ given: the covariance is σ²M⁻¹ of the measured plan, so the
    # expected error at a test pose is the design-time ρ0 of that plan (up to the linearisation point).
    plan = ur10.random_configurations(40, 3)
    data = pincal.simulate_measurements(pincal.random_errors(params, seed=4), plan, SIGMA, seed=5)
    result = pincal.identify(params, data, sigma=SIGMA)
    q0 = ur10.random_configurations(3, 11)
    np.testing.assert_allclose(result.expected_error(q0), rho0_each(params, plan, q0, sigma=SIGMA), rtol=1e-2)
    parameters, gp = result.point_variances(q0)
    assert np.all(gp == 0.0)
    assert "the residuals are within the noise: the model explains the data" in result.report()
    assert result.unexplained == 0.0


def test_the_gp_part_is_small_on_its_data_and_its_amplitude_far_from_them(with_gp, ur10):
    result, _ = with_gp
    fitted = result.residual_model
    # A residual model of very short lengthscales: away from its training configurations it knows
    # nothing (variance s² per coordinate), on them about the noise.
    s, n = 2e-4, 1e-5
    sharp = ResidualModel(fitted.revolute, fitted.inputs, fitted.residuals, s, np.full(12, 1e-2), n)
    result = dataclasses.replace(result, residual_model=sharp)
    far = ur10.random_configurations(5, 31)
    _, gp_far = result.point_variances(far)
    np.testing.assert_allclose(gp_far[:, 0], 3 * s**2, rtol=1e-9)
    _, gp_near = result.point_variances(fitted.inputs[:5])
    np.testing.assert_allclose(gp_near[:, 0], 3 * (s**2 - s**4 / (s**2 + n**2)), rtol=1e-6)
    parameters, _ = result.point_variances(far)
    np.testing.assert_allclose(result.expected_error(far), np.sqrt(parameters[:, 0] + 3 * s**2), rtol=1e-12)


def test_the_held_out_error_is_predicted_with_the_residual_model(params, field_data, with_gp):
    result, validation = with_gp
    assert validation.residual_model
    # The errors after calibration on points the fit did not see, against what it predicted for them.
    assert 0.75 < validation.expected_rms / validation.stats_after["rms"] < 1.33
    assert "the residual model's variance" in validation.report()
    assert "the residual model's variance" in result.report()
    summary = result.as_dict()["expected_error"]
    assert summary["residual_model"] > summary["parameters"] > 0
    assert validation.as_dict()["expected_rms"] == pytest.approx(validation.expected_rms)
    # Without the residual model the same fit counts what it does not explain, the residual level
    # beyond σ (docs/method.md §11.6): its prediction still holds on the points it did not see.
    fit, plain = holdout(params, field_data, 0.3, seed=1, sigma=SIGMA)
    assert 0.75 < plain.expected_rms / plain.stats_after["rms"] < 1.33
    assert fit.unexplained == pytest.approx(fit.residual_level**2 - SIGMA**2)
    assert not plain.residual_model and "no residual model" in plain.report()
    assert "what the model does not explain" in fit.report()


def test_kfold_and_validate_predict_each_point(params, ur10):
    truth = pincal.random_errors(params, seed=12)
    data = pincal.simulate_measurements(truth, ur10.random_configurations(60, 13), SIGMA, seed=14)
    other = pincal.simulate_measurements(truth, ur10.random_configurations(30, 15), SIGMA, seed=16)
    folds = kfold(params, data, 3, seed=0, sigma=SIGMA)
    assert folds.expected.shape == folds.after.shape
    # Noise-only data: the prediction (parameters and noise) is the errors' RMS, within the scatter
    # of 60 and 30 three-coordinate errors.
    assert 0.8 < folds.expected_rms / folds.stats_after["rms"] < 1.25
    checked = validate(pincal.identify(params, data, sigma=SIGMA), other)
    assert 0.75 < checked.expected_rms / checked.stats_after["rms"] < 1.33


def test_the_accuracy_report_after_calibration_counts_the_residual_model(with_gp, field_data):
    result, _ = with_gp
    q0 = result.residual_model.inputs[0]  # a measured configuration: the residual model knows it best
    report = result.accuracy(q0, samples=64, workspace=200)
    calibrated = report.plans[0]
    at_test_pose = calibrated.row("test pose")
    assert at_test_pose.rms == pytest.approx(result.expected_error(q0)[0], rel=1e-12)
    assert calibrated.from_measurements**2 + calibrated.from_residual_model**2 == pytest.approx(
        at_test_pose.rms**2, rel=1e-9
    )
    # Away from the data the residual model knows less: the workspace is worse than the test pose.
    assert calibrated.row("workspace").median > at_test_pose.rms
    assert "from the residual model's variance" in "\n".join(report.lines())
    assert report.as_dict()["plans"][0]["from_residual_model"] == calibrated.from_residual_model
