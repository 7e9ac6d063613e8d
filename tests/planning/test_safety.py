"""Safe by default: a design keeps a margin inside the joint limits and everything the joints move
above the mounting plane, and every report names the smallest margins (checked against hand
computations of the KR 270's geometry and of the limits)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import pincal
from pincal.errors import BadArgument, BadConstraint, Infeasible
from pincal.planning.constraints import (
    DEFAULT_JOINT_LIMITS,
    Clearance,
    JointLimits,
    Mount,
    SelfCollision,
    constraints_from_dict,
    joint_margins,
    satisfied,
    with_safety,
)
from pincal.planning.safety import safety_margins

KR_Q0 = np.radians([0, -60, 60, 0, 45, 0])
FAST = dict(workers=1, starts=4, pool=400)  # a pincal.Search's
pytestmark = pytest.mark.ur10(markers=[(0.1, 0.05, 0.2)])  # the ur10 fixture (tests/conftest.py)


@pytest.fixture(scope="module")
def kr_params(kr270_marker):
    return kr270_marker.parameters("lengths,offsets").identifiable().identifiable


def test_default_margin_is_two_degrees_and_one_centimetre():
    rail = pincal.load_robot("rail_arm")
    margins = joint_margins(rail, [DEFAULT_JOINT_LIMITS])
    np.testing.assert_allclose(margins, np.where(rail.revolute, math.radians(2), 0.01))
    assert not rail.revolute[0]  # the rail is prismatic: 1 cm
    # A given margin is one number for both kinds (the JointLimits of earlier versions) ...
    np.testing.assert_allclose(joint_margins(rail, [JointLimits(0.05)]), 0.05)
    # ... or an angle and a length; the largest of several JointLimits at each joint.
    both = [JointLimits(0.05, 0.002), JointLimits(0.01, 0.003)]
    np.testing.assert_allclose(joint_margins(rail, both), np.where(rail.revolute, 0.05, 0.003))


def test_default_margin_takes_at_most_a_tenth_of_a_narrow_range():
    narrow = pincal.load_robot("planar_2r", joint_ranges={"joint2": (0.0, math.radians(10))})
    margins = joint_margins(narrow, [DEFAULT_JOINT_LIMITS])
    assert margins[1] == pytest.approx(math.radians(1))  # a tenth of 10°, not 2°
    assert margins[0] == pytest.approx(math.radians(2))
    # A margin asked for is honoured whole, or refused.
    with pytest.raises(Infeasible, match="joint2"):
        JointLimits(math.radians(6)).bind(narrow)


def test_with_safety_adds_the_defaults_once(kr270_marker):
    full = with_safety(kr270_marker)
    assert [type(c).__name__ for c in full] == ["JointLimits", "Mount", "SelfCollision", "Clearance"]
    assert full[0] == DEFAULT_JOINT_LIMITS and full[1] == Mount("floor", clearance=0.05)
    assert full[2] == SelfCollision(optional=True) and full[3] == Clearance(0.05)
    assert with_safety(kr270_marker, full) == full  # idempotent
    assert with_safety(kr270_marker, (), 0, "none", clearance=0)[:2] == (JointLimits(0.0), Mount("none"))
    assert with_safety(kr270_marker, (), (0.1, 0.02))[0] == JointLimits(0.1, 0.02)
    with pytest.raises(BadArgument, match="given twice"):
        with_safety(kr270_marker, full, joint_margin=0.1)
    with pytest.raises(BadArgument, match="given twice"):
        with_safety(kr270_marker, full, mount="none")
    with pytest.raises(BadArgument, match="joint_margin"):
        with_safety(kr270_marker, (), joint_margin="2deg")


def test_no_floor_for_a_floating_base_or_a_chain_from_another_root():
    with pytest.warns(pincal.PincalWarning, match="floating base"):
        talos = pincal.load_robot("talos", tip="gripper_left_base_link")
    assert talos.floating and with_safety(talos)[1] == Mount("none")
    arm = pincal.load_robot("kr270", root="link_2")
    assert with_safety(arm)[1] == Mount("none")


def test_mount_heights_against_the_kr270_geometry(kr270_marker):
    bound = Mount("floor").bind(kr270_marker)
    # A1 turns about the vertical, so the origins of A1 and A2 never change height: left out.
    assert "joint_a1 origin" not in bound.names and "joint_a2 origin" not in bound.names
    assert bound.names[:2] == ["joint_a3 origin", "joint_a4 origin"] and bound.names[-1] == "marker 0"
    q = np.radians([[30, -60, 20, 0, 0, 0]])
    heights = bound.margins(pincal.planning.constraints.Kinematics(kr270_marker, q))[0]
    # A2 about +y: the upper arm (1.15 m along x at zero) rises by −1.15 sin q2 above A2 (0.675 m).
    a3 = 0.675 - 1.15 * math.sin(q[0, 1])
    assert heights[0] == pytest.approx(a3, abs=1e-12)
    # The forearm (1.2 m along x, 0.041 m below it) turns by q2 + q3 about +y.
    t = q[0, 1] + q[0, 2]
    assert heights[1] == pytest.approx(a3 - 1.2 * math.sin(t) - 0.041 * math.cos(t), abs=1e-12)
    marker = kr270_marker.points(q)[0, 0, 2]
    assert heights[-1] == pytest.approx(marker, abs=1e-12)
    # Another plane: normal·p ≥ offset, the height is measured from it.
    riser = Mount.parse("0,0,2,-0.8").bind(kr270_marker)
    np.testing.assert_allclose(
        riser.margins(pincal.planning.constraints.Kinematics(kr270_marker, q))[0], heights + 0.8, atol=1e-12
    )


def test_a_planar_arm_in_its_base_plane_has_nothing_to_keep(planar):
    bound = Mount("floor").bind(planar)
    assert bound.names == []
    assert Mount("floor").satisfied(planar, np.array([[0.3, -2.0], [3.0, 3.0]])).all()


def test_mount_parse_and_yaml():
    assert Mount.parse("Ceiling") == Mount("ceiling") and Mount.parse("none").kind == "none"
    plane = Mount.parse("0,0,1,-0.8")
    assert plane.kind == "plane" and plane.offset == -0.8
    for bad in ("roof", "0,0,1", "0,0,0,1"):
        with pytest.raises(BadConstraint):
            Mount.parse(bad)
    with pytest.raises(BadConstraint, match="kind 'plane'"):
        Mount("floor", (1, 0, 0))
    cons = constraints_from_dict(
        {"joint_limits": {"margin_deg": 3, "prismatic": 0.02}, "mount": {"normal": [0, 0, 1], "offset": 0.1}}
    )
    assert cons == (JointLimits(math.radians(3), 0.02), Mount("plane", (0, 0, 1), 0.1))
    assert constraints_from_dict({"mount": "wall"}) == (Mount("wall"),)
    with pytest.raises(BadConstraint, match="not both"):
        constraints_from_dict({"mount": {"plane": "floor", "offset": 1}})


def test_safety_report_names_the_smallest_margins(kr270_marker):
    lo = np.degrees(kr270_marker.lower)
    plan = np.radians(
        [
            [0, -60, 60, 0, 45, 0],
            [0, lo[1] + 1.0, 60, 0, 45, 0],  # 1° from A2's lower limit
            [90, -10, 150, 0, -60, 0],  # forearm folded down: the marker 0.32 m below the floor
        ]
    )
    report = safety_margins(kr270_marker, plan, with_safety(kr270_marker))
    assert report.angle.what == "joint_a2" and report.angle.pose == 1
    assert report.angle.value == pytest.approx(math.radians(1.0), abs=1e-12)
    assert report.angle.required == pytest.approx(math.radians(2)) and not report.angle.ok
    assert report.length is None  # no prismatic joint
    heights = (
        Mount("floor").bind(kr270_marker).margins(pincal.planning.constraints.Kinematics(kr270_marker, plan))
    )
    assert report.floor.value == pytest.approx(heights.min()) and report.floor.value < 0
    assert report.floor.pose == 2 and not report.ok
    text = "\n".join(report.lines())
    assert (
        "joint_a2 1° from its limit at pose 2 (kept: 2°)" in text
        and "below what the constraints keep" in text
    )
    assert report.obstacle is None and "no workcell" in text
    assert json.loads(json.dumps(report.as_dict()))["floor"]["pose"] == 2


def test_default_design_is_safe_and_opting_out_is_possible(kr_params, kr270_marker):
    result = pincal.design(
        kr_params, 6, test_pose=pincal.around(KR_Q0, math.radians(10)), search=pincal.Search(**FAST, seed=3)
    )
    report = safety_margins(kr270_marker, result.plan, with_safety(kr270_marker))
    assert report.ok, report.lines()
    assert report.angle.value >= math.radians(2) - 1e-9 and report.floor.value >= 0
    assert satisfied(kr270_marker, result.plan, with_safety(kr270_marker)).all()
    free = pincal.design(
        kr_params,
        6,
        test_pose=KR_Q0,
        search=pincal.Search(**FAST, seed=3),
        safety=pincal.Safety(joint_margin=0, mount="none"),
    )  # no margin asked: still within the URDF limits
    assert safety_margins(kr270_marker, free.plan).angle.value >= -1e-9


def test_cli_design_reports_safety_and_takes_the_options(tmp_path, cli):
    argv = ["design", "kr270", "-m", "9", "--test-pose=0,-60,60,0,45,0", "--deg", "--marker", "0.1,0.05,0.2"]
    argv += [
        "--params",
        "lengths,offsets",
        "--starts",
        "2",
        "--workers",
        "1",
        "--pool-size",
        "300",
        "--no-accuracy",
    ]
    safety = cli.json(*argv, "--joint-margin", "5deg")["safety"]
    assert safety["ok"] and safety["joint_limit_angle"]["required"] == pytest.approx(math.radians(5))
    assert safety["joint_limit_angle"]["value"] >= math.radians(5) - 1e-9
    assert safety["floor"]["value"] >= 0 and safety["mount"].startswith("floor")
    code, out, _ = cli.run(*argv, "--mount", "none", "--joint-margin", "0")
    assert code == 0 and "safety (smallest margins" in out and "floor: not checked (mount none)" in out
    cell = tmp_path / "cell.yaml"
    cell.write_text("joint_limits: {margin_deg: 3}\n")
    cli.fails(*argv, "--joint-margin", "2parsecs", match="--joint-margin angle")
    cli.fails(*argv, "--mount", "roof", match="mount 'roof'")
    cli.fails(*argv, "--constraints", cell, "--joint-margin", "1deg", match="keep one")


def test_show_and_evaluate_report_the_margins(tmp_path, cli, kr270_marker):
    plan = tmp_path / "plan.csv"
    qs = np.radians([[0, -60, 60, 0, 45, 0], [90, -10, 150, 0, -60, 0], [30, -80, 90, 0, 30, 0]])
    pincal.Plan.for_robot(kr270_marker, qs).to_csv(plan, degrees=True)
    robot = ["kr270", "--plan", plan, "--deg", "--marker", "0.1,0.05,0.2", "--params", "offsets"]
    robot += ["--test-pose=0,-60,60,0,45,0"]
    expected = safety_margins(kr270_marker, qs, with_safety(kr270_marker))
    for command in (["show", *robot, "--html", tmp_path / "scene.html"], ["evaluate", *robot]):
        safety = cli.json(*command, "--no-accuracy")["safety"]
        assert safety["floor"]["pose"] == 1 and safety["floor"]["value"] == pytest.approx(
            expected.floor.value
        )
        assert not safety["ok"] and safety["floor"]["what"] == expected.floor.what


# A UR10 folded with its forearm through its shoulder (the pose test_campaign names): its meshes
# overlap by more than 5 cm; "fine" is clear of itself.
UR10_FOLDED = np.radians([6.0, -149.4, -178.0, 209.7, -112.7, -49.8])
UR10_FINE = np.radians([20.5, -64.5, 106.0, -100.3, -123.1, 48.5])


def test_safety_report_names_a_pose_where_the_robot_meets_itself(ur10):
    with pytest.warns(pincal.PincalWarning, match="pose 2 of the plan: the robot collides with itself") as w:
        report = safety_margins(ur10, np.vstack([UR10_FINE, UR10_FOLDED]), with_safety(ur10))
    s = report.self_collision
    assert s.pose == 1 and s.value < -0.05 and not s.ok and not report.ok
    assert s.what in str(w[0].message) and s.what.count(" / ") == 1  # the pair, named
    # The campaign's own check of the pose finds it as deep (the same geometry, the same pairs).
    campaign = pincal.plan_campaign(ur10, np.vstack([UR10_FINE, UR10_FOLDED]), home=UR10_FINE)
    assert s.value == pytest.approx(campaign.pose_clearance[1], abs=1e-9)
    text = "\n".join(report.lines())
    assert f"self-collision: {s.what} overlap (by up to" in text and "at pose 2" in text
    assert "collides with itself" in text and "URDF's collision geometry" in text
    assert json.loads(json.dumps(report.as_dict()))["self_collision"]["pose"] == 1
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning for a clear plan
        clear = safety_margins(ur10, UR10_FINE[None], with_safety(ur10))
    assert clear.self_collision.value > 0 and clear.self_collision.ok and clear.ok
    assert safety_margins(ur10, UR10_FINE[None], self_collision=False).self_collision is None
    # A clearance asked between links is the one required.
    with pytest.warns(pincal.PincalWarning, match="pose 1 of the plan: two links of the robot come closer"):
        kept = safety_margins(ur10, UR10_FINE[None], [*with_safety(ur10), SelfCollision(min_distance=0.5)])
    assert kept.self_collision.required == 0.5 and not kept.ok


def test_design_and_evaluate_warn_of_a_folded_pose(tmp_path, cli, ur10):
    """A design keeps clear of its own links by default (the UR10 has collision geometry): a pool
    pose where the robot meets itself is dropped, named; evaluate checks a plan's poses and warns,
    naming the pose and the pair."""
    from pincal.model.collision import CollisionWorld
    from pincal.planning.feasibility import Feasibility

    world = CollisionWorld(ur10, ())
    drawn = Feasibility(ur10, with_safety(ur10)).sample(40, np.random.default_rng(1))
    clear = drawn[world.distances_many(drawn).min(axis=1) > 0.01][:12]
    pool = tmp_path / "pool.csv"
    pincal.Plan.for_robot(ur10, np.vstack([clear, UR10_FOLDED])).to_csv(pool, degrees=True)
    argv = ["ur10", "--marker", "0.1,0.05,0.2", "--deg", "--test-pose=0,-70,90,-110,-90,0", "--no-accuracy"]
    design = ["design", *argv, "--pool", pool, "--starts", 2, "--workers", 1, "--json", "--clearance", 0]
    code, out, err = cli.run(*design, "-m", 12)  # the folded pose is dropped from the pool, named
    assert code == 0, err
    payload = json.loads(out)
    assert "1 of the 13 pool configurations dropped (self collision 1)" in err
    assert payload["safety"]["self_collision"]["value"] > 0 and payload["safety"]["ok"]
    cli.fails(*design, "-m", 13, match="only 12 of the 13 pool configurations")
    evaluated = cli.run("evaluate", *argv, "--plan", pool)
    assert evaluated.code == 0 and "pose 13 of the plan: the robot collides with itself" in evaluated.err
    assert "self-collision: " in evaluated.out and "overlap (by up to" in evaluated.out
    assert "at pose 13" in evaluated.out


def test_geometry_coal_cannot_take_leaves_the_links_unchecked_and_says_so(ur10, monkeypatch):
    """Some published meshes have no convex hull coal can build (centauro's: "Too many neighbor"):
    the report then says the links were not checked, and the rest of it stands."""
    import pincal.planning.safety as safety

    def refuse(*args, **kwargs):
        raise RuntimeError("From file: convex.cpp\nat line: 186\nmessage: Too many neighbor")

    monkeypatch.setattr(safety, "CollisionWorld", refuse)
    report = safety_margins(ur10, UR10_FOLDED[None], with_safety(ur10))
    assert report.self_collision is None and report.floor is not None
    assert (
        report.self_note
        == "links not checked: coal could not take the collision geometry (Too many neighbor)"
    )
    assert f"  ({report.self_note})" in report.lines()


def test_meshes_without_a_convex_hull_are_checked_as_they_are():
    """centauro ships meshes qhull cannot hull ("Too many neighbors"): they are kept as meshes (their
    distances their own), so the report and a campaign check its links like any robot's."""
    from tests.support.robot_zoo import chain_of

    robot = chain_of("centauro").robot
    qs = robot.random_configurations(3, 0)
    report = safety_margins(robot, qs, with_safety(robot))
    assert report.self_collision is not None and "URDF's collision geometry" in report.self_note
    campaign = pincal.plan_campaign(robot, qs, home=qs[0])
    assert campaign.geometry.startswith("the URDF's collision geometry") and campaign.checked
