"""Any two configurations of a plan at least a distance apart in joint space."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.model.robot import Robot
from pincal.planning.constraints.base import TOLERANCE, number
from pincal.typing import ConfigurationsLike


@dataclass(frozen=True)
class MinSpacing:
    """Any two configurations of a plan at least ``distance`` apart (Euclidean norm [rad or m]).

    Attributes:
        distance: smallest allowed ‖qᵢ − qⱼ‖ between configurations [rad, or m for prismatic joints].
    """

    distance: float
    key = "min_spacing"
    reach = 0.05

    def __post_init__(self) -> None:
        object.__setattr__(self, "distance", number(self.distance, "min_spacing distance", 0.0))

    def margins(self, qs: np.ndarray) -> np.ndarray:
        """(m(m−1)/2,) ‖qᵢ − qⱼ‖ − distance over pairs i < j [rad]."""
        i, j = np.triu_indices(len(qs), 1)
        return np.linalg.norm(qs[i] - qs[j], axis=1) - self.distance

    def satisfied(self, robot: Robot, q: ConfigurationsLike) -> np.ndarray:
        """(m,) False for configuration j when it is too close to an earlier one."""
        qs = robot.configurations(q)
        i, j = np.triu_indices(len(qs), 1)
        bad = np.linalg.norm(qs[i] - qs[j], axis=1) < self.distance - TOLERANCE
        out = np.ones(len(qs), dtype=bool)
        out[j[bad]] = False
        return out
