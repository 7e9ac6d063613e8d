"""Checks of the arguments every stage takes alike (counts, σ), so that one rule and one message
serve the API and the CLI."""

from __future__ import annotations

import math

import numpy as np

from pincal.errors import PincalError


def positive_int(value: object, name: str, low: int = 1) -> int:
    """``value`` as an int, if it is an integer ≥ ``low`` (bools refused).

    Raises:
        PincalError: naming ``name``, the bound and the value given.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise PincalError(f"{name} must be an integer ≥ {low}, got {value!r}")
    return int(value)


def positive_sigma(sigma: object) -> float:
    """σ, the measurement noise per coordinate [m], as a float, if it is finite and positive.

    Raises:
        PincalError: the value given.
    """
    try:
        s = float(sigma)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        s = math.nan
    if not (math.isfinite(s) and s > 0):
        raise PincalError(f"sigma must be a positive number of metres, got {sigma!r}")
    return s
