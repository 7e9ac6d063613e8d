"""pincal baseline: ρ0 over random feasible plans (and of the D-optimal plan), to compare designs to."""

from __future__ import annotations

import argparse

from pincal.cli import COMMANDS
from pincal.cli._accuracy import prior_from_args, test_region_from_args
from pincal.cli._common import (
    add_command,
    add_output_arguments,
    add_progress_argument,
    emit_json,
    read_plan,
    recorded_warnings,
    robot_from_args,
    sigma_from_args,
)
from pincal.cli._design_options import search_from_args
from pincal.cli._instrument import INSTRUMENT_HELP, add_instrument_arguments, measuring_from_args, with_sigma
from pincal.cli._parameters import params_from_args
from pincal.cli._safety import safe_constraints_from_args
from pincal.cli._types import count
from pincal.cli.design import add_design_arguments, print_baseline, print_warnings
from pincal.planning.baselines import random_plans
from pincal.planning.driver import METHODS, design
from pincal.planning.options import Safety

HELP = COMMANDS["baseline"].help
EXAMPLES = """\
examples:
  pincal baseline kr270 -m 12 --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2 --random 10000 \\
      --sigma 3e-5
  pincal baseline planar_2r -m 2 --test-pose=0.3,1.2 --params joint2.tx,tip.tx --random 1000 \\
      --d-optimal --json
  pincal baseline ur10 -m 12 --test-pose=0,-1.2,1.5,-1,-1.5,0 --pool taught.csv --random 5000 --d-optimal

Random plans: configurations drawn uniformly within the joint limits, kept if they satisfy
--constraints and the design's safe defaults (the joint margin, the floor, the robot clear of itself
when its URDF has collision geometry: --self-collision off when collisions are checked elsewhere);
with --pool, m distinct
configurations of the pool (plan CSV format, e.g. taught poses) per plan, and the D-optimal plan
is made of pool configurations too. Singular plans (no finite rho0) are counted, not averaged.
rho0 in metres for --sigma.

{instrument}
"""
EXAMPLES = EXAMPLES.replace("{instrument}", INSTRUMENT_HELP)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "baseline", HELP, EXAMPLES)
    add_design_arguments(p)
    p.add_argument(
        "--random", type=count("--random"), required=True, metavar="N", help="number of random plans"
    )
    p.add_argument(
        "--worst", action="store_true", help="with several test poses, the worst rho0, not the mean"
    )
    p.add_argument(
        "--d-optimal", action="store_true", help="also design the D-optimal plan and report its rho0"
    )
    p.add_argument(
        "--method",
        default="exchange",
        metavar="NAME",
        help=f"search for --d-optimal: {' or '.join(METHODS)}",
    )
    p.add_argument(
        "--starts", type=count("--starts"), default=8, help="starts of the --d-optimal search (default 8)"
    )
    p.add_argument(
        "--workers", type=count("--workers"), help="processes for the --d-optimal search (default: all CPUs)"
    )
    add_instrument_arguments(p, test_pose=True)
    add_progress_argument(p)
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    sigma, sigma_text = sigma_from_args(args)
    measuring = measuring_from_args(args, robot_from_args(args), sigma if args.sigma is not None else None)
    robot = measuring.robot
    sigma_text = measuring.text or sigma_text
    params, source = params_from_args(robot, args, measuring.instrument)
    q0 = test_region_from_args(robot, args)
    prior = prior_from_args(args)
    constraints = safe_constraints_from_args(robot, args)  # the design's safe defaults too
    criterion = "test-pose-worst" if args.worst else "test-pose"
    pool = read_plan(robot, args.pool, args.deg) if args.pool else None
    with recorded_warnings() as records:
        randoms = random_plans(
            params,
            args.m,
            args.random,
            q0,
            criterion=criterion,
            prior=prior,
            constraints=constraints,
            seed=args.seed,
            pool=pool,
            **with_sigma(sigma, measuring.options),
        )
        d_opt = None
        if args.d_optimal:
            d_opt = design(
                params,
                args.m,
                q0,
                criterion="D",
                prior=prior,
                search=search_from_args(args, pool),
                safety=Safety(constraints=constraints),
                **with_sigma(sigma, measuring.options),
            )
    print_warnings(records)
    if args.json:
        payload = {
            "robot": robot.name,
            "params": list(params.names),
            "params_source": source,
            "pool": args.pool,
            "random": randoms.as_dict(),
        }
        if d_opt is not None:
            payload["d_optimal"] = d_opt.rho0
            payload["d_optimal_plan"] = d_opt.plan.q.tolist()
        emit_json(payload)
        return 0
    print(f"{robot.name}: {len(params)} parameters ({source}), m = {args.m}, {sigma_text}")
    print_baseline(randoms, d_opt, pool=args.pool)
    return 0
