"""What every real data set of the suite is put through: each model fitted on the training rows and
judged on the held-out rows, measured error beside predicted error, and plans of m configurations
chosen from the measured rows (designed, D-optimal, random) judged on the same held-out rows.

A data set is a list of sessions (one instrument frame each: a tracker's placement, a socket) split
once into training and held-out rows; every figure of a set uses that one split. Errors are the
distance between the measured and the predicted point [m], as :func:`pincal.validate` gives them.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

import pincal
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.validation import Validation
from pincal.errors import PincalError


@dataclass(frozen=True)
class Model:
    """One model of the comparison.

    Attributes:
        name: its name in the tables.
        spec: the parameter groups beside the set's own (base, sockets): "" for the nominal robot.
        gp: with the Gaussian-process residual model (``residual_model="gp"``).
    """

    name: str
    spec: str
    gp: bool = False


MODELS = (
    Model("nominal", ""),
    Model("geometric (full,offsets)", "full,offsets"),
    Model("+ gains", "full,offsets,gains"),
    Model("+ compliance", "full,offsets,compliance"),
    Model("+ residual model (gp)", "full,offsets", gp=True),
)
"""The models compared on every set (compliance only where the URDF has inertias)."""


@dataclass(frozen=True)
class Split:
    """A data set split into training and held-out rows, per session.

    Attributes:
        train: the training rows of each session.
        test: the held-out rows of each session.
    """

    train: tuple[MeasurementData, ...]
    test: tuple[MeasurementData, ...]

    @classmethod
    def of(cls, sessions: Sequence[MeasurementData], fraction: float, seed: int) -> Split:
        """Hold out a random ``fraction`` of each session's rows (``seed``: the permutation's)."""
        rng = np.random.default_rng(seed)
        train, test = [], []
        for data in sessions:
            order = rng.permutation(data.m)
            cut = data.m - max(1, round(fraction * data.m))
            train.append(data.subset(np.sort(order[:cut])))
            test.append(data.subset(np.sort(order[cut:])))
        return cls(tuple(train), tuple(test))


@dataclass(frozen=True)
class Outcome:
    """One fit judged on the held-out rows.

    Attributes:
        status: the fit's status.
        n_params: the parameters it estimated.
        fit_rms: RMS of its residuals on the training rows [m] (per coordinate).
        validation: its errors on the held-out rows, measured and predicted.
        seconds: wall time of fit and validation [s].
    """

    status: str
    n_params: int
    fit_rms: float
    validation: Validation
    seconds: float

    @property
    def rms(self) -> float:
        return self.validation.stats_after["rms"]

    @property
    def max(self) -> float:
        return self.validation.stats_after["max"]


def judged(params: pincal.ParameterSet, split: Split, *, sigma: float | None, gp: bool = False) -> Outcome:
    """Identify ``params`` on the training rows and validate on the held-out rows of every session."""
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # thin fits of small plans warn; the table says what they do
        result = pincal.identify(params, list(split.train), sigma=sigma, residual_model="gp" if gp else None)
        parts = [pincal.validate(result, test, session=s) for s, test in enumerate(split.test)]
    validation = Validation(
        np.concatenate([v.before for v in parts]),
        np.concatenate([v.after for v in parts]),
        tuple(label for v in parts for label in v.labels),
        "held-out rows",
        (result.status,),
        None if parts[0].expected is None else np.concatenate([v.expected for v in parts]),
        gp,
    )
    return Outcome(
        result.status, len(result.values), result.residual_rms_after, validation, time.perf_counter() - start
    )


def mm(x: float) -> str:
    return f"{x * 1e3:.3f}"


def models_table(
    parameters: object, split: Split, models: Sequence[Model], *, sigma: float | None
) -> tuple[list[str], dict[str, Outcome]]:
    """Markdown rows of the models' held-out figures; ``parameters(spec)`` gives the set of a model."""
    lines = [
        "| model | parameters | status | fit RMS | held-out RMS | held-out max | predicted RMS | "
        "predicted / measured | time |",
        "| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    outcomes = {}
    for model in models:
        out = judged(parameters(model.spec), split, sigma=sigma, gp=model.gp)
        outcomes[model.name] = out
        predicted = out.validation.expected_rms
        lines.append(
            f"| {model.name} | {out.n_params} | {out.status} | {mm(out.fit_rms)} | {mm(out.rms)} | {mm(out.max)} | "
            f"{mm(predicted)} | {predicted / out.rms:.2f} | {out.seconds:.1f} s |"
        )
    return lines, outcomes


def _rows_of(plan: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """The pool's row of each planned configuration (the design picks measured rows)."""
    rows = [int(np.flatnonzero(np.all(pool == q, axis=1))[0]) for q in np.asarray(plan)]
    return np.array(rows)


def designs_table(
    params: pincal.ParameterSet,
    split: Split,
    sizes: Sequence[int],
    *,
    sigma: float,
    draws: int = 10,
    seed: int = 0,
    starts: int = 8,
) -> list[str]:
    """Markdown rows: for each m, the held-out RMS of a calibration on m of the training rows (one
    session) chosen by the test-pose design over the held-out configurations, by a D-optimal design,
    and at random (median and range of ``draws`` draws), with the designed plan's ρ0."""
    (train,) = split.train
    (test,) = split.test
    pool = train.q
    lines = [
        f"| m | designed (test-pose) | D-optimal | random, median of {draws} [min – max] | ρ0 of the design (σ alone) |",
        "| ---: | ---: | ---: | ---: | ---: |",
    ]
    rng = np.random.default_rng(seed)
    for m in sizes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                design = pincal.design(
                    params,
                    m,
                    test.q,
                    sigma=sigma,
                    with_d_optimal=True,
                    search=pincal.Search(pool=pool, starts=starts, seed=seed, workers=1),
                    safety=pincal.Safety(joint_margin=0, mount="none"),
                )
            except PincalError as error:
                lines.append(f"| {m} | no plan: {str(error).split(';')[0]} | | | |")
                continue

        def on(rows: np.ndarray) -> float:
            return judged(params, Split((train.subset(rows),), split.test), sigma=sigma).rms

        designed = on(_rows_of(design.plan.q, pool))
        d_optimal = on(_rows_of(design.d_optimal.plan.q, pool))
        random = [on(np.sort(rng.choice(len(pool), m, replace=False))) for _ in range(draws)]
        lines.append(
            f"| {m} | {mm(designed)} | {mm(d_optimal)} | {mm(float(np.median(random)))} "
            f"[{mm(min(random))} – {mm(max(random))}] | {mm(design.rho0)} |"
        )
    return lines
