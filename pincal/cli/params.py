"""pincal params: the parameters of a robot and which are identifiable."""

from __future__ import annotations

import argparse

from pincal.arguments import DEFAULT_SIGMA, positive_sigma
from pincal.calibration.measurements import MeasurementData
from pincal.cli import COMMANDS
from pincal.cli._common import (
    CONDITIONING_HELP,
    add_command,
    add_output_arguments,
    add_robot_arguments,
    emit_json,
    parse_floats,
    read_plan,
    robot_from_args,
)
from pincal.cli._instrument import (
    INSTRUMENT_HELP,
    add_instrument_arguments,
    instrument_from_args,
    kind_from_args,
    rig_from_args,
    robot_with_fixtures,
)
from pincal.cli._parameters import DEFAULT_PARAMS, add_base_argument, mentions_base
from pincal.cli._types import seed_type, sigma_type
from pincal.evaluation.data_check import check_plan
from pincal.instruments.identifiability import identifiable
from pincal.planning.plan import Plan

HELP = COMMANDS["params"].help
EXAMPLES = """\
examples:
  pincal params kr270                               # full,offsets on the flange centre
  pincal params kr270 --marker 0.1,0.05,0.2 --params full
  pincal params ur10 --params lengths,offsets --json
  pincal params kr270 --marker 0.1,0.05,0.2 --base  # the set 'identify --base' uses on tracker data
  pincal params kr270 --marker 0.1,0.05,0.2 --data meas.csv --deg   # can YOUR data identify them?
  pincal params kr270 --marker 0.1,0.05,0.2 --plan plan.csv --deg --sigma 3e-5
  pincal params kr270 --marker 0.1,0.05,0.2 --params lengths,offsets,gains,compliance --payloads 0,135,270
  pincal params kr270 --measure pose                 # a pose sees joint_a6.offset, a point there not
  pincal params ur10 --measure z                     # a height gauge
  pincal params ur10 --anchor 1,1,0 --anchor -1,1.5,0.5 --anchor 1.5,-1,1   # three draw-wires
  pincal params panda --camera rig.yaml              # a camera on the hand seeing a grid

With --data or --plan, the identifiable set is also checked on those configurations (what identify
does first): rank and conditioning, the weakest combinations, and the parameters they cannot
determine to 1 cm / 10 mrad for the noise --sigma (default 3e-5 m).

{conditioning}

Names: <joint>.tx|ty|tz (origin xyz error, parent link coordinates, m), <joint>.rx|ry|rz (rotation
about the joint frame's axes, rad), <joint>.offset, <tip>.tx..rz, marker<k>.x|y|z, base.tx..rz.
<joint>.gain (the joint moves by q(1+gain)), <joint>.compliance (it yields by compliance x the
gravity torque on it, rad/(N m) or m/N; the URDF must give the links' masses).
Compliance shows only through the gravity torques: a joint gravity never loads (a vertical axis) is
dropped as invisible, and under the arm's own weight alone a compliance correlates with the link
lengths; the report gives each compliance's separation (near 0: it cannot be told apart), and with
--payloads the separation a payload change buys (design --payloads chooses them).
Groups: offsets, lengths, full, base, markers, gains, compliance, instrument (the fixtures of
--anchor and --camera: anchor.x|y|z, camera.tx..rz, target.tx..rz; added to --params unless it
names them); mix them and names with commas.

{instrument}
"""
EXAMPLES = EXAMPLES.replace("{conditioning}", CONDITIONING_HELP)
EXAMPLES = EXAMPLES.replace("{instrument}", INSTRUMENT_HELP)


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
    p.add_argument(
        "--seed", type=seed_type(), default=0, help="seed of the random configurations (default 0)"
    )
    source = p.add_mutually_exclusive_group()
    source.add_argument("--data", metavar="MEAS.csv", help="check identifiability on these measurements")
    source.add_argument("--plan", metavar="PLAN.csv", help="check identifiability on these configurations")
    p.add_argument(
        "--payloads",
        metavar="KG,KG,...",
        help="with compliance parameters: the payloads you can mount; the report gives each compliance's "
        "separation with them",
    )
    p.add_argument("--deg", action="store_true", help="joint values of --data/--plan are in degrees")
    p.add_argument("--mm", action="store_true", help="coordinates of --data are in millimetres")
    p.add_argument(
        "--sigma",
        type=sigma_type(),
        help=f"noise per coordinate [m] for the check (default {DEFAULT_SIGMA:g})",
    )
    add_instrument_arguments(p)
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    robot = robot_with_fixtures(robot_from_args(args), args)
    sigma = None if args.sigma is None else positive_sigma(args.sigma, "--sigma")
    kind = kind_from_args(args, robot)
    data = None
    if args.data:
        rig = rig_from_args(args)
        given = kind if args.measure else rig.kind if rig else None  # else the columns say
        data = MeasurementData.from_csv(args.data, robot, degrees=args.deg, millimetres=args.mm, kind=given)
        kind = data.measure if kind is None else kind
    instrument = instrument_from_args(args, kind, sigma)
    spec = args.params + (",base" if args.base and not mentions_base(args.params) else "")
    if robot.fixtures and "instrument" not in spec:
        spec += ",instrument"
    params = robot.parameters(spec)
    # With the base, it is kept first: the chain parameters it makes redundant are the ones dropped.
    payloads = None if args.payloads is None else parse_floats(args.payloads, "--payloads")
    prefer = "base" if mentions_base(spec) else ()
    if instrument.is_default:
        ident = params.identifiable(seed=args.seed, prefer=prefer, payloads=payloads)
    else:
        ident = identifiable(params, instrument, seed=args.seed, prefer=prefer, payloads=payloads)
    check = None
    if args.data or args.plan:
        if data is not None:
            configurations = Plan.for_robot(robot, data.q, data.payload)  # under the payloads carried
        else:
            configurations = read_plan(robot, args.plan, args.deg)
        check = check_plan(ident.identifiable, configurations, instrument=instrument)
    if args.json:
        emit_json(
            {
                "robot": robot.name,
                "tip": robot.tip,
                "joints": list(robot.joint_names),
                "markers": robot.markers.tolist(),
                **({} if instrument.is_default else {"instrument": instrument.as_dict()}),
                "params": list(params.names),
                "units": dict(zip(params.names, params.units)),
                "identifiable": list(ident.identifiable.names),
                "rank": ident.rank,
                "dropped": ident.dropped,
                "combinations": ident.combinations,
                "data_check": check.as_dict() if check is not None else None,
                "compliance_separation": ident.separation,
                "compliance_separation_with_payloads": ident.separation_with_payloads,
            }
        )
        return 0
    joints = ", ".join(robot.joint_names)
    print(f"{robot.name}: joints {joints}; tip {robot.tip}; markers {robot.markers.tolist()}")
    print(ident.report())
    if check is not None:
        print(f"on the configurations of {args.data or args.plan}:")
        print(check.report())
    return 0
