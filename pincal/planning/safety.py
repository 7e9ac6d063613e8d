"""How close a plan comes to what a real cell forbids: the joint limits, the floor, the obstacles,
the robot itself.

:func:`safety_margins` names, over every configuration of a plan, the smallest distance to a joint
limit (the URDF's hard limit; revolute and prismatic joints apart), the smallest height of a
moving point above the mounting plane, with a workcell the smallest distance between the robot and
an obstacle, and the smallest distance between two links of the robot (its URDF collision
geometry, else capsules from the kinematics; negative: they overlap) — with the joint, point or
pair and the configuration where each occurs, and what the constraints ask (the margin kept, the
clearance). Every report that prints a plan (design, evaluate, show, campaign) prints these lines.
A design keeps clear of the floor and the obstacles by the clearance of the safe defaults (5 cm),
and of its own links when the robot's URDF has collision geometry (a ``self_collision`` constraint
by default); the report checks the plan's m configurations always — with capsules derived from the
kinematics when the URDF has no collision geometry — and warns naming the pose and the pair when
two links meet.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from pincal.errors import PincalWarning, warn
from pincal.model.collision import CollisionWorld
from pincal.model.robot import Robot
from pincal.planning.constraints import (
    AnyConstraint,
    Kinematics,
    Mount,
    SelfCollision,
    Workcell,
    joint_margins,
)
from pincal.planning.plan import Plan
from pincal.typing import ConfigurationsLike

__all__ = ["Closest", "SafetyReport", "safety_margins"]


@dataclass(frozen=True)
class Closest:
    """The smallest margin of one kind over a plan.

    Attributes:
        value: the margin [rad for a revolute joint's limit, else m] (negative: violated).
        pose: the configuration where it occurs (0-based index in the plan).
        what: the joint, the point (``joint_a3 origin``, ``marker 0``) or the pair
            (``link_4 / table``).
        required: what the constraints ask there [rad or m] (the margin kept, the clearance).
    """

    value: float
    pose: int
    what: str
    required: float = 0.0

    @property
    def ok(self) -> bool:
        """The margin is at least what the constraints ask (to rounding)."""
        return self.value >= self.required - 1e-9

    def as_dict(self) -> dict:
        return {"value": self.value, "pose": self.pose, "what": self.what, "required": self.required}


@dataclass(frozen=True)
class SafetyReport:
    """The smallest margins of a plan (see the module doc); a kind that does not apply is None.

    Attributes:
        angle: the revolute joint closest to a limit (margin [rad]).
        length: the prismatic joint closest to a limit (margin [m]).
        floor: the moving point closest to the mounting plane (height [m]).
        obstacle: the robot's geometry closest to a workcell obstacle (distance [m]).
        mount: the mount the plan was checked against.
        note: how the obstacle distances were computed (which robot geometry), or "".
        self_collision: the two links of the robot closest to each other (distance [m], negative
            when they overlap), None when not checked or when no pair of links can meet.
        self_note: how the links' distances were computed (which geometry), or "".
        self_off: the plan was designed with the self-collision check off
            (``SelfCollision(enabled=False)``, ``--self-collision off``): its links are reported,
            not kept apart.
    """

    angle: Closest | None
    length: Closest | None
    floor: Closest | None
    obstacle: Closest | None
    mount: Mount
    note: str = ""
    self_collision: Closest | None = None
    self_note: str = ""
    self_off: bool = False

    @property
    def ok(self) -> bool:
        """Every margin is what the constraints ask."""
        kinds = (self.angle, self.length, self.floor, self.obstacle, self.self_collision)
        return all(c is None or c.ok for c in kinds)

    def as_dict(self) -> dict:
        def one(c: Closest | None) -> dict | None:
            return None if c is None else c.as_dict()

        return {
            "joint_limit_angle": one(self.angle),
            "joint_limit_length": one(self.length),
            "floor": one(self.floor),
            "obstacle": one(self.obstacle),
            "self_collision": one(self.self_collision),
            "mount": self.mount.describe(),
            "ok": self.ok,
            "note": self.note,
            "self_note": self.self_note,
        }

    def lines(self, degrees: bool = True) -> list[str]:
        """The report, one line per kind (poses numbered from 1)."""

        def flag(c: Closest) -> str:
            return "" if c.ok else "  ** below what the constraints keep **"

        out = ["safety (smallest margins over the plan; poses numbered from 1):"]
        if self.angle is not None:
            a = self.angle
            shown = f"{math.degrees(a.value):.3g}°" if degrees else f"{a.value:.4g} rad"
            kept = f"{math.degrees(a.required):.3g}°" if degrees else f"{a.required:.4g} rad"
            out.append(
                f"  joint limit: {a.what} {shown} from its limit at pose {a.pose + 1} (kept: {kept}){flag(a)}"
            )
        if self.length is not None:
            c = self.length
            out.append(
                f"  joint limit: {c.what} {_mm(c.value)} from its limit at pose {c.pose + 1} "
                f"(kept: {_mm(c.required)}){flag(c)}"
            )
        if self.floor is not None:
            f = self.floor
            out.append(
                f"  floor: {f.what} {_mm(f.value)} above the mounting plane at pose {f.pose + 1} "
                f"(kept: {_mm(f.required)}; mount {self.mount.describe()}){flag(f)}"
            )
        else:
            why = "mount none" if self.mount.kind == "none" else "nothing the joints move leaves its height"
            out.append(f"  floor: not checked ({why})")
        if self.obstacle is not None:
            o = self.obstacle
            out.append(
                f"  obstacle: {o.what} {_mm(o.value)} apart at pose {o.pose + 1} "
                f"(kept: {_mm(o.required)}){flag(o)}"
            )
        else:
            out.append("  obstacle: no workcell given (constraints 'workcell:')")
        if self.note:
            out.append(f"  ({self.note})")
        if self.self_collision is not None:
            s = self.self_collision
            collides = "  ** the robot collides with itself **" if s.value <= 0 else flag(s)
            off = " (off: not kept by the design)" if self.self_off else ""
            out.append(f"  self-collision{off}: {_self_line(s)} at pose {s.pose + 1}{collides}")
        if self.self_note:
            out.append(f"  ({self.self_note})")
        return out


def _self_line(s: Closest) -> str:
    """The closest pair of links, in words: how far apart, or how deep they overlap."""
    if s.value <= 0:  # a depth of the meshes' convex hulls, which the meshes' own does not exceed
        return f"{s.what} overlap (by up to {_mm(-s.value)})"
    return f"{s.what} {_mm(s.value)} apart (kept: {_mm(s.required)})"


def _mm(metres: float) -> str:
    return f"{metres * 1e3:.4g} mm" if abs(metres) < 1 else f"{metres:.4g} m"


def safety_margins(
    robot: Robot,
    plan: ConfigurationsLike,
    constraints: Iterable[AnyConstraint] = (),
    *,
    self_collision: bool = True,
) -> SafetyReport:
    """The smallest margins of ``plan`` to the joint limits, the floor, the obstacles and itself.

    Args:
        robot: the robot.
        plan: (m, nq) configurations [rad or m] or a Plan.
        constraints: the constraints the plan was designed with, the safe defaults included (see
            :func:`~pincal.planning.constraints.with_safety`): their JointLimits give the margin
            asked at each joint, their Mount the plane and its clearance (none: ``none``), their
            workcell the obstacles and the clearance kept from them, their SelfCollision the
            clearance between links (default 0).
        self_collision: check each configuration's links against each other (one distance pass
            per configuration: milliseconds); a pose where two links meet is warned of
            (:class:`~pincal.errors.PincalWarning`, naming the pose, from 1, and the pair).

    Raises:
        BadConfiguration: a configuration of the wrong size or outside the joint limits.
    """
    qs = robot.configurations(plan)
    payload = plan.payload if isinstance(plan, Plan) else None  # a compliant robot yields to it
    constraints = tuple(constraints)
    kept = joint_margins(robot, constraints)
    lower, upper = robot.model.lowerPositionLimit, robot.model.upperPositionLimit
    margin = np.minimum(qs - lower, upper - qs)  # (m, nq) to the hard limits
    kinds: list[Closest | None] = []  # revolute, then prismatic; None: no such joint
    for mask in (robot.revolute, ~robot.revolute):
        if not mask.any():
            kinds.append(None)
            continue
        # The joint closest to its limit, relative to the margin kept there.
        excess = np.where(mask, margin - kept, np.inf)
        i, j = np.unravel_index(int(np.argmin(excess)), excess.shape)
        kinds.append(Closest(float(margin[i, j]), int(i), robot.joint_names[j], float(kept[j])))
    mounts = [c for c in constraints if isinstance(c, Mount)]
    mount = mounts[0] if mounts else Mount("none")
    floor = None
    bound = mount.bind(robot)
    heights = bound.margins(Kinematics(robot, qs, payload=payload))
    if heights.size:
        i, k = np.unravel_index(int(np.argmin(heights)), heights.shape)
        floor = Closest(float(heights[i, k]) + mount.clearance, int(i), bound.names[k], mount.clearance)
    obstacle, note = None, ""
    for c in constraints:
        if isinstance(c, Workcell):
            value, pose, pair, note = c.closest(robot, qs, payload)
            if pose >= 0 and (obstacle is None or value < obstacle.value):
                obstacle = Closest(value, pose, pair, c.min_distance)
    itself, self_note = _closest_links(robot, qs, constraints, payload) if self_collision else (None, "")
    off = any(isinstance(c, SelfCollision) and not c.enabled for c in constraints)
    if off:
        self_note = "self-collision off (--self-collision off, SelfCollision(enabled=False))" + (
            f"; {self_note}" if self_note else ""
        )
    if itself is not None and not itself.ok:
        warn(
            f"pose {itself.pose + 1} of the plan: "
            + (
                "the robot collides with itself"
                if itself.value <= 0
                else "two links of the robot come closer"
            )
            + f" ({_self_line(itself)}); "
            + (
                "the plan was designed with the self-collision check off (--self-collision off, "
                "SelfCollision(enabled=False)): check it where the robot's collisions are checked"
                if off
                else "a design keeps its links apart when the robot's URDF has collision geometry (its "
                "'self_collision:' constraint, --constraints, by default)"
            ),
            PincalWarning,
        )
    return SafetyReport(kinds[0], kinds[1], floor, obstacle, mount, note, itself, self_note, off)


def _closest_links(
    robot: Robot, qs: np.ndarray, constraints: tuple[AnyConstraint, ...], payload: np.ndarray | None = None
) -> tuple[Closest | None, str]:
    """The closest pair of the robot's own links over ``qs`` (None: no pair can meet; ``payload``:
    each configuration's payload row, or None) and how the distances were computed; the geometry
    and clearance of the constraints' SelfCollision and Workcell when given (the campaign's checks
    use the same)."""
    selfs = [c for c in constraints if isinstance(c, SelfCollision)]
    cells = [c for c in constraints if isinstance(c, Workcell)]
    radius = next((c.link_radius for c in cells if c.link_radius is not None), None)
    dirs = tuple(d for c in selfs for d in c.package_dirs) + tuple(d for c in cells for d in c.package_dirs)
    try:
        world = CollisionWorld(robot, (), self_collision=True, link_radius=radius, search=dirs)
        distances = world.distances_many(qs, payload=payload) if world.pairs and len(qs) else None
    except RuntimeError as exc:  # coal on a mesh it cannot take (its convex hull: "Too many neighbor")
        why = str(exc).strip().splitlines()[-1].removeprefix("message: ") if str(exc).strip() else "an error"
        return None, f"links not checked: coal could not take the collision geometry ({why})"
    note = f"links checked with {world.geometry.source}"
    if world.skipped:
        note += f"; {len(world.skipped)} pair(s) touching at the zero configuration not checked"
    if distances is None:
        return None, note
    i, k = np.unravel_index(int(np.argmin(distances)), distances.shape)
    required = max((c.min_distance for c in selfs), default=0.0)
    return Closest(float(distances[i, k]), int(i), world.names[k], required), note
