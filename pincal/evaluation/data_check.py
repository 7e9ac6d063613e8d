r"""Identifiability on the data that will be used (issue 10): can *these* configurations identify
*this* parameter set?

:func:`pincal.model.base_parameters.identifiability` answers the question for random
configurations over the whole joint range. Real data cover less: a small region, joints parked at
one value. :func:`check_parameters` takes the information matrix of the user's own
configurations, whitened by the measurement noise (M = Σ JᵢᵀWᵢJᵢ, W = diag(1/σ²), so that
cov(Π̂) = M⁻¹), and reports:

* the rank and the conditioning of the data (the number every report gives: the smallest
  eigenvalue of the column-normalised M, :func:`~pincal.evaluation.information.conditioning`);
* the weakest parameter combinations, in words;
* the subset the data can identify: parameters are taken greedily in the order of
  :func:`~pincal.model.base_parameters.preference_order` (offsets, lengths, ...; the base first
  when it is identified) and one is kept when, with it, the data still determine every kept
  parameter to better than :data:`IDENTIFIABLE_STD` (1 cm, 10 mrad) for the noise σ and the
  conditioning stays above :data:`MIN_DATA_CONDITIONING`; each one left
  out is named with the reason (invisible in these data, inseparable from a kept one, or
  determined only to ±x).

A parameter the data determine only to ±1 cm is not identified by estimating it: its estimate
is noise, and its correlations throw the others off. Either leave it at its nominal value (the
reduced set) or give a prior (:class:`~pincal.Prior`, MAP identification).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pincal.deprecation import keywords_after
from pincal.evaluation.information import (
    condition_number,
    conditioning,
    covariance_diagonal,
    information_matrix,
    jacobi_scaled,
    rank,
    weakest,
)
from pincal.instruments.given import measured
from pincal.instruments.instrument import Instrument
from pincal.model.base_parameters import preference_order
from pincal.model.jacobian import ZERO_COLUMN
from pincal.model.parameters import ParameterSet
from pincal.typing import ConfigurationsLike

IDENTIFIABLE_STD = {"m": 1e-2, "rad": 1e-2, "1": 1e-2, "rad/(N·m)": 1e-4, "m/N": 1e-5}
"""A parameter is identifiable on the data when they determine it to better than this standard
error [m for lengths, rad for angles, 1 for gains, rad/(N·m) and m/N for compliances] (with every
other kept parameter estimated too): beyond, its estimate is noise that can reach values no real
robot has (a gain of 1 %; a compliance that bends a joint by 10 mrad under 100 N·m, ten times a
cobot's)."""

MIN_DATA_CONDITIONING = 1e-6
"""...and when the kept set's conditioning (σ_min² of the unit-column Jacobian,
:func:`~pincal.evaluation.information.conditioning`) stays above this: a small sampled region (a
few degrees per joint: 1e-8 and below) does not. A design's default floor (1e-2) never adapts
below it, so a designed plan passes (the kept set's conditioning is at least the whole set's)."""


@dataclass(frozen=True, eq=False)
class DataCheck:
    """What the user's configurations can identify.

    Attributes:
        names: the parameters examined (a parameter set's names, plus one base per extra session).
        units: ``"m"`` or ``"rad"`` for each.
        kept: indices into ``names`` of the parameters the data identify, in order.
        dropped: ``{name: reason}`` for the others.
        rank: numerical rank of the column-scaled data Jacobian.
        conditioning: the data's conditioning, the number every pincal report gives (see
            :func:`~pincal.evaluation.information.conditioning`: the smallest eigenvalue of the
            column-normalised information matrix, in (0, 1], 0 when rank deficient), of all of
            ``names``.
        conditioning_kept: the same for the kept parameters.
        condition_number: σ_max/σ_min of the column-scaled data Jacobian of all of ``names``
            (``inf`` when rank deficient); reports give the conditioning instead.
        condition_number_kept: the same for the kept parameters.
        weakest: the least determined combinations, in words, weakest first.
        std: (len(kept),) standard errors of the kept parameters for the noise σ [m or rad].
        sigma: the noise per coordinate the check assumed [m] (per-point σ when the data had them:
            then their median).
        m: number of configurations.
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    kept: tuple[int, ...]
    dropped: dict[str, str]
    rank: int
    condition_number: float
    condition_number_kept: float
    weakest: tuple[str, ...]
    std: np.ndarray
    sigma: float
    m: int
    conditioning: float = float("nan")
    conditioning_kept: float = float("nan")

    @property
    def identifiable(self) -> bool:
        """True when the data identify every parameter examined."""
        return not self.dropped

    @property
    def kept_names(self) -> tuple[str, ...]:
        """Names of the parameters the data identify."""
        return tuple(self.names[i] for i in self.kept)

    def report(self) -> str:
        """Text: rank, conditioning, weakest combinations, and what is left out and why."""
        shown = _conditioning_text(self.conditioning)
        lines = [
            f"data identifiability ({self.m} configurations, sigma {self.sigma * 1e3:.3g} mm): rank "
            f"{self.rank} of {len(self.names)} parameters, conditioning {shown}"
        ]
        lines += [f"  weakest: {w}" for w in self.weakest]
        if self.dropped:
            kept = (
                f"kept {len(self.kept)} (conditioning {_conditioning_text(self.conditioning_kept)})"
                if self.kept
                else "kept none"
            )
            lines.append(
                f"  the data cannot identify {len(self.dropped)} of them; {kept}; "
                "left at their nominal values:"
            )
            lines += [f"    {name}: {why}" for name, why in self.dropped.items()]
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """JSON-ready: rank, condition numbers (None for inf), weakest, kept, dropped, sigma."""

        def finite(v: float) -> float | None:
            return float(v) if np.isfinite(v) else None

        return {
            "rank": self.rank,
            "n_params": len(self.names),
            "conditioning": float(self.conditioning),
            "conditioning_kept": float(self.conditioning_kept),
            "condition_number": finite(self.condition_number),
            "condition_number_kept": finite(self.condition_number_kept),
            "weakest": list(self.weakest),
            "kept": list(self.kept_names),
            "dropped": dict(self.dropped),
            "sigma": self.sigma,
            "m": self.m,
        }


def _shown(value: float, unit: str) -> str:
    return f"{value * 1e3:.3g} {'mm' if unit == 'm' else 'mrad'}"


def _combination(names: Sequence[str], v: np.ndarray) -> str:
    big = sorted(np.flatnonzero(np.abs(v) >= 0.2), key=lambda i: -abs(v[i]))[:4]
    sign = 1.0 if v[big[0]] >= 0 else -1.0
    terms = [f"{'+' if sign * v[i] >= 0 else '-'} {abs(v[i]):.2f}·{names[int(i)]}" for i in big]
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else "-" + text[2:]


@dataclass(frozen=True, eq=False)
class _Columns:
    """The columns of an information matrix under check.

    Attributes:
        names, units: of each column.
        M: (P, P) the whitened information (cov = M⁻¹).
        scaled: M Jacobi-scaled: the cosines between the columns of the whitened Jacobian.
        bound: (P,) the standard error beyond which a column is not identified [m or rad].
        always: the columns kept whatever their standard error.
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    M: np.ndarray
    scaled: np.ndarray
    bound: np.ndarray
    always: frozenset[int]

    @classmethod
    def of(cls, names: Sequence[str], units: Sequence[str], M: np.ndarray, always: Sequence[int]) -> _Columns:
        _, scaled = jacobi_scaled(M, ZERO_COLUMN)
        bound = np.array([IDENTIFIABLE_STD[u] for u in units])
        return cls(tuple(names), tuple(units), M, scaled, bound, frozenset(always))


def _check(columns: _Columns, order: Sequence[int], m: int, sigma: float) -> DataCheck:
    """The data check of the columns, taken in ``order`` (see the module doc), for m
    configurations of noise ``sigma`` per coordinate [m] (for the report)."""
    names, M = columns.names, columns.M
    kept, std, dropped = _identifiable_subset(columns, order)
    position = {i: n for n, i in enumerate(kept)}
    kept_sorted = sorted(kept)
    std = np.array([std[position[i]] for i in kept_sorted])
    sub = M[np.ix_(kept_sorted, kept_sorted)]
    return DataCheck(
        names=names,
        units=columns.units,
        kept=tuple(kept_sorted),
        dropped={n: dropped[n] for n in names if n in dropped},
        rank=rank(M),
        condition_number=condition_number(M),
        condition_number_kept=condition_number(M[np.ix_(kept_sorted, kept_sorted)])
        if kept_sorted
        else np.inf,
        weakest=_weakest_words(names, M),
        std=std,
        sigma=float(sigma),
        m=int(m),
        conditioning=_conditioning(M),
        conditioning_kept=_conditioning(sub) if kept_sorted else 0.0,
    )


def _identifiable_subset(
    columns: _Columns, order: Sequence[int]
) -> tuple[list[int], np.ndarray, dict[str, str]]:
    """(kept columns in the order taken, their standard errors, {name: reason} of those left out):
    the ``always`` columns first, then each column of ``order`` unless :func:`_refusal` says why not."""
    names, M, always = columns.names, columns.M, columns.always
    zero = columns.scaled.diagonal() == 0.0
    kept: list[int] = []
    dropped: dict[str, str] = {}
    std = np.zeros(0)
    for i in sorted(order, key=lambda i: i not in always):
        if zero[i] and i not in always:
            dropped[names[i]] = (
                "invisible in these data: it does not move the measured points at these configurations"
            )
            continue
        trial = kept + [i]
        diag = covariance_diagonal(M[np.ix_(trial, trial)])
        if i in always:
            kept, std = trial, np.sqrt(diag) if diag is not None else np.full(len(trial), np.inf)
            continue
        why = _refusal(columns, trial, diag)
        if why is not None:
            dropped[names[i]] = why
            continue
        assert diag is not None  # a singular trial is refused above
        kept, std = trial, np.sqrt(diag)
    for i, name in enumerate(names):
        if name in dropped and columns.units[i] in COMPLIANCE_UNITS:
            dropped[name] += COMPLIANCE_HINT
    return kept, std, dropped


COMPLIANCE_UNITS = ("rad/(N·m)", "m/N")
COMPLIANCE_HINT = (
    "; a compliance shows only through how the gravity torque on its joint varies over the data: "
    "measure under several payloads (the payload_kg column; 'design --payloads' chooses them)"
)
"""What the reason a compliance is left out adds: how to make it separable."""


def _refusal(columns: _Columns, trial: list[int], diag: np.ndarray | None) -> str | None:
    """Why the last column of ``trial`` cannot join the ones kept before it (``diag``: the
    covariance diagonal of ``trial``, None if singular): inseparable from them, nearly so, or it
    leaves one too poorly determined; None when it can."""
    names, units, scaled, bound = columns.names, columns.units, columns.scaled, columns.bound
    i, kept = trial[-1], trial[:-1]
    partner = ""
    if kept:
        k = max(kept, key=lambda k: abs(scaled[i, k]))
        partner = f"; it moves the points nearly as {names[k]} does (cosine {abs(scaled[i, k]):.4f})"
    if diag is None:
        return "inseparable in these data from the parameters kept before it" + partner
    floor = conditioning(columns.M[np.ix_(trial, trial)])
    if floor < MIN_DATA_CONDITIONING:
        return (
            f"nearly inseparable in these data from those kept before it (conditioning {floor:.2g} "
            f"< {MIN_DATA_CONDITIONING:g})" + partner
        )
    trial_std = np.sqrt(diag)
    limited = [j for j in range(len(trial)) if trial[j] not in columns.always]
    worse = [j for j in limited if trial_std[j] > bound[trial[j]]]
    if not worse:
        return None
    j = len(trial) - 1 if worse[-1] == len(trial) - 1 else worse[0]
    shown = f"±{_shown(trial_std[j], units[trial[j]])} (limit {_shown(bound[trial[j]], units[trial[j]])})"
    if j == len(trial) - 1:
        return f"these data determine it only to {shown}" + partner
    return f"with it, these data would determine {names[trial[j]]} only to {shown}" + partner


def _weakest_words(names: tuple[str, ...], M: np.ndarray) -> tuple[str, ...]:
    """The least determined combinations of M's columns, in words: the weakest, and up to two more
    while their relative singular value is below 0.05."""
    words: list[str] = []
    for s, v in weakest(M, min(3, len(names))):
        if s >= 0.05 and words:
            break
        words.append(f"{_combination(names, v)} (relative singular value {s:.2g})")
    return tuple(words)


def check_parameters(
    params: ParameterSet, M: np.ndarray, m: int, sigma: float, extra: Mapping[str, str] | None = None
) -> DataCheck:
    """The data check identification makes: which of ``params`` data of whitened information
    ``M`` determine, taken in the order :func:`~pincal.model.base_parameters.preference_order`
    prefers them, the base (``base.*``, if in ``params``) and the instrument's fixtures (a camera,
    its target, anchors) first and always kept: an instrument's placement is never left at its
    nominal value. :func:`pincal.identify`, :func:`check_plan`
    and a design's check of its plan all go through here.

    Args:
        params: the parameter set, the first columns of ``M``.
        M: (P + E, P + E) information Σ JᵢᵀWᵢJᵢ (W = 1/σ² per coordinate, so cov = M⁻¹).
        m: number of configurations (for the report).
        sigma: the noise per coordinate behind W [m] (for the report).
        extra: ``{name: unit}`` of the E columns after the parameters, always kept (the bases of
            further sessions, one per instrument placement).
    """
    extra = {} if extra is None else extra
    P = len(params)
    base = [i for i, p in enumerate(params) if p.kind in ("base", "fixture")]
    always = base + list(range(P, P + len(extra)))
    order = preference_order(params, frozenset(params.names[i] for i in base)) + always[len(base) :]
    names, units = params.names + tuple(extra), params.units + tuple(extra.values())
    return _check(_Columns.of(names, units, M, always), order, m, sigma)


@keywords_after(2)
def check_plan(
    params: ParameterSet,
    plan: ConfigurationsLike,
    *,
    sigma: float | None = None,
    instrument: Instrument | None = None,
) -> DataCheck:
    """The data check of ``params`` on configurations ``plan`` (a Plan, (m, nq) array, or the
    ``q`` of measurements), as identify makes it (:func:`check_parameters`), for what
    ``instrument`` measures, weighted by its error model, or for points with noise ``sigma`` per
    coordinate [m] (its shorthand; default :data:`~pincal.arguments.DEFAULT_SIGMA`; not both)."""
    instrument, sigma = measured(instrument, sigma)
    qs = params.robot.configurations(plan)
    payload = getattr(plan, "payload", None)
    if instrument is not None and not instrument.is_default:
        rows = instrument.engine(params).jacobian(qs, frame="tip", payload=payload)
        M = information_matrix(rows) / sigma**2
        return check_parameters(params, M, len(qs), sigma)
    M = information_matrix(params.jacobian(qs, frame="tip", payload=payload)) / sigma**2
    return check_parameters(params, M, len(qs), sigma)


def _conditioning(M: np.ndarray) -> float:
    """The conditioning of M, 0 when it is rank deficient (the rounding of a singular M's
    smallest eigenvalue is not a conditioning)."""
    return conditioning(M) if rank(M) == len(M) else 0.0


def _conditioning_text(value: float) -> str:
    return f"{value:.3g}" if value > 0 else "0 (singular)"
