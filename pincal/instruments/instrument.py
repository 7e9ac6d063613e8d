"""An instrument: what it measures and how well, turned into the rows every criterion, design and
simulation works with (docs/method.md §13).

:class:`Instrument` pairs a measurement kind (:mod:`pincal.instruments.kind`) with an error model
(:mod:`pincal.instruments.error_model`). Its :class:`RowsEngine` gives, for a parameter set and
configurations, the *whitened* rows s·Lᵢ⁻¹Jᵢ (Σᵢ = LᵢLᵢᵀ the covariance of configuration i's values,
s the model's reference σ [m]): their information is s²·Σ JᵢᵀΣᵢ⁻¹Jᵢ, so every criterion that scales by
s (ρ0 = s·√tr(J₀M⁻¹J₀ᵀ)) gives the weighted one, ρ0² = tr(J₀(Σ JᵢᵀΣᵢ⁻¹Jᵢ)⁻¹J₀ᵀ), in metres whatever
the instrument reads. Values the instrument cannot read at a configuration (a target point out of
the camera's view) give zero rows.

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

from pincal.errors import BadArgument
from pincal.instruments.error_model import ErrorModel, PerCoordinate
from pincal.instruments.identifiability import identifiable
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.model.base_parameters import NEARLY_REDUNDANT, Identifiability
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.typing import SeedLike


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
        payloads: Sequence[object] | None = None,
    ) -> Identifiability:
        """Which of ``params`` this instrument's measurements identify (arguments as
        :meth:`pincal.ParameterSet.identifiable`; see
        :func:`pincal.instruments.identifiability.identifiable`): a pose sees the last joint's
        offset that a point on its axis hides."""
        return identifiable(params, self, n_configurations, seed, tol, prefer, payloads)

    def describe(self) -> str:
        return f"{self.kind.describe()}; {self.error.describe()}"

    def as_dict(self) -> dict:
        return {"measure": self.kind.as_dict(), "error": self.error.as_dict()}


def instrument_for(kind: Kind | None, error: ErrorModel | None, sigma: float) -> Instrument:
    """The instrument of a ``measure=`` and an ``instrument=`` argument (None: points, and
    :class:`PerCoordinate` with ``sigma``)."""
    return Instrument(Point() if kind is None else kind, PerCoordinate(sigma) if error is None else error)


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
        self, qs: np.ndarray, frame: str = "tip", payload: np.ndarray | None = None, masked: bool = True
    ) -> np.ndarray:
        """(m, r, P) whitened rows at joint readings ``qs`` (validated by the caller).

        ``frame="tip"`` allows each configuration's rows in its tip frame where that leaves their
        information unchanged (a rotation-invariant kind, a direction-free error model); the
        rows are in the instrument's frame otherwise. ``masked=False`` keeps the rows of values
        the instrument could not read there (identifiability: what the kind can reveal at all).
        """
        kind, error = self.instrument.kind, self.instrument.error
        tip = frame == "tip" and kind.rotation_invariant and error.direction_free
        if self.plain and isinstance(kind, Point):  # today's rows, bit for bit
            return self.points.jacobian(qs, frame="tip" if tip else "world", payload=payload)
        J = kind.tip_rows(self.points, qs, payload) if tip else kind.rows(self.points, qs, payload)
        seen = kind.seen(self.robot, qs, payload) if masked else np.ones(J.shape[:2], dtype=bool)
        if self.plain:
            return J if seen.all() else np.where(seen[..., None], J, 0.0)
        covariance = error.covariance(kind, self.robot, qs, payload)
        return self.scale * covariance.whiten(J, seen)

    def tool_rows(self, qs: np.ndarray, orientation_length: float | None = None) -> np.ndarray:
        """(k, 3K [+ 3], P) the rows of the test poses ``qs``: the markers' positions in the tip
        frame, and with ``orientation_length`` L [m], L times the tip frame's orientation rows."""
        J0 = self.points.jacobian(qs, frame="tip")
        if orientation_length is None:
            return J0
        angular = self.points.frame_rows(qs)[0][:, 3:]
        return np.concatenate([J0, orientation_length * angular], axis=1)
