"""A newcomer's first hour (issue 21), calibration: xacro robots calibrated and exported, and the URDF a
RobotWrapper carries found by the export."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import pincal
from tests.support.urdfs import XACRO_ARM

# ------------------------------------------------------------------- xacro robots export
XACRO = XACRO_ARM  # planar 2-joint arm: properties, a macro, ${pi} limits


def test_a_xacro_robot_is_calibrated_and_exported_end_to_end(tmp_path, cli):
    """identify on a xacro robot exported 'has no joints' (the xacro source was parsed as the
    URDF): the export starts from the expansion loading uses, and the file loads back."""
    pytest.importorskip("xacro")
    src = tmp_path / "arm.urdf.xacro"
    src.write_text(XACRO)
    robot = pincal.load_robot(src, markers=[(0.05, 0.02, 0.1)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    true = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=1)
    plan = pincal.Plan.for_robot(robot, robot.random_configurations(30, 2))
    data = pincal.simulate_measurements(true, plan, sigma=1e-6, seed=3)
    data.to_csv(tmp_path / "meas.csv")
    out = tmp_path / "calibrated.urdf"
    argv = ["identify", src, "--marker", "0.05,0.02,0.1", "--params", ",".join(params.names)]
    code, stdout, err = cli.run(*argv, "--data", tmp_path / "meas.csv", "--out", out)
    assert code == 0, err
    back = pincal.load_robot(out, markers=[(0.05, 0.02, 0.1)])
    assert back.joint_names == ("j1", "j2")
    qs = robot.random_configurations(20, 4)
    # the exported URDF reproduces the true robot's points (to the noise), not the nominal one's
    np.testing.assert_allclose(back.points(qs), true.robot.replace(base=back.base).points(qs), atol=2e-5)
    assert np.abs(back.points(qs) - robot.points(qs)).max() > 1e-4
    assert json.loads(out.with_name("calibrated.calibration.json").read_text())["conditioning"] > 0


# ----------------------------------------------------------------- a RobotWrapper's URDF
@pytest.mark.filterwarnings("ignore:.*mesh file:pincal.PincalWarning")  # the copy is not beside the meshes
def test_export_finds_the_urdf_a_robot_wrapper_carries(tmp_path):
    erd = pytest.importorskip("example_robot_data")
    wrapper = erd.load("ur5")
    robot = pincal.load_robot(wrapper, tip="tool0")
    assert robot.urdf_path is not None and Path(robot.urdf_path) == Path(wrapper.urdf).resolve()
    params = robot.parameters("lengths").identifiable().identifiable
    moved = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 0.0}, seed=0).robot
    path = pincal.export_urdf(moved, tmp_path / "ur5_moved.urdf")  # no source_urdf=
    back = pincal.load_robot(path, tip="tool0")
    qs = robot.random_configurations(5, 1)
    np.testing.assert_allclose(back.points(qs), moved.points(qs), atol=1e-9)
    bare = pincal.load_robot(wrapper.model, tip="tool0")  # a pin.Model carries no file
    with pytest.raises(pincal.errors.UrdfError, match="give source_urdf"):
        pincal.export_urdf(bare, tmp_path / "x.urdf")
