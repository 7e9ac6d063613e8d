"""pincal example: the input files the README and the --help examples use, shipped with pincal."""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from typing import NamedTuple

from pincal.cli import COMMANDS
from pincal.cli._common import add_command, add_output_arguments, emit_json
from pincal.errors import BadArgument
from pincal.model.dh import shipped_dh_tables
from pincal.outputs import atomic_write_text

HELP = COMMANDS["example"].help


class Example(NamedTuple):
    """One shipped input file: where it is (a file of pincal.examples, or a shipped DH table by
    name), its usual file name, what it holds."""

    package: str
    resource: str
    file: str
    what: str

    def text(self) -> str:
        if self.package == "dh":
            return shipped_dh_tables()[self.resource].read_text(encoding="utf-8")
        return resources.files(self.package).joinpath(self.resource).read_text(encoding="utf-8")


EXAMPLES_SHIPPED: dict[str, Example] = {
    "rig": Example(
        "pincal.examples",
        "rig.yaml",
        "rig.yaml",
        "a camera rig: an eye-in-hand camera and a checkerboard (--camera)",
    ),
    "cell": Example(
        "pincal.examples",
        "cell.yaml",
        "cell.yaml",
        "a workcell: a table, a column and a fixture mesh (--constraints)",
    ),
    "fixture": Example(
        "pincal.examples",
        "fixture.stl",
        "fixture.stl",
        "the fixture mesh cell.yaml names (ASCII STL, millimetres)",
    ),
    "program": Example(
        "pincal.examples",
        "program.csv",
        "program.csv",
        "a KR 270 program's joint targets, degrees (compensate --targets)",
    ),
    "points": Example(
        "pincal.examples",
        "points.csv",
        "points.csv",
        "KR 270 Cartesian targets x,y,z in the base frame, metres (compensate --targets)",
    ),
    "weld": Example(
        "pincal.examples", "weld.csv", "weld.csv", "a KR 270 test path (a seam), degrees (--test-path)"
    ),
    "taught": Example(
        "pincal.examples", "taught.csv", "taught.csv", "60 taught UR10 poses, radians (--pool)"
    ),
    "cycles": Example(
        "pincal.examples",
        "cycles.csv",
        "cycles.csv",
        "an ISO 9283 test: P1-P5 measured in 10 cycles, mm and degrees (iso9283 --data)",
    ),
    "iso_cubes": Example(
        "pincal.examples",
        "iso_cubes.csv",
        "measurements_iso_cubes.csv",
        "ISO cubes of the public IPA UR10 set, a slice (MIT: pincal/examples/ipa_ur10.LICENSE.md) (iso9283)",
    ),
    "ipa_random": Example(
        "pincal.examples",
        "ipa_random.csv",
        "ipa_random.csv",
        "600 random poses of a real UR10 measured by a laser tracker (IPA set, series C; MIT) (notebook 06)",
    ),
    "table": Example("dh", "ur5_dh", "table.yaml", "a DH table: Universal Robots' UR5 (urdf-from-dh)"),
}
"""Every example by name (what ``pincal example NAME`` prints)."""

EXAMPLES = f"""\
examples:
  pincal example                          # the list
  pincal example rig > rig.yaml           # one example on stdout
  pincal example cell --out cell.yaml     # or written to a file
  pincal example fixture --out fixture.stl

The examples ({", ".join(EXAMPLES_SHIPPED)}) are the input files the README and the commands'
--help examples use, under the file names they use: write one, read it, change it for your robot.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "example", HELP, EXAMPLES)
    p.add_argument("name", nargs="?", metavar="NAME", help="the example: " + ", ".join(EXAMPLES_SHIPPED))
    p.add_argument("--out", metavar="FILE", help="write it here (default: print it)")
    add_output_arguments(p)
    p.set_defaults(run=run)


def example_text(name: str) -> str:
    """The text of the shipped example ``name``."""
    if name not in EXAMPLES_SHIPPED:
        raise BadArgument(f"unknown example {name!r}; valid: {', '.join(EXAMPLES_SHIPPED)}")
    return EXAMPLES_SHIPPED[name].text()


def run(args: argparse.Namespace) -> int:
    if args.name is None:
        if args.json:
            emit_json({name: {"file": e.file, "what": e.what} for name, e in EXAMPLES_SHIPPED.items()})
            return 0
        width = max(len(n) for n in EXAMPLES_SHIPPED)
        for name, e in EXAMPLES_SHIPPED.items():
            print(f"{name:{width}s}  {e.file:12s}  {e.what}")
        print("write one: pincal example NAME --out FILE (or > FILE)")
        return 0
    text = example_text(args.name)
    if args.out:
        atomic_write_text(args.out, text)
    if args.json:
        emit_json(
            {"name": args.name, "file": EXAMPLES_SHIPPED[args.name].file, "out": args.out, "text": text}
        )
    elif args.out:
        print(f"wrote {args.out}: {EXAMPLES_SHIPPED[args.name].what}")
    else:
        sys.stdout.write(text)
    return 0
