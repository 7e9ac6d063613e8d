"""Vendor-like URDFs (issue 11, item 4): every joint turned to a z axis with rpy angles rounded to
4 digits, as published descriptions do. Identifiability, design and identification must give the
exact-angle robot's results to 1 %. CI time: ~15 s of CPU (two robots, two designs each, 2 starts)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal
from pincal.model.base_parameters import independent_columns
from tests.vendor_like import z_axis_urdf

MARKER = [(0.1, 0.05, 0.2)]
SIGMA = 3e-5


@pytest.fixture(scope="module", params=["kr270", "ur10"])
def pair(request, tmp_path_factory):
    """(exact, rounded) robots of one shipped / example-robot-data arm."""
    base = pincal.load_robot(request.param, markers=MARKER)
    folder = tmp_path_factory.mktemp(request.param)
    robots = []
    for digits in (None, 4):
        path = folder / f"{request.param}_{digits}.urdf"
        path.write_text(z_axis_urdf(base, digits))
        robots.append(pincal.load_robot(path, markers=MARKER))
    return base, *robots


def test_the_z_axis_description_is_the_same_robot(pair):
    base, exact, rounded = pair
    qs = base.random_configurations(20, 0)
    np.testing.assert_allclose(exact.points(qs), base.points(qs), atol=1e-12)
    error = np.abs(rounded.points(qs) - base.points(qs)).max()
    assert 1e-7 < error < 1e-4  # the rounding really moves the robot, by micrometres


def test_rounded_angles_keep_the_identifiable_set(pair):
    _, exact, rounded = pair
    a = exact.parameters("full,offsets").identifiable()
    b = rounded.parameters("full,offsets").identifiable()
    assert b.identifiable.names == a.identifiable.names
    # The old absolute 1e-6 cut kept numerically dependent columns on a rounded UR10 (rank 28 of
    # a rank-27 Jacobian); the information matrix of any plan was then singular.
    s = b.singular_values
    assert s[b.rank - 1] > 1e-3 * s[0] and s[b.rank] < 1e-9 * s[0]


def test_design_and_identify_match_the_exact_robot_to_one_percent(pair):
    _, exact, rounded = pair
    q0 = exact.random_configurations(1, 7)
    exact_params = exact.parameters("full,offsets").identifiable().identifiable
    rounded_params = rounded.parameters("full,offsets").identifiable().identifiable
    m = -(-len(exact_params) // 3) + 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.DegenerateOptimumWarning)
        design = pincal.design(exact_params, m, test_pose=q0, starts=2, seed=1, sigma=SIGMA)
        # The exact robot's optimum is (to 1 %) a plan of the rounded robot's, and the rounded
        # robot's design from it stays there: no singular information matrix, no floor failure.
        assert pincal.rho0(rounded_params, design.plan, q0, SIGMA) == pytest.approx(design.value, rel=0.01)
        again = pincal.design(
            rounded_params,
            m,
            test_pose=q0,
            method="continuous",
            init=[design.plan],
            starts=1,
            seed=1,
            sigma=SIGMA,
        )
    assert again.value == pytest.approx(design.value, rel=0.01)
    fits = []
    for params in (exact_params, rounded_params):
        truth = pincal.random_errors(params, seed=3)
        data = pincal.simulate_measurements(truth, design.plan, sigma=SIGMA, seed=4)
        fit = pincal.identify(params, data, sigma=SIGMA)
        assert fit.success
        assert np.all(np.abs(fit.values - truth.values) < 5 * fit.std)
        fits.append(fit)
    np.testing.assert_allclose(fits[1].std, fits[0].std, rtol=0.01)


def test_nearly_redundant_column_is_named_with_its_distance():
    """Kernel oracle: c = (a + b)/√2 tilted by 1e-5 out of span{a, b} is dropped, and its
    distance to the span is 1e-5."""
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.standard_normal((50, 4)))
    a, b, n, d = q.T
    c = np.cos(1e-5) * (a + b) / np.sqrt(2) + np.sin(1e-5) * n
    A = np.column_stack([a, b, c, d])
    kept, distance = independent_columns(A, [0, 1, 2, 3])
    assert kept == [0, 1, 3]
    assert distance[2] == pytest.approx(np.sin(1e-5), rel=1e-6)
    kept, distance = independent_columns(A, [0, 1, 2, 3], tol=1e-6)
    assert kept == [0, 1, 2, 3] and distance[2] == pytest.approx(np.sin(1e-5), rel=1e-6)
