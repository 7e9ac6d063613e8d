"""Every marker on one side of a plane (normal · p ≥ offset)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.errors import BadConstraint
from pincal.model.robot import Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number, vector


@dataclass(frozen=True)
class HalfSpace(Constraint):
    """Every marker on the side of a plane where ``normal · p ≥ offset`` (instrument frame).

    Example: ``HalfSpace((0, 0, 1), 0.3)`` keeps the markers at least 0.3 m above z = 0.

    Attributes:
        normal: (3,) plane normal, pointing to the allowed side (normalised on construction).
        offset: signed distance of the plane from the origin along ``normal`` [m].
    """

    normal: tuple[float, float, float]
    offset: float = 0.0
    key = "half_space"

    def __post_init__(self) -> None:
        n = np.array(vector(self.normal, "half_space normal"))
        if np.linalg.norm(n) < 1e-12:
            raise BadConstraint("half_space normal must not be zero")
        object.__setattr__(self, "normal", tuple(float(v) for v in n / np.linalg.norm(n)))
        object.__setattr__(self, "offset", number(self.offset, "half_space offset"))

    def bind(self, robot: Robot) -> Bound:
        return HalfSpaceBound(np.array(self.normal), self.offset)


class HalfSpaceBound(Bound):
    def __init__(self, normal: np.ndarray, offset: float) -> None:
        self.normal, self.offset = normal, offset

    def margins(self, kin: Kinematics) -> np.ndarray:
        return kin.points @ self.normal - self.offset
