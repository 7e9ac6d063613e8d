"""Checks of the arguments every stage takes alike (counts, σ), so that one rule and one message
serve the API and the CLI."""

from __future__ import annotations

import math

import numpy as np

from pincal.errors import BadArgument

DEFAULT_SIGMA = 3e-5
"""The measurement noise σ per coordinate [m] assumed when none is given, everywhere (API and
CLI): 30 µm, a laser tracker's. Every ρ0 is proportional to σ: give the instrument's own."""


def sigma_note(sigma: float, given: bool = True) -> str:
    """How a report names the σ it used: ``σ = 0.030 mm (default: laser tracker)``."""
    shown = f"σ = {sigma * 1e3:.3f} mm" if sigma < 1 else f"σ = {sigma:g} m"
    return shown + ("" if given else " (default: laser tracker)")


MAX_LENGTH = 1e6
"""Longest length pincal accepts [m]: a link, a marker offset, a measured coordinate (1000 km).
Beyond any robot or instrument, and far enough from overflow that the products and squares of
Jacobians and residuals stay finite."""
SIGMA_RANGE = (1e-12, 1e3)
"""The σ pincal accepts [m]: 1 pm (below any instrument; 1/σ² stays far from overflow) to 1 km."""


def check_lengths(values: object, what: str, error: type[Exception] = BadArgument) -> None:
    """Raise ``error`` if any of ``values`` [m] is over :data:`MAX_LENGTH` in size: ``what`` begins
    the message (``"marker coordinate"``: 'marker coordinate 1e+09 m, over the ...')."""
    arr = np.abs(np.asarray(values, dtype=float))
    if arr.size and not np.all(arr <= MAX_LENGTH):
        worst = float(arr.flat[int(np.argmax(np.where(np.isfinite(arr), arr, np.inf)))])
        raise error(
            f"{what} {worst:.3g} m, over the {MAX_LENGTH:.0e} m pincal accepts (a unit or number error?)"
        )


MAX_COUNT = 10**7
"""Largest count (configurations, plans, starts, trials, pool size) pincal accepts: beyond any real
run, and below what would exhaust memory before a first result."""


def positive_int(value: object, name: str, low: int = 1, high: int | None = MAX_COUNT) -> int:
    """``value`` as an int, if it is an integer in [``low``, ``high``] (bools refused; ``high``
    None: no upper bound).

    Raises:
        PincalError: naming ``name``, the bounds and the value given.
    """
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or value < low
        or (high is not None and value > high)
    ):
        bounds = f"≥ {low}" if high is None else f"from {low} to {high:,}"
        raise BadArgument(
            f"{name} must be an integer {bounds}, got {value!r}",
            argument=name,
            value=value,
            valid=f"an integer {bounds}",
        )
    return int(value)


def positive_sigma(sigma: object = DEFAULT_SIGMA, name: str = "sigma") -> float:
    """σ, the measurement noise per coordinate [m], as a float, if it is finite and positive,
    within :data:`SIGMA_RANGE`.

    Raises:
        PincalError: naming ``name`` and the value given.
    """
    try:
        s = float(sigma)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        s = math.nan
    if not (math.isfinite(s) and s > 0):
        raise BadArgument(
            f"{name} must be a positive number of metres, got {sigma!r}",
            argument=name,
            value=sigma,
            valid="> 0 [m]",
        )
    low, high = SIGMA_RANGE
    if not low <= s <= high:
        raise BadArgument(
            f"{name} must be from {low:g} to {high:g} m, got {sigma!r}",
            argument=name,
            value=sigma,
            valid=f"{low:g} to {high:g} [m]",
        )
    return s


Seed = int | np.integer | np.random.Generator | np.random.SeedSequence | None
"""What every ``seed`` argument accepts: an int ≥ 0 or a ``numpy.random.SeedSequence`` (the same
draws each time), a ``numpy.random.Generator`` (its stream continues; the caller's generator
advances), or None (fresh entropy)."""


def _check_seed(seed: object) -> None:
    if seed is None or isinstance(seed, (np.random.Generator, np.random.SeedSequence)):
        return
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BadArgument(
            f"seed must be an integer ≥ 0, a numpy Generator or None, got {seed!r}",
            argument="seed",
            value=seed,
        )


def generator(seed: Seed) -> np.random.Generator:
    """The random generator of a ``seed`` argument (see :data:`Seed`): a Generator is used as is.

    Raises:
        PincalError: a seed of another kind (a negative or non-integer number, a bool).
    """
    _check_seed(seed)
    return np.random.default_rng(seed)


def seed_entropy(seed: Seed) -> int:
    """An int that repeats a run seeded by ``seed`` when passed as its seed: the int itself, the
    entropy of a SeedSequence, one draw from a Generator, or fresh entropy for None.

    Raises:
        PincalError: as :func:`generator`.
    """
    _check_seed(seed)
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(2**63))
    if isinstance(seed, np.random.SeedSequence):
        return int(seed.entropy)
    return int(np.random.SeedSequence(None if seed is None else int(seed)).entropy)
