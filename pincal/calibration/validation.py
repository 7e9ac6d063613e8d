"""Validation on held-out data, the way calibration engineers report a calibration.

The position error of each held-out measured point — the distance between what the instrument
measured and what the model predicts — before calibration (nominal robot, the base of the initial
rigid fit when the base is identified) and after (the calibrated robot), summarised by RMS, max
and 95th percentile. For another measurement kind, the error of each block of values in its first
unit: a pose's position, a distance, a target point's pixels.

* :func:`validate`: a fitted result on other data (another file measured from the same
  instrument placement as the result's first data file, or from session ``session``).
* :func:`holdout`: fit on a random part of the data, validate on the rest (``fraction`` held out,
  per session).
* :func:`kfold`: k fits, each validated on the fold it did not see; every point is held out once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pincal.arguments import fraction as checked_fraction
from pincal.arguments import generator, positive_int
from pincal.calibration.identification import IdentificationResult, identify
from pincal.calibration.measurements import MeasurementData
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, warn
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot

MIN_COORDINATES_PER_UNKNOWN = 2
"""A fit behind a validation (a holdout's, a k-fold fold's) with fewer measured coordinates than
this many per unknown it estimates is warned about: it follows the noise of the rows it fits, and
the held-out error overstates what a calibration on all the data reaches (a 12-configuration
KR 270 plan held out by 20 %: 30 coordinates for 27 parameters, a held-out error of 13 σ)."""


@dataclass(frozen=True, eq=False)
class Validation:
    """Position errors on held-out points.

    Attributes:
        before: (n,) error of each held-out point before calibration [m] (one per measured point:
            configurations × markers).
        after: (n,) the same after calibration [m].
        labels: the file and line of each error's configuration.
        how: how the points were held out, in words.
        statuses: the status of each fit behind the errors (one for a file or a holdout, k for
            k-fold).
        expected: (n,) the error each fit predicts for each held-out point [m]: the root of the
            variance of its prediction (the parameters' standard errors propagated, plus the
            residual model's posterior variance when the fit has one,
            :meth:`~pincal.IdentificationResult.point_variances`) plus the measurement's own
            noise, 3n² (n the residual model's noise per coordinate, else the fit's σ); None when
            not computed. Its RMS against that of ``after`` says whether the calibration is
            honest about what it cannot explain.
        residual_model: True when the fits had a residual model (its mean corrects ``after``, its
            variance is in ``expected``).
        unit: the errors' unit: ``m`` (points; a pose's or a partial pose's position, a
            distance), or ``px`` for images (``rad`` when only orientations are measured); ``expected``
            is computed for points only.
    """

    before: np.ndarray
    after: np.ndarray
    labels: tuple[str, ...]
    how: str
    statuses: tuple[str, ...] = ("converged",)
    expected: np.ndarray | None = None
    residual_model: bool = False
    unit: str = "m"

    @staticmethod
    def _stats(errors: np.ndarray) -> dict[str, float]:
        return {
            "rms": float(np.sqrt(np.mean(errors**2))),
            "max": float(errors.max()),
            "p95": float(np.percentile(errors, 95)),
        }

    @property
    def stats_before(self) -> dict[str, float]:
        """``{"rms", "max", "p95"}`` of the errors before calibration [m]."""
        return self._stats(self.before)

    @property
    def stats_after(self) -> dict[str, float]:
        """``{"rms", "max", "p95"}`` of the errors after calibration [m]."""
        return self._stats(self.after)

    @property
    def expected_rms(self) -> float:
        """RMS of :attr:`expected` [m] (NaN when not computed): what the fits predicted ``after``'s
        RMS to be."""
        if self.expected is None:
            return float("nan")
        return float(np.sqrt(np.mean(self.expected**2)))

    def as_dict(self) -> dict:
        return {
            "how": self.how,
            **({} if self.unit == "m" else {"unit": self.unit}),
            "n_points": int(self.before.size),
            "before": self.stats_before,
            "after": self.stats_after,
            "expected_rms": self.expected_rms if np.isfinite(self.expected_rms) else None,
            "residual_model": self.residual_model,
            "statuses": list(self.statuses),
            "errors_before": self.before.tolist(),
            "errors_after": self.after.tolist(),
            "errors_expected": None if self.expected is None else self.expected.tolist(),
        }

    def report(self) -> str:
        b, a = self.stats_before, self.stats_after

        scale, unit = {"m": (1e3, "mm"), "rad": (1e3, "mrad")}.get(self.unit, (1.0, self.unit))

        def row(what: str, s: dict[str, float]) -> str:
            rms, p95, top = (s[k] * scale for k in ("rms", "p95", "max"))
            return f"  {what:7s} RMS {rms:8.4g} {unit}, 95% {p95:8.4g} {unit}, max {top:8.4g} {unit}"

        lines = [
            f"validation on {self.before.size} held-out point(s), {self.how}:",
            row("before", b),
            row("after", a),
        ]
        if np.isfinite(self.expected_rms):
            what = (
                "the parameters' standard errors, the residual model's variance and the noise"
                if self.residual_model
                else "the parameters' standard errors, the residual level beyond the noise and the noise; "
                "no residual model"
            )
            lines.append(f"  predicted RMS after {self.expected_rms * 1e3:8.4g} mm ({what})")
        failed = [s for s in self.statuses if s != "converged"]
        if failed:
            lines.append(
                f"  {len(failed)} of {len(self.statuses)} fit(s) did not converge: {', '.join(failed)}"
            )
        return "\n".join(lines)


def _errors(
    result: IdentificationResult, data: MeasurementData, session: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, list[str]]:
    """(before, after, expected, labels): the error of each held-out point (of another kind: of each
    block of values measured, in its first value's unit) before and after calibration, and the
    error the fit predicts for it (points only, else None)."""
    data = data.for_robot(result.params.robot)
    before_robot = result.initial_robot or result.params.robot
    if result.bases:
        before_robot = before_robot.replace(base=result.initial_bases[session])
    session = session if result.bases else 0
    if data.is_points:
        before = np.linalg.norm(data.points - before_robot.points(data.q, check=False), axis=-1).reshape(-1)
        predicted = result.predict(data.q, payload=data.payload, session=session)
        after = np.linalg.norm(data.points - predicted, axis=-1).reshape(-1)
        labels = [label for label in data.labels() for _ in range(data.n_markers)]
        return before, after, _expected(result, data, session), labels
    after_robot = result.robot.replace(base=result.bases[session]) if result.bases else result.robot
    kind, heads = data.measure, _heads(data, result.robot)

    def sizes(robot: Robot) -> np.ndarray:
        r = kind.difference(data.values, kind.predict(robot, data.q, data.payload))
        return np.stack([np.linalg.norm(r[:, h], axis=1) for h in heads], axis=1)  # (m, blocks)

    before, after = sizes(before_robot), sizes(after_robot)
    measured = np.isfinite(before)
    labels = [label for i, label in enumerate(data.labels()) for b in range(len(heads)) if measured[i, b]]
    return before[measured], after[measured], None, labels


def _expected(result: IdentificationResult, data: MeasurementData, session: int) -> np.ndarray:
    """(m·K,) the error ``result`` predicts for each of ``data``'s points (measured in session
    ``session``, with its own base's uncertainty) [m]: its prediction's
    variance (the parameters, and what the model does not explain: the residual model's variance or
    the residual level beyond the instrument's noise, u²) plus the noise of a measurement, 3n² per
    point (n the residual model's noise; else σ when given; when σ was estimated, the residual level
    less u²: with the noise, the residual level whole)."""
    parameters, rest = result.point_variances(data.q, payload=data.payload, session=session)
    model = result.residual_model
    if model is not None:
        noise2 = model.noise**2
    elif not result.sigma_estimated:
        noise2 = result.sigma**2
    else:
        level2 = result.sigma**2 if np.isfinite(result.sigma) else 0.0
        noise2 = max(level2 - np.nan_to_num(result.unexplained), 0.0)
    return np.sqrt(parameters + rest + 3 * noise2).reshape(-1)


def _joined(parts: list[np.ndarray | None]) -> np.ndarray | None:
    """The parts concatenated, or None when any is None (not computed for that kind)."""
    present = [p for p in parts if p is not None]
    return None if len(present) < len(parts) else np.concatenate(present)


def _heads(data: MeasurementData, robot: Robot) -> list[list[int]]:
    """Each block's values of its first value's unit (a pose's position, a point's pixels)."""
    units = data.measure.units(robot)
    return [[i for i in b if units[i] == units[b[0]]] for b in data.measure.blocks(robot)]


def _unit(data: MeasurementData, robot: Robot) -> str:
    """The unit of the validation errors of ``data``."""
    return "m" if data.is_points else data.measure.units(robot)[0]


@keywords_after(2)
def validate(result: IdentificationResult, data: MeasurementData, *, session: int = 0) -> Validation:
    """Errors of ``result`` on other measurements ``data`` (in session ``session``'s instrument
    frame: the first data file's by default)."""
    if not isinstance(data, MeasurementData):
        raise BadArgument(f"validate needs a MeasurementData, got {type(data).__name__}")
    if not 0 <= session < max(len(result.sessions), 1):
        raise BadArgument(f"session must be between 0 and {len(result.sessions) - 1}, got {session}")
    before, after, expected, labels = _errors(result, data, session)
    source = data.source or "other data"
    return Validation(
        before,
        after,
        tuple(labels),
        f"file {source}",
        (result.status,),
        expected,
        result.residual_model is not None,
        _unit(data, result.robot),
    )


def _as_sessions(data: MeasurementData | Sequence[MeasurementData]) -> list[MeasurementData]:
    return [data] if isinstance(data, MeasurementData) else list(data)


def _warn_if_thin(
    fits: list[IdentificationResult], sessions: list[MeasurementData], fraction: float | None
) -> None:
    """Warn when a fit behind a validation (a holdout of ``fraction``, or the k-fold ``fits``) has
    fewer than :data:`MIN_COORDINATES_PER_UNKNOWN` measured coordinates per unknown it estimated,
    saying the numbers and what to do."""
    counts = [(fit, (fit.data.m - len(fit.rejected)) * fit.data.row_size, _unknowns(fit)) for fit in fits]
    fit, coordinates, unknowns = min(counts, key=lambda c: c[1] / max(c[2], 1))
    if coordinates >= MIN_COORDINATES_PER_UNKNOWN * unknowns:
        return
    total = sum(d.m for d in sessions)
    needed = -(-MIN_COORDINATES_PER_UNKNOWN * unknowns // fit.data.row_size)  # configurations
    if fraction is not None:
        how, what = f"holdout {fraction:g}", "the fit"
        todo = (
            f"hold out at most {total - needed} of the {total} configurations, measure more"
            if total > needed
            else f"measure at least {_enough(needed, fraction)} configurations for this holdout"
        )
    else:
        how, what, folds = f"{len(fits)}-fold", "a fold's fit", _folds(sessions, needed)
        todo = f"use {folds} folds or more" if folds else f"measure at least {needed + 1} configurations"
    warn(
        f"{how}: {what} on {fit.data.m} of {total} configurations has {coordinates} measured "
        f"coordinates for {unknowns} parameters, fewer than twice as many ({2 * unknowns}): it follows "
        f"the noise of its data, and the held-out error overstates the calibration's; {todo}, or "
        "validate on another file (pincal.validate, --validate)"
    )


def _enough(needed: int, fraction: float) -> int:
    """The fewest configurations that leave ``needed`` to fit once ``fraction`` is held out."""
    total = needed + 1
    while total - max(1, round(fraction * total)) < needed:
        total += 1
    return total


def _unknowns(result: IdentificationResult) -> int:
    """The unknowns a fit estimated: every one with a prior, else those its data determine (the
    bases of further sessions included)."""
    if result.check is None:
        return len(result.params)
    return len(result.check.names) if result.prior is not None else len(result.check.kept)


def _folds(sessions: list[MeasurementData], needed: int) -> int | None:
    """The fewest folds whose every fit has ``needed`` configurations, or None (not even one
    configuration held out at a time)."""
    for k in range(2, min(d.m for d in sessions) + 1):
        if sum(d.m - len(range(0, d.m, k)) for d in sessions) >= needed:
            return k
    return None


def _fit_and_test(
    params: ParameterSet, sessions: list[MeasurementData], test_rows: list[np.ndarray], kwargs: dict
) -> tuple[IdentificationResult, np.ndarray, np.ndarray, np.ndarray | None, list[str]]:
    train = [
        d.subset(np.setdiff1d(np.arange(d.m), rows)) for d, rows in zip(sessions, test_rows, strict=True)
    ]
    result = identify(params, train, **kwargs)
    before, after, expected, labels = [], [], [], []
    for s, (d, rows) in enumerate(zip(sessions, test_rows, strict=True)):
        if len(rows) == 0:
            continue
        b, a, e, held = _errors(result, d.subset(rows), s)
        before.append(b)
        after.append(a)
        expected.append(e)
        labels += held
    return result, np.concatenate(before), np.concatenate(after), _joined(expected), labels


@keywords_after(3)
def holdout(
    params: ParameterSet,
    data: MeasurementData | Sequence[MeasurementData],
    fraction: float,
    *,
    seed: int | None = 0,
    **kwargs: object,
) -> tuple[IdentificationResult, Validation]:
    """Fit on a random ``1 − fraction`` of each session's rows, validate on the rest.

    Args:
        params, data, kwargs: as for :func:`~pincal.identify`.
        fraction: the share of the rows held out, in (0, 1).
        seed: of the random split (same seed, same split).

    Returns:
        (the fit on the training rows, its validation on the held-out rows).
    """
    fraction = checked_fraction(fraction, "holdout fraction")
    rng = generator(seed)
    sessions = _as_sessions(data)
    rows = [np.sort(rng.permutation(d.m)[: max(1, round(fraction * d.m))]) for d in sessions]
    result, before, after, expected, labels = _fit_and_test(params, sessions, rows, kwargs)
    _warn_if_thin([result], sessions, fraction)
    trained = sum(d.m for d in sessions) - sum(map(len, rows))
    how = f"{fraction:.0%} held out (seed {seed}), fitted on the other {trained} configurations"
    gp, unit = result.residual_model is not None, _unit(sessions[0], params.robot)
    return result, Validation(before, after, tuple(labels), how, (result.status,), expected, gp, unit)


@keywords_after(3)
def kfold(
    params: ParameterSet,
    data: MeasurementData | Sequence[MeasurementData],
    k: int,
    *,
    seed: int | None = 0,
    **kwargs: object,
) -> Validation:
    """k-fold cross-validation: each configuration is held out once, predicted by the fit on the
    other k − 1 folds (rows shuffled with ``seed``, per session).

    Args:
        params, data, kwargs: as for :func:`~pincal.identify`.
        k: number of folds, at least 2 and at most the number of configurations of each session.
    """
    k = positive_int(k, "k (folds)", low=2)
    sessions = _as_sessions(data)
    if any(d.m < k for d in sessions):
        raise BadArgument(f"k-fold: {k} folds need at least {k} configurations in each data file")
    rng = generator(seed)
    orders = [rng.permutation(d.m) for d in sessions]
    before, after, expected, labels, fits = [], [], [], [], []
    for fold in range(k):
        rows = [np.sort(order[fold::k]) for order in orders]
        result, b, a, e, lab = _fit_and_test(params, sessions, rows, kwargs)
        before.append(b)
        after.append(a)
        expected.append(e)
        labels += lab
        fits.append(result)
    _warn_if_thin(fits, sessions, None)
    statuses = [fit.status for fit in fits]
    how = f"{k}-fold cross-validation (seed {seed})"
    return Validation(
        np.concatenate(before),
        np.concatenate(after),
        tuple(labels),
        how,
        tuple(statuses),
        _joined(expected),
        any(fit.residual_model is not None for fit in fits),
        _unit(sessions[0], params.robot),
    )
