"""pincal evaluate: ρ0 and the classic criteria of a plan."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from pincal.cli import COMMANDS
from pincal.cli._accuracy import (
    REGION_HELP,
    add_region_arguments,
    add_report_arguments,
    add_task_payload_arguments,
    prior_from_args,
    report_accuracy,
    residual_model_from_args,
    split_line,
    task_payload_from_args,
    test_region_from_args,
)
from pincal.cli._common import (
    CONDITIONING_HELP,
    SIGMA_HELP,
    add_command,
    add_output_arguments,
    add_robot_arguments,
    add_test_pose_argument,
    emit_json,
    fmt_length,
    read_plan,
    robot_from_args,
    sigma_from_args,
)
from pincal.cli._instrument import INSTRUMENT_HELP, add_instrument_arguments, measuring_from_args, with_sigma
from pincal.cli._parameters import add_base_argument, params_from_args
from pincal.cli._safety import SAFETY_HELP, add_safety_arguments, safe_constraints_from_args
from pincal.errors import BadArgument, SingularPlan
from pincal.evaluation.accuracy_report import AccuracyReport
from pincal.evaluation.classic import Criteria, criteria
from pincal.evaluation.data_check import DataCheck, check_plan
from pincal.evaluation.residual_criterion import expected_error
from pincal.evaluation.test_pose import rho0_each, rho0_split
from pincal.planning.safety import SafetyReport, safety_margins

HELP = COMMANDS["evaluate"].help
EXAMPLES = """\
examples:
  pincal evaluate kr270 --plan plan.csv --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2 --sigma 3e-5
  pincal evaluate planar_2r --plan plan.csv --test-pose=0.3,1.2 --params joint2.tx,tip.tx --json
  pincal evaluate kr270 --plan plan.csv --deg --test-pose=0,-90,90,0,45,0 --base   # tracker-frame data
  pincal evaluate robots/kr270.urdf --plan plan.csv --test-pose=-0.5,-1.2,1.0,0,0.8,0 \\
      --test-pose=0.5,-1.2,1.0,0,0.8,0 --worst
  pincal evaluate kr270 --plan plan.csv --deg --test-path weld.csv --marker 0.1,0.05,0.2 --sigma 3e-5 \\
      --prior 1mm,1mrad --accuracy-plot accuracy.png
  pincal evaluate kr270 --plan plan.csv --deg --test-pose=0,-60,60,0,45,0 --marker 0.1,0.05,0.2 \
      --params lengths,offsets,gains,compliance --task-payload 270 --payload-centre 0,0,0.25
  pincal evaluate ur10 --plan plan.csv --test-pose=0,-1.2,1.5,-1,-1.5,0 --measure pose --sigma 1e-4 \\
      --sigma-rot 2e-3 --orientation-length 0.2     # motion capture; the tool's orientation counts
  pincal evaluate kr270 --plan plan.csv --deg --test-pose=0,-90,90,0,45,0 --marker 0.1,0.05,0.2 \\
      --instrument tracker --instrument-at 4,0,1    # a tracker 4 m away, radial/transverse sigma

PLAN.csv: a header row of joint names, one configuration per row, radians (degrees with --deg).
rho0 is in metres for --sigma (noise per coordinate, metres; default 3e-5, a laser tracker).
The report also checks the parameters on the plan's configurations: rank and conditioning, the
weakest combinations, and those the plan cannot determine to 1 cm / 10 mrad for the noise --sigma.
The design criteria (D: log_det, A: trace, E: max_eig, cond: σ_max/σ_min of the unscaled Jacobian,
unit-dependent, for --criterion cond; O1-O4 higher is better) are listed for comparison, and how
close the plan comes to the joint limits, the floor and the obstacles of --constraints (the margins
a design keeps by default, or --joint-margin, --mount).
A plan with payload columns (from 'design --payloads') is evaluated under its payloads, and the test
pose(s) under --task-payload KG (centre --payload-centre, tip frame; default none), as design does:
with gains or compliances among --params, rho0^2 is split into its geometric and elastic parts.
--residual-model CAL.urdf (a calibration identified with --residual-model gp): also the expected
error at the test pose(s) when the parameters and that residual are estimated from the plan, and
the accuracy report of it (the residual model's variance included).
"""
EXAMPLES += "\n" + CONDITIONING_HELP + "\n\n" + SAFETY_HELP + "\n" + REGION_HELP + "\n\n" + INSTRUMENT_HELP


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "evaluate", HELP, EXAMPLES)
    add_robot_arguments(p)
    add_base_argument(p)
    p.add_argument("--plan", required=True, metavar="PLAN.csv", help="the configurations to evaluate")
    add_test_pose_argument(p, required=False)
    add_region_arguments(p)
    p.add_argument(
        "--worst", action="store_true", help="with several test poses, report the worst, not the mean"
    )
    p.add_argument("--sigma", type=float, default=None, help=SIGMA_HELP)
    p.add_argument("--deg", action="store_true", help="plan and test poses are in degrees")
    add_task_payload_arguments(p)
    p.add_argument(
        "--residual-model",
        metavar="CAL.urdf",
        help="the residual model of an earlier calibration (its sidecar): the expected error with it, its "
        "variance included",
    )
    p.add_argument(
        "--constraints", metavar="FILE.yaml", help="workcell constraints (YAML): the margins are reported"
    )
    add_safety_arguments(p)
    add_report_arguments(p)
    add_instrument_arguments(p, test_pose=True)
    add_output_arguments(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    sigma, sigma_text = sigma_from_args(args)
    measuring = measuring_from_args(args, robot_from_args(args), sigma if args.sigma is not None else None)
    robot, options = measuring.robot, measuring.options
    sigma_text = measuring.text or sigma_text
    params, source = params_from_args(robot, args, measuring.instrument)
    plan = read_plan(robot, args.plan, args.deg)
    q0 = test_region_from_args(robot, args)
    prior = prior_from_args(args)
    task = task_payload_from_args(args)
    each = rho0_each(params, plan, q0, prior=prior, task_payload=task, **with_sigma(sigma, options))
    value = float(each.max()) if args.worst else float(np.sqrt(np.mean(each**2)))
    crit = _classic_criteria(params, plan, prior, options)
    model = None if args.residual_model is None else residual_model_from_args(robot, args.residual_model)
    with_model = None
    if model is not None:
        if prior is not None:
            raise BadArgument("--residual-model: the expected error with a residual model takes no --prior")
        with_model = expected_error(params, plan, q0, model, sigma=sigma, task_payload=task)
    report = report_accuracy(
        args, params, plan, q0, sigma, prior, task_payload=task, residual_model=model, **options
    )
    split = None
    if prior is None and any(p.kind in ("gain", "compliance") for p in params):
        split = rho0_split(params, plan, q0, sigma=sigma, task_payload=task)
    check = check_plan(params, plan, instrument=measuring.instrument)  # --sigma's points by default
    safety = safety_margins(robot, plan, safe_constraints_from_args(robot, args))
    e = _Evaluation(each, value, crit, split, with_model, check, safety, report)
    if args.json:
        emit_json(
            {
                "robot": robot.name,
                "tip": robot.tip,
                "markers": robot.markers.tolist(),
                "m": len(plan),
                "sigma": measuring.instrument.reference if options else sigma,
                **({"instrument": measuring.instrument.as_dict()} if options else {}),
                "rho0": value,
                "rho0_aggregate": "worst" if args.worst else "mean",
                "rho0_per_test_pose": each.tolist(),
                "n_params": len(params),
                "params": list(params.names),
                "criteria": None if crit is None else crit.as_dict(),
                "prior": None if prior is None else prior.as_dict(),
                "accuracy": None if report is None else report.as_dict(),
                "task_payload": None if task is None else task.row.tolist(),
                "rho0_split": split,
                "expected_error_with_residual_model": with_model,
                "data_check": check.as_dict(),
                "safety": safety.as_dict(),
            }
        )
        return 0
    print(f"{robot.name}: {len(plan)} configurations, {len(params)} parameters ({source}), {sigma_text}")
    _print_text(args, e)
    return 0


@dataclass(frozen=True)
class _Evaluation:
    """What ``pincal evaluate`` found about a plan (see :func:`run`)."""

    each: np.ndarray
    value: float
    crit: Criteria | None
    split: dict[str, float] | None
    with_model: float | None
    check: DataCheck
    safety: SafetyReport
    report: AccuracyReport | None


def _classic_criteria(params, plan, prior, options: dict):
    """The classic criteria of the plan, or None when only the prior makes it identify the parameters."""
    classic = {k: v for k, v in options.items() if k != "orientation_length"}
    try:
        crit = criteria(params, plan, **classic)
        assert not isinstance(crit, tuple)  # one plan, one set of criteria
    except SingularPlan:
        if prior is None:
            raise
        crit = None  # the prior makes ρ0 finite; the classic criteria of M alone are not
    return crit


def _print_text(args: argparse.Namespace, e: _Evaluation) -> None:
    """The text report of ``pincal evaluate`` after its first line."""
    agg = "worst" if args.worst else "root mean square"
    if len(e.each) == 1:
        print(f"rho0 at the test pose: {fmt_length(e.value)}  ({e.value:.6g} m)")
    else:
        print(f"rho0 over {len(e.each)} test poses ({agg}): {fmt_length(e.value)}  ({e.value:.6g} m)")
        for i, r in enumerate(e.each[:10]):
            print(f"  test pose {i}: {fmt_length(r)}")
        if len(e.each) > 10:
            print(f"  ... ({len(e.each)} test poses in all; --json lists each)")
    if e.crit is None:
        print("criteria: none (the plan alone cannot identify the parameters; rho0 holds with the prior)")
    else:
        print(
            "design criteria (lower is better: log_det (D), trace (A), max_eig (E), cond (σ_max/σ_min of "
            "the unscaled Jacobian); higher: O1-O4):"
        )
        for name, v in e.crit.as_dict().items():
            print(f"  {name:8s} {v:.6g}")
    if e.split is not None:
        print(split_line(e.split))
    if e.with_model is not None:
        print(
            f"expected error at the test pose(s) with the residual model of {args.residual_model}: "
            f"{fmt_length(e.with_model)} (rho0 assumes the model exact; this counts what it leaves)"
        )
    print(e.check.report())
    print("\n".join(e.safety.lines(degrees=True)))
    if e.report is not None:
        print("\n".join(e.report.lines(degrees=args.deg)))
