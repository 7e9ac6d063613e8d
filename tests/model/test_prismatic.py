"""A robot with a prismatic joint (the shipped rail_arm: a 3-axis arm on a 1.5 m rail) through
params, design, simulate, identify, export and show, in the API and the CLI; degrees apply to the
revolute joints only (the rail stays in metres, in files too)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import pincal

SIGMA = 3e-5
Q0 = [0.8, 0.3, 0.4, -0.6]  # rail [m], waist, shoulder, elbow [rad]
PARAMS = "full,offsets"
# The identifiable set of PARAMS (pincal params rail_arm); the CLI asks for one.
BASE = (
    "rail.ty,rail.tz,rail.rx,rail.ry,rail.rz,rail.offset,waist.ry,waist.offset,shoulder.tx,shoulder.ty,"
    "shoulder.rx,shoulder.offset,elbow.tz,elbow.rx,elbow.rz,elbow.offset,tool0.tx"
)


@pytest.fixture(scope="module")
def rail():
    return pincal.load_robot("rail_arm")


def test_the_rail_is_prismatic_and_the_geometry_is_the_urdf_s(rail):
    assert rail.joint_names == ("rail", "waist", "shoulder", "elbow")
    assert rail.revolute.tolist() == [False, True, True, True]
    # Closed form: rail along x, waist about z, shoulder and elbow about y (URDF origins in metres).
    s, w, e = 0.4, 0.3, -0.6
    reach = 0.05 + 0.55 * math.sin(s) + 0.45 * math.cos(s + e) + 0.03 * math.sin(s + e)
    expected = [
        0.8 + reach * math.cos(w),
        reach * math.sin(w),
        0.6 + 0.55 * math.cos(s) - 0.45 * math.sin(s + e) + 0.03 * math.cos(s + e),
    ]
    np.testing.assert_allclose(rail.points(Q0)[0, 0], expected, atol=1e-12)
    offsets = {p.name: p.unit for p in rail.parameters("offsets").parameters}
    assert offsets == {
        "rail.offset": "m",
        "waist.offset": "rad",
        "shoulder.offset": "rad",
        "elbow.offset": "rad",
    }


def test_degrees_convert_the_revolute_columns_only(rail, tmp_path):
    q = np.array([[0.5, 0.1, 0.2, -0.3], [1.2, -1.0, 0.5, 1.0]])
    plan = pincal.Plan.for_robot(rail, q)
    plan.to_csv(tmp_path / "p.csv", degrees=True)
    rows = np.loadtxt(tmp_path / "p.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(rows[:, 0], q[:, 0])  # the rail in metres (was 28.6479 for 0.5 m)
    np.testing.assert_allclose(rows[:, 1:], np.degrees(q[:, 1:]), rtol=1e-15)
    back = pincal.Plan.from_csv(tmp_path / "p.csv", robot=rail, degrees=True)
    np.testing.assert_allclose(back.q, q, rtol=0, atol=1e-15)
    # A plan that does not know its joints cannot guess: it says so instead of converting metres.
    with pytest.raises(pincal.errors.BadArgument, match="which joints are revolute"):
        pincal.Plan(q, rail.joint_names).to_csv_text(degrees=True)
    with pytest.raises(pincal.errors.BadArgument, match="needs the robot"):
        pincal.Plan.from_csv(tmp_path / "p.csv", degrees=True)
    assert pincal.Plan(q, rail.joint_names).to_csv_text(degrees=True, robot=rail) == plan.to_csv_text(
        degrees=True
    )


def test_limits_are_reported_in_the_joint_s_unit(rail, tmp_path):
    with pytest.raises(
        pincal.errors.BadConfiguration, match=r"joint rail = 1.7 is outside its limits \[0, 1.5\] \(metres\)"
    ):
        rail.configurations([1.7, 0, 0, 0])
    path = tmp_path / "p.csv"
    path.write_text("rail,waist,shoulder,elbow\n0.5,10,20,200\n")
    with pytest.raises(
        pincal.errors.BadConfiguration,
        match=r"joint elbow = 200 is outside its limits \[-137.51, 137.51\] \(degrees\)",
    ) as caught:
        pincal.Plan.from_csv(path, robot=rail, degrees=True)
    assert caught.value.joint == "elbow" and caught.value.line is None


def test_design_simulate_identify_export_recover_the_true_robot(rail, tmp_path):
    params = rail.parameters(PARAMS).identifiable().identifiable
    result = pincal.design(
        params, 10, test_pose=Q0, sigma=SIGMA, search=pincal.Search(starts=4, workers=1, pool=400, seed=1)
    )
    assert result.plan.revolute == (False, True, True, True)
    assert result.rho0 == pytest.approx(pincal.rho0(params, result.plan, Q0, sigma=SIGMA), rel=1e-12)
    truth = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=3)
    data = pincal.simulate_measurements(truth.robot, result.plan, 1e-7, seed=4)
    fit = pincal.identify(params, data)
    assert fit.success, fit.message
    np.testing.assert_allclose(fit.values, truth.values, atol=1e-5)  # the known errors, recovered
    out = pincal.export_urdf(fit, tmp_path / "rail_calibrated.urdf")
    calibrated = pincal.load_robot(out)
    assert calibrated.revolute.tolist() == [False, True, True, True]
    check = rail.random_configurations(50, 5)
    assert np.abs(calibrated.points(check) - truth.robot.points(check)).max() < 1e-5
    page = tmp_path / "scene.html"
    built = pincal.scene(params, result.plan, Q0, sigma=SIGMA)
    built.save_html(page)
    assert page.stat().st_size > 1000
    np.testing.assert_array_equal(built.plan, result.plan.q)
    assert built.rho0[0] == pytest.approx(result.rho0, rel=1e-9)


def test_cli_params_design_measure_identify_show(tmp_path, cli):
    params = cli.json("params", "rail_arm", "--params", PARAMS)
    assert "rail.offset" in json.dumps(params)
    assert (
        ",".join(pincal.load_robot("rail_arm").parameters(PARAMS).identifiable().identifiable.names) == BASE
    )
    plan = tmp_path / "plan.csv"
    test_pose = "--test-pose=0.8,17.19,22.92,-34.38"  # the rail in metres, the angles in degrees
    cli.json("design", "rail_arm", "-m", "10", test_pose, "--deg", "--params", BASE, "--sigma", "3e-5",
             "--starts", "4", "--workers", "1", "--pool-size", "400", "--out", plan)  # fmt: skip
    rows = np.loadtxt(plan, delimiter=",", skiprows=1)
    assert rows[:, 0].min() >= 0 and rows[:, 0].max() <= 1.5  # metres, within the rail
    assert np.abs(rows[:, 1:]).max() > 2 * math.pi  # degrees
    meas, urdf = tmp_path / "meas.csv", tmp_path / "rail_calibrated.urdf"
    code, _, _ = cli.run("measure-sim", "rail_arm", "--plan", plan, "--deg", "--error-std", "1e-3,1e-3",
                         "--sigma", "1e-7", "--out", meas)  # fmt: skip
    assert code == 0
    written = np.loadtxt(meas, delimiter=",", skiprows=1)
    np.testing.assert_allclose(written[:, :4], rows, atol=1e-9)  # the rail in metres, angles in degrees
    identified = cli.json("identify", "rail_arm", "--data", meas, "--deg", "--params", BASE, "--out", urdf)
    assert identified["status"] == "converged"
    assert pincal.load_robot(urdf).revolute.tolist() == [False, True, True, True]
    cli.json("show", "rail_arm", "--plan", plan, "--deg", test_pose, "--params", BASE, "--html",
             tmp_path / "plan.html")  # fmt: skip
    assert (tmp_path / "plan.html").stat().st_size > 1000


def test_a_long_track_is_drawn_over_its_whole_length(tmp_path):
    """Random configurations, and a design's candidate pool, cover a prismatic joint's whole range
    however long (a 10 m track from -4 m to 6 m), while a revolute joint is drawn within one turn."""
    from tests.conftest import ROOT

    text = (ROOT / "robots" / "rail_arm.urdf").read_text(encoding="utf-8")
    long_track = text.replace('<limit lower="0.0" upper="1.5"', '<limit lower="-4.0" upper="6.0"')
    assert long_track != text
    (tmp_path / "long_track.urdf").write_text(long_track, encoding="utf-8")
    robot = pincal.load_robot(tmp_path / "long_track.urdf")
    lower, upper = robot.sampled_range()
    assert (lower[0], upper[0]) == (-4.0, 6.0)
    np.testing.assert_array_equal(lower[1:], np.maximum(robot.lower[1:], -np.pi))
    q = robot.random_configurations(4000, 0)
    assert q[:, 0].min() < -3.8 and q[:, 0].max() > 5.8  # was cut at ±π m
    assert np.all(q >= robot.lower) and np.all(q <= robot.upper)
    pool = pincal.planning.feasibility.Feasibility(robot).sample(2000, np.random.default_rng(1))
    assert pool[:, 0].min() < -3.5 and pool[:, 0].max() > 5.5
