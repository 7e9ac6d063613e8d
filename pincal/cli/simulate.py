"""pincal simulate: Monte-Carlo check of a plan against the predicted ρ0."""

from __future__ import annotations

import argparse
from pathlib import Path

from pincal.calibration.monte_carlo import MonteCarloResult, monte_carlo
from pincal.calibration.synthetic import DEFAULT_ERROR_STD, error_std_pair
from pincal.cli import COMMANDS
from pincal.cli._accuracy import add_task_payload_arguments, task_payload_from_args
from pincal.cli._common import (
    SIGMA_HELP,
    add_command,
    add_output_arguments,
    add_progress_argument,
    add_robot_arguments,
    add_test_pose_argument,
    emit_json,
    fmt_length,
    parse_floats,
    read_plan,
    robot_from_args,
    sigma_from_args,
    test_poses_from_args,
)
from pincal.cli._instrument import INSTRUMENT_HELP, add_instrument_arguments, measuring_from_args, with_sigma
from pincal.cli._parameters import params_from_args
from pincal.cli._plot import add_simulation_plot_arguments, save_simulation_plot
from pincal.cli._types import count, seed_type, sigma_type
from pincal.errors import BadArgument
from pincal.typing import ConfigurationsLike

HELP = COMMANDS["simulate"].help
EXAMPLES = """\
examples:
  pincal simulate kr270 --plan plan.csv --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2
  pincal simulate kr270 --plan plan.csv --test-pose=0,-1.57,1.57,0,0.78,0 --marker 0.1,0.05,0.2 \\
      --trials 1000 --sigma 3e-5 --error-std 1e-3,1e-3 --seed 7 --json
  pincal simulate planar_2r --plan plan.csv --test-pose=0.3,1.2 --params joint2.tx,tip.tx --sigma 1e-4
  pincal simulate kr270 --plan designed.csv --compare random.csv --compare dopt.csv \
      --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2
  pincal simulate kr270 --plan loaded.csv --test-pose=0,-60,60,0,45,0 --deg --marker 0.1,0.05,0.2 \
      --params lengths,offsets,gains,compliance --task-payload 270 --payload-centre 0,0,0.25
  pincal simulate ur10 --plan plan.csv --test-pose=0,-1.2,1.5,-1,-1.5,0 --measure pose --sigma 1e-4 \
      --sigma-rot 2e-3 --trials 100                  # 6-D motion capture

Each trial draws a "true" robot with random errors of the parameters (Gaussian, std LEN metres for
lengths and ANG radians for angles; default 1e-3,1e-3), simulates measurements at the plan with
noise --sigma per coordinate (metres; default 3e-5, a laser tracker), identifies the parameters and
measures the remaining position error at the test pose(s). rho0_empirical (RMS of that error) must
match rho0_predicted within its statistical error when the errors are small; the report says how
nonlinearity shows when they are not. PLAN.csv: a header row of joint names, one configuration per
row, radians (degrees with --deg). --compare OTHER.csv (repeatable) simulates other plans (a random
one, a D-optimal one) with the same trials, errors, noise and seed, and reports their rho0 beside
this plan's (text, JSON 'compare', and --plot side by side).
A plan with payload columns (design --payloads) is measured under its payloads and the test pose(s)
under --task-payload KG (--payload-centre X,Y,Z in the tip frame); with gains or compliances among
--params the true robots carry random ones (gains 5e-4, compliances of about 1 mrad at each joint's
reference torque).
With --measure (and the instrument's
options below) the trials simulate and identify that instrument's data, its noise drawn from its
error model; the error at the test pose is still the markers' (with --orientation-length, plus L
times the tool's orientation error).

{instrument}
"""
EXAMPLES = EXAMPLES.replace("{instrument}", INSTRUMENT_HELP)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "simulate", HELP, EXAMPLES)
    add_robot_arguments(p)
    p.add_argument("--plan", required=True, metavar="PLAN.csv", help="the configurations to simulate")
    add_test_pose_argument(p)
    p.add_argument(
        "--trials", type=count("--trials", low=2), default=200, help="Monte-Carlo trials (default 200)"
    )
    p.add_argument("--sigma", type=sigma_type(), default=None, help=SIGMA_HELP)
    p.add_argument(
        "--error-std",
        metavar="LEN,ANG",
        default=f"{DEFAULT_ERROR_STD['length']:g},{DEFAULT_ERROR_STD['angle']:g}",
        help="std of the random geometric errors, metres and radians (default 1e-3,1e-3)",
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="random seed (default 0)")
    p.add_argument("--deg", action="store_true", help="plan and test poses are in degrees")
    add_task_payload_arguments(p)
    add_simulation_plot_arguments(p)
    add_instrument_arguments(p, test_pose=True)
    add_progress_argument(p)
    add_output_arguments(p)
    p.set_defaults(run=run)


def parse_error_std(text: str) -> dict[str, float]:
    """'LEN,ANG' (metres, radians) as the error_std of :func:`pincal.monte_carlo`."""
    values = parse_floats(text, "--error-std")
    if len(values) != 2:
        raise BadArgument(
            f"--error-std {text!r}: expected LEN,ANG, two non-negative numbers (metres, radians)"
        )
    length, angle = error_std_pair({"length": values[0], "angle": values[1]})
    return {"length": length, "angle": angle}


def run(args: argparse.Namespace) -> int:
    sigma, sigma_text = sigma_from_args(args)
    error_std = parse_error_std(args.error_std)
    measuring = measuring_from_args(args, robot_from_args(args), sigma if args.sigma is not None else None)
    robot = measuring.robot
    sigma_text = measuring.text or sigma_text
    params, source = params_from_args(robot, args, measuring.instrument)
    plan = read_plan(robot, args.plan, args.deg)
    others = [(path, read_plan(robot, path, args.deg)) for path in args.compare or ()]
    q0 = test_poses_from_args(robot, args)
    task = task_payload_from_args(args)

    def simulated(configurations: ConfigurationsLike) -> MonteCarloResult:  # the same trials, errors and seed
        return monte_carlo(
            params, configurations, q0, trials=args.trials, seed=args.seed, error_std=error_std,
            task_payload=task, progress=args.progress, **with_sigma(sigma, measuring.options),
        )  # fmt: skip

    mc = simulated(plan)
    compared = [(path, len(other), simulated(other)) for path, other in others]
    if args.plot:
        save_simulation_plot(args.plot, _labelled(args.plan, mc, compared))
    if args.json:
        emit_json(
            {
                "robot": robot.name,
                "tip": robot.tip,
                "markers": robot.markers.tolist(),
                "m": len(plan),
                "n_params": len(params),
                "params": list(params.names),
                "seed": args.seed,
                **mc.as_dict(),
                "compare": [{"plan": path, "m": m, **result.as_dict()} for path, m, result in compared],
            }
        )
        return 0
    print(
        f"{robot.name}: {len(plan)} configurations, {len(params)} parameters ({source}), "
        f"{sigma_text}, "
        f"errors {error_std['length']:g} m / {error_std['angle']:g} rad, {mc.trials} trials"
    )
    print(f"rho0 predicted: {fmt_length(mc.rho0_predicted)}")
    print(f"rho0 empirical: {fmt_length(mc.rho0_empirical)} ± {fmt_length(mc.rho0_empirical_se)}")
    print(f"error before calibration (RMS): {fmt_length(mc.as_dict()['error_before_rms'])}")
    print(
        "error after calibration, quantiles: "
        + ", ".join(f"{q:g}: {fmt_length(v)}" for q, v in mc.quantiles.items())
    )
    print(mc.note)
    if compared:
        print("compared plans (the same trials, errors, noise and seed):")
        for path, m, result in compared:
            predicted = result.rho0_predicted
            print(
                f"  {path}: {m} configurations, rho0 predicted {fmt_length(predicted)} "
                f"({predicted / mc.rho0_predicted:.3g} times this plan's), empirical "
                f"{fmt_length(result.rho0_empirical)} ± {fmt_length(result.rho0_empirical_se)}"
            )
    return 0


def _labelled(
    plan: str, result: MonteCarloResult, compared: list[tuple[str, int, MonteCarloResult]]
) -> dict[str, MonteCarloResult]:
    """``{label: result}`` for the figure: each plan file's name without its suffix, primed when
    two are alike; the simulated plan first."""
    labelled = {Path(plan).stem: result}
    for path, _, other in compared:
        label = Path(path).stem
        while label in labelled:
            label += "'"
        labelled[label] = other
    return labelled
