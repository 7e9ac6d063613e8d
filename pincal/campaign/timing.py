"""How long a campaign takes: the moves between configurations and the time spent at each
(docs/method.md §12.1).

A joint-space move from a to b runs every joint at once and ends when the slowest ends
(synchronised joints). Joint j, with speed limit vⱼ and, optionally, acceleration limit aⱼ, covers
dⱼ = |bⱼ − aⱼ| in

* tⱼ = dⱼ / vⱼ                     without acceleration limits;
* tⱼ = dⱼ / vⱼ + vⱼ / aⱼ           with them, when dⱼ ≥ vⱼ² / aⱼ (a trapezoid: it reaches vⱼ);
* tⱼ = 2 √(dⱼ / aⱼ)               with them, when dⱼ < vⱼ² / aⱼ (a triangle: it never does);

and the move takes maxⱼ tⱼ. At each measurement pose the robot then waits a settle time (its
position settling after the stop) and the instrument's dwell (the time it takes per point:
:data:`DWELLS`). The speeds are the URDF's ``<limit velocity>`` unless given, scaled by a speed
fraction (a controller's override, e.g. 0.5 for 50 %).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.deprecation import renamed_keyword
from pincal.errors import BadArgument, warn
from pincal.model.robot import Robot

DWELLS = {"tracker": 2.0, "probe": 10.0}
"""The instrument's time per point [s] by kind: a laser tracker at its best accuracy (averaging
over about 2 s), a 6-DoF probe (about 10 s)."""

DEFAULT_DWELL = "tracker"
"""The instrument assumed when none is given."""

DEFAULT_SETTLE = 0.5
"""Time [s] the robot is left to settle at a measurement pose before the instrument reads."""


SPEED_RANGE = (1e-6, 1e3)
"""Joint speeds a campaign takes [rad/s or m/s]: a joint slower than a micro-radian per second
never arrives, one faster than 1000 rad/s is no robot (and the times stay finite)."""
ACCELERATION_RANGE = (1e-6, 1e6)
"""Joint accelerations a campaign takes [rad/s² or m/s²]."""
MAX_WAIT = 86_400.0
"""Longest settle or dwell a campaign takes at a pose [s]: a day."""
MIN_SPEED_FRACTION = 1e-3
"""Smallest fraction of the speeds a campaign runs at."""


def _positive_vector(
    values: object, n: int, what: str, names: tuple[str, ...], valid: tuple[float, float]
) -> np.ndarray:
    """``values``, one per joint or one for all, each within ``valid``, or BadArgument naming it."""
    try:
        arr = np.array(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.size == 1:
        arr = np.full(n, arr[0])
    low, high = valid
    if arr.size != n or not np.all((arr >= low) & (arr <= high)):  # NaN fails too
        raise BadArgument(
            f"{what} must be {n} numbers from {low:g} to {high:g} (one per joint: {', '.join(names)}) "
            f"or one for all, got {values!r}",
            argument=what,
            value=values,
        )
    return arr


def dwell_seconds(dwell: float | str | None) -> tuple[float, str]:
    """(seconds, instrument) of a dwell given as seconds, an instrument kind of :data:`DWELLS` or None
    (the default instrument)."""
    if dwell is None:
        dwell = DEFAULT_DWELL
    if isinstance(dwell, str) and dwell.strip().lower() in DWELLS:
        kind = dwell.strip().lower()
        return DWELLS[kind], kind
    try:
        value = float(dwell)
    except (TypeError, ValueError):
        value = math.nan
    if not (0 <= value <= MAX_WAIT):  # NaN fails too
        raise BadArgument(
            f"dwell must be seconds from 0 to {MAX_WAIT:g} or an instrument "
            f"({', '.join(f'{k}: {v:g} s' for k, v in DWELLS.items())}), got {dwell!r}",
            argument="dwell",
            value=dwell,
        )
    return value, "given"


@dataclass(frozen=True, eq=False)
class Timing:
    """The time model of a campaign (see the module doc).

    Attributes:
        speeds: (nq,) joint speed limits used [rad/s, or m/s for a prismatic joint] (after the
            speed fraction).
        accelerations: (nq,) joint acceleration limits [rad/s², m/s²], or None (instant speed).
        settle: wait after each move to a measurement pose [s].
        dwell: the instrument's time per measurement pose [s].
        dwell_source: where the dwell came from: ``tracker`` or ``probe`` (its typical dwell) or
            ``given`` (in seconds). Named ``instrument`` in pincal 0.1 (``instrument=`` is a
            :class:`pincal.instruments.Instrument` across pincal); ``Timing(instrument=...)`` and
            ``.instrument`` keep working until pincal 0.3, with a DeprecationWarning (the JSON key of
            :meth:`as_dict` stays ``"instrument"``).
        speed_source: where the speeds came from (``URDF velocity limits`` or ``given``).
    """

    speeds: np.ndarray
    accelerations: np.ndarray | None
    settle: float = DEFAULT_SETTLE
    dwell: float = DWELLS[DEFAULT_DWELL]
    dwell_source: str = DEFAULT_DWELL
    speed_source: str = "given"

    @classmethod
    def for_robot(
        cls,
        robot: Robot,
        speeds: object = None,
        accelerations: object = None,
        *,
        speed_fraction: float = 1.0,
        settle: float = DEFAULT_SETTLE,
        dwell: float | str | None = None,
    ) -> Timing:
        """The time model of ``robot``.

        Args:
            robot: the robot.
            speeds: joint speed limits [rad/s or m/s], one per joint or one for all (default: the
                URDF's ``<limit velocity>``).
            accelerations: joint acceleration limits [rad/s² or m/s²], one per joint or one for
                all, or None (moves at full speed from the start).
            speed_fraction: the fraction of the speeds the robot runs at, in (0, 1].
            settle: wait after each move to a measurement pose [s].
            dwell: the instrument's time per point [s], or ``tracker`` (2 s), ``probe`` (10 s);
                default ``tracker``.

        Raises:
            BadArgument: a bad value, or no speed limits in the URDF (give ``speeds``).
        """
        names = robot.joint_names
        source = "given"
        if speeds is None:
            urdf = np.asarray(robot.model.velocityLimit, dtype=float)
            if urdf.size != robot.nq or not np.all(np.isfinite(urdf)) or np.any(urdf <= 0):
                missing = [n for n, v in zip(names, urdf, strict=False) if not (np.isfinite(v) and v > 0)]
                raise BadArgument(
                    f"the URDF gives no speed limit (<limit velocity>) for joint(s) {', '.join(missing)}: "
                    "give the joints' speeds (--joint-speeds, speeds=) in rad/s (m/s for prismatic "
                    "joints)",
                    argument="speeds",
                )
            speeds, source = urdf, "URDF velocity limits"
        v = _positive_vector(speeds, robot.nq, "speeds", names, SPEED_RANGE)
        a = (
            None
            if accelerations is None
            else _positive_vector(accelerations, robot.nq, "accelerations", names, ACCELERATION_RANGE)
        )
        try:
            fraction = float(speed_fraction)
        except (TypeError, ValueError):
            fraction = math.nan
        if not (MIN_SPEED_FRACTION <= fraction <= 1):
            raise BadArgument(
                f"speed_fraction must be from {MIN_SPEED_FRACTION:g} to 1, got {speed_fraction!r}",
                argument="speed_fraction",
            )
        try:
            settle_s = float(settle)
        except (TypeError, ValueError):
            settle_s = math.nan
        if not (0 <= settle_s <= MAX_WAIT):  # NaN fails too
            raise BadArgument(
                f"settle must be seconds from 0 to {MAX_WAIT:g}, got {settle!r}",
                argument="settle",
                value=settle,
            )
        dwell_s, dwell_source = dwell_seconds(dwell)
        if fraction < 1:
            source += f" × {fraction:g}"
        return cls(v * fraction, a, settle_s, dwell_s, dwell_source, source)

    def joint_times(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(..., nq) time each joint needs from ``a`` to ``b`` [s] (broadcast over leading axes)."""
        d = np.abs(np.asarray(b, dtype=float) - np.asarray(a, dtype=float))
        v = self.speeds
        if self.accelerations is None:
            return d / v
        acc = self.accelerations
        cruise = d / v + v / acc
        triangle = 2.0 * np.sqrt(d / acc)
        return np.where(d >= v**2 / acc, cruise, triangle)

    def move_time(self, a: np.ndarray, b: np.ndarray) -> np.ndarray | float:
        """Time of the synchronised move from ``a`` to ``b`` [s]: the slowest joint's."""
        t = self.joint_times(a, b).max(axis=-1)
        return float(t) if np.ndim(t) == 0 else t

    def matrix(self, qs: np.ndarray) -> np.ndarray:
        """(n, n) move times between every pair of configurations ``qs`` [s] (symmetric)."""
        qs = np.asarray(qs, dtype=float)
        return self.joint_times(qs[:, None, :], qs[None, :, :]).max(axis=-1)

    @property
    def stop(self) -> float:
        """Time spent at each measurement pose: settle plus dwell [s]."""
        return self.settle + self.dwell

    def describe(self) -> str:
        """The model in words, for reports."""
        acc = "no acceleration limits" if self.accelerations is None else "acceleration limits given"
        kind = {"tracker": "laser tracker", "probe": "6-DoF probe"}.get(self.dwell_source, "given")
        return (
            f"joint speeds: {self.speed_source}, {acc}; settle {self.settle:g} s, dwell {self.dwell:g} s "
            f"per pose ({kind})"
        )

    def as_dict(self) -> dict:
        return {
            "speeds": self.speeds.tolist(),
            "accelerations": None if self.accelerations is None else self.accelerations.tolist(),
            "settle": self.settle,
            "dwell": self.dwell,
            "instrument": self.dwell_source,  # the key of pincal 0.1's outputs
            "speed_source": self.speed_source,
        }

    @property
    def instrument(self) -> str:
        """pincal 0.1's name of :attr:`dwell_source` (until pincal 0.3)."""
        warn(
            f"Timing.instrument is renamed dwell_source ({RENAMED_WHY}): read .dwell_source "
            "(Timing.instrument stops working in pincal 0.3)",
            DeprecationWarning,
        )
        return self.dwell_source


RENAMED_WHY = "instrument= is a pincal.instruments.Instrument across pincal"
# Timing(instrument=...) of pincal 0.1, until 0.3
Timing.__init__ = renamed_keyword(  # type: ignore[method-assign]
    "instrument", "dwell_source", RENAMED_WHY, name="Timing"
)(Timing.__init__)
