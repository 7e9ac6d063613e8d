"""The values passed between the stages of :func:`pincal.planning.driver.design`: :class:`Settings`
(the checked arguments), :class:`Pool` (the candidates the starts come from: configurations, each
with its payload) and :class:`Outcome` (the end of one start). They are frozen; each stage returns
new ones.

Every design is one pipeline (validate, pool, search, choose, report); its options change what a
stage does, never which pipeline runs. A plan that chooses a payload per configuration searches a
pool of (configuration, payload) candidates; without payloads every candidate carries none (0 kg),
and a residual model is one more criterion
(:class:`~pincal.evaluation.residual_criterion.ResidualCriterion`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.errors import FloorUnreachable, Infeasible, PincalError, SingularPlan
from pincal.evaluation.prior import Prior
from pincal.instruments.instrument import Instrument
from pincal.model.residual import ResidualModel
from pincal.planning.constraints import AnyConstraint
from pincal.planning.feasibility import Feasibility
from pincal.planning.results import StartRecord

D_OPTIMAL = "D"
"""The criterion of the D-optimal design searched with another (``with_d_optimal``)."""


@dataclass(frozen=True)
class Settings:
    """The checked arguments of one design (canonical names, Python numbers)."""

    criterion: str
    method: str
    m: int
    test_poses: np.ndarray | None
    instrument: Instrument  # what is measured and how well (sigma= is turned into one at the door)
    starts: int  # the starts, or with ``adaptive`` those of one batch
    workers: int
    keep: float
    screen_iterations: int
    maxiter: int
    floor: float
    constraints: tuple[AnyConstraint, ...]
    feasibility: Feasibility
    user_pool: bool
    polish: bool
    entropy: int
    prior: Prior | None = None
    prior_information: np.ndarray | None = None  # Λ = σ²Σp⁻¹, added to M by every criterion
    plain: bool = True  # points with one σ: their own Jacobian rows, exactly as before instruments
    orientation_length: float | None = None  # [m]: ρ0 counts the tool's orientation error too
    adaptive: bool = False  # batches of ``starts`` until they agree (pincal.planning.stopping)
    loads: np.ndarray | None = None  # (n, 4) payload rows each configuration chooses among; None: none
    task_payload: np.ndarray | None = None  # (k, 4) payload rows at the test poses (with ``loads``)
    residual_model: ResidualModel | None = None  # the criterion is then tr Σ₀ with it

    @property
    def sigma(self) -> float:
        """The instrument's reference σ [m] (the criteria's scale)."""
        return self.instrument.reference

    @property
    def measured(self) -> Instrument | None:
        """The instrument whose rows the criteria take, or None: the points' own rows (``plain``)."""
        return None if self.plain else self.instrument

    @property
    def loaded(self) -> bool:
        """Each candidate carries a payload (the plan chooses them, or a residual model scores them)."""
        return self.loads is not None

    def seed_sequence(self, *key: int) -> np.random.SeedSequence:
        """The child ``key`` of the design's seed sequence: (0,) draws the pool, (1, i) start i
        (what ``SeedSequence(seed).spawn`` hands out, without mutating a shared sequence)."""
        return np.random.SeedSequence(self.entropy, spawn_key=key)


@dataclass(frozen=True)
class Pool:
    """Where the starts come from: the candidates and the user's init plans.

    Attributes:
        candidates: (N, nq) the candidates' configurations.
        rejected: the user's configurations left out as infeasible.
        init: the user's init plans (continuous method).
        payload: (N, 4) each candidate's payload rows [kg, x, y, z] (every configuration paired
            with every payload the plan may choose), or None: no payload (0 kg).
    """

    candidates: np.ndarray
    rejected: int
    init: tuple[np.ndarray, ...]
    payload: np.ndarray | None = None

    def n_starts(self, settings: Settings) -> int:
        """The init plans first, then the drawn starts (of the first batch, when adaptive)."""
        return len(self.init) + settings.starts

    def n_keep(self, settings: Settings, n: int | None = None) -> int:
        """Of ``n`` starts (default :meth:`n_starts`), those run to convergence after screening
        (continuous), or polished (exchange)."""
        n = self.n_starts(settings) if n is None else n
        return n if settings.keep >= 1 else max(1, math.ceil(settings.keep * n))


@dataclass(frozen=True)
class Outcome:
    """The end of one start.

    Attributes:
        record: what the start did (reported in the history).
        q: (m, nq) its final plan; None if it was dropped after screening, or degenerate.
        F: the objective at q (exact).
        usable: q satisfies every constraint.
        dropped: the start failed alone (:func:`degenerate`) and was dropped.
        payload: (m, 4) the payload of each configuration of q, or None (none).
    """

    record: StartRecord
    q: np.ndarray | None
    F: float
    usable: bool
    dropped: bool = False
    payload: np.ndarray | None = None

    @classmethod
    def degenerate(cls, start: int, error: PincalError) -> Outcome:
        """The outcome of start ``start``, dropped for ``error``."""
        message = f"degenerate, dropped: {error}"
        return cls(
            StartRecord(start, math.inf, None, 0, 0.0, False, False, message), None, math.inf, False, True
        )


Drawn = np.ndarray | PincalError
"""A start's plan (its pool indices), or the error it failed with alone (:func:`degenerate`)."""


def degenerate(error: BaseException) -> bool:
    """``error`` ends one start and not the design: none of the start's random plans was regular
    (SingularPlan), or none could be spaced (Infeasible). The other starts draw other plans; the
    design fails only when every start does. A floor no plan reaches (FloorUnreachable) is the
    design's: its floor adapts, or it fails."""
    return isinstance(error, (SingularPlan, Infeasible)) and not isinstance(error, FloorUnreachable)


def dropped_count(outcomes: tuple[Outcome, ...]) -> int:
    """The starts dropped as degenerate."""
    return sum(o.dropped for o in outcomes)


def every_start_failed(errors: list[PincalError], n: int) -> PincalError:
    """The first start's error, saying that all ``n`` starts failed so."""
    error = errors[0]
    error.args = (f"all {n} starts were degenerate (the first: {error})",) + error.args[1:]
    return error
