"""Fixtures: the rigid parts of a measurement set-up whose placement is identified with the robot
(docs/method.md §13.1).

A point or pose measurement needs only the markers on the tool and the robot's base in the
instrument's frame (:class:`~pincal.Robot`'s ``markers`` and ``base``). Other instruments bring
parts of their own whose placement is known only roughly and is identified with the robot's
geometry:

* a draw-wire sensor's or a ballbar's fixed end, an *anchor* point in the instrument's frame;
* a camera and the target it sees (a grid of known points), one fixed to the tool and the other
  in the cell (eye-in-hand: the camera on the tool; eye-to-hand: the target on the tool).

A :class:`Fixture` is one such part: a name (``camera``, ``target``, ``anchor0``), its nominal
placement and what it is fixed to — the tip frame (``on="tip"``) or the instrument's frame
(``on="world"``). Its errors are parameters like a joint origin's (docs/method.md §2.1):
``<name>.tx|ty|tz`` add to the placement's translation, in the coordinates of what it is fixed to
[m], and ``<name>.rx|ry|rz`` turn it about its own axes (R ← R·exp₃(δω)) [rad]. A point fixture (an
anchor) has a position only: ``<name>.x|y|z`` [m]. Fixtures do not move the markers: their columns
of the point Jacobian are zero, and the measurement kinds of :mod:`pincal.instruments` fill them.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.arguments import MAX_LENGTH
from pincal.errors import BadArgument

MOUNTS = ("tip", "world")
"""What a fixture may be fixed to: the robot's tip frame, or the instrument's frame."""

RESERVED = ("base", "marker", "tip")
"""Names no fixture may take (they name the robot's own parameters)."""

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


@dataclass(frozen=True, eq=False)
class Fixture:
    """A rigid part of the measurement set-up, identified with the robot (see module doc).

    Attributes:
        name: its name in parameter names (``camera`` gives ``camera.tx`` ... ``camera.rz``).
        placement: its nominal placement in what it is fixed to (a new copy is kept) [m, rad].
        on: ``"tip"`` (fixed to the tool) or ``"world"`` (fixed in the instrument's frame).
        point: it is a point (an anchor): a position only, three parameters ``<name>.x|y|z``.
    """

    name: str
    placement: pin.SE3
    on: str = "world"
    point: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name) or self.name in RESERVED:
            raise BadArgument(
                f"fixture name {self.name!r}: a letter then letters, digits or '_', and not one of "
                f"{', '.join(RESERVED)}",
                argument="fixture",
                value=self.name,
            )
        if self.on not in MOUNTS:
            raise BadArgument(
                f"fixture {self.name!r}: on={self.on!r}; valid: {', '.join(MOUNTS)}",
                argument="fixture",
                value=self.on,
                valid=MOUNTS,
            )
        placement = placement_of(self.placement, f"fixture {self.name!r}")
        if self.point:
            placement = pin.SE3(np.eye(3), placement.translation)
        object.__setattr__(self, "placement", placement)

    @property
    def components(self) -> tuple[str, ...]:
        """The names of its parameters' components: ``x y z`` for a point, else ``tx ... rz``."""
        return ("x", "y", "z") if self.point else ("tx", "ty", "tz", "rx", "ry", "rz")

    def moved(self, twist: np.ndarray) -> Fixture:
        """The fixture with errors ``twist`` (δt, δω) (6,) applied: t + δt, R·exp₃(δω)."""
        placement = pin.SE3(
            self.placement.rotation @ pin.exp3(np.asarray(twist[3:], dtype=float)),
            self.placement.translation + np.asarray(twist[:3], dtype=float),
        )
        return Fixture(self.name, placement, self.on, self.point)

    def __repr__(self) -> str:
        xyz = ", ".join(f"{v:.6g}" for v in self.placement.translation)
        return f"Fixture({self.name!r}, on={self.on!r}, xyz=({xyz}){', point' if self.point else ''})"


def placement_of(value: object, what: str) -> pin.SE3:
    """A new ``pin.SE3`` from a placement: an SE3, a 4×4 matrix, (x, y, z) or
    (x, y, z, roll, pitch, yaw) [m, rad].

    Raises:
        BadArgument: anything else, a non-finite value, a translation beyond
            :data:`~pincal.arguments.MAX_LENGTH` or a 4×4 matrix whose rotation is not one.
    """
    if isinstance(value, pin.SE3):
        placement = pin.SE3(value)
    else:
        try:
            arr = np.array(value, dtype=float)
        except (TypeError, ValueError):
            arr = np.full(1, np.nan)
        if arr.shape == (4, 4):
            rotation = arr[:3, :3]
            if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
                raise BadArgument(f"{what}: the 4x4 placement's rotation is not a rotation", argument=what)
            placement = pin.SE3(rotation, arr[:3, 3])
        elif arr.shape in ((3,), (6,)) and np.all(np.isfinite(arr)):
            rpy = arr[3:] if arr.size == 6 else np.zeros(3)
            placement = pin.SE3(pin.rpy.rpyToMatrix(*rpy), arr[:3])
        else:
            raise BadArgument(
                f"{what}: a placement is X,Y,Z or X,Y,Z,ROLL,PITCH,YAW [m, rad] or a 4x4 matrix, "
                f"got {value!r}",
                argument=what,
            )
    t = placement.translation
    if not (np.all(np.isfinite(placement.homogeneous)) and np.all(np.abs(t) <= MAX_LENGTH)):
        raise BadArgument(
            f"{what}: the placement must be finite and within {MAX_LENGTH:.0e} m", argument=what
        )
    return placement


def checked_fixtures(fixtures: Iterable[Fixture] | None) -> tuple[Fixture, ...]:
    """A tuple of Fixtures with distinct names.

    Raises:
        BadArgument: not Fixtures, or two with one name.
    """
    items = tuple(fixtures or ())
    if not all(isinstance(f, Fixture) for f in items):
        raise BadArgument("fixtures must be pincal Fixture objects", argument="fixtures")
    names = [f.name for f in items]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise BadArgument(
            f"two fixtures are named {twice[0]!r}; each needs its own name", argument="fixtures"
        )
    return items
