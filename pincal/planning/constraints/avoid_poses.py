"""Keep away from given configurations (poses found unreachable, or not to be measured again)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.errors import BadConstraint
from pincal.model.robot import Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number


@dataclass(frozen=True, eq=False)
class AvoidPoses(Constraint):
    """Every configuration at least ``distance`` from each of ``poses`` (Euclidean norm of the joint
    differences [rad, or m for prismatic joints]).

    Used by the adaptive campaign (:func:`pincal.next_poses`) to keep the next poses away from
    planned poses the robot could not reach, or the instrument could not see.

    Attributes:
        poses: (k, nq) configurations to keep away from [rad or m].
        distance: how far [rad or m].
    """

    poses: np.ndarray
    distance: float
    key = "avoid_poses"
    reach = 0.05

    def __post_init__(self) -> None:
        try:
            poses = np.array(self.poses, dtype=float, copy=True)
        except (TypeError, ValueError):
            raise BadConstraint(f"avoid_poses: poses must be numbers, got {self.poses!r}") from None
        if poses.ndim == 1:
            poses = poses[None, :]
        if poses.ndim != 2 or not np.all(np.isfinite(poses)):
            raise BadConstraint(
                f"avoid_poses: poses must be (k, nq) finite joint values, got shape {poses.shape}"
            )
        poses.flags.writeable = False
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "distance", number(self.distance, "avoid_poses distance", 0.0))

    def bind(self, robot: Robot) -> Bound:
        if self.poses.shape[1] != robot.nq:
            raise BadConstraint(
                f"avoid_poses: {self.poses.shape[1]} joint values per pose, the robot has {robot.nq}"
            )
        return AvoidBound(self.poses, self.distance)


class AvoidBound(Bound):
    reach = 0.05

    def __init__(self, poses: np.ndarray, distance: float) -> None:
        self.poses, self.distance = poses, distance

    def margins(self, kin: Kinematics) -> np.ndarray:
        if not len(self.poses):
            return np.zeros((len(kin.qs), 0))
        d = np.linalg.norm(kin.qs[:, None, :] - self.poses[None, :, :], axis=2)
        return d.min(axis=1, keepdims=True) - self.distance
