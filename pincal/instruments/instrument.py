"""An instrument: what it measures and how well, turned into the rows every criterion, design and
simulation works with (docs/method.md §13).

:class:`Instrument` pairs a measurement kind (:mod:`pincal.instruments.kind`) with an error model
(:mod:`pincal.instruments.error_model`). Its :class:`RowsEngine` gives, for a parameter set and
configurations, the *whitened* rows s·Lᵢ⁻¹Jᵢ (Σᵢ = LᵢLᵢᵀ the covariance of configuration i's values,
s the model's reference σ [m]): their information is s²·Σ JᵢᵀΣᵢ⁻¹Jᵢ, so every criterion that scales by
s (ρ0 = s·√tr(J₀M⁻¹J₀ᵀ)) gives the weighted one, ρ0² = tr(J₀(Σ JᵢᵀΣᵢ⁻¹Jᵢ)⁻¹J₀ᵀ), in metres whatever
the instrument reads. Values the instrument cannot read at a configuration (a target point out of
the camera's view) give zero rows; a value read only with some probability (a target point near
the image's edge, which the errors still unknown may move out of it) gives its rows times √w, w
its weight below 1 (:meth:`Kind.weights`): the information counts only what a measurement is
likely to deliver.

Points with one σ per coordinate — pincal's default — need no whitening: the rows are the point
Jacobian itself, exactly as before instruments existed, so designs and criteria are unchanged.

The test pose's rows (:meth:`RowsEngine.tool_rows`) are those of the markers' positions whatever the
instrument (ρ0 is where the tool is), with, when asked, the tip frame's orientation rows times a
length L: ρ0² then adds L² times the expected squared orientation error [rad²].
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from pincal.arguments import MAX_LENGTH
from pincal.errors import BadArgument
from pincal.instruments.error_model import ErrorModel, PerCoordinate
from pincal.instruments.identifiability import identifiable
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.model.base_parameters import NEARLY_REDUNDANT, Identifiability
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows
from pincal.typing import PayloadLike, SeedLike

MAX_JACOBIAN_VALUES = 50_000_000
"""Most values of a Jacobian built at once (400 MB: a pool of 3000 camera views of a 100-corner grid
and 40 parameters is 24 million; an image kind's intermediate arrays take some
three times more): a 266 928-pose plan measured by a camera asked for 3.6 GiB and more."""

POOL_ROWS = 6
"""Configurations with more rows than this are compressed to their rank for the exchange search
(:meth:`RowsEngine.pool`)."""


@dataclass(frozen=True, eq=False)
class Instrument:
    """What an instrument measures (``kind``) and how well (``error``).

    Attributes:
        kind: the measurement kind (default :class:`~pincal.instruments.point.Point`).
        error: the error model (default :class:`~pincal.instruments.error_model.PerCoordinate`
            with pincal's default σ).
    """

    kind: Kind = field(default_factory=Point)
    error: ErrorModel = field(default_factory=PerCoordinate)

    def __post_init__(self) -> None:
        if not isinstance(self.kind, Kind):
            raise BadArgument(f"an instrument's kind must be a pincal measurement kind, got {self.kind!r}")
        if not isinstance(self.error, ErrorModel):
            raise BadArgument(
                f"an instrument's error model must be PerCoordinate or Tracker, got {self.error!r}"
            )

    @property
    def reference(self) -> float:
        """The error model's reference σ [m] (the criteria's scale)."""
        return self.error.reference

    @property
    def is_default(self) -> bool:
        """Points with one σ for every coordinate: today's rows, no whitening."""
        return isinstance(self.kind, Point) and isinstance(self.error, PerCoordinate)

    def engine(self, params: ParameterSet) -> RowsEngine:
        """The rows of this instrument for ``params`` (one engine per thread)."""
        return RowsEngine(params, self)

    def identifiable(
        self,
        params: ParameterSet,
        n_configurations: int = 200,
        seed: SeedLike = 0,
        tol: float = NEARLY_REDUNDANT,
        prefer: str | Iterable[str] = (),
        payloads: Sequence[PayloadLike] | None = None,
    ) -> Identifiability:
        """Which of ``params`` this instrument's measurements identify (arguments as
        :meth:`pincal.ParameterSet.identifiable`; see
        :func:`pincal.instruments.identifiability.identifiable`): a pose sees the last joint's
        offset that a point on its axis hides."""
        return identifiable(params, self, n_configurations, seed, tol, prefer, payloads)

    def describe(self, robot: Robot | None = None) -> str:
        """What is measured and how well, in words (on ``robot``: only the σ of what it measures)."""
        units = None if robot is None else set(self.kind.units(robot))
        return f"{self.kind.describe()}; {self.error.describe(units)}"

    def as_dict(self) -> dict:
        return {"measure": self.kind.as_dict(), "error": self.error.as_dict()}


class RowsEngine:
    """The whitened rows of one instrument for one parameter set (see module doc).

    Holds a :class:`~pincal.model.jacobian.JacobianEngine` (a ``pinocchio.Data``): one per thread.

    Attributes:
        params: the parameter set.
        instrument: the instrument.
        points: the model's engine of the markers' positions.
        rows: r, values per configuration.
        n_params: P.
        scale: the reference σ s [m].
    """

    def __init__(self, params: ParameterSet, instrument: Instrument) -> None:
        instrument.kind.check(params.robot)
        self.params = params
        self.instrument = instrument
        self.points = JacobianEngine(params)
        self.robot = params.robot
        self.rows = instrument.kind.size(params.robot)
        self.n_params = len(params)
        self.scale = instrument.reference
        self.plain = (
            instrument.error.uniform(instrument.kind, params.robot) and instrument.error.direction_free
        )

    def jacobian(
        self, qs: np.ndarray, frame: str = "tip", payload: PayloadRows = None, masked: bool = True
    ) -> np.ndarray:
        """(m, r, P) whitened rows at joint readings ``qs`` (validated by the caller).

        ``frame="tip"`` allows each configuration's rows in its tip frame where that leaves their
        information unchanged (a rotation-invariant kind, a direction-free error model); the
        rows are in the instrument's frame otherwise. ``masked=False`` keeps the rows of values
        the instrument could not read there (identifiability: what the kind can reveal at all).
        """
        kind, error = self.instrument.kind, self.instrument.error
        values = len(qs) * kind.size(self.robot) * self.points.n_params
        if values > MAX_JACOBIAN_VALUES:
            raise BadArgument(
                f"{len(qs)} configurations x {kind.size(self.robot)} measured values x "
                f"{self.points.n_params} parameters: a Jacobian of {values * 8 / 2**30:.3g} GiB, more than "
                f"the {MAX_JACOBIAN_VALUES * 8 / 2**30:.3g} GiB pincal builds; give fewer configurations",
                argument="plan",
            )
        tip = frame == "tip" and kind.rotation_invariant and error.direction_free
        if self.plain and isinstance(kind, Point):  # today's rows, bit for bit
            return self.points.jacobian(qs, frame="tip" if tip else "world", payload=payload)
        J = kind.tip_rows(self.points, qs, payload) if tip else kind.rows(self.points, qs, payload)
        weight = kind.weights(self.points, qs, J, payload) if masked else np.ones(J.shape[:2])
        seen = weight > 0
        if self.plain:
            out = J if seen.all() else np.where(seen[..., None], J, 0.0)
        else:
            out = self.scale * error.covariance(kind, self.robot, qs, payload).whiten(J, seen)
        if np.all((weight == 0) | (weight == 1)):
            return out  # seen or not: the rows as they are
        return np.where(seen[..., None], out * np.sqrt(weight)[..., None], 0.0)

    def tool_rows(
        self, qs: np.ndarray, orientation_length: float | None = None, payload: PayloadRows = None
    ) -> np.ndarray:
        """(k, 3K [+ 3], P) the rows of the test poses ``qs`` (see :func:`tool_rows`)."""
        return tool_rows(self.points, qs, orientation_length, payload)

    def pool(self, qs: np.ndarray) -> np.ndarray:
        """(N, r', P) rows of many candidate configurations with the information of
        :meth:`jacobian`'s: its rows, or, when a configuration's rows have a lower rank than their
        number (a camera's 2 per target point move with 12 twists at most), the r' = rank rows
        S·Vᵀ of their singular value decomposition (JᵢᵀJᵢ unchanged): every exchange of the
        search then costs (2r')³, not (2r)³."""
        J = self.jacobian(qs)
        if J.shape[1] <= POOL_ROWS:
            return J
        _, s, Vt = np.linalg.svd(J, full_matrices=False)
        keep = s > s[:, :1] * 1e-12
        r = max(int(keep.sum(axis=1).max()), 1)
        if r == J.shape[1]:
            return J
        return (s[:, :r, None] * Vt[:, :r]) * keep[:, :r, None]

    @property
    def model(self) -> pin.Model:
        """The robot's Pinocchio model (read-only use)."""
        return self.points.model


def tool_rows(
    engine: JacobianEngine | RowsEngine,
    qs: np.ndarray,
    orientation_length: float | None = None,
    payload: PayloadRows = None,
) -> np.ndarray:
    """(k, 3K [+ 3], P) the rows of test poses ``qs``: the markers' positions in the tip frame (ρ0's
    J₀, whatever the instrument), and with ``orientation_length`` L [m], L times the tip frame's
    orientation rows, so that ρ0² adds L²·E‖δθ‖² (docs/method.md §13.3); under the payload rows
    ``payload`` (k, 4) of the task, if any."""
    engine = engine.points if isinstance(engine, RowsEngine) else engine
    J0 = engine.jacobian(qs, frame="tip", payload=payload)
    if orientation_length is None:
        return J0
    angular = engine.frame_rows(qs, payload=payload, pose=False)[0][:, 3:]
    return np.concatenate([J0, orientation_length * angular], axis=1)


def pool_rows(engine: JacobianEngine | RowsEngine, qs: np.ndarray) -> np.ndarray:
    """(N, r', P) the rows of a pool of candidates for the exchange (:meth:`RowsEngine.pool`; the
    markers' tip-frame rows for a plain engine)."""
    return engine.pool(qs) if isinstance(engine, RowsEngine) else engine.jacobian(qs, frame="tip")


def rows_engine(params: ParameterSet, instrument: Instrument | None) -> JacobianEngine | RowsEngine:
    """The engine of what a plan measures: the markers' points (None: exactly as always), or the
    instrument's whitened rows."""
    return JacobianEngine(params) if instrument is None else instrument.engine(params)


def orientation_length_of(value: object) -> float | None:
    """A checked ``orientation_length`` [m] (None: positions only).

    Raises:
        BadArgument: not a positive length within :data:`~pincal.arguments.MAX_LENGTH`.
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= MAX_LENGTH:
        raise BadArgument(
            f"orientation_length must be a positive length [m]: the lever that turns the tool's "
            f"orientation error into a distance, got {value!r}",
            argument="orientation_length",
            value=value,
        )
    return float(value)
