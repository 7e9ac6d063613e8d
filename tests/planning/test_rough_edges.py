"""A newcomer's first hour (issue 21), planning inputs: YAML booleans are not numbers, and joint names
with commas and hashes survive a plan file."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from tests.conftest import ROOT

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("joint_limits: {margin_deg: true}", "joint_limits margin_deg must be a number"),
        ("min_spacing: {distance_deg: yes}", "min_spacing distance_deg must be a number"),
        ("workspace_box: {lower: [0, 0, true], upper: [1, 1, 1]}", "workspace_box lower[2] must be"),
        ("visibility: {tracker: [4, 0, 1], max_range: false}", "visibility max_range must be"),
        ("self_collision: {min_distance: true}", "self_collision min_distance must be"),
    ],
)
def test_yaml_booleans_are_not_numbers(cell, cli, text, fragment):
    (cell / "cell.yaml").write_text(text)
    argv = ["design", cell / "robot.urdf", "-m", "3", "--test-pose=0.3,1.2", *PLANAR, "--workers", "1"]
    err = cli.fails(*argv, "--constraints", cell / "cell.yaml", match=fragment)
    assert "got True" in err or "got False" in err


def test_joint_names_with_commas_and_hashes_survive_a_plan_file(tmp_path, cli):
    text = (ROOT / "robots" / "planar_2r.urdf").read_text()
    text = text.replace('"joint1"', '"a,b"').replace('"joint2"', '"#2 &quot;q&quot;"')
    (tmp_path / "odd.urdf").write_text(text)
    robot = pincal.load_robot(tmp_path / "odd.urdf", tip="tip")
    assert robot.joint_names == ("a,b", '#2 "q"')
    plan = pincal.Plan.for_robot(robot, [[0.1, 1.0], [0.5, -1.0], [1.0, 2.0]])
    plan.to_csv(tmp_path / "plan.csv")
    back = pincal.Plan.from_csv(tmp_path / "plan.csv", robot=robot)
    np.testing.assert_array_equal(back.q, plan.q)
    data = pincal.simulate_measurements(robot, plan, sigma=0.0)
    data.to_csv(tmp_path / "meas.csv")
    assert pincal.MeasurementData.from_csv(tmp_path / "meas.csv", robot).joint_names == robot.joint_names
    argv = ["design", tmp_path / "odd.urdf", "--tip", "tip", "-m", "6", "--test-pose=0.3,1.2"]
    argv += ["--workers", "1", "--starts", "2", "--pool-size", "200", "--no-accuracy"]
    code, _, err = cli.run(*argv, "--out", tmp_path / "d.csv")
    assert code == 0, err
    assert pincal.Plan.from_csv(tmp_path / "d.csv", robot=robot).m == 6
