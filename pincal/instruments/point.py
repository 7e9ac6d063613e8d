"""Points: the position of each marker, three coordinates in the instrument's frame (a laser
tracker's reflector, a probe's tip; docs/method.md §2.4 and §13.1)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pincal.instruments.kind import Kind, numbered
from pincal.model.jacobian import JacobianEngine
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows


@dataclass(frozen=True)
class Point(Kind):
    """Each marker's position (x, y, z) [m]: 3K values per configuration."""

    name: ClassVar[str] = "point"
    rotation_invariant: ClassVar[bool] = True

    def coordinates(self, robot: Robot) -> tuple[str, ...]:
        return numbered(("x", "y", "z"), robot.n_markers)

    def units(self, robot: Robot) -> tuple[str, ...]:
        return ("m",) * (3 * robot.n_markers)

    def components(self, robot: Robot) -> tuple[tuple[int, int] | None, ...]:
        return tuple((k, c) for k in range(robot.n_markers) for c in range(3))

    def blocks(self, robot: Robot) -> tuple[tuple[int, ...], ...]:
        return tuple((3 * k, 3 * k + 1, 3 * k + 2) for k in range(robot.n_markers))

    def predict(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return ForwardKinematics(robot).markers(qs, payload).reshape(len(qs), -1)

    def rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return engine.jacobian(qs, frame="world", payload=payload)

    def tip_rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return engine.jacobian(qs, frame="tip", payload=payload)
