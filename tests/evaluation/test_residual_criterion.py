"""The test-pose criterion with a residual model, tr Σ₀: oracles and the top-up design it gives."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.errors import BadArgument
from pincal.evaluation.prior import Prior
from pincal.evaluation.residual_criterion import ResidualCriterion, expected_error
from pincal.model.residual import ResidualModel

SIGMA = 2e-5


@pytest.fixture(scope="module")
def setup():
    robot = pincal.load_robot("ur10", markers=[(0.03, -0.02, 0.1), (0.0, 0.05, 0.05)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    return robot, params


def _model(robot, amplitude: float, lengthscale: float = 0.6) -> ResidualModel:
    q = robot.random_configurations(5, 0)
    d = 2 * robot.nq  # (cos, sin) of each revolute joint
    return ResidualModel(
        robot.revolute, q, np.zeros((5, 3 * robot.n_markers)), amplitude, np.full(d, lengthscale), 1e-5
    )


def test_without_a_residual_it_is_rho0(setup):
    robot, params = setup
    plan = robot.random_configurations(20, 1)
    q0 = robot.random_configurations(2, 2)
    tiny = _model(robot, 1e-15)
    assert expected_error(params, plan, q0, tiny, sigma=SIGMA) == pytest.approx(
        pincal.rho0(params, plan, q0, sigma=SIGMA), rel=1e-7
    )


def test_it_is_the_dense_generalised_least_squares_formula(setup):
    # Σ₀ written out with full (3Km × 3Km) matrices, every coordinate's covariance explicit.
    robot, params = setup
    model = _model(robot, 3e-4)
    plan = robot.random_configurations(15, 3)
    q0 = robot.random_configurations(1, 4)
    H = params.jacobian(plan, frame="world").reshape(-1, len(params))
    J0 = params.jacobian(q0, frame="world")[0]
    r = J0.shape[0]
    K = np.kron(model.kernel(plan, plan), np.eye(r)) + SIGMA**2 * np.eye(len(H))
    k0 = np.kron(model.kernel(plan, q0), np.eye(r))
    K00 = model.amplitude**2 * np.eye(r)
    Kinv = np.linalg.inv(K)
    R = J0.T - H.T @ Kinv @ k0
    sigma0 = K00 - k0.T @ Kinv @ k0 + R.T @ np.linalg.inv(H.T @ Kinv @ H) @ R
    assert expected_error(params, plan, q0, model, sigma=SIGMA) ** 2 == pytest.approx(
        np.trace(sigma0), rel=1e-8
    )


def test_a_top_up_design_with_a_residual_model_beats_the_plain_design_at_its_own_game(setup):
    robot, params = setup
    q0 = np.array([[0.3, -1.2, 1.4, -1.0, -1.4, 0.2]])
    model = _model(robot, 5e-4, lengthscale=0.4)
    plain = pincal.design(
        params, 14, q0, sigma=SIGMA, search=pincal.Search(pool=300, starts=2, seed=1, workers=1)
    )
    topup = pincal.design(
        params, 14, q0, sigma=SIGMA, residual_model=model, search=pincal.Search(pool=300, starts=2, seed=1)
    )
    assert topup.criterion == ResidualCriterion.name
    assert topup.value == pytest.approx(expected_error(params, topup.plan, q0, model, sigma=SIGMA), rel=1e-9)
    # It is better, by its own criterion, than the plan designed as if the model were exact ...
    assert topup.value < 0.8 * expected_error(params, plain.plan, q0, model, sigma=SIGMA)
    # ... which, valuing what it does not model, the plain design cannot see: its own ρ0 is lower.
    assert plain.rho0 < topup.rho0
    assert topup.rho0 == pytest.approx(pincal.rho0(params, topup.plan, q0, sigma=SIGMA), rel=1e-9)


def test_batched_swaps_are_the_plan_values(setup):
    robot, params = setup
    model = _model(robot, 3e-4)
    plan, cand = robot.random_configurations(12, 5), robot.random_configurations(6, 6)
    q0 = robot.random_configurations(2, 7)
    J, Jc = params.jacobian(plan, frame="world"), params.jacobian(cand, frame="world")
    criterion = ResidualCriterion(model, params.jacobian(q0, frame="world"), q0, SIGMA)
    batched = criterion.swapped_traces(J, plan, 4, Jc, cand)
    for n in range(len(cand)):
        trial, Jt = plan.copy(), J.copy()
        trial[4], Jt[4] = cand[n], Jc[n]
        assert batched[n] == pytest.approx(criterion.trace(Jt, trial), rel=1e-9)


def test_the_accuracy_report_with_a_residual_model(setup):
    robot, params = setup
    plan = robot.random_configurations(20, 1)
    q0 = robot.random_configurations(1, 2)
    sizes = dict(samples=40, workspace=60)
    # A residual of no amplitude: the report is the plain one, row by row.
    tiny = pincal.accuracy(params, plan, q0, sigma=SIGMA, residual_model=_model(robot, 1e-15), **sizes)
    plain = pincal.accuracy(params, plan, q0, sigma=SIGMA, **sizes)
    for with_gp, without in zip(tiny.plans[0].rows, plain.plans[0].rows, strict=True):
        assert with_gp.rms == pytest.approx(without.rms, rel=1e-6)
    # With one, its test-pose row is the criterion's expected error, and its variance is in every row.
    model = _model(robot, 3e-4)
    report = pincal.accuracy(params, plan, q0, sigma=SIGMA, residual_model=model, **sizes)
    assert report.plans[0].row("test pose").rms == pytest.approx(
        expected_error(params, plan, q0, model, sigma=SIGMA), rel=1e-9
    )
    assert all(a.rms > b.rms for a, b in zip(report.plans[0].rows, plain.plans[0].rows, strict=True))
    assert report.residual_model and "residual model" in "\n".join(report.lines())
    with pytest.raises(BadArgument, match="no prior"):
        pincal.accuracy(params, plan, q0, sigma=SIGMA, residual_model=model, prior=Prior.parse("1mm,1mrad"))


def test_the_accuracy_report_with_a_residual_model_searches_the_worst(setup):
    """Over a region, the report with a residual model searches the worst expected error as the
    geometric report searches ρ: no smaller than any sampled value, inside the region, and the
    expected error recomputed at the pose it names."""
    robot, params = setup
    plan = robot.random_configurations(20, 1)
    q0 = robot.random_configurations(1, 2)[0]
    region = pincal.around(q0, np.radians(10), samples=30)
    model = _model(robot, 3e-4)
    report = pincal.accuracy(
        params, plan, region, sigma=SIGMA, residual_model=model, samples=40, workspace=60
    )
    worst = report.plans[0].worst
    assert worst is not None and worst.searched
    sampled = report.plans[0].rows[0]  # the test region's own samples
    assert worst.sampled == pytest.approx(sampled.max, rel=1e-12) and worst.rho >= worst.sampled
    assert np.all(np.abs(worst.pose - q0) <= np.radians(10) + 1e-9)
    assert worst.rho == pytest.approx(
        expected_error(params, plan, worst.pose[None], model, sigma=SIGMA), rel=1e-9
    )
    assert "worst found" in "\n".join(report.lines())
    assert report.as_dict()["plans"][0]["worst_found"]["searched"]
    # Plain test poses are the samples themselves: the worst of them, not searched.
    poses = robot.random_configurations(3, 5)
    at_poses = pincal.accuracy(
        params, plan, poses, sigma=SIGMA, residual_model=model, samples=40, workspace=60
    )
    assert at_poses.plans[0].worst is None or not at_poses.plans[0].worst.searched
