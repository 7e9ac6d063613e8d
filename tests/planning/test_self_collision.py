"""The self-collision check made cheap without changing what it decides, and its opt-out (issue 32
item 4): the bound measures only the pairs whose bounding spheres come within reach; an oracle
here measures every pair at every configuration, as the check did before."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import BadArgument, BadConstraint
from pincal.planning.constraints import Kinematics, SelfCollision, constraints_from_dict, with_safety
from pincal.planning.constraints.self_collision import memoryless
from pincal.planning.feasibility import Feasibility
from tests.conftest import ROOT


def all_pairs(bound, qs: np.ndarray, warm: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The oracle: every pair's convex-hull distance less the clearance (m, pairs), and the exact
    check (m,), every pair measured at every configuration with Pinocchio's all-pairs calls (as the
    check ran before it culled); ``warm``: coal's GJK warm-started from the pair's previous call,
    as it was then."""
    hulls, exact = bound.hulls.createData(), bound.exact.createData()
    for request in exact.collisionRequests:
        request.security_margin = bound.min_distance
    if not warm:
        for request in [*hulls.distanceRequests, *exact.collisionRequests]:
            memoryless(request)
    thetas = bound.forward.joint_values(qs, None)
    margins, ok = np.empty((len(qs), len(bound.names))), np.empty(len(qs), dtype=bool)
    for i, theta in enumerate(thetas):
        pin.updateGeometryPlacements(bound.model, bound.data, bound.hulls, hulls, theta)
        pin.computeDistances(bound.hulls, hulls)
        margins[i] = [r.min_distance for r in hulls.distanceResults]
        ok[i] = not pin.computeCollisions(bound.model, bound.data, bound.exact, exact, theta, True)
    return margins - bound.min_distance, ok


def robot_named(name: str):
    return pincal.load_robot(name, tip="gripper_left_base_link" if name == "tiago_pro" else None)


@pytest.mark.parametrize(
    ("name", "n", "clearance"),
    [("ur10", 2000, 0.0), ("ur10", 500, 0.01), ("panda", 2000, 0.0), ("tiago_pro", 300, 0.0)],
)
def test_the_culled_check_decides_as_the_all_pairs_check(name, n, clearance):
    robot = robot_named(name)
    bound = SelfCollision(clearance).bind(robot)
    qs = robot.random_configurations(n, 7)
    kin = Kinematics(robot, qs)
    margins, ok = bound.margins(kin), bound.satisfied(kin)
    oracle, oracle_ok = all_pairs(bound, qs)
    _, before_ok = all_pairs(bound, qs, warm=True)
    assert 0.02 < (~ok).mean() < 0.5  # the sample holds both kinds
    assert np.array_equal(ok, oracle_ok) and np.array_equal(ok, before_ok)  # the same feasibility
    assert np.array_equal(bound.strictly_satisfied(kin), ok & np.all(oracle > 0, axis=1))
    # What the search reads, min(margin / reach, 1), is the oracle's; a pair not measured has a
    # lower bound of its distance there, beyond the reach like the distance itself.
    reach = bound.reach
    thetas = bound.forward.joint_values(qs, None)
    culled = (
        bound.hull_spheres.lower_bounds(*bound.forward.batch_placements(thetas))
        >= bound.min_distance + reach + 1e-3
    )
    assert culled.mean() > 0.3  # most pairs at most configurations are not measured
    assert np.all(oracle[culled] >= margins[culled] - 1e-9) and np.all(oracle[culled] >= reach)
    np.testing.assert_allclose(np.minimum(margins, reach), np.minimum(oracle, reach), rtol=0, atol=2e-6)
    if name != "tiago_pro":  # some of its shape pairs keep some state in coal (< 1e-6 m)
        assert np.array_equal(np.minimum(margins / reach, 1), np.minimum(oracle / reach, 1))


def test_few_pairs_are_measured():
    """Most pairs of a large robot are far apart at most configurations: tiago_pro's 547 pairs,
    about 7 % measured (its base, torso, head and other arm against the moving arm)."""
    robot = robot_named("tiago_pro")
    bound = SelfCollision().bind(robot)
    thetas = bound.forward.joint_values(robot.random_configurations(300, 7), None)
    lower = bound.hull_spheres.lower_bounds(*bound.forward.batch_placements(thetas))
    oracle, _ = all_pairs(bound, robot.random_configurations(300, 7))
    assert np.all(lower <= oracle + 1e-9)  # the spheres bound the distances from below
    measured = (lower < bound.reach + 1e-3).mean()
    assert len(bound.names) == 547 and measured < 0.15


def test_a_distance_does_not_depend_on_what_was_measured_before(ur10):
    """coal's GJK is not warm-started from a pair's previous call: a configuration's margins are
    the same in any order (a worker's earlier starts no longer move a later start)."""
    bound = SelfCollision().bind(ur10)
    qs = ur10.random_configurations(300, 3)
    forward = bound.margins(Kinematics(ur10, qs))
    assert np.array_equal(forward, bound.margins(Kinematics(ur10, qs[::-1]))[::-1])
    warm, _ = all_pairs(bound, qs, warm=True)
    warm_back, _ = all_pairs(bound, qs[::-1], warm=True)
    assert not np.array_equal(warm, warm_back[::-1])  # as it was: the order moved the distances


def test_self_collision_can_be_turned_off_in_python(ur10):
    off = SelfCollision(enabled=False)
    assert off.bind(ur10).empty
    for constraints in (with_safety(ur10, [off]), with_safety(ur10, self_collision=False)):
        selfs = [c for c in constraints if isinstance(c, SelfCollision)]
        assert selfs == [SelfCollision(optional=selfs[0].optional, enabled=False)]
        assert "self_collision" not in [key for key, _ in Feasibility(ur10, constraints).bound]
    assert "self_collision" in [key for key, _ in Feasibility(ur10, with_safety(ur10)).bound]
    once = with_safety(ur10, self_collision=False)
    assert with_safety(ur10, once) == once  # idempotent
    with pytest.raises(BadArgument, match="self-collision is both turned off"):
        with_safety(ur10, [SelfCollision(0.01)], self_collision=False)
    with pytest.raises(BadConstraint, match="enabled must be True or False"):
        SelfCollision(enabled=1)  # type: ignore[arg-type]
    # A constraints file: false turns it off (it used to mean the same as no entry).
    assert constraints_from_dict({"self_collision": False}) == (SelfCollision(enabled=False),)
    assert constraints_from_dict({"self_collision": True}) == (SelfCollision(),)


def test_self_collision_off_on_the_command_line(tmp_path, cli, ur10):
    """--self-collision off: a pool pose where the UR10 folds through itself is kept, and the
    report's self-collision line says the design did not keep the links apart."""
    from tests.planning.test_safety import UR10_FINE, UR10_FOLDED

    rng = np.random.default_rng(1)
    drawn = Feasibility(ur10, with_safety(ur10)).sample(200, rng)
    bound = SelfCollision(0.01).bind(ur10)  # (forearm and wrist 2 are never 2 cm apart)
    clear = drawn[bound.satisfied(Kinematics(ur10, drawn))][:11]
    pool = tmp_path / "pool.csv"
    pincal.Plan.for_robot(ur10, np.vstack([clear, UR10_FINE, UR10_FOLDED])).to_csv(pool, degrees=True)
    argv = ["ur10", "--marker", "0.1,0.05,0.2", "--deg", "--test-pose=0,-70,90,-110,-90,0", "--no-accuracy"]
    design = ["design", *argv, "--pool", pool, "--starts", 1, "--workers", 1, "--clearance", 0, "-m", 13]
    cli.fails(*design, match="only 12 of the 13 pool configurations")  # on by default
    code, out, err = cli.run(*design, "--self-collision", "off")
    assert code == 0, err
    assert "self-collision (off: not kept by the design): " in out and "collides with itself" in out
    assert "designed with the self-collision check off" in err
    payload = json.loads(cli.run(*design, "--self-collision", "off", "--json").out)
    assert payload["safety"]["self_note"].startswith("self-collision off") and not payload["safety"]["ok"]
    rules = tmp_path / "cell.yaml"
    rules.write_text("self_collision: {min_distance: 0.01}\n")
    cli.fails(*design, "--constraints", rules, "--self-collision", "off", match="--self-collision")
    for command in ("design", "next", "baseline"):
        assert "--self-collision {on,off}" in cli.run(command, "--help").out


def test_the_readme_says_how_to_turn_it_off():
    readme = (ROOT / "README.md").read_text()
    assert "--self-collision off" in readme and "SelfCollision(enabled=False)" in readme
