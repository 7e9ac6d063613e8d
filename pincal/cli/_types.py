"""The argparse types of the CLI's options: the text read, then checked by the same
:mod:`pincal.arguments` checker as the API, under the option's name."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from pincal.arguments import positive_int, positive_sigma
from pincal.errors import BadArgument


def checked(option: str, check: Callable[..., object], parse: type = float, **bounds: object):
    """An argparse ``type=``: the option's text read as ``parse`` (int or float), then checked by
    ``check`` (a :mod:`pincal.arguments` checker, with ``bounds``) under the option's name, so that
    the CLI refuses a value where it is read with the same bounds and words as the API:
    ``pincal: error: argument --trials: must be an integer from 2 to 10,000,000, got 1``."""

    def convert(text: str) -> object:
        try:
            value = parse(text)
        except (ValueError, OverflowError):
            kind = "an integer" if parse is int else "a number"
            raise argparse.ArgumentTypeError(f"expected {kind}, got {text!r}") from None
        try:
            return check(value, option, **bounds)
        except BadArgument as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix(f"{option} ")) from None

    convert.__name__ = check.__name__
    convert.parses = parse  # type: ignore[attr-defined]  # what it reads (the fuzzer draws from it)
    return convert


def count(option: str, low: int = 1) -> Callable[[str], object]:
    """The argparse type of a count option (configurations, starts, trials, ...)."""
    return checked(option, positive_int, int, low=low)


def seed_type(option: str = "--seed") -> Callable[[str], object]:
    """The argparse type of --seed: an integer ≥ 0."""
    return checked(option, positive_int, int, low=0, high=None)


def sigma_type(option: str = "--sigma", zero: bool = False) -> Callable[[str], object]:
    """The argparse type of --sigma [m] (``zero``: 0 allowed, exact points)."""
    return checked(option, lambda v, name: positive_sigma(v, name, zero=zero))
