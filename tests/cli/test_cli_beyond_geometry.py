"""The beyond-geometry workflow on the command line: design with payloads, measure, identify gains and
compliance, compensate a program under the task's payload."""

from __future__ import annotations

import json

import numpy as np

import pincal

ROBOT = ["kr270", "--marker", "0.1,0.05,0.2"]
PARAMS = (
    "lengths,offsets,gains,joint_a2.compliance,joint_a3.compliance,joint_a4.compliance,joint_a5.compliance"
)


def test_design_measure_identify_compensate(cli, tmp_path):
    plan, meas, cal = tmp_path / "plan.csv", tmp_path / "meas.csv", tmp_path / "cal.urdf"
    design = cli.json(
        "design", *ROBOT, "-m", 24, "--test-pose=0,-60,60,0,45,0", "--deg", "--params", PARAMS,
        "--payloads", "0,135,270", "--task-payload", 270, "--payload-centre", "0,0,0.25",
        "--pool-size", 200, "--starts", 2, "--out", plan,
    )  # fmt: skip
    split = design["rho0_split"]
    assert abs(split["total"] - design["rho0"] ** 2) < 1e-6 * split["total"]
    header = plan.read_text().splitlines()[0]
    assert header.endswith("payload_kg,payload_x,payload_y,payload_z")
    # The accuracy report is under the task's payload: its test-pose row is the design's rho0.
    assert abs(design["accuracy"]["plans"][0]["rows"][0]["rms"] - design["rho0"]) < 1e-9 * design["rho0"]
    # evaluate reads the plan's payloads and takes the task's: the design's numbers again.
    evaluated = cli.json(
        "evaluate", *ROBOT, "--plan", plan, "--test-pose=0,-60,60,0,45,0", "--deg", "--params", PARAMS,
        "--task-payload", 270, "--payload-centre", "0,0,0.25", "--no-accuracy",
    )  # fmt: skip
    assert abs(evaluated["rho0"] - design["rho0"]) < 1e-9 * design["rho0"]
    assert abs(evaluated["rho0_split"]["elastic"] - split["elastic"]) < 1e-9 * split["total"]
    bare = cli.json(
        "evaluate", *ROBOT, "--plan", plan, "--test-pose=0,-60,60,0,45,0", "--deg", "--params", PARAMS,
        "--no-accuracy",
    )  # fmt: skip
    assert bare["rho0"] != evaluated["rho0"] and bare["task_payload"] is None
    code, _, err = cli.run("design", *ROBOT, "-m", 24, "--test-pose=0,-60,60,0,45,0", "--deg", "--params",
                           PARAMS, "--payloads", "0,135", "--baseline", 10)  # fmt: skip
    assert code == 2 and "--baseline (random plans carry no payloads)" in err
    code, out, err = cli.run(
        "measure-sim", *ROBOT, "--plan", plan, "--deg", "--params", PARAMS, "--error-std", "5e-4,5e-4",
        "--sigma", 3e-5, "--seed", 3, "--out", meas,
    )  # fmt: skip
    assert code == 0, err
    assert "payload_kg" in meas.read_text().splitlines()[0]  # the data carry the payloads
    result = cli.json(
        "identify", *ROBOT, "--data", meas, "--deg", "--params", PARAMS, "--sigma", 3e-5, "--out", cal
    )
    assert result["status"] == "converged"
    assert result["residual_rms_after"] < 2 * 3e-5 * np.sqrt(3)
    side = json.loads(cal.with_suffix(".calibration.json").read_text())
    assert set(side["joint_compliances"]) == set(pincal.load_robot("kr270").joint_names)
    program = tmp_path / "program.csv"
    program.write_text(
        "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6\n10,-60,70,20,40,-30\n-30,-80,100,-40,60,10\n"
    )
    summary = cli.json(
        "compensate", *ROBOT, "--calibration", cal, "--targets", program, "--deg", "--payload", 270,
        "--payload-centre", "0,0,0.25", "--out", tmp_path / "corrected.csv",
    )  # fmt: skip
    assert summary["not_reached"] == [] and summary["terms"]["compliance"]


def test_params_reports_compliance_separation(cli):
    code, out, _ = cli.run("params", *ROBOT, "--params", "lengths,offsets,compliance")
    assert code == 0
    assert "gravity applies no torque on this joint" in out and "compliance separation" in out
    assert "--payloads 0,50,100" in out  # how to see what a payload change buys, on the command line
    loaded = cli.json("params", *ROBOT, "--params", "lengths,offsets,compliance", "--payloads", "0,135,270")
    assert set(loaded["compliance_separation_with_payloads"]) == set(loaded["compliance_separation"])
    assert all(0 < v <= 1 for v in loaded["compliance_separation_with_payloads"].values())


def test_residual_model_from_identify_to_a_top_up_design(cli, tmp_path):
    plan, meas, cal = tmp_path / "plan.csv", tmp_path / "meas.csv", tmp_path / "cal.urdf"
    robot = pincal.load_robot("ur10", markers=[(0.03, -0.02, 0.1)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    truth = pincal.random_errors(params, seed=1)
    field = pincal.calibration.synthetic.SmoothField.random(robot, 3e-4, seed=2)
    data = pincal.simulate_measurements(
        truth, robot.random_configurations(60, 3), 1e-5, seed=4, unmodelled=field
    )
    data.to_csv(meas)
    result = cli.json(
        "identify", "ur10", "--marker", "0.03,-0.02,0.1", "--data", meas, "--residual-model", "gp",
        "--out", cal, "--holdout", 0.25, "--test-pose=0.3,-1.2,1.4,-1,-1.4,0.2",
    )  # fmt: skip
    assert result["residual_model"]["kind"] == "gp" and result["residual_model"]["configurations"] == 45
    # The predicted errors count the residual model's variance: held out and at the test pose.
    assert result["validation"]["residual_model"] and result["validation"]["expected_rms"] > 0
    calibrated = result["accuracy"]["plans"][0]
    test_pose = calibrated["rows"][0]["rms"]
    assert abs(
        calibrated["from_measurements"] ** 2 + calibrated["from_residual_model"] ** 2 - test_pose**2
    ) < (1e-9 * test_pose**2)
    assert result["expected_error"]["residual_model"] > 0
    side = json.loads(cal.with_suffix(".calibration.json").read_text())
    assert len(side["residual_model"]["inputs"]) == 45
    design = cli.json(
        "design", "ur10", "--marker", "0.03,-0.02,0.1", "-m", 12, "--test-pose=0.3,-1.2,1.4,-1,-1.4,0.2",
        "--residual-model", cal, "--pool-size", 150, "--starts", 2, "--out", plan,
    )  # fmt: skip
    assert design["criterion"] == "test-pose-gp" and design["value"] > 0
    # Its accuracy report is of the expected error with the residual model: the test-pose row is the
    # criterion's value, and evaluate gives the same from the plan file.
    assert abs(design["accuracy"]["plans"][0]["rows"][0]["rms"] - design["value"]) < 1e-9 * design["value"]
    assert design["accuracy"]["residual_model"]
    evaluated = cli.json(
        "evaluate", "ur10", "--marker", "0.03,-0.02,0.1", "--plan", plan,
        "--test-pose=0.3,-1.2,1.4,-1,-1.4,0.2", "--residual-model", cal, "--no-accuracy",
    )  # fmt: skip
    assert abs(evaluated["expected_error_with_residual_model"] - design["value"]) < 1e-9 * design["value"]
    assert evaluated["expected_error_with_residual_model"] > evaluated["rho0"]
    code, out, _ = cli.run(
        "design", "ur10", "-m", 12, "--test-pose=0.3,-1.2,1.4,-1,-1.4,0.2", "--residual-model", meas
    )
    assert code == 2


def test_identify_reports_the_predicted_error_at_the_test_pose(cli, tmp_path):
    meas = tmp_path / "meas.csv"
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=1), robot.random_configurations(30, 2), 3e-5, seed=3
    )
    data.to_csv(meas)
    code, out, err = cli.run(
        "identify", *ROBOT, "--data", meas, "--params", "lengths,offsets", "--sigma", 3e-5,
        "--test-pose=0,-1.05,1.05,0,0.8,0", "--kfold", 3,
    )  # fmt: skip
    assert code == 0, err
    assert "predicted RMS after" in out and "calibrated" in out
    assert "standard errors alone (no residual model" in out
    code, _, err = cli.run("identify", *ROBOT, "--data", meas, "--task-payload", 100)
    assert code == 2 and "--task-payload" in err


def test_show_takes_the_task_payload_as_evaluate_does(cli, tmp_path):
    """The scene's ρ0 (trace of its error ellipsoid) under --task-payload, of a plan measured under
    its payload columns, is evaluate's ρ0 at each test pose; without it, evaluate's without."""
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    qs = robot.random_configurations(24, 5)
    plan = tmp_path / "plan.csv"
    pincal.Plan.for_robot(robot, qs, [0.0, 135.0, 270.0] * 8).to_csv(plan, degrees=True)
    poses = ["--test-pose=0,-60,60,0,45,0", "--test-pose=20,-80,90,10,30,0"]
    common = [*ROBOT, "--plan", plan, "--deg", *poses, "--params", PARAMS, "--no-accuracy"]
    load = ["--task-payload", 270, "--payload-centre", "0,0,0.25"]
    evaluated = cli.json("evaluate", *common, *load)["rho0_per_test_pose"]
    shown = cli.json("show", *common, *load, "--html", tmp_path / "scene.html")
    np.testing.assert_allclose(shown["rho0"], evaluated, rtol=1e-9)
    assert shown["task_payload"] == [270.0, 0.0, 0.0, 0.25]
    bare = cli.json("show", *common, "--html", tmp_path / "bare.html")
    np.testing.assert_allclose(bare["rho0"], cli.json("evaluate", *common)["rho0_per_test_pose"], rtol=1e-9)
    assert bare["task_payload"] is None and not np.allclose(bare["rho0"], shown["rho0"], rtol=1e-3)
    code, out, _ = cli.run("show", *common, *load, "--html", tmp_path / "scene.html")
    assert code == 0 and "under the task's payload: 270 kg at (0, 0, 0.25) m" in out
    cli.fails("show", *common, *load, "--plot", tmp_path / "r.png", match="--plot with --task-payload")
    cli.fails(
        "show",
        *common,
        "--payload-centre",
        "0,0,0.25",
        "--html",
        tmp_path / "s.html",
        match="--payload-centre",
    )
