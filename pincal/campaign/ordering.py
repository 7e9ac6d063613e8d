"""The order of a campaign: the tour from home through every measurement pose and back that takes
the least time (docs/method.md §12.2).

It is a travelling-salesman tour over the move-time matrix (node 0: home). Up to
:data:`EXACT_LIMIT` poses it is solved exactly by dynamic programming over subsets (Held & Karp
1962, O(n² 2ⁿ)); beyond, by the classic local searches — a nearest-neighbour tour, from home and
from the given order, improved by 2-opt (reverse a stretch) and Or-opt (move a run of one to three
poses elsewhere) until no move shortens it (Lin 1965, Or 1976) — which end within a few percent of
the optimum on such instances. The move times of synchronised joints, maxⱼ tⱼ(|Δqⱼ|), are a
metric, so a tour can be reversed and its length is the same either way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

EXACT_LIMIT = 12
"""Tours of up to this many poses are solved exactly (Held–Karp; 12 poses: 50 ms)."""


@dataclass(frozen=True)
class Tour:
    """A tour from home (node 0) through nodes 1..n and back.

    Attributes:
        order: the nodes 1..n in visiting order.
        cost: the tour's total move cost (home to the first node, ..., the last node to home).
        exact: the optimum (Held–Karp), else a local optimum of 2-opt and Or-opt.
    """

    order: tuple[int, ...]
    cost: float
    exact: bool


def tour_cost(cost: np.ndarray, order: tuple[int, ...] | list[int] | np.ndarray) -> float:
    """Total cost of the closed tour 0 → order → 0."""
    path = [0, *order, 0]
    return float(sum(cost[a, b] for a, b in zip(path[:-1], path[1:], strict=True)))


def held_karp(cost: np.ndarray) -> Tour:
    """The optimal tour over ``cost`` ((n+1, n+1), node 0 home), by dynamic programming over the
    subsets of nodes 1..n: best[S, j] = the cheapest path from home through the set S ending at j."""
    n = len(cost) - 1
    if n == 0:
        return Tour((), 0.0, True)
    c = np.asarray(cost, dtype=float)[1:, 1:]
    size = 1 << n
    best = np.full((size, n), np.inf)
    parent = np.full((size, n), -1, dtype=np.int64)
    for j in range(n):
        best[1 << j, j] = cost[0, j + 1]
    subsets = np.arange(size)
    popcount = np.array([bin(S).count("1") for S in range(size)])
    for layer in range(2, n + 1):
        in_layer = subsets[popcount == layer]
        for j in range(n):
            S = in_layer[(in_layer >> j) & 1 == 1]
            # best path through S ending at j: through S \ {j} ending at some k, then k → j (best
            # is inf where k is not in S \ {j}).
            values = best[S & ~(1 << j)] + c[:, j]
            pick = np.argmin(values, axis=1)
            best[S, j] = values[np.arange(len(S)), pick]
            parent[S, j] = pick
    full = size - 1
    closing = best[full] + np.asarray(cost, dtype=float)[1:, 0]
    j = int(np.argmin(closing))
    order = []
    S = full
    while j >= 0:
        order.append(j + 1)
        S, j = S & ~(1 << j), int(parent[S, j])
    order.reverse()
    return Tour(tuple(order), float(closing.min()), True)


def _nearest_neighbour(cost: np.ndarray) -> list[int]:
    n = len(cost) - 1
    left = set(range(1, n + 1))
    at, order = 0, []
    while left:
        nxt = min(left, key=lambda k: (cost[at, k], k))
        order.append(nxt)
        left.remove(nxt)
        at = nxt
    return order


def improve(cost: np.ndarray, order: list[int]) -> list[int]:
    """A local optimum of 2-opt and Or-opt from ``order`` (see the module doc)."""
    cost = np.asarray(cost, dtype=float)
    path = [0, *order, 0]
    improved = True
    while improved:
        improved = False
        # 2-opt: reverse path[i..k] when c(a,b) + c(c,d) > c(a,c) + c(b,d).
        for i in range(1, len(path) - 2):
            a, b = path[i - 1], path[i]
            ks = np.arange(i + 1, len(path) - 1)
            cs, ds = np.array(path)[ks], np.array(path)[ks + 1]
            gain = cost[a, b] + cost[cs, ds] - cost[a, cs] - cost[b, ds]
            k = int(np.argmax(gain))
            if gain[k] > 1e-12:
                k = int(ks[k])
                path[i : k + 1] = path[i : k + 1][::-1]
                improved = True
        # Or-opt: move a run of 1 to 3 nodes (either way round) between two other neighbours.
        for length in (1, 2, 3):
            i = 1
            while i + length <= len(path) - 1:
                run = path[i : i + length]
                before, after = path[i - 1], path[i + length]
                removed = cost[before, run[0]] + cost[run[-1], after] - cost[before, after]
                rest = path[:i] + path[i + length :]
                best_gain, best_at, best_run = 1e-12, -1, run
                for at in range(len(rest) - 1):
                    x, y = rest[at], rest[at + 1]
                    for r in (run, run[::-1]):
                        gain = removed - (cost[x, r[0]] + cost[r[-1], y] - cost[x, y])
                        if gain > best_gain:
                            best_gain, best_at, best_run = gain, at, r
                if best_at >= 0:
                    path = rest[: best_at + 1] + list(best_run) + rest[best_at + 1 :]
                    improved = True
                i += 1
    return path[1:-1]


def best_tour(cost: np.ndarray, given: list[int] | None = None) -> Tour:
    """The best tour over ``cost`` ((n+1, n+1), node 0 home): exact up to :data:`EXACT_LIMIT` nodes,
    else the better of the local searches from a nearest-neighbour tour and from ``given``."""
    cost = np.asarray(cost, dtype=float)
    n = len(cost) - 1
    if n <= EXACT_LIMIT:
        return held_karp(cost)
    starts = [_nearest_neighbour(cost), list(given) if given is not None else list(range(1, n + 1))]
    tours = [improve(cost, s) for s in starts]
    order = min(tours, key=lambda t: tour_cost(cost, t))
    return Tour(tuple(order), tour_cost(cost, order), False)
