"""--around, --test-path, --test-box, --prior and the accuracy report on the command line (issue 9).
Budget: about 10 s."""

from __future__ import annotations

import numpy as np
import pytest

import pincal

PLANAR = ["planar_2r", "--params", "joint2.tx,tip.tx", "--workers", "1", "--starts", "2"]
SIGMA = 3e-5


@pytest.fixture(scope="module")
def planar_params():
    return pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")


def test_design_for_a_path_reports_its_mean_and_the_d_optimal_plan(cli, tmp_path, planar_params):
    path = tmp_path / "path.csv"
    poses = np.column_stack([np.linspace(-1, 1, 500), np.linspace(0.3, 1.4, 500)])
    pincal.Plan(poses, ("joint1", "joint2")).to_csv(path)
    data = cli.json("design", *PLANAR, "-m", "3", "--test-path", str(path), "--sigma", str(SIGMA))
    plan = np.array(data["plan"])
    expected = pincal.rho0(planar_params, plan, pincal.TestPath(poses), sigma=SIGMA)
    assert data["rho0"] == pytest.approx(expected, rel=1e-12)
    plans = data["accuracy"]["plans"]
    assert [p["name"] for p in plans] == ["plan", "D-optimal"]
    assert plans[0]["rows"][0]["rms"] == pytest.approx(expected, rel=1e-12)
    rows = ["test region", "region ±10°", "region ±20°", "workspace"]
    assert [r["where"] for r in plans[0]["rows"]] == rows
    # The D-optimal plan of the planar arm has Σ cos q2 = 0: ρ0² = 2σ²/m everywhere (docs/method.md §9.3).
    assert plans[1]["rows"][3]["median"] == pytest.approx(np.sqrt(2 * SIGMA**2 / 3), rel=1e-6)


def test_evaluate_with_a_prior_and_a_neighbourhood(cli, tmp_path, planar_params):
    plan_csv = tmp_path / "plan.csv"
    plan = np.array([[0.1, 0.0]])  # arm stretched: Δl1 and Δl2 move the tip alike, singular without a prior
    pincal.Plan(plan, ("joint1", "joint2")).to_csv(plan_csv)
    argv = ["evaluate", *PLANAR[:3], "--plan", str(plan_csv), "--test-pose=0.2,1.0", "--sigma", str(SIGMA)]
    cli.fails(*argv, match="singular plan")
    png = tmp_path / "accuracy.png"
    data = cli.json(*argv, "--prior", "1mm,1mrad", "--around", "5deg", "--accuracy-plot", str(png))
    prior = pincal.Prior(1e-3, 1e-3)
    region = pincal.around([0.2, 1.0], np.radians(5))
    assert data["rho0"] == pytest.approx(
        pincal.rho0(planar_params, plan, region, sigma=SIGMA, prior=prior), rel=1e-12
    )
    assert data["criteria"] is None and png.stat().st_size > 0
    here = data["accuracy"]["plans"][0]
    assert here["from_measurements"] ** 2 + here["from_prior"] ** 2 == pytest.approx(
        data["rho0"] ** 2, rel=1e-9
    )
    assert here["worst_found"]["rho"] >= max(data["rho0_per_test_pose"]) * (1 - 1e-12)


@pytest.mark.parametrize(
    "extra, match",
    [
        (["--test-pose=0.2,1.0", "--around", "-5deg"], "--around '-5deg'"),
        (["--test-pose=0.2,1.0", "--around", "5furlongs"], "unknown unit 'furlongs'"),
        (["--test-pose=0.2,1.0", "--prior", "1kg,1mrad"], "unknown unit"),
        (["--test-pose=0.2,1.0", "--test-box", "1,2,3,4,5"], "six numbers"),
        (["--around", "5deg"], "need a --test-pose"),
        ([], "give a test pose"),
    ],
)
def test_bad_region_input_is_one_line(cli, tmp_path, extra, match):
    plan_csv = tmp_path / "plan.csv"
    pincal.Plan(np.array([[0.1, 0.4], [0.3, -1.0]]), ("joint1", "joint2")).to_csv(plan_csv)
    cli.fails("evaluate", *PLANAR[:3], "--plan", str(plan_csv), *extra, match=match)


def test_scene_colours_sampled_poses_by_predicted_error(cli, tmp_path, planar_params):
    from pincal.viewing.drawing import error_colors

    plan = np.array([[0.1, 0.4], [0.3, -1.0], [1.0, 2.0]])
    samples = np.array([[0.0, 0.2], [0.5, 1.0], [-1.0, 3.0]])
    built = pincal.scene(planar_params, plan, [0.2, 1.0], sigma=SIGMA, error_samples=samples)
    expected = [pincal.rho0(planar_params, plan, q, sigma=SIGMA) for q in samples]  # each as a test pose
    np.testing.assert_allclose(built.error_values, expected, rtol=1e-12)
    rgb = error_colors(built.error_values)
    lo, hi = np.argmin(built.error_values), np.argmax(built.error_values)
    assert rgb[lo][1] > rgb[lo][0] and rgb[hi][0] > rgb[hi][1]  # green at the smallest, red at the largest
    plan_csv, html = tmp_path / "plan.csv", tmp_path / "scene.html"
    pincal.Plan(plan, ("joint1", "joint2")).to_csv(plan_csv)
    data = cli.json(
        "show",
        *PLANAR[:3],
        "--plan",
        str(plan_csv),
        "--test-pose=0.2,1.0",
        "--sigma",
        str(SIGMA),
        "--error-cloud",
        "50",
        "--html",
        str(html),
    )
    assert data["error_cloud"]["n"] == 50 and html.stat().st_size > 0
    assert data["accuracy"]["plans"][0]["rows"][0]["rms"] == pytest.approx(
        pincal.rho0(planar_params, plan, [0.2, 1.0], sigma=SIGMA), rel=1e-12
    )


def test_evaluate_over_a_cartesian_box(cli, tmp_path):
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    p0 = robot.points(q0)[0, 0]
    plan = robot.random_configurations(10, 3)
    plan_csv = tmp_path / "plan.csv"
    pincal.Plan.for_robot(robot, plan).to_csv(plan_csv, degrees=True)  # --deg: the plan file too
    box = ",".join(f"{v:.6f}" for v in np.concatenate([p0 - 0.05, p0 + 0.05]))
    data = cli.json(
        "evaluate",
        "kr270",
        "--marker",
        "0.1,0.05,0.2",
        "--params",
        "lengths,offsets",
        "--plan",
        str(plan_csv),
        "--test-pose=0,-60,60,0,45,0",
        "--deg",
        "--test-box",
        box,
        "--sigma",
        str(SIGMA),
        "--no-accuracy",
    )
    corners = np.array(box.split(","), dtype=float)  # the box as the command reads it
    region = pincal.cartesian_box(corners[:3], corners[3:], reference=q0).resolve(robot)
    points = robot.points(region.poses)[:, 0]
    assert np.all(np.abs(points - p0) <= 0.05 + 1e-6)  # forward kinematics: every pose is in the box
    read = pincal.Plan.from_csv(plan_csv, robot, degrees=True)  # as the command reads it (rounded)
    expected = pincal.rho0(params, read, pincal.TestPath(region.poses), sigma=SIGMA)
    assert data["rho0"] == pytest.approx(expected, rel=1e-9) and len(data["rho0_per_test_pose"]) == len(
        points
    )
