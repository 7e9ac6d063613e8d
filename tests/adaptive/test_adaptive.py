"""Adaptive campaigns: the measured poses' information against the plan they came from, outliers
and unreachable poses, the stopping rule, and the adaptive loop against the one-shot plan by
Monte-Carlo over simulated campaigns (heteroscedastic noise, an outlier, an unreachable pose)."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.adaptive.loop import AVOID_DISTANCE, assess, next_poses
from pincal.adaptive.measured import MeasuredPrior
from pincal.adaptive.rehearsal import Faults, one_shot_plan, rehearse, summary
from pincal.errors import BadArgument, SingularPlan
from tests.adaptive.conftest import FAST, SEARCH

SIGMA = 3e-5


def test_measured_information_is_the_plans_own(params, first, region, kr270_marker):
    """Designing given measured poses is designing their union: ρ0 of new poses with the measured
    prior equals ρ0 of old and new poses together, to rounding."""
    measured = MeasuredPrior.from_measurements(params, first.q, SIGMA)
    new = kr270_marker.random_configurations(3, 7)
    together = pincal.rho0(
        params, first.concat(pincal.Plan.for_robot(kr270_marker, new)), region, sigma=SIGMA
    )
    assert pincal.rho0(params, new, region, sigma=SIGMA, prior=measured) == pytest.approx(together, rel=1e-9)
    # With a prior too: its precision adds up with the measured information.
    prior = pincal.Prior(1e-3, 1e-3)
    both = MeasuredPrior.from_measurements(params, first.q, SIGMA, prior)
    np.testing.assert_allclose(both.precision(params), prior.precision(params) + measured.fisher)
    np.testing.assert_allclose(both.std(params), prior.std(params))  # "before calibration" is the prior's
    with pytest.raises(BadArgument, match="other parameters"):
        measured.precision(kr270_marker.parameters("offsets"))


def test_assessment_predicts_from_the_data_so_far(params, first, region):
    truth = pincal.random_errors(params, seed=1)
    data = pincal.simulate_measurements(truth, first, sigma=SIGMA, seed=2)
    a = assess(params, data, region, plan=first, sigma=SIGMA)
    assert a.sigma_source == "given" and a.used.all() and not len(a.unreachable)
    fitted = params.on(a.identification.robot)  # the prediction uses the fitted robot (method §11.6)
    assert a.unexplained == 0.0  # noise only: the residuals are within σ
    assert a.predicted == pytest.approx(pincal.rho0(fitted, first, region, sigma=SIGMA), rel=1e-9)
    # σ re-estimated from the residuals: the prediction scales with it.
    b = assess(params, data, region, plan=first)
    assert b.sigma_source == "estimated" and b.sigma == pytest.approx(b.identification.sigma)
    assert b.unexplained == 0.0  # within the default instrument's σ, 0.03 mm
    assert b.predicted == pytest.approx(
        pincal.rho0(params.on(b.identification.robot), first, region, sigma=b.sigma), rel=1e-9
    )


def test_outliers_and_unreachable_poses_are_named_and_left_out(params, region, kr270_marker):
    plan = pincal.design(params, 10, region, search=pincal.Search(**FAST, seed=1)).plan
    truth = pincal.random_errors(params, seed=3)
    data = pincal.simulate_measurements(truth, plan.q[1:], sigma=SIGMA, seed=4)  # pose 0 not reached
    points = np.array(data.points)
    points[4, 0, 2] += 2e-3  # a 2 mm reading error
    data = pincal.MeasurementData(data.q, points, data.joint_names)
    step = next_poses(params, data, region, 3, plan=plan, sigma=SIGMA, search=SEARCH)
    assert [o.row for o in step.outliers] == [4] and step.used == 8 and step.measured == 9
    np.testing.assert_allclose(step.unreachable, plan.q[:1])
    # The information kept is that of the 8 good rows.
    kept = np.delete(np.arange(9), 4)
    fitted = params.on(step.identification.robot)
    assert step.predicted == pytest.approx(pincal.rho0(fitted, data.q[kept], region, sigma=SIGMA), rel=1e-9)
    # The next poses keep away from the unreachable one, and improve the prediction.
    assert np.linalg.norm(step.plan.q - plan.q[0], axis=1).min() >= AVOID_DISTANCE - 1e-9
    assert step.predicted_after < step.predicted and len(step.plan) == 3 and not step.stop
    # ... better than three random next poses would.
    for seed in range(3):
        random3 = kr270_marker.random_configurations(3, seed)
        measured = MeasuredPrior.from_measurements(params, data.q[kept], SIGMA)
        assert step.predicted_after <= pincal.rho0(params, random3, region, sigma=SIGMA, prior=measured)
    text = "\n".join(step.lines(degrees=True))
    assert "outlier dropped" in text and "unreachable" in text and "next 3 poses" in text


def test_stopping_rule(params, first, region):
    truth = pincal.random_errors(params, seed=5)
    data = pincal.simulate_measurements(truth, first, sigma=SIGMA, seed=6)
    predicted = assess(params, data, region, sigma=SIGMA).predicted
    done = next_poses(params, data, region, 3, target=1.01 * predicted, sigma=SIGMA, search=SEARCH)
    assert done.stop and len(done.plan) == 0 and done.predicted_after is None and "stop" in done.message
    more = next_poses(params, data, region, 3, target=0.5 * predicted, sigma=SIGMA, search=SEARCH)
    assert not more.stop and len(more.plan) == 3


def test_too_few_next_poses_are_refused(params, region, first):
    truth = pincal.random_errors(params, seed=5)
    data = pincal.simulate_measurements(truth, first.q[:1], sigma=SIGMA, seed=6)  # 3 of 12 coordinates
    with pytest.raises(SingularPlan, match="at least 3 poses"):
        next_poses(params, data, region, 2, sigma=SIGMA, search=SEARCH)


def test_adaptive_reaches_the_target_in_fewer_poses_than_one_shot(params, region):
    """Monte-Carlo over simulated campaigns with heteroscedastic noise (1.5 σ on average, growing
    with the distance to the tracker), an outlier and an unreachable pose: the same stopping rule,
    fewer poses measured adaptively (benchmarks/bench_adaptive.py runs more seeds)."""
    target = 2e-5
    plan = one_shot_plan(params, region, target, SIGMA, search=pincal.Search(**FAST, seed=0))
    results = [
        rehearse(
            params,
            region,
            target,
            plan=plan,
            seed=seed,
            faults=Faults(),
            search=pincal.Search(**FAST, seed=seed),
        )
        for seed in range(3)
    ]
    stats = summary(results, target)
    assert stats["adaptive"]["reached"] == 1.0
    assert stats["adaptive"]["poses_mean"] < stats["one-shot"]["poses_mean"]
    # Stopping was honest: the error the data truly leave is near the target.
    assert stats["adaptive"]["true_over_target_mean"] < 1.2


def test_cli_next(tmp_path, cli, params, first, kr270_marker):
    truth = pincal.random_errors(params, seed=1)
    data = pincal.simulate_measurements(truth, first, sigma=SIGMA, seed=2)
    measured, plan, out = tmp_path / "meas.csv", tmp_path / "plan.csv", tmp_path / "next.csv"
    data.to_csv(measured, degrees=True, robot=kr270_marker)
    first.to_csv(plan, degrees=True)
    argv = ["next", "kr270", "--data", measured, "--plan", plan, "--deg", "--marker", "0.1,0.05,0.2"]
    argv += ["--params", "lengths,offsets", "--test-pose=0,-60,60,0,45,0", "--around", "10deg"]
    argv += ["--starts", "2", "--workers", "1"]
    payload = cli.json(*argv, "--target", "1um", "--out", out)
    assert not payload["stop"] and len(payload["next"]) == 3 and payload["sigma_source"] == "estimated"
    written = pincal.Plan.from_csv(out, robot=kr270_marker, degrees=True)
    np.testing.assert_allclose(written.q, payload["next"], atol=1e-9)
    code, text, _ = cli.run(*argv, "--target", "10mm")
    assert code == 0 and "stop: the predicted error is below the target" in text
    cli.fails(*argv, "--target", "fast", match="--target 'fast'")


def test_the_rehearsal_takes_a_search_and_its_0_1_options_until_0_3(params, region):
    """``one_shot_plan``'s flat keywords and ``rehearse``'s ``design_options=`` dict of pincal 0.1
    become ``search=`` with a DeprecationWarning at the caller's line, and the same campaigns."""
    target = 2e-5
    with pytest.warns(DeprecationWarning, match=r"one_shot_plan\(\): the flat keywords") as caught:
        old = one_shot_plan(params, region, target, SIGMA, seed=0, **FAST)
    assert caught[0].filename == __file__
    new = one_shot_plan(params, region, target, SIGMA, search=pincal.Search(**FAST, seed=0))
    assert old.q.tobytes() == new.q.tobytes()
    with pytest.warns(DeprecationWarning, match=r"rehearse\(\): the flat keywords .* search=pincal.Search"):
        before = rehearse(params, region, target, plan=new, seed=1, design_options=FAST)
    after = rehearse(params, region, target, plan=new, seed=1, search=pincal.Search(**FAST, seed=1))
    assert before == after
    with pytest.raises(TypeError, match="design_options= and search="):
        rehearse(params, region, target, plan=new, design_options=FAST, search=pincal.Search())


def test_next_poses_takes_a_search_and_a_safety_and_its_0_1_keywords_until_0_3(params, first, region):
    """next_poses()'s flat keywords of pincal 0.1 become ``search=`` and ``safety=`` with a
    DeprecationWarning at the caller's line, next_poses' own 8 starts and 1 worker kept (the hint
    writes them), and the same next poses; a dict is no Search."""
    data = pincal.simulate_measurements(pincal.random_errors(params, seed=1), first, sigma=SIGMA, seed=2)
    flat = dict(pool=300, polish=False, seed=3, clearance=0.04)
    message = r"next_poses\(\): the flat keywords .* search=pincal.Search\(starts=8, workers=1, pool="
    with pytest.warns(DeprecationWarning, match=message) as caught:
        old = next_poses(params, data, region, 3, plan=first, sigma=SIGMA, **flat)
    assert caught[0].filename == __file__ and "safety=pincal.Safety(clearance=...)" in str(caught[0].message)
    search = pincal.Search(starts=8, seed=3, workers=1, pool=300, polish=False)
    safety = pincal.Safety(clearance=0.04)
    new = next_poses(params, data, region, 3, plan=first, sigma=SIGMA, search=search, safety=safety)
    assert old.plan.q.tobytes() == new.plan.q.tobytes() and old.message == new.message
    assert (old.predicted, old.predicted_after) == (new.predicted, new.predicted_after)
    with pytest.raises(BadArgument, match=r"search= takes a pincal.Search\(...\)"):
        next_poses(params, data, region, 3, sigma=SIGMA, search=dict(FAST))
    with pytest.raises(BadArgument, match=r"safety= takes a pincal.Safety\(...\)"):
        next_poses(params, data, region, 3, sigma=SIGMA, search=SEARCH, safety={"clearance": 0.04})
    with pytest.raises(TypeError, match="starts and search="):
        next_poses(params, data, region, 3, sigma=SIGMA, starts=2, search=SEARCH)
