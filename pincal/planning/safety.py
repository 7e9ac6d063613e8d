"""How close a plan comes to what a real cell forbids: the joint limits, the floor, the obstacles.

:func:`safety_margins` names, over every configuration of a plan, the smallest distance to a joint
limit (the URDF's hard limit; revolute and prismatic joints apart), the smallest height of a
moving point above the mounting plane and, with a workcell, the smallest distance between the
robot and an obstacle — with the joint, point or pair and the configuration where each occurs, and
what the constraints ask (the margin kept, the clearance). Every report that prints a plan
(design, evaluate, campaign) prints these lines.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from pincal.model.robot import Robot
from pincal.planning.constraints import (
    AnyConstraint,
    Kinematics,
    Mount,
    Workcell,
    joint_margins,
)
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
    """

    angle: Closest | None
    length: Closest | None
    floor: Closest | None
    obstacle: Closest | None
    mount: Mount
    note: str = ""

    @property
    def ok(self) -> bool:
        """Every margin is what the constraints ask."""
        return all(c is None or c.ok for c in (self.angle, self.length, self.floor, self.obstacle))

    def as_dict(self) -> dict:
        def one(c: Closest | None) -> dict | None:
            return None if c is None else c.as_dict()

        return {
            "joint_limit_angle": one(self.angle),
            "joint_limit_length": one(self.length),
            "floor": one(self.floor),
            "obstacle": one(self.obstacle),
            "mount": self.mount.describe(),
            "ok": self.ok,
            "note": self.note,
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
                f"(mount {self.mount.describe()}){flag(f)}"
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
        return out


def _mm(metres: float) -> str:
    return f"{metres * 1e3:.4g} mm" if abs(metres) < 1 else f"{metres:.4g} m"


def safety_margins(
    robot: Robot, plan: ConfigurationsLike, constraints: Iterable[AnyConstraint] = ()
) -> SafetyReport:
    """The smallest margins of ``plan`` to the joint limits, the floor and the obstacles.

    Args:
        robot: the robot.
        plan: (m, nq) configurations [rad or m] or a Plan.
        constraints: the constraints the plan was designed with, the safe defaults included (see
            :func:`~pincal.planning.constraints.with_safety`): their JointLimits give the margin
            asked at each joint, their Mount the plane (none: ``none``), their workcell the
            obstacles.

    Raises:
        BadConfiguration: a configuration of the wrong size or outside the joint limits.
    """
    qs = robot.configurations(plan)
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
    heights = bound.margins(Kinematics(robot, qs))
    if heights.size:
        i, k = np.unravel_index(int(np.argmin(heights)), heights.shape)
        floor = Closest(float(heights[i, k]), int(i), bound.names[k], 0.0)
    obstacle, note = None, ""
    for c in constraints:
        if isinstance(c, Workcell):
            value, pose, pair, note = c.closest(robot, qs)
            if pose >= 0 and (obstacle is None or value < obstacle.value):
                obstacle = Closest(value, pose, pair, c.min_distance)
    return SafetyReport(kinds[0], kinds[1], floor, obstacle, mount, note)
