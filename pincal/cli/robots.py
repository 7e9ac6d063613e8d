"""pincal robots: the robots pincal can load by name, and the chains each offers."""

from __future__ import annotations

import argparse
import warnings

from pincal.cli import COMMANDS
from pincal.cli._common import add_command, add_output_arguments, emit_json, joint_ranges_from_args
from pincal.errors import PincalError, PincalWarning
from pincal.model.dh import shipped_dh_tables
from pincal.model.loading import chain_ends, example_robot_data_names, load_robot, shipped_robots

HELP = COMMANDS["robots"].help
EXAMPLES = """\
examples:
  pincal robots                        # every robot: its default chain, or the tips to choose from
  pincal robots talos                  # the chain ends of one robot (or URDF file)
  pincal robots talos --root torso_2_link
  pincal params talos --root torso_2_link --tip gripper_left_base_link

A robot with several chain ends needs --tip FRAME; --root LINK starts the chain below the URDF's
root (the link held fixed in front of the instrument; a floating base is held at its root link).
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "robots", HELP, EXAMPLES)
    p.add_argument("robot", nargs="?", metavar="ROBOT", help="one robot (name or URDF path) to describe")
    p.add_argument(
        "--root", metavar="LINK", help="start the chains at this link (see 'pincal params --help')"
    )
    p.add_argument("--joint-range", action="append", metavar="NAME=LO,HI", help="as for 'pincal params'")
    add_output_arguments(p)
    p.set_defaults(run=run)


def _summary(name: str, root: str | None = None, ranges: dict | None = None) -> dict:
    try:
        ends = chain_ends(name, root=root, joint_ranges=ranges)
        if ends.default is not None:  # the default chain must load (zero-range joints, ...)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", PincalWarning)
                load_robot(name, root=root, joint_ranges=ranges)
    except PincalError as exc:
        return {"loadable": False, "reason": str(exc), "text": f"cannot load: {exc}"}
    return {
        "loadable": True,
        "floating": ends.floating,
        "root": ends.root,
        "default_tip": ends.default,
        "tips": [
            {"frame": c.frame, "joints": c.joints, "finger": c.finger, "hand": list(c.hand)}
            for c in ends.candidates
        ],
        "text": ends.describe(),
    }


def run(args: argparse.Namespace) -> int:
    if args.robot:
        ends = chain_ends(args.robot, root=args.root, joint_ranges=joint_ranges_from_args(args))
        summary = _summary(args.robot, args.root, joint_ranges_from_args(args))
        if args.json:
            summary.pop("text")
            emit_json({"robot": ends.name, **summary})
            return 0
        print(f"{ends.name}: {'floating base, ' if ends.floating else ''}chains from {ends.root}")
        for c in ends.candidates:
            mark = "  (default)" if c.frame == ends.default else ""
            print(f"  --tip {c.describe()}{mark}")
        if ends.default is None and ends.candidates:
            print("several chain ends: give --tip FRAME")
        return 0
    shipped = {name: str(path) for name, path in shipped_robots().items()}
    tables = {name: str(path) for name, path in shipped_dh_tables().items()}
    erd = example_robot_data_names()
    chains = {name: _summary(name) for name in [*shipped, *erd]}
    if args.json:
        for value in chains.values():
            value.pop("text")
        emit_json({"shipped": shipped, "example_robot_data": erd, "chains": chains, "dh_tables": tables})
        return 0
    print("shipped with pincal:")
    for name, path in shipped.items():
        print(f"  {name:26s} {chains[name]['text']}  [{path}]")
    print("DH tables shipped with pincal ('pincal urdf-from-dh NAME --out NAME.urdf' writes the URDF):")
    for name, path in tables.items():
        print(f"  {name:26s} [{path}]")
    print("example-robot-data ('pincal robots NAME' lists a robot's chain ends):")
    for name in erd:
        print(f"  {name:26s} {chains[name]['text']}")
    return 0
