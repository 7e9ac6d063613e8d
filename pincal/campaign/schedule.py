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

import io
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from pincal.arguments import Seed, generator
from pincal.campaign.line_of_sight import Occlusion, occlusions
from pincal.campaign.motion import Detour, MoveCheck, certify_move, find_detour
from pincal.campaign.ordering import best_tour, tour_cost
from pincal.campaign.timing import Timing
from pincal.errors import CannotWrite
from pincal.files import atomic_write_text, csv_header
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

HOME = -1
"""The index that stands for the home configuration in :attr:`Move.start` and :attr:`Move.end`."""


@dataclass(frozen=True, eq=False)
class Move:
    """One move of the campaign.

    Attributes:
        start: the plan row it leaves (0-based), or :data:`HOME`.
        end: the plan row it goes to, or :data:`HOME`.
        time: its duration [s] (through the detour when there is one).
        check: the check of the straight move (None when moves are not checked).
        detour: the detour taken instead of the straight move, or None.
    """

    start: int
    end: int
    time: float
    check: MoveCheck | None = None
    detour: Detour | None = None

    @property
    def clear(self) -> bool | None:
        """The move as run (straight or by its detour) is certified clear (None: not checked)."""
        if self.check is None:
            return None
        return self.check.clear or self.detour is not None

    def as_dict(self) -> dict:
        return {
            "from": None if self.start == HOME else self.start,
            "to": None if self.end == HOME else self.end,
            "time": self.time,
            "clear": self.clear,
            "check": None if self.check is None else self.check.as_dict(),
            "via": None if self.detour is None else self.detour.via.tolist(),
            "via_checks": None
            if self.detour is None
            else [self.detour.first.as_dict(), self.detour.second.as_dict()],
        }


@dataclass(frozen=True, eq=False)
class Campaign:
    """A plan as a technician runs it (see the module doc).

    Attributes:
        robot: the robot.
        plan: the plan as given.
        home: (nq,) the configuration the campaign starts and ends at [rad or m].
        order: the plan's rows (0-based) in the order they are measured.
        moves: the m + 1 moves: home to the first pose, ..., the last pose to home.
        timing: the time model.
        exact: the order is the optimum (Held–Karp), else a 2-opt/Or-opt local optimum.
        given_time: the campaign's time in the plan's own order, without detours [s].
        checked: the moves and poses were checked against collisions.
        geometry: the robot geometry of the checks (``the URDF's collision geometry`` or the
            capsules), or "".
        pose_clearance: (m,) at each pose, the distance of the pair closest to its clearance [m]
            (inf: nothing to check).
        pose_closest: that pair at each pose.
        pose_required: (m,) the clearance that pair keeps [m].
        home_short: the pair at the home configuration closer than its clearance, or "".
        required: what each kind of pair keeps [m]: ``{"self": ..., "obstacle": ..., "floor": ...}``.
        occlusions: the markers the instrument cannot see (with a visibility constraint).
        skipped_pairs: pairs of the robot's shapes in contact at the reference configuration, not checked.
        home_source: where :attr:`home` comes from, in words (``given``, ``the URDF zero``, or
            ``the plan's first pose`` and why).
    """

    robot: Robot
    plan: Plan
    home: np.ndarray
    order: tuple[int, ...]
    moves: tuple[Move, ...]
    timing: Timing
    exact: bool
    given_time: float
    checked: bool = False
    geometry: str = ""
    pose_clearance: np.ndarray | None = None
    pose_closest: tuple[str, ...] = ()
    pose_required: np.ndarray | None = None
    home_short: str = ""
    required: dict | None = None
    occlusions: tuple[Occlusion, ...] = ()
    skipped_pairs: tuple[str, ...] = ()
    home_source: str = ""

    @property
    def m(self) -> int:
        """Number of measurement poses."""
        return len(self.order)

    @property
    def move_time(self) -> float:
        """Time spent moving [s]."""
        return float(sum(mv.time for mv in self.moves))

    @property
    def stop_time(self) -> float:
        """Time spent at the poses (settle and dwell) [s]."""
        return self.m * self.timing.stop

    @property
    def total(self) -> float:
        """The campaign's time from home and back [s]."""
        return self.move_time + self.stop_time

    @property
    def blocked(self) -> tuple[str, ...]:
        """The moves that could not be made clear, named (``pose 3 → pose 7: link_4 / table ...``)."""
        out = []
        for mv in self.moves:
            if mv.check is not None and not mv.clear:
                out.append(f"{self._name(mv.start)} → {self._name(mv.end)}: {mv.check.blocked}")
        return tuple(out)

    @property
    def unsafe_poses(self) -> tuple[int, ...]:
        """The poses (0-based plan rows) closer than their clearance to something."""
        if self.pose_clearance is None:
            return ()
        assert self.pose_required is not None  # set with pose_clearance (a checked campaign)
        return tuple(int(i) for i in np.flatnonzero(self.pose_clearance < self.pose_required - 1e-12))

    @property
    def closest_pose(self) -> int | None:
        """The pose (0-based plan row) whose closest pair comes nearest to its clearance (None:
        not checked, or nothing to check)."""
        if self.pose_clearance is None or self.pose_required is None or not self.m:
            return None
        excess = self.pose_clearance - self.pose_required
        if not np.isfinite(excess).any():
            return None
        return int(np.argmin(excess))

    def _name(self, index: int) -> str:
        return "home" if index == HOME else f"pose {index + 1}"

    def waypoints(self) -> list[tuple[np.ndarray, int, float]]:
        """Every configuration the robot goes through, in order: (q, plan row + 1 for a
        measurement pose or 0 for home and a detour's via point, time spent there [s])."""
        out = [(self.home, 0, 0.0)]
        for mv in self.moves:
            if mv.detour is not None:
                out.append((mv.detour.via, 0, 0.0))
            if mv.end == HOME:
                out.append((self.home, 0, 0.0))
            else:
                out.append((self.plan.q[mv.end], mv.end + 1, self.timing.stop))
        return out

    def to_csv_text(self, degrees: bool = False) -> str:
        """The robot program as CSV: a header of joint names, ``pose`` and ``wait``, then every
        waypoint (:meth:`waypoints`), joints in radians (revolute ones in degrees if asked) and
        metres, ``pose`` the plan row measured there (1-based; 0 for home and via points), ``wait``
        the time spent there [s]."""
        out = io.StringIO()
        out.write("# pincal campaign: " + self.summary() + "\n")
        out.write(csv_header([*self.robot.joint_names, "pose", "wait"]))  # a name with a comma quoted
        for q, pose, wait in self.waypoints():
            values = self.robot.to_degrees(q) if degrees else q
            if not (np.all(np.isfinite(values)) and math.isfinite(wait)):
                raise CannotWrite(
                    f"the campaign's waypoint {list(map(float, values))} (wait {wait!r} s) is not finite: "
                    "no robot program is written"
                )
            out.write(",".join([*(repr(float(v)) for v in values), str(pose), f"{wait:g}"]) + "\n")
        return out.getvalue()

    def to_csv(self, path: str | os.PathLike, degrees: bool = False) -> None:
        """Write :meth:`to_csv_text` atomically."""
        atomic_write_text(path, self.to_csv_text(degrees))

    def summary(self) -> str:
        """One line: poses, order, time."""
        how = "optimal order" if self.exact else "2-opt/Or-opt order"
        return f"{self.m} poses, {how}, {self.total / 60:.3g} min from home and back"

    def as_dict(self) -> dict:
        return {
            "m": self.m,
            "order": list(self.order),
            "home": self.home.tolist(),
            "home_source": self.home_source,
            "exact": self.exact,
            "total": self.total,
            "move_time": self.move_time,
            "stop_time": self.stop_time,
            "given_time": self.given_time,
            "gain": self.given_time - self.tour_time,
            "moves": [mv.as_dict() for mv in self.moves],
            "dwell": [self.timing.dwell] * self.m,
            "settle": [self.timing.settle] * self.m,
            "timing": self.timing.as_dict(),
            "checked": self.checked,
            "geometry": self.geometry,
            "required": self.required,
            "pose_clearance": None
            if self.pose_clearance is None
            else [float(v) if math.isfinite(v) else None for v in self.pose_clearance],
            "pose_closest": list(self.pose_closest),
            "blocked": list(self.blocked),
            "unsafe_poses": list(self.unsafe_poses),
            "closest_pose": self.closest_pose,
            "home_short": self.home_short,
            "occlusions": [o.as_dict() for o in self.occlusions],
            "skipped_pairs": list(self.skipped_pairs),
        }

    @property
    def tour_time(self) -> float:
        """The campaign's time in the chosen order without detours [s] (to compare with
        :attr:`given_time`)."""
        straight = [self.timing.move_time(*self._ends(mv)) for mv in self.moves]
        return float(sum(straight)) + self.stop_time

    def _ends(self, mv: Move) -> tuple[np.ndarray, np.ndarray]:
        def q(i: int) -> np.ndarray:
            return self.home if i == HOME else self.plan.q[i]

        return q(mv.start), q(mv.end)

    def lines(self) -> list[str]:
        """The report: order, times, checks."""
        t = self.timing
        out = [f"campaign: {self.summary()}"]
        out.append(f"  {t.describe()}")
        if self.home_source:
            out.append(f"  home: {self.home_source}")
        saved = self.given_time - self.tour_time
        out.append(
            f"  in the plan's order: {self.given_time / 60:.3g} min; this order saves {saved:.3g} s "
            f"({100 * saved / max(self.given_time, 1e-12):.3g} %)"
        )
        out.append(
            f"  moving {self.move_time:.4g} s, at the poses {self.stop_time:.4g} s "
            f"({self.m} × ({t.settle:g} s settle + {t.dwell:g} s dwell))"
        )
        out.append("  order (plan rows, 1-based): " + " ".join(str(i + 1) for i in self.order))
        for mv in self.moves:
            line = f"    {self._name(mv.start):>8} → {self._name(mv.end):<8} {mv.time:7.3f} s"
            if mv.check is not None:
                c = mv.check
                if mv.detour is not None:
                    line += f"  detour (straight: {c.blocked})"
                elif c.clear and not math.isfinite(c.certified):
                    line += "  clear: nothing to check"
                elif c.clear:
                    line += (
                        f"  clear (certified ≥ {c.certified * 1e3:.3g} mm; closest {c.sampled * 1e3:.4g} mm, "
                        f"{c.closest}; {c.evaluations} evaluations)"
                    )
                else:
                    line += f"  NOT CLEAR: {c.blocked}"
            out.append(line)
        if self.checked:
            out.append(f"  checked against: {self.geometry}")
            if self.required:
                r = self.required
                out.append(
                    f"  clearance kept: self {r['self'] * 1e3:.3g} mm, "
                    f"obstacles {r['obstacle'] * 1e3:.3g} mm, floor {r['floor'] * 1e3:.3g} mm"
                )
            closest = self.closest_pose
            if closest is not None:
                i = closest
                assert self.pose_clearance is not None and self.pose_required is not None  # checked
                short = "  ** closer than the clearance **" if i in self.unsafe_poses else ""
                out.append(
                    f"  closest pose: pose {i + 1}, {self.pose_closest[i]} "
                    f"{self.pose_clearance[i] * 1e3:.4g} mm "
                    f"(kept: {self.pose_required[i] * 1e3:.3g} mm){short}"
                )
            if self.skipped_pairs:
                out.append(
                    "  not checked (in contact at the reference configuration): "
                    + ", ".join(self.skipped_pairs)
                )
            for name in self.blocked:
                out.append(f"  blocked: {name}")
            if self.home_short:
                out.append(f"  home itself is too close: {self.home_short}")
            for i in self.unsafe_poses:
                assert self.pose_clearance is not None  # unsafe_poses are empty without it
                out.append(
                    f"  pose {i + 1} itself is too close: {self.pose_closest[i]} "
                    f"{self.pose_clearance[i] * 1e3:.3g} mm"
                )
        else:
            out.append("  moves not checked for collisions")
        for o in self.occlusions:
            out.append(f"  line of sight: {o}")
        return out


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
    plan = Plan.for_robot(robot, qs)
    timing = Timing.for_robot(robot) if timing is None else timing
    constraints = with_safety(robot, constraints, joint_margin, mount, clearance=clearance)
    world, need = _world(robot, constraints, self_collision) if check else (None, None)
    if home is not None:
        home_q, home_source = robot.configurations(home, what="home")[0], "given"
    elif world is not None:  # the zero only when it is clear itself (a UR10's has its wrist below the floor)
        home_q, home_source = default_home(robot, qs, lambda q: bool(np.all(world.distances(q) >= need)))
    else:
        home_q, home_source = default_home(robot, qs)
    nodes = np.vstack([home_q[None], qs])
    cost = timing.matrix(nodes)
    m = len(qs)
    given = list(range(1, m + 1))
    tour = best_tour(cost, given)
    given_time = tour_cost(cost, given) + m * timing.stop
    order = tuple(i - 1 for i in tour.order)
    route = [HOME, *order, HOME]
    if not check:
        unchecked = tuple(
            Move(a, b, float(cost[a + 1, b + 1])) for a, b in zip(route[:-1], route[1:], strict=True)
        )
        return Campaign(
            robot, plan, home_q, order, unchecked, timing, tour.exact, given_time, home_source=home_source
        )
    assert world is not None and need is not None  # check: _world built them above
    at = {i: world.distances(q) for i, q in enumerate(qs)}
    at[HOME] = world.distances(home_q)
    rng = generator(seed)
    margins = joint_margins(robot, constraints)
    lower = robot.model.lowerPositionLimit + margins
    upper = robot.model.upperPositionLimit - margins

    def q_of(i: int) -> np.ndarray:
        return home_q if i == HOME else qs[i]

    moves: list[Move] = []
    steps = Steps(progress, "campaign", "move")
    steps.stage("certified", len(route) - 1)
    for a, b in zip(route[:-1], route[1:], strict=True):
        straight = float(cost[a + 1, b + 1])
        c = certify_move(world, q_of(a), q_of(b), need, (at[a], at[b]))
        detour = None
        ends_clear = np.all(at[a] >= need) and np.all(at[b] >= need)
        if not c.clear and ends_clear:
            detour = find_detour(
                world, q_of(a), q_of(b), need, lower, upper, timing.move_time, rng, extra=(home_q,)
            )
        time = straight
        if detour is not None:
            time = float(timing.move_time(q_of(a), detour.via) + timing.move_time(detour.via, q_of(b)))
        moves.append(Move(a, b, float(time), c, detour))
        steps.advance()
    steps.close()
    worst = [int(np.argmin(at[i] - need)) if world.size else -1 for i in range(m)]
    closest = tuple(world.names[k] if k >= 0 else "" for k in worst)
    pose_distance = np.array([at[i][k] if k >= 0 else np.inf for i, k in enumerate(worst)])
    required_at = np.array([need[k] if k >= 0 else 0.0 for k in worst])
    blocked_sight = []
    for con in constraints:
        if isinstance(con, Visibility):
            tracker = robot.base.inverse() * np.array(con.tracker)
            blocked_sight += occlusions(world, qs, tracker)
    kinds = np.array(world.kinds)
    required = {
        kind: float(need[kinds == kind][0]) if np.any(kinds == kind) else 0.0
        for kind in ("self", "obstacle", "floor")
    }
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
        pose_clearance=pose_distance,
        pose_closest=closest,
        pose_required=required_at,
        home_short=_short(world, at[HOME], need),
        required=required,
        occlusions=tuple(blocked_sight),
        skipped_pairs=tuple(world.skipped),
        home_source=home_source,
    )


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
