"""Safe by default, the clearance (issue 32): a design keeps its markers, tip and link origins 5 cm
above the floor and 5 cm from every obstacle (the uncalibrated robot's error and the marker's size),
keeps the robot clear of itself when its URDF has collision geometry, and a campaign calls nothing
closer than that clear."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pincal
from pincal.calibration.synthetic import random_errors
from pincal.errors import BadArgument
from pincal.model.collision import CollisionWorld
from pincal.planning.constraints import (
    DEFAULT_CLEARANCE,
    Clearance,
    Mount,
    Obstacle,
    SelfCollision,
    Workcell,
    constraints_from_dict,
    with_safety,
)
from pincal.planning.feasibility import Feasibility
from pincal.planning.safety import safety_margins

README = ["kr270", "-m", "12", "--test-pose=0,-60,60,0,45,0", "--around", "10deg", "--deg"]
README += ["--marker", "0.1,0.05,0.2"]
FAST = ["--starts", "2", "--workers", "1", "--no-accuracy", "--json"]


def heights(robot: pincal.Robot, qs: np.ndarray) -> np.ndarray:
    """(m, points) every moving marker, tip and link origin above the floor [m]."""
    bound = Mount("floor").bind(robot)
    return bound.batch_points(qs)[:, bound.keep] @ bound.normal


@pytest.fixture(scope="module")
def readme_plan(tmp_path_factory):
    """The README's design (fewer starts), through the CLI, and the robot it was designed for."""
    import contextlib
    import io

    from pincal.cli import main

    out, printed = tmp_path_factory.mktemp("readme") / "plan.csv", io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(io.StringIO()):
        assert main(["design", *README, *FAST, "--out", str(out)]) == 0
    payload = json.loads(printed.getvalue())
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    return robot, np.array(payload["plan"]), payload


def test_default_clearance_is_five_centimetres_from_floor_and_obstacles(kr270_marker):
    table = Workcell((Obstacle("table", "box", (1, 1, 0.1), (1.9, 0, 0.4)),), min_distance=0.02)
    full = with_safety(kr270_marker, [table])
    assert DEFAULT_CLEARANCE == 0.05 and Clearance(0.05) in full
    mount = next(c for c in full if isinstance(c, Mount))
    cell = next(c for c in full if isinstance(c, Workcell))
    assert mount.clearance == 0.05 and cell.min_distance == 0.05
    assert with_safety(kr270_marker, full) == full  # idempotent
    # 0 keeps what the constraints ask themselves; a larger min_distance of the cell's own is kept.
    off = with_safety(kr270_marker, [table], clearance=0)
    assert next(c for c in off if isinstance(c, Mount)).clearance == 0
    assert next(c for c in off if isinstance(c, Workcell)).min_distance == 0.02
    assert with_safety(kr270_marker, off) == off  # 0 survives the defaults added again (a design inside next)
    wide = with_safety(kr270_marker, [Workcell(table.obstacles, min_distance=0.2)])
    assert next(c for c in wide if isinstance(c, Workcell)).min_distance == 0.2
    with pytest.raises(BadArgument, match="given twice"):
        with_safety(kr270_marker, full, clearance=0.1)
    with pytest.raises(BadArgument, match="clearance"):
        with_safety(kr270_marker, clearance=-1)
    assert Clearance(0.1) in constraints_from_dict({"clearance": 0.1})


def test_readme_design_keeps_the_clearance_from_the_floor_at_every_pose(readme_plan):
    robot, qs, payload = readme_plan
    assert heights(robot, qs).min() >= DEFAULT_CLEARANCE - 1e-9  # markers, tip, link origins
    floor = payload["safety"]["floor"]
    assert floor["required"] == DEFAULT_CLEARANCE and floor["value"] >= DEFAULT_CLEARANCE - 1e-9


def test_a_robot_with_1mm_errors_stays_above_the_floor(readme_plan):
    robot, qs, _ = readme_plan
    params = robot.parameters()
    lowest = min(
        heights(random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=s).robot, qs).min()
        for s in range(20)
    )
    assert lowest > 0.03  # the errors move the points by millimetres: 5 cm covers them


def test_clearance_0_restores_the_old_behaviour(cli, kr270_marker):
    payload = cli.json("design", *README, *FAST, "--clearance", "0")
    assert payload["safety"]["floor"]["required"] == 0
    assert payload["safety"]["floor"]["value"] < DEFAULT_CLEARANCE  # the search goes to the floor again
    # The KR 270's URDF has no collision geometry: nothing else was added.
    feasibility = Feasibility(kr270_marker, with_safety(kr270_marker, clearance=0))
    assert [key for key, _ in feasibility.bound] == ["mount"]
    cli.fails("design", *README, *FAST, "--clearance", "5parsecs", match="--clearance")


def test_a_default_ur10_design_holds_no_self_colliding_pose():
    ur10 = pincal.load_robot("ur10", markers=[(0.1, 0.05, 0.2)])
    params = ur10.parameters("lengths,offsets").identifiable().identifiable
    q0 = np.radians([20.5, -64.5, 106.0, -100.3, -123.1, 48.5])
    result = pincal.design(params, 10, q0, search=pincal.Search(seed=0, workers=1, starts=2, pool=400))
    assert SelfCollision().satisfied(ur10, result.plan).all()
    assert CollisionWorld(ur10, ()).distances_many(result.plan.q).min() > 0
    report = safety_margins(ur10, result.plan, with_safety(ur10))
    assert report.ok and report.self_collision.value > 0 and report.floor.value >= DEFAULT_CLEARANCE - 1e-9


def test_campaign_reports_a_pose_closer_than_the_clearance(cli, tmp_path, kr270_marker):
    drawn = Feasibility(kr270_marker, with_safety(kr270_marker, clearance=0)).sample(
        400, np.random.default_rng(2)
    )
    low = heights(kr270_marker, drawn).min(axis=1)
    close = drawn[np.flatnonzero((low > 0.01) & (low < 0.04))[0]]
    fine = drawn[np.flatnonzero(low > 0.3)[0]]
    plan = np.vstack([fine, close])
    campaign = pincal.plan_campaign(kr270_marker, plan, home=fine)
    assert campaign.unsafe_poses == (1,) and campaign.closest_pose == 1
    assert campaign.required["floor"] == DEFAULT_CLEARANCE
    text = "\n".join(campaign.lines())
    assert "pose 2 itself is too close" in text and "closest pose: pose 2" in text
    assert "closer than the clearance" in text
    assert not all(mv.clear for mv in campaign.moves)  # a move to it is not clear either
    old = pincal.plan_campaign(kr270_marker, plan, home=fine, clearance=0)
    assert old.unsafe_poses == () and all(mv.clear for mv in old.moves)
    path = tmp_path / "plan.csv"
    pincal.Plan.for_robot(kr270_marker, plan).to_csv(path)
    argv = [
        "campaign",
        "kr270",
        "--plan",
        path,
        "--marker",
        "0.1,0.05,0.2",
        "--home=" + ",".join(map(str, fine)),
    ]
    payload = cli.json(*argv)
    assert payload["unsafe_poses"] == [1] and payload["closest_pose"] == 1 and not payload["safety"]["ok"]
    assert cli.json(*argv, "--clearance", "0")["unsafe_poses"] == []
    assert json.dumps(payload)  # serialisable
