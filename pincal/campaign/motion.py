r"""Moves certified collision-free, with a stated bound rather than a number of samples
(docs/method.md §12.3).

A move from a to b runs the joints along the straight segment q(s) = a + s(b − a), s ∈ [0, 1]. For
every pair the collision world checks (the robot against itself, the cell's obstacles and the
floor: :class:`~pincal.model.collision.CollisionWorld`), no point of the
pair's moving shape travels farther, relative to the other shape, than λ = Σⱼ wⱼ |Δqⱼ| over a
stretch of the segment where the joints move by Δq (w: the world's motion weights). So if the
pair is η(s₀) apart at s₀ and η(s₁) apart at s₁, everywhere between them it is at least

    (η(s₀) + η(s₁) − λ(s₀, s₁)) / 2

apart (Schwarzer, Saha & Latombe, IEEE T-RO 2005): a stretch where this bound is at least the
clearance asked is clear — certified, not sampled — and only the stretches where it is not are
bisected, until every stretch is certified, or a configuration closer than the clearance is found
(the move collides there), or :data:`MAX_EVALUATIONS` distance evaluations did not settle it.
:func:`certify_move` reports the certified bound (the smallest distance anywhere on the move is at
least this), the smallest distance at the configurations evaluated, and the pair.

A move that is not clear gets a detour (:func:`find_detour`): an intermediate configuration c,
drawn around the segment farther and farther out, that is itself clear and from which both a → c
and c → b are certified; the quickest one found is kept.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.model.collision import CollisionWorld, with_exact

MAX_EVALUATIONS = 1000
"""Distance evaluations one move may use before it is declared not certified."""

DETOUR_EVALUATIONS = 2000
"""Distance evaluations the search for one detour may use in all (candidates and their moves)."""

DETOUR_TRIES = 24
"""Candidate intermediate configurations tried at each detour distance."""

DETOUR_SCALES = (0.05, 0.1, 0.2, 0.35, 0.5)
"""How far detour candidates are drawn from the segment, as fractions of each joint's range."""


class Carrying:
    """A collision world whose robot carries one of a few payloads, which one not known (a move
    between two poses of a plan that mounts payloads: the payload is changed at one of them): each
    pair's distance is the smallest over the payloads, and its motion weights bound the change of
    every one (:meth:`~pincal.model.collision.CollisionWorld.weights_under` the payloads), so of
    their minimum too. It reads as the world for :func:`certify_move` and :func:`find_detour`.

    Args:
        world: the collision world.
        rows: (r, 4) the payloads [kg, x, y, z] (a row of zeros: none).
    """

    def __init__(self, world: CollisionWorld, rows: np.ndarray) -> None:
        self.world, self.rows = world, np.asarray(rows, dtype=float).reshape(-1, 4)
        self.size, self.names, self.n_points = world.size, world.names, world.n_points
        self.refinable = world.refinable
        self.weights = world.weights_under(self.rows)

    def distances(self, q: np.ndarray, refine: bool = True) -> np.ndarray:
        """(size,) the smallest distance of each pair over the payloads [m] at the reading ``q``."""
        return np.min([self.world.distances(q, refine, row[None]) for row in self.rows], axis=0)

    def exact_distances(self, q: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        """The smallest over the payloads of :meth:`CollisionWorld.exact_distances`."""
        return np.min([self.world.exact_distances(q, pairs, row[None]) for row in self.rows], axis=0)


@dataclass(frozen=True)
class MoveCheck:
    """The clearance of one straight joint-space move.

    Attributes:
        clear: every pair keeps its clearance along the whole move (certified).
        certified: a lower bound of the smallest distance anywhere on the move [m] (inf with no
            pair to check); at least the clearance when ``clear``.
        sampled: the smallest distance at the configurations evaluated [m].
        closest: the pair of ``sampled`` (``link_4 (capsule) / table``).
        evaluations: configurations at which the distances were computed.
        blocked: why the move is not clear (the pair found too close, and where), or "".
        at: where along the move (0 to 1) the blocking configuration is, or None.
    """

    clear: bool
    certified: float
    sampled: float
    closest: str
    evaluations: int
    blocked: str = ""
    at: float | None = None

    def as_dict(self) -> dict:
        finite = np.isfinite
        return {
            "clear": self.clear,
            "certified": float(self.certified) if finite(self.certified) else None,
            "sampled": float(self.sampled) if finite(self.sampled) else None,
            "closest": self.closest,
            "evaluations": self.evaluations,
            "blocked": self.blocked,
            "at": self.at,
        }


def certify_move(
    world: CollisionWorld | Carrying,
    a: np.ndarray,
    b: np.ndarray,
    required: np.ndarray | float = 0.0,
    ends: tuple[np.ndarray, np.ndarray] | None = None,
    max_evaluations: int = MAX_EVALUATIONS,
) -> MoveCheck:
    """Certify the straight move from ``a`` to ``b`` (see the module doc).

    The distances at the configurations visited are the convex hulls' (fast lower bounds); a pair
    of meshes whose hulls do not clear a stretch is measured again on the meshes at its ends before
    the stretch is bisected or declared blocked.

    Args:
        world: the collision world (or the world under the payloads the move may carry, :class:`Carrying`).
        a, b: (nq,) the move's ends [rad or m].
        required: the clearance each pair must keep [m] (one for all, or (world.size,)).
        ends: the distances at ``a`` and ``b`` (:meth:`CollisionWorld.distances`), when known.
        max_evaluations: distance evaluations allowed (configurations visited).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if world.size == 0:
        return MoveCheck(True, np.inf, np.inf, "", 0)
    need = np.broadcast_to(np.asarray(required, dtype=float), (world.size,))
    span = world.weights @ np.abs(b - a)  # λ over the whole move, per pair
    refinable = np.concatenate([world.refinable, np.zeros(world.n_points, dtype=bool)])
    move = _Samples(world, a, b, refinable)
    at, refine = move.at, move.refine
    if ends is not None:
        move.samples[0.0] = (np.array(ends[0], dtype=float), np.ones(world.size, dtype=bool))
        move.samples[1.0] = (np.array(ends[1], dtype=float), np.ones(world.size, dtype=bool))
    certified = np.inf
    stack = [(0.0, 1.0)]
    blocked, where = "", None
    while stack and not blocked:
        s0, s1 = stack.pop()
        for s in (s0, s1):
            e = at(s)
            short = np.flatnonzero(e < need - 1e-12)
            if len(short):
                refine(s, short)
                if np.any(e < need - 1e-12):
                    k = int(np.argmax(need - e))
                    blocked = f"{world.names[k]}: {e[k] * 1e3:.3g} mm apart (keeps {need[k] * 1e3:.3g} mm)"
                    where = s
                    break
        if blocked:
            break
        e0, e1 = at(s0), at(s1)
        lower = 0.5 * (e0 + e1 - span * (s1 - s0))
        failing = np.flatnonzero(lower < need)
        if len(failing) and refinable[failing].any():
            refine(s0, failing)
            refine(s1, failing)
            lower = 0.5 * (e0 + e1 - span * (s1 - s0))
            failing = np.flatnonzero(lower < need)
        if not len(failing):
            certified = min(certified, float(lower.min()))
            continue
        if move.evaluations >= max_evaluations:
            k = int(failing[np.argmin((lower - need)[failing])])
            blocked = (
                f"{world.names[k]}: not certified within {max_evaluations} distance evaluations "
                f"(it comes within {max(lower[k], 0) * 1e3:.3g} mm of the clearance)"
            )
            where = 0.5 * (s0 + s1)
            break
        mid = 0.5 * (s0 + s1)
        stack.append((mid, s1))  # the first half is checked first (popped next)
        stack.append((s0, mid))
    sampled = np.min([e for e, _ in move.samples.values()], axis=0)
    k = int(np.argmin(sampled))
    return MoveCheck(
        not blocked,
        certified if not blocked else float(sampled.min()),
        float(sampled[k]),
        world.names[k],
        move.evaluations,
        blocked,
        where,
    )


class _Samples:
    """The distances of a straight move's configurations visited, by s in [0, 1], and the
    distance evaluations spent on them (a convex hulls' evaluation, or a meshes' one, counts one)."""

    def __init__(self, world: CollisionWorld | Carrying, a: np.ndarray, b: np.ndarray, refinable: np.ndarray):
        self.world, self.a, self.b, self.refinable = world, a, b, refinable
        self.samples: dict[
            float, tuple[np.ndarray, np.ndarray]
        ] = {}  # s -> (distances, measured on the meshes)
        self.evaluations = 0

    def at(self, s: float) -> np.ndarray:
        """The distances at s (the hulls' unless refined)."""
        if s not in self.samples:
            q = self.a + s * (self.b - self.a)
            self.samples[s] = (self.world.distances(q, refine=False), ~self.refinable)
            self.evaluations += 1
        return self.samples[s][0]

    def refine(self, s: float, pairs: np.ndarray) -> None:
        """The distances of ``pairs`` at s measured on the meshes (in place)."""
        e, exact = self.samples[s]
        todo = pairs[~exact[pairs]]
        if len(todo):
            e[todo] = with_exact(e[todo], self.world.exact_distances(self.a + s * (self.b - self.a), todo))
            exact[todo] = True
            self.evaluations += 1  # the meshes' distances, counted as one more evaluation


@dataclass(frozen=True)
class Detour:
    """A move split in two by an intermediate configuration.

    Attributes:
        via: (nq,) the intermediate configuration [rad or m].
        first, second: the checks of the two moves (both clear).
    """

    via: np.ndarray
    first: MoveCheck
    second: MoveCheck


def find_detour(
    world: CollisionWorld | Carrying,
    a: np.ndarray,
    b: np.ndarray,
    required: np.ndarray | float,
    lower: np.ndarray,
    upper: np.ndarray,
    move_time,
    rng: np.random.Generator,
    extra: tuple[np.ndarray, ...] = (),
) -> Detour | None:
    """The quickest detour found from ``a`` to ``b`` through one clear intermediate configuration.

    Candidates are ``extra`` (e.g. the home configuration) and configurations drawn around the
    segment, :data:`DETOUR_TRIES` at each distance of :data:`DETOUR_SCALES` (a fraction of each
    joint's range in [lower, upper]); the first distance with a clear detour ends the search, and
    the quickest of its detours (by ``move_time(a, c) + move_time(c, b)``) is returned, or None
    (also when :data:`DETOUR_EVALUATIONS` distance evaluations did not find one).
    """
    need = np.broadcast_to(np.asarray(required, dtype=float), (world.size,))
    ends = world.distances(a), world.distances(b)
    span = upper - lower
    budget = [DETOUR_EVALUATIONS]

    def attempt(candidates: list[np.ndarray]) -> Detour | None:
        for c in sorted(candidates, key=lambda c: move_time(a, c) + move_time(c, b)):
            if budget[0] <= 0:
                return None
            dc = world.distances(c)
            budget[0] -= 1
            if np.any(dc < need):
                continue
            first = certify_move(
                world, a, c, need, (ends[0], dc), max_evaluations=min(budget[0], MAX_EVALUATIONS)
            )
            budget[0] -= first.evaluations
            if not first.clear:
                continue
            second = certify_move(
                world, c, b, need, (dc, ends[1]), max_evaluations=min(budget[0], MAX_EVALUATIONS)
            )
            budget[0] -= second.evaluations
            if second.clear:
                return Detour(c, first, second)  # candidates are sorted by time: the quickest clear one
        return None

    detour = attempt([np.clip(np.asarray(c, dtype=float), lower, upper) for c in extra])
    if detour is not None:
        return detour
    for scale in DETOUR_SCALES:
        s = rng.uniform(0.2, 0.8, DETOUR_TRIES)
        base = a[None] + s[:, None] * (b - a)[None]
        candidates = base + rng.normal(0.0, scale, base.shape) * span
        detour = attempt(list(np.clip(candidates, lower, upper)))
        if detour is not None or budget[0] <= 0:
            return detour
    return None
