"""Which target points a camera configuration yields: the design's information counts only what a
measurement would deliver, and its predicted error is the one calibration delivers
(docs/method.md §13.1)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
import yaml

import pincal
from pincal.cli.example import example_text
from pincal.instruments import Instrument, PerCoordinate
from pincal.instruments.camera import Camera
from pincal.instruments.identifiability import identifiable
from pincal.instruments.image import LIKELY_READ
from pincal.instruments.rig import rig_from_dict

Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
ERRORS = {"length": 1e-3, "angle": 1e-3}  # the simulation's, and the image kind's default
N_TRIALS = 100

EXAMPLE = yaml.safe_load(example_text("rig"))
"""The example rig (notebook 05's): a camera on the tool seeing a 6 x 5 grid on the floor."""


@pytest.fixture(scope="module")
def rig():
    return rig_from_dict(EXAMPLE)


@pytest.fixture(scope="module")
def camera_params(rig):
    panda = pincal.load_robot("panda").with_fixtures(*rig.fixtures)
    instrument = Instrument(rig.kind, PerCoordinate(sigma_px=rig.pixel_sigma))
    return identifiable(panda.parameters("full,offsets,instrument"), instrument).identifiable


def test_inside_probability_is_the_share_of_gaussian_pixels_in_the_image():
    camera = Camera(600, 600, 320, 240, width=640, height=480)
    uv = np.array([[320.0, 240.0], [5.0, 240.0], [-10.0, 470.0], [700.0, 10.0]])
    spread = np.array([[3.0, 3.0], [10.0, 2.0], [20.0, 20.0], [50.0, 5.0]])
    draws = np.random.default_rng(0).normal(uv, spread, size=(200_000, 4, 2))
    inside = ((draws >= 0) & (draws <= (640, 480))).all(axis=-1).mean(axis=0)
    assert camera.inside_probability(uv, spread) == pytest.approx(inside, abs=4e-3)
    hard = camera.inside_probability(uv, np.zeros_like(uv))
    assert hard.tolist() == [1.0, 1.0, 0.0, 0.0]


def test_a_configuration_that_sees_none_of_the_grid_adds_no_information(rig, camera_params):
    robot = camera_params.robot
    pool = robot.random_configurations(400, 3)
    blind = pool[~rig.kind.seen(robot, pool).any(axis=1)][:5]
    assert len(blind) == 5  # a camera on the tool faces away from the target most of the time
    engine = Instrument(rig.kind, PerCoordinate(sigma_px=rig.pixel_sigma)).engine(camera_params)
    assert not np.any(engine.jacobian(blind))
    plan = pool[rig.kind.seen(robot, pool).sum(axis=1) >= 24][:12]
    instrument = Instrument(rig.kind, PerCoordinate(sigma_px=rig.pixel_sigma))
    before = pincal.rho0(camera_params, plan, Q0, instrument=instrument)
    after = pincal.rho0(camera_params, np.vstack([plan, blind]), Q0, instrument=instrument)
    assert after == pytest.approx(before, rel=1e-9)


def test_weights_are_the_probability_a_point_is_read(rig, camera_params):
    robot = camera_params.robot
    pool = robot.random_configurations(400, 4)
    pool = pool[rig.kind.seen(robot, pool).any(axis=1)][:40]
    engine = Instrument(rig.kind, PerCoordinate(sigma_px=rig.pixel_sigma)).engine(camera_params)
    rows = rig.kind.rows(engine.points, pool)
    weight = rig.kind.weights(engine.points, pool, rows)
    seen = rig.kind.seen(robot, pool)
    assert np.all((weight == 0) | ((weight >= LIKELY_READ) & (weight <= 1)))
    assert 0 < weight[seen].mean() < 1  # some points near the edge count for a share
    exact = dataclasses.replace(rig.kind, error_std=None)
    assert np.array_equal(exact.weights(engine.points, pool, rows), seen.astype(float))
    tiny = dataclasses.replace(rig.kind, error_std=(1e-12, 1e-12))
    assert np.array_equal(tiny.weights(engine.points, pool, rows) > 0, seen)
    with pytest.raises(pincal.PincalError, match="error_std"):
        dataclasses.replace(rig.kind, error_std=(1e-3, -1.0))


EYE_TO_HAND = {
    "camera": {**EXAMPLE["camera"], "mount": "cell", "xyz": [1.2, 0.0, 0.5], "rpy_deg": [-90, 0, 90]},
    "target": {"grid": EXAMPLE["target"]["grid"], "xyz": [0.0, 0.0, 0.05]},
    "pixel_sigma": EXAMPLE["pixel_sigma"],
}
"""benchmarks/eye_to_hand_rig.yaml: the example rig's camera in the cell, its grid on the tool."""


@pytest.mark.long
@pytest.mark.parametrize("case", ["eye-in-hand", "eye-to-hand"])
def test_the_predicted_error_is_the_one_calibration_delivers(rig, case):
    """Over N simulated calibrations (pincal.monte_carlo: fresh 1 mm / 1 mrad errors and pixel
    noise each), the RMS error at the test pose is the design's prediction within 3 standard errors
    of the ratio + 2 %. Point designs are held to 4 standard errors + the linearisation difference +
    2 % (tests/evaluation/test_regions_monte_carlo.py); here that band would pass main's design
    before this fix (1.24 ± 0.06 over these 100 trials: 0.24 < 0.28), and for a camera the
    linearisation term (ρ0 at each true robot) also decides anew which corners are read: 62 % on
    the example rig, which would make any band pass. 3 standard errors fail main's design
    (0.24 > 0.21) and pass this one's."""
    if case == "eye-to-hand":
        rig = rig_from_dict(EYE_TO_HAND)
    panda = pincal.load_robot("panda").with_fixtures(*rig.fixtures)
    pixels = PerCoordinate(sigma_px=rig.pixel_sigma)
    instrument = Instrument(rig.kind, pixels)
    params = identifiable(panda.parameters("full,offsets,instrument"), instrument).identifiable
    search = pincal.Search(starts=2, seed=0)
    plan = pincal.design(params, 20, Q0, instrument=instrument, search=search).plan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mc = pincal.monte_carlo(
            params, plan, Q0, trials=N_TRIALS, seed=7, error_std=ERRORS, instrument=instrument
        )
    # One identification of the example rig's 100, started at the nominal geometry, ends in a
    # local minimum (monte_carlo leaves it out of the ratio); point designs' tests see none.
    assert mc.failures == 0 and mc.local_minima <= 1, mc.note
    tolerance = 3 * mc.ratio_se + 0.02
    # Measured here (seed 7, N = 100): the example rig 0.91 ± 0.05, the eye-to-hand rig 0.99 ± 0.04;
    # with the bench's seeds (benchmarks/RESULTS.md, "Camera designs") over 150 trials 0.88 ± 0.04
    # and 0.98 ± 0.04: the floor p >= 0.9 makes the example rig's prediction a little pessimistic.
    assert abs(mc.ratio - 1) < tolerance, (mc.ratio, tolerance, mc.note)
