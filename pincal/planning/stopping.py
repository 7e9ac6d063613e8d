"""When a multistart stops: the adaptive number of starts of a design (``starts=None``).

Starts run in batches of :data:`BATCH` (each batch searched, then the best of it polished, as a
design of :data:`BATCH` starts would), until the best value found is matched within
:data:`TOLERANCE` by :data:`AGREE` starts, or :data:`CAP` starts have run. Easy plans stop after
the first batch; small, hard plans, whose starts end in many local optima, get the starts they
need. The batches do not depend on the number of workers and start k keeps its own seed
(:func:`pincal.planning.starts.start_seed`): the same seed gives the same design whatever runs it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

BATCH = 8
"""Starts added at a time (the first batch is a design of 8 starts)."""

CAP = 128
"""Starts run at most."""

TOLERANCE = 0.01
"""How close a start's value must come to the best to match it (relative: 1 %)."""

AGREE = 3
"""Starts (the best among them) whose values must match the best before the search stops."""


def matched(values: Iterable[float], log_scale: bool = False, tolerance: float | None = None) -> int:
    """How many of the starts' final values (lower is better; inf for a start without a usable
    plan) lie within ``tolerance`` (default :data:`TOLERANCE`) of the best, the best itself
    included; 0 if none is finite.

    ``log_scale``: the values are logarithms (the D criterion's log det M⁻¹): within the tolerance
    means det M⁻¹ within it, ``value <= best + log(1 + tolerance)``.
    """
    finite = [v for v in values if math.isfinite(v)]
    if not finite:
        return 0
    best = min(finite)
    tolerance = TOLERANCE if tolerance is None else tolerance
    limit = best + math.log1p(tolerance) if log_scale else best + tolerance * abs(best)
    return sum(v <= limit for v in finite)


def enough(values: Iterable[float], log_scale: bool = False) -> bool:
    """The search may stop: :data:`AGREE` starts match the best (see :func:`matched`)."""
    return matched(values, log_scale) >= AGREE
