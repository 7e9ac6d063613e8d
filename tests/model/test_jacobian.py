"""Analytic parameter Jacobians against central finite differences (docs/method.md §3)."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

import pincal
from pincal.errors import PincalError

GROUPS = ["offsets", "lengths", "full", "base", "markers", "full,offsets,base,markers"]

ROBOTS = {
    "planar_2r": dict(source="planar_2r", tip="tip", markers=None),
    "kr270": dict(source="kr270", tip="tool0", markers=None),
    "kr270_marker": dict(source="kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)]),
    "kr270_two_markers": dict(source="kr270", tip="tool0", markers=[(0.1, 0.05, 0.2), (-0.05, 0.1, 0.1)]),
    "ur10": dict(source="ur10", tip="tool0", markers=[(0.03, -0.02, 0.1)]),
    "panda": dict(source="panda", tip="panda_hand", markers=[(0.0, 0.04, 0.1)]),
}


def _relative_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.mark.parametrize("group", GROUPS)
@pytest.mark.parametrize("key", list(ROBOTS))
def test_analytic_matches_finite_differences(key, group):
    spec = ROBOTS[key]
    robot = pincal.load_robot(spec["source"], tip=spec["tip"], markers=spec["markers"])
    params = robot.parameters(group)
    q = robot.random_configurations(6, np.random.default_rng(zlib.crc32((key + group).encode())))
    analytic = params.jacobian(q)
    fd = params.jacobian(q, method="fd")
    assert analytic.shape == (6, 3 * robot.n_markers, len(params))
    assert _relative_error(analytic, fd) <= 1e-6


def test_jacobian_of_a_perturbed_robot(kr270_marker):
    # Identification linearises at the current estimate: the Jacobian must hold there too.
    params = kr270_marker.parameters("full,offsets,base,markers")
    moved = params.apply(np.random.default_rng(3).normal(0, 1e-2, len(params)))
    p2 = params.on(moved)
    q = kr270_marker.random_configurations(5, 4)
    assert _relative_error(p2.jacobian(q), p2.jacobian(q, method="fd")) <= 1e-6


def test_tip_frame_rows_give_the_same_information(kr270_marker):
    params = kr270_marker.parameters("full,offsets,base")
    q = kr270_marker.random_configurations(8, 5)
    Jw = params.jacobian(q, frame="world")
    Jt = params.jacobian(q, frame="tip")
    Mw = pincal.evaluation.information_matrix(Jw)
    Mt = pincal.evaluation.information_matrix(Jt)
    np.testing.assert_allclose(Mt, Mw, atol=1e-12 * np.abs(Mw).max())
    np.testing.assert_allclose(np.linalg.norm(Jw, axis=1), np.linalg.norm(Jt, axis=1), atol=1e-12)


def test_offset_column_is_the_joint_jacobian_column(planar):
    # d p / d q1 of the planar arm: (-y, x).
    q = np.array([0.7, -0.4])
    J = planar.parameters("offsets").jacobian(q)[0]
    x, y, _ = planar.points(q)[0, 0]
    np.testing.assert_allclose(J[:, 0], [-y, x, 0], atol=1e-14)


def test_single_configuration_shape(kr270):
    J = kr270.parameters("offsets").jacobian(kr270.random_configurations(1, 0)[0])
    assert J.shape == (1, 3, 6)


def test_bad_method_and_frame(kr270):
    params = kr270.parameters("offsets")
    q = kr270.random_configurations(2, 0)
    with pytest.raises(PincalError, match="analytic, fd"):
        params.jacobian(q, method="symbolic")
    with pytest.raises(PincalError, match="world, tip"):
        params.jacobian(q, frame="base")
