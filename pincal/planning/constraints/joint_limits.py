"""The URDF joint limits, shrunk by a margin (always applied).

A design keeps :data:`DEFAULT_JOINT_LIMITS` by default: 2° inside the limits of every revolute
joint and 1 cm inside those of every prismatic joint — controllers stop at soft limits inside the
hard ones, and a plan that sits on a hard limit cannot be run — but never more than a tenth of a
joint's range from each end, so that a joint with a narrow range still moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.errors import BadConstraint, Infeasible
from pincal.model.robot import LIMIT_TOLERANCE, Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number


@dataclass(frozen=True)
class JointLimits(Constraint):
    """Keep a margin away from every joint limit.

    Attributes:
        margin: distance kept from each limit [rad] (and [m] for a prismatic joint when
            ``prismatic`` is None).
        prismatic: distance kept from the limits of the prismatic joints [m] (None: ``margin``).
        fraction: at most this fraction of each joint's range is kept from each end (None: the
            margin is kept whole, or refused as Infeasible when it leaves no room).
    """

    margin: float = 0.0
    prismatic: float | None = None
    fraction: float | None = None
    key = "joint_limits"

    def __post_init__(self) -> None:
        object.__setattr__(self, "margin", number(self.margin, "joint_limits margin", 0.0))
        if self.prismatic is not None:
            object.__setattr__(
                self, "prismatic", number(self.prismatic, "joint_limits prismatic margin", 0.0)
            )
        if self.fraction is not None:
            value = number(self.fraction, "joint_limits fraction", 0.0)
            if value >= 0.5:
                raise BadConstraint(f"joint_limits fraction must be below 0.5 of the range, got {value:g}")
            object.__setattr__(self, "fraction", value)

    def margins_for(self, robot: Robot) -> np.ndarray:
        """(nq,) the margin kept at each of ``robot``'s joints [rad or m]."""
        length = self.margin if self.prismatic is None else self.prismatic
        out = np.where(robot.revolute, self.margin, length).astype(float)
        if self.fraction is not None:
            span = robot.model.upperPositionLimit - robot.model.lowerPositionLimit
            out = np.minimum(out, self.fraction * span)
        return out

    def describe(self) -> str:
        """``2° (1 cm on prismatic joints)``: the margin in words."""
        text = f"{math.degrees(self.margin):.3g}°"
        if self.prismatic is not None and self.prismatic != self.margin:
            text += f" ({self.prismatic * 100:.3g} cm on prismatic joints)"
        return text

    def bind(self, robot: Robot) -> Bound:
        return LimitsBound(robot, self.margins_for(robot))


DEFAULT_JOINT_LIMITS = JointLimits(math.radians(2.0), 0.01, fraction=0.1)
"""The margin a design keeps from the joint limits unless told otherwise: 2° on revolute joints,
1 cm on prismatic ones, at most a tenth of each joint's range from each end."""


class LimitsBound(Bound):
    def __init__(self, robot: Robot, margin: float | np.ndarray) -> None:
        self.margin = np.broadcast_to(np.asarray(margin, dtype=float), (robot.nq,))
        self.lower = robot.model.lowerPositionLimit + self.margin
        self.upper = robot.model.upperPositionLimit - self.margin
        if np.any(self.upper < self.lower):
            j = int(np.argmax(self.lower - self.upper))
            raise Infeasible(
                f"joint limit margin {self.margin[j]:g} leaves no room between the limits of joint "
                f"{robot.joint_names[j]}"
            )

    def margins(self, kin: Kinematics) -> np.ndarray:
        return np.minimum(kin.qs - self.lower, self.upper - kin.qs)

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        return np.all(self.margins(kin) >= -LIMIT_TOLERANCE, axis=1)
