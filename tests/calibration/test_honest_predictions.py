"""Every prediction path honest (docs/method.md §11.6 and §4.2, issue 29 item 1): a prediction uses the
fitted model's Jacobian (where the URDF puts the base does not matter), counts what the model does
not explain, is "unknown" rather than the instrument's default σ when σ cannot be estimated, and a
parameter group means its identifiable part (``base`` the base alone)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.adaptive.loop import assess, next_poses
from pincal.calibration.synthetic import SmoothField
from pincal.calibration.validation import validate
from pincal.errors import BadArgument

SIGMA = 3e-5
FAST = dict(starts=2, pool=300, workers=1, polish=False)
SEARCH = pincal.Search(**FAST, seed=0)
"""next_poses's search in the tests: few starts over a small pool."""


def test_identifiable_keeps_the_base_when_the_set_holds_it(ur10, kr270_marker):
    for robot in (ur10, kr270_marker):
        kept = robot.parameters("full,offsets,base").identifiable().identifiable.names
        assert [n for n in kept if n.startswith("base.")] == [
            f"base.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")
        ]


def test_the_prediction_does_not_depend_on_where_the_urdf_puts_the_base(ur10):
    """One robot described twice, the second turned 180° and moved by metres at its base against the
    data's frame: the same fit, the same predicted error (at and away from the data, held out, in
    the accuracy report) to 1e-9."""
    turned = ur10.replace(base=pin.SE3(pin.rpy.rpyToMatrix(0.0, 0.0, np.pi), np.array([3.0, -2.0, 0.5])))
    sets = [r.parameters("full,offsets,base").identifiable().identifiable for r in (ur10, turned)]
    truth = pincal.random_errors(sets[0], seed=3)
    data = pincal.simulate_measurements(truth, ur10.random_configurations(30, 4), SIGMA, seed=5)
    other = pincal.simulate_measurements(truth, ur10.random_configurations(12, 6), SIGMA, seed=7)
    fits = [pincal.identify(p, data) for p in sets]
    assert [f.status for f in fits] == ["converged", "converged"]
    q = ur10.random_configurations(8, 9)
    a, b = (f.expected_error(q) for f in fits)
    np.testing.assert_allclose(a, b, rtol=1e-9)
    va, vb = (validate(f, other) for f in fits)
    np.testing.assert_allclose(va.expected, vb.expected, rtol=1e-9)
    np.testing.assert_allclose(va.after, vb.after, rtol=1e-6)
    ra, rb = (f.accuracy(q[0], samples=16, workspace=32) for f in fits)
    for row_a, row_b in zip(ra.plans[0].rows, rb.plans[0].rows):
        assert row_a.rms == pytest.approx(row_b.rms, rel=1e-9)
    # The nominal Jacobian, which the prediction used before, gives another answer for the turned one.
    J = sets[1].jacobian(q, frame="tip")
    nominal = np.sqrt(np.einsum("mip,pr,mir->m", J, np.nan_to_num(fits[1].covariance), J))
    parameters, _ = fits[1].point_variances(q)
    assert not np.allclose(nominal, np.sqrt(parameters[:, 0]), rtol=0.05)


def test_a_fit_counts_what_the_model_does_not_explain(ur10):
    """0.3 mm of smooth error no parameter models, σ given as the instrument's 0.01 mm: the residual
    level beyond σ is counted, and the predicted error away from the data matches the true one."""
    params = ur10.parameters("full,offsets").identifiable().identifiable
    truth = pincal.random_errors(params, seed=6)
    field = SmoothField.random(ur10, 3e-4, seed=7)
    data = pincal.simulate_measurements(
        truth, ur10.random_configurations(150, 8), 1e-5, seed=9, unmodelled=field
    )
    fit = pincal.identify(params, data, sigma=1e-5)
    assert fit.unexplained == pytest.approx(fit.residual_level**2 - 1e-10)
    q = ur10.random_configurations(400, 10)
    true_points = truth.robot.points(q) + field(q)[:, None, :]
    true_error = np.sqrt(np.mean(np.sum((fit.predict(q) - true_points) ** 2, axis=-1)))
    predicted = np.sqrt(np.mean(fit.expected_error(q) ** 2))
    assert 0.7 < predicted / true_error < 1.4
    # Noise only: the χ² test finds nothing to count.
    clean = pincal.simulate_measurements(truth, ur10.random_configurations(150, 8), 1e-5, seed=9)
    assert pincal.identify(params, clean, sigma=1e-5).unexplained == 0.0


def test_next_never_falls_back_to_a_default_sigma(kr270_marker):
    """Four rows for twelve parameters leave no degree of freedom to estimate σ (as rejecting
    outliers from a small batch does): the prediction is then unknown, and no target, however large,
    stops the campaign (it stopped on the instrument's default σ before)."""
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    region = pincal.around(np.radians([0, -60, 60, 0, 45, 0]), math.radians(10), samples=32)
    plan = pincal.design(params, 4, region, search=pincal.Search(**FAST, seed=0)).plan
    data = pincal.simulate_measurements(pincal.random_errors(params, seed=1), plan, SIGMA, seed=2)
    a = assess(params, data, region)
    assert a.sigma_source == "unknown" and math.isnan(a.predicted) and math.isnan(a.sigma)
    step = next_poses(params, data, region, 3, target=1.0, search=SEARCH)  # a 1 m target
    assert not step.stop and len(step.plan) == 3 and step.predicted_after is None
    assert "no prediction yet" in step.message
    text = "\n".join(step.lines())
    assert "unknown" in text and "no stop while the prediction cannot be made" in text
    out = step.as_dict()
    assert out["sigma"] is None and out["predicted"] is None and out["sigma_source"] == "unknown"
    # Given σ, the same data predict (and the stopping rule can fire).
    given = next_poses(params, data, region, 3, target=1.0, sigma=SIGMA, search=SEARCH)
    assert given.stop and given.sigma_source == "given" and math.isfinite(given.predicted)


def test_next_counts_what_the_model_does_not_explain(ur10):
    """A campaign on a robot with 0.3 mm of error no parameter models, σ given: the prediction with
    the data so far counts the residual level beyond σ, so it is near the error truly left over the
    test region (before, it was the parameters' part alone, several times smaller)."""
    params = ur10.parameters("full,offsets").identifiable().identifiable
    truth = pincal.random_errors(params, seed=11)
    field = SmoothField.random(ur10, 3e-4, seed=12)
    q0 = np.radians([0, -60, 60, -90, -90, 0])
    region = pincal.around(q0, math.radians(20), samples=64)
    data = pincal.simulate_measurements(
        truth, ur10.random_configurations(60, 13), 1e-5, seed=14, unmodelled=field
    )
    a = assess(params, data, region, sigma=1e-5)
    assert a.unexplained > 0
    fit = a.identification
    samples = region.resolve(ur10).poses
    true_points = truth.robot.points(samples) + field(samples)[:, None, :]
    true_error = np.sqrt(np.mean(np.sum((fit.predict(samples) - true_points) ** 2, axis=-1)))
    assert 0.5 < a.predicted / true_error < 2.0
    parameters_only = pincal.rho0(a.params, data.q, region, sigma=1e-5)
    assert parameters_only < 0.5 * true_error  # what the prediction was before


def test_next_refuses_a_reject_that_is_not_a_number(kr270_marker):
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=1), kr270_marker.random_configurations(8, 1), SIGMA, seed=2
    )
    with pytest.raises(BadArgument, match="reject"):
        next_poses(params, data, np.zeros(6), 3, reject=float("nan"), search=SEARCH)


@pytest.fixture(scope="module")
def measured(tmp_path_factory, kr270_marker):
    """A measurement CSV of the KR 270 with the off-axis marker, in the tracker's frame (base 2 m away)."""
    folder = tmp_path_factory.mktemp("honest")
    params = kr270_marker.parameters("full,offsets,base").identifiable().identifiable
    truth = pincal.random_errors(params, seed=21)
    data = pincal.simulate_measurements(truth, kr270_marker.random_configurations(30, 22), SIGMA, seed=23)
    path = folder / "meas.csv"
    data.to_csv(path)
    return path


MARKER_ARG = "0.1,0.05,0.2"


def test_cli_params_base_is_the_base_placement_alone(cli, measured):
    out = cli.json("identify", "kr270", "--data", measured, "--marker", MARKER_ARG, "--params", "base")
    assert sorted(out["params"]) == [f"base.{c}" for c in ("rx", "ry", "rz", "tx", "ty", "tz")]
    assert "the base placement only" in out["params_source"]


def test_cli_a_group_means_its_identifiable_part(cli, measured):
    out = cli.json(
        "identify", "kr270", "--data", measured, "--marker", MARKER_ARG, "--params", "full,offsets,gains"
    )
    source = out["params_source"]
    assert source.startswith("the identifiable part of full,offsets,gains:") and "redundant" in source
    assert len(out["params"]) < len(pincal.load_robot("kr270").parameters("full,offsets,gains"))
    assert any(name.endswith(".gain") for name in out["params"])
    # A parameter named one by one and not identifiable is refused, naming it and why.
    line = cli.fails(
        "identify", "kr270", "--data", measured, "--marker", MARKER_ARG,
        "--params", "full,offsets,joint_a1.rz", match="joint_a1.rz cannot be identified",
    )  # fmt: skip
    assert "redundant" in line and "name its group" in line


# ------------------------------------------------------------- refusals name the likely cause first
def _identified_message(data, params) -> str:
    result = pincal.identify(params, data)
    assert result.status == "implausible"
    return result.message


def test_an_ill_conditioned_subset_is_blamed_on_its_conditioning(kr270_marker):
    """Fifteen configurations within ±20° of one pose, a robot with 3 mm of error no parameter models:
    the fit's values are implausible because the data barely condition them (3e-6), not because of
    the columns or the units (what the message said before)."""
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    field = SmoothField.random(kr270_marker, 3e-3, seed=3)
    rng = np.random.default_rng(0)
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    rng.uniform(-1, 1, (45, 6))  # the draws before the case found
    qs = q0 + np.radians(20) * rng.uniform(-1, 1, (15, 6))
    truth = pincal.random_errors(params, seed=1)
    data = pincal.simulate_measurements(truth, qs, 3e-5, seed=2, unmodelled=field)
    message = _identified_message(data, params)
    assert message.startswith("likely cause: too few or ill-conditioned configurations")
    assert "condition the parameters at 3.1e-06" in message


def test_units_come_first_in_one_line(kr270_marker, tmp_path, cli):
    """A file in millimetres read as metres: the cause, units and --mm, opens the message."""
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=4), kr270_marker.random_configurations(30, 5), SIGMA, seed=6
    )
    millimetres = pincal.MeasurementData(data.q, np.asarray(data.points) * 1e3, data.joint_names)
    message = _identified_message(millimetres, params)
    assert message.startswith("likely cause: units:") and "--mm" in message.split(" — ")[0]


def test_radians_read_as_degrees_are_named(ur10):
    """Joint readings in radians read as degrees: every joint within a few degrees (the UR10's ±2π
    limits let them through): the cause is the joint units, with --deg."""
    params = ur10.parameters("full,offsets").identifiable().identifiable
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=4), ur10.random_configurations(30, 5), SIGMA, seed=6
    )
    small = pincal.MeasurementData(np.radians(data.q), data.points, data.joint_names)
    message = _identified_message(small, params)
    assert message.startswith("likely cause: joint units:") and "--deg" in message.split(" — ")[0]
