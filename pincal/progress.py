"""The progress of a long computation on stderr, never stdout (which holds the report or the JSON):
on a terminal a bar, elsewhere — a CI log, a script's pipe — one line every :data:`EVERY` seconds
(none for a computation shorter than that). Switched off, it does nothing: the CLI's
``--no-progress``, and the API's default."""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator, Sequence
from typing import Any, TextIO, TypeVar

T = TypeVar("T")

EVERY = 5.0
"""Seconds between two progress lines when stderr is not a terminal."""


class Steps:
    """Progress through stages of counted steps (``"12 of 16 starts searched"``).

    Args:
        on: report at all.
        label: what is running, first on each line (``"campaign"``, ``"design D"``).
        unit: one step (``"move"``, ``"start"``, ``"trial"``).
        stream: where to write (default stderr).
    """

    def __init__(self, on: bool, label: str, unit: str, stream: TextIO | None = None) -> None:
        self.on, self.label, self.unit = on, label, unit
        self.stream = sys.stderr if stream is None else stream
        self.tty = on and bool(getattr(self.stream, "isatty", lambda: False)())
        self.bar: Any = None  # a tqdm bar on a terminal
        self.what, self.total, self.done = "", 0, 0
        self.t0 = self.last = time.perf_counter()

    def stage(self, what: str, total: int) -> None:
        """A new stage: ``total`` steps to be ``what`` (``"searched"``, ``"certified"``, ...)."""
        if not self.on:
            return
        self.close()
        self.what, self.total, self.done = what, total, 0
        if self.tty:
            from tqdm import tqdm

            self.bar = tqdm(
                total=total,
                desc=f"{self.label}: {what}",
                unit=self.unit,
                leave=False,
                dynamic_ncols=True,
                file=self.stream,
            )

    def advance(self, note: str = "") -> None:
        """One step of the stage is done; ``note`` (``"best ρ0 0.02 mm"``) goes with it."""
        if not self.on:
            return
        self.done += 1
        if self.bar is not None:
            self.bar.update(1)
            if note:
                self.bar.set_postfix_str(note)
            return
        now = time.perf_counter()
        if now - self.last >= EVERY:
            self.last = now
            print(
                f"pincal: {self.label}: {self.done} of {self.total} {self.unit}s {self.what}, "
                f"{note + ', ' if note else ''}{now - self.t0:.0f} s",
                file=self.stream,
                flush=True,
            )

    def each(self, what: str, items: Sequence[T]) -> Iterator[T]:
        """``items``, one stage of steps ``what``: a step is done when the next item is asked for."""
        self.stage(what, len(items))
        for item in items:
            yield item
            self.advance()
        self.close()

    def close(self) -> None:
        """The stage is over: the bar goes."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None
