"""pincal compensate: a calibration with gains and compliance, exported, then used on a program."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.compensation.calibration_file import load_calibration


@pytest.fixture(scope="module")
def calibration(tmp_path_factory, kr270_marker):
    """A true KR 270 (geometric errors, gains, compliances) and its calibration exported."""
    folder = tmp_path_factory.mktemp("compensate")
    robot = kr270_marker
    params = robot.parameters("lengths,offsets,gains,compliance").identifiable().identifiable
    rng = np.random.default_rng(5)
    values = np.array(
        [
            rng.normal(0, 5e-4)
            if p.kind in ("placement", "offset")
            else rng.normal(0, 3e-4)
            if p.kind == "gain"
            else 3e-7
            for p in params
        ]
    )
    true = params.apply(values)
    plan = robot.random_configurations(60, 6, margin=0.1)
    data = pincal.simulate_measurements(true, plan, sigma=1e-6, seed=7)
    result = pincal.identify(params, data, sigma=1e-6)
    assert result.success
    urdf = folder / "kr270_cal.urdf"
    pincal.export_urdf(result, urdf)
    return robot, true, result, urdf, folder


def test_the_sidecar_carries_gains_compliances_and_gravity(calibration):
    robot, true, result, urdf, _ = calibration
    side = json.loads(urdf.with_suffix(".calibration.json").read_text())
    assert set(side["joint_gains"]) == set(robot.joint_names)
    assert side["gravity"] == [0.0, 0.0, -9.81]
    deployed = load_calibration(urdf, robot)
    np.testing.assert_allclose(deployed.robot.joint_gains, result.robot.joint_gains, atol=1e-15)
    np.testing.assert_allclose(deployed.robot.joint_compliances, result.robot.joint_compliances, atol=1e-20)
    q = robot.random_configurations(5, 8)
    np.testing.assert_allclose(
        deployed.robot.points(q, payload=100.0), result.robot.points(q, payload=100.0), atol=1e-9
    )


def test_compensated_program_lands_on_the_true_robot(calibration, cli):
    robot, true, _, urdf, folder = calibration
    program = folder / "program.csv"
    q = np.radians([[10, -60, 70, 20, 40, -30], [-30, -80, 100, -40, 60, 10], [60, -45, 30, 90, -50, 120]])
    program.write_text(
        ",".join(robot.joint_names) + "\n" + "\n".join(",".join(map(str, r)) for r in np.degrees(q))
    )
    out = folder / "corrected.csv"
    run = cli.run(
        "compensate", "kr270", "--marker", "0.1,0.05,0.2", "--calibration", urdf,
        "--targets", program, "--deg", "--payload", "150", "--out", out,
    )  # fmt: skip
    assert run.code == 0, run.err
    assert "3 corrected targets" in run.out and "3 of 3 reached" in run.out
    commands = pincal.Plan.from_csv(out, robot, degrees=True).q
    nominal = robot.replace(base=pin.SE3.Identity()).tip_poses(q)[1]
    truth = true.replace(base=pin.SE3.Identity())
    before = np.linalg.norm(truth.tip_poses(q, payload=150.0)[1] - nominal, axis=1)
    after = np.linalg.norm(truth.tip_poses(commands, payload=150.0)[1] - nominal, axis=1)
    assert before.min() > 1e-3  # millimetres off without compensation
    assert after.max() < 1e-5  # within the calibration's own error (simulated at 1 µm noise)


def test_cartesian_program_and_json(calibration, cli):
    robot, _, _, urdf, folder = calibration
    seed = np.radians([10, -60, 70, 20, 40, -30])
    p0 = robot.replace(base=pin.SE3.Identity()).tip_poses(seed)[1][0]
    points = folder / "points.csv"
    points.write_text(
        "x,y,z\n" + "\n".join(",".join(map(str, p0 * 1000 + d)) for d in ([0, 0, 0], [50, 0, 0], [50, 50, 0]))
    )
    out = folder / "cartesian.csv"
    summary = cli.json(
        "compensate", "kr270", "--marker", "0.1,0.05,0.2", "--calibration", urdf, "--targets", points,
        "--mm", "--seed-pose=10,-60,70,20,40,-30", "--deg", "--out", out,
    )  # fmt: skip
    assert summary["cartesian"] and summary["targets"] == 3 and summary["not_reached"] == []
    assert summary["terms"] == {"gains": True, "compliance": True, "residual model": False}


def test_bad_compensate_inputs_are_one_line(calibration, cli, tmp_path):
    robot, _, _, urdf, folder = calibration
    lonely = tmp_path / "alone.urdf"
    lonely.write_text(urdf.read_text())
    program = tmp_path / "p.csv"
    program.write_text(",".join(robot.joint_names) + "\n0,-1,1,0,0.5,0\n")
    out = tmp_path / "o.csv"
    cli.fails(
        "compensate", "kr270", "--calibration", lonely, "--targets", program, "--out", out, match="sidecar"
    )
    points = tmp_path / "xyz.csv"
    points.write_text("x,y,z\n1,0,2\n")
    cli.fails(
        "compensate", "kr270", "--calibration", urdf, "--targets", points, "--out", out, match="--seed-pose"
    )
    assert not out.exists()
