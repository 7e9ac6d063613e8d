"""The parameter set a command asks for (--params, --base): the identifiable part of what is
named, the base and the instrument's fixtures added as the data need."""

from __future__ import annotations

import argparse

from pincal.errors import BadArgument
from pincal.instruments.identifiability import identifiable
from pincal.instruments.instrument import Instrument
from pincal.model.base_parameters import Identifiability
from pincal.model.catalogue import GROUPS
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot

DEFAULT_PARAMS = "full,offsets"
"""The parameters a command examines or identifies without --params (their identifiable part)."""


BASE_HELP = (
    "the points are measured in the instrument's frame: the robot base (base.*) is identified too, "
    "and the chain parameters it makes redundant are dropped (the set 'pincal identify --base' uses)"
)


def add_base_argument(parser: argparse.ArgumentParser) -> None:
    """--base: add base.* to the parameters (read by :func:`params_from_args`)."""
    parser.add_argument("--base", action="store_true", help=BASE_HELP)


def _is_base(token: str) -> bool:
    return token == "base" or token.startswith("base.")


def mentions_base(spec: str | None) -> bool:
    """True when a --params SPEC names the base group or a base.* parameter."""
    return any(_is_base(t.strip()) for t in (spec or "").split(","))


def params_from_args(
    robot: Robot, args: argparse.Namespace, instrument: Instrument | None = None
) -> tuple[ParameterSet, str]:
    """The parameter set asked for, and a description of where it came from (see
    :func:`parameters_with_base`)."""
    params, source, _ = parameters_with_base(robot, args, instrument)
    return params, source


def _identifiable(params: ParameterSet, instrument: Instrument | None, prefer: str = "") -> Identifiability:
    """What the instrument (points when None) can identify of ``params``."""
    if instrument is None or instrument.is_default:
        return params.identifiable(prefer=prefer)
    return identifiable(params, instrument, prefer=prefer)


def _with_fixtures(robot: Robot, spec: str) -> str:
    """``spec`` and the instrument's fixtures (identified with the robot) when it names none."""
    names = ["instrument"] + [f.name for f in robot.fixtures]
    tokens = [t.strip().split(".")[0] for t in spec.split(",")]
    if not robot.fixtures or any(t in names for t in tokens):
        return spec
    return spec + ",instrument"


def parameters_with_base(
    robot: Robot, args: argparse.Namespace, instrument: Instrument | None = None
) -> tuple[ParameterSet, str, list[str]]:
    """The set asked for, plus base.* when the data are in the instrument's frame (docs/method.md
    §4.2).

    Without --params: the identifiable base set of ``full,offsets``. With --params: a group means
    its identifiable part (the description names how many were left out and why), a parameter
    named one by one must be identifiable (the error names it and the fix). ``--params base`` is
    the base placement alone (and ``markers`` the markers alone: every group means itself only).
    With --base, or base names beside chain ones in --params: the chain set plus the whole base,
    the base kept first and the chain parameters it makes redundant dropped — the set identify
    uses on instrument-frame data. The instrument's fixtures (--anchor, --camera) are added unless
    --params names them, and what is identifiable is what ``instrument`` measures (points when
    None).

    Returns:
        (parameters, description, chain parameters dropped as redundant with the base).
    """
    spec = getattr(args, "params", None)
    tokens = [t.strip() for t in (spec or "").split(",") if t.strip()]
    if not (getattr(args, "base", False) or mentions_base(spec)):
        return _chain_params(robot, spec, args.robot, instrument) + ([],)
    rest = ",".join(t for t in tokens if not _is_base(t)) or None
    if spec is not None and rest is None:  # the base placement alone
        params, source = _reduced(robot, spec, args.robot, instrument, prefer="base")
        return params, f"{source}: the base placement only", []
    chain, source = _chain_params(robot, rest, args.robot, instrument)
    params = _identifiable(robot.parameters(list(chain.names) + ["base"]), instrument, "base").identifiable
    dropped = [n for n in chain.names if n not in params.names]
    note = f"; {len(dropped)} chain parameter(s) redundant with it dropped" if dropped else ""
    return params, f"{source}, with the base frame{note}", dropped


def _chain_params(
    robot: Robot, spec: str | None, robot_arg: str, instrument: Instrument | None = None
) -> tuple[ParameterSet, str]:
    if spec is None:
        default = _with_fixtures(robot, DEFAULT_PARAMS)
        ident = _identifiable(robot.parameters(default), instrument)
        return ident.identifiable, f"identifiable base set of {default}"
    return _reduced(robot, spec, robot_arg, instrument)


def _reduced(
    robot: Robot, spec: str, robot_arg: str, instrument: Instrument | None, prefer: str = ""
) -> tuple[ParameterSet, str]:
    """The identifiable part of --params ``spec`` (its groups reduced, the instrument's fixtures
    added unless named) and its description; a parameter named one by one and not identifiable is
    refused, naming why."""
    params = robot.parameters(_with_fixtures(robot, spec))
    ident = _identifiable(params, instrument, prefer)
    groups = set(GROUPS) | {f.name for f in robot.fixtures}
    named = [n for n in ident.dropped if n in {t.strip() for t in spec.split(",")} - groups]
    if named:
        reason = ident.dropped[named[0]].split(":")[0]
        raise BadArgument(
            f"--params {spec}: {', '.join(named)} cannot be identified from {ident.measured} measurements "
            f"({named[0]} is {reason}); leave {'them' if len(named) > 1 else 'it'} out, or name "
            f"{'their' if len(named) > 1 else 'its'} group to take the identifiable part of it "
            f"(see 'pincal params {robot_arg}')"
        )
    if not ident.dropped:
        return params, spec
    why: dict[str, int] = {}
    for reason in ident.dropped.values():
        word = reason.split(":")[0]
        why[word] = why.get(word, 0) + 1
    said = ", ".join(f"{k} {word}" for word, k in why.items())
    return ident.identifiable, (
        f"the identifiable part of {spec}: {len(ident.dropped)} of {len(params)} left out ({said}; "
        f"'pincal params {robot_arg} --params {spec}' names them)"
    )
