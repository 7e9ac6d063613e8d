"""From a plan to a campaign: the order the robot runs the poses in, each move checked, the time
(docs/method.md §12).

:func:`plan_campaign` takes a plan (the measurement configurations) and returns a
:class:`Campaign`: the tour from a home configuration through every pose and back that takes the
least time (:mod:`pincal.campaign.ordering`, on the move times of :mod:`pincal.campaign.timing`),
every move between consecutive configurations certified collision-free against the robot itself,
the cell and the floor (:mod:`pincal.campaign.motion`), a detour through a clear intermediate
configuration where a move is not, and the line of sight from the tracker of a visibility
constraint checked at every pose (:mod:`pincal.campaign.line_of_sight`).

The order minimises the time of the moves; the detours are added afterwards (a campaign with
detours could be a little quicker in another order).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from pincal.arguments import Seed, generator
from pincal.campaign.line_of_sight import occlusions
from pincal.campaign.motion import Carrying, certify_move, find_detour
from pincal.campaign.ordering import best_tour, tour_cost
from pincal.campaign.result import HOME, Campaign, Move
from pincal.campaign.timing import Timing
from pincal.model.collision import CollisionWorld
from pincal.model.robot import Robot
from pincal.planning.constraints import (
    AnyConstraint,
    JointMargin,
    Mount,
    MountSpec,
    SelfCollision,
    Visibility,
    Workcell,
    joint_margins,
    with_safety,
)
from pincal.planning.plan import Plan
from pincal.progress import Steps
from pincal.typing import ConfigurationsLike, JointValues


def default_home(robot: Robot, qs: np.ndarray, clear=None) -> tuple[np.ndarray, str]:
    """The URDF zero when it lies within the joint limits (and ``clear(zero)``, when given), else
    the plan's first configuration; with where it comes from, in words."""
    zero = np.zeros(robot.nq)
    inside = np.all(zero >= robot.model.lowerPositionLimit) and np.all(zero <= robot.model.upperPositionLimit)
    if not inside:
        return qs[0].copy(), "the plan's first pose (the URDF zero is outside the joint limits)"
    if clear is not None and not clear(zero):
        return qs[0].copy(), "the plan's first pose (the URDF zero is not clear itself)"
    return zero, "the URDF zero"


def plan_campaign(
    robot: Robot,
    plan: ConfigurationsLike,
    *,
    home: JointValues | None = None,
    timing: Timing | None = None,
    constraints: Iterable[AnyConstraint] = (),
    joint_margin: JointMargin = None,
    mount: MountSpec = None,
    clearance: float | None = None,
    check: bool = True,
    self_collision: bool = True,
    seed: Seed = 0,
    progress: bool = False,
) -> Campaign:
    """The campaign of a plan: ordered, timed, every move checked (see the module doc).

    Args:
        robot: the robot.
        plan: (m, nq) measurement configurations [rad or m] or a Plan.
        home: (nq,) the configuration the campaign starts from and ends at (default: the URDF zero
            when within the joint limits and, with ``check``, clear itself; else the plan's first
            configuration).
        timing: the time model (default: :meth:`Timing.for_robot`: URDF speeds, a laser tracker).
        constraints: the cell: a :class:`~pincal.planning.constraints.Workcell` (its obstacles and
            clearance), the :class:`~pincal.planning.constraints.Mount` (the floor), a
            :class:`~pincal.planning.constraints.SelfCollision` (its clearance between links),
            :class:`~pincal.planning.constraints.Visibility` (line of sight from its tracker); the
            safe defaults are added as a design adds them (``joint_margin``, ``mount``).
        joint_margin, mount, clearance: as :func:`pincal.design`'s (the mount is the floor of the
            checks; a pose or a move closer to the floor or an obstacle than the clearance is not
            clear).
        check: certify the moves and check the poses (False: order and time only).
        self_collision: check the robot against itself too.
        seed: the random draws of the detours.
        progress: report the moves certified on stderr (a bar on a terminal, else a line every
            few seconds).

    Returns:
        the :class:`Campaign`.

    Raises:
        BadConfiguration: a configuration of the wrong size or outside the joint limits.
        BadArgument: a bad timing or constraint argument.
    """
    plan = plan if isinstance(plan, Plan) else Plan.for_robot(robot, plan)
    qs = robot.configurations(plan)
    loads = plan.payload
    plan = Plan.for_robot(robot, qs)
    timing = Timing.for_robot(robot) if timing is None else timing
    constraints = with_safety(robot, constraints, joint_margin, mount, clearance=clearance)
    world, need = _world(robot, constraints, self_collision) if check else (None, None)
    home_q, home_source = _home(robot, qs, home, world, need)
    cost = timing.matrix(np.vstack([home_q[None], qs]))
    m = len(qs)
    given = list(range(1, m + 1))
    tour = best_tour(cost, given)
    given_time = tour_cost(cost, given) + m * timing.stop
    order = tuple(i - 1 for i in tour.order)
    route = [HOME, *order, HOME]
    if world is None or need is None:  # not checked: order and time only
        unchecked = tuple(
            Move(a, b, float(cost[a + 1, b + 1])) for a, b in zip(route[:-1], route[1:], strict=True)
        )
        return Campaign(
            robot, plan, home_q, order, unchecked, timing, tour.exact, given_time, home_source=home_source
        )
    # With compliances, each pose is checked under the payload it carries (home: none).
    carried = loads if loads is not None and loads.any() and world.forward.gravity is not None else None
    rows = {HOME: np.zeros(4), **({} if carried is None else dict(enumerate(carried)))}
    at = {
        i: world.distances(q, payload=None if carried is None else carried[i : i + 1])
        for i, q in enumerate(qs)
    }
    at[HOME] = world.distances(home_q)
    nodes = {HOME: home_q, **dict(enumerate(qs))}
    moves = _certified_moves(
        robot,
        world,
        need,
        constraints,
        timing,
        cost,
        route,
        nodes,
        at,
        seed,
        progress,
        rows if carried is not None else None,
    )
    return Campaign(
        robot,
        plan,
        home_q,
        order,
        tuple(moves),
        timing,
        tour.exact,
        given_time,
        checked=True,
        geometry=world.geometry.source,
        home_short=_short(world, at[HOME], need),
        skipped_pairs=tuple(world.skipped),
        home_source=home_source,
        **_pose_checks(robot, world, need, constraints, qs, at, carried),
    )


def _home(
    robot: Robot, qs: np.ndarray, home: JointValues | None, world: CollisionWorld | None, need
) -> tuple[np.ndarray, str]:
    """The campaign's home configuration and where it comes from (see :func:`plan_campaign`)."""
    if home is not None:
        return robot.configurations(home, what="home")[0], "given"
    if world is not None:  # the zero only when it is clear itself (a UR10's has its wrist below the floor)
        return default_home(robot, qs, lambda q: bool(np.all(world.distances(q) >= need)))
    return default_home(robot, qs)


def _certified_moves(
    robot: Robot,
    world: CollisionWorld,
    need: np.ndarray,
    constraints: tuple,
    timing: Timing,
    cost: np.ndarray,
    route: list[int],
    nodes: dict[int, np.ndarray],
    at: dict[int, np.ndarray],
    seed: Seed,
    progress: bool,
    rows: dict[int, np.ndarray] | None = None,
) -> list[Move]:
    """Each move of the route certified (:func:`certify_move`), a detour found where a move between
    clear poses is not, and timed; ``nodes`` and ``at``: each pose's configuration and distances
    (:data:`HOME` the home's); ``rows``: each pose's payload row [kg, x, y, z], when it matters
    (a move is then checked under each payload of its ends, :class:`Carrying`)."""
    rng = generator(seed)
    margins = joint_margins(robot, constraints)
    lower = robot.model.lowerPositionLimit + margins
    upper = robot.model.upperPositionLimit - margins
    moves: list[Move] = []
    steps = Steps(progress, "campaign", "move")
    steps.stage("certified", len(route) - 1)
    for a, b in zip(route[:-1], route[1:], strict=True):
        straight = float(cost[a + 1, b + 1])
        moving: CollisionWorld | Carrying = world
        ends = at[a], at[b]
        if rows is not None:
            moving = Carrying(world, np.unique(np.vstack([rows[a], rows[b]]), axis=0))
            ends = (moving.distances(nodes[a]), moving.distances(nodes[b]))
        c = certify_move(moving, nodes[a], nodes[b], need, ends)
        detour = None
        ends_clear = np.all(ends[0] >= need) and np.all(ends[1] >= need)
        if not c.clear and ends_clear:
            detour = find_detour(
                moving, nodes[a], nodes[b], need, lower, upper, timing.move_time, rng, extra=(nodes[HOME],)
            )
        time = straight
        if detour is not None:
            time = float(timing.move_time(nodes[a], detour.via) + timing.move_time(detour.via, nodes[b]))
        moves.append(Move(a, b, float(time), c, detour))
        steps.advance()
    steps.close()
    return moves


def _pose_checks(
    robot: Robot,
    world: CollisionWorld,
    need: np.ndarray,
    constraints: tuple,
    qs: np.ndarray,
    at: dict[int, np.ndarray],
    carried: np.ndarray | None = None,
) -> dict:
    """The poses' checks as :class:`Campaign`'s fields: each pose's closest pair, its distance and
    the clearance it keeps, the clearance of each kind of pair, the lines of sight blocked (under
    each pose's payload row of ``carried``, when given)."""
    m = len(qs)
    worst = [int(np.argmin(at[i] - need)) if world.size else -1 for i in range(m)]
    closest = tuple(world.names[k] if k >= 0 else "" for k in worst)
    pose_distance = np.array([at[i][k] if k >= 0 else np.inf for i, k in enumerate(worst)])
    required_at = np.array([need[k] if k >= 0 else 0.0 for k in worst])
    blocked_sight = []
    for con in constraints:
        if isinstance(con, Visibility):
            tracker = robot.base.inverse() * np.array(con.tracker)
            blocked_sight += occlusions(world, qs, tracker, carried)
    kinds = np.array(world.kinds)
    required = {
        kind: float(need[kinds == kind][0]) if np.any(kinds == kind) else 0.0
        for kind in ("self", "obstacle", "floor")
    }
    return {
        "pose_clearance": pose_distance,
        "pose_closest": closest,
        "pose_required": required_at,
        "required": required,
        "occlusions": tuple(blocked_sight),
    }


def _short(world: CollisionWorld, distances: np.ndarray, need: np.ndarray) -> str:
    """The pair closest to (and below) its clearance, with its distance, or ""."""
    if not world.size or np.all(distances >= need):
        return ""
    k = int(np.argmin(distances - need))
    return f"{world.names[k]} {distances[k] * 1e3:.3g} mm apart (keeps {need[k] * 1e3:.3g} mm)"


def _world(robot: Robot, constraints: tuple, self_collision: bool) -> tuple[CollisionWorld, np.ndarray]:
    """The collision world of the campaign's checks and the clearance each of its pairs keeps [m]."""
    cells = [c for c in constraints if isinstance(c, Workcell)]
    mounts = [c for c in constraints if isinstance(c, Mount)]
    selfs = [c for c in constraints if isinstance(c, SelfCollision)]
    obstacles = [obj for cell in cells for obj in cell.geometry_objects()]
    radius = next((c.link_radius for c in cells if c.link_radius is not None), None)
    dirs = tuple(d for c in cells for d in c.package_dirs) + tuple(d for c in selfs for d in c.package_dirs)
    world = CollisionWorld(
        robot,
        obstacles,
        self_collision=self_collision,
        mount_points=mounts[0].bind(robot) if mounts else None,
        link_radius=radius,
        search=dirs,
    )
    keep = {
        "obstacle": max((c.min_distance for c in cells), default=0.0),
        "self": max((c.min_distance for c in selfs), default=0.0),
        "floor": max((c.clearance for c in mounts), default=0.0),
    }
    return world, np.array([keep[k] for k in world.kinds])
