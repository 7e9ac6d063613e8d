"""A camera design's candidates are views that likely read enough of the target to reveal the
camera's pose relative to it (pincal.planning.views); every other kind's pool is drawn as before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

import pincal
from pincal.cli.example import example_text
from pincal.errors import Infeasible
from pincal.instruments import Instrument, PerCoordinate
from pincal.instruments.identifiability import identifiable
from pincal.instruments.point import Point
from pincal.instruments.rig import rig_from_dict
from pincal.model.jacobian import JacobianEngine
from pincal.planning import views
from pincal.planning.constraints import with_safety
from pincal.planning.feasibility import Feasibility


@pytest.fixture(scope="module")
def rig():
    return rig_from_dict(yaml.safe_load(example_text("rig")))


@pytest.fixture(scope="module")
def params(rig):
    panda = pincal.load_robot("panda").with_fixtures(*rig.fixtures)
    instrument = Instrument(rig.kind, PerCoordinate(sigma_px=rig.pixel_sigma))
    return identifiable(panda.parameters("full,offsets,instrument"), instrument).identifiable


def _oracle(kind, engine, qs):
    """Three target points or more likely read (weight above 0), not all on one line."""
    read = kind.weights(engine, qs, kind.rows(engine, qs))[:, ::2] > 0
    out = []
    for corners in read:
        points = kind.points[corners]
        out.append(len(points) >= 3 and np.linalg.matrix_rank(points - points.mean(axis=0)) >= 2)
    return np.array(out)


def test_a_view_reads_enough_where_three_points_not_in_a_line_are_likely_read(rig, params):
    engine = JacobianEngine(params)
    qs = params.robot.random_configurations(3000, np.random.default_rng(5))
    reads = rig.kind.reads(engine, qs)
    assert np.array_equal(reads, _oracle(rig.kind, engine, qs))
    assert 50 < reads.sum() < 300  # one view in nineteen (and many read a point or two)
    # a row of the grid alone never reveals the camera's turn about it: three of its points read
    # reveal what all of them would (rank 5)
    row = dataclasses.replace(rig.kind, points=rig.kind.points[:6])
    read = row.weights(engine, qs, row.rows(engine, qs))[:, ::2] > 0
    assert np.array_equal(row.reads(engine, qs), read.sum(axis=1) >= 3)
    assert Point().reads(engine, qs).all()


def test_a_camera_pool_holds_only_views_that_read_enough(rig, params):
    feasibility = Feasibility(params.robot, with_safety(params.robot))
    engine = JacobianEngine(params)
    pool = views.draw_candidates(feasibility, rig.kind, params, 300, np.random.default_rng(2), 20, True)
    assert len(pool) == 300 and _oracle(rig.kind, engine, pool).all()
    assert feasibility.feasible(pool).all()


def test_every_other_kind_draws_its_pool_as_before(params):
    feasibility = Feasibility(params.robot, with_safety(params.robot))
    rngs = np.random.default_rng(7), np.random.default_rng(7)
    drawn = views.draw_candidates(feasibility, Point(), params, 200, rngs[0], 20, False)
    assert np.array_equal(drawn, feasibility.sample(200, rngs[1], minimum=20))
    assert rngs[0].random() == rngs[1].random()  # the same draws: the pool's stream unchanged


def test_a_camera_that_reads_too_little_of_the_target_is_refused_saying_so(rig, params, monkeypatch):
    monkeypatch.setattr(views, "ROUNDS", 2)
    pinhole = dataclasses.replace(rig.kind, camera=dataclasses.replace(rig.kind.camera, width=8, height=8))
    feasibility, rng = Feasibility(params.robot), np.random.default_rng(0)
    with pytest.raises(Infeasible, match=r"image \(eye-in-hand.* at only 0 of 400 feasible configurations"):
        views.draw_candidates(feasibility, pinhole, params, 200, rng, 20, False)
