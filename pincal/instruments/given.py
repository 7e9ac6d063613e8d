"""The one door of what is measured and how well (docs/method.md §13): a public function's
``instrument=`` (an :class:`~pincal.instruments.Instrument`: a kind and an error model) and
``sigma=`` (its shorthand: points with one σ per coordinate [m]) turned, once, into what travels
below it, σ checked there.

Every public function that takes them (:func:`pincal.design`, :func:`pincal.rho0`,
:func:`pincal.accuracy`, :func:`pincal.simulate_measurements`, ...) reads them through
:func:`measured` (or :func:`instrument_of`): both given is refused, whatever the function.

pincal 0.1 said it in two keywords, ``measure=`` (a kind) and ``instrument=`` (an error model);
they keep working until pincal :data:`~pincal.deprecation.REMOVAL`, with a DeprecationWarning at
the caller's line naming the Instrument to write (:data:`takes_instrument`, through
:func:`pincal.deprecation.moved_keywords`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ParamSpec, TypeVar

from pincal.arguments import DEFAULT_SIGMA, positive_sigma
from pincal.deprecation import moved_keywords
from pincal.errors import BadArgument
from pincal.instruments.error_model import ErrorModel, PerCoordinate
from pincal.instruments.instrument import Instrument
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.model.robot import Robot

__all__ = [
    "OLD_FORM",
    "error_model_alone",
    "error_model_of",
    "hint",
    "instrument_of",
    "keywords",
    "measured",
    "old_instrument",
    "takes_instrument",
    "takes_instrument_of_data",
]

P = ParamSpec("P")
R = TypeVar("R")

OLD_FORM = (
    "{function}(): measure= and an error model as instrument= are deprecated: write {hint} (one "
    "instrument= since pincal 0.2; the old form stops working in pincal {removal})"
)
"""The DeprecationWarning of the 0.1 form (pyproject's filterwarnings makes it an error in the tests)."""


def measured(
    instrument: object = None, sigma: object = None, *, zero: bool = False
) -> tuple[Instrument | None, float]:
    """(the instrument given, or None for ``sigma=``'s shorthand: points with one σ per coordinate;
    the σ [m]: the shorthand's, checked, its default :data:`~pincal.arguments.DEFAULT_SIGMA` when
    None, or the instrument's reference σ). ``zero``: σ = 0 (exact points) is allowed.

    Raises:
        BadArgument: both given, an ``instrument`` that is not an Instrument, or a bad σ.
    """
    if instrument is None:
        return None, DEFAULT_SIGMA if sigma is None else positive_sigma(sigma, zero=zero)
    if sigma is not None:
        raise BadArgument(
            "give sigma= (points, one σ per coordinate) or instrument= (its error model has its own σ), "
            "not both",
            argument="sigma",
        )
    if not isinstance(instrument, Instrument):
        raise BadArgument(
            "instrument= takes a pincal.instruments.Instrument(kind, error model) "
            f"(e.g. Instrument(Pose(), Tracker())), got {instrument!r}",
            argument="instrument",
            value=instrument,
        )
    return instrument, instrument.reference


def instrument_of(instrument: object = None, sigma: object = None) -> tuple[Instrument, bool]:
    """(the instrument, True when it is ``sigma=``'s shorthand: points with one σ per coordinate,
    whose rows are the points' own): :func:`measured`, the shorthand as an Instrument."""
    if instrument is None:  # PerCoordinate checks σ (positive_sigma), once
        return Instrument(Point(), PerCoordinate(DEFAULT_SIGMA if sigma is None else sigma)), True  # type: ignore[arg-type]
    given, _ = measured(instrument, sigma)
    assert given is not None  # an instrument was given
    return given, False


def old_instrument(flat: dict, kwargs: dict) -> tuple[dict, str]:
    """The keywords of today for pincal 0.1's ``measure=`` (in ``flat``) and an error model given
    as ``instrument=`` (in ``kwargs``, with a ``sigma=`` beside them), and what to write instead
    (a :data:`~pincal.deprecation.Regroup`). Points with no error model are the ``sigma=``
    shorthand; a kind alone is measured with one σ per coordinate (``sigma``, or the default); an
    error model overrules ``sigma`` (checked all the same), as it did."""
    error = kwargs.get("instrument")
    if "measure" not in flat and not isinstance(error, ErrorModel):
        return kwargs, ""
    out = dict(kwargs)
    kind = flat.get("measure")
    if error is None and (kind is None or isinstance(kind, Point)):
        out.pop("instrument", None)
        return out, "sigma=... alone (points with one σ per coordinate: no measure=)"
    sigma = out.pop("sigma", None)
    sigma = DEFAULT_SIGMA if sigma is None else positive_sigma(sigma, zero=True)
    if sigma == 0:  # exact values (pincal.simulate_measurements): said with sigma=0 still
        out["sigma"], sigma = 0.0, DEFAULT_SIGMA
    out["instrument"] = Instrument(
        Point() if kind is None else kind, PerCoordinate(sigma) if error is None else error
    )
    return out, hint(out["instrument"]) + (", sigma=0" if "sigma" in out else "")


def hint(instrument: Instrument) -> str:
    """What to write for ``instrument`` (``instrument=pincal.instruments.Instrument(Pose(...), ...)``)."""
    return (
        f"instrument=pincal.instruments.Instrument({type(instrument.kind).__name__}(...), "
        f"{type(instrument.error).__name__}(...))"
    )


def takes_instrument(function: Callable[P, R]) -> Callable[P, R]:
    """The decorator of a public function that takes ``instrument=`` and ``sigma=``: pincal 0.1's
    ``measure=`` and error model keep working (:func:`old_instrument`), with a warning."""
    return moved_keywords(("measure",), old_instrument, OLD_FORM)(function)


def keywords(instrument: Instrument | None, sigma: float) -> dict:
    """The keywords that say it again to another public function: ``instrument=`` (given), or the
    shorthand ``sigma=`` (None: points with ``sigma``), as :func:`measured` returned them."""
    return {"sigma": sigma} if instrument is None else {"instrument": instrument}


def error_model_alone(flat: dict, kwargs: dict) -> tuple[dict, str]:
    """:func:`old_instrument` of a function whose data carry their kind (:func:`pincal.identify`):
    an error model alone as ``instrument=`` is passed on as it is (the function pairs it with
    the data's kind), with what to write instead."""
    error = kwargs.get("instrument")
    if not isinstance(error, ErrorModel):
        return kwargs, ""
    return kwargs, f"instrument=pincal.instruments.Instrument(<the data's kind>, {type(error).__name__}(...))"


def error_model_of(instrument: object, sigma: object, kind: Kind, robot: Robot) -> ErrorModel | None:
    """The error model of ``instrument`` for data of ``kind`` that carry their kind (checked as
    :func:`measured` does: an Instrument, not with ``sigma``), None when none is given; pincal
    0.1's error model alone is taken as it is (:func:`error_model_alone` warned of it).

    Raises:
        BadArgument: not an Instrument, given with ``sigma``, or of another kind than the data's.
    """
    if instrument is None or isinstance(instrument, ErrorModel):
        return instrument
    given, _ = measured(instrument, sigma)
    assert given is not None  # an instrument was given
    if type(given.kind) is not type(kind) or given.kind.coordinates(robot) != kind.coordinates(robot):
        raise BadArgument(
            f"the instrument measures {given.kind.describe()}, but the data hold {kind.describe()}: give "
            f"the data's own (instrument=pincal.instruments.Instrument({type(kind).__name__}(...), "
            f"{type(given.error).__name__}(...)))",
            argument="instrument",
            value=instrument,
        )
    return given.error


def takes_instrument_of_data(function: Callable[P, R]) -> Callable[P, R]:
    """:func:`takes_instrument` of a function whose data carry their kind: pincal 0.1's error
    model alone keeps working, with a warning (:func:`error_model_alone`)."""
    return moved_keywords((), error_model_alone, OLD_FORM)(function)
