"""The noise of the measured coordinates, and the whitening every weighted step of identification
goes through.

Identification weighs each measured configuration (a *row*: its d values — 3K coordinates of K
markers, or a pose's, distances, pixels: :mod:`pincal.instruments`) by the inverse of its
covariance Σᵢ, through whitened residuals eᵢ = Lᵢ⁻¹ rᵢ (Σᵢ = LᵢLᵢᵀ): the least-squares fit, the
data check, the standard errors, the outlier scores and the quality of the fit all take their
weights from :class:`Noise`, never from σ directly. Σᵢ is diagonal — one standard deviation per
value: the σ given, the data's uncertainty columns, the instrument's σ per unit, or the default —
or full: the data's covariances, or a laser tracker's model (radial and transverse σ at the
measured point), whose Cholesky factor is stored per row and whitens block by block. A value not
measured (a target point out of view) weighs nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pincal.arguments import DEFAULT_SIGMA
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData
from pincal.instruments.error_model import ErrorModel, PerCoordinate, RowCovariance
from pincal.model.robot import Robot


@dataclass(frozen=True, eq=False)
class Noise:
    """The noise of m measured rows of d coordinates each (sessions stacked).

    Attributes:
        std: (m, d) standard deviation of each measured value [m, rad or px], read-only.
        reference: the σ the data check and the sanity limits use [m]: the median of the data's own
            σ (of their lengths), else the σ given, else the error model's, else
            :data:`~pincal.arguments.DEFAULT_SIGMA`.
        per_point: the data carry their own σ (uncertainty columns, covariances).
        given: a σ (or an error model) was given (used unless the data carry their own).
        factor: (m, d, d) lower Cholesky factors of each row's covariance, read-only, or None
            (diagonal: ``std``).
        seen: (m, d) True where a value was measured, read-only, or None (every one).
    """

    std: np.ndarray
    reference: float
    per_point: bool
    given: bool
    factor: np.ndarray | None = None
    seen: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("std", "factor", "seen"):
            value = getattr(self, name)
            if value is not None:
                value = np.array(value)
                value.flags.writeable = False
                object.__setattr__(self, name, value)

    @classmethod
    def of(
        cls,
        sessions: Sequence[MeasurementData],
        sigma: float | None,
        error: ErrorModel | None = None,
        robots: Sequence[Robot] = (),
    ) -> Noise:
        """The noise of ``sessions``: their own σ (or covariances) when every one has them, else the
        error model ``error`` (a tracker's is taken at the points each session's robot in
        ``robots`` predicts), else ``sigma`` (or the default) for every length and the default σ
        of the other units.

        Raises:
            BadMeasurementData: some sessions have uncertainty columns and others not, or the
                sessions measure different kinds.
        """
        per_point = [d.sigma is not None or d.covariance is not None for d in sessions]
        if any(per_point) and not all(per_point):
            raise BadMeasurementData(
                "either every data file has uncertainty columns (s or sx,sy,sz), or none"
            )
        kinds = {(type(d.measure), d.row_size) for d in sessions}
        if len(kinds) > 1:
            raise BadMeasurementData(
                "every data file of one identification must measure the same kind of values"
            )
        plain = isinstance(error, PerCoordinate) and sessions[0].is_points and sigma is None
        if sessions[0].is_points and (error is None or plain):
            if plain:
                assert isinstance(error, PerCoordinate)  # what plain means
                sigma = error.sigma
            return cls._of_points(sessions, sigma, plain)
        return cls._of_kind(sessions, sigma, error, robots, all(per_point))

    @classmethod
    def _of_points(cls, sessions: Sequence[MeasurementData], sigma: float | None, given: bool) -> Noise:
        """Points with their own σ, or one σ for every coordinate."""
        d = 3 * sessions[0].n_markers
        given = given or sigma is not None
        if all(s.sigma is not None for s in sessions):
            values = np.concatenate([np.asarray(s.sigma).reshape(-1) for s in sessions])
            return cls(values.reshape(-1, d), float(np.median(values)), True, given)
        reference = DEFAULT_SIGMA if sigma is None else sigma
        return cls(np.full((sum(s.m for s in sessions), d), reference), reference, False, given)

    @classmethod
    def _of_kind(
        cls,
        sessions: Sequence[MeasurementData],
        sigma: float | None,
        error: ErrorModel | None,
        robots: Sequence[Robot],
        own: bool,
    ) -> Noise:
        """Any kind: the data's own σ and covariances, or an error model's."""
        seen = np.isfinite(np.concatenate([d.values for d in sessions]))
        kind = sessions[0].measure
        model = error if error is not None else PerCoordinate(DEFAULT_SIGMA if sigma is None else sigma)
        if own:
            covariance = _own(sessions)
        else:
            parts = [model.covariance(kind, r, d.q, d.payload) for r, d in zip(robots, sessions, strict=True)]
            covariance = _stacked(parts)
        std = covariance.std
        if std is None:
            std = np.sqrt(np.diagonal(covariance.matrices(), axis1=1, axis2=2))
        lengths = std[:, np.array(kind.units(robots[0])) == "m"]
        reference = float(np.median(lengths)) if own and lengths.size else model.reference
        given = error is not None or sigma is not None
        return cls(std, reference, own, given, covariance.factor, None if seen.all() else seen)

    @property
    def known(self) -> bool:
        """True when σ is known (given, or the data's own); else the standard errors are scaled to
        the σ estimated from the residuals."""
        return self.per_point or self.given

    @property
    def row_size(self) -> int:
        """d, the coordinates of one row."""
        return self.std.shape[1]

    @property
    def plain(self) -> bool:
        """Every value measured, with independent errors: whitening divides by σ."""
        return self.factor is None and self.seen is None

    def coordinates(self, used: np.ndarray) -> np.ndarray:
        """(N,) mask of the coordinates of the rows ``used`` ((m,) mask)."""
        return np.repeat(used, self.row_size)

    def count(self, used: np.ndarray) -> int:
        """The values measured in the rows ``used``."""
        return int(used.sum()) * self.row_size if self.seen is None else int(self.seen[used].sum())

    def whiten(self, v: np.ndarray, used: np.ndarray | None = None) -> np.ndarray:
        """The residuals (N,) or the Jacobian (N, n) ``v`` of the rows ``used`` (all: None),
        whitened: L⁻¹ of each row (divided by σ when diagonal); zero where nothing was measured."""
        if self.plain:
            std = self.std.reshape(-1) if used is None else self.std.reshape(-1)[self.coordinates(used)]
            return v / (std if v.ndim == 1 else std[:, None])
        return self.whitening(np.ones(len(self.std), dtype=bool) if used is None else used)(v)

    def whitening(self, used: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """:meth:`whiten` of the rows ``used`` as a function for repeated use (the solver's): it
        multiplies by 1/σ (or by each row's L⁻¹), computed once."""
        if self.factor is None:
            w = 1.0 / self.std[used]
            if self.seen is not None:
                w = np.where(self.seen[used], w, 0.0)
            w = w.reshape(-1)

            def whitened(v: np.ndarray) -> np.ndarray:
                return v * (w if v.ndim == 1 else w[:, None])

            return whitened
        inverse = np.linalg.inv(self.factor[used])
        if self.seen is not None:
            inverse = np.where(self.seen[used][:, :, None], inverse, 0.0)
        rows, d = len(inverse), self.row_size

        def whitened_rows(v: np.ndarray) -> np.ndarray:
            block = v.reshape(rows, d, -1)
            return np.matmul(inverse, block).reshape(v.shape)

        return whitened_rows


def _own(sessions: Sequence[MeasurementData]) -> RowCovariance:
    """The sessions' own σ or covariances, stacked."""
    if all(d.covariance is None for d in sessions):
        return RowCovariance(std=np.concatenate([d.sigma for d in sessions]))
    matrices = [_matrices(d) for d in sessions]
    return RowCovariance(factor=np.linalg.cholesky(np.concatenate(matrices)))


def _matrices(data: MeasurementData) -> np.ndarray:
    """(m, r, r) one session's covariances: its own, or its σ's on the diagonal."""
    if data.covariance is not None:
        return data.covariance
    assert data.sigma is not None  # _own's sessions all have σ or covariances
    return np.einsum("mi,ij->mij", data.sigma**2, np.eye(data.row_size))


def _stacked(parts: list[RowCovariance]) -> RowCovariance:
    """One RowCovariance of the sessions' (all diagonal, or made full)."""
    if all(p.std is not None for p in parts):
        return RowCovariance(std=np.concatenate([p.std for p in parts]))
    return RowCovariance(factor=np.linalg.cholesky(np.concatenate([p.matrices() for p in parts])))
