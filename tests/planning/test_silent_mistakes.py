"""Mistakes that used to pass in silence get one line (issue 32), plans: a plan in radians read with
--deg."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal
from pincal.errors import PincalWarning

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]
TEST_POSE = "--test-pose=0.3,1.2"


def warnings_of(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("pincal: warning: ")]


# ------------------------------------------------------------------- radians read as degrees
def test_a_plan_in_radians_read_with_deg_is_warned_about(cell, cli):
    evaluate = ["evaluate", cell / "robot.urdf", *PLANAR, "--plan", cell / "plan.csv", "--json"]
    code, _, err = cli.run(*evaluate, "--deg", "--test-pose=17,69")
    assert code == 0, err
    (line,) = warnings_of(err)
    assert "plan file" in line and "looks like radians" in line and "drop --deg" in line
    code, _, err = cli.run(*evaluate, TEST_POSE)  # the same file read as radians
    assert code == 0 and not warnings_of(err), err
    (cell / "deg.csv").write_text("joint1,joint2\n5.7,57\n28,-57\n57,114\n")  # degrees
    code, _, err = cli.run(*evaluate[:-3], "--plan", cell / "deg.csv", "--json", "--deg", "--test-pose=17,69")
    assert code == 0 and not warnings_of(err), err


def test_one_turned_row_is_not_taken_for_radians(cell):
    robot = pincal.load_robot(cell / "robot.urdf", tip="tip")
    (cell / "one.csv").write_text("joint1,joint2\n0,0\n0,2\n")  # home and one small move
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plan = pincal.Plan.from_csv(cell / "one.csv", robot=robot, degrees=True)
    np.testing.assert_allclose(plan.q[1], [0, np.radians(2)])
    with pytest.warns(PincalWarning, match="looks like radians"):
        pincal.Plan.from_csv(cell / "plan.csv", robot=robot, degrees=True)
