"""Validated, not only predicted: simulated campaigns with known gains, compliances, payloads and a
smooth unmodelled error field (issue 20's item 6)."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.calibration import holdout
from pincal.calibration.synthetic import COMPLIANCE_RANGE, SmoothField

SIGMA = 3e-5
PAYLOADS = [0.0, 135.0, 270.0]  # kg, the KR 270's range


@pytest.fixture(scope="module")
def elastic(kr270_marker):
    return (
        kr270_marker.parameters("lengths,offsets,gains,compliance")
        .identifiable(payloads=PAYLOADS)
        .identifiable
    )


def _loads(m: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.choice(PAYLOADS, m), np.zeros((m, 2)), np.full(m, 0.25)])


def test_random_errors_have_published_magnitudes(elastic):
    truth = pincal.random_errors(elastic, seed=1)
    values = truth.as_dict()
    gains = [v for n, v in values.items() if n.endswith(".gain")]
    compliances = np.array([v for n, v in values.items() if n.endswith(".compliance")])
    assert 1e-5 < np.abs(gains).max() < 3e-3
    assert np.all(compliances > 0)
    # Each compliance within the published range of industrial joints (docs/method.md §11.2).
    assert np.all((compliances >= COMPLIANCE_RANGE[0]) & (compliances <= COMPLIANCE_RANGE[1]))


def test_parameters_are_recovered_within_their_standard_errors(kr270_marker, elastic):
    truth = pincal.random_errors(elastic, seed=2)
    plan = kr270_marker.random_configurations(80, 3, margin=0.1)
    data = pincal.simulate_measurements(truth, plan, SIGMA, seed=4, payload=_loads(80, 5))
    assert data.payload is not None and set(data.payload[:, 0]) == set(PAYLOADS)
    result = pincal.identify(elastic, data, sigma=SIGMA)
    assert result.success and not result.dropped
    z = (result.values - truth.values) / result.std
    assert np.abs(z).max() < 4.5  # 4.5 standard errors over 22 parameters
    assert 0.4 < np.sqrt(np.mean(z**2)) < 1.8  # the standard errors are the real scatter
    assert result.residual_rms_after < 2 * SIGMA * np.sqrt(3)
    report = result.report()
    assert "ppm" in report and "µrad/(N·m)" in report


def test_without_the_payload_columns_compliance_is_misread(kr270_marker, elastic):
    # The same data read as if nothing were carried: the fit cannot explain the loaded rows.
    truth = pincal.random_errors(elastic, seed=2)
    plan = kr270_marker.random_configurations(80, 3, margin=0.1)
    data = pincal.simulate_measurements(truth, plan, SIGMA, seed=4, payload=_loads(80, 5))
    blind = pincal.MeasurementData(data.q, data.points, data.joint_names)
    result = pincal.identify(elastic, blind, sigma=SIGMA, sanity=False)
    assert result.residual_rms_after > 10 * SIGMA


@pytest.mark.parametrize("spec", ["full,offsets"])
def test_the_residual_model_lowers_held_out_error(spec):
    pytest.importorskip("sklearn")
    robot = pincal.load_robot("ur10", markers=[(0.03, -0.02, 0.1)])
    params = robot.parameters(spec).identifiable().identifiable
    truth = pincal.random_errors(params, seed=6)
    field = SmoothField.random(robot, 3e-4, seed=7)  # 0.3 mm no parameter explains
    data = pincal.simulate_measurements(
        truth, robot.random_configurations(200, 8), 1e-5, seed=9, unmodelled=field
    )
    plain, without = holdout(params, data, 0.3, seed=1, sigma=1e-5)
    modelled, with_gp = holdout(params, data, 0.3, seed=1, sigma=1e-5, residual_model="gp")
    assert modelled.residual_model is not None and plain.residual_model is None
    assert with_gp.stats_after["rms"] < 0.7 * without.stats_after["rms"]  # on data the model did not see
    assert "residual model: Gaussian process" in modelled.report()
