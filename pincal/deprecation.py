"""What pincal 0.2 deprecates, and until when: names moved out of the top level (see
``pincal/__init__.py``), names moved from one module to another (:func:`moved_from`; a whole
module moved to another stage: :func:`moved_module`), arguments passed
by position after a function's first few (:func:`keywords_after`) and flat keywords now grouped
into values (:func:`moved_keywords`, e.g. :func:`pincal.design`'s ``starts=`` into
``search=pincal.Search(starts=...)``; ``measure=`` and an error model as ``instrument=`` into one
:class:`~pincal.instruments.Instrument`, :mod:`pincal.instruments.given`). All keep working, with
a DeprecationWarning naming what to write instead, until pincal :data:`REMOVAL`.

Imports nothing but the standard library: ``import pincal`` reads :data:`REMOVAL`.

A keyword renamed so that one name means one thing across pincal (:func:`renamed_keyword`, e.g.
:func:`pincal.compensate`'s ``seed=``, a starting configuration, into ``start=``: ``seed=`` is a
random seed everywhere else) keeps working the same way.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import sys
import warnings
from collections.abc import Callable, Collection, Sequence
from typing import Any, ParamSpec, TypeVar

__all__ = ["REMOVAL", "keywords_after", "moved_from", "moved_keywords", "moved_module", "renamed_keyword"]

REMOVAL = "0.3"
"""The release that removes what 0.2 deprecates."""

P = ParamSpec("P")
R = TypeVar("R")


def keywords_after(n: int, names: Sequence[str] = ()) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Make the decorated function's arguments after its first ``n`` keyword-only, as its
    signature (with ``*``) says, while a call passing them by position, as pincal 0.1 allowed,
    still works until pincal :data:`REMOVAL`, with a DeprecationWarning at the caller's line naming
    the keywords to write. Type checkers read the keyword-only signature.

    Args:
        n: the arguments that stay positional (the function's first ``n``, before its ``*``).
        names: the keywords the arguments after the first ``n`` stood for in pincal 0.1, in order,
            when they are not the signature's (keywords since grouped: :func:`moved_keywords`).
    """

    def decorate(function: Callable[P, R]) -> Callable[P, R]:
        parameters = inspect.signature(function).parameters.values()
        positional = [p.name for p in parameters if p.kind is p.POSITIONAL_OR_KEYWORD]
        if len(positional) != n:
            raise TypeError(f"{function.__name__} has {len(positional)} positional arguments, not {n}")
        keywords = list(names) or [p.name for p in parameters if p.kind is p.KEYWORD_ONLY]

        @functools.wraps(function)
        def call(*args: P.args, **kwargs: P.kwargs) -> R:
            if len(args) <= n:
                return function(*args, **kwargs)
            extra = args[n:]
            if len(extra) > len(keywords):
                raise TypeError(
                    f"{function.__name__}() takes {n} positional arguments, then keywords "
                    f"({', '.join(keywords)}), but {len(args)} were given"
                )
            moved = dict(zip(keywords, extra))
            twice = sorted(moved.keys() & kwargs.keys())
            if twice:
                raise TypeError(f"{function.__name__}() got multiple values for argument {twice[0]!r}")
            warnings.warn(
                f"{function.__name__}(): passing {', '.join(moved)} by position is deprecated: write "
                f"{', '.join(f'{name}=...' for name in moved)} (pincal's arguments after the first "
                f"{n} are keyword-only; by position stops working in pincal {REMOVAL})",
                DeprecationWarning,
                stacklevel=2,
            )
            return function(*args[:n], **moved, **kwargs)  # type: ignore[arg-type]

        return call

    return decorate


def moved_from(module: str, homes: dict[str, tuple[str, ...]]) -> Callable[[str], Any]:
    """A module ``__getattr__`` (PEP 562) for names that moved out of ``module`` into other modules:
    ``module.name`` is still the new home's until pincal :data:`REMOVAL`, with a DeprecationWarning
    at the caller's line naming the new home (none for the import machinery's own look-ups); any
    other name is an AttributeError.

    Args:
        module: the module the names moved from (its ``__name__``).
        homes: each module now defining moved names, and those names.
    """
    home_of = {name: home for home, names in homes.items() for name in names}

    def __getattr__(name: str) -> Any:
        home = home_of.get(name)
        if home is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home), name)
        if not sys._getframe(1).f_code.co_filename.startswith("<frozen importlib"):
            warnings.warn(
                f"{module}.{name} moved: import it from {home} (use {home}.{name}; {module}.{name} "
                f"stops working in pincal {REMOVAL})",
                DeprecationWarning,
                stacklevel=2,
            )
        return value

    return __getattr__


def moved_module(old: str, new: str, names: tuple[str, ...]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of a module moved from ``old`` to ``new`` (:func:`moved_from` with
    one home): usage, as the whole of the old module: ``__getattr__ = moved_module(__name__,
    "pincal.x.y", ("A", "b"))``."""
    return moved_from(old, {new: names})


Regroup = Callable[[dict, dict], tuple[dict, str]]
"""(the flat keywords given, every other argument by name, those given by position included) ->
(the keywords to call with, what to write instead: "" when nothing given is deprecated)."""

GROUPED = (
    "{function}(): the flat keywords are deprecated: write {hint} (grouped in pincal 0.2; the flat "
    "keywords stop working in pincal {removal})"
)
"""The warning of :func:`moved_keywords` for flat keywords now grouped into values."""


def moved_keywords(
    names: Collection[str], regroup: Regroup, message: str = GROUPED
) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Let the decorated function take, until pincal :data:`REMOVAL`, the flat keywords ``names`` of
    pincal 0.1 that its signature now groups into values (or replaces by another keyword's
    value): ``regroup`` turns them (and any other argument given in an old form) into today's
    keywords and says what to write, which a DeprecationWarning at the caller's line repeats
    (``message``, with ``{function}``, ``{hint}`` and ``{removal}``). Type checkers and help() read
    today's signature.

    Args:
        names: the flat keywords no longer in the signature.
        regroup: see :data:`Regroup`; it sees the function's positional arguments by name (a
            ``sigma`` given by position), and raises TypeError for a flat keyword given with its
            value.
        message: the warning (default :data:`GROUPED`).
    """
    flat_names = frozenset(names)

    def decorate(function: Callable[P, R]) -> Callable[P, R]:
        parameters = inspect.signature(function).parameters.values()
        positional = [p.name for p in parameters if p.kind is p.POSITIONAL_OR_KEYWORD]

        @functools.wraps(function)
        def call(*args: P.args, **kwargs: P.kwargs) -> R:
            flat = {name: kwargs.pop(name) for name in list(kwargs) if name in flat_names}
            named = dict(zip(positional, args))
            twice = sorted(named.keys() & kwargs.keys())
            if twice:
                raise TypeError(f"{function.__name__}() got multiple values for argument {twice[0]!r}")
            new, hint = regroup(flat, {**named, **kwargs})
            if hint:
                warnings.warn(
                    message.format(function=function.__name__, hint=hint, removal=REMOVAL),
                    DeprecationWarning,
                    stacklevel=_caller(),
                )
            return function(*args[len(named) :], **new)  # type: ignore[arg-type]

        return call

    return decorate


def _caller() -> int:
    """The stack level of the caller of a deprecated call: past this module's own wrappers (a
    :func:`moved_keywords` call may be wrapped by :func:`keywords_after`)."""
    frame, level = inspect.currentframe(), 1
    while frame is not None and frame.f_code.co_filename == __file__:
        frame, level = frame.f_back, level + 1
    return level - 1


def renamed_keyword(
    old: str,
    new: str,
    why: str,
    old_form: Callable[[Any], bool] | None = None,
    what: str = "",
    name: str | None = None,
) -> Callable[[Callable[P, R]], Callable[P, R]]:
    """Let the decorated function take, until pincal :data:`REMOVAL`, its keyword ``new`` under the
    name ``old`` of pincal 0.1, with a DeprecationWarning at the caller's line saying why it was
    renamed. Type checkers and help() read today's signature.

    Args:
        old: the keyword's name in pincal 0.1.
        new: its name today.
        why: why it was renamed (what ``old`` means elsewhere in pincal), for the warning.
        old_form: when ``old`` is still a keyword of the function, with another meaning: which of
            its values are of the 0.1 meaning (those are moved to ``new``); None: every value.
        what: the 0.1 meaning in words, for the warning (``" as a position"``).
        name: the function's name in the warning (default its ``__name__``; a class's for its
            ``__init__``).
    """

    def decorate(function: Callable[P, R]) -> Callable[P, R]:
        called = name or function.__name__

        @functools.wraps(function)
        def call(*args: P.args, **kwargs: P.kwargs) -> R:
            if old in kwargs and (old_form is None or old_form(kwargs[old])):
                if new in kwargs:
                    raise TypeError(f"{called}() got {old}={what} and {new}=: give {new}= only")
                kwargs[new] = kwargs.pop(old)
                warnings.warn(
                    f"{called}(): {old}={what} is renamed {new}= ({why}): write {new}=... "
                    f"({old}={what} stops working in pincal {REMOVAL})",
                    DeprecationWarning,
                    stacklevel=_caller(),
                )
            return function(*args, **kwargs)

        return call

    return decorate
