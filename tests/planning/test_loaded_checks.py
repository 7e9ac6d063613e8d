"""A loaded design checks each (configuration, payload) candidate under its own payload: a robot
with joint compliances yields to the payload it carries, towards the floor, the cell or itself.

The oracle is a plane the unloaded robot clears and the loaded, compliant one does not (heights
from Pinocchio under the payload, :mod:`tests.support.kinematics_oracle`)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal
from pincal.campaign.schedule import plan_campaign
from pincal.errors import DegenerateOptimumWarning, Infeasible
from pincal.model.statics import Payload
from pincal.planning.constraints import Mount, Obstacle, Workcell, with_safety
from pincal.planning.feasibility import Feasibility
from pincal.planning.safety import safety_margins
from tests.support.kinematics_oracle import heights

COMPLIANCES = np.array([0.0, 2e-6, 3e-6, 0.0, 0.0, 0.0])  # rad/(N·m): industrial
HEAVY = Payload(270.0, (0.0, 0.0, 0.2))
LOADS = np.vstack([np.zeros(4), HEAVY.row])
PLANE = 0.4  # [m] above the base: the plane z = PLANE of the base frame
Q0 = np.radians([0, -60, 60, 0, 45, 0])


@pytest.fixture(scope="module")
def compliant(kr270_marker):
    return kr270_marker.replace(joint_compliances=COMPLIANCES)


def lowest(robot: pincal.Robot, qs: np.ndarray, payload: Payload | None = None) -> np.ndarray:
    """(m,) the oracle's lowest moving point at each reading (the points the mount keeps)."""
    keep = Mount("floor").bind(robot).keep
    return np.array([heights(robot, q, payload)[keep].min() for q in qs])


@pytest.fixture(scope="module")
def pool(compliant):
    """(dipping, free): 40 configurations the unloaded robot holds above the plane and the loaded
    one below it, 40 it holds above it either way (by 5 cm)."""
    plane = Mount("plane", (0, 0, 1), PLANE).bind(compliant)
    margin = np.radians(3.0)  # inside the design's joint margins (2°)
    rng = np.random.default_rng(2)
    qs = rng.uniform(compliant.lower + margin, compliant.upper - margin, (20000, compliant.nq))
    bare = plane.heights(qs).min(axis=1)
    loaded = plane.heights(qs, np.repeat(LOADS[1:], len(qs), axis=0)).min(axis=1)  # rows below the door
    dipping = qs[(bare > 1e-4) & (loaded < -1e-4)][:40]
    free = qs[loaded > 0.05][:40]
    # The oracle agrees: these clear the plane unloaded, and not under the payload.
    assert len(dipping) == 40 and np.all(lowest(compliant, dipping) > PLANE)
    assert np.all(lowest(compliant, dipping, HEAVY) < PLANE)
    return dipping, free


def test_a_candidate_is_checked_under_its_own_payload(compliant, kr270_marker, pool):
    dipping, free = pool
    constraints = [Mount("plane", (0, 0, 1), PLANE)]
    feasibility = Feasibility(compliant, constraints)
    assert feasibility.loaded
    qs, rows = feasibility.feasible_pairs(np.vstack([dipping, free]), LOADS)
    # Every dipping configuration unloaded only, every free one with both payloads, in order.
    expected = np.vstack([dipping, np.repeat(free, 2, axis=0)])
    np.testing.assert_array_equal(qs, expected)
    np.testing.assert_array_equal(rows, np.vstack([np.zeros((40, 4)), np.tile(LOADS, (40, 1))]))
    # The rigid robot: the payload moves nothing, every pair is kept.
    rigid = Feasibility(kr270_marker, constraints)
    assert not rigid.loaded
    assert len(rigid.feasible_pairs(dipping, LOADS)[0]) == 80
    # A taught configuration is kept when it is feasible under one payload at least.
    kept, dropped = feasibility.feasible_pool(dipping, 1, LOADS)
    np.testing.assert_array_equal(kept, dipping)
    assert dropped == 0
    with pytest.raises(Infeasible, match=r"only 0 of the 40 pool configurations .*\(mount 40\)"):
        feasibility.feasible_pool(dipping, 1, LOADS[1:])  # under the heavy payload alone


def test_a_loaded_design_keeps_each_pose_clear_under_its_payload(compliant, pool):
    """A taught pool whose half dips below the plane under the payload: the plan mounts the
    payload only where the loaded robot clears the plane (the oracle's heights), and the dipping
    configurations it keeps are unloaded."""
    dipping, free = pool
    params = compliant.parameters("lengths,offsets,compliance")
    params = params.identifiable(payloads=[0.0, 270.0]).identifiable
    search = pincal.Search(pool=np.vstack([dipping, free]), starts=2, workers=1, seed=0)
    safety = pincal.Safety(mount=Mount("plane", (0, 0, 1), PLANE), clearance=0.0)
    loads = pincal.Loads(payloads=[0.0, HEAVY])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateOptimumWarning)
        result = pincal.design(params, 12, Q0, search=search, safety=safety, loads=loads)
    plan = result.plan
    assert plan.payload is not None and set(plan.payload[:, 0]) == {0.0, 270.0}
    for q, row in zip(plan.q, plan.payload, strict=True):
        load = Payload(row[0], tuple(row[1:])) if row[0] else None
        assert lowest(compliant, q[None], load)[0] >= PLANE - 1e-9
    is_dipping = [bool(np.any(np.all(q == dipping, axis=1))) for q in plan.q]
    assert not np.any(plan.payload[is_dipping, 0])


def test_a_campaign_checks_each_pose_and_move_under_its_payload(compliant, kr270_marker, pool):
    """The campaign of a plan that mounts the payload at a dipping pose: that pose is below the
    plane by the oracle's depth, and so is every move to or from it; unloaded, it clears the plane
    by the oracle's height. A rigid robot's campaign does not depend on the payloads. The plan's
    safety report says the same."""
    dipping, free = pool
    qs = np.vstack([dipping[:1], free[:1]])
    options = dict(mount=Mount("plane", (0, 0, 1), PLANE), clearance=0.0, self_collision=False)
    loaded = pincal.Plan.for_robot(compliant, qs, payload=[HEAVY, Payload(0.0)])
    campaign = plan_campaign(compliant, loaded, **options)
    bare = plan_campaign(compliant, qs, **options)
    for i, load in enumerate([HEAVY, None]):
        depth = lowest(compliant, qs[i : i + 1], load)[0] - PLANE
        assert campaign.pose_clearance[i] == pytest.approx(depth, abs=1e-9)
    assert campaign.pose_clearance[0] < 0 < bare.pose_clearance[0]
    assert bare.pose_clearance[0] == pytest.approx(lowest(compliant, qs[:1])[0] - PLANE, abs=1e-9)
    for move in campaign.moves:
        if 0 in (move.start, move.end):
            assert not move.check.clear and move.check.sampled < 0
    rigid = [plan_campaign(kr270_marker, p, **options) for p in (qs, loaded)]
    np.testing.assert_array_equal(rigid[0].pose_clearance, rigid[1].pose_clearance)
    # The safety report of the plan: the floor under each pose's payload.
    constraints = with_safety(compliant, mount=options["mount"], clearance=0.0)
    floors = [safety_margins(compliant, p, constraints, self_collision=False).floor for p in (loaded, qs)]
    assert floors[0] is not None and floors[0].pose == 0
    assert floors[0].value == pytest.approx(campaign.pose_clearance[0], abs=1e-9)
    assert floors[1] is not None and floors[1].value > 0


def test_the_workcell_is_checked_under_the_candidates_payload(compliant, pool):
    """A small ball where the loaded robot's marker is at a dipping pose: the unloaded robot clears
    it, the loaded one touches it; the pairs say so."""
    q = pool[0][0]
    marker = compliant.points(q, payload=HEAVY)[0, 0]  # base frame (the robot has no base placement)
    assert np.linalg.norm(marker - compliant.points(q)[0, 0]) > 5e-3
    cell = Workcell((Obstacle("ball", "sphere", (1e-3,), tuple(marker)),), link_radius=0.01)
    feasibility = Feasibility(compliant, [cell])
    qs, rows = feasibility.feasible_pairs(q[None], LOADS)
    np.testing.assert_array_equal(rows, np.zeros((1, 4)))
