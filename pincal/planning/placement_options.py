"""What each position's design in :func:`pincal.planning.placement.place_instrument` is given: the
instrument placed (checked once, at the door: :func:`~pincal.instruments.given.measured`) and the
design's options, in :class:`~pincal.Search`, :class:`~pincal.Safety` and :class:`~pincal.Loads`."""

from __future__ import annotations

from dataclasses import fields

from pincal.errors import BadArgument
from pincal.instruments.error_model import ErrorModel, PerCoordinate, Tracker
from pincal.instruments.given import measured, old_instrument
from pincal.instruments.image import Image
from pincal.instruments.instrument import Instrument
from pincal.instruments.point import Point
from pincal.planning.options import Loads, Safety, Search


def placed_instrument(instrument: object, sigma: object) -> Instrument:
    """The instrument placed, checked at the door (:func:`~pincal.instruments.given.measured`):
    points with a tracker of pincal's defaults when none is given.

    Raises:
        BadArgument: ``sigma`` given (the instrument placed has its own error model), or not an
            Instrument.
    """
    if sigma is not None:
        raise BadArgument(
            "place_instrument places an instrument with its own error model: give instrument=, not sigma=",
            argument="sigma",
        )
    given, _ = measured(instrument)
    return Instrument(Point(), Tracker()) if given is None else given


def placed_tracker(error: ErrorModel) -> Tracker:
    """The tracker placed."""
    if not isinstance(error, Tracker):
        raise BadArgument(
            "place_instrument places a laser tracker (instrument=pincal.instruments.Instrument(kind, "
            "pincal.instruments.Tracker(...))) or a camera"
        )
    return error


def old_placed(flat: dict, kwargs: dict) -> tuple[dict, str]:
    """:func:`~pincal.instruments.given.old_instrument` of :func:`place_instrument`, whose default
    error model is a tracker's for points and poses (a camera's, one σ per coordinate)."""
    kind, error = flat.get("measure"), kwargs.get("instrument")
    if ("measure" not in flat and not isinstance(error, ErrorModel)) or error is not None:
        return old_instrument(flat, kwargs)
    if not isinstance(kind, Image):
        error = Tracker()
    elif kwargs.get("sigma") is not None:  # pincal 0.1 measured a camera with sigma= per length
        error = PerCoordinate(kwargs["sigma"])
    out = {k: v for k, v in kwargs.items() if k != "sigma"}
    if error is None:
        return old_instrument(flat, out)
    return old_instrument(flat, dict(out, instrument=error))


FULL_ONLY = frozenset(
    ("pool", "starts", "workers", "polish", "executor", "init", "method", "keep", "screen_iterations",
     "maxiter", "with_d_optimal", "progress")
)  # fmt: skip
"""The options of :func:`pincal.design` that the full designs take and the screen's quick designs
do not (they run :data:`~pincal.planning.placement.SCREEN_STARTS` exchange starts over the shared
pool, in this process)."""


def design_values(options: dict) -> dict:
    """:func:`pincal.design`'s keywords for a position's design: ``options`` (design's flat options
    of pincal 0.1, as :func:`place_instrument` takes them) in the values they belong to."""
    out = {k: v for k, v in options.items() if k not in OF_VALUES}
    for name, kind in (("search", Search), ("safety", Safety), ("loads", Loads)):
        given = {f.name: options[f.name] for f in fields(kind) if f.name in options}
        if given:
            out[name] = kind(**given)
    return out


OF_VALUES = frozenset(f.name for kind in (Search, Safety, Loads) for f in fields(kind))
"""The options of a design that belong to :class:`~pincal.Search`, :class:`~pincal.Safety` or
:class:`~pincal.Loads`."""
