"""The progress of a design on stderr, stage by stage (the starts searched, then the best of them
polished or run to convergence), each step with the best value so far in the criterion's units;
a bar on a terminal, else a line every few seconds (:class:`pincal.progress.Steps`)."""

from __future__ import annotations

import math

import numpy as np

from pincal.evaluation.criterion import Criterion
from pincal.progress import Steps


class Progress:
    """Progress of one design on stderr (see module doc); off: does nothing.

    Args:
        on: report at all.
        criterion: the criterion's name, for the lines.
        objective: the criterion (its values are reported in its units).
        stream: where to write (default stderr).
    """

    def __init__(self, on: bool, criterion: str, objective: Criterion, stream=None) -> None:
        self.on, self.objective = on, objective
        self.steps = Steps(on, f"design {criterion}", "start", stream)
        self.best = math.inf

    def stage(self, what: str, total: int) -> None:
        """A new stage: ``total`` starts to be ``what`` (``"searched"``, ``"polished"``, ...)."""
        self.steps.stage(what, total)

    def __call__(self, outcome: object) -> None:
        """One start of the stage is done (``outcome`` carries its F)."""
        if not self.on:
            return
        F = getattr(outcome, "F", math.nan)
        if getattr(outcome, "feasible", True) and np.isfinite(F):
            self.best = min(self.best, float(self.objective.report(F)))
        self.steps.advance("" if not np.isfinite(self.best) else f"best {self.objective.describe(self.best)}")

    def close(self) -> None:
        self.steps.close()
