"""The checks of every argument pincal takes, in one place: one rule, one bound and one message
for the same kind of value wherever it is given (a Python argument, a CLI option, a YAML or CSV
cell).

Kinds and their bounds:

* σ, the measurement noise per coordinate [m]: :func:`positive_sigma`, within :data:`SIGMA_RANGE`
  (zero too where exact points make sense: ``zero=True``);
* counts (configurations, plans, starts, trials, samples, iterations, folds):
  :func:`positive_int`, up to :data:`MAX_COUNT`;
* seeds: :func:`checked_seed`, :func:`generator`, :func:`seed_entropy` (see :data:`~pincal.typing.SeedLike`);
* lengths [m]: :func:`length`, :func:`check_lengths`, up to :data:`MAX_LENGTH` in size;
* angles [rad] and joint values [rad or m]: :func:`angle`, :func:`joint_range`, up to
  :data:`MAX_ANGLE` in size;
* fractions, ratios and tolerances: :func:`fraction`, :func:`ratio` (up to :data:`MAX_RATIO`),
  :func:`number` (any other bounded number);
* names (robots, joints, frames): :func:`checked_name`, at most :data:`MAX_NAME` characters.

Every check refuses booleans (``True`` is not the number 1: a YAML ``margin_deg: true`` is a
mistake) and text (the CLI and the file readers convert text before they check), and raises
:class:`~pincal.errors.BadArgument` (or the ``error`` subclass given) naming the argument, what is
valid and the value given.
"""

from __future__ import annotations

import math
import re
from typing import cast

import numpy as np

from pincal.errors import BadArgument
from pincal.typing import SeedLike

DEFAULT_SIGMA = 3e-5
"""The measurement noise σ per coordinate [m] assumed when none is given, everywhere (API and
CLI): 30 µm, a laser tracker's. Every ρ0 is proportional to σ: give the instrument's own."""


def sigma_note(sigma: float, given: bool = True) -> str:
    """How a report names the σ it used: ``σ = 0.030 mm (default: laser tracker)``."""
    shown = f"σ = {sigma * 1e3:.3f} mm" if sigma < 1 else f"σ = {sigma:g} m"
    return shown + ("" if given else " (default: laser tracker)")


MAX_LENGTH = 1e6
"""Longest length pincal accepts [m]: a link, a marker offset, a measured coordinate, a box
corner, a half-width (1000 km). Beyond any robot or instrument, and far enough from overflow that
the products and squares of Jacobians and residuals stay finite."""
MAX_ANGLE = 1e6
"""Largest angle or revolute joint value pincal accepts in size [rad]: beyond any joint (a
multi-turn joint turns a few hundred times), far from overflow. A joint value (radians or metres)
is bounded by it and :data:`MAX_LENGTH` alike (both 1e6)."""
SIGMA_RANGE = (1e-12, 1e3)
"""The σ pincal accepts [m]: 1 pm (below any instrument; 1/σ² stays far from overflow) to 1 km."""
MAX_COUNT = 10**7
"""Largest count (configurations, plans, starts, trials, pool size) pincal accepts: beyond any real
run, and below what would exhaust memory before a first result."""
MAX_RATIO = 1e12
"""Largest ratio or factor pincal accepts (a drawing scale, a rejection threshold in robust σ)."""
MAX_NAME = 200
"""Longest name (robot, joint, link, frame, parameter) pincal accepts [characters]."""

_REAL = (int, float, np.integer, np.floating)


def _is_real(value: object) -> bool:
    """True for an int or float (NumPy's too, 0-d arrays of them), never a bool."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    return isinstance(value, _REAL) and not isinstance(value, (bool, np.bool_))


def _float(value: object) -> float:
    """``value`` as a float, NaN if it is not a real number (bools and text included) or too
    large for a float."""
    if not _is_real(value):
        return math.nan
    try:
        return float(value)  # type: ignore[arg-type]
    except OverflowError:  # an int of more than 308 digits
        return math.nan


def _shown(value: object) -> str:
    """``repr`` of a value for a message; NumPy scalars as the plain numbers they hold."""
    if isinstance(value, (np.generic, np.ndarray)) and np.ndim(value) == 0:
        return repr(np.asarray(value).item())
    return repr(value)


def _g(x: float) -> str:
    return f"{x:g}"


def number(
    value: object,
    name: str,
    low: float = -math.inf,
    high: float = math.inf,
    *,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
    error: type[BadArgument] = BadArgument,
) -> float:
    """``value`` as a float, if it is a finite real number (not a bool, not text) in the interval
    from ``low`` to ``high`` (each end excluded when ``low_open`` / ``high_open``).

    Args:
        value: what was given.
        name: the argument as the caller knows it (``"sigma"``, ``"--around"``,
            ``"joint_limits margin_deg"``): it begins the message.
        low, high: the bounds (infinite: none).
        low_open, high_open: exclude that bound.
        unit: the unit named in the message (``"m"``, ``"rad"``), or "".
        error: the BadArgument subclass raised (e.g. ``BadConstraint`` in a constraints file).

    Raises:
        ``error``: '{name} must be {what is valid}, got {value!r}'.
    """
    v = _float(value)
    inside = (
        math.isfinite(v) and (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    )
    if not inside:
        valid = describe(low, high, low_open=low_open, high_open=high_open, unit=unit)
        raise error(f"{name} must be {valid}, got {_shown(value)}", argument=name, value=value, valid=valid)
    return v


def describe(
    low: float, high: float, *, low_open: bool = False, high_open: bool = False, unit: str = ""
) -> str:
    """What :func:`number` accepts, in words: 'a positive number of metres up to 1e+06'."""
    units = {"m": " of metres", "rad": " of radians", "m or rad": " (metres or radians)"}.get(unit, "")
    left, right = "(" if low_open else "[", ")" if high_open else "]"
    if (low, high, unit) == (0, 1, ""):
        return f"a fraction in {left}0, 1{right}"
    if low == -math.inf and high == math.inf:
        return f"a finite number{units}"
    if low == -math.inf:
        return f"a number{units} {'<' if high_open else '≤'} {_g(high)}"
    if high == math.inf:
        return (
            f"a positive number{units}"
            if (low, low_open) == (0, True)
            else (f"a number{units} {'>' if low_open else '≥'} {_g(low)}")
        )
    if low == 0 and low_open and not high_open:
        return f"a positive number{units} up to {_g(high)}"
    if low > 0 and not (low_open or high_open):
        return f"a positive number{units} from {_g(low)} to {_g(high)}"
    if low >= 0 and (low > 0 or low_open):
        return f"a positive number{units} in {left}{_g(low)}, {_g(high)}{right}"
    if low == 0 and not high_open:
        return f"a number{units} from 0 to {_g(high)}"
    return f"a number{units} in {left}{_g(low)}, {_g(high)}{right}"


LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6}
"""Units a length may be written in at the edges (``--prior 1mm,1mrad``, ``--around 10deg,2cm``) [m]."""
ANGLE_UNITS = {"rad": 1.0, "mrad": 1e-3, "urad": 1e-6, "µrad": 1e-6, "deg": math.pi / 180}
"""Units an angle may be written in at the edges [rad]."""
UNITS_TEXT = f"length units: {', '.join(LENGTH_UNITS)}; angle units: {', '.join(ANGLE_UNITS)}"

_QUANTITY = re.compile(r"^\s*([-+0-9.eE]+|inf)\s*([a-zµ]*)\s*$")


def quantities(text: str, what: str, valid: str) -> list[tuple[str | None, float]]:
    """The comma-separated quantities of ``text`` ('1mm,1mrad', '10deg,2cm', '0.5'): for each,
    ('length' [m] | 'angle' [rad] | None for a bare number (unscaled), value).

    Raises:
        BadArgument: a token that is not a number with an optional known unit; the message
            begins with ``what`` and ends with ``valid``.
    """
    out: list[tuple[str | None, float]] = []
    for token in (t.strip() for t in str(text).split(",")):
        match = _QUANTITY.match(token.lower())
        if match is None:
            raise BadArgument(f"{what} {text!r}: cannot read {token!r}; {valid}", argument=what, value=text)
        digits, unit = match.groups()
        try:
            value = float(digits)
        except ValueError:
            raise BadArgument(
                f"{what} {text!r}: cannot read {token!r}; {valid}", argument=what, value=text
            ) from None
        if unit in LENGTH_UNITS:
            out.append(("length", value * LENGTH_UNITS[unit]))
        elif unit in ANGLE_UNITS:
            out.append(("angle", value * ANGLE_UNITS[unit]))
        elif unit == "":
            out.append((None, value))
        else:
            raise BadArgument(f"{what} {text!r}: unknown unit {unit!r}; {valid}", argument=what, value=text)
    return out


def check_lengths(values: object, what: str, error: type[Exception] = BadArgument) -> None:
    """Raise ``error`` if any of ``values`` [m] is over :data:`MAX_LENGTH` in size: ``what`` begins
    the message (``"marker coordinate"``: 'marker coordinate 1e+09 m, over the ...')."""
    arr = np.abs(np.asarray(values, dtype=float))
    if arr.size and not np.all(arr <= MAX_LENGTH):
        worst = float(arr.flat[int(np.argmax(np.where(np.isfinite(arr), arr, np.inf)))])
        raise error(
            f"{what} {worst:.3g} m, over the {MAX_LENGTH:.0e} m pincal accepts (a unit or number error?)"
        )


def length(
    value: object, name: str, *, positive: bool = True, error: type[BadArgument] = BadArgument
) -> float:
    """A length [m]: finite, up to :data:`MAX_LENGTH`, positive (or ≥ 0 with ``positive=False``)."""
    return number(value, name, 0.0, MAX_LENGTH, low_open=positive, unit="m", error=error)


def coordinate(value: object, name: str, error: type[BadArgument] = BadArgument) -> float:
    """A coordinate or signed offset [m]: finite, within ±:data:`MAX_LENGTH`."""
    return number(value, name, -MAX_LENGTH, MAX_LENGTH, unit="m", error=error)


def point(value: object, name: str, size: int = 3, error: type[BadArgument] = BadArgument) -> np.ndarray:
    """``size`` coordinates [m] (a point, a box corner), each within ±:data:`MAX_LENGTH`."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        valid = f"{size} numbers [m]"
        raise error(f"{name} must be {valid}, got {_shown(value)}", argument=name, value=value, valid=valid)
    items = list(value)  # type: ignore[call-overload]
    if len(items) != size:
        valid = f"{size} numbers [m]"
        raise error(f"{name} must be {valid}, got {_shown(value)}", argument=name, value=value, valid=valid)
    return np.array([coordinate(v, f"{name}[{i}]", error) for i, v in enumerate(items)])


def angle(
    value: object,
    name: str,
    *,
    positive: bool = True,
    high: float = MAX_ANGLE,
    error: type[BadArgument] = BadArgument,
) -> float:
    """An angle [rad]: finite, up to ``high`` (:data:`MAX_ANGLE`), positive (or ≥ 0)."""
    return number(value, name, 0.0, high, low_open=positive, unit="rad", error=error)


def joint_range(value: object, name: str, error: type[BadArgument] = BadArgument) -> tuple[float, float]:
    """(lower, upper) joint values [rad or m], each within ±:data:`MAX_ANGLE`, lower ≤ upper."""
    try:
        low, high = cast("tuple[object, object]", value)  # a TypeError or ValueError if it is not a pair
    except (TypeError, ValueError):
        valid = "(lower, upper) [rad or m]"
        raise error(
            f"{name} must be {valid}, got {_shown(value)}", argument=name, value=value, valid=valid
        ) from None
    lo = number(low, f"{name} lower", -MAX_ANGLE, MAX_ANGLE, unit="m or rad", error=error)
    hi = number(high, f"{name} upper", -MAX_ANGLE, MAX_ANGLE, unit="m or rad", error=error)
    if lo > hi:
        raise error(f"{name} must have lower ≤ upper, got ({lo:g}, {hi:g})", argument=name, value=value)
    return lo, hi


def fraction(
    value: object,
    name: str,
    *,
    zero: bool = False,
    one: bool = False,
    error: type[BadArgument] = BadArgument,
) -> float:
    """A fraction in (0, 1): ``zero`` / ``one`` include that end."""
    return number(value, name, 0.0, 1.0, low_open=not zero, high_open=not one, error=error)


def ratio(value: object, name: str, error: type[BadArgument] = BadArgument) -> float:
    """A positive factor or threshold (a drawing scale, K robust σ), up to :data:`MAX_RATIO`."""
    return number(value, name, 0.0, MAX_RATIO, low_open=True, error=error)


def positive_int(value: object, name: str, low: int = 1, high: int | None = MAX_COUNT) -> int:
    """``value`` as an int, if it is an integer in [``low``, ``high``] (bools refused; ``high``
    None: no upper bound).

    Raises:
        PincalError: naming ``name``, the bounds and the value given.
    """
    if (
        isinstance(value, (bool, np.bool_))
        or not isinstance(value, (int, np.integer))
        or value < low
        or (high is not None and value > high)
    ):
        bounds = f"≥ {low}" if high is None else f"from {low} to {high:,}"
        raise BadArgument(
            f"{name} must be an integer {bounds}, got {_shown(value)}",
            argument=name,
            value=value,
            valid=f"an integer {bounds}",
        )
    return int(value)


def positive_sigma(sigma: object = DEFAULT_SIGMA, name: str = "sigma", *, zero: bool = False) -> float:
    """σ, the measurement noise per coordinate [m], as a float, if it is finite and within
    :data:`SIGMA_RANGE` (or 0 with ``zero``: exact points).

    Raises:
        PincalError: naming ``name`` and the value given.
    """
    low, high = SIGMA_RANGE
    v = _float(sigma)
    if zero and v == 0:
        return 0.0
    if not (math.isfinite(v) and low <= v <= high):
        valid = f"a positive number of metres from {low:g} to {high:g}"
        valid += " (or 0: exact points)" if zero else ""
        raise BadArgument(
            f"{name} must be {valid}, got {_shown(sigma)}", argument=name, value=sigma, valid=valid
        )
    return v


def checked_name(value: object, what: str, error: type[BadArgument] = BadArgument) -> str:
    """A name (robot, joint, frame, link): non-empty text of at most :data:`MAX_NAME` characters
    without control characters."""
    if not isinstance(value, str) or not value.strip():
        raise error(f"{what} must be a non-empty name, got {_shown(value)}", argument=what, value=value)
    if len(value) > MAX_NAME:
        raise error(
            f"{what} {value[:40]!r}... is {len(value)} characters long, more than the {MAX_NAME} a "
            "name may have",
            argument=what,
            value=value,
        )
    if any(ord(c) < 32 for c in value):
        raise error(f"{what} {value!r} holds a control character", argument=what, value=value)
    return value


Seed = SeedLike
"""The former name of :data:`pincal.typing.SeedLike` (code written against it keeps working)."""


def _check_seed(seed: object) -> None:
    if seed is None or isinstance(seed, (np.random.Generator, np.random.SeedSequence)):
        return
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BadArgument(
            f"seed must be an integer ≥ 0, a numpy Generator or None, got {seed!r}",
            argument="seed",
            value=seed,
        )


def checked_seed(value: SeedLike) -> SeedLike:
    """``value`` if it is a valid seed (see :data:`~pincal.typing.SeedLike`), for storing before it is used.

    Raises:
        PincalError: a seed of another kind (a negative or non-integer number, a bool).
    """
    _check_seed(value)
    return value


def generator(seed: SeedLike) -> np.random.Generator:
    """The random generator of a ``seed`` argument (see :data:`~pincal.typing.SeedLike`): a
    Generator is used as is.

    Raises:
        PincalError: a seed of another kind (a negative or non-integer number, a bool).
    """
    _check_seed(seed)
    return np.random.default_rng(seed)


def seed_entropy(seed: SeedLike) -> int:
    """An int that repeats a run seeded by ``seed`` when passed as its seed: the int itself, the
    entropy of a SeedSequence, one draw from a Generator, or fresh entropy for None.

    Raises:
        PincalError: as :func:`generator`.
    """
    _check_seed(seed)
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(2**63))
    if isinstance(seed, np.random.SeedSequence):
        return int(seed.entropy)  # type: ignore[arg-type]  # an int: pincal makes no spawned sequence
    return int(np.random.SeedSequence(None if seed is None else int(seed)).entropy)  # type: ignore[arg-type]
