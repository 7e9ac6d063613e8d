"""Test regions and paths, the prior's Bayesian criterion and accuracy away from the test pose
(issue 9), against brute-force and closed-form oracles. Budget: about 5 s."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.evaluation.test_pose import TestPoseCriterion

SIGMA = 3e-5


@pytest.fixture(scope="module")
def kr(kr270_marker):
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    return params, q0


def _path(robot, q0, n, seed=0):
    rng = np.random.default_rng(seed)
    return np.clip(q0 + rng.uniform(-0.4, 0.4, (n, robot.nq)), robot.lower, robot.upper)


def _brute_rho0_squared(params, plan, poses, sigma, prior_cov=None):
    """σ² tr(J0 M⁻¹ J0ᵀ) per pose with an explicit inverse, or the posterior covariance in the
    Kalman form Σp − ΣpJᵀ(JΣpJᵀ + σ²I)⁻¹JΣp (no M⁻¹: finite for any plan)."""
    J = params.jacobian(plan).reshape(-1, len(params))
    J0 = params.jacobian(poses)
    if prior_cov is None:
        C = sigma**2 * np.linalg.inv(J.T @ J)
    else:
        S = J @ prior_cov @ J.T + sigma**2 * np.eye(len(J))
        C = prior_cov - prior_cov @ J.T @ np.linalg.solve(S, J @ prior_cov)
    return np.einsum("kip,pq,kiq->k", J0, C, J0)


@pytest.mark.parametrize("n", [1, 10, 2000])
def test_mean_over_path_equals_brute_force_mean(kr, n):
    params, q0 = kr
    robot = params.robot
    plan = robot.random_configurations(10, 3)
    path = pincal.TestPath(_path(robot, q0, n))
    got = pincal.rho0(params, plan, path, sigma=SIGMA) ** 2
    expected = _brute_rho0_squared(params, plan, path.q, SIGMA).mean()
    assert got == pytest.approx(expected, rel=1e-12)
    # The compressed weight has at most P columns, whatever the path's length.
    assert TestPoseCriterion(params, path, SIGMA).weight_factor.shape[1] <= len(params)


def test_mean_over_test_poses_planar_closed_form(planar):
    # docs/method.md §9.3: ρ0² is affine in cos q20, so the mean over test poses is the closed form
    # at the mean cosine.
    params = planar.parameters("joint2.tx,tip.tx")
    rng = np.random.default_rng(4)
    for _ in range(20):
        plan = rng.uniform(-np.pi, np.pi, (4, 2))
        poses = rng.uniform(-np.pi, np.pi, (50, 2))
        m, S = 4, np.cos(plan[:, 1]).sum()
        expected = 2 * SIGMA**2 * (m - np.cos(poses[:, 1]).mean() * S) / (m**2 - S**2)
        assert pincal.rho0(params, plan, pincal.TestPath(poses), sigma=SIGMA) ** 2 == pytest.approx(
            expected, rel=1e-10
        )


def test_worst_over_path_is_the_largest(kr):
    params, q0 = kr
    plan = params.robot.random_configurations(10, 3)
    poses = _path(params.robot, q0, 40)
    worst = pincal.rho0(params, plan, pincal.TestPath(poses), sigma=SIGMA, aggregate="worst") ** 2
    assert worst == pytest.approx(_brute_rho0_squared(params, plan, poses, SIGMA).max(), rel=1e-12)


@pytest.mark.parametrize("m", [1, 3, 12])
def test_prior_criterion_equals_brute_force_posterior(kr, m):
    params, q0 = kr
    plan = params.robot.random_configurations(m, 7)  # m = 1, 3: singular without the prior
    prior = pincal.Prior(1e-3, 2e-3)
    cov = prior.covariance(params)
    got = pincal.rho0(params, plan, q0, sigma=SIGMA, prior=prior) ** 2
    assert got == pytest.approx(_brute_rho0_squared(params, plan, q0[None], SIGMA, cov)[0], rel=1e-9)


def test_prior_criterion_tends_to_rho0(kr):
    params, q0 = kr
    plan = params.robot.random_configurations(12, 7)
    plain = pincal.rho0(params, plan, q0, sigma=SIGMA)
    gaps = [
        abs(pincal.rho0(params, plan, q0, sigma=SIGMA, prior=pincal.Prior(s, s)) / plain - 1)
        for s in (1e-2, 1, 1e2)
    ]
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] < 1e-10
    assert pincal.rho0(params, plan, q0, sigma=SIGMA, prior=pincal.Prior(np.inf, np.inf)) == pytest.approx(
        plain, rel=1e-14
    )


def test_prior_split_equals_kalman_form(kr):
    # Error of the MAP estimate: K e − (I − KJ) x, K = ΣpJᵀ(JΣpJᵀ + σ²I)⁻¹: the measurements give
    # σ² tr(J0 K Kᵀ J0ᵀ), the prior errors left uncorrected tr(J0 (I−KJ) Σp (I−KJ)ᵀ J0ᵀ).
    params, q0 = kr
    plan = params.robot.random_configurations(4, 11)
    prior = pincal.Prior(1e-3, 1e-3)
    Sp = prior.covariance(params)
    J = params.jacobian(plan).reshape(-1, len(params))
    K = Sp @ J.T @ np.linalg.inv(J @ Sp @ J.T + SIGMA**2 * np.eye(len(J)))
    J0 = params.jacobian(q0)[0]
    R = np.eye(len(params)) - K @ J
    criterion = TestPoseCriterion(params, q0, SIGMA, "each", prior)
    noise, bias = criterion.split(J.T @ J, len(plan))
    assert noise[0] == pytest.approx(SIGMA**2 * np.trace(J0 @ K @ K.T @ J0.T), rel=1e-9)
    assert bias[0] == pytest.approx(np.trace(J0 @ R @ Sp @ R.T @ J0.T), rel=1e-9)


def test_neighbourhood_samples(kr270_marker):
    q0 = np.radians([0, -10, 60, 0, 45, 0])  # joint a2 within 10° of its upper limit (−5°)
    region = pincal.around(q0, np.radians(10), samples=100).resolve(kr270_marker)
    assert region.poses.shape == (100, 6) and np.array_equal(region.poses[0], q0)
    assert np.all(np.abs(region.poses - q0) <= np.radians(10) + 1e-12)
    assert np.all(region.poses <= kr270_marker.upper) and region.continuous
    with pytest.raises(pincal.PincalError, match="half-width"):
        pincal.around(q0, -1.0)


def test_worst_found_is_at_least_every_sample(kr):
    params, q0 = kr
    predicted = pincal.evaluation.PredictedError(params, params.robot.random_configurations(8, 2), SIGMA)
    region = pincal.around(q0, np.radians(20), samples=64).resolve(params.robot)
    worst = pincal.evaluation.worst_found(predicted, region)
    sampled = predicted(region.poses)
    assert worst.searched and worst.sampled == pytest.approx(sampled.max(), rel=1e-12)
    assert worst.rho >= sampled.max()
    assert predicted(worst.pose[None])[0] == pytest.approx(worst.rho, rel=1e-12)  # it is where it says
    assert np.all(np.abs(worst.pose - q0) <= np.radians(20) + 1e-9)


def test_cartesian_box_by_inverse_kinematics(kr270_marker):
    robot = kr270_marker
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    p0 = robot.points(q0)[0, 0]
    region = pincal.cartesian_box(p0 - 0.1, p0 + 0.1, reference=q0, samples=32).resolve(robot)
    points = robot.points(region.poses)[:, 0]
    assert np.all(points >= p0 - 0.1 - 1e-8) and np.all(points <= p0 + 0.1 + 1e-8)
    lower, upper = kr270_marker.lower, kr270_marker.upper
    assert np.all(region.poses >= lower) and np.all(region.poses <= upper)
    # Every pose has the tool orientation of q0 (forward kinematics of a second marker as the oracle).
    two = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2), (0.0, 0.0, 0.0)])
    R = two.points(region.poses)[:, 1] - two.points(region.poses)[:, 0]  # R·(−marker0)
    R0 = two.points(q0)[0, 1] - two.points(q0)[0, 0]
    assert np.allclose(R, R0, atol=1e-8)
    predicted = pincal.evaluation.PredictedError(
        pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)]).parameters("lengths"),
        robot.random_configurations(8, 2),
        SIGMA,
    )
    worst = pincal.evaluation.worst_found(predicted, region)
    assert worst.rho >= predicted(region.poses).max()
    assert np.all(robot.points(worst.pose)[0, 0] <= p0 + 0.1 + 1e-8)


def test_accuracy_report(kr):
    params, q0 = kr
    robot = params.robot
    plan = robot.random_configurations(12, 5)
    other = robot.random_configurations(12, 6)
    prior = pincal.Prior(1e-3, 1e-3)
    report = pincal.accuracy(
        params, plan, q0, sigma=SIGMA, prior=prior, compare={"other": other}, samples=64, workspace=200
    )
    here = report.plans[0]
    assert here.row("test pose").rms == pytest.approx(
        pincal.rho0(params, plan, q0, sigma=SIGMA, prior=prior), rel=1e-12
    )
    assert report.plans[1].row("test pose").rms == pytest.approx(
        pincal.rho0(params, other, q0, sigma=SIGMA, prior=prior), rel=1e-12
    )
    assert here.from_measurements**2 + here.from_prior**2 == pytest.approx(
        here.row("test pose").rms ** 2, rel=1e-9
    )
    assert [r.where for r in here.rows] == ["test pose", "±10°", "±20°", "workspace"]
    assert report.before == pytest.approx(np.sqrt(_brute_prior_only(params, q0, prior)), rel=1e-12)
    assert "from the prior" in "\n".join(report.lines())


def _brute_prior_only(params, q0, prior):
    J0 = params.jacobian(q0)[0]
    return np.trace(J0 @ prior.covariance(params) @ J0.T)


# ------------------------------------------------------------------ the design side: objectives
@pytest.mark.parametrize("criterion", ["test-pose", "test-pose-worst", "D", "A", "E"])
def test_objectives_with_a_prior_and_a_path(kr, criterion):
    """Objective values agree with the core; ∂F/∂M matches central differences; the exchange with a
    prior starts from a plan singular without it and ends exactly locally optimal (brute force)."""
    import itertools

    from pincal.evaluation.registry import make_criterion as make_objective
    from pincal.model.jacobian import JacobianEngine
    from pincal.planning import exchange

    params, q0 = kr
    robot = params.robot
    P = len(params)
    engine = JacobianEngine(params)
    poses = _path(robot, q0, 300)
    prior = pincal.Prior(1e-3, 1e-3)
    obj = make_objective(criterion, P, 3, engine.jacobian(poses), SIGMA, prior.information(params, SIGMA))
    pool = robot.random_configurations(30, 8)
    J_pool = engine.jacobian(pool)
    if criterion.startswith("test-pose"):
        J = J_pool[:2].reshape(-1, P)  # 2 configurations: singular without the prior
        agg = "mean" if criterion == "test-pose" else "worst"
        expected = pincal.rho0(
            params, pool[:2], pincal.TestPath(poses), sigma=SIGMA, aggregate=agg, prior=prior
        )
        assert obj.report(obj.value(J.T @ J, 2)) == pytest.approx(expected, rel=1e-10)
    M = J_pool[:8].reshape(-1, P).T @ J_pool[:8].reshape(-1, P)
    F, G = obj.value_and_gradient(M, 8)
    E = np.random.default_rng(1).standard_normal((P, P))
    E = (E + E.T) * 1e-3 * np.abs(M).max()
    fd = (obj.value(M + 1e-4 * E, 8) - obj.value(M - 1e-4 * E, 8)) / 2e-4
    if criterion != "test-pose-worst":  # the exact maximum is not differentiable at a tie
        assert np.sum(G * E) == pytest.approx(fd, rel=1e-5)

    out = exchange.fedorov(obj, J_pool, pool, np.arange(2))

    def value(index):
        Jd = J_pool[list(index)].reshape(-1, P)
        return obj.value(Jd.T @ Jd, len(index))

    assert out.F == pytest.approx(value(out.index), rel=1e-9, abs=1e-9)
    for i, c in itertools.product(range(2), range(len(pool))):
        if c not in out.index:
            trial = out.index.copy()
            trial[i] = c
            assert value(trial) >= out.F - 1e-9


# --------------------------------------------------------------------- design() over regions, priors
def test_design_for_a_neighbourhood_reports_its_mean(kr):
    params, q0 = kr
    region = pincal.around(q0, np.radians(10), samples=64)
    result = pincal.design(
        params, 8, region, sigma=SIGMA, search=pincal.Search(starts=2, workers=1, polish=False)
    )
    assert result.rho0 == pytest.approx(pincal.rho0(params, result.plan, region, sigma=SIGMA), rel=1e-12)
    assert len(result.rho0_each) == 64


def test_design_with_a_prior_below_the_parameter_count(kr):
    params, q0 = kr
    prior = pincal.Prior(1e-3, 1e-3)
    with pytest.warns(pincal.errors.DegenerateOptimumWarning, match="effectively singular.*MAP"):
        result = pincal.design(
            params, 3, q0, sigma=SIGMA, prior=prior, search=pincal.Search(starts=2, workers=1, polish=False)
        )
    brute = _brute_rho0_squared(params, result.plan.q, q0[None], SIGMA, prior.covariance(params))[0]
    assert 3 * 3 < len(params) and result.rho0**2 == pytest.approx(brute, rel=1e-9)
    with pytest.raises(pincal.errors.SingularPlan):
        pincal.design(params, 3, q0, sigma=SIGMA, search=pincal.Search(starts=2, workers=1))


def test_planar_closed_form_with_an_uninformative_prior(planar):
    # docs/method.md §9.3: ρ0,min² = (σ²/m) cos² q20 / (1 − |sin q20|); a prior of infinite std
    # changes nothing.
    params = planar.parameters("joint2.tx,tip.tx")
    q20, m = 1.0, 3
    result = pincal.design(
        params,
        m,
        [0.0, q20],
        sigma=SIGMA,
        prior=pincal.Prior(np.inf, np.inf),
        search=pincal.Search(starts=4, workers=1),
        safety=pincal.Safety(min_conditioning=1e-4),
    )
    expected = SIGMA**2 / m * np.cos(q20) ** 2 / (1 - abs(np.sin(q20)))
    assert result.rho0**2 == pytest.approx(expected, rel=1e-6)


def test_a_floor_a_d_optimal_plan_meets_is_not_refused(kr):
    # Issue 9: at floor 1e-2, m = 4 was refused ("no start meets the floor") although a D-optimal
    # plan above it exists. The starts now come from a D-optimal exchange when random plans fail.
    params, q0 = kr
    result = pincal.design(
        params,
        4,
        q0,
        sigma=SIGMA,
        search=pincal.Search(starts=2, workers=1),
        safety=pincal.Safety(min_conditioning=1e-2),
    )
    assert result.conditioning > 1e-2
    # A low floor that binds is warned about, and the advice is never to lower it.
    lengths = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")  # q20 = 0: singular limit
    with pytest.warns(pincal.errors.DegenerateOptimumWarning) as caught:
        pincal.design(
            lengths,
            2,
            [0.2, 0.0],
            sigma=SIGMA,
            search=pincal.Search(starts=2, workers=1),
            safety=pincal.Safety(min_conditioning=1e-4),
        )
    advice = " ".join(str(w.message) for w in caught)
    assert "raise min_conditioning" in advice and "lower" not in advice


def test_a_region_is_resolved_once_while_its_values_and_the_limits_hold():
    """resolve() keeps its result per robot: the same object again for the same values and joint
    limits; a centre changed in place, or a limit changed in the model, is resolved afresh (and
    the kept samples cannot be written)."""
    robot = pincal.load_robot("kr270", tip="tool0")  # its own model: changed below
    q0 = np.radians([0.0, -60.0, 60.0, 0.0, 45.0, 0.0])
    centre = q0.copy()
    region = pincal.around(centre, np.radians(10), samples=32)
    first = region.resolve(robot)
    assert region.resolve(robot) is first
    assert not first.poses.flags.writeable and not first.unit_samples.flags.writeable
    path = pincal.TestPath([list(q0), list(q0 + 0.1)])
    assert path.resolve(robot) is path.resolve(robot)
    centre[0] += 0.05  # the user's array (the region holds it), changed in place
    moved = region.resolve(robot)
    assert moved is not first and moved.poses[0, 0] == pytest.approx(q0[0] + 0.05)
    robot.model.upperPositionLimit[0] = q0[0] + 0.06
    clipped = region.resolve(robot)
    assert clipped is not moved and clipped.poses[:, 0].max() <= q0[0] + 0.06 + 1e-12
    assert moved.poses[:, 0].max() > q0[0] + 0.06


def test_an_equal_region_made_anew_shares_the_resolved_samples():
    """A region made anew with the values of one resolved recently gets its samples (read-only, seeded:
    the same numbers) without drawing again; another seed, width or robot resolves its own."""
    robot = pincal.load_robot("kr270", tip="tool0")
    q0 = np.radians([0.0, -60.0, 60.0, 0.0, 45.0, 0.0])
    first = pincal.around(q0, np.radians(10), samples=24).resolve(robot)
    again = pincal.around(q0.copy(), np.radians(10), samples=24).resolve(robot)
    assert again is first and not again.poses.flags.writeable
    other_seed = pincal.around(q0, np.radians(10), samples=24, seed=1).resolve(robot)
    wider = pincal.around(q0, np.radians(11), samples=24).resolve(robot)
    assert other_seed is not first and wider is not first
    assert not np.array_equal(other_seed.poses, first.poses)
    own = pincal.load_robot("kr270", tip="tool0")  # another robot, equal limits
    elsewhere = pincal.around(q0, np.radians(10), samples=24).resolve(own)
    assert elsewhere is not first and np.array_equal(elsewhere.poses, first.poses)
    box = dict(lower=[1.2, -0.3, 1.0], upper=[1.5, 0.3, 1.4], reference=q0, samples=8)
    corner = np.array(box["lower"])
    shared = pincal.cartesian_box(corner, box["upper"], box["reference"], samples=8).resolve(robot)
    assert pincal.cartesian_box(**box).resolve(robot) is shared
    corner[2] += 0.2  # the first box's array, changed in place: the shared samples' map keeps its own
    np.testing.assert_allclose(
        robot.points(shared.to_configuration(np.zeros(3)))[0, 0], box["lower"], atol=1e-6
    )
