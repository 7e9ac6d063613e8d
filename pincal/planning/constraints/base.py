"""The base of every constraint: the exact-check tolerance, the batch kinematics a constraint
reads, a constraint bound to a robot (:class:`Bound`: margins, exact check) and the checks of a
constraint's numbers."""

from __future__ import annotations

from functools import cached_property

import numpy as np
import pinocchio as pin

from pincal import arguments
from pincal.arguments import MAX_LENGTH
from pincal.errors import BadConstraint
from pincal.model.kinematics import ForwardKinematics, marker_positions
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows
from pincal.typing import ConfigurationsLike

TOLERANCE = 1e-9
"""Slack [m or rad] allowed when checking a constraint exactly (rounding)."""


def vector(value: object, what: str, size: int = 3) -> tuple[float, ...]:
    """``size`` numbers (a position [m] or a direction), each within ±1e6 (see
    :func:`pincal.arguments.point`)."""
    return tuple(float(v) for v in arguments.point(value, what, size, BadConstraint))


def number(value: object, what: str, low: float = -MAX_LENGTH, strict: bool = False) -> float:
    """A length [m] or angle [rad] from ``low`` (excluded when ``strict``) to 1e6 (see
    :func:`pincal.arguments.number`: booleans and text refused)."""
    return arguments.number(value, what, low, MAX_LENGTH, low_open=strict, error=BadConstraint)


class Kinematics:
    """Tip poses and marker positions of a batch of configurations, in the instrument frame,
    computed when a constraint first reads them (the joint limits never do), with the robot's
    gains and compliances under the payload (:class:`~pincal.model.kinematics.ForwardKinematics`,
    which the mount and the collision checks read too).

    Attributes:
        qs: (m, nq) configurations (the joints' readings).
        payload: (m, 4) the payload rows [kg, x, y, z] of the configurations, or None (none).
        rotations: (m, 3, 3) tip orientations.
        positions: (m, 3) tip positions [m].
        points: (m, K, 3) marker positions [m].
    """

    def __init__(
        self,
        robot: Robot,
        qs: np.ndarray,
        data: pin.Data | None = None,
        payload: PayloadRows = None,
        *,
        forward: ForwardKinematics | None = None,
    ) -> None:
        self.robot, self.qs, self._data = robot, qs, data
        self.payload = payload
        if forward is not None:
            self.__dict__["forward"] = forward

    @cached_property
    def forward(self) -> ForwardKinematics:
        """The robot's forward kinematics (made on first use, when none was given)."""
        return ForwardKinematics(self.robot, self._data)

    @cached_property
    def _tip(self) -> tuple[np.ndarray, np.ndarray]:
        return self.forward.tip(self.qs, self.payload)

    @property
    def rotations(self) -> np.ndarray:
        return self._tip[0]

    @property
    def positions(self) -> np.ndarray:
        return self._tip[1]

    @cached_property
    def points(self) -> np.ndarray:
        return marker_positions(self.robot, self.rotations, self.positions)

    def subset(self, idx: np.ndarray) -> Kinematics:
        """The kinematics of configurations ``idx`` (what is computed already is kept, not redone)."""
        payload = None if self.payload is None else self.payload[idx]
        sub = Kinematics(self.robot, self.qs[idx], payload=payload, forward=self.forward)
        if "_tip" in self.__dict__:
            sub.__dict__["_tip"] = (self.rotations[idx], self.positions[idx])
        if "points" in self.__dict__:
            sub.__dict__["points"] = self.points[idx]
        return sub


class Bound:
    """A per-configuration constraint bound to a robot (may hold Pinocchio/coal data)."""

    reach: float = 0.05
    """Distance from the boundary [m or rad] within which the continuous search reads the margin
    (beyond it the constraint does not bind: its value there is the reach)."""

    @property
    def empty(self) -> bool:
        """True when the bound checks nothing (a mount of kind ``none``): no constraint then."""
        return False

    def margins(self, kin: Kinematics) -> np.ndarray:
        """(m, c) signed margins [m or rad]: ≥ 0 where satisfied (smooth where possible)."""
        raise NotImplementedError

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        """(m,) True where the configuration satisfies the constraint exactly."""
        return np.all(self.margins(kin) >= -TOLERANCE, axis=1)

    def strictly_satisfied(self, kin: Kinematics) -> np.ndarray:
        """(m,) :meth:`satisfied`, and every margin positive (where a continuous search starts; a
        bound whose margins are lower bounds of an exact check, e.g. convex hulls, needs both)."""
        ok = self.satisfied(kin)
        if ok.any():
            ok[ok] = np.all(self.margins(kin.subset(np.flatnonzero(ok))) > 0, axis=1)
        return ok


class NothingChecked(Bound):
    """A bound that checks nothing (an optional check with nothing to check, a constraint another
    one carries): empty, every configuration satisfies it."""

    @property
    def empty(self) -> bool:
        return True

    def margins(self, kin: Kinematics) -> np.ndarray:
        return np.zeros((len(kin.qs), 0))

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        return np.ones(len(kin.qs), dtype=bool)


class Constraint:
    """Base of the per-configuration constraints."""

    key: str = ""

    def bind(self, robot: Robot) -> Bound:  # pragma: no cover - abstract
        raise NotImplementedError

    def satisfied(self, robot: Robot, q: ConfigurationsLike) -> np.ndarray:
        """(m,) True where configuration i of ``q`` (validated) satisfies this constraint."""
        qs = robot.configurations(q)
        return self.bind(robot).satisfied(Kinematics(robot, qs))
