"""Every marker inside an axis-aligned box of the instrument's frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.errors import BadConstraint
from pincal.model.robot import Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, vector


@dataclass(frozen=True)
class WorkspaceBox(Constraint):
    """Every marker inside the box ``lower ≤ p ≤ upper`` (instrument frame).

    Attributes:
        lower: (x, y, z) lower corner [m].
        upper: (x, y, z) upper corner [m].
    """

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]
    key = "workspace_box"

    def __post_init__(self) -> None:
        lower = vector(self.lower, "workspace_box lower")
        upper = vector(self.upper, "workspace_box upper")
        if any(lo >= hi for lo, hi in zip(lower, upper, strict=True)):
            raise BadConstraint(f"workspace_box: lower {lower} must be below upper {upper} on every axis")
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)

    def bind(self, robot: Robot) -> Bound:
        return BoxBound(np.array(self.lower), np.array(self.upper))


class BoxBound(Bound):
    def __init__(self, lower: np.ndarray, upper: np.ndarray) -> None:
        self.lower, self.upper = lower, upper

    def margins(self, kin: Kinematics) -> np.ndarray:
        p = kin.points
        return np.concatenate([p - self.lower, self.upper - p], axis=1).reshape(len(p), -1)
