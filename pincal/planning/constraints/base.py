"""The base of every constraint: the exact-check tolerance, the batch kinematics a constraint
reads, a constraint bound to a robot (:class:`Bound`: margins, exact check) and the checks of a
constraint's numbers."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint
from pincal.model.robot import Robot

TOLERANCE = 1e-9
"""Slack [m or rad] allowed when checking a constraint exactly (rounding)."""


def vector(value: object, what: str, size: int = 3) -> tuple[float, ...]:
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise BadConstraint(f"{what} must be {size} numbers, got {value!r}") from None
    if arr.size != size or not np.all(np.isfinite(arr)):
        raise BadConstraint(f"{what} must be {size} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def number(value: object, what: str, low: float = -math.inf, strict: bool = False) -> float:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        raise BadConstraint(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < low or (strict and v == low):
        bound = f"{'>' if strict else '≥'} {low:g}"
        raise BadConstraint(f"{what} must be a finite number {bound}, got {value!r}")
    return v


class Kinematics:
    """Tip poses and marker positions of a batch of configurations, in the instrument frame.

    Attributes:
        qs: (m, nq) configurations.
        rotations: (m, 3, 3) tip orientations.
        positions: (m, 3) tip positions [m].
        points: (m, K, 3) marker positions [m].
    """

    def __init__(self, robot: Robot, qs: np.ndarray, data: pin.Data | None = None) -> None:
        self.qs = qs
        self.rotations, self.positions = robot.tip_poses(qs, check=False, data=data)
        self.points = self.positions[:, None, :] + np.einsum("mij,kj->mki", self.rotations, robot.markers)


class Bound:
    """A per-configuration constraint bound to a robot (may hold Pinocchio/coal data)."""

    reach: float = 0.05
    """Distance from the boundary [m or rad] within which the search's barrier acts."""

    def margins(self, kin: Kinematics) -> np.ndarray:
        """(m, c) signed margins [m or rad]: ≥ 0 where satisfied (smooth where possible)."""
        raise NotImplementedError

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        """(m,) True where the configuration satisfies the constraint exactly."""
        return np.all(self.margins(kin) >= -TOLERANCE, axis=1)


class Constraint:
    """Base of the per-configuration constraints."""

    key: str = ""

    def bind(self, robot: Robot) -> Bound:  # pragma: no cover - abstract
        raise NotImplementedError

    def satisfied(self, robot: Robot, q: object) -> np.ndarray:
        """(m,) True where configuration i of ``q`` (validated) satisfies this constraint."""
        qs = robot.configurations(q)
        return self.bind(robot).satisfied(Kinematics(robot, qs))
