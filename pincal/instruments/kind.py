"""What an instrument measures: the interface every measurement kind implements (docs/method.md §13.1).

A measurement kind turns a configuration of the robot into r measured values (a *row* of the data:
3 per marker for a point, 6 for a pose, one per component kept for a partial measurement, one per
distance, 2 per target point for an image) and gives their derivative with respect to every
parameter (the rows of the parameter Jacobian, in the instrument's frame). Everything downstream —
identifiability, the criteria, the design, identification and simulation — works on those rows
and their covariance (:mod:`pincal.instruments.error_model`), whatever the kind.

A kind is a frozen value: it holds what describes the measurement (the components kept, the
camera's intrinsics, the target's points), never the placements identified with the robot, which
are the robot's fixtures (:mod:`pincal.model.fixtures`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
import pinocchio as pin

from pincal.model.jacobian import JacobianEngine
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows

POSE_COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")
"""The six components of a pose: position [m] and rotation vector [rad], in the instrument's frame."""


class Kind(ABC):
    """A measurement kind (see module doc). Subclasses are frozen dataclasses.

    Attributes:
        name: the kind's name (``point``, ``pose``, ``partial``, ``distance``, ``image``).
        rotation_invariant: the information of a configuration is unchanged when its rows are
            rotated as the tool turns (a point, a pose): with noise that does not depend on the
            direction, the criteria may take the rows in the tip frame, which is cheaper.
        partial_view: a measurement may read only some of its values, or none (a camera sees
            part of its target): a design draws its candidates where :meth:`reads` is true.
    """

    name: ClassVar[str] = ""
    rotation_invariant: ClassVar[bool] = False
    partial_view: ClassVar[bool] = False

    # ----------------------------------------------------------------- what is measured
    @abstractmethod
    def coordinates(self, robot: Robot) -> tuple[str, ...]:
        """The name of each measured value of a row (also its column in a data file)."""

    @abstractmethod
    def units(self, robot: Robot) -> tuple[str, ...]:
        """The unit of each measured value: ``"m"``, ``"rad"`` or ``"px"``."""

    def size(self, robot: Robot) -> int:
        """r, the values of one row."""
        return len(self.coordinates(robot))

    def components(self, robot: Robot) -> tuple[tuple[int, int] | None, ...]:
        """For each value, (marker k, pose component c) when it is component c (0..5: x, y, z, rx,
        ry, rz) of marker k's frame in the instrument's frame, else None (a distance, a pixel):
        a tracker's error model applies to the position components."""
        return (None,) * self.size(robot)

    def blocks(self, robot: Robot) -> tuple[tuple[int, ...], ...]:
        """The values that belong together (one marker's, one target point's): outliers are scored
        and reported by block."""
        return tuple((i,) for i in range(self.size(robot)))

    def check(self, robot: Robot) -> None:  # noqa: B027 (most kinds need nothing)
        """Raise a :class:`~pincal.errors.BadArgument` when ``robot`` lacks what the kind needs
        (its markers, its fixtures)."""

    def describe(self) -> str:
        """The kind in a few words, for reports."""
        return self.name

    def as_dict(self) -> dict:
        """JSON-ready description."""
        return {"kind": self.name}

    # ---------------------------------------------------------------------- prediction
    @abstractmethod
    def predict(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, r) the values the instrument would read on ``robot`` at joint readings ``qs`` (m, nq)
        [m, rad or px] (validated by the caller), with the payload rows of each configuration."""

    def difference(self, measured: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """(m, r) measured − predicted (NaN where a value was not measured)."""
        return measured - predicted

    def seen(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, r) True where the instrument can read the value at ``qs`` (a camera: the point is in
        its view); every value by default."""
        return np.ones((len(qs), self.size(robot)), dtype=bool)

    def weights(
        self, engine: JacobianEngine, qs: np.ndarray, rows: np.ndarray, payload: PayloadRows = None
    ) -> np.ndarray:
        """(m, r) the share of each value's information a measurement at ``qs`` is expected to
        deliver, given its rows (m, r, P) from :meth:`rows`: 1 where :meth:`seen`, 0 elsewhere by
        default. A kind whose view depends on the errors still unknown (a camera: a corner near the
        image's edge) weighs each value by how likely it is read (:meth:`Image.weights`)."""
        return self.seen(engine.robot, qs, payload).astype(float)

    def reads(self, engine: JacobianEngine, qs: np.ndarray) -> np.ndarray:
        """(m,) True where a measurement at ``qs`` (no payload) is likely to read all that its
        configuration can reveal: the rows its :meth:`weights` count span what the rows of all
        its values span. Every configuration by default; a camera's where it likely reads enough
        of the target (:meth:`Image.reads`)."""
        return np.ones(len(qs), dtype=bool)

    @abstractmethod
    def rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, r, P) the parameter Jacobian of the measured values at ``qs``, in the instrument's
        frame, for ``engine``'s parameter set on its robot."""

    def tip_rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """The rows in each configuration's tip frame where the kind is rotation invariant (cheaper;
        the same information under direction-free noise); :meth:`rows` otherwise."""
        return self.rows(engine, qs, payload)


# ------------------------------------------------------------------------ shared helpers
def marker_frame(robot: Robot, k: int) -> pin.SE3:
    """Marker k's frame in the tip frame: the tip's axes at the marker."""
    return pin.SE3(np.eye(3), np.array(robot.markers[k]))


def marker_frame_rows(
    engine: JacobianEngine, qs: np.ndarray, k: int, payload: PayloadRows, pose: bool = True
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """(J, R, p): marker k's frame twist rows (m, 6, P) in its own axes (the marker's own
    parameters included), its orientations (m, 3, 3) and positions (m, 3) in the instrument's frame
    (None, None without ``pose``: :meth:`~pincal.model.jacobian.JacobianEngine.frame_rows`)."""
    J, R, p = engine.frame_rows(qs, marker_frame(engine.robot, k), payload, pose)
    J[:, :3] += engine.marker_columns()[k]
    return J, R, p


def in_world(J: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(m, 6, P) twist rows in a frame's axes (linear, angular) rotated into the instrument's axes."""
    out = np.empty_like(J)
    out[:, :3] = np.matmul(R, J[:, :3])
    out[:, 3:] = np.matmul(R, J[:, 3:])
    return out


def marker_poses(robot: Robot, qs: np.ndarray, payload: PayloadRows) -> tuple[np.ndarray, np.ndarray]:
    """(R, p): every marker frame's orientation (m, K, 3, 3) and position (m, K, 3) in the
    instrument's frame (the markers' frames have the tip's axes)."""
    rotations, positions = ForwardKinematics(robot).tip(qs, payload)
    points = positions[:, None, :] + np.einsum("mij,kj->mki", rotations, robot.markers)
    return np.broadcast_to(rotations[:, None], (len(qs), robot.n_markers, 3, 3)), points


def rotation_vectors(R: np.ndarray) -> np.ndarray:
    """(..., 3) log₃ of rotation matrices (..., 3, 3) [rad]."""
    flat = R.reshape(-1, 3, 3)
    return np.array([pin.log3(r) for r in flat]).reshape(R.shape[:-2] + (3,))


def numbered(names: tuple[str, ...], count: int) -> tuple[str, ...]:
    """Column names of ``count`` markers: the names as they are for one, suffixed by the marker's
    index for several (``x0, y0, z0, x1, ...``)."""
    if count == 1:
        return names
    return tuple(f"{n}{k}" for k in range(count) for n in names)
