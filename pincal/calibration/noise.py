"""The noise of the measured coordinates, and the whitening every weighted step of identification
goes through.

Identification weighs each measured configuration (a *row*: its d = 3K coordinates, K markers) by
the inverse of its covariance Σᵢ, through whitened residuals eᵢ = Lᵢ⁻¹ rᵢ (Σᵢ = LᵢLᵢᵀ): the
least-squares fit, the data check, the standard errors, the outlier scores and the quality of the
fit all take their weights from :class:`Noise`, never from σ directly. Today Σᵢ is diagonal, one
standard deviation per coordinate (the σ given, the data's uncertainty columns, or the default), so
whitening divides by σ; a measurement kind with a full covariance per row (a pose, a distance, an
image point) changes :class:`Noise` alone.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pincal.arguments import DEFAULT_SIGMA
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData


@dataclass(frozen=True, eq=False)
class Noise:
    """The noise of m measured rows of d coordinates each (sessions stacked).

    Attributes:
        std: (m, d) standard deviation of each measured coordinate [m], read-only.
        reference: the σ the data check and the sanity limits use [m]: the median of the data's own
            σ, else the σ given, else :data:`~pincal.arguments.DEFAULT_SIGMA`.
        per_point: the data carry their own σ (uncertainty columns).
        given: a σ was given (used unless the data carry their own).
    """

    std: np.ndarray
    reference: float
    per_point: bool
    given: bool

    def __post_init__(self) -> None:
        std = np.array(self.std, dtype=float)
        std.flags.writeable = False
        object.__setattr__(self, "std", std)

    @classmethod
    def of(cls, sessions: Sequence[MeasurementData], sigma: float | None) -> Noise:
        """The noise of ``sessions``: their own σ when every one has uncertainty columns, else
        ``sigma`` (or the default) for every coordinate.

        Raises:
            BadMeasurementData: some sessions have uncertainty columns and others not.
        """
        per_point = [d.sigma is not None for d in sessions]
        if any(per_point) and not all(per_point):
            raise BadMeasurementData(
                "either every data file has uncertainty columns (s or sx,sy,sz), or none"
            )
        d = 3 * sessions[0].n_markers
        given = sigma is not None
        if all(per_point):
            values = np.concatenate([np.asarray(s.sigma).reshape(-1) for s in sessions])
            return cls(values.reshape(-1, d), float(np.median(values)), True, given)
        reference = DEFAULT_SIGMA if sigma is None else sigma
        return cls(np.full((sum(s.m for s in sessions), d), reference), reference, False, given)

    @property
    def known(self) -> bool:
        """True when σ is known (given, or the data's own); else the standard errors are scaled to
        the σ estimated from the residuals."""
        return self.per_point or self.given

    @property
    def row_size(self) -> int:
        """d, the coordinates of one row."""
        return self.std.shape[1]

    def coordinates(self, used: np.ndarray) -> np.ndarray:
        """(N,) mask of the coordinates of the rows ``used`` ((m,) mask)."""
        return np.repeat(used, self.row_size)

    def whiten(self, v: np.ndarray, used: np.ndarray | None = None) -> np.ndarray:
        """The residuals (N,) or the Jacobian (N, n) ``v`` of the rows ``used`` (all: None),
        whitened: divided by their σ."""
        std = self.std.reshape(-1) if used is None else self.std.reshape(-1)[self.coordinates(used)]
        return v / (std if v.ndim == 1 else std[:, None])

    def whitening(self, used: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """:meth:`whiten` of the rows ``used`` as a function for repeated use (the solver's): it
        multiplies by 1/σ, computed once."""
        w = 1.0 / self.std.reshape(-1)[self.coordinates(used)]

        def whitened(v: np.ndarray) -> np.ndarray:
            return v * (w if v.ndim == 1 else w[:, None])

        return whitened
