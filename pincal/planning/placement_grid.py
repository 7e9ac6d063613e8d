"""The grid of instrument positions :func:`pincal.planning.placement.place_instrument` searches:
``steps`` per axis of a box, at most :data:`MAX_POSITIONS` of them."""

from __future__ import annotations

import math

import numpy as np

from pincal.errors import BadArgument

MAX_POSITIONS = 10_000
"""The most grid positions a placement searches: each is a design (a quick one when screened), and
a grid of ``steps`` ** 3 positions grows beyond any run's time and memory (1 000 steps: 10⁹)."""


def _box(box: object) -> tuple[np.ndarray, np.ndarray]:
    try:
        arr = np.array(box, dtype=float).reshape(2, 3)
    except (TypeError, ValueError):
        raise BadArgument(f"the instrument's box must be X0,Y0,Z0,X1,Y1,Z1 [m], got {box!r}") from None
    lower, upper = arr.min(axis=0), arr.max(axis=0)
    if not np.all(np.isfinite(arr)):
        raise BadArgument(f"the instrument's box must be finite, got {box!r}")
    return lower, upper


def _point(value: object, what: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise BadArgument(f"{what} must be X,Y,Z [m], got {value!r}") from None
    return arr


def _grid_size(lower: np.ndarray, upper: np.ndarray, steps: int) -> int:
    """The number of grid positions: ``steps`` per axis of the box (one on an axis of zero width).

    Raises:
        BadArgument: ``steps`` is no positive integer, or the grid has more than
            :data:`MAX_POSITIONS` positions.
    """
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 1:
        raise BadArgument(f"steps must be a positive integer, got {steps!r}")
    wide = sum(1 for lo, hi in zip(lower, upper) if hi > lo)
    size = steps**wide
    if size > MAX_POSITIONS:
        raise BadArgument(
            f"{steps} steps per axis make a grid of {size:,} positions over the box's {wide} axes of "
            f"non-zero width: at most {MAX_POSITIONS:,} (steps from 1 to "
            f"{math.floor(MAX_POSITIONS ** (1 / wide) + 1e-9)} on {wide} axes)",
            argument="steps",
            value=steps,
        )
    return size


def _grid(lower: np.ndarray, upper: np.ndarray, steps: int) -> list[np.ndarray]:
    """The grid's positions: ``steps`` per axis of the box (one on an axis of zero width)."""
    _grid_size(lower, upper, steps)
    axes = [np.linspace(lo, hi, steps) if hi > lo else np.array([lo]) for lo, hi in zip(lower, upper)]
    return [np.array(p) for p in np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T]
