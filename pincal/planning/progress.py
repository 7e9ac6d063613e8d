"""The progress of a design on stderr, stage by stage: on a terminal a bar (the starts searched,
then the best of them polished or run to convergence), elsewhere — a CI log, a script's pipe — one
line every :data:`EVERY` seconds; each with the best value so far, in its units."""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np

from pincal.evaluation.criterion import Criterion

EVERY = 5.0
"""Seconds between two progress lines when stderr is not a terminal."""


class Progress:
    """Progress of one design on stderr (see module doc); off: does nothing.

    Args:
        on: report at all.
        criterion: the criterion's name, for the lines.
        objective: the criterion (its values are reported in its units).
        stream: where to write (default stderr).
    """

    def __init__(self, on: bool, criterion: str, objective: Criterion, stream=None) -> None:
        self.on, self.criterion, self.objective = on, criterion, objective
        self.stream = sys.stderr if stream is None else stream
        self.tty = on and bool(getattr(self.stream, "isatty", lambda: False)())
        self.best = math.inf
        self.bar: Any = None  # a tqdm bar on a terminal
        self.what, self.total, self.done = "", 0, 0
        self.t0 = self.last = time.perf_counter()

    def stage(self, what: str, total: int) -> None:
        """A new stage: ``total`` starts to be ``what`` (``"searched"``, ``"polished"``, ...)."""
        if not self.on:
            return
        self.close()
        self.what, self.total, self.done = what, total, 0
        if self.tty:
            from tqdm import tqdm

            self.bar = tqdm(
                total=total,
                desc=f"design: {what}",
                unit="start",
                leave=False,
                dynamic_ncols=True,
                file=self.stream,
            )

    def __call__(self, outcome: object) -> None:
        """One start of the stage is done (``outcome`` carries its F)."""
        if not self.on:
            return
        F = getattr(outcome, "F", math.nan)
        if getattr(outcome, "feasible", True) and np.isfinite(F):
            self.best = min(self.best, float(self.objective.report(F)))
        self.done += 1
        best = "" if not np.isfinite(self.best) else f"best {self.objective.describe(self.best)}"
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix_str(best)
            return
        now = time.perf_counter()
        if now - self.last >= EVERY:
            self.last = now
            print(
                f"pincal: design {self.criterion}: {self.done} of {self.total} starts {self.what}, "
                f"{best}, {now - self.t0:.0f} s",
                file=self.stream,
                flush=True,
            )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
