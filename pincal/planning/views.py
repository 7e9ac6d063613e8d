"""The candidates of a design whose instrument sees only part of what it measures (a camera: part
of its target): drawn where a measurement likely reads all its configuration can reveal.

A random configuration of a Panda carrying the example rig's camera sees none of the target
nine times in ten: a pool drawn uniformly holds a few candidates that inform the design among
many that add nothing, and a random plan of 20 of them, a start, is rank-deficient. The pool is
therefore drawn in rounds until it holds its size of candidates where
:meth:`~pincal.instruments.kind.Kind.reads` is true (a camera: three target points at least,
not in a line, likely read). Every other kind's pool is drawn exactly as before.
"""

from __future__ import annotations

import numpy as np

from pincal.errors import Infeasible
from pincal.instruments.kind import Kind
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.planning.feasibility import Feasibility

ROUNDS = 50
"""Rounds of ``size`` feasible configurations a pool of ``size`` may draw to find its candidates
(100 000 configurations for the default pool of 2000). On the example rig, where one view in
eighteen qualifies, the default pool takes 18 rounds and 4.7 s of CPU, most of it the
feasibility checks (a point design's pool: 0.15 s)."""


def draw_candidates(
    feasibility: Feasibility,
    kind: Kind,
    params: ParameterSet,
    size: int,
    rng: np.random.Generator,
    minimum: int,
    strict: bool,
    loads: np.ndarray | None = None,
) -> np.ndarray:
    """Up to ``size`` feasible configurations (:meth:`Feasibility.sample`, at least ``minimum``,
    each under one of the payload rows ``loads`` at least), for a kind with a partial view
    (:attr:`Kind.partial_view`) only where it reads enough (:meth:`Kind.reads`, unloaded), drawn
    in rounds of ``size`` until there are ``size`` of them or :data:`ROUNDS` rounds were drawn.

    Raises:
        Infeasible: fewer than ``minimum`` feasible configurations, or fewer than ``minimum``
            among them where the instrument reads enough (the message says how many of how many).
    """
    if not kind.partial_view:
        return feasibility.sample(size, rng, minimum=minimum, strict=strict, loads=loads)
    engine = JacobianEngine(params)
    found: list[np.ndarray] = []
    count = drawn = 0
    for round_ in range(ROUNDS):
        least = minimum if round_ == 0 else 0
        qs = feasibility.sample(size, rng, minimum=least, strict=strict, loads=loads)
        drawn += len(qs)
        keep = qs[kind.reads(engine, qs)]
        found.append(keep)
        count += len(keep)
        if count >= size or not len(qs):
            break
    if count < minimum:
        raise Infeasible(
            f"the {kind.describe()} is likely to read enough of what it measures (a camera: three "
            f"target points, not in a line) at only {count} of {drawn} feasible configurations drawn "
            f"({minimum} needed): place the target (or the camera) where the robot can see it, or "
            "give a pool of configurations that see it"
        )
    return np.concatenate(found)[:size]
