"""The starts of a design: each a random regular plan of pool configurations, from its own child
seed, so that the same seed gives the same starts whatever runs them (the parent or a worker)."""

from __future__ import annotations

import numpy as np

from pincal.errors import FloorUnreachable, Infeasible, SingularPlan
from pincal.evaluation.d_optimal import DOptimal
from pincal.evaluation.information import conditioning, factor, jacobi_scaled, rank
from pincal.planning.exchange import ExchangeOutcome, fedorov


def start_seed(entropy: int, start: int) -> np.random.SeedSequence:
    """The seed of start ``start``: the child (1, start) of the design's seed sequence (what
    ``SeedSequence(seed).spawn`` hands out, without mutating a shared sequence)."""
    return np.random.SeedSequence(entropy, spawn_key=(1, start))


def draw_start(
    J: np.ndarray,
    pool: np.ndarray,
    m: int,
    spacing: float,
    seed: np.random.SeedSequence,
    floor: float,
    prior: np.ndarray | None = None,
    exchanged: dict | None = None,
) -> np.ndarray:
    """The pool indices of one start's plan (see :func:`pick`), from its seed."""
    return pick(J, pool, m, spacing, np.random.default_rng(seed), floor, prior, exchanged)


def exchange_of(index: np.ndarray, exchanged: dict) -> ExchangeOutcome | None:
    """The D-optimal exchange (no prior, no floor) kept in ``exchanged`` by :func:`pick` whose end
    the plan ``index`` is, or None (a random plan)."""
    for out in exchanged.values():
        if np.array_equal(out.index, index):
            return out
    return None


TRIES = 100
"""Random plans a start tries before the D-optimal exchange takes over."""

BATCH = 10
"""Random plans whose conditioning is computed at once (one stacked eigenvalue call)."""


def pick(
    J: np.ndarray,
    pool: np.ndarray,
    m: int,
    spacing: float,
    rng: np.random.Generator,
    floor: float,
    prior: np.ndarray | None = None,
    exchanged: dict | None = None,
) -> np.ndarray:
    """Indices of m pool configurations forming a regular plan (conditioning above ``floor``, spaced),
    at random. With no floor (a prior), any plan whose posterior information is regular.

    When no random plan reaches twice the floor, a D-optimal exchange from a random regular one
    does (it spreads the information over every parameter): a floor that a D-optimal plan meets
    is never refused. ``exchanged`` (a dict, for the same ``J``, ``pool`` and ``spacing``) keeps
    each such exchange by the plan it started from: drawn again under another floor, the same
    start does not search again.

    The random plans are tried in order, :data:`BATCH` at a time: their conditionings in one
    stacked call, the Cholesky test of regularity only where its answer decides (the first
    regular plan, and a plan above twice the floor); the same plan as trying them one by one.
    """
    N, rows, P = J.shape
    regular = None  # a regular random plan below the floor, to start the D-optimal exchange from
    tried = []  # the information matrices tried, for the rank in the error when none is regular
    for begin in range(0, TRIES, BATCH):
        indices, failure = [], None
        for _ in range(begin, min(begin + BATCH, TRIES)):
            try:
                indices.append(_random_plan(rng, pool, m, spacing))
            except Infeasible as error:  # raised once the plans drawn before it are tried
                failure = error
                break
        Ms = []
        for index in indices:
            stacked = J[index].reshape(-1, P)
            Ms.append(stacked.T @ stacked)
        tried += Ms
        if floor <= 0:
            for index, M in zip(indices, Ms, strict=True):
                if _regular(M if prior is None else M + prior, rows, m):
                    return index
        elif Ms:
            conds = np.linalg.eigvalsh(jacobi_scaled(np.array(Ms))[1])[:, 0]
            for index, M, cond in zip(indices, Ms, conds, strict=True):
                if (regular is None or cond > 2 * floor) and _regular(M, rows, m):
                    if cond > 2 * floor:
                        return index
                    regular = index if regular is None else regular
        if failure is not None:
            raise failure
    if regular is not None:
        key = tuple(int(i) for i in regular)
        out = None if exchanged is None else exchanged.get(key)
        if out is None:
            out = fedorov(DOptimal(rows), J, pool, regular, spacing)
            if exchanged is not None:
                exchanged[key] = out
        stacked = J[out.index].reshape(-1, P)
        reached = conditioning(stacked.T @ stacked)
        if reached > floor:
            return out.index
        raise FloorUnreachable(m, floor, reached)
    raise SingularPlan(P, rows, m, max(rank(M) for M in tried))


def _random_plan(rng: np.random.Generator, pool: np.ndarray, m: int, spacing: float) -> np.ndarray:
    """m pool indices at random, each at least ``spacing`` from the others (raises Infeasible)."""
    N = len(pool)
    order = rng.permutation(N)
    if spacing <= 0:
        return order[:m]
    chosen: list[int] = []
    for c in order:
        if all(np.linalg.norm(pool[c] - pool[k]) >= spacing for k in chosen):
            chosen.append(int(c))
            if len(chosen) == m:
                break
    if len(chosen) < m:
        raise Infeasible(
            f"cannot place {m} configurations at least {spacing:.4g} rad apart among the "
            f"{N} feasible candidates; lower min_spacing"
        )
    return np.array(chosen)


def _regular(M: np.ndarray, rows: int, m: int) -> bool:
    """M passes the singularity test of :func:`~pincal.evaluation.information.factor`."""
    try:
        factor(M, rows, m)
    except SingularPlan:
        return False
    return True
