"""Mistakes that used to pass in silence get one line (issue 32): a measurement file without its
z column, a plan in radians read with --deg, σ typed in millimetres, an option misspelt."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.errors import PincalWarning
from pincal.instruments import Partial

ROOT = Path(__file__).resolve().parents[1]
PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]
TEST_POSE = "--test-pose=0.3,1.2"


@pytest.fixture
def cell(tmp_path):
    shutil.copy(ROOT / "robots" / "planar_2r.urdf", tmp_path / "robot.urdf")
    (tmp_path / "plan.csv").write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n")
    return tmp_path


def warnings_of(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("pincal: warning: ")]


# ------------------------------------------------------------- a measurement file without z
def _xy_file(path: Path) -> Path:
    robot = pincal.load_robot("planar_2r", tip="tip")
    qs = robot.random_configurations(8, 0)
    xy = robot.points(qs)[:, 0, :2]
    rows = "\n".join(",".join(f"{v:.9g}" for v in (*q, *p)) for q, p in zip(qs, xy))
    path.write_text("joint1,joint2,x,y\n" + rows + "\n")
    return path


def test_a_file_without_z_is_read_as_x_y_with_a_warning_naming_the_fix(tmp_path):
    path = _xy_file(tmp_path / "meas.csv")
    robot = pincal.load_robot("planar_2r", tip="tip")
    with pytest.warns(PincalWarning, match=r"columns x,y but no z: .*add its column.*--measure x,y"):
        data = pincal.MeasurementData.from_csv(path, robot)
    assert data.measure == Partial(("x", "y"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert pincal.MeasurementData.from_csv(path, robot, kind=Partial(("x", "y"))).measure == data.measure
        path.write_text("joint1,joint2,z\n0,0,0\n")  # a height gauge's lone z is no point missing two
        pincal.MeasurementData.from_csv(path, robot)


def test_identify_warns_of_a_file_without_z_unless_measure_says_so(tmp_path, cli):
    path = _xy_file(tmp_path / "meas.csv")
    argv = ["identify", "planar_2r", *PLANAR, "--data", path]
    code, _, err = cli.run(*argv)
    assert code == 0, err
    (line,) = warnings_of(err)
    assert "'" + str(path) + "' has columns x,y but no z" in line and "--measure x,y" in line
    code, _, err = cli.run(*argv, "--measure", "x,y")
    assert code == 0 and not warnings_of(err), err


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


# ---------------------------------------------------------------------- σ in millimetres
def test_sigma_in_millimetres_is_warned_about(cell, cli):
    evaluate = ["evaluate", cell / "robot.urdf", *PLANAR, "--plan", cell / "plan.csv", TEST_POSE]
    code, out, err = cli.run(*evaluate, "--sigma", "0.03")
    assert code == 0, err
    assert warnings_of(err) == [
        "pincal: warning: --sigma 0.03 is 30 mm per coordinate, which looks like millimetres: --sigma is "
        "in metres (a laser tracker's 0.03 mm is --sigma 3e-5)"
    ]
    code, _, err = cli.run(*evaluate, "--sigma", "3e-5")
    assert code == 0 and not warnings_of(err), err


# ------------------------------------------------------------------------ a misspelt option
@pytest.mark.parametrize(
    "argv, hint",
    [
        (["design", "kr270", "-m", "12", "--markers", "0.1,0.05,0.2"],
         "--markers 0.1,0.05,0.2 (did you mean --marker?)"),
        (["evaluate", "kr270", "--plan", "p.csv", "--sigmas=3e-5"], "--sigmas=3e-5 (did you mean --sigma?)"),
        (["params", "kr270", "--tips", "tool0"], "--tips tool0 (did you mean --tip?)"),
    ],
)  # fmt: skip
def test_a_misspelt_option_gets_a_close_match(cli, argv, hint):
    line = cli.fails(*argv)
    assert line == f"pincal: error: unrecognized arguments: {hint} (see 'pincal {argv[0]} --help')"


def test_an_unknown_option_without_a_close_match_is_refused_as_before(cli):
    line = cli.fails("params", "kr270", "--zzzz")
    assert line == "pincal: error: unrecognized arguments: --zzzz (see 'pincal --help')"
