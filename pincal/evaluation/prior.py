r"""A prior on the geometric errors, in physical units (docs/method.md §8.4).

Before calibration the user knows roughly how large the errors are: "lengths within about 1 mm,
angles within about 1 mrad". :class:`Prior` holds those standard deviations by kind (lengths in
metres, angles in radians; any parameter or group can be given its own) and turns them into the
prior covariance Σp = diag(std²) of a :class:`~pincal.ParameterSet`, its inverse Σp⁻¹ (the prior
precision; 0 for an infinite std: no prior on that parameter), and σ²Σp⁻¹, the prior as
information in the units of M = Σ JᵢᵀJᵢ (pseudo-measurements).

With measurements of noise σ per coordinate, the posterior covariance of the errors is
σ²(M + σ²Σp⁻¹)⁻¹ = (M/σ² + Σp⁻¹)⁻¹ (Chaloner & Verdinelli 1995): finite for every plan, and
σ²M⁻¹ again as Σp → ∞.

    >>> import pincal
    >>> prior = pincal.Prior.parse("1mm,1mrad")
    >>> prior.length, prior.angle
    (0.001, 0.001)
    >>> str(prior)
    '1 mm, 1 mrad'
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from pincal.arguments import ANGLE_UNITS, LENGTH_UNITS, UNITS_TEXT, number, positive_sigma, quantities
from pincal.errors import BadArgument
from pincal.model.parameters import ParameterSet

PRIOR_RANGE = (1e-12, 1e6)
"""Finite prior standard deviations pincal accepts [m or rad] (inf: no prior): 1/std² stays far
from overflow and underflow."""


def _positive(value: object, what: str) -> float:
    """A prior standard deviation: in :data:`PRIOR_RANGE`, or inf (no prior)."""
    if isinstance(value, (float, np.floating)) and value == math.inf:
        return math.inf
    low, high = PRIOR_RANGE
    return number(value, f"prior standard deviation of {what} (or inf: no prior)", low, high)


@dataclass(frozen=True)
class Prior:
    """Prior standard deviations of the geometric errors, by kind.

    Attributes:
        length: standard deviation of every parameter in metres [m] (``inf``: no prior).
        angle: standard deviation of every parameter in radians [rad] (``inf``: no prior).
        overrides: ``{parameter name or group: std}`` in that parameter's own unit, applied after
            ``length`` and ``angle`` in the order given (e.g. ``{"base": math.inf}``: the base is
            unknown; ``{"joint_a1.offset": 0.01}``).
    """

    length: float
    angle: float
    overrides: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "length", _positive(self.length, "lengths"))
        object.__setattr__(self, "angle", _positive(self.angle, "angles"))
        object.__setattr__(
            self, "overrides", {str(k): _positive(v, repr(k)) for k, v in dict(self.overrides).items()}
        )

    @classmethod
    def parse(cls, text: str) -> Prior:
        """A prior from ``"1mm,1mrad"``: a length and an angle, each with a unit
        (m, cm, mm, um; rad, mrad, urad, deg), in either order; bare numbers are metres then
        radians (``"1e-3,1e-3"``).

        Raises:
            PincalError: the text is not a length and an angle (the message says what is valid).
        """
        valid = (
            f"expected a length and an angle, e.g. '1mm,1mrad' ({UNITS_TEXT}; bare numbers are m then rad)"
        )
        if len([t for t in str(text).split(",") if t.strip()]) != 2:
            raise BadArgument(f"bad prior {text!r}: {valid}")
        found: dict[str, float] = {}
        for position, (kind, value) in enumerate(quantities(str(text), "bad prior", valid)):
            kind = kind or ("length", "angle")[position]
            if kind in found:
                raise BadArgument(f"bad prior {text!r}: two {kind}s; {valid}")
            found[kind] = value
        return cls(found["length"], found["angle"])

    def std(self, params: ParameterSet) -> np.ndarray:
        """(P,) prior standard deviation of each parameter of ``params`` [m or rad]."""
        out = np.array([self.length if p.is_length else self.angle for p in params], dtype=float)
        for name, value in self.overrides.items():
            chosen = set(params.select(name).names)
            out[[i for i, n in enumerate(params.names) if n in chosen]] = value
        return out

    def covariance(self, params: ParameterSet) -> np.ndarray:
        """(P, P) prior covariance Σp = diag(std²) [m², rad²] (inf where there is no prior)."""
        return np.diag(self.std(params) ** 2)

    def precision(self, params: ParameterSet) -> np.ndarray:
        """(P, P) prior precision Σp⁻¹ = diag(1/std²) (0 where there is no prior): add it to
        JᵀJ/σ² for the posterior information, or to a MAP normal equation."""
        return np.diag(1.0 / self.std(params) ** 2)

    def information(self, params: ParameterSet, sigma: float) -> np.ndarray:
        """(P, P) σ²Σp⁻¹: the prior in the units of M = Σ JᵢᵀJᵢ for noise ``sigma`` [m] per
        coordinate; the posterior covariance is σ²(M + σ²Σp⁻¹)⁻¹."""
        return positive_sigma(sigma) ** 2 * self.precision(params)

    def as_dict(self) -> dict:
        """``{"length": m, "angle": rad, "overrides": {...}}`` (inf as None)."""

        def finite(v: float) -> float | None:
            return v if math.isfinite(v) else None

        return {
            "length": finite(self.length),
            "angle": finite(self.angle),
            "overrides": {k: finite(v) for k, v in self.overrides.items()},
        }

    def __str__(self) -> str:
        def show(v: float, units: dict[str, float], small: str, large: str) -> str:
            if not math.isfinite(v):
                return "none"
            return f"{v / units[small]:.4g} {small}" if v < 0.1 * units[large] else f"{v:.4g} {large}"

        text = f"{show(self.length, LENGTH_UNITS, 'mm', 'm')}, {show(self.angle, ANGLE_UNITS, 'mrad', 'rad')}"
        return text + "".join(f", {k}: {v:.4g}" for k, v in self.overrides.items())
