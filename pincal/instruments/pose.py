"""Poses and partial poses: the position and orientation of each marker's frame, or some of their
components (docs/method.md §13.1).

A marker's frame has the tip frame's axes at the marker (a motion-capture rigid body or a 6-DoF
tracker probe defined on the tool). Its pose in the instrument's frame is read as the position
(x, y, z) [m] and the rotation vector (rx, ry, rz) = log₃(R) [rad].

* :class:`Pose`: all six per marker. The orientation's residual is the rotation vector of
  R_measured·R_predictedᵀ (no wrap-around at ±π), and its rows are the frame's angular velocity
  rows in the instrument's axes.
* :class:`Partial`: any subset of the six per marker (``z`` for a height gauge, ``x,y`` for a probe
  on a plane), as a mask per marker. A rotation component is a component of log₃(R); its rows are
  those of log₃ (Pinocchio's ``Jlog3``).

A pose reveals what a point hides: the offset of the last joint when the marker is on its axis
(the frame turns), and a marker's own position along with the tip's orientation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument
from pincal.instruments.kind import (
    POSE_COMPONENTS,
    Kind,
    in_world,
    marker_frame_rows,
    marker_poses,
    numbered,
    rotation_vectors,
)
from pincal.model.jacobian import JacobianEngine
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows


def _units(components: tuple[int, ...]) -> tuple[str, ...]:
    return tuple("m" if c < 3 else "rad" for c in components)


@dataclass(frozen=True)
class Pose(Kind):
    """Each marker frame's position [m] and rotation vector [rad]: 6K values per configuration."""

    name: ClassVar[str] = "pose"
    rotation_invariant: ClassVar[bool] = True

    def coordinates(self, robot: Robot) -> tuple[str, ...]:
        return numbered(POSE_COMPONENTS, robot.n_markers)

    def units(self, robot: Robot) -> tuple[str, ...]:
        return _units(tuple(range(6))) * robot.n_markers

    def components(self, robot: Robot) -> tuple[tuple[int, int] | None, ...]:
        return tuple((k, c) for k in range(robot.n_markers) for c in range(6))

    def blocks(self, robot: Robot) -> tuple[tuple[int, ...], ...]:
        return tuple(tuple(range(6 * k, 6 * k + 6)) for k in range(robot.n_markers))

    def predict(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        R, p = marker_poses(robot, qs, payload)
        return np.concatenate([p, rotation_vectors(R)], axis=2).reshape(len(qs), -1)

    def difference(self, measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        m = len(measured)
        a, b = measured.reshape(m, -1, 6), predicted.reshape(m, -1, 6)
        out = a - b
        for i, k in zip(*np.nonzero(np.all(np.isfinite(a[:, :, 3:]), axis=2))):
            out[i, k, 3:] = pin.log3(pin.exp3(a[i, k, 3:]) @ pin.exp3(b[i, k, 3:]).T)
        return out.reshape(m, -1)

    def rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return self._rows(engine, qs, payload, world=True)

    def tip_rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return self._rows(engine, qs, payload, world=False)

    def _rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows, world: bool) -> np.ndarray:
        blocks = []
        for k in range(engine.robot.n_markers):
            J, R, _ = marker_frame_rows(engine, qs, k, payload, pose=world)
            if world:
                assert R is not None  # pose=True: the frame's orientations come with its rows
                J = in_world(J, R)
            blocks.append(J)
        return np.concatenate(blocks, axis=1)


@dataclass(frozen=True)
class Partial(Kind):
    """Some components of each marker frame's pose (see module doc).

    Args:
        masks: for each marker, the components measured, among ``x y z rx ry rz``; one mask for
            every marker when a single one is given. Kept in that canonical order.
    """

    masks: tuple[tuple[str, ...], ...] = (("z",),)
    name: ClassVar[str] = "partial"

    def __post_init__(self) -> None:
        masks = tuple(tuple(m) for m in ((self.masks,) if isinstance(self.masks[0], str) else self.masks))
        checked = []
        for mask in masks:
            bad = [c for c in mask if c not in POSE_COMPONENTS]
            if bad or not mask or len(set(mask)) != len(mask):
                raise BadArgument(
                    f"partial measurement {','.join(mask) or '(empty)'}: give distinct components among "
                    f"{', '.join(POSE_COMPONENTS)}",
                    argument="measure",
                    value=",".join(mask),
                    valid=POSE_COMPONENTS,
                )
            checked.append(tuple(c for c in POSE_COMPONENTS if c in mask))
        object.__setattr__(self, "masks", tuple(checked))

    def mask(self, robot: Robot, k: int) -> tuple[int, ...]:
        """The component indices (0..5) measured on marker k."""
        mask = self.masks[0] if len(self.masks) == 1 else self.masks[k]
        return tuple(POSE_COMPONENTS.index(c) for c in mask)

    def check(self, robot: Robot) -> None:
        if len(self.masks) not in (1, robot.n_markers):
            raise BadArgument(
                f"partial measurement: {len(self.masks)} masks for {robot.n_markers} marker(s); give one "
                f"for every marker, or one per marker (separated by '/')",
                argument="measure",
            )

    def describe(self) -> str:
        return "partial (" + " / ".join(",".join(m) for m in self.masks) + ")"

    def as_dict(self) -> dict:
        return {"kind": self.name, "masks": [list(m) for m in self.masks]}

    def coordinates(self, robot: Robot) -> tuple[str, ...]:
        K = robot.n_markers
        return tuple(
            POSE_COMPONENTS[c] + (str(k) if K > 1 else "") for k in range(K) for c in self.mask(robot, k)
        )

    def units(self, robot: Robot) -> tuple[str, ...]:
        return tuple(u for k in range(robot.n_markers) for u in _units(self.mask(robot, k)))

    def components(self, robot: Robot) -> tuple[tuple[int, int] | None, ...]:
        return tuple((k, c) for k in range(robot.n_markers) for c in self.mask(robot, k))

    def blocks(self, robot: Robot) -> tuple[tuple[int, ...], ...]:
        out, start = [], 0
        for k in range(robot.n_markers):
            n = len(self.mask(robot, k))
            out.append(tuple(range(start, start + n)))
            start += n
        return tuple(out)

    def predict(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        R, p = marker_poses(robot, qs, payload)
        full = np.concatenate([p, rotation_vectors(R)], axis=2)
        return np.concatenate([full[:, k, list(self.mask(robot, k))] for k in range(robot.n_markers)], axis=1)

    def rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        blocks = []
        for k in range(engine.robot.n_markers):
            mask = self.mask(engine.robot, k)
            J, R, _ = marker_frame_rows(engine, qs, k, payload)
            assert R is not None  # pose=True (the default): the frame's orientations come with its rows
            world = np.matmul(R, J[:, :3])
            if any(c >= 3 for c in mask):
                logs = np.array([pin.Jlog3(r) for r in R])
                angular = np.matmul(logs, J[:, 3:])
                world = np.concatenate([world, angular], axis=1)
            blocks.append(world[:, list(mask)])
        return np.concatenate(blocks, axis=1)


def partial_from_text(text: str) -> Partial:
    """A :class:`Partial` from ``"z"``, ``"x,y"`` or per marker ``"x,y/z"``."""
    return Partial(tuple(tuple(c.strip() for c in part.split(",") if c.strip()) for part in text.split("/")))
