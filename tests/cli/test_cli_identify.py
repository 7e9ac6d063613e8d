"""The CLI of the calibration loop: pincal measure-sim, identify, simulate."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.cli import main

MARKER = ["--marker", "0.1,0.05,0.2"]


@pytest.fixture
def plan_csv(tmp_path, kr270_marker):
    path = tmp_path / "plan.csv"
    pincal.Plan.for_robot(kr270_marker, kr270_marker.random_configurations(30, 1)).to_csv(path)
    return path


def test_rehearsal_measure_sim_then_identify(tmp_path, cli, kr270_marker):
    meas, true_urdf, cal = tmp_path / "meas.csv", tmp_path / "true.urdf", tmp_path / "cal.urdf"
    plan_deg = tmp_path / "plan_deg.csv"
    pincal.Plan.for_robot(kr270_marker, kr270_marker.random_configurations(30, 1)).to_csv(
        plan_deg, degrees=True
    )
    code, out, _ = cli.run(
        "measure-sim",
        "kr270",
        "--plan",
        plan_deg,
        "--error-std",
        "1e-3,1e-3",
        "--save-true",
        true_urdf,
        "--sigma",
        "1e-7",
        "--out",
        meas,
        "--mm",
        "--deg",
        "--seed",
        3,
        *MARKER,
    )
    assert code == 0 and "30 configurations" in out
    header = meas.read_text().splitlines()[0]
    assert header == "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z"
    code, out, _ = cli.run(
        "identify", "kr270", "--data", meas, "--mm", "--deg", "--out", cal, "--json", *MARKER
    )
    assert code == 0
    result = json.loads(out)
    assert result["status"] == "converged" and result["iterations"] >= 1 and result["out"] == str(cal)
    assert result["residual_rms_before"] > 1e-3 > 1e-6 > result["residual_rms_after"]
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    truth = pincal.random_errors(
        params, error_std={"length": 1e-3, "angle": 1e-3}, seed=np.random.default_rng(3)
    )
    assert list(result["params"]) == list(params.names)
    for name, value in truth.as_dict().items():
        assert result["params"][name]["value"] == pytest.approx(value, abs=2e-5)
        assert 0 < result["params"][name]["std"] < 1e-5
    # The calibrated URDF and the true URDF agree to the noise level.
    calibrated = pincal.load_robot(cal, markers=[(0.1, 0.05, 0.2)])
    true = pincal.load_robot(true_urdf, markers=[(0.1, 0.05, 0.2)])
    q = kr270_marker.random_configurations(20, 9)
    assert np.abs(calibrated.points(q) - true.points(q)).max() < 1e-5
    code, out, _ = cli.run("identify", "kr270", "--data", meas, "--mm", "--deg", *MARKER)
    assert code == 0 and "converged" in out and "joint_a2.offset" in out and "mrad" in out


def test_instrument_frame_data_with_base(tmp_path, cli, plan_csv):
    meas = tmp_path / "tracker.csv"
    code, _, _ = cli.run(
        "measure-sim",
        "kr270",
        "--plan",
        plan_csv,
        "--true",
        pincal.shipped_robots()["kr270"],
        "--sigma",
        "0",
        "--out",
        meas,
        "--base-pose",
        "-2.5,1.0,0.2,0.1,-0.2,2.5",
        *MARKER,
    )
    assert code == 0
    code, out, _ = cli.run("identify", "kr270", "--data", meas, "--base", "--json", *MARKER)
    result = json.loads(out)
    assert code == 0 and result["status"] == "converged" and result["method"] == "trf"
    np.testing.assert_allclose(result["base"]["xyz"], [-2.5, 1.0, 0.2], atol=1e-9)
    np.testing.assert_allclose(result["base"]["rpy"], [0.1, -0.2, 2.5], atol=1e-9)
    assert "joint_a1.offset" in result["dropped_for_base"]
    rotation = pin.log3(pin.rpy.rpyToMatrix(0.1, -0.2, 2.5))  # base.r* compose as exp3, not rpy
    np.testing.assert_allclose(
        [result["params"][f"base.{c}"]["value"] for c in ("rx", "ry", "rz")], rotation, atol=1e-9
    )
    code, out, _ = cli.run("identify", "kr270", "--data", meas, "--params", "lengths,offsets,base", *MARKER)
    assert code == 0 and "base.rz" in out and "robot base in the instrument frame" in out


def test_simulate_json(tmp_path, cli):
    robot = pincal.load_robot("planar_2r")
    plan = robot.random_configurations(6, 2)
    pincal.Plan.for_robot(robot, plan).to_csv(tmp_path / "p.csv")
    code, out, _ = cli.run(
        "simulate",
        "planar_2r",
        "--plan",
        tmp_path / "p.csv",
        "--test-pose",
        "0.3,1.2",
        "--params",
        "joint2.tx,tip.tx",
        "--trials",
        100,
        "--sigma",
        "1e-4",
        "--error-std",
        "1e-3,0",
        "--json",
    )
    assert code == 0
    result = json.loads(out)
    params = robot.parameters("joint2.tx,tip.tx")
    assert result["rho0_predicted"] == pytest.approx(pincal.rho0(params, plan, [0.3, 1.2], sigma=1e-4))
    assert result["trials"] == 100 and set(result["quantiles"]) == {"0.5", "0.9", "0.95", "0.99"}
    assert abs(result["rho0_empirical"] - result["rho0_predicted"]) < 3 * result["rho0_empirical_se"]
    code, out, _ = cli.run(
        "simulate",
        "planar_2r",
        "--plan",
        tmp_path / "p.csv",
        "--test-pose",
        "0.3,1.2",
        "--trials",
        20,
    )
    assert code == 0 and "rho0 predicted" in out and "rho0 empirical" in out


def test_simulate_compare_is_in_the_report(tmp_path, cli):
    """Issue 21: --compare without --plot was ignored. The compared plans are simulated with the
    same trials and seed and reported beside the plan, in text and JSON."""
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("joint2.tx,tip.tx")
    plans = {"designed": robot.random_configurations(6, 2), "random": robot.random_configurations(4, 5)}
    for name, plan in plans.items():
        pincal.Plan.for_robot(robot, plan).to_csv(tmp_path / f"{name}.csv")
    argv = ["simulate", "planar_2r", "--plan", tmp_path / "designed.csv", "--test-pose", "0.3,1.2",
            "--params", "joint2.tx,tip.tx", "--trials", 30, "--sigma", "1e-4",
            "--compare", tmp_path / "random.csv"]  # fmt: skip
    result = cli.json(*argv)
    assert [c["plan"] for c in result["compare"]] == [str(tmp_path / "random.csv")]
    compared = result["compare"][0]
    assert compared["m"] == 4 and compared["trials"] == 30
    predicted = pincal.rho0(params, plans["random"], [0.3, 1.2], sigma=1e-4)
    assert compared["rho0_predicted"] == pytest.approx(predicted, rel=1e-12)
    assert result["rho0_predicted"] == pytest.approx(
        pincal.rho0(params, plans["designed"], [0.3, 1.2], sigma=1e-4)
    )
    code, out, _ = cli.run(*argv)
    ratio = predicted / result["rho0_predicted"]
    assert code == 0 and "compared plans" in out
    assert f"{tmp_path / 'random.csv'}: 4 configurations, rho0 predicted {predicted * 1e3:.4g} mm" in out
    assert f"({ratio:.3g} times this plan's)" in out
    cli.fails(*argv[:-1], tmp_path / "none.csv", match="does not exist")


@pytest.mark.parametrize("command", ["identify", "simulate", "measure-sim"])
def test_help_has_examples(capsys, command):
    with pytest.raises(SystemExit) as exit_info:
        main([command, "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    assert "examples:" in text and f"pincal {command} kr270" in text


# ----------------------------------------------------------------------------- bad input
HEADER = "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n"


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "is empty"),
        (HEADER + "0,-1,0,0,0,0,1,2,x\n", "line 2: column z is 'x', not a number"),
        (HEADER + "0,-1,0,0,0,0,1,2\n", "line 2: 8 values, expected 9"),
        (HEADER + "0,-1,0,0,0,0,1,2,3\n0,-1,0,0,0,0,1,nan,3\n", "line 3: column y is nan"),
        (HEADER.replace("joint_a3", "a3") + "0,-1,0,0,0,0,1,2,3\n", "missing joint_a3; unknown column.s. a3"),
        (HEADER + "0,-1,0,0,0,0,1,2,3\n" * 8, "at least 9 configurations"),
        (HEADER + "0,1,0,0,0,0,1,2,3\n", "line 2: joint joint_a2 = 1 is outside its limits"),
    ],
)
def test_bad_measurement_files(tmp_path, cli, text, match):
    (tmp_path / "m.csv").write_text(text)
    assert re.search(match, cli.fails("identify", "kr270", "--data", tmp_path / "m.csv", *MARKER))


def test_identify_failures(tmp_path, cli, kr270_marker, plan_csv):
    meas = tmp_path / "meas.csv"
    cli.run(
        "measure-sim",
        "kr270",
        "--plan",
        plan_csv,
        "--error-std",
        "1e-2,1e-2",
        "--sigma",
        "3e-5",
        "--out",
        meas,
        *MARKER,
    )
    line = cli.fails("identify", "kr270", "--data", meas, "--max-iterations", 1, *MARKER)
    assert "no convergence" in line
    code, out, err = cli.run("identify", "kr270", "--data", meas, "--max-iterations", 1, "--json", *MARKER)
    assert code == 2 and json.loads(out)["status"] == "not_converged" and "no convergence" in err
    assert "unknown frame 'flange'" in cli.fails(
        "identify", "kr270", "--data", meas, "--tip", "flange", *MARKER
    )
    same = np.tile(kr270_marker.random_configurations(1, 0), (30, 1))
    pincal.simulate_measurements(kr270_marker, same, 0.0).to_csv(tmp_path / "same.csv")
    line = cli.fails("identify", "kr270", "--data", tmp_path / "same.csv", *MARKER)
    assert "1 distinct configuration" in line and "at least 9" in line
    line = cli.fails("identify", "kr270", "--data", meas, "--params", "full,offsets,joint_a1.rz", *MARKER)
    assert "joint_a1.rz cannot be identified" in line  # named one by one (a group is reduced)


def test_outputs_never_overwrite_inputs(tmp_path, cli, plan_csv):
    urdf = tmp_path / "kr270.urdf"
    shutil.copy(pincal.shipped_robots()["kr270"], urdf)
    original = urdf.read_text()
    meas = tmp_path / "meas.csv"
    cli.run(
        "measure-sim",
        urdf,
        "--plan",
        plan_csv,
        "--error-std",
        "1e-3,1e-3",
        "--sigma",
        "3e-5",
        "--out",
        meas,
        *MARKER,
    )
    assert "is the robot's URDF" in cli.fails("identify", urdf, "--data", meas, "--out", urdf, *MARKER)
    assert "is the input --data" in cli.fails("identify", urdf, "--data", meas, "--out", meas, *MARKER)
    line = cli.fails(
        "measure-sim", urdf, "--plan", plan_csv, "--true", urdf, "--sigma", "0", "--out", plan_csv
    )
    assert "is the input --plan" in line
    line = cli.fails("measure-sim", urdf, "--plan", plan_csv, "--true", urdf, "--sigma", "0", "--out", urdf)
    assert "is the robot's URDF" in line
    assert urdf.read_text() == original


def test_measure_sim_and_simulate_bad_input(tmp_path, cli, plan_csv):
    line = cli.fails(
        "measure-sim",
        "kr270",
        "--plan",
        plan_csv,
        "--true",
        pincal.shipped_robots()["planar_2r"],
        "--sigma",
        "0",
        "--out",
        tmp_path / "m.csv",
    )
    assert "unknown frame 'tool0'" in line  # the true URDF's chain does not hold the tip
    line = cli.fails(
        "measure-sim",
        "kr270",
        "--plan",
        plan_csv,
        "--error-std",
        "1e-3",
        "--sigma",
        "0",
        "--out",
        tmp_path / "m.csv",
    )
    assert "LEN,ANG" in line
    line = cli.fails(
        "measure-sim",
        "kr270",
        "--plan",
        plan_csv,
        "--true",
        "none.urdf",
        "--sigma",
        "0",
        "--out",
        tmp_path / "m.csv",
    )
    assert "does not exist" in line
    assert not (tmp_path / "m.csv").exists()
    line = cli.fails(
        "simulate", "kr270", "--plan", plan_csv, "--test-pose=0,-1,1,0,0,0", "--error-std", "a,b"
    )
    assert "--error-std" in line
    line = cli.fails("simulate", "kr270", "--plan", plan_csv, "--test-pose=0,-1,1,0,0,0", "--trials", 1)
    assert "--trials" in line
