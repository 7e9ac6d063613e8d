r"""What the poses measured so far already tell, as a prior for the next design.

Measurements of noise σᵢ per coordinate at configurations qᵢ carry the information
F = Σᵢ JᵢᵀWᵢJᵢ, Wᵢ = diag(1/σᵢ²) [1/m², 1/rad²] about the parameters; measurements of
any other kind (a pose, distances, pixels: :mod:`pincal.instruments`), Wᵢ = Σᵢ⁻¹ of their error
model (:meth:`MeasuredPrior.from_instrument`) or of their own uncertainties
(:meth:`MeasuredPrior.from_rows`). Designing the next poses
*given* them is designing with F added to what the new poses bring — exactly the way a prior's
precision Σp⁻¹ is added (Chaloner & Verdinelli 1995): the posterior precision after the next
poses is Σp⁻¹ + F + Mₙₑw/σ². :class:`MeasuredPrior` is a :class:`~pincal.Prior` whose precision
holds F too, so :func:`pincal.design`, :func:`pincal.rho0` and :func:`pincal.accuracy` take it as
they take any prior: the next design maximises what the new poses add to what is known.

Its :meth:`~pincal.Prior.std` stays the errors' prior before any measurement (what "before
calibration" means in a report; ``inf``: none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.errors import BadArgument
from pincal.evaluation.prior import Prior
from pincal.instruments.instrument import Instrument
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet


@dataclass(frozen=True, eq=False)
class MeasuredPrior(Prior):
    """A prior that also holds the information of poses already measured (see the module doc).

    Attributes (beyond :class:`~pincal.Prior`'s):
        names: the parameters ``fisher`` is about, in its order.
        fisher: (P, P) F = Σᵢ JᵢᵀWᵢJᵢ of the measured poses [1/m², 1/rad²].
        measured: how many poses it holds.
    """

    names: tuple[str, ...] = ()
    fisher: np.ndarray | None = None
    measured: int = 0

    def __post_init__(self) -> None:
        super().__post_init__()
        fisher = (
            np.zeros((len(self.names),) * 2) if self.fisher is None else np.array(self.fisher, dtype=float)
        )
        if fisher.shape != (len(self.names),) * 2 or not np.all(np.isfinite(fisher)):
            raise BadArgument(
                f"measured information must be a finite ({len(self.names)}, {len(self.names)}) matrix, "
                f"got shape {fisher.shape}"
            )
        fisher = 0.5 * (fisher + fisher.T)
        fisher.flags.writeable = False
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "fisher", fisher)

    @classmethod
    def from_measurements(
        cls, params: ParameterSet, qs: np.ndarray, sigma: np.ndarray | float, prior: Prior | None = None
    ) -> MeasuredPrior:
        """The prior of poses ``qs`` measured with noise ``sigma`` [m] per coordinate (one for all,
        or (m, K, 3) in the instrument frame), on top of ``prior`` (None: no prior).

        The Jacobians are the nominal robot's, as a design's are.
        """
        qs = params.robot.configurations(qs, what="measured configuration")
        J = JacobianEngine(params).jacobian(qs, frame="world")  # (m, 3K, P)
        s = np.broadcast_to(np.asarray(sigma, dtype=float).reshape(-1), (J.shape[0] * J.shape[1],))
        Jw = J.reshape(-1, len(params)) / s[:, None]
        base = prior if prior is not None else Prior(math.inf, math.inf)
        return cls(base.length, base.angle, dict(base.overrides), tuple(params.names), Jw.T @ Jw, len(qs))

    @classmethod
    def from_instrument(
        cls, params: ParameterSet, qs: np.ndarray, instrument: Instrument, prior: Prior | None = None
    ) -> MeasuredPrior:
        """The prior of poses ``qs`` measured with ``instrument`` (any kind, its error model), on top
        of ``prior``: F = Σᵢ JᵢᵀΣᵢ⁻¹Jᵢ from the instrument's whitened rows s·Lᵢ⁻¹Jᵢ over s², its
        reference σ (:class:`~pincal.instruments.instrument.RowsEngine`), in the instrument's frame."""
        qs = params.robot.configurations(qs, what="measured configuration")
        rows = instrument.engine(params).jacobian(qs, frame="world") / instrument.reference
        return cls.from_rows(params, rows, prior)

    @classmethod
    def from_rows(cls, params: ParameterSet, rows: np.ndarray, prior: Prior | None = None) -> MeasuredPrior:
        """The prior of measured poses whose rows, whitened by their own covariance (Lᵢ⁻¹Jᵢ, zero where
        a value was not measured), are ``rows`` (m, r, P) [1/m, 1/rad], on top of ``prior``."""
        Jw = np.asarray(rows, dtype=float).reshape(-1, len(params))
        base = prior if prior is not None else Prior(math.inf, math.inf)
        return cls(base.length, base.angle, dict(base.overrides), tuple(params.names), Jw.T @ Jw, len(rows))

    def _check(self, params: ParameterSet) -> None:
        if tuple(params.names) != self.names:
            raise BadArgument(
                "the measured information was built for other parameters: "
                f"{len(self.names)} ({', '.join(self.names[:4])}, ...), not those given ({len(params)})",
                argument="prior",
            )

    def precision(self, params: ParameterSet) -> np.ndarray:
        """(P, P) Σp⁻¹ + F: the prior's precision and the measured poses' information."""
        self._check(params)
        return super().precision(params) + self.fisher

    def as_dict(self) -> dict:
        out = super().as_dict()
        out["measured_poses"] = self.measured
        return out

    def __str__(self) -> str:
        before = super().__str__()
        return f"{self.measured} measured poses" + (
            "" if before.startswith("none, none") else f" and {before}"
        )
