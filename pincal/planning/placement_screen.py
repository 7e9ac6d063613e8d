"""The placement's screen: one pool of candidate configurations for a whole box of instrument
positions, and the part of it each position sees (:func:`pincal.planning.placement.place_instrument`)."""

from __future__ import annotations

import numpy as np

from pincal.arguments import positive_int
from pincal.model.parameters import ParameterSet
from pincal.planning.constraints import AnyConstraint, Constraint, Kinematics, with_safety
from pincal.planning.driver import DEFAULT_POOL
from pincal.planning.feasibility import Feasibility


class Screen:
    """The screen's candidates: configurations drawn once for the whole box within the constraints
    every position shares (the workcell's and the safe defaults), their kinematics computed once; a
    position's quick design chooses among the first :attr:`size` of them it sees, so that every
    position chooses among as many as a design there would (one that sees fewer, fewer).

    Args:
        params: the parameters (on the robot).
        constraints: the workcell's constraints.
        options: :func:`pincal.design`'s options: ``pool`` (a size, or configurations: the
            feasible ones are the candidates), ``joint_margin``, ``mount``, ``seed`` (an int).
        m: configurations a plan needs.
    """

    def __init__(
        self, params: ParameterSet, constraints: tuple[AnyConstraint, ...], options: dict, m: int
    ) -> None:
        robot, pool = params.robot, options.get("pool")
        safe = with_safety(robot, constraints, options.get("joint_margin"), options.get("mount"))
        feasibility = Feasibility(robot, safe)
        if pool is None or isinstance(pool, (int, np.integer)):
            self.size = min(SCREEN_POOL, DEFAULT_POOL if pool is None else positive_int(pool, "pool size", m))
            rng = np.random.default_rng(np.random.SeedSequence(options["seed"]))
            self.qs = feasibility.sample(SCREEN_DRAWS * self.size, rng, minimum=m)
        else:
            self.qs = feasibility.feasible_pool(pool, m)[0]
            self.size = len(self.qs)
        self.kinematics = Kinematics(robot, self.qs)

    def seen(self, params: ParameterSet, extra: tuple[AnyConstraint, ...]) -> np.ndarray:
        """The candidates within the constraints a position brings (each checked on those the ones
        before kept: the visibility first, then the line of sight), the first :attr:`size`."""
        kept = np.arange(len(self.qs))
        for constraint in extra:
            if not len(kept):
                break
            assert isinstance(constraint, Constraint)  # a position brings visibility, line of sight
            bound = constraint.bind(params.robot)
            kept = kept[bound.satisfied(self.kinematics.subset(kept))]
        return self.qs[kept[: self.size]]


SCREEN_POOL = 500
"""Candidate configurations a position's quick design in the screen chooses from (at most the
pool's size)."""

SCREEN_DRAWS = 40
"""The screen draws this many times :data:`SCREEN_POOL` feasible configurations for the box: a
position that sees one in 40 of them (a tracker's reflector, 30° about its normal, sees one
direction in 15) still has its :data:`SCREEN_POOL`."""
