"""From plan to campaign: the time model against hand computation, the ordering against brute force,
the motion certification against hand-built scenes with known distances, detours, line of sight,
the campaign command and its animation."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

import pincal
from pincal.arguments import DEFAULT_SIGMA
from pincal.campaign.line_of_sight import occlusions
from pincal.campaign.motion import certify_move, find_detour
from pincal.campaign.ordering import EXACT_LIMIT, best_tour, held_karp, improve, tour_cost
from pincal.campaign.result import HOME
from pincal.campaign.schedule import plan_campaign
from pincal.campaign.timing import DWELLS, Timing
from pincal.errors import BadArgument
from pincal.model.collision import TOUCHING, with_exact
from pincal.planning.constraints import Mount, Obstacle, Workcell

R = 0.05  # capsule radius of the planar scenes [m]


@pytest.fixture(scope="module")
def planar2():
    return pincal.load_robot("planar_2r")


def planar_world(robot, obstacles, **kw):
    return Workcell(tuple(obstacles), link_radius=R).world(robot, **kw)


# ------------------------------------------------------------------------------------ timing
def test_move_time_is_the_slowest_joint_by_hand(kr270):
    timing = Timing.for_robot(kr270, settle=0.5, dwell="tracker")
    v = np.radians([105, 101, 107, 122, 113, 175])  # the KR 270's maximum speeds (its URDF)
    np.testing.assert_allclose(timing.speeds, v, rtol=1e-12)
    a = np.radians([0, -90, 90, 0, 0, 0])
    b = np.radians([90, -60, 100, 30, 10, 200])
    # Joint times 90/105, 30/101, 10/107, 30/122, 10/113, 200/175 s: A6 is the slowest.
    assert timing.move_time(a, b) == pytest.approx(200 / 175, rel=1e-12)
    assert timing.stop == 2.5 and timing.dwell == DWELLS["tracker"] == 2.0
    slow = Timing.for_robot(kr270, speed_fraction=0.5, dwell="probe")
    assert slow.move_time(a, b) == pytest.approx(400 / 175) and slow.dwell == 10.0


def test_trapezoid_and_triangle_by_hand(planar2):
    timing = Timing.for_robot(planar2, speeds=[1.0, 2.0], accelerations=[2.0, 1.0])
    # Joint 1: v²/a = 0.5 ≤ 3, a trapezoid: 3/1 + 1/2 = 3.5 s. Joint 2: v²/a = 4 > 1, a triangle:
    # 2√(1/1) = 2 s.
    np.testing.assert_allclose(timing.joint_times(np.zeros(2), np.array([3.0, -1.0])), [3.5, 2.0])
    # At the switch (d = v²/a) both expressions give 2v/a.
    assert timing.joint_times(np.zeros(2), np.array([0.5, 4.0])) == pytest.approx([1.0, 4.0])
    m = timing.matrix(np.array([[0.0, 0.0], [3.0, -1.0], [0.5, 4.0]]))
    assert m[0, 1] == pytest.approx(3.5) and np.allclose(m, m.T) and np.all(np.diag(m) == 0)


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(speeds=[1.0]), None),
        (dict(speeds=[1.0, 0.0]), "speeds must be 2 numbers from 1e-06 to 1000"),
        (dict(accelerations=[1, 2, 3]), "accelerations must be 2"),
        (dict(speed_fraction=1.5), "speed_fraction"),
        (dict(dwell="laser"), "dwell must be seconds"),
        (dict(settle=-1), "settle"),
    ],
)
def test_timing_arguments_are_checked(planar2, kw, match):
    if match is None:
        np.testing.assert_allclose(Timing.for_robot(planar2, **kw).speeds, [1.0, 1.0])
        return
    with pytest.raises(BadArgument, match=match):
        Timing.for_robot(planar2, **kw)


# ---------------------------------------------------------------------------------- ordering
def test_held_karp_equals_brute_force():
    rng = np.random.default_rng(0)
    for n in range(1, 8):
        for _ in range(4):
            points = rng.random((n + 1, 3))
            cost = np.abs(points[:, None] - points[None]).max(axis=-1)  # a max-norm metric, like move times
            brute = min(tour_cost(cost, p) for p in itertools.permutations(range(1, n + 1)))
            tour = held_karp(cost)
            assert sorted(tour.order) == list(range(1, n + 1)) and tour.exact
            assert tour.cost == pytest.approx(brute, abs=1e-12) == tour_cost(cost, tour.order)


def test_the_heuristic_ends_at_a_local_optimum_near_the_exact_one():
    rng = np.random.default_rng(1)
    for n in (10, 12):
        points = rng.random((n + 1, 6))
        cost = np.abs(points[:, None] - points[None]).max(axis=-1)
        order = improve(cost, list(range(1, n + 1)))
        path = [0, *order, 0]
        value = tour_cost(cost, order)
        # No 2-opt move (reversing path[i..k]) shortens it: the oracle tries them all.
        for i in range(1, n + 1):
            for k in range(i + 1, n + 1):
                assert (
                    tour_cost(cost, (path[:i] + path[i : k + 1][::-1] + path[k + 1 :])[1:-1]) >= value - 1e-12
                )
        # Nor moving one pose elsewhere (Or-opt with runs of 1).
        for i in range(n):
            rest = order[:i] + order[i + 1 :]
            for j in range(n):
                assert tour_cost(cost, rest[:j] + [order[i]] + rest[j:]) >= value - 1e-12
        assert held_karp(cost).cost <= value <= 1.1 * held_karp(cost).cost
    # Beyond the exact limit, best_tour uses the local search, and is never worse than the given order.
    points = rng.random((EXACT_LIMIT + 9, 6))
    cost = np.abs(points[:, None] - points[None]).max(axis=-1)
    tour = best_tour(cost, list(range(1, EXACT_LIMIT + 9)))
    assert not tour.exact and tour.cost <= tour_cost(cost, range(1, EXACT_LIMIT + 9))


# --------------------------------------------------------------------------- certified moves
def test_a_sweep_through_an_obstacle_is_blocked_where_it_hits(planar2):
    # The stretched arm (1.8 m) turns about the vertical from -60° to +60°; a ball of radius 0.1 sits
    # on the x axis 1.4 m out: the second link meets it when the arm's angle is within ±asin(0.15/1.4).
    ball = Obstacle("ball", "sphere", (0.1,), (1.4, 0.0, 0.0))
    world = planar_world(planar2, [ball], self_collision=False)
    a, b = np.radians([-60.0, 0.0]), np.radians([60.0, 0.0])
    check = certify_move(world, a, b)
    assert not check.clear and "/ ball" in check.blocked
    hit = math.asin((0.1 + R) / 1.4)
    reached = -math.radians(60) + check.at * math.radians(120)
    assert -hit - 0.02 <= reached <= 0.0  # found on the way in (bisection's first blocking sample)


def test_a_clear_sweep_is_certified_with_a_valid_bound(planar2):
    # The same sweep with the ball 0.06 m beyond the stretched arm's capsule: the true smallest
    # distance is 0.06 m, at the middle of the move.
    gap = 0.06
    ball = Obstacle("ball", "sphere", (0.1,), (1.8 + R + 0.1 + gap, 0.0, 0.0))
    world = planar_world(planar2, [ball], self_collision=False)
    a, b = np.radians([-60.0, 0.0]), np.radians([60.0, 0.0])
    check = certify_move(world, a, b, required=0.02)
    assert check.clear and check.blocked == ""
    assert 0.02 <= check.certified <= gap + 1e-9  # a lower bound of the true smallest distance
    dense = world.distances_many(a[None] + np.linspace(0, 1, 801)[:, None] * (b - a)[None])
    assert dense.min() == pytest.approx(gap, abs=1e-4) and dense.min() >= check.certified - 1e-12
    # Asking for more clearance than there is: not clear.
    assert not certify_move(world, a, b, required=gap + 0.01).clear


def test_detour_goes_around(planar2):
    # The second link folds from +90° to -90° through the first link's line; a ball beside the
    # elbow's sweep blocks the straight move; a detour through another configuration avoids it.
    ball = Obstacle("ball", "sphere", (0.1,), (1.5, 0.0, 0.0))
    world = planar_world(planar2, [ball], self_collision=False)
    a, b = np.radians([0.0, 90.0]), np.radians([0.0, -90.0])
    assert not certify_move(world, a, b).clear
    rng = np.random.default_rng(0)
    lower, upper = planar2.lower, planar2.upper
    timing = Timing.for_robot(planar2)
    detour = find_detour(world, a, b, 0.0, lower, upper, timing.move_time, rng)
    assert detour is not None and detour.first.clear and detour.second.clear
    assert np.all(world.distances(detour.via) >= 0)


def test_meshes_in_contact_are_not_clear():
    # coal gives 0, not a depth, for meshes that intersect: a contact must not pass for a clearance
    # of 0. The convex hulls' signed distance is kept when the meshes touch.
    np.testing.assert_array_equal(
        with_exact(np.array([-0.07, 0.01, 0.0, 0.02]), np.array([0.0, 0.03, 0.0, 0.0])),
        [-0.07, 0.03, -TOUCHING, -TOUCHING],
    )
    # A UR10 folded with its forearm through its shoulder (shoulder_lift -149°, elbow -178°): the
    # meshes intersect (shoulder / forearm hulls 77 mm deep, and others), so the pose is not clear
    # and the moves to it are named.
    ur10 = pincal.load_robot("ur10", markers=[(0.1, 0.05, 0.2)])
    folded = np.radians([6.0, -149.4, -178.0, 209.7, -112.7, -49.8])
    fine = np.radians([20.5, -64.5, 106.0, -100.3, -123.1, 48.5])
    campaign = plan_campaign(ur10, np.vstack([fine, folded]), home=fine)
    assert "collision geometry" in campaign.geometry
    assert campaign.unsafe_poses == (1,)
    assert campaign.pose_clearance[1] < -0.05  # the deepest of its overlapping pairs
    assert campaign.blocked and all("pose 2" in b for b in campaign.blocked)
    assert all(mv.detour is None for mv in campaign.moves)


def test_line_of_sight_blocked_by_a_box(planar2):
    robot = pincal.load_robot("planar_2r", markers=[(0.0, 0.0, 0.0)])
    wall = Obstacle("wall", "box", (0.1, 1.0, 1.0), (2.5, 0.0, 0.0))
    world = planar_world(robot, [wall], self_collision=False)
    qs = np.array([[0.0, 0.0], [math.pi / 2, 0.0]])
    hidden = occlusions(world, qs, np.array([4.0, 0.0, 0.0]))  # the tracker behind the wall
    assert [(o.pose, o.marker, o.by) for o in hidden] == [(0, 0, "wall")]
    # The arm itself in the way: the tracker below the first link, looking at the tip beyond it.
    assert occlusions(world, np.array([[0.0, math.pi]]), np.array([0.5, 0.0, 0.0]))[0].by.startswith("link1")


# -------------------------------------------------------------------------------- campaigns
@pytest.fixture(scope="module")
def kr_plan(kr270_marker):
    rng = np.random.default_rng(3)
    constraints = pincal.planning.constraints.with_safety(kr270_marker)
    from pincal.planning.feasibility import Feasibility

    return Feasibility(kr270_marker, constraints).sample(7, rng)


def test_campaign_time_adds_up_by_hand(kr270_marker, kr_plan):
    timing = Timing.for_robot(kr270_marker, settle=0.3, dwell=1.5)
    home = np.radians([0, -90, 90, 0, 0, 0])
    campaign = plan_campaign(kr270_marker, kr_plan, home=home, timing=timing)
    assert sorted(campaign.order) == list(range(7)) and campaign.exact
    route = [home, *kr_plan[list(campaign.order)], home]
    straight = [timing.move_time(a, b) for a, b in zip(route[:-1], route[1:], strict=True)]
    for i, (mv, t) in enumerate(zip(campaign.moves, straight, strict=True)):
        via = [] if mv.detour is None else [mv.detour.via]  # a detour's time goes through its via point
        stops = [route[i], *via, route[i + 1]]
        assert mv.time == pytest.approx(sum(timing.move_time(a, b) for a, b in zip(stops[:-1], stops[1:])))
        assert mv.detour is not None or mv.time == pytest.approx(t, rel=1e-12)
    assert campaign.total == pytest.approx(sum(mv.time for mv in campaign.moves) + 7 * 1.8)
    # The order is the best over all 7! orders (brute force over the move times).
    cost = timing.matrix(np.vstack([home, kr_plan]))
    best = min(tour_cost(cost, p) for p in itertools.permutations(range(1, 8)))
    assert campaign.tour_time == pytest.approx(best + 7 * 1.8)
    assert campaign.given_time == pytest.approx(tour_cost(cost, range(1, 8)) + 7 * 1.8)
    assert campaign.given_time >= campaign.tour_time
    assert campaign.moves[0].start == HOME and campaign.moves[-1].end == HOME
    assert campaign.home_source == "given" and "  home: given" in campaign.lines()
    waypoints = campaign.waypoints()
    assert [p for _, p, _ in waypoints if p] == [i + 1 for i in campaign.order]
    assert all(w == pytest.approx(1.8) for _, p, w in waypoints if p)


def test_campaign_checks_every_move_against_the_cell(kr270_marker, kr_plan):
    table = Obstacle("table", "box", (1.0, 1.0, 0.1), (1.9, 0.0, 0.4))
    cell = Workcell((table,), min_distance=0.02)
    campaign = plan_campaign(kr270_marker, kr_plan, constraints=[cell], seed=1)
    floor = Mount("floor").bind(kr270_marker)
    world = cell.world(kr270_marker, self_collision=True, mount_points=floor)
    assert campaign.checked and "capsules" in campaign.geometry
    # The KR 270's zero has joint_a2 outside [-140°, -5°]: home is the plan's first pose, and said.
    assert np.array_equal(campaign.home, kr_plan[0]) and "outside the joint limits" in campaign.home_source
    # The safe defaults' clearance, 5 cm, from the floor and the table (above the cell's own 2 cm).
    assert campaign.required == {"self": 0.0, "obstacle": 0.05, "floor": 0.05}
    for mv in campaign.moves:
        ends = [campaign.home if i == HOME else kr_plan[i] for i in (mv.start, mv.end)]
        stops = [ends[0], *([] if mv.detour is None else [mv.detour.via]), ends[1]]
        if not mv.clear:
            continue
        # What the campaign certifies holds on a dense sampling of every move it runs.
        for a, b in zip(stops[:-1], stops[1:], strict=True):
            dense = world.distances_many(a[None] + np.linspace(0, 1, 101)[:, None] * (b - a)[None])
            need = np.where(np.array(world.kinds) == "self", 0.0, 0.05)
            assert np.all(dense >= need - 1e-9)
    payload = json.loads(json.dumps(campaign.as_dict()))
    assert payload["order"] == list(campaign.order) and len(payload["moves"]) == 8
    assert payload["dwell"] == [2.0] * 7 and payload["total"] == pytest.approx(campaign.total)


def test_cli_campaign_json_csv_and_animation(tmp_path, cli, kr270_marker, kr_plan):
    plan = tmp_path / "plan.csv"
    pincal.Plan.for_robot(kr270_marker, kr_plan).to_csv(plan, degrees=True)
    out, html = tmp_path / "campaign.csv", tmp_path / "campaign.html"
    argv = ["campaign", "kr270", "--plan", plan, "--deg", "--marker", "0.1,0.05,0.2"]
    payload = cli.json(*argv, "--out", out, "--html", html, "--dwell", "probe")
    assert sorted(payload["order"]) == list(range(7)) and payload["dwell"] == [10.0] * 7
    assert payload["total"] == pytest.approx(sum(mv["time"] for mv in payload["moves"]) + 7 * 10.5)
    assert payload["safety"]["ok"] and payload["timing"]["speed_source"] == "URDF velocity limits"
    rows = [r for r in out.read_text().splitlines() if not r.startswith("#")]
    assert rows[0].split(",")[-2:] == ["pose", "wait"]
    poses = [int(r.split(",")[-2]) for r in rows[1:]]
    assert [p for p in poses if p] == [i + 1 for i in payload["order"]] and poses[0] == poses[-1] == 0
    assert "set_animation" in html.read_text()
    code, text, _ = cli.run(*argv, "--no-check")
    assert code == 0 and "moves not checked" in text
    cli.fails(*argv, "--dwell", "forever", match="--dwell")
    cli.fails(*argv, "--joint-speeds", "1,2", match="--joint-speeds")
    cli.fails(*argv, "--speed", "0", match="--speed")
    cli.fails(*argv, "--home", "0,0", match="--home")


def test_animation_numbers_the_poses_in_execution_order(kr270_marker, kr_plan):
    from meshcat.servers.tree import walk

    from pincal.viewing.animation import campaign_scene
    from tests.support.meshcat_nodes import matrix, node

    table = Obstacle("table", "box", (1.0, 1.0, 0.1), (1.9, 0.0, 0.4))
    campaign = plan_campaign(kr270_marker, kr_plan, check=False)
    built = campaign_scene(campaign, [Workcell((table,))])
    points = kr270_marker.points(kr_plan)
    for k, row in enumerate(campaign.order):
        marker = node(built, f"campaign/poses/pose_{k + 1:02d}/marker_0")
        np.testing.assert_allclose(matrix(marker)[:3, 3], points[row, 0], atol=1e-12)
    animated = [n for n in walk(built.viewer.window.tree) if n.animation is not None]
    assert len(animated) == 1
    assert node(built, "cell/visuals/table").object is not None
    assert built.times.shape == (7,) and np.all(np.diff(built.times) > 0) and built.duration > built.times[-1]
    assert "set_animation" in built.html()


def test_view_frames_every_pose_and_keeps_the_floor_under_them(kr270_marker):
    """A pose stretched straight up (the tip 3.2 m high) and one reaching below the base plane: the
    camera's field of view holds the sphere around every joint origin and marker, and the grid is
    under the lowest point."""
    from pincal.viewing import drawing
    from pincal.viewing.scene import static_viewer
    from tests.support.meshcat_nodes import matrix

    qs = np.radians([[0, -90, 0, 0, 0, 0], [90, -10, 150, 0, -60, 0]])
    vis = static_viewer()
    reach = drawing_reach = pincal.model.collision.reach(kr270_marker)
    centre = drawing.set_view(vis, kr270_marker, qs, drawing_reach)
    shift = matrix(vis.window.node(f"/meshcat/{drawing.ROOT}"))[:3, 3]
    np.testing.assert_allclose(shift, -centre)
    origins = drawing._joint_origins(kr270_marker, qs)
    pts = np.vstack([origins, kr270_marker.points(qs).reshape(-1, 3)])
    radius = np.linalg.norm(pts - centre, axis=1).max() + drawing.VIEW_PAD * reach
    camera = vis.window.node("/Cameras/default/rotated/<object>")
    import umsgpack

    position = [
        umsgpack.unpackb(p)["value"]
        for p in camera.properties
        if umsgpack.unpackb(p)["property"] == "position"
    ]
    distance = np.linalg.norm(position[-1])
    assert radius <= distance * math.sin(math.radians(drawing.FIELD_OF_VIEW / 2))
    grid = matrix(vis.window.node("/Grid"))[:3, 3]
    assert grid[2] + centre[2] <= pts[:, 2].min() < 0  # the grid under the lowest point


# -------------------------------------------------------------------------- accuracy vs time
def test_accuracy_against_campaign_time(kr270_marker):
    from pincal.campaign.tradeoff import accuracy_vs_time, parse_sizes

    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable  # 12: m ≥ 4
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    region = pincal.around(q0, math.radians(10), samples=32)
    timing = Timing.for_robot(kr270_marker, dwell="probe")
    result = accuracy_vs_time(
        params,
        region,
        (3, 6, 9),
        timing=timing,
        search=pincal.Search(starts=2, pool=200, workers=1, polish=False),
    )
    assert (
        [r.m for r in result.rows] == [6, 9]
        and result.skipped[0][0] == 3
        and "4 poses" in result.skipped[0][1]
    )
    for row in result.rows:
        assert row.predicted == pytest.approx(
            pincal.rho0(params, row.plan, region, sigma=DEFAULT_SIGMA), rel=1e-9
        )
        campaign = plan_campaign(kr270_marker, row.plan, timing=timing, check=False)
        assert row.minutes == pytest.approx(campaign.total / 60) and row.minutes >= row.m * 10.5 / 60
    assert "accuracy against campaign time" in result.lines()[0]
    assert parse_sizes("6:30:6") == (6, 12, 18, 24, 30) and parse_sizes("12,6") == (6, 12)
    with pytest.raises(BadArgument, match="START:STOP"):
        parse_sizes("6-30")


def test_cli_design_campaign_reports_the_tradeoff(tmp_path, cli):
    figure = tmp_path / "tradeoff.png"
    argv = ["design", "kr270", "-m", "6", "--test-pose=0,-60,60,0,45,0", "--deg", "--marker", "0.1,0.05,0.2"]
    argv += ["--params", "lengths,offsets", "--starts", "2", "--workers", "1", "--pool-size", "200"]
    argv += ["--no-accuracy", "--no-polish"]
    payload = cli.json(*argv, "--campaign", "--campaign-m", "6,8", "--campaign-plot", figure)
    assert [r["m"] for r in payload["tradeoff"]["rows"]] == [6, 8] and payload["campaign"]["time"] > 6 * 2.5
    assert figure.stat().st_size > 1000
    cli.fails(*argv, "--campaign-plot", figure, match="go with --campaign")


def test_accuracy_vs_time_takes_design_values_and_its_flat_keywords_until_0_3(kr270_marker):
    """The flat design keywords of pincal 0.1 (``starts=``, ``constraints=``, ...) regroup into
    ``search=``/``safety=`` with a DeprecationWarning at the caller's line, and the same trade-off."""
    from pincal.campaign.tradeoff import accuracy_vs_time

    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    fast = dict(starts=1, pool=100, workers=1, polish=False)
    with pytest.warns(DeprecationWarning, match=r"accuracy_vs_time\(\): the flat keywords") as caught:
        old = accuracy_vs_time(params, q0, (6,), clearance=0.1, **fast)
    assert caught[0].filename == __file__
    assert "search=pincal.Search(starts=..." in str(caught[0].message)
    assert "safety=pincal.Safety(clearance=...)" in str(caught[0].message)
    new = accuracy_vs_time(
        params, q0, (6,), search=pincal.Search(**fast), safety=pincal.Safety(clearance=0.1)
    )
    assert old.rows[0].plan.q.tobytes() == new.rows[0].plan.q.tobytes()
    assert old.as_dict() == new.as_dict()
    with pytest.raises(TypeError, match=r"accuracy_vs_time\(\) got starts and search="):
        accuracy_vs_time(params, q0, (6,), starts=1, search=pincal.Search())
    with pytest.raises(BadArgument, match=r"safety= takes a pincal.Safety"):
        accuracy_vs_time(params, q0, (6,), safety={"clearance": 0.1})  # type: ignore[arg-type]


def test_the_dwell_source_is_not_an_instrument_and_its_0_1_name_works_until_0_3(kr270_marker):
    """``instrument=`` is an Instrument across pincal: a Timing's dwell source is ``dwell_source``;
    ``Timing(instrument=...)`` and ``.instrument`` keep working with a DeprecationWarning at the
    caller's line, and the JSON key stays "instrument" (pincal campaign's output)."""
    timing = Timing.for_robot(kr270_marker, dwell="probe")
    assert timing.dwell_source == "probe" and timing.as_dict()["instrument"] == "probe"
    with pytest.warns(DeprecationWarning, match=r"Timing\(\): instrument= is renamed dwell_source=") as w:
        old = Timing(timing.speeds, None, instrument="probe")
    assert w[0].filename == __file__ and old.dwell_source == "probe"
    with pytest.warns(DeprecationWarning, match=r"Timing.instrument is renamed dwell_source ") as w:
        assert old.instrument == "probe"
    assert w[0].filename == __file__


def test_the_tradeoff_measures_with_the_design_s_instrument(kr270_marker, cli):
    """A pose measures 6 values a configuration: no fewer than 2 poses can identify 12 parameters
    (points: 4), and each plan's predicted error is ρ0 with that instrument (it was points with the
    default σ)."""
    from pincal.campaign.tradeoff import accuracy_vs_time
    from pincal.instruments import Instrument, PerCoordinate, Pose

    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    pose = Instrument(Pose(), PerCoordinate(2e-5, 1e-4))
    fast = pincal.Search(starts=1, pool=100, workers=1, polish=False)
    result = accuracy_vs_time(params, q0, (1, 3, 4), instrument=pose, search=fast)
    assert [r.m for r in result.rows] == [3, 4] and "the 2 poses" in result.skipped[0][1]
    for row in result.rows:
        assert row.predicted == pytest.approx(pincal.rho0(params, row.plan, q0, instrument=pose), rel=1e-9)
    assert result.sigma == 2e-5
    with pytest.raises(BadArgument, match="not both"):
        accuracy_vs_time(params, q0, (4,), instrument=pose, sigma=1e-5, search=fast)
    argv = ["design", "kr270", "-m", "4", "--test-pose=0,-60,60,0,45,0", "--deg", "--marker", "0.1,0.05,0.2"]
    argv += ["--params", "lengths,offsets", "--starts", "1", "--workers", "1", "--pool-size", "100"]
    argv += ["--no-accuracy", "--no-polish", "--measure", "pose", "--sigma", "2e-5", "--sigma-rot", "1e-4"]
    payload = cli.json(*argv, "--campaign", "--campaign-m", "3,4")
    rows = payload["tradeoff"]["rows"]
    assert [r["m"] for r in rows] == [3, 4]
    assert rows[1]["predicted"] == pytest.approx(payload["rho0"], rel=1e-9)
