"""Plans designed for one test pose, a neighbourhood (``pincal.around``) and a path
(``pincal.TestPath``) keep their promises where they are checked: real nonlinear identifications
(pincal.monte_carlo: random true robots with errors of 1 mm / 1 mrad, noisy measurements,
Gauss-Newton) against the predicted error, at the test poses and away from them (issue 9, item 4).

Tolerance. ``monte_carlo`` gives the empirical RMS error and its standard error from the trials'
spread (delta method on the mean squared error). The prediction is linearised at the nominal
geometry; with 1 mm / 1 mrad errors the Jacobian at the true robot differs by ~1e-3 relative, and
the poorly conditioned single-pose plan adds the nonlinearity of its near-singular directions,
which ``rho0_at_truth`` (the prediction linearised at each true robot) measures. Each check allows
4 standard errors (a two-sided Gaussian tail of 6e-5; the run is seeded, so it is deterministic
anyway) plus that measured linearisation difference plus 2 % (the prediction is a first-order
one; measured bias at 1 mm / 1 mrad on this robot is below 1 %, issue 9). Budget: about 25 s of
CPU (150 trials × 12 plan-region pairs; measured ratios 0.97–1.07, standard errors ~3 %).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal

SIGMA = 3e-5  # m: a laser tracker
M = 8
TRIALS = 150
Q0 = np.radians([0, -60, 60, 0, 45, 0])
ERRORS = {"length": 1e-3, "angle": 1e-3}


@pytest.fixture(scope="module")
def calibrations(kr270_marker):
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    rng = np.random.default_rng(2024)
    path = Q0 + np.linspace(-1, 1, 100)[:, None] * np.radians([30, 10, -10, 20, 15, 30])

    def box(degrees):
        return Q0 + np.radians(degrees) * rng.uniform(-1, 1, (25, 6))

    regions = {"q0": Q0[None], "±10°": box(10), "±20°": box(20), "path": path}
    options = dict(sigma=SIGMA, starts=2, seed=0, workers=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.DegenerateOptimumWarning)
        plans = {
            # At the former default floor 1e-4 (issue 9's case): the default 1e-2 already keeps a
            # single-pose plan far more regular (benchmarks/RESULTS.md, bench_floor).
            "single pose": pincal.design(params, M, Q0, min_conditioning=1e-4, **options).plan,
            "neighbourhood": pincal.design(params, M, pincal.around(Q0, np.radians(10)), **options).plan,
            "path": pincal.design(params, M, pincal.TestPath(path), **options).plan,
        }
    measured = {
        (plan_name, region): pincal.monte_carlo(
            params, plan, poses, sigma=SIGMA, trials=TRIALS, seed=7, error_std=ERRORS
        )
        for plan_name, plan in plans.items()
        for region, poses in regions.items()
    }
    return measured


def test_predicted_errors_hold_at_and_away_from_the_test_poses(calibrations):
    measured = calibrations
    for (plan, region), mc in measured.items():
        assert mc.failures == 0 and mc.local_minima == 0, (plan, region, mc.note)
        linearisation = abs(mc.rho0_at_truth / mc.rho0_predicted - 1)
        tolerance = 4 * mc.ratio_se + linearisation + 0.02
        assert abs(mc.ratio - 1) < tolerance, (plan, region, mc.ratio, tolerance, mc.note)


def test_designing_for_the_region_pays_off_where_the_robot_works(calibrations):
    """Measured, not predicted: the single-pose plan is far worse away from q0 than a plan
    designed for the neighbourhood, and worse along the path than the plan designed for it."""
    measured = calibrations

    def error(plan, region):
        return measured[plan, region].rho0_empirical

    for region in ("±10°", "±20°"):
        assert error("neighbourhood", region) < error("single pose", region) / 2, region
    assert error("path", "path") < error("single pose", "path") / 2
    # ... and the price at q0 is small: within 15 % of the plan designed for q0 alone.
    assert error("neighbourhood", "q0") < 1.15 * error("single pose", "q0")


def test_the_single_pose_promise_is_local(calibrations):
    """The plan designed for q0 alone keeps its promise at q0 and measurably loses it 10° away."""
    measured = calibrations
    at_q0, away = measured["single pose", "q0"], measured["single pose", "±10°"]
    assert away.rho0_empirical > 2 * at_q0.rho0_empirical
