"""pincal params: the parameters of a robot and which are identifiable."""

from __future__ import annotations

import argparse

from pincal.cli._common import (
    DEFAULT_PARAMS,
    add_base_argument,
    add_command,
    add_output_arguments,
    add_robot_arguments,
    emit_json,
    mentions_base,
    robot_from_args,
)

HELP = "list geometric parameters and report which are identifiable, and why not"
EXAMPLES = """\
examples:
  pincal params kr270                               # full,offsets on the flange centre
  pincal params kr270 --marker 0.1,0.05,0.2 --params full
  pincal params ur10 --params lengths,offsets --json
  pincal params kr270 --marker 0.1,0.05,0.2 --base  # the set 'identify --base' uses on tracker data

Names: <joint>.tx|ty|tz (origin xyz error, parent link coordinates, m), <joint>.rx|ry|rz (rotation
about the joint frame's axes, rad), <joint>.offset, <tip>.tx..rz, marker<k>.x|y|z, base.tx..rz.
Groups: offsets, lengths, full, base, markers; mix them and names with commas.
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "params", HELP, EXAMPLES)
    add_robot_arguments(p, params=False)
    p.add_argument(
        "--params",
        metavar="SPEC",
        default=DEFAULT_PARAMS,
        help=f"parameters to examine (default {DEFAULT_PARAMS})",
    )
    add_base_argument(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the random configurations (default 0)")
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    robot = robot_from_args(args)
    spec = args.params + (",base" if args.base and not mentions_base(args.params) else "")
    params = robot.parameters(spec)
    # With the base, it is kept first: the chain parameters it makes redundant are the ones dropped.
    ident = params.identifiable(seed=args.seed, prefer="base" if mentions_base(spec) else ())
    if args.json:
        emit_json(
            {
                "robot": robot.name,
                "tip": robot.tip,
                "joints": list(robot.joint_names),
                "markers": robot.markers.tolist(),
                "params": list(params.names),
                "units": dict(zip(params.names, params.units)),
                "identifiable": list(ident.identifiable.names),
                "rank": ident.rank,
                "dropped": ident.dropped,
                "combinations": ident.combinations,
            }
        )
        return 0
    joints = ", ".join(robot.joint_names)
    print(f"{robot.name}: joints {joints}; tip {robot.tip}; markers {robot.markers.tolist()}")
    print(ident.report())
    return 0
