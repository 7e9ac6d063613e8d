"""pincal robots: the robots pincal can load by name."""

from __future__ import annotations

import argparse

from pincal.cli._common import add_output_arguments, emit_json
from pincal.model.robot import example_robot_data_names, shipped_robots

HELP = "list the robots loadable by name (shipped URDFs and example-robot-data)"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("robots", help=HELP, description=HELP + ".")
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    shipped = {name: str(path) for name, path in shipped_robots().items()}
    erd = example_robot_data_names()
    if args.json:
        emit_json({"shipped": shipped, "example_robot_data": erd})
        return 0
    print("shipped with pincal:")
    for name, path in shipped.items():
        print(f"  {name:12s} {path}")
    print("example-robot-data (fixed-base arms calibrate; give --tip for robots with grippers):")
    print("  " + ", ".join(erd))
    return 0
