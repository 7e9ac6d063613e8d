"""Exchange search: the best m configurations of a pool of feasible candidates (Fedorov-style).

Starting from m pool configurations, each configuration of the plan in turn is exchanged for the
pool candidate that improves the criterion most, until no exchange improves it: the search stops
when every other configuration has been tried since the last exchange (the one exchanged last
already is the best of its candidates for the others as they are). The criterion
scores every candidate swap at once through its exchange state
(:meth:`pincal.evaluation.criterion.Criterion.exchange`: low-rank updates of the inverse
information matrix for the information criteria, see :mod:`pincal.evaluation.low_rank`); the
state of the plan is recomputed exactly after every exchange, so rounding never drifts. Candidates already in
the plan, or closer than the minimum spacing to another configuration of it, are not considered,
nor an exchange that would take the plan's conditioning (see
:func:`pincal.evaluation.information.conditioning`) below the floor.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pincal.evaluation.criterion import Criterion
from pincal.evaluation.information import conditioning
from pincal.lapack import potrf

TOLERANCE = 1e-10
"""An exchange must lower the objective F (a log) by more than this."""

MAX_SWEEPS = 100
"""Passes over the plan a search is allowed (it stops earlier once no exchange improves)."""


@dataclass(frozen=True)
class ExchangeOutcome:
    """The end of one start of the exchange search.

    Attributes:
        index: (m,) pool indices of the plan.
        F: objective value (exact).
        sweeps: passes over the plan.
        swaps: exchanges made.
        time_s: wall time [s].
    """

    index: np.ndarray
    F: float
    sweeps: int
    swaps: int
    time_s: float

    @property
    def converged(self) -> bool:
        """No exchange improves the plan (the search stopped before :data:`MAX_SWEEPS`): searched
        again with the same criterion, under any floor it satisfies, it stays as it is."""
        return self.sweeps < MAX_SWEEPS

    def confirmed(self) -> ExchangeOutcome:
        """What the search started again from this converged plan returns: the same plan and
        value after one pass without an exchange."""
        return ExchangeOutcome(self.index, self.F, 1, 0, 0.0)


def _best_regular(values, F, cand, M, J_pool, Ji, floor, tries: int = 32) -> int | None:
    """Index (into ``values``) of the best improving exchange that keeps the conditioning above
    ``floor``; None if there is none among the ``tries`` best."""
    improving = np.flatnonzero(values < F - TOLERANCE)
    if not len(improving):
        return None

    def regular(k) -> bool:
        Jc = J_pool[cand[k]]
        return floor <= 0 or _above(M + Jc.T @ Jc - Ji.T @ Ji, floor)

    first = int(improving[np.argmin(values[improving])])  # the stable order's first: most often the one
    if regular(first):
        return first
    order = improving[np.argsort(values[improving], kind="stable")][1:tries]
    return next((int(k) for k in order if regular(k)), None)


def _above(M: np.ndarray, floor: float) -> bool:
    """conditioning(M) > floor, decided as :func:`~pincal.evaluation.information.conditioning`
    decides it, mostly without the eigenvalues. With S the Jacobi-scaled M (unit diagonal), a
    Cholesky factor of S − (1 + 1e-4)·floor·I proves λ_min(S) > floor, and a failed one of
    S − (1 − 1e-4)·floor·I proves λ_min(S) < floor: the factorisation's rounding and the
    eigenvalues' are below P²·1e-16 (≈ 1e-13 for 27 parameters, 1e-11 for 300), far inside the
    margin 1e-4·floor for floors from 1e-6 (the searches use 1e-6 and more). Between the two, or for
    smaller floors, the smallest eigenvalue decides."""
    d = np.sqrt(np.abs(M.diagonal()))
    if floor >= 1e-6 and d.min() > 0:
        S = M / np.outer(d, d)
        diagonal = np.einsum("ii->i", S)
        diagonal -= (1.0 + 1e-4) * floor
        if potrf(S)[1] == 0:
            return True
        diagonal += 2e-4 * floor
        if potrf(S)[1] != 0:
            return False
    return conditioning(M) > floor


class _Crowding:
    """Which candidates are closer than the minimum spacing to which configuration of the plan:
    ``close`` (N, m), and ``crowd`` (N,) how many of the plan's configurations each is close to.
    A candidate may replace configuration i when it is close to none of the others, crowd =
    close[:, i]: two vector operations per exchange instead of the distances to the m − 1 others."""

    def __init__(self, pool: np.ndarray, index: np.ndarray, spacing: float) -> None:
        self.pool, self.spacing = pool, spacing
        self.close = np.linalg.norm(pool[:, None, :] - pool[index][None], axis=2) < spacing
        self.crowd = self.close.sum(axis=1)

    def far(self, i: int) -> np.ndarray:
        """(N,) the candidates at least the spacing from every configuration of the plan but i."""
        return self.crowd == self.close[:, i]

    def moved(self, i: int, c: int) -> None:
        """Configuration i of the plan is now candidate c."""
        close = np.linalg.norm(self.pool - self.pool[c], axis=1) < self.spacing
        self.crowd += close.astype(np.int64) - self.close[:, i]
        self.close[:, i] = close


def fedorov(
    objective: Criterion,
    J_pool: np.ndarray,
    pool: np.ndarray,
    index: np.ndarray,
    spacing: float = 0.0,
    floor: float = 0.0,
    max_sweeps: int = MAX_SWEEPS,
) -> ExchangeOutcome:
    """Exchange search from the plan ``pool[index]``.

    Args:
        objective: the criterion.
        J_pool: (N, 3K, P) tip-frame Jacobians of the pool.
        pool: (N, nq) the candidate configurations.
        index: (m,) pool indices of the starting plan (its M must be regular).
        spacing: minimum joint-space distance between configurations of the plan [rad].
        floor: smallest conditioning an exchange may leave the plan with.
        max_sweeps: passes over the plan allowed.
    """
    t0 = time.perf_counter()
    N = len(J_pool)
    state = objective.exchange(J_pool, np.array(index))
    m = len(state.index)
    used = np.zeros(N, dtype=bool)
    used[state.index] = True
    crowding = _Crowding(pool, state.index, spacing) if spacing > 0 else None
    sweeps = swaps = 0
    last = None  # the configuration exchanged last
    while sweeps < max_sweeps:
        sweeps += 1
        for i in range(m):
            if i == last:  # every other configuration tried since, none improved: converged
                break
            allowed = ~used if crowding is None else ~used & crowding.far(i)
            cand, values = state.scores(i, allowed)
            if not len(cand):
                continue
            out = int(state.index[i])
            best = _best_regular(values, state.F, cand, state.M, J_pool, J_pool[out], floor)
            if best is None:
                continue
            c = int(cand[best])
            state.swap(i, best)
            used[out] = False
            used[c] = True
            if crowding is not None:
                crowding.moved(i, c)
            swaps += 1
            last = i
        else:
            state.resync()
            if last is None:  # a whole sweep without an exchange
                break
            continue
        break
    state.resync()
    return ExchangeOutcome(state.index, state.F, sweeps, swaps, time.perf_counter() - t0)
