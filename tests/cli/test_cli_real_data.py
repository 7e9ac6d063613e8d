"""The identify CLI on real-like tracker data (issue 10) and the composable result (item 8).

Oracles: the true robot and bases of simulated files, the rows corrupted on purpose, plain
Pinocchio forward kinematics on the exported URDF + sidecar. Budget: about 15 s.
"""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal import MeasurementData, identify, random_errors, simulate_measurements

MARKER = ["--marker", "0.1,0.05,0.2"]
SIGMA = 3e-5


@pytest.fixture(scope="module")
def robot(kr270_marker):
    return kr270_marker


@pytest.fixture(scope="module")
def truth(robot):
    return random_errors(robot.parameters("full,offsets").identifiable().identifiable, seed=4)


@pytest.fixture
def meas(tmp_path, robot, truth):
    """40 configurations; row 7 (line 9) carries a 22 mm gross error."""
    data = simulate_measurements(truth.robot, robot.random_configurations(40, 3), SIGMA, seed=2)
    points = np.array(data.points)
    points[7] += [0.0, 0.022, 0.0]
    path = tmp_path / "meas.csv"
    MeasurementData(data.q, points, data.joint_names).to_csv(path)
    return path


def test_reject_lists_the_row_and_holdout_reports_before_after(tmp_path, cli, meas):
    code, out, _ = cli.run(
        "identify",
        "kr270",
        "--data",
        meas,
        *MARKER,
        "--reject",
        5,
        "--holdout",
        0.25,
        "--seed",
        2,
        "--json",
    )
    result = json.loads(out)
    assert code == 0 and result["status"] == "converged"
    validation = result["validation"]
    after = sorted(validation["errors_after"])
    assert validation["n_points"] == 10 and len(validation["errors_before"]) == 10
    assert after[-2] < 5 * SIGMA * np.sqrt(3) < validation["before"]["rms"]  # all but the gross error
    assert 0 < result["conditioning"] < 1 and result["identifiability"]["rank"] == 27
    code, out, _ = cli.run("identify", "kr270", "--data", meas, *MARKER, "--reject", 5)
    assert code == 0 and "rejected 1 row(s)" in out and "line 9: 22" in out
    assert "conditioning" in out and "weakest" in out


def test_mm_file_without_mm_is_implausible_and_force_writes(tmp_path, cli, robot, truth):
    data = simulate_measurements(truth.robot, robot.random_configurations(30, 5), SIGMA, seed=1)
    path = tmp_path / "mm.csv"
    data.to_csv(path, millimetres=True)
    out_urdf = tmp_path / "cal.urdf"
    code, out, err = cli.run("identify", "kr270", "--data", path, *MARKER, "--out", out_urdf, "--json")
    assert code == 2 and json.loads(out)["status"] == "implausible" and "--mm" in json.loads(out)["causes"][0]
    assert len(err.strip().splitlines()) == 1 and err.startswith("pincal: error: likely cause: units:")
    assert len(err.split(" — ")[0]) < 200  # the cause first, not after the symptoms (issue 29)
    assert not out_urdf.exists()
    # the one-line refusal names the likely cause, without --json or --force (issue 21)
    code, out, err = cli.run("identify", "kr270", "--data", path, *MARKER, "--out", out_urdf)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "likely cause: units" in err and "millimetres read as metres? try --mm" in err
    assert not out_urdf.exists()
    code, out, err = cli.run("identify", "kr270", "--data", path, *MARKER, "--out", out_urdf, "--force")
    assert code == 0 and out_urdf.exists() and "written because of --force" in err
    code, out, _ = cli.run("identify", "kr270", "--data", path, *MARKER, "--mm", "--kfold", 3)
    assert code == 0 and "converged" in out and "3-fold" in out


def test_a_forgotten_marker_is_named_in_the_refusal(tmp_path, cli, robot, truth):
    path = tmp_path / "tracker.csv"
    simulate_measurements(truth.robot, robot.random_configurations(30, 5), SIGMA, seed=1).to_csv(path)
    code, out, err = cli.run("identify", "kr270", "--data", path)  # no --marker
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith("pincal: error: likely cause: marker") and "did you pass --marker X,Y,Z" in err
    assert "no real robot has this: the tool frame tool0 moves by" in err


def test_a_holdout_too_small_to_fit_is_warned_about(tmp_path, cli, robot, truth):
    """Issue 21: a 12-configuration plan held out by 20 % fits 10 configurations, 30 coordinates
    for 27 parameters: the held-out error overstates the calibration's, and the user is told so."""
    path = tmp_path / "twelve.csv"
    simulate_measurements(truth.robot, robot.random_configurations(12, 5), SIGMA, seed=1).to_csv(path)
    code, out, err = cli.run("identify", "kr270", "--data", path, *MARKER, "--holdout", 0.2)
    assert code == 0 and "validation on 2 held-out point(s)" in out
    (line,) = err.strip().splitlines()
    assert line.startswith("pincal: warning: holdout 0.2: the fit on 10 of 12 configurations has 30 measured")
    assert "for 27 parameters, fewer than twice as many (54)" in line
    # 22 configurations, 20 % (4) held out: the 18 left give 54 coordinates, twice 27
    assert "measure at least 22 configurations for this holdout" in line and "--validate" in line
    code, out, err = cli.run("identify", "kr270", "--data", path, *MARKER, "--holdout", 0.2, "--json")
    assert code == 0 and json.loads(out)["validation"]["n_points"] == 2 and "pincal: warning: holdout" in err


def test_two_placements_and_the_validation_plot(tmp_path, cli, robot):
    pytest.importorskip("matplotlib")
    params = robot.parameters("full,offsets,base").identifiable(prefer="base").identifiable
    truth = random_errors(params, seed=2)
    bases = [
        pin.SE3(pin.rpy.rpyToMatrix(0.05, -0.1, 2.0), np.array([-2.5, 1.0, 0.2])),
        pin.SE3(pin.rpy.rpyToMatrix(-0.1, 0.05, -1.0), np.array([1.5, 3.0, -0.4])),
    ]
    files = []
    for i, base in enumerate(bases):
        data = simulate_measurements(
            truth.robot.replace(base=base), robot.random_configurations(20, i), SIGMA, seed=i
        )
        files.append(tmp_path / f"s{i}.csv")
        data.to_csv(files[-1])
    other = tmp_path / "other.csv"
    simulate_measurements(
        truth.robot.replace(base=bases[0]), robot.random_configurations(15, 9), SIGMA, seed=9
    ).to_csv(other)
    plot = tmp_path / "v.png"
    argv = ["identify", "kr270", "--data", files[0], "--data", files[1], "--base", *MARKER]
    code, out, _ = cli.run(*argv, "--validate", other, "--plot", plot, "--json")
    result = json.loads(out)
    assert code == 0 and result["status"] == "converged" and len(result["bases"]) == 2
    for found, base in zip(result["bases"], bases, strict=True):
        np.testing.assert_allclose(found["xyz"], base.translation, atol=2e-4)
    assert result["validation"]["after"]["rms"] < 5 * SIGMA * np.sqrt(3)
    assert plot.stat().st_size > 1000


def test_params_and_evaluate_check_the_users_configurations(tmp_path, cli, robot, meas):
    code, out, _ = cli.run("params", "kr270", *MARKER, "--data", meas, "--json")
    check = json.loads(out)["data_check"]
    assert code == 0 and check["rank"] == 27 and 0 < check["conditioning"] < 1 and check["m"] == 40
    plan = tmp_path / "same.csv"
    pincal.Plan.for_robot(robot, np.tile(robot.random_configurations(1, 0), (12, 1))).to_csv(plan)
    code, out, _ = cli.run("params", "kr270", *MARKER, "--plan", plan)
    assert code == 0 and "conditioning 0 (singular)" in out and "cannot identify" in out
    pincal.Plan.for_robot(robot, robot.random_configurations(15, 4)).to_csv(plan)
    code, out, _ = cli.run("evaluate", "kr270", "--plan", plan, "--test-pose=0,-1.5,1.5,0,0.5,0", *MARKER)
    assert code == 0 and "data identifiability (15 configurations" in out


# --------------------------------------------------------------------- the composable result
def test_to_model_and_the_sidecar_predict_instrument_coordinates(tmp_path, robot):
    params = robot.parameters("full,offsets,base").identifiable(prefer="base").identifiable
    truth = random_errors(params, seed=6)
    base = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 2.5), np.array([-2.5, 1.0, 0.2]))
    real = truth.robot.replace(base=base)
    result = identify(params, simulate_measurements(real, robot.random_configurations(40, 1), 0.0))
    assert result.success and np.any(result.robot.joint_offsets != 0)
    qs = robot.random_configurations(10, 7)
    expected = real.points(qs)[:, 0]

    model = result.robot.to_model()  # plain Pinocchio: offsets folded, no offset table
    data = model.createData()
    tip = model.getFrameId(robot.tip)
    for q, p in zip(qs, expected, strict=True):
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(result.robot.base * data.oMf[tip] * result.robot.markers[0], p, atol=1e-9)

    out = pincal.export_urdf(result, tmp_path / "cal.urdf")
    side = json.loads((tmp_path / "cal.calibration.json").read_text())
    assert side["condition_number"] == pytest.approx(result.condition_number) and side["sigma"] > 0
    urdf_model = pin.buildModelFromUrdf(str(out))
    urdf_data = urdf_model.createData()
    frame = urdf_model.getFrameId(side["tip"])
    base_read = pin.SE3(np.array(side["base"]["matrix"]))
    for q, p in zip(qs, expected, strict=True):
        pin.framesForwardKinematics(urdf_model, urdf_data, q)
        predicted = base_read * urdf_data.oMf[frame] * np.array(side["markers"][0])
        np.testing.assert_allclose(predicted, p, atol=1e-9)
