"""Criteria and designs of what an instrument measures, weighted by its error model: ρ0 stays the
markers' position error at the test pose, M = Σ JᵢᵀΣᵢ⁻¹Jᵢ (docs/method.md §13.2, §13.3)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal
from pincal.instruments import (
    Camera,
    Image,
    Instrument,
    PerCoordinate,
    Point,
    Pose,
    Tracker,
    grid,
)
from pincal.instruments.instrument import tool_rows
from pincal.model.jacobian import JacobianEngine

Q0 = np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0])
pytestmark = pytest.mark.ur10(markers=[(0.05, 0.02, 0.1)])  # the ur10 fixture (tests/conftest.py)


@pytest.fixture(scope="module")
def pose_params(ur10):
    return Instrument(Pose()).identifiable(ur10.parameters("full,offsets")).identifiable


def test_default_instrument_is_today_exactly(ur10):
    params = ur10.parameters("full,offsets").identifiable().identifiable
    plan = ur10.random_configurations(15, 1)
    plain = pincal.rho0(params, plan, Q0, sigma=2e-5)
    points = Instrument(Point(), PerCoordinate(2e-5))
    same = pincal.rho0(params, plan, Q0, instrument=points)
    assert same == plain
    assert pincal.criteria(params, plan, instrument=points) == pincal.criteria(params, plan)


def test_rho0_is_weighted_by_the_inverse_covariance(ur10):
    """ρ0² = tr(J₀ (Σ JᵢᵀΣᵢ⁻¹Jᵢ)⁻¹ J₀ᵀ), for a tracker's anisotropic covariance."""
    params = ur10.parameters("full,offsets").identifiable().identifiable
    plan = ur10.random_configurations(15, 2)
    tracker = Tracker(at=(3.0, 1.0, 0.5))
    J = JacobianEngine(params).jacobian(plan, frame="world")
    cov = tracker.covariance(Point(), ur10, plan).matrices()
    M = sum(j.T @ np.linalg.solve(c, j) for j, c in zip(J, cov))
    J0 = params.jacobian(Q0, frame="world")[0]
    expected = np.sqrt(np.trace(J0 @ np.linalg.solve(M, J0.T)))
    measured = Instrument(Point(), tracker)
    assert pincal.rho0(params, plan, Q0, instrument=measured) == pytest.approx(expected, rel=1e-9)
    each = pincal.evaluation.rho0_each(params, plan, [Q0, Q0 * 0.5], instrument=measured)
    assert each[0] == pytest.approx(expected, rel=1e-9)


def test_orientation_part_of_the_test_pose_criterion(ur10, pose_params):
    """ρ0² = E‖δp‖² + L²·E‖δθ‖², from the posterior covariance of a pose plan."""
    plan = ur10.random_configurations(12, 3)
    mocap = PerCoordinate(1e-4, 2e-3)
    engine = Instrument(Pose(), mocap).engine(pose_params)
    W = engine.jacobian(plan).reshape(-1, len(pose_params))
    C = np.linalg.inv(W.T @ W) * mocap.sigma**2
    points = JacobianEngine(pose_params)
    Jp, Jw = points.jacobian(Q0[None], frame="tip")[0], points.frame_rows(Q0[None])[0][0, 3:]
    position, angle = np.trace(Jp @ C @ Jp.T), np.trace(Jw @ C @ Jw.T)
    kw = {"instrument": Instrument(Pose(), mocap)}
    assert pincal.rho0(pose_params, plan, Q0, **kw) == pytest.approx(np.sqrt(position), rel=1e-9)
    with_angle = pincal.rho0(pose_params, plan, Q0, orientation_length=0.25, **kw)
    assert with_angle == pytest.approx(np.sqrt(position + 0.25**2 * angle), rel=1e-9)
    assert tool_rows(points, Q0[None], 0.25).shape == (1, 6, len(pose_params))
    with pytest.raises(pincal.errors.BadArgument, match="orientation_length"):
        pincal.rho0(pose_params, plan, Q0, orientation_length=-1.0)


def test_pool_rows_keep_the_information(ur10):
    """A camera's 2N rows per configuration are compressed to their rank for the exchange."""
    kind = Image(Camera(600, 600, 320, 240), grid(6, 5, 0.03))
    robot = pincal.load_robot("panda").with_fixtures(
        *kind.fixtures((0.05, 0, 0.05), (0.5, 0, 0, np.pi, 0, 0))
    )
    params = robot.parameters("full,offsets,instrument")
    engine = Instrument(kind).engine(params)
    qs = robot.random_configurations(50, 4)
    J, R = engine.jacobian(qs), engine.pool(qs)
    assert R.shape[1] <= 12 < J.shape[1]  # a camera's twist and a target's: 12 at most
    M = np.einsum("nrp,nrs->nps", J, J)
    assert np.abs(np.einsum("nrp,nrs->nps", R, R) - M).max() < 1e-12 * np.abs(M).max()


def test_design_measures_what_the_instrument_does(ur10, pose_params):
    mocap = PerCoordinate(1e-4, 2e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.PincalWarning)
        result = pincal.design(
            pose_params,
            8,
            Q0,
            instrument=pincal.instruments.Instrument(Pose(), mocap),
            search=pincal.Search(starts=2, workers=1, seed=1, pool=300),
        )
    assert result.sigma == mocap.sigma and result.as_dict()["instrument"]["measure"] == {"kind": "pose"}
    again = pincal.rho0(pose_params, result.plan, Q0, instrument=Instrument(Pose(), mocap))
    assert result.rho0 == pytest.approx(again, rel=1e-12)
    randoms = pincal.random_plans(pose_params, 8, 50, Q0, instrument=Instrument(Pose(), mocap), seed=2)
    assert randoms.n_singular == 0 and result.rho0 < randoms.min
    with pytest.raises(pincal.errors.SingularPlan):  # 4 poses of 6 values cannot identify 30 parameters
        pincal.design(
            pose_params,
            4,
            Q0,
            instrument=pincal.instruments.Instrument(Pose(), pincal.instruments.PerCoordinate()),
            search=pincal.Search(workers=1),
        )


def test_monte_carlo_of_a_pose_plan_matches_its_prediction(ur10, pose_params):
    mocap = Instrument(Pose(), PerCoordinate(1e-4, 2e-3))
    plan = ur10.random_configurations(20, 5)
    mc = pincal.monte_carlo(pose_params, plan, Q0, trials=40, seed=3, instrument=mocap)
    assert mc.failures == 0 and abs(mc.ratio - 1) < 4 * mc.ratio_se
    assert mc.rho0_predicted == pytest.approx(pincal.rho0(pose_params, plan, Q0, instrument=mocap), rel=1e-12)


def test_accuracy_away_from_the_test_pose_with_a_tracker(ur10):
    params = ur10.parameters("full,offsets").identifiable().identifiable
    plan = ur10.random_configurations(15, 6)
    tracker = Instrument(Point(), Tracker(at=(3.0, 0.0, 1.0)))
    report = pincal.accuracy(params, plan, Q0, instrument=tracker, samples=16, workspace=32)
    at = report.plans[0].rows[0].rms
    assert at == pytest.approx(pincal.rho0(params, plan, Q0, instrument=tracker), rel=1e-9)
    assert report.sigma == tracker.reference


def test_cli_design_and_evaluate_with_instruments(cli, tmp_path):
    plan = tmp_path / "plan.csv"
    pose = ("--measure", "pose", "--sigma", "1e-4", "--sigma-rot", "2e-3")
    out = cli.json("design", "ur10", "-m", "10", "--test-pose=0,-1.2,1.5,-1,-1.5,0", *pose, "--starts",
                   "2", "--pool-size", "300", "--workers", "1", "--no-accuracy", "--out", plan)  # fmt: skip
    assert out["instrument"]["measure"] == {"kind": "pose"} and out["n_params"] == 30
    ev = cli.json("evaluate", "ur10", "--plan", plan, "--test-pose=0,-1.2,1.5,-1,-1.5,0", *pose,
                  "--no-accuracy")  # fmt: skip
    assert ev["rho0"] == pytest.approx(out["rho0"], rel=1e-9)
    tracker = cli.json("evaluate", "ur10", "--plan", plan, "--test-pose=0,-1.2,1.5,-1,-1.5,0", "--instrument",
                       "tracker", "--instrument-at", "3,0,1", "--no-accuracy")  # fmt: skip
    assert tracker["instrument"]["error"]["model"] == "tracker" and tracker["rho0"] > 0
    code, text, _ = cli.run("evaluate", "ur10", "--plan", plan, "--test-pose=0,-1.2,1.5,-1,-1.5,0", *pose,
                            "--orientation-length", "0.2", "--no-accuracy")  # fmt: skip
    assert code == 0 and "L = 0.2 m" in text


def test_cli_reports_use_the_instrument_of_the_command_line(cli, tmp_path):
    """--measure pose --sigma S: every number of the report is of poses with S per length (0.1's
    classic criteria and D-optimal reference took the default σ: the keyword went without it)."""
    ur10 = pincal.load_robot("ur10")
    plan = tmp_path / "plan.csv"
    pincal.Plan.for_robot(ur10, ur10.random_configurations(10, 7)).to_csv(plan)
    pose = ("--measure", "pose", "--sigma", "1e-4")
    ev = cli.json(
        "evaluate", "ur10", "--plan", plan, "--test-pose=0,-1.2,1.5,-1,-1.5,0", *pose, "--no-accuracy"
    )
    params, qs = ur10.parameters(",".join(ev["params"])), pincal.Plan.from_csv(plan, ur10)
    expected = pincal.criteria(params, qs, instrument=Instrument(Pose(), PerCoordinate(1e-4)))
    assert ev["criteria"]["log_det"] == pytest.approx(expected.log_det, rel=1e-12)
    default = pincal.criteria(params, qs, instrument=Instrument(Pose()))
    assert abs(ev["criteria"]["log_det"] - default.log_det) > 1.0  # σ = 1e-4, not the default 3e-5
