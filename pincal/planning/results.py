"""What a design hands back: the plan with its criterion value and per-start history
(:class:`DesignResult`, :class:`StartRecord`), and the distribution of a criterion over random
plans (:class:`RandomPlans`), the baseline a design is judged against."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.evaluation.prior import Prior
from pincal.instruments.instrument import Instrument
from pincal.planning.plan import Plan

__all__ = ["DesignResult", "RandomPlans", "StartRecord"]


@dataclass(frozen=True)
class StartRecord:
    """What one start of the search did (for convergence plots).

    Attributes:
        start: index of the start.
        value: criterion value at its end, in the criterion's units (inf if singular).
        screen_value: value after the screening iterations (continuous method), else None.
        iterations: optimiser iterations (continuous) or exchange sweeps (exchange).
        time_s: wall time of this start [s].
        continued: run to convergence (False: dropped after screening).
        feasible: its plan satisfies every constraint.
        message: the optimiser's last message.
    """

    start: int
    value: float
    screen_value: float | None
    iterations: int
    time_s: float
    continued: bool
    feasible: bool
    message: str = ""

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        d["value"] = finite_or_none(self.value)
        d["screen_value"] = None if self.screen_value is None else finite_or_none(self.screen_value)
        return d


@dataclass(frozen=True)
class DesignResult:
    """A designed measurement plan.

    Attributes:
        plan: the m configurations [rad or m].
        value: the criterion's value (units: ρ0 [m] for the test-pose criteria; log det M⁻¹,
            tr M⁻¹, λ_max(M⁻¹), cond for D, A, E, cond), as :func:`pincal.rho0` and
            :func:`pincal.criteria` compute it.
        criterion: the criterion minimised.
        rho0: ρ0 at the test pose(s) [m] for ``sigma`` (root mean square over several; worst for
            ``test-pose-worst``); None without a test pose.
        rho0_each: (k,) ρ0 at each test pose [m], or None.
        sigma: measurement noise per coordinate [m].
        method: the search method.
        starts: starts run.
        matched: starts whose value is within
            :data:`~pincal.planning.stopping.TOLERANCE` of the best, the best included.
        adaptive: the number of starts was the adaptive default (``starts=None``): batches until
            :data:`~pincal.planning.stopping.AGREE` starts matched or the cap was reached.
        continued: starts run to convergence.
        seed: the entropy of the seed sequence (pass it as ``seed`` to repeat the design).
        time_s: wall time [s].
        history: one record per start.
        pool_size: candidate configurations (the exchange's pool, or where starts were drawn).
        pool_rejected: configurations of a user pool dropped as infeasible.
        conditioning: the plan's conditioning, the smallest eigenvalue of its Jacobi-scaled
            information matrix (in (0, 1]; see ``min_conditioning`` of :func:`design`).
        message: a one-line summary.
        prior: the prior the design used (ρ0 is then the Bayesian one), or None.
        instrument: what the plan is measured with and how well (``sigma`` is then its reference
            σ), or None: points with ``sigma``.
        orientation_length: L [m] of the test-pose criterion's orientation part, or None.
        instrument_at: (x, y, z) the instrument's position chosen with the plan
            (:func:`pincal.planning.place_instrument`) [m], or None.
        dropped: starts that failed alone and were dropped (degenerate: none of their random plans
            was regular), of ``starts``; the plan is the best of the others.
        d_optimal: the D-optimal design from the same starts (``design(..., with_d_optimal=True)``),
            or None; not in :meth:`as_dict`.
    """

    plan: Plan
    value: float
    criterion: str
    rho0: float | None
    rho0_each: np.ndarray | None
    sigma: float
    method: str
    starts: int
    continued: int
    seed: int
    time_s: float
    history: tuple[StartRecord, ...]
    pool_size: int
    pool_rejected: int
    conditioning: float
    message: str
    prior: Prior | None = None
    instrument: Instrument | None = None
    orientation_length: float | None = None
    instrument_at: tuple[float, float, float] | None = None
    dropped: int = 0
    d_optimal: DesignResult | None = None
    matched: int = 0
    adaptive: bool = False

    @property
    def m(self) -> int:
        """Number of configurations."""
        return len(self.plan)

    def as_dict(self) -> dict:
        """A JSON-ready dict (radians, metres)."""
        return {
            "plan": self.plan.q.tolist(),
            "joint_names": list(self.plan.joint_names),
            "m": self.m,
            "criterion": self.criterion,
            "value": finite_or_none(self.value),
            "rho0": self.rho0,
            "rho0_per_test_pose": None if self.rho0_each is None else self.rho0_each.tolist(),
            "sigma": self.sigma,
            "method": self.method,
            "starts": self.starts,
            "dropped_starts": self.dropped,
            "starts_matched": self.matched,
            "starts_adaptive": self.adaptive,
            "continued": self.continued,
            "seed": self.seed,
            "time_s": self.time_s,
            "pool_size": self.pool_size,
            "pool_rejected": self.pool_rejected,
            "conditioning": self.conditioning,
            "message": self.message,
            "prior": None if self.prior is None else self.prior.as_dict(),
            **self._instrument_dict(),
            "history": [h.as_dict() for h in self.history],
        }

    def _instrument_dict(self) -> dict:
        """The instrument and the orientation length, when the design had them."""
        out: dict = {}
        if self.instrument is not None:
            out["instrument"] = self.instrument.as_dict()
        if self.orientation_length is not None:
            out["orientation_length"] = self.orientation_length
        if self.instrument_at is not None:
            out["instrument_at"] = list(self.instrument_at)
        return out


@dataclass(frozen=True)
class RandomPlans:
    """The distribution of a criterion over random feasible plans (the baseline).

    Attributes:
        criterion: the criterion (``test-pose`` or ``test-pose-worst``: ρ0 [m]).
        m: configurations per plan.
        n: plans drawn.
        n_singular: plans with a singular information matrix (no finite value).
        values: (n − n_singular,) the finite values, in draw order, read-only.
        sigma: measurement noise per coordinate [m].
    """

    criterion: str
    m: int
    n: int
    n_singular: int
    values: np.ndarray
    sigma: float

    @property
    def min(self) -> float:
        return float(self.values.min()) if len(self.values) else math.nan

    @property
    def mean(self) -> float:
        return float(self.values.mean()) if len(self.values) else math.nan

    @property
    def median(self) -> float:
        return float(np.median(self.values)) if len(self.values) else math.nan

    @property
    def max(self) -> float:
        return float(self.values.max()) if len(self.values) else math.nan

    def as_dict(self) -> dict:
        """``{min, mean, median, max, n, n_singular, m, criterion, sigma}`` (NaN as None)."""
        return {
            "min": finite_or_none(self.min),
            "mean": finite_or_none(self.mean),
            "median": finite_or_none(self.median),
            "max": finite_or_none(self.max),
            "n": self.n,
            "n_singular": self.n_singular,
            "m": self.m,
            "criterion": self.criterion,
            "sigma": self.sigma,
        }


def dropped_line(dropped: int, starts: int) -> str:
    """What a design says of its dropped starts: ``"2 of 8 starts were degenerate and dropped"``."""
    return f"{dropped} of {starts} starts were degenerate and dropped"


def finite_or_none(v: float | None) -> float | None:
    """A finite value as a Python float; NaN, ±inf and None as None (JSON has no inf)."""
    return float(v) if v is not None and np.isfinite(v) else None
