"""pincal identify: geometric errors from measurements, and the calibrated URDF."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, fraction, positive_int, positive_sigma, ratio
from pincal.calibration.formats import FORMATS, format_of, read_measurements
from pincal.calibration.identification import LOSSES, METHODS, RESIDUAL_MODELS, identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.validation import holdout, kfold, validate
from pincal.cli import COMMANDS
from pincal.cli._accuracy import test_region_from_args
from pincal.cli._common import (
    CONDITIONING_HELP,
    FIGURE_NOTE,
    add_command,
    add_output_arguments,
    add_progress_argument,
    add_robot_arguments,
    add_test_pose_argument,
    emit_json,
    robot_from_args,
)
from pincal.cli._instrument import (
    INSTRUMENT_HELP,
    add_instrument_arguments,
    error_from_args,
    instrument_from_args,
    kind_from_args,
    rig_from_args,
    robot_with_fixtures,
)
from pincal.cli._parameters import add_base_argument, parameters_with_base
from pincal.cli._types import checked, count, seed_type, sigma_type
from pincal.errors import BadArgument, IdentificationFailed, OverwriteRefused
from pincal.evaluation.prior import Prior
from pincal.export.mjcf import export_mjcf, writes_mjcf
from pincal.export.urdf import export_urdf, sidecar_path
from pincal.viewing.plots import save_figure, validation_errors

HELP = COMMANDS["identify"].help
EXAMPLES = f"""\
examples:
  pincal identify kr270 --data meas.csv --marker 0.1,0.05,0.2 --out kr270_calibrated.urdf
  pincal identify kr270 --data meas.csv --mm --deg --marker 0.1,0.05,0.2 --json
  pincal identify robots/kr270.urdf --data tracker.csv --base --marker 0.1,0.05,0.2 --out cal.urdf
  pincal identify kr270 --data a.csv --data b.csv --base --marker 0.1,0.05,0.2   # two placements
  pincal identify kr270 --data meas.csv --marker 0.1,0.05,0.2 --reject 5 --holdout 0.2 --seed 1 \\
      --plot validation.png
  pincal identify kr270 --data grid.csv --marker 0.1,0.05,0.2 --prior 1mm,1mrad --kfold 5
  pincal identify planar_2r --data meas.csv --params joint2.tx,tip.tx --loss soft_l1
  pincal identify kr270 --data loaded.csv --marker 0.1,0.05,0.2 --params full,offsets,gains,compliance \
      --residual-model gp --holdout 0.3 --out cal.urdf        # beyond geometry
  pincal identify ur10 --data mocap.csv --base --sigma 1e-4 --sigma-rot 2e-3 --out ur10_cal.urdf  # poses
  pincal identify kr270 --data heights.csv --marker 0.1,0.05,0.2          # z alone: a height gauge
  pincal identify ur10 --data wires.csv --anchor 1,1,0 --anchor -1,1.5,0.5 --anchor 1.5,-1,1 \
      --anchor 0.5,-1.5,0.2                                  # draw-wires; the anchors are identified
  pincal identify panda --data corners.csv --camera rig.yaml --out panda_cal.urdf   # a camera
  pincal identify kr270 --data tracker.csv --base --marker 0.1,0.05,0.2 --instrument tracker
  pincal identify ur10 --data config/ur10_config.yaml --base --marker 0.05,0,0.12   # FIGAROH's data
  pincal identify ur10 --data calibration_data.db3 --sensor camera --base --marker 0.02,0,0.1 \
      --marker -0.02,0,0.1                  # robot_calibration's bag (pip install "pincal[ros]")
  pincal identify ur10 --data samples.yaml --joint-states joint_states.yaml --base   # MoveIt Calibration

MEAS.csv: a header row, then one configuration per row: one column per joint, named as in the URDF
(radians; degrees with --deg), and the measured point(s): x,y,z for one marker or x0,y0,z0,x1,y1,z1,...
for several, in the order of --marker (metres; millimetres with --mm). Optional uncertainty columns
s (or sx,sy,sz; per marker s0,... or sx0,...), in the coordinates' unit, weight each point by 1/s^2.
Rows with a missing or non-numeric cell, NaN, or a joint outside its limits are errors naming the line.
Other tools' data (--format, else found from the file): FIGAROH's calibration CSV or configuration
YAML (figaroh), ROS robot_calibration's CalibrationData bag (.db3, .mcap, .bag) or YAML
(robot_calibration; --sensor NAME picks the sensor), industrial_calibration's observations YAML
(industrial_calibration) and MoveIt Calibration's hand-eye samples YAML with its joint states
(moveit; --joint-states FILE, one per --data): metres and radians, joints matched by name.
--base: the points are in the instrument's frame, not the robot base frame: the base placement
(base.*) is identified too, starting from a rigid fit (the "before" residual is the one after it),
and the chain parameters it makes redundant are dropped. Several --data files, each measured from its
own instrument placement, share the robot's parameters with one base each (base2.*, base3.*, ...).

{{instrument}}

The report gives the data's identifiability first: rank and conditioning (see below) of YOUR
configurations, the weakest parameter combinations, and the parameters the data
cannot identify (nearly inseparable, or determined only to worse than 1 cm / 10 mrad), left at their
nominal value with the reason (with --prior, every parameter estimated MAP instead). Rows over 5
robust sigma are named by file line (mm and sigma); --reject K drops rows over K robust sigma and
refits. sigma defaults to {DEFAULT_SIGMA:g} m for these checks; the standard errors use sigma
estimated from the residuals unless --sigma or s columns give it.
A result no real robot has (a link origin or the tool frame moving by over 5 cm, an angle by over
0.1 rad, residuals 1000x sigma) is "implausible"; the error line names the likely cause (units:
--mm; a forgotten --marker; --base; columns).
--out writes the user's URDF with corrected joint origins (joint offsets folded into them) and the
tip's fixed joint corrected, and a sidecar CAL.calibration.json with the base, markers, sigma and
conditioning: p = base * oMf[tip] * marker predicts the instrument's coordinates. A MuJoCo robot
(ROBOT.xml), or an --out ending in .xml, is written as MJCF: the bodies' pos/quat, the joints' ref
(the offsets), the markers as sites, everything else kept (README, MJCF).
Estimates are errors relative to the nominal URDF (m, rad); text output shows mm and mrad.
Exit code 2 when the data cannot identify the parameters, the fit does not converge, or the result is
implausible (then no URDF, unless --force: the URDF is written, with a warning, and the exit code is 0).
--validate, --holdout FRACTION --seed S, --kfold K: RMS, 95th percentile and max position error before
and after calibration on held-out points (text, JSON 'validation', --plot FILE.png). A holdout or a
k-fold fold whose fit keeps fewer than twice as many measured coordinates as parameters is warned
about (its held-out error overstates the calibration's), with what to do; each also gives the RMS the
fit predicted for those errors (its standard errors, the residual model's variance, the noise).
--test-pose Q0 (repeatable; --around ANGLE, or --test-path PATH.csv; --task-payload KG): the predicted
error of the calibrated robot there, over +-10/20 degrees around and over the workspace, from the
parameters' standard errors and, with --residual-model, the residual model's variance (large far
from the measured configurations: measure near where the robot works).
Beyond geometry: --params gains,compliance adds each joint's gain (it moves by q(1+gain)) and
compliance (it yields by compliance x the gravity torque on it; the URDF must give the links'
masses; --gravity if the base is not level); optional columns payload_kg and payload_x,payload_y,
payload_z say what the robot carried at each row (a payload change is what separates compliance from
the link lengths). --residual-model gp then models what the fit leaves as a Gaussian process over
joint space (hyperparameters from these data only), whose mean corrects the predictions (and the
--holdout/--kfold errors). The sidecar holds gains, compliances, gravity and the residual model:
'pincal compensate' uses them to correct a program's joint targets.
"""
EXAMPLES = EXAMPLES.replace("{instrument}", INSTRUMENT_HELP)
EXAMPLES += "\n" + CONDITIONING_HELP + "\n"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "identify", HELP, EXAMPLES)
    add_robot_arguments(p)
    p.add_argument(
        "--data",
        required=True,
        action="append",
        metavar="MEAS.csv",
        help="the measurements (format below); repeat for sessions from other instrument placements",
    )
    p.add_argument(
        "--mm", action="store_true", help="measured coordinates (and s columns) are in millimetres"
    )
    p.add_argument("--deg", action="store_true", help="joint values are in degrees")
    p.add_argument(
        "--format",
        choices=tuple(FORMATS),
        help="the --data files' format (default: found from each file): pincal's CSV or another tool's",
    )
    p.add_argument(
        "--sensor", metavar="NAME", help="robot_calibration data: the sensor whose points were measured"
    )
    p.add_argument(
        "--joint-states",
        action="append",
        metavar="FILE.yaml",
        help="MoveIt Calibration samples: the joint states saved with them (one per --data, in order)",
    )
    _add_fit_arguments(p)
    _add_validation_arguments(p)
    _add_output_arguments(p)
    add_instrument_arguments(p)
    add_output_arguments(p)
    add_progress_argument(p)  # the residual model's fit, on many configurations
    p.set_defaults(run=run)


def _add_fit_arguments(p: argparse.ArgumentParser) -> None:
    """The options of the fit: the parameters (--base), noise, prior, loss, solver, rejection."""
    add_base_argument(p)
    p.add_argument(
        "--sigma",
        type=sigma_type(),
        help="measurement noise per coordinate [m] for the standard errors (default: from the residuals)",
    )
    p.add_argument(
        "--prior", metavar="LEN,ANGLE", help="prior std of the errors, e.g. 1mm,1mrad: MAP estimate"
    )
    p.add_argument("--loss", choices=LOSSES, default="linear", help="robust loss (default linear)")
    p.add_argument("--method", choices=METHODS, default="trf", help="least_squares method (default trf)")
    p.add_argument(
        "--reject",
        type=checked("--reject", ratio),
        metavar="K",
        help="drop rows beyond K robust sigma and refit",
    )
    p.add_argument(
        "--residual-model",
        choices=RESIDUAL_MODELS,
        help="gp: model what the fit leaves as a Gaussian process over joint space (needs pincal[gp]); "
        "exact up to 500 configurations, beyond approximate (FITC through 1500 inducing configurations)",
    )
    p.add_argument(
        "--maxiter",
        "--max-iterations",
        dest="maxiter",
        type=count("--max-iterations"),
        default=100,
        help="solver evaluations (default 100)",
    )


def _add_validation_arguments(p: argparse.ArgumentParser) -> None:
    """The options of the validation: --validate, --holdout, --kfold, their seed and figure."""
    p.add_argument("--validate", metavar="OTHER.csv", help="held-out measurements (same placement as --data)")
    p.add_argument(
        "--holdout",
        type=checked("--holdout", fraction),
        metavar="FRACTION",
        help="hold this share of the rows out",
    )
    p.add_argument(
        "--kfold", type=count("--kfold", low=2), metavar="K", help="k-fold cross-validation of the fit"
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="seed of --holdout and --kfold (default 0)")
    p.add_argument(
        "--plot", metavar="FILE.png", help="save the validation errors before/after (a figure)" + FIGURE_NOTE
    )


def _add_output_arguments(p: argparse.ArgumentParser) -> None:
    """The calibrated URDF written (--out, --force) and the accuracy reported (--test-pose, ...)."""
    p.add_argument(
        "--out",
        metavar="CALIBRATED.urdf",
        help="write the calibrated URDF (and its sidecar) here; MJCF for a MuJoCo robot or an .xml name",
    )
    p.add_argument("--force", action="store_true", help="write the URDF of an implausible result anyway")
    add_test_pose_argument(p, required=False)
    p.add_argument(
        "--around",
        metavar="ANGLE[,LENGTH]",
        help="with --test-pose: report over its neighbourhood (e.g. 10deg; 10deg,2cm with prismatic joints)",
    )
    p.add_argument("--test-path", metavar="PATH.csv", help="report over a path (plan CSV format)")
    p.add_argument(
        "--task-payload", type=float, metavar="KG", help="the task's payload at the test pose(s) (compliance)"
    )
    p.set_defaults(test_box=None)


def _check_outputs(args: argparse.Namespace, robot) -> None:
    """The sidecar --out writes must not be an input either (main checks --out and --plot)."""
    inputs = [*args.data, *(args.joint_states or []), robot.urdf_path, args.validate]
    if args.out:
        writes_mjcf(robot, args.out)  # an MJCF robot's calibration is MJCF: refused before the work
    if args.out and sidecar_path(args.out).resolve() in [Path(p).resolve() for p in inputs if p]:
        raise OverwriteRefused(
            f"the sidecar of --out {args.out} would overwrite an input: choose another name"
        )


def _read_data(args: argparse.Namespace, robot, path: str, kind, index: int) -> MeasurementData:
    """One --data (or --validate) file, in its format: pincal's CSV, or another tool's data."""
    name = args.format or format_of(path)
    if name == "pincal":
        return MeasurementData.from_csv(path, robot, degrees=args.deg, millimetres=args.mm, kind=kind)
    given = [o for o, on in (("--deg", args.deg), ("--mm", args.mm), ("--measure", args.measure)) if on]
    if given:
        raise BadArgument(
            f"{', '.join(given)}: for pincal's CSV; {path} is {FORMATS[name].tool}'s data, in metres and "
            f"radians, and says what was measured"
        )
    options = {"sensor": args.sensor, "joint_states": args.joint_states[index] if args.joint_states else None}
    data = read_measurements(path, robot, format=name, **options)
    if kind is not None and type(data.measure) is not type(kind):
        raise BadArgument(f"{path} holds {data.measure.describe()} measurements, not {kind.describe()}")
    return data


def run(args: argparse.Namespace) -> int:
    robot = robot_with_fixtures(robot_from_args(args), args)
    sigma = None if args.sigma is None else positive_sigma(args.sigma, "--sigma")
    rig = rig_from_args(args)
    error = error_from_args(args, sigma)
    positive_int(args.maxiter, "--maxiter")
    prior = Prior.parse(args.prior) if args.prior else None
    if sum(x is not None for x in (args.validate, args.holdout, args.kfold)) > 1:
        raise BadArgument("choose one of --validate, --holdout and --kfold")
    if args.plot and not (args.validate or args.holdout or args.kfold):
        raise BadArgument("--plot draws the validation errors: give --validate, --holdout or --kfold")
    _check_outputs(args, robot)
    if args.task_payload is not None and not args.test_pose and not args.test_path:
        raise BadArgument("--task-payload is the load at the test pose(s): give --test-pose or --test-path")
    test_region = test_region_from_args(robot, args, required=False)
    sessions = _sessions(args, robot, rig)
    instrument = instrument_from_args(args, sessions[0].measure, sigma)
    params, source, dropped = parameters_with_base(robot, args, instrument)
    options = dict(
        sigma=sigma, maxiter=args.maxiter, prior=prior, loss=args.loss, method=args.method,
        reject=args.reject, residual_model=args.residual_model, progress=args.progress,
    )  # fmt: skip
    if error is not None:  # the error model has its own σ
        options.update(sigma=None, instrument=instrument)
    result, validation = _fit(args, robot, params, sessions, options)
    writable = result.success or (args.force and result.status == "implausible")
    writer = export_mjcf if args.out and writes_mjcf(robot, args.out) else export_urdf
    out = writer(result, args.out, force=args.force) if args.out and writable else None
    if args.plot and validation is not None:
        save_figure(validation_errors(validation), args.plot)
    accuracy = None
    if test_region is not None and np.any(np.isfinite(result.std)):  # else no standard errors
        accuracy = result.accuracy(test_region, payload=args.task_payload, seed=args.seed)
    if args.json:
        payload = {"robot": robot.name, "tip": robot.tip, "params_source": source, **result.as_dict()}
        payload["dropped_for_base"] = dropped
        payload["validation"] = validation.as_dict() if validation is not None else None
        payload["accuracy"] = accuracy.as_dict() if accuracy is not None else None
        payload["out"] = str(out) if out else None
        payload["sidecar"] = str(sidecar_path(out)) if out else None
        emit_json(payload)
    if not result.success and not (writable and out):
        raise IdentificationFailed(result)
    if args.json:
        return 0
    _print_report(args, robot, params, source, dropped, result, validation, accuracy)
    if out:
        format_name = "MJCF" if writer is export_mjcf else "URDF"
        print(f"calibrated {format_name} written to {out} (sidecar {sidecar_path(out)})")
    if not result.success:
        print(f"pincal: warning: the result is {result.status}; written because of --force", file=sys.stderr)
    return 0


def _sessions(args: argparse.Namespace, robot, rig) -> list[MeasurementData]:
    """The --data files read, each in its format, checked to measure one kind."""
    # --measure says what a file's columns leave open (x,y alone is a partial measurement, not a
    # point file missing its z); without it, the columns (and --camera) say what was measured.
    kind = kind_from_args(args, robot) if args.measure else rig.kind if rig is not None else None
    if args.joint_states and len(args.joint_states) != len(args.data):
        raise BadArgument(
            f"{len(args.joint_states)} --joint-states for {len(args.data)} --data: give one per --data file"
        )
    sessions = [_read_data(args, robot, d, kind, i) for i, d in enumerate(args.data)]
    kinds = {type(d.measure).__name__ for d in sessions}
    if len(kinds) > 1:
        raise BadArgument(
            f"the --data files measure different things ({', '.join(sorted(kinds))}); give one kind"
        )
    return sessions


def _fit(args: argparse.Namespace, robot, params, sessions: list[MeasurementData], options: dict):
    """(the identification's result, its validation or None): by --holdout, --validate or --kfold."""
    validation = None
    if args.holdout is not None:
        result, validation = holdout(params, sessions, args.holdout, seed=args.seed, **options)
    else:
        result = identify(params, sessions, **options)
        if args.validate:
            other = _read_data(args, robot, args.validate, sessions[0].measure, 0)
            validation = validate(result, other)
        elif args.kfold is not None:
            validation = kfold(params, sessions, args.kfold, seed=args.seed, **options)
    return result, validation


def _print_report(
    args: argparse.Namespace, robot, params, source, dropped, result, validation, accuracy
) -> None:
    """The text report: what was fitted, the result, the calibrated frames, validation, accuracy."""
    files = ", ".join(args.data)
    print(f"{robot.name}: {len(params)} parameters ({source}), {result.data.m} configurations from {files}")
    if dropped:
        print(f"dropped as redundant with the base frame: {', '.join(dropped)}")
    print(result.report())
    kinds = {q.kind for q in params}
    if "marker" in kinds:
        print(f"calibrated markers in {robot.tip} [m]: {result.robot.markers.tolist()}")
    for name, pose in result.as_dict().get("fixtures", {}).items():
        frame = robot.tip if pose["on"] == "tip" else "the instrument frame"
        print(f"{name} in {frame}: xyz {pose['xyz']} m, rpy {pose['rpy']} rad")
    if "base" in kinds:
        for i, base in enumerate(result.as_dict()["bases"]):
            which = "" if len(args.data) == 1 else f" ({args.data[i]})"
            print(f"robot base in the instrument frame{which}: xyz {base['xyz']} m, rpy {base['rpy']} rad")
    if validation is not None:
        print(validation.report())
    if accuracy is not None:
        print("\n".join(accuracy.lines(degrees=args.deg)))
    if args.plot:
        print(f"validation figure written to {args.plot}")
