"""The URDF joint limits, shrunk by a margin (always applied)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.errors import Infeasible
from pincal.model.robot import LIMIT_TOLERANCE, Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number


@dataclass(frozen=True)
class JointLimits(Constraint):
    """Keep ``margin`` away from every joint limit.

    Attributes:
        margin: distance kept from each limit [rad, or m for a prismatic joint].
    """

    margin: float = 0.0
    key = "joint_limits"

    def __post_init__(self) -> None:
        object.__setattr__(self, "margin", number(self.margin, "joint_limits margin", 0.0))

    def bind(self, robot: Robot) -> Bound:
        return LimitsBound(robot, self.margin)


class LimitsBound(Bound):
    def __init__(self, robot: Robot, margin: float) -> None:
        self.lower = robot.model.lowerPositionLimit + margin
        self.upper = robot.model.upperPositionLimit - margin
        if np.any(self.upper < self.lower):
            j = int(np.argmax(self.lower - self.upper))
            raise Infeasible(
                f"joint limit margin {margin:g} leaves no room between the limits of joint "
                f"{robot.joint_names[j]}"
            )

    def margins(self, kin: Kinematics) -> np.ndarray:
        return np.minimum(kin.qs - self.lower, self.upper - kin.qs)

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        return np.all(self.margins(kin) >= -LIMIT_TOLERANCE, axis=1)
