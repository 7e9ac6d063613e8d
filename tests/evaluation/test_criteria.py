"""Criteria against the planar 2-link closed form (docs/method.md §9) and other exact oracles."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.errors import BadConfiguration, PincalError, SingularPlan
from pincal.evaluation.test_pose import TestPoseCriterion
from tests.evaluation.test_low_rank import check_swaps

SIGMA = 3e-5


def closed_form_rho0_squared(plan: np.ndarray, q20: float, sigma: float) -> float:
    m = len(plan)
    S = np.cos(plan[:, 1]).sum()
    return 2 * sigma**2 * (m - np.cos(q20) * S) / (m**2 - S**2)


@pytest.mark.parametrize("spec", ["joint2.tx,tip.tx", "joint1.offset,joint2.offset"])
def test_rho0_equals_closed_form(planar, spec):
    params = planar.parameters(spec)
    rng = np.random.default_rng(2)
    worst = 0.0
    for _ in range(300):
        m = int(rng.integers(1, 9))
        plan = rng.uniform(-np.pi, np.pi, (m, 2))
        q0 = rng.uniform(-np.pi, np.pi, 2)
        S = np.cos(plan[:, 1]).sum()
        if m**2 - S**2 < 1e-3 * m**2:  # nearly singular plans: the closed form itself is ill-conditioned
            continue
        expected = closed_form_rho0_squared(plan, q0[1], SIGMA)
        got = pincal.rho0(params, plan, q0, sigma=SIGMA) ** 2
        worst = max(worst, abs(got - expected) / expected)
    assert worst <= 1e-10


def test_closed_form_covariance_and_classic_criteria(planar):
    # cov = sigma^2/(m^2 - S^2) [[m, -S], [-S, m]]: A = 2m/(m^2-S^2), D = -log(m^2 - S^2).
    params = planar.parameters("joint2.tx,tip.tx")
    plan = np.array([[0.1, 0.5], [1.0, -2.0], [-0.5, 1.2], [2.0, 0.3]])
    m, S = len(plan), np.cos(plan[:, 1]).sum()
    crit = pincal.criteria(params, plan)
    assert crit.trace == pytest.approx(2 * m / (m**2 - S**2), rel=1e-12)
    assert crit.log_det == pytest.approx(-np.log(m**2 - S**2), rel=1e-12)
    # eigenvalues of M = [[m, S], [S, m]] are m +- |S|
    assert crit.max_eig == pytest.approx(1 / (m - abs(S)), rel=1e-12)
    assert crit.cond == pytest.approx(np.sqrt((m + abs(S)) / (m - abs(S))), rel=1e-12)
    s = np.sqrt([m + abs(S), m - abs(S)])
    assert crit.O1 == pytest.approx(np.sqrt(s.prod()) / np.sqrt(m), rel=1e-12)
    assert crit.O2 == pytest.approx(s[1] / s[0], rel=1e-12)
    assert crit.O3 == pytest.approx(s[1], rel=1e-12)
    assert crit.O4 == pytest.approx(s[1] ** 2 / s[0], rel=1e-12)


def test_d_optimal_plan_gives_2_sigma2_over_m_everywhere(planar):
    params = planar.parameters("joint2.tx,tip.tx")
    plan = np.array([[0.3, np.pi / 2], [1.0, -np.pi / 2], [-2.0, 2.0], [0.5, np.pi - 2.0]])  # S = 0
    for q20 in np.linspace(-3, 3, 7):
        r2 = pincal.rho0(params, plan, [0.2, q20], sigma=SIGMA) ** 2
        assert r2 == pytest.approx(2 * SIGMA**2 / len(plan), rel=1e-12)


def test_closed_form_optimum_is_reached_by_its_plan(planar):
    # S* = m (1 - |sin q20|)/cos q20 gives rho0_min^2 = (sigma^2/m) cos^2 q20 / (1 - |sin q20|).
    params = planar.parameters("joint2.tx,tip.tx")
    q20, m = 1.0, 2
    c = (1 - abs(np.sin(q20))) / np.cos(q20)  # cos q2i for every i
    plan = np.array([[0.0, np.arccos(c)], [1.0, -np.arccos(c)]])
    expected = SIGMA**2 / m * np.cos(q20) ** 2 / (1 - abs(np.sin(q20)))
    assert pincal.rho0(params, plan, [0.0, q20], sigma=SIGMA) ** 2 == pytest.approx(expected, rel=1e-12)


def test_repeat_permute_and_add(kr270_marker):
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    plan = pincal.Plan.for_robot(kr270_marker, kr270_marker.random_configurations(12, 1))
    q0 = kr270_marker.random_configurations(1, 2)
    base = pincal.rho0(params, plan, q0, sigma=SIGMA)
    assert pincal.rho0(params, plan.repeat(3), q0, sigma=SIGMA) ** 2 == pytest.approx(base**2 / 3, rel=1e-10)
    perm = np.random.default_rng(0).permutation(12)
    assert pincal.rho0(params, plan.q[perm], q0, sigma=SIGMA) == pytest.approx(base, rel=1e-10)
    more = plan.concat(pincal.Plan.for_robot(kr270_marker, kr270_marker.random_configurations(1, 3)))
    assert pincal.rho0(params, more, q0, sigma=SIGMA) <= base
    assert pincal.rho0(params, plan, q0, sigma=2 * SIGMA) == pytest.approx(2 * base, rel=1e-12)


def test_several_test_poses(kr270_marker):
    params = kr270_marker.parameters("lengths,offsets")
    plan = kr270_marker.random_configurations(10, 4)
    q0 = kr270_marker.random_configurations(3, 5)
    each = pincal.evaluation.rho0_each(params, plan, q0, sigma=SIGMA)
    singles = [pincal.rho0(params, plan, q, sigma=SIGMA) for q in q0]
    np.testing.assert_allclose(each, singles, rtol=1e-12)
    assert pincal.rho0(params, plan, q0, sigma=SIGMA) == pytest.approx(np.sqrt(np.mean(each**2)), rel=1e-12)
    assert pincal.rho0(params, plan, q0, sigma=SIGMA, aggregate="worst") == pytest.approx(
        each.max(), rel=1e-12
    )
    with pytest.raises(PincalError, match="mean, worst, each"):
        pincal.rho0(params, plan, q0, aggregate="median")


def test_position_covariance_trace_is_rho0_squared(kr270_marker):
    params = kr270_marker.parameters("full,offsets,base").identifiable().identifiable
    plan = kr270_marker.random_configurations(12, 6)
    q0 = kr270_marker.random_configurations(2, 7)
    cov = pincal.evaluation.position_covariance(params, plan, q0, sigma=SIGMA)
    each = pincal.evaluation.rho0_each(params, plan, q0, sigma=SIGMA)
    np.testing.assert_allclose(np.trace(cov, axis1=1, axis2=2), each**2, rtol=1e-10)
    np.testing.assert_allclose(cov, cov.transpose(0, 2, 1), atol=1e-20)


def test_rho0_matches_a_monte_carlo_of_linear_least_squares(kr270_marker):
    # Draw noise, solve the linear least squares, measure the error at q0: its RMS is rho0.
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    plan = kr270_marker.random_configurations(12, 8)
    q0 = kr270_marker.random_configurations(1, 9)
    J = params.jacobian(plan).reshape(-1, len(params))
    J0 = params.jacobian(q0).reshape(-1, len(params))
    rng = np.random.default_rng(10)
    noise = rng.normal(0, SIGMA, (J.shape[0], 4000))
    estimate = np.linalg.lstsq(J, noise, rcond=None)[0]
    errors = np.sum((J0 @ estimate) ** 2, axis=0)
    empirical = np.sqrt(errors.mean())
    predicted = pincal.rho0(params, plan, q0, sigma=SIGMA)
    # squared error has relative std about sqrt(2/3)/sqrt(n) at most (3 coordinates): 5 sigma
    assert empirical == pytest.approx(predicted, rel=5 * np.sqrt(2 / 4000))


def test_singular_plan_names_the_minimum(kr270_marker):
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable  # 27 parameters
    q0 = kr270_marker.random_configurations(1, 0)
    with pytest.raises(SingularPlan, match="at least 9 configurations") as info:
        pincal.rho0(params, kr270_marker.random_configurations(4, 1), q0)
    assert info.value.min_configurations == 9
    with pytest.raises(SingularPlan, match="at least 9"):
        pincal.criteria(params, kr270_marker.random_configurations(2, 1))


def test_degenerate_plan(planar):
    params = planar.parameters("joint2.tx,tip.tx")
    plan = np.array([[0.1, 0.0], [1.0, 0.0], [2.0, 0.0]])  # stretched arm: dl1 and dl2 inseparable
    with pytest.raises(SingularPlan, match="degenerate") as info:
        pincal.rho0(params, plan, [0.0, 1.0])
    assert info.value.rank == 1


def test_unidentifiable_parameters_give_a_singular_plan(kr270):
    params = kr270.parameters("offsets")  # joint_a6.offset is invisible without an off-axis marker
    with pytest.raises(SingularPlan):
        pincal.rho0(params, kr270.random_configurations(20, 1), kr270.random_configurations(1, 2))


def test_bad_sigma_and_test_pose(kr270):
    params = kr270.parameters("lengths")
    with pytest.raises(PincalError, match="sigma"):
        TestPoseCriterion(params, kr270.random_configurations(1, 0), sigma=0)
    with pytest.raises(pincal.errors.BadConfiguration, match="test pose"):
        TestPoseCriterion(params, np.zeros(5))


def test_criterion_does_not_modify_inputs(kr270_marker):
    params = kr270_marker.parameters("lengths,offsets")
    plan = kr270_marker.random_configurations(10, 4)
    q0 = kr270_marker.random_configurations(1, 5)
    before, before0 = plan.copy(), q0.copy()
    pincal.rho0(params, plan, q0)
    pincal.criteria(params, plan)
    np.testing.assert_array_equal(plan, before)
    np.testing.assert_array_equal(q0, before0)


# ------------------------------------------------------- the criterion interface, every criterion
@pytest.mark.parametrize("with_prior", [False, True])
@pytest.mark.parametrize("name", ["test-pose", "test-pose-worst", "D", "A", "E", "cond"])
def test_every_criterion_object_keeps_its_promises(kr270_marker, name, with_prior):
    """For every criterion of the registry: ∂F/∂M matches central differences of F, the batch
    values match one by one, and the exchange state scores every candidate swap as the exact value
    of the swapped plan (the low-rank update is exact), before and after a swap it makes."""
    from pincal.evaluation.registry import make_criterion
    from pincal.model.jacobian import JacobianEngine

    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    P = len(params)
    engine = JacobianEngine(params)
    rng = np.random.default_rng(4)
    pool = kr270_marker.random_configurations(30, rng)
    J_pool = engine.jacobian(pool, frame="tip")
    J0 = engine.jacobian(kr270_marker.random_configurations(3, rng), frame="tip")
    prior = pincal.Prior(1e-3, 1e-3).information(params, SIGMA) if with_prior else None
    criterion = make_criterion(name, P, 3, J0, SIGMA, prior)
    assert criterion.name == name

    def exact(index) -> float:
        J = J_pool[list(index)].reshape(-1, P)
        return criterion.value(J.T @ J, len(index))

    index = np.arange(8)
    J = J_pool[index].reshape(-1, P)
    M = J.T @ J
    F, G = criterion.value_and_gradient(M, 8)
    assert F == pytest.approx(exact(index), rel=1e-12)
    E = rng.standard_normal((P, P))
    E = (E + E.T) * 1e-7 * np.abs(M).max()
    fd = (criterion.value(M + E, 8) - criterion.value(M - E, 8)) / 2
    assert np.sum(G * E) == pytest.approx(fd, rel=1e-4, abs=1e-12)
    Ms = np.stack([M, M + J_pool[20].T @ J_pool[20]])
    np.testing.assert_allclose(criterion.batch_values(Ms), [F, exact([*index, 20])], rtol=1e-9)

    check_swaps(criterion.exchange(J_pool, index.copy()), len(pool), exact, (0, 5), rel=1e-8)


# ------------------------------------------------------------ public evaluations on many plans
def test_batches_of_plans_give_each_plans_value(kr270_marker):
    """rho0, rho0_each, criteria and accuracy on a batch (k, m, nq) — or a list of Plans — give
    what they give plan by plan; a singular plan of a batch is named."""
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    rng = np.random.default_rng(8)
    plans = kr270_marker.random_configurations(4 * 7, rng).reshape(4, 7, -1)
    poses = kr270_marker.random_configurations(3, rng)
    prior = pincal.Prior(1e-3, 1e-3)
    for kw in ({}, {"aggregate": "worst"}, {"prior": prior}):
        one = [pincal.rho0(params, p, poses, sigma=SIGMA, **kw) for p in plans]
        np.testing.assert_allclose(pincal.rho0(params, plans, poses, sigma=SIGMA, **kw), one, rtol=1e-12)
    each = np.array([pincal.evaluation.rho0_each(params, p, poses, sigma=SIGMA) for p in plans])
    np.testing.assert_allclose(
        pincal.evaluation.rho0_each(params, plans, poses, sigma=SIGMA), each, rtol=1e-12
    )
    as_plans = [pincal.Plan.for_robot(kr270_marker, p) for p in plans]
    assert pincal.rho0(params, as_plans, poses, sigma=SIGMA).shape == (4,)
    for c, p in zip(pincal.criteria(params, plans), plans, strict=True):
        expected = pincal.criteria(params, p).as_dict()
        for key, value in c.as_dict().items():
            assert value == pytest.approx(expected[key], rel=1e-9)
    reports = pincal.accuracy(params, plans[:2], poses, sigma=SIGMA, workspace=50, samples=20)
    for report, p in zip(reports, plans[:2], strict=True):
        single = pincal.accuracy(params, p, poses, sigma=SIGMA, workspace=50, samples=20)
        for a, b in zip(report.plans[0].rows, single.plans[0].rows, strict=True):
            assert a.rms == pytest.approx(b.rms, rel=1e-12) and a.max == pytest.approx(b.max, rel=1e-12)
    singular = plans.copy()
    singular[2] = singular[2][0]  # seven times the same configuration
    with pytest.raises(SingularPlan, match="plan 2"):
        pincal.rho0(params, singular, poses, sigma=SIGMA)
    with pytest.raises(PincalError):
        pincal.rho0(params, plans[..., :3], poses)


def test_repeated_single_evaluations_follow_their_arguments(kr270_marker):
    """rho0 keeps the criterion of recent arguments (J0 computed once): every call still gives
    what a criterion built afresh gives, for another test pose, σ, aggregate, parameter set or
    task payload, in any order, and a region of the same centre is not taken for the pose."""
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    other = kr270_marker.parameters("full,offsets").identifiable().identifiable
    rng = np.random.default_rng(9)
    plan = kr270_marker.random_configurations(12, rng)
    poses = kr270_marker.random_configurations(3, rng)
    cases = [
        (params, poses[0], SIGMA, "mean"),
        (params, poses[1], SIGMA, "mean"),
        (params, poses[0], 2 * SIGMA, "mean"),
        (params, poses, SIGMA, "mean"),
        (params, poses, SIGMA, "worst"),
        (other, poses[0], SIGMA, "mean"),
        (params, pincal.around(poses[0], np.radians(5)), SIGMA, "mean"),
    ]
    fresh = [TestPoseCriterion(p, q, s, a)(plan) for p, q, s, a in cases]
    assert len(set(fresh)) == len(fresh)  # every case differs
    for _ in range(2):
        for (p, q, s, a), expected in zip(cases, fresh, strict=True):
            assert pincal.rho0(p, plan, q, sigma=s, aggregate=a) == pytest.approx(expected, rel=1e-12)
    loaded = pincal.rho0(params, plan, poses[0], task_payload=50.0)
    assert loaded == pytest.approx(fresh[0], rel=1e-12)  # no compliance: the payload changes nothing


def test_a_test_pose_changed_in_place_is_a_new_test_pose(kr270_marker):
    """rho0 keeps the criterion of the test pose's values, not of the array: the same array
    changed in place gives the new pose's ρ0, and a value moved outside its limits is refused."""
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    rng = np.random.default_rng(10)
    plan = kr270_marker.random_configurations(12, rng)
    q0 = kr270_marker.random_configurations(1, rng)[0]
    first = pincal.rho0(params, plan, q0, sigma=SIGMA)
    q0[1] = 0.5 * (q0[1] + kr270_marker.upper[1])
    moved = pincal.rho0(params, plan, q0, sigma=SIGMA)
    assert moved != first
    assert moved == pytest.approx(TestPoseCriterion(params, q0, SIGMA)(plan), rel=1e-12)
    q0[1] = kr270_marker.upper[1] + 0.1
    with pytest.raises(BadConfiguration, match="test pose 0: joint"):
        pincal.rho0(params, plan, q0, sigma=SIGMA)
    q0[1] = np.inf
    with pytest.raises(BadConfiguration, match="must be finite"):
        pincal.rho0(params, plan, q0, sigma=SIGMA)
