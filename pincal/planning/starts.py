"""The starts of a design: each a random regular plan of pool configurations, from its own child
seed, so that the same seed gives the same starts whatever runs them (the parent or a worker)."""

from __future__ import annotations

import numpy as np

from pincal.errors import FloorUnreachable, Infeasible, SingularPlan
from pincal.evaluation.d_optimal import DOptimal
from pincal.evaluation.information import conditioning, factor, rank
from pincal.planning.exchange import fedorov


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
) -> np.ndarray:
    """The pool indices of one start's plan (see :func:`pick`), from its seed."""
    return pick(J, pool, m, spacing, np.random.default_rng(seed), floor, prior)


def pick(
    J: np.ndarray,
    pool: np.ndarray,
    m: int,
    spacing: float,
    rng: np.random.Generator,
    floor: float,
    prior: np.ndarray | None = None,
) -> np.ndarray:
    """Indices of m pool configurations forming a regular plan (conditioning above ``floor``, spaced),
    at random. With no floor (a prior), any plan whose posterior information is regular.

    When no random plan reaches twice the floor, a D-optimal exchange from a random regular one
    does (it spreads the information over every parameter): a floor that a D-optimal plan meets
    is never refused.
    """
    N, rows, P = J.shape
    best_rank = 0
    regular = None  # a regular random plan below the floor, to start the D-optimal exchange from
    for _ in range(100):
        order = rng.permutation(N)
        if spacing > 0:
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
            index = np.array(chosen)
        else:
            index = order[:m]
        stacked = J[index].reshape(-1, P)
        M = stacked.T @ stacked
        try:
            if floor <= 0:
                factor(M if prior is None else M + prior, rows, m)
                return index
            factor(M, rows, m)
            if conditioning(M) > 2 * floor:
                return index
            regular = index if regular is None else regular
        except SingularPlan:
            pass
        best_rank = max(best_rank, rank(M))
    if regular is not None:
        out = fedorov(DOptimal(rows), J, pool, regular, spacing)
        stacked = J[out.index].reshape(-1, P)
        reached = conditioning(stacked.T @ stacked)
        if reached > floor:
            return out.index
        raise FloorUnreachable(m, floor, reached)
    raise SingularPlan(P, rows, m, best_rank)
