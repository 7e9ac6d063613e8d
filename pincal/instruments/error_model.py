"""How well an instrument measures: the covariance of each row of measured values (docs/method.md §13.2).

Each configuration's r values have a covariance Σᵢ (r×r). Identification weighs them by Σᵢ⁻¹ and
every criterion works with the information M = Σ JᵢᵀΣᵢ⁻¹Jᵢ, through whitened rows Lᵢ⁻¹Jᵢ
(Σᵢ = LᵢLᵢᵀ). Two models:

* :class:`PerCoordinate`: independent values, one standard deviation per unit — σ for lengths
  [m] (a point's coordinates, a distance), σ_rot for angles [rad] (a pose's orientation), σ_px for
  pixels. It does not depend on the direction, so the information of a point or a pose may be
  taken in the tip frame. Motion capture is this model with its position and angle σ.
* :class:`Tracker`: a laser tracker at a known position measures a point at distance d with a
  radial σ_r = a + b·d along its beam (the interferometer or absolute distance meter) and a
  transverse σ_t = c + e·d across it (the angle encoders), so Σ = σ_r² uuᵀ + σ_t² (I − uuᵀ), u the
  beam's direction. Its defaults are the Leica AT500's specification (Leica Absolute Tracker AT500
  User Manual, §2.8.2, "Laser Tracker Subsystem Specifications", per ISO 10360-10:2021 Annex D):
  maximum permissible errors ±(10 µm + 0.3 µm/m) along the beam (ADM) and ±(15 µm + 6 µm/m) across
  it; the manual states that typical results are half the MPE, so the defaults take σ as half
  the MPE: σ_r = 5 µm + 0.15 µm/m, σ_t = 7.5 µm + 3 µm/m (at 10 m: 6.5 µm and 37.5 µm, six times
  larger across the beam than along it).

A data file's own uncertainty columns or covariance override the model (:mod:`pincal.calibration.noise`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Collection
from dataclasses import dataclass

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, positive_sigma
from pincal.errors import BadArgument
from pincal.instruments.kind import Kind, marker_poses
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows

DEFAULT_SIGMA_ROT = 1e-4
"""Default orientation noise [rad] (0.006°): a 6-DoF tracker probe's order; motion capture is
nearer 1e-3 (give ``sigma_rot``)."""

DEFAULT_SIGMA_PX = 0.5
"""Default pixel noise [px]: a checkerboard corner found to half a pixel."""

TRACKER_RADIAL = (5e-6, 0.15e-6)
"""Default (a [m], b [m/m]) of a tracker's radial σ = a + b·d: half the AT500's ADM MPE."""

TRACKER_TRANSVERSE = (7.5e-6, 3e-6)
"""Default (c [m], e [m/m]) of a tracker's transverse σ = c + e·d: half the AT500's transverse MPE."""


@dataclass(frozen=True, eq=False)
class RowCovariance:
    """The covariance of m rows of r values: diagonal (``std``) or full (``factor``).

    Attributes:
        std: (m, r) standard deviations, or None.
        factor: (m, r, r) lower Cholesky factors L (Σ = LLᵀ), or None.
    """

    std: np.ndarray | None = None
    factor: np.ndarray | None = None

    def whiten(self, v: np.ndarray, seen: np.ndarray | None = None) -> np.ndarray:
        """L⁻¹v row by row, for values (m, r) or Jacobian rows (m, r, P); zero where not ``seen``
        (m, r)."""
        if self.std is not None:
            out = v / (self.std if v.ndim == 2 else self.std[..., None])
        else:
            assert self.factor is not None  # one of std and factor is given
            out = np.linalg.solve(self.factor, v if v.ndim == 3 else v[..., None])
            out = out if v.ndim == 3 else out[..., 0]
        if seen is not None and not seen.all():
            out = np.where(seen if v.ndim == 2 else seen[..., None], out, 0.0)
        return out

    def matrices(self) -> np.ndarray:
        """(m, r, r) Σᵢ."""
        if self.std is not None:
            return np.einsum("mi,ij->mij", self.std**2, np.eye(self.std.shape[1]))
        assert self.factor is not None  # one of std and factor is given
        return np.matmul(self.factor, np.swapaxes(self.factor, 1, 2))


class ErrorModel(ABC):
    """An instrument's error model (see module doc)."""

    @property
    @abstractmethod
    def reference(self) -> float:
        """A length σ [m] reports and the criteria use as their scale: ρ0 does not depend on it."""

    @property
    def direction_free(self) -> bool:
        """The covariance of a point or a pose does not change when its axes turn."""
        return False

    @abstractmethod
    def covariance(
        self, kind: Kind, robot: Robot, qs: np.ndarray, payload: PayloadRows = None
    ) -> RowCovariance:
        """The covariance of the rows ``kind`` measures on ``robot`` at ``qs`` (m, nq)."""

    def uniform(self, kind: Kind, robot: Robot) -> bool:
        """Every value has the σ :attr:`reference`, independently of the others and of where it
        is: the rows need no whitening (the criteria scale by σ)."""
        return False

    @abstractmethod
    def describe(self, units: Collection[str] | None = None) -> str:
        """The model in words, for reports: of the values of ``units`` (``"m"``, ``"rad"``,
        ``"px"``: what the instrument measures, see :meth:`Kind.units`), default all."""

    @abstractmethod
    def as_dict(self) -> dict:
        """JSON-ready description."""


@dataclass(frozen=True)
class PerCoordinate(ErrorModel):
    """Independent values with one σ per unit (see module doc).

    Args:
        sigma: lengths [m] (point coordinates, distances).
        sigma_rot: angles [rad] (a pose's orientation).
        sigma_px: pixels [px].
    """

    sigma: float = DEFAULT_SIGMA
    sigma_rot: float = DEFAULT_SIGMA_ROT
    sigma_px: float = DEFAULT_SIGMA_PX

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", positive_sigma(self.sigma))
        for name in ("sigma_rot", "sigma_px"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float, np.floating)) and np.isfinite(value) and value > 0):
                raise BadArgument(
                    f"{name} must be a positive number, got {value!r}", argument=name, value=value
                )
            object.__setattr__(self, name, float(value))

    @property
    def reference(self) -> float:
        return self.sigma

    @property
    def direction_free(self) -> bool:
        return True

    def std(self, units: tuple[str, ...]) -> np.ndarray:
        """(r,) σ of values of these units."""
        return np.array([{"m": self.sigma, "rad": self.sigma_rot, "px": self.sigma_px}[u] for u in units])

    def covariance(
        self, kind: Kind, robot: Robot, qs: np.ndarray, payload: PayloadRows = None
    ) -> RowCovariance:
        return RowCovariance(std=np.tile(self.std(kind.units(robot)), (len(qs), 1)))

    def uniform(self, kind: Kind, robot: Robot) -> bool:
        return bool(np.all(self.std(kind.units(robot)) == self.sigma))

    def describe(self, units: Collection[str] | None = None) -> str:
        shown = {
            "m": f"{self.sigma * 1e3:.4g} mm",
            "rad": f"{self.sigma_rot * 1e3:.4g} mrad",
            "px": f"{self.sigma_px:.3g} px",
        }
        return "sigma " + ", ".join(text for unit, text in shown.items() if units is None or unit in units)

    def as_dict(self) -> dict:
        return {
            "model": "per-coordinate",
            "sigma": self.sigma,
            "sigma_rot": self.sigma_rot,
            "sigma_px": self.sigma_px,
        }


@dataclass(frozen=True)
class Tracker(ErrorModel):
    """A laser tracker at ``at`` (see module doc).

    Args:
        at: the tracker's position (x, y, z) in the instrument's frame [m] (the origin when the
            data are in the tracker's own frame).
        radial: (a [m], b [m/m]) of σ_r = a + b·d along the beam.
        transverse: (c [m], e [m/m]) of σ_t = c + e·d across it.
        sigma_rot: a 6-DoF probe's orientation σ [rad], for poses.
    """

    at: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radial: tuple[float, float] = TRACKER_RADIAL
    transverse: tuple[float, float] = TRACKER_TRANSVERSE
    sigma_rot: float = DEFAULT_SIGMA_ROT

    def __post_init__(self) -> None:
        at = np.array(self.at, dtype=float).reshape(-1)
        if at.shape != (3,) or not np.all(np.isfinite(at)):
            raise BadArgument(
                f"tracker position must be X,Y,Z [m], got {self.at!r}", argument="instrument-at"
            )
        object.__setattr__(self, "at", tuple(float(v) for v in at))
        for name in ("radial", "transverse"):
            pair = tuple(float(v) for v in getattr(self, name))
            if len(pair) != 2 or not all(np.isfinite(pair)) or pair[0] <= 0 or pair[1] < 0:
                raise BadArgument(
                    f"tracker {name} sigma: a > 0 [m] and b >= 0 [m/m] of a + b*d, "
                    f"got {getattr(self, name)!r}",
                    argument=name,
                )
            object.__setattr__(self, name, pair)

    @property
    def reference(self) -> float:
        return self.transverse[0] + self.transverse[1]  # across the beam at 1 m

    def sigmas(self, distance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(σ_r, σ_t) [m] at distances [m]."""
        return self.radial[0] + self.radial[1] * distance, self.transverse[0] + self.transverse[1] * distance

    def point_covariance(self, points: np.ndarray) -> np.ndarray:
        """(..., 3, 3) Σ of points (..., 3) in the instrument's frame [m²]."""
        beam = points - np.array(self.at)
        d = np.linalg.norm(beam, axis=-1)
        u = beam / np.maximum(d, 1e-12)[..., None]
        sr, st = self.sigmas(d)
        uu = u[..., :, None] * u[..., None, :]
        return (sr**2)[..., None, None] * uu + (st**2)[..., None, None] * (np.eye(3) - uu)

    def covariance(
        self, kind: Kind, robot: Robot, qs: np.ndarray, payload: PayloadRows = None
    ) -> RowCovariance:
        every = kind.components(robot)
        components = [c for c in every if c is not None]  # all of them, or refused here
        if len(components) < len(every):
            raise BadArgument(
                f"a laser tracker measures points and poses, not {kind.describe()}: give the instrument's "
                f"sigma instead (--sigma)",
                argument="instrument",
            )
        _, points = marker_poses(robot, qs, payload)
        point_cov = self.point_covariance(points)  # (m, K, 3, 3)
        m, r = len(qs), len(components)
        cov = np.zeros((m, r, r))
        for a, (ka, ca) in enumerate(components):
            for b, (kb, cb) in enumerate(components):
                if ka == kb and ca < 3 and cb < 3:
                    cov[:, a, b] = point_cov[:, ka, ca, cb]
                elif a == b:
                    cov[:, a, b] = self.sigma_rot**2
        return RowCovariance(factor=np.linalg.cholesky(cov))

    def describe(self, units: Collection[str] | None = None) -> str:
        (a, b), (c, e) = self.radial, self.transverse
        at = ", ".join(f"{v:.4g}" for v in self.at)
        return (
            f"laser tracker at ({at}) m: radial sigma {a * 1e6:.3g} um + {b * 1e6:.3g} um/m, transverse "
            f"{c * 1e6:.3g} um + {e * 1e6:.3g} um/m"
        )

    def as_dict(self) -> dict:
        return {
            "model": "tracker",
            "at": list(self.at),
            "radial": list(self.radial),
            "transverse": list(self.transverse),
            "sigma_rot": self.sigma_rot,
        }
