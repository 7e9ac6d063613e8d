"""The Hilti stationing data (data/hilti_stationing/, CC BY-NC-SA 3.0) read as pincal measurements."""

from __future__ import annotations

import importlib.util
import sys
import warnings

import numpy as np
import pytest

import pincal
from pincal.calibration.measurements import MeasurementData
from tests.conftest import ROOT

_spec = importlib.util.spec_from_file_location(
    "hilti_stationing", ROOT / "benchmarks" / "hilti_stationing.py"
)
hilti = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("hilti_stationing", hilti)  # its dataclasses look their module up
_spec.loader.exec_module(hilti)


@pytest.fixture(scope="module")
def flat():
    return hilti.read(hilti.DATA / "flat.yaml")


def test_waypoints_are_read_with_both_column_stages(flat):
    assert len(flat.q) == 444
    robot = hilti.robot()
    assert flat.joint_names == robot.joint_names
    robot.check_limits(
        flat.q, [f"waypoint {i}" for i in range(len(flat.q))]
    )  # every value within the URDF's limits
    # The two stages are mimic joints of one: the top stage is always 30 mm behind the middle one.
    np.testing.assert_allclose(flat.q[:, 0] - flat.q[:, 1], 0.03, atol=1e-12)
    assert flat.stationing.sum() == 78 and len(np.unique(flat.station)) == 15


def test_gravity_from_the_base_accelerometer(flat):
    g = flat.gravity
    assert np.linalg.norm(g) == pytest.approx(9.81, abs=0.01)
    tilt = np.degrees(np.arccos(-g[2] / np.linalg.norm(g)))
    assert 0.1 < tilt < 1.0  # the floor is level to within a degree, not exactly
    np.testing.assert_allclose(hilti.robot(g).gravity, g)


def test_csv_conversion_round_trips(flat, tmp_path):
    out = tmp_path / "flat.csv"
    hilti.main(["convert", str(hilti.DATA / "flat.yaml"), "--out", str(out)])
    data = MeasurementData.from_csv(out, hilti.robot())
    np.testing.assert_array_equal(data.q, flat.q)
    np.testing.assert_array_equal(data.points[:, 0], flat.points)


def test_the_nominal_robot_explains_the_data_to_centimetres(flat):
    # Registered by its base alone, the published model is within centimetres of every prism position;
    # what is left (millimetres) is what calibration is for.
    robot = hilti.robot(flat.gravity)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = pincal.identify(robot.parameters("base"), flat.measurements(), sigma=hilti.SIGMA)
    error = np.linalg.norm(result.robot.points(flat.q, check=False)[:, 0] - flat.points, axis=1)
    assert 3e-3 < np.sqrt(np.mean(error**2)) < 2e-2
