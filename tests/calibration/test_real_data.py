"""Identification on realistic tracker data made here (issue 10, item 9).

Each campaign is simulated on a KR 270 with known geometric errors plus what real data hold:
non-geometric error (joint-angle-proportional gains, gravity compliance), a small sampled region,
gross outliers, per-point σ, two instrument placements, a millimetre file, a forgotten marker.
Oracles: the true errors and bases, the rows corrupted on purpose, the planar closed-form
weighted covariance, and the held-out error the model can reach (the same fit on noise-free data).
Budget: about 20 s.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal import MeasurementData, identify, random_errors, simulate_measurements

SIGMA = 3e-5


@pytest.fixture(scope="module")
def robot(kr270_marker):
    return kr270_marker


@pytest.fixture(scope="module")
def params(robot):
    return robot.parameters("full,offsets").identifiable().identifiable


@pytest.fixture(scope="module")
def truth(params):
    return random_errors(params, seed=4)


def _region(n, seed, width=0.1):
    q0 = np.array([0.0, -1.2, 1.0, 0.0, 0.8, 0.0])
    return q0 + width * np.random.default_rng(seed).uniform(-1, 1, (n, 6))


def _non_geometric(true_robot, qs, sigma, seed):
    """Points of a robot whose joints 2 and 3 read 0.01 % too little (gear ratio) and whose arm
    sags under gravity by 50 µrad × cos(q2 + q3) at joint 3."""
    real = np.array(qs, dtype=float)
    real[:, 1:3] *= 1.0001
    real[:, 2] += 5e-5 * np.cos(qs[:, 1] + qs[:, 2])
    points = true_robot.points(real, check=False)
    points = points + sigma * np.random.default_rng(seed).standard_normal(points.shape)
    return MeasurementData(qs, points, true_robot.joint_names)


# ----------------------------------------------------------------------------- a small region
def test_small_region_is_reduced_to_what_the_data_identify_and_predicts_the_region(params, truth):
    """The issue's small grid: every full set used to end not_converged. Now the data check drops
    what the region cannot separate (named, with the reason), the fit converges, and held-out
    points of the region are predicted close to the instrument's noise."""
    data = simulate_measurements(truth.robot, _region(40, 0), SIGMA, seed=1)
    result, validation = pincal.calibration.holdout(params, data, 0.25, seed=3)
    assert result.success, result.message
    assert result.check.condition_number > 1e3 and result.dropped
    assert all(("determine" in why or "inseparable" in why) for why in result.dropped.values())
    assert set(result.dropped) <= set(params.names) and "left nominal" in result.message
    assert result.check.weakest and "weakest" in result.report()
    held = simulate_measurements(truth.robot, _region(30, 9), SIGMA, seed=2)
    check = pincal.validate(result, held)
    assert check.stats_before["rms"] > 1e-3  # the nominal robot is millimetres off
    assert check.stats_after["rms"] < 4 * SIGMA * np.sqrt(3)  # within a few σ of a 3-D point
    assert validation.stats_after["rms"] < 4 * SIGMA * np.sqrt(3)


def test_a_prior_keeps_every_parameter_with_a_map_estimate(params, truth):
    data = simulate_measurements(truth.robot, _region(40, 0), SIGMA, seed=1)
    result = identify(params, data, prior=pincal.Prior.parse("1mm,1mrad"))
    assert result.success and not result.dropped and result.prior is not None
    assert np.all(np.isfinite(result.std)) and np.all(result.std < 1.01e-3)  # posterior ≤ prior
    held = simulate_measurements(truth.robot, _region(30, 9), SIGMA, seed=2)
    assert pincal.validate(result, held).stats_after["rms"] < 4 * SIGMA * np.sqrt(3)


# ------------------------------------------------------------------------- non-geometric error
def test_non_geometric_error_reaches_the_floor_the_model_can_reach(robot, params, truth):
    qs = robot.random_configurations(60, 5)
    held = robot.random_configurations(40, 6)
    data = _non_geometric(truth.robot, qs, SIGMA, seed=7)
    result = identify(params, data, sigma=SIGMA)
    assert result.success, result.message
    assert "the data hold errors the model does not" in result.message  # χ over 3 given σ
    floor = identify(params, _non_geometric(truth.robot, qs, 0.0, seed=0))  # noise-free: the model's best
    test = _non_geometric(truth.robot, held, 0.0, seed=0)
    reached = pincal.validate(result, test).stats_after["rms"]
    best = pincal.validate(floor, test).stats_after["rms"]
    assert best > 5 * SIGMA  # the non-geometric error is really there
    assert reached < best + 3 * SIGMA


# ---------------------------------------------------------------------------------- outliers
@pytest.fixture(scope="module")
def outlier_file(tmp_path_factory, robot, truth):
    """60 configurations, 2 of them (3 %) with a reflector that lost its beam (+22 mm)."""
    data = simulate_measurements(truth.robot, robot.random_configurations(60, 3), SIGMA, seed=2)
    points = np.array(data.points)
    points[[11, 42]] += [0.022, -0.004, 0.003]
    path = tmp_path_factory.mktemp("out") / "tracker.csv"
    MeasurementData(data.q, points, data.joint_names).to_csv(path)
    return path  # rows 11 and 42 are on lines 13 and 44 (header on line 1)


def test_outliers_are_named_by_line_and_rejected(robot, params, truth, outlier_file):
    data = MeasurementData.from_csv(outlier_file, robot)
    plain = identify(params, data)
    assert [o.row for o in plain.outliers[:2]] == [11, 42] or [o.row for o in plain.outliers[:2]] == [42, 11]
    assert {o.label for o in plain.outliers[:2]} == {
        f"measurement file {str(outlier_file)!r}, line 13",
        f"measurement file {str(outlier_file)!r}, line 44",
    }
    assert all(o.distance > 5e-3 for o in plain.outliers[:2]) and "suspicious rows" in plain.report()
    rejected = identify(params, data, reject=5)
    assert sorted(o.row for o in rejected.rejected) == [11, 42] and not rejected.outliers
    assert all(o.score > 100 for o in rejected.rejected)
    assert rejected.residual_rms_after < 2 * SIGMA * np.sqrt(3)
    z = (rejected.values - truth.values) / rejected.std
    assert np.abs(z).max() < 5  # the true errors within the standard errors
    robust = identify(params, data, loss="cauchy")
    assert np.abs(robust.values - truth.values).max() < np.abs(plain.values - truth.values).max() / 10
    # Levenberg-Marquardt takes the linear loss only: reject scores its rows on a trf fit (its soft_l1
    # scoring fit used to fail under lm, silently, and nothing was rejected)
    with_lm = identify(params, data, reject=5, method="lm")
    assert with_lm.method == "lm" and [o.row for o in with_lm.rejected] == [o.row for o in rejected.rejected]
    assert not with_lm.outliers and with_lm.residual_rms_after < 2 * SIGMA * np.sqrt(3)


# ----------------------------------------------------------------------------- per-point σ
def test_per_point_sigma_weights_the_fit_as_the_closed_form_says():
    """Weighted planar 2-link: cov = (Jᵀ W J)⁻¹, W = diag(1/σᵢ²), J from the analytic Jacobian."""
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("joint2.tx,tip.tx")
    plan = robot.random_configurations(9, 11)
    s = np.where(np.arange(9) % 3 == 0, 1e-3, 1e-5)[:, None, None] * np.ones((9, 1, 3))
    truth = params.apply([3e-3, -2e-3])
    points = truth.points(plan) + s * np.random.default_rng(1).standard_normal((9, 1, 3))
    data = MeasurementData(plan, points, robot.joint_names, sigma=s)
    result = identify(params, data)
    J = params.on(truth).jacobian(plan).reshape(-1, 2)
    w = 1.0 / s.reshape(-1)
    cov = np.linalg.inv((J * w[:, None] ** 2).T @ J)
    np.testing.assert_allclose(result.covariance, cov, rtol=1e-6)
    assert not result.sigma_estimated


def test_sigma_columns_in_a_file(tmp_path, robot):
    path = tmp_path / "s.csv"
    path.write_text(",".join(robot.joint_names) + ",x,y,z,s\n0,-1.5,1.5,0,0.5,0,1,2,3,1e-5\n")
    assert MeasurementData.from_csv(path, robot).sigma.tolist() == [[[1e-5] * 3]]
    path.write_text(",".join(robot.joint_names) + ",x,y,z,sx,sy,sz\n0,-1.5,1.5,0,0.5,0,1,2,3,1,2,3\n")
    np.testing.assert_allclose(
        MeasurementData.from_csv(path, robot, millimetres=True).sigma, [[[1e-3, 2e-3, 3e-3]]]
    )
    path.write_text(",".join(robot.joint_names) + ",x,y,z,sx,sz\n0,-1.5,1.5,0,0.5,0,1,2,3,1,2\n")
    with pytest.raises(pincal.errors.BadMeasurementData, match="without one"):
        MeasurementData.from_csv(path, robot)
    path.write_text(",".join(robot.joint_names) + ",x,y,z,s\n0,-1.5,1.5,0,0.5,0,1,2,3,0\n")
    with pytest.raises(pincal.errors.BadMeasurementData, match="line 2.*positive"):
        MeasurementData.from_csv(path, robot)


# ------------------------------------------------------------------------ two placements
def test_two_sessions_share_the_robot_with_one_base_each(robot):
    params = robot.parameters("full,offsets,base").identifiable(prefer="base").identifiable
    truth = random_errors(params, seed=2)
    first = pin.SE3(pin.rpy.rpyToMatrix(0.05, -0.1, 2.0), np.array([-2.5, 1.0, 0.2]))
    second = pin.SE3(pin.rpy.rpyToMatrix(-0.1, 0.05, -1.0), np.array([1.5, 3.0, -0.4]))
    a = simulate_measurements(truth.robot.replace(base=first), robot.random_configurations(20, 1), 0.0)
    b = simulate_measurements(truth.robot.replace(base=second), robot.random_configurations(20, 2), 0.0)
    result = identify(params, [a, b])
    assert result.success, result.message
    chain = [i for i, p in enumerate(params) if p.kind != "base"]
    np.testing.assert_allclose(result.values[chain], truth.values[chain], atol=1e-9)
    assert result.bases[0].isApprox(first, 1e-9) and result.bases[1].isApprox(second, 1e-9)
    assert result.residual_rms_after < 1e-9 and result.data.m == 40
    assert "base2.tx" in result.check.names


# --------------------------------------------------------------------------- wrong input
def test_a_millimetre_file_read_as_metres_is_implausible(tmp_path, robot, params, truth):
    data = simulate_measurements(truth.robot, robot.random_configurations(30, 3), SIGMA, seed=2)
    path = tmp_path / "mm.csv"
    data.to_csv(path, millimetres=True)
    wrong = identify(params, MeasurementData.from_csv(path, robot))
    assert wrong.status == "implausible" and not wrong.success
    assert "--mm" in wrong.causes[0] and f"likely cause: {wrong.causes[0]}" in wrong.message
    with pytest.raises(pincal.errors.IdentificationFailed, match="likely cause: units"):
        pincal.export_urdf(wrong, tmp_path / "x.urdf")
    right = identify(params, MeasurementData.from_csv(path, robot, millimetres=True))
    assert right.success and np.abs(right.values - truth.values).max() < 1e-4


def test_a_forgotten_marker_is_implausible(robot, params, truth):
    data = simulate_measurements(truth.robot, robot.random_configurations(30, 3), SIGMA, seed=2)
    bare = pincal.load_robot("kr270")  # no --marker: the tool0 origin
    result = identify(bare.parameters("full,offsets").identifiable().identifiable, data)
    assert result.status == "implausible"
    assert "tool frame tool0 moves" in result.message and "--marker" in result.causes[0]
    chain_only = identify(bare.parameters("lengths,offsets").identifiable().identifiable, data)
    assert chain_only.status == "implausible" and any("--marker" in c for c in chain_only.causes)


def test_before_residual_with_base_is_after_the_rigid_fit(robot):
    params = robot.parameters("lengths,offsets,base").identifiable(prefer="base").identifiable
    far = robot.replace(base=pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 2.5), np.array([-2.5, 1.0, 0.2])))
    result = identify(params, simulate_measurements(far, robot.random_configurations(20, 1), 0.0))
    assert result.success and result.residual_rms_before < 1e-9  # a pure rigid motion: nothing left


# ---------------------------------------------------------------------------- validation
def test_validation_warns_when_a_fit_has_fewer_than_two_coordinates_per_parameter(robot, params, truth):
    """A fit on fewer than 2 × 27 coordinates follows the noise; the warning says the numbers and
    what to do (hold out fewer, more folds, more configurations); a fit with enough says nothing."""
    data = simulate_measurements(truth.robot, robot.random_configurations(30, 8), SIGMA, seed=3)
    with pytest.warns(
        pincal.PincalWarning, match="the fit on 15 of 30 configurations has 45 measured"
    ) as caught:
        pincal.calibration.holdout(params, data, 0.5, seed=1)
    assert "hold out at most 12 of the 30 configurations, measure more" in str(caught[0].message)
    twenty = data.subset(range(20))
    with pytest.warns(pincal.PincalWarning, match="a fold's fit on 13 of 20 configurations has 39") as caught:
        pincal.calibration.kfold(params, twenty, 3, seed=1)
    assert "use 10 folds or more" in str(caught[0].message)  # each fit then has 18 configurations
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        pincal.calibration.holdout(params, data, 0.2, seed=1)  # 24 configurations, 72 coordinates: enough
        pincal.calibration.kfold(params, twenty, 10, seed=1)


def test_kfold_holds_every_point_out_once(robot, params, truth):
    data = simulate_measurements(truth.robot, robot.random_configurations(40, 8), SIGMA, seed=3)
    check = pincal.calibration.kfold(params, data, 4, seed=1)
    assert check.before.size == 40 and sorted(set(check.labels)) == sorted(data.labels())
    assert check.statuses == ("converged",) * 4
    assert check.stats_after["rms"] < 3 * SIGMA * np.sqrt(3) < check.stats_before["rms"]
    assert check.stats_after["p95"] <= check.stats_after["max"]
    with pytest.raises(pincal.PincalError, match="k"):
        pincal.calibration.kfold(params, data, 1)
    with pytest.raises(pincal.PincalError, match="fraction"):
        pincal.calibration.holdout(params, data, 1.5)


def test_data_check_matches_the_planar_closed_form():
    """Planar 2-link, joint2.tx and tip.tx: M = [[m, S], [S, m]]/σ² with S = Σ cos q2, so the
    standard errors are σ·sqrt(m/(m² − S²)) and the condition number sqrt((1 + |S|/m)/(1 − |S|/m))."""
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("joint2.tx,tip.tx")
    plan = robot.random_configurations(7, 11)
    m, S = len(plan), np.cos(plan[:, 1]).sum()
    check = pincal.evaluation.check_plan(params, plan, sigma=1e-4)
    assert check.identifiable and check.rank == 2 and check.kept_names == params.names
    np.testing.assert_allclose(check.std, 1e-4 * np.sqrt(m / (m**2 - S**2)), rtol=1e-9)
    r = abs(S) / m
    assert check.condition_number == pytest.approx(np.sqrt((1 + r) / (1 - r)), rel=1e-9)
    straight = plan.copy()
    straight[:, 1] = 0.0  # an outstretched arm: both translations move the tip alike
    same = pincal.evaluation.check_plan(params, straight, sigma=1e-4)
    assert not np.isfinite(same.condition_number) and same.rank == 1
    assert list(same.dropped) == ["tip.tx"] and "inseparable" in same.dropped["tip.tx"]
