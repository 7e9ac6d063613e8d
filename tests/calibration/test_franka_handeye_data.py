"""The Franka hand-eye data (data/franka_handeye/, MIT) read as pincal pose measurements."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np

import pincal
from tests.conftest import ROOT

_spec = importlib.util.spec_from_file_location("franka_handeye", ROOT / "benchmarks" / "franka_handeye.py")
franka = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("franka_handeye", franka)
_spec.loader.exec_module(franka)


def test_the_panda_model_is_the_controllers_and_a_hand_eye_fit_explains_the_poses():
    q, board, ee = franka.read()
    assert q.shape == (12, 7) and len(board) == 12
    R, p = pincal.load_robot("panda").tip_poses(q)
    np.testing.assert_allclose(R, ee[:, :3, :3], atol=1e-4)
    np.testing.assert_allclose(p, ee[:, :3, 3], atol=1e-4)
    result, robot = franka.fit(q, board, list(range(12)), franka.HAND_EYE)
    assert result.status == "converged"
    e = result.residuals.reshape(12, 6)
    before = franka.measurements(robot, q, board).points - pincal.instruments.Pose().predict(robot, q)
    # The camera a few millimetres and degrees from its rounded nominal, the board placed by the
    # first pose: the fit leaves a few millimetres (the dataset's own hand-eye: 2.6 mm), at least
    # half what the nominal robot leaves.
    after = np.sqrt(np.mean(np.sum(e[:, :3] ** 2, axis=1)))
    assert after < 5e-3 and np.sqrt(np.mean(np.sum(before[:, :3] ** 2, axis=1))) > 1.5 * after
    # The camera's origin found within a centimetre of the dataset's own hand-eye result.
    own = np.array(franka.json.loads((franka.DATA / "calibration_result.json").read_text())["xyz"])
    marker = result.robot.markers[0]
    assert np.linalg.norm(marker - own) < 0.01
