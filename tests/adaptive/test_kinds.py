"""The adaptive loop on data of another kind than points: the poses so far and the next ones are
measured with the data's instrument (its whitened rows), against pincal.rho0 with that instrument
on the fitted robot, a Monte-Carlo of the campaign, and the CLI."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.adaptive.loop import assess, next_poses
from pincal.errors import BadArgument, SingularPlan
from pincal.evaluation.region import resolve_test_poses
from pincal.instruments import Instrument, Partial, PerCoordinate, Point, Pose, Tracker
from tests.adaptive.conftest import FAST, Q0, SEARCH

MOCAP = Instrument(Pose(), PerCoordinate(2e-5, 1e-4))


@pytest.fixture(scope="module")
def poses(params, first):
    """Pose data (motion capture) of the first plan on a robot with random errors."""
    truth = pincal.random_errors(params, seed=1)
    return pincal.simulate_measurements(truth, first, instrument=MOCAP, seed=2)


def test_pose_data_are_measured_as_poses(params, region, poses):
    """The prediction with the data so far and after the next poses is ρ0 of the pose instrument on
    the fitted robot (not the points' ρ0 that pincal 0.2 reported for the same data)."""
    a = assess(params, poses, region, instrument=MOCAP)
    assert a.sigma_source == "given" and a.used.all() and a.unexplained == 0.0
    now = pincal.rho0(a.params, poses.q, region, instrument=MOCAP)
    assert a.predicted == pytest.approx(now, rel=1e-9)
    as_points = pincal.rho0(a.params, poses.q, region, sigma=2e-5)
    assert abs(as_points - now) > 0.05 * now  # what reading them as points predicted
    step = next_poses(params, poses, region, 2, instrument=MOCAP, search=SEARCH)
    after = pincal.rho0(a.params, np.vstack([poses.q, step.plan.q]), region, instrument=MOCAP)
    assert step.predicted_after == pytest.approx(after, rel=1e-9)
    assert f"{after * 1e3:.4g} mm" in step.message
    # sigma= is the length σ of the data's kind (angles at pincal's default, 1e-4 rad), as identify
    # takes it: the same instrument here.
    same = next_poses(params, poses, region, 2, sigma=2e-5, search=SEARCH)
    assert same.predicted_after == step.predicted_after and np.array_equal(same.plan.q, step.plan.q)


def test_rows_per_configuration_are_the_kinds(params, region, poses, first):
    """One pose measured brings 6 of the 12 parameters: two more poses complete them (one point
    brings 3: at least 3 poses more)."""
    one = poses.subset([0])
    step = next_poses(params, one, region, 2, instrument=MOCAP, search=SEARCH)
    assert len(step.plan) == 2 and math.isfinite(step.predicted_after)
    after = pincal.rho0(params, np.vstack([one.q, step.plan.q]), region, instrument=MOCAP)
    assert step.predicted_after == pytest.approx(after, rel=1e-9)  # no fit from one pose: nominal robot
    points = pincal.simulate_measurements(pincal.random_errors(params, seed=1), first.q[:1], sigma=2e-5)
    with pytest.raises(SingularPlan, match="at least 3 poses"):
        next_poses(params, points, region, 2, sigma=2e-5, search=SEARCH)


def test_partial_data_with_sigma_re_estimated(kr270_marker, region):
    """x,y of the marker (a probe on a plane), σ re-estimated: the prediction is ρ0 of the partial
    instrument with the identification's σ, on the fitted robot."""
    plane = Instrument(Partial(("x", "y")), PerCoordinate(2e-5))
    params = plane.identifiable(kr270_marker.parameters("lengths,offsets")).identifiable
    plan = pincal.design(params, 10, region, instrument=plane, search=pincal.Search(**FAST, seed=0)).plan
    data = pincal.simulate_measurements(pincal.random_errors(params, seed=3), plan, instrument=plane, seed=4)
    a = assess(params, data, region)
    assert a.sigma_source == "estimated" and a.identification is not None
    assert a.sigma == a.identification.sigma and 0.5 < a.sigma / 2e-5 < 1.5
    estimated = Instrument(Partial(("x", "y")), PerCoordinate(a.sigma))
    rho = pincal.rho0(a.params, data.q[a.used], region, instrument=estimated)
    assert a.predicted == pytest.approx(a.with_unexplained(rho), rel=1e-9)
    step = next_poses(params, data, region, 2, search=SEARCH)
    after = pincal.rho0(a.params, np.vstack([data.q[a.used], step.plan.q]), region, instrument=estimated)
    assert step.predicted_after == pytest.approx(a.with_unexplained(after), rel=1e-9)


def test_what_is_refused(params, region, poses):
    with pytest.raises(BadArgument, match="the data hold"):
        next_poses(params, poses, region, 2, instrument=Instrument(Point(), Tracker()), search=SEARCH)
    with pytest.raises(BadArgument, match="not both"):
        next_poses(params, poses, region, 2, instrument=MOCAP, sigma=2e-5, search=SEARCH)
    with pytest.raises(BadArgument, match=r"Instrument\(Pose"):
        next_poses(params, poses, region, 2, instrument=PerCoordinate(2e-5), search=SEARCH)


def test_the_prediction_from_pose_data_is_delivered(params, region, poses, kr270_marker):
    """A simulated campaign of the data so far and the next poses, measured with the pose
    instrument and identified again and again (pincal.monte_carlo on the fitted robot): the error
    it delivers over the test region is the one next_poses predicted, within the Monte-Carlo's own
    scatter (as the instruments' Monte-Carlo tests allow)."""
    a = assess(params, poses, region, instrument=MOCAP)
    step = next_poses(params, poses, region, 2, instrument=MOCAP, search=SEARCH)
    tests, _ = resolve_test_poses(kr270_marker, region)
    plan = np.vstack([poses.q, step.plan.q])
    mc = pincal.monte_carlo(a.params, plan, tests, trials=40, seed=3, instrument=MOCAP)
    assert mc.rho0_predicted == pytest.approx(step.predicted_after, rel=1e-9)
    assert mc.failures == 0 and abs(mc.ratio - 1) < 4 * mc.ratio_se


def test_cli_next_with_pose_data(tmp_path, cli, params, poses, first, kr270_marker):
    """pincal next --measure pose reports what the library does on the data it reads."""
    measured, plan = tmp_path / "mocap.csv", tmp_path / "plan.csv"
    poses.to_csv(measured, degrees=True, robot=kr270_marker)
    first.to_csv(plan, degrees=True)
    argv = ["next", "kr270", "--data", measured, "--plan", plan, "--deg", "--marker", "0.1,0.05,0.2"]
    argv += ["--params", "lengths,offsets", "--test-pose=0,-60,60,0,45,0", "--around", "10deg"]
    argv += ["--starts", "2", "--workers", "1", "-k", "2", "--measure", "pose"]
    payload = cli.json(*argv, "--sigma", "2e-5", "--sigma-rot", "1e-4")
    data = pincal.MeasurementData.from_csv(measured, kr270_marker, degrees=True, kind=Pose())
    region = pincal.around(Q0, math.radians(10))  # the CLI's --around 10deg
    step = next_poses(
        params, data, region, 2, plan=first, instrument=MOCAP, search=pincal.Search(starts=2, workers=1)
    )
    assert payload["sigma_source"] == "given" and payload["sigma"] == 2e-5
    assert payload["predicted"] == pytest.approx(step.predicted, rel=1e-12)
    assert payload["predicted_after"] == pytest.approx(step.predicted_after, rel=1e-12)
    np.testing.assert_allclose(payload["next"], step.plan.q, atol=1e-12)
    cli.fails(*argv, "--sigma", "2e-5", "--instrument", "tracker", match="--sigma")


def test_pose_data_with_their_own_uncertainties(params, region, poses):
    """Uncertainty columns equal to the instrument's σ tell what the instrument does: the same
    prediction now and after the next poses (measured at the data's medians, per unit)."""
    std = np.tile([2e-5] * 3 + [1e-4] * 3, (poses.m, 1))
    own = pincal.MeasurementData(poses.q, poses.points, poses.joint_names, sigma=std, kind=Pose())
    a, b = assess(params, own, region), assess(params, poses, region, instrument=MOCAP)
    assert a.sigma_source == "data" and a.sigma == 2e-5
    assert a.predicted == pytest.approx(b.predicted, rel=1e-9)
    step = next_poses(params, own, region, 2, search=SEARCH)
    again = next_poses(params, poses, region, 2, instrument=MOCAP, search=SEARCH)
    assert step.predicted_after == pytest.approx(again.predicted_after, rel=1e-9)


def test_cli_next_identifies_the_instrument_s_fixtures_as_identify_does(tmp_path, cli, ur10):
    """Draw-wire data: pincal next fits the anchors with the robot, as pincal identify does (it took a
    point's identifiable set, without them: σ came out 0.35 mm for 0.03 mm wires)."""
    anchors = ["--anchor", "1,1,0", "--anchor", "-1,1.5,0.5", "--anchor", "1.5,-1,1"]
    plan, wires = tmp_path / "plan.csv", tmp_path / "wires.csv"
    pincal.Plan.for_robot(ur10, ur10.random_configurations(30, 4)).to_csv(plan)
    cli.run("measure-sim", "ur10", "--plan", plan, *anchors, "--error-std", "1e-3,1e-3", "--out", wires)
    fit = cli.json("identify", "ur10", "--data", wires, *anchors)
    step = cli.json("next", "ur10", "--data", wires, *anchors, "--test-pose=0,-1.2,1.5,-1,-1.5,0", "-k", "2",
                    "--starts", "1", "--workers", "1")  # fmt: skip
    assert set(step["params"]) == set(fit["params"]) and len(step["params"]) == len(fit["params"])
    assert any(name.startswith("anchor") for name in step["params"])
    assert step["sigma"] == pytest.approx(fit["sigma"], rel=1e-9) and step["sigma"] < 5e-5
