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
one; measured bias at 1 mm / 1 mrad on this robot is below 1 %, issue 9). Budget: the KR 270 case
about 25 s of CPU (150 trials × 12 plan-region pairs; measured ratios 0.97–1.07, standard errors
~3 %) and a few seconds for the designs of two more seeds (compared by their predicted errors);
the UR10 case is marked slow (500 trials, ~65 s of CPU; ratios 0.96–1.02, errors 1–2.5 %).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal

SIGMA = 3e-5  # m: a laser tracker
M = 8
ERRORS = {"length": 1e-3, "angle": 1e-3}
SWEEP = np.radians([30, 10, -10, 20, 15, 30])
"""The test path: q0 + t·SWEEP, t in [-1, 1] (a seam through the test pose)."""
CASES = [
    pytest.param(("kr270", np.radians([0, -60, 60, 0, 45, 0]), 150), id="kr270", marks=pytest.mark.long),
    # The UR10 of example-robot-data with more trials (tighter statistics): about 90 s of CPU.
    pytest.param(
        ("ur10", np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0]), 500), id="ur10", marks=pytest.mark.slow
    ),
]


SEEDS = (0, 1, 2)
"""Design seeds: the plans of seed 0 are calibrated (Monte Carlo); those of every seed are compared
by their predicted errors, so a claim that holds for one search's path only fails here."""


@pytest.fixture(scope="module", params=CASES)
def calibrations(request):
    """({(plan, region): MonteCarloResult}, {seed: {(plan, region): predicted ρ0}}) for plans
    designed for q0, its ±10° neighbourhood and a path, each checked at q0, over ±10° and ±20°
    boxes and along the path: calibrated for the first design seed, predicted for each."""
    name, q0, trials = request.param
    robot = pincal.load_robot(name, tip="tool0", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    rng = np.random.default_rng(2024)
    path = q0 + np.linspace(-1, 1, 100)[:, None] * SWEEP

    def box(degrees):
        return q0 + np.radians(degrees) * rng.uniform(-1, 1, (25, 6))

    regions = {"q0": q0[None], "±10°": box(10), "±20°": box(20), "path": path}

    def plans(seed):
        options = dict(sigma=SIGMA, search=pincal.Search(starts=2, seed=seed, workers=1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", pincal.errors.DegenerateOptimumWarning)
            return {
                # At the former default floor 1e-4 (issue 9's case): the default 1e-2 already keeps
                # a single-pose plan far more regular (benchmarks/RESULTS.md, bench_floor).
                "single pose": pincal.design(
                    params, M, q0, **options, safety=pincal.Safety(min_conditioning=1e-4)
                ).plan,
                "neighbourhood": pincal.design(params, M, pincal.around(q0, np.radians(10)), **options).plan,
                "path": pincal.design(params, M, pincal.TestPath(path), **options).plan,
            }

    designed = {seed: plans(seed) for seed in SEEDS}
    measured = {
        (plan_name, region): pincal.monte_carlo(
            params, plan, poses, sigma=SIGMA, trials=trials, seed=7, error_std=ERRORS
        )
        for plan_name, plan in designed[SEEDS[0]].items()
        for region, poses in regions.items()
    }
    predicted = {
        seed: {
            (plan_name, region): pincal.rho0(params, plan, poses, sigma=SIGMA)
            for plan_name, plan in designed[seed].items()
            for region, poses in regions.items()
        }
        for seed in SEEDS
    }
    return measured, predicted


def test_predicted_errors_hold_at_and_away_from_the_test_poses(calibrations):
    measured, _ = calibrations
    for (plan, region), mc in measured.items():
        assert mc.failures == 0 and mc.local_minima == 0, (plan, region, mc.note)
        linearisation = abs(mc.rho0_at_truth / mc.rho0_predicted - 1)
        tolerance = 4 * mc.ratio_se + linearisation + 0.02
        assert abs(mc.ratio - 1) < tolerance, (plan, region, mc.ratio, tolerance, mc.note)


def _errors(calibrations):
    """(what, error(plan, region)) for the measured errors, then the predicted ones of each seed."""
    measured, predicted = calibrations
    yield "measured", lambda plan, region: measured[plan, region].rho0_empirical
    for seed, rho in predicted.items():
        yield f"predicted, design seed {seed}", lambda plan, region, rho=rho: rho[plan, region]


def test_designing_for_the_region_pays_off_where_the_robot_works(calibrations):
    """Measured, and predicted for several design seeds: the single-pose plan is far worse away
    from q0 than a plan designed for the neighbourhood, and worse along the path than the plan
    designed for it."""
    for what, error in _errors(calibrations):
        for region in ("±10°", "±20°"):
            assert error("neighbourhood", region) < error("single pose", region) / 2, (what, region)
        assert error("path", "path") < error("single pose", "path") / 2, what
        # ... and the price at q0 is small: within 25 % of the plan designed for q0 alone (two
        # local searches: predicted 7-10 % on the KR 270 for design seeds 0-3, plus the Monte
        # Carlo's standard error of ~3 % on each measured error).
        assert error("neighbourhood", "q0") < 1.25 * error("single pose", "q0"), what


def test_the_single_pose_promise_is_local(calibrations):
    """The plan designed for q0 alone keeps its promise at q0 and measurably loses it 10° away."""
    for what, error in _errors(calibrations):
        assert error("single pose", "±10°") > 2 * error("single pose", "q0"), what
