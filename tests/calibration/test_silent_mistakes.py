"""Mistakes that used to pass in silence get one line (issue 32), measurements: a measurement file
without its z column."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

import pincal
from pincal.errors import PincalWarning
from pincal.instruments import Partial

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]


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
