"""The options of ``pincal design`` (its --help text): the parser's arguments, by group."""

from __future__ import annotations

import argparse

from pincal.arguments import number
from pincal.cli._accuracy import (
    REGION_HELP,
    add_region_arguments,
    add_report_arguments,
    add_task_payload_arguments,
)
from pincal.cli._common import (
    CONDITIONING_HELP,
    SIGMA_HELP,
    add_output_arguments,
    add_progress_argument,
    add_robot_arguments,
    add_test_pose_argument,
)
from pincal.cli._instrument import INSTRUMENT_HELP, add_instrument_arguments
from pincal.cli._parameters import add_base_argument
from pincal.cli._plot import add_plot_argument
from pincal.cli._safety import SAFETY_HELP, add_safety_arguments, add_self_collision_argument
from pincal.cli._types import checked, count, seed_type, sigma_type
from pincal.cli.campaign import TRADEOFF_HELP, add_tradeoff_arguments
from pincal.planning import stopping as _stopping
from pincal.planning.driver import METHODS, MIN_CONDITIONING
from pincal.planning.objectives import CRITERIA
from pincal.planning.options import Search
from pincal.planning.placement import SCREEN, STEPS

EXAMPLES = """\
examples:
  pincal design kr270 -m 12 --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2 --sigma 3e-5 \\
      --params lengths,offsets --out plan.csv --baseline 1000
  pincal design planar_2r -m 2 --test-pose=0.3,1.2 --params joint2.tx,tip.tx --json
  pincal design ur10 -m 12 --test-pose=0,-1.2,1.5,-1,-1.5,0 --method exchange --pool taught.csv
  pincal design kr270 -m 10 --test-pose=0,-90,90,0,45,0 --deg --constraints cell.yaml --starts 32
  pincal design kr270 -m 12 --test-pose=0,-60,60,0,45,0 --deg --around 10deg --marker 0.1,0.05,0.2 \\
      --sigma 3e-5 --out plan.csv                   # accurate over ±10°, not only at the test pose
  pincal design kr270 -m 12 --test-path weld.csv --deg --marker 0.1,0.05,0.2 --sigma 3e-5
  pincal design kr270 -m 6 --test-pose=0,-60,60,0,45,0 --deg --prior 1mm,1mrad --sigma 3e-5
  pincal design kr270 -m 15 --test-pose=0,-60,60,0,45,0 --deg --marker 0.1,0.05,0.2 \
      --params lengths,offsets,gains,joint_a2.compliance,joint_a3.compliance --payloads 0,135,270 \
      --task-payload 270 --payload-centre 0,0,0.25 --out plan.csv   # a payload per configuration
  pincal design ur10 -m 8 --test-pose=0,-1.2,1.5,-1,-1.5,0 --measure pose --sigma 1e-4 --sigma-rot 2e-3
  pincal design panda -m 20 --test-pose=0,-0.3,0,-2.2,0,2,0.8 --camera rig.yaml   # a camera and a grid
  pincal design kr270 -m 12 --test-pose=0,-90,90,0,45,0 --deg --marker 0.1,0.05,0.2 \
      --instrument tracker --instrument-at 4,0,1    # a tracker's radial/transverse error, 4 m away
  pincal design ur10 -m 12 --test-pose=0,-1.2,1.5,-1,-1.5,0 --marker 0.05,0.02,0.1 \
      --place-instrument 1.5,-2,0.75,9,2,0.75 --placement-plot placement.png   # where the tracker goes

Payloads (--payloads KG,KG,...; --task-payload KG; --payload-centre X,Y,Z): the exchange chooses a
payload for each configuration of a generated pool (--pool-size) or of your --pool; the plan CSV
carries payload columns, rho0 is under the task's payload, split into its geometric and elastic
parts, and the accuracy report (and --accuracy-plot) is under the task's payload too, next to a
payload-free D-optimal plan. Any --measure (poses, partial poses, distances, a camera) and
--instrument take payloads: each candidate's rows are the instrument's, weighted by its error
model, under its payload. {limits}.
--residual-model CAL.urdf: a top-up plan for the residual model of an earlier calibration; the
report gives its expected error at the test pose(s), and the accuracy table is of that expected
error (the residual model's variance included) for the plan and a D-optimal plan (no --pool or
--accuracy-plot with it). It measures points with one --sigma: the residual model is a Gaussian
process of the markers' positions, fitted to point residuals, and says nothing of orientations,
pixels or distances.

Criteria (--criterion): test-pose (rho0, root mean square over several --test-pose), test-pose-worst
(the worst test pose; --worst is the same), D, A, E, cond. Methods: exchange (the default: best m of
a pool of feasible configurations, then refined by the continuous search unless --no-polish; --pool
gives your own, e.g. taught poses, in the plan CSV format, and keeps the plan on them), continuous
(all joint values at once, from many random starts, the constraints kept by SLSQP).
--baseline N: rho0 of N random feasible plans (drawn from --pool when given, else within the joint
limits and --constraints) and of the D-optimal plan, next to the designed plan's.
--place-instrument X0,Y0,Z0,X1,Y1,Z1: choose the tracker's position in that box (instrument frame,
metres) together with the plan: a grid of --place-steps per axis (default 3), then the best
position's neighbours at half the step, each position screened by a quick design (2 exchange starts
over 500 of one pool's configurations it sees, no polish: a fraction of a second), then the best
--place-screen N (default 3) and the default position designed in full (8 exchange starts, the
best 2 polished for at most 150 iterations unless --starts is given: about 10 s of CPU each with
the line of sight); --place-screen all designs every position in full with the design's defaults
(27 + 6 on a 3-step box: an hour or more with the polish). At each position the plan is designed with the
tracker there (--instrument tracker, --tracker-sigma: its error; default the AT500's), under its
range (1 to
40 m), a 30-degree acceptance angle about the reflector's normal (the tip frame's z) and the line of
sight (nothing of the robot's collision geometry within 1 cm of the beam; unchecked, and said so,
when the URDF has none). With --camera (eye-to-hand), the camera is placed, aimed at the target at
the test pose, counting the target points in its field of view. The report (and JSON 'instrument_at',
'placement') gives the position chosen, rho0 there and at the default position (--instrument-at, or
the box's centre) and their factor; --placement-plot FILE.png maps rho0 over the box.
--base: the tracker measures in its own frame, so base.* are identified too (as 'identify --base').
--constraints FILE.yaml: joint_limits, workspace_box, half_space, visibility, line_of_sight,
self_collision, min_spacing (see pincal.planning.constraints.load_constraints for the layout).
--min-conditioning X: no plan whose conditioning is below X (default 1e-2, none with --prior); a
plan below 1e-3 is warned about whatever the floor, and so is a floor below 1e-3 that stops the
search.
{conditioning}

{safety}
{tradeoff}
{region}
Units: metres and radians; --deg reads test poses and --pool, and writes --out and prints the plan,
in degrees. The JSON plan is always in radians; rho0 is in metres for --sigma
(default 3e-5 m, a laser tracker; the report says which sigma it used).
"""
PAYLOAD_LIMITS = (
    "not supported with them: --baseline (random plans carry no payloads), --method continuous and "
    "--polish (the continuous search cannot choose among discrete payloads)"
)
EXAMPLES = (
    EXAMPLES.replace("{region}", REGION_HELP.rstrip())
    .replace("{conditioning}", CONDITIONING_HELP)
    .replace("{limits}", PAYLOAD_LIMITS[0].upper() + PAYLOAD_LIMITS[1:])
    .replace("{safety}", SAFETY_HELP.rstrip())
    .replace("{tradeoff}", TRADEOFF_HELP.rstrip())
)
EXAMPLES += "\n" + INSTRUMENT_HELP + "\n"


def add_design_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments design and baseline share: robot, parameters, m, test poses, constraints, noise,
    the pool of candidate configurations."""
    add_robot_arguments(p)
    add_base_argument(p)
    p.add_argument(
        "-m", type=count("-m"), required=True, metavar="M", help="number of configurations to measure"
    )
    add_test_pose_argument(p, required=False)
    add_region_arguments(p)
    p.add_argument("--constraints", metavar="FILE.yaml", help="workcell constraints (YAML)")
    add_safety_arguments(p)
    add_self_collision_argument(p)
    p.add_argument("--sigma", type=sigma_type(), default=None, help=SIGMA_HELP)
    p.add_argument(
        "--deg", action="store_true", help="joint values in degrees (test poses, pool, plan output)"
    )
    p.add_argument("--seed", type=seed_type(), default=0, help="seed of every random choice (default 0)")
    p.add_argument(
        "--pool",
        metavar="FILE.csv",
        help="candidate configurations (plan CSV format, e.g. taught poses): plans are made of them, "
        "random baselines drawn from them",
    )


def search_from_args(args: argparse.Namespace, pool) -> Search:
    """The :class:`pincal.Search` of the arguments design and baseline share (--method, --starts,
    --seed, --workers, --progress, design's --polish) over ``pool``."""
    return Search(
        method=args.method,
        starts=args.starts,
        seed=args.seed,
        pool=pool,
        polish=getattr(args, "polish", None),
        workers=args.workers,
        progress=args.progress,
    )


def add_design_options(p: argparse.ArgumentParser) -> None:
    """Every argument of ``pincal design``, in the order --help lists them."""
    add_design_arguments(p)
    _add_search_options(p)
    _add_output_options(p)
    _add_payload_options(p)
    _add_placement_options(p)
    add_plot_argument(p)
    add_report_arguments(p)
    add_tradeoff_arguments(p)
    add_instrument_arguments(p, test_pose=True)
    add_output_arguments(p)


def _add_search_options(p: argparse.ArgumentParser) -> None:
    """The criterion and the search: method, pool, polish, starts, workers, conditioning floor."""
    p.add_argument(
        "--criterion", default="test-pose", metavar="NAME", help=f"{', '.join(CRITERIA)} (default test-pose)"
    )
    p.add_argument(
        "--worst", action="store_true", help="with several test poses, minimise the worst (test-pose-worst)"
    )
    p.add_argument(
        "--method", default="exchange", metavar="NAME", help=f"{' or '.join(METHODS)} (default exchange)"
    )
    p.add_argument(
        "--pool-size",
        type=count("--pool-size"),
        metavar="N",
        help="random feasible candidates to draw (default 2000)",
    )
    p.add_argument(
        "--polish",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="exchange: refine the best plans with the continuous search (default: on, off with --pool)",
    )
    p.add_argument(
        "--starts",
        type=_starts_type,
        default=None,
        metavar="N|auto",
        help=f"number of starts, run exactly; default auto: batches of {_stopping.BATCH} until "
        f"{_stopping.AGREE} starts match the best within {100 * _stopping.TOLERANCE:g} %%, "
        f"at most {_stopping.CAP}",
    )
    p.add_argument(
        "--workers",
        type=count("--workers"),
        help="processes running the starts (default: all CPUs; 1: serial)",
    )
    p.add_argument(
        "--min-conditioning",
        type=checked("--min-conditioning", number, low=0.0, high=0.1, high_open=True),
        default=None,
        metavar="X",
        help=f"floor of the plan's conditioning (see below; default {MIN_CONDITIONING:g}, 0 with --prior)",
    )


def _add_output_options(p: argparse.ArgumentParser) -> None:
    """The plan written, the random baselines, the progress."""
    p.add_argument(
        "--out", metavar="PLAN.csv", help="write the plan (radians, degrees with --deg), atomically"
    )
    p.add_argument(
        "--baseline",
        type=count("--baseline"),
        metavar="N",
        help="also report N random feasible plans and the D-optimal plan",
    )
    add_progress_argument(p)


def _add_payload_options(p: argparse.ArgumentParser) -> None:
    """The payloads mounted, the task's payload, a top-up's residual model."""
    p.add_argument(
        "--payloads",
        metavar="KG,KG,...",
        help="the payloads you can mount: a payload is chosen for each configuration (the plan CSV carries "
        "payload columns); an exchange over (configuration, payload) pairs",
    )
    add_task_payload_arguments(p)
    p.add_argument(
        "--residual-model",
        metavar="CAL.urdf",
        help="a top-up plan: the residual model of an earlier calibration (its sidecar) values measuring "
        "where the residual is correlated with the test pose's",
    )


def _add_placement_options(p: argparse.ArgumentParser) -> None:
    """The instrument's placement searched with the plan (--place-instrument)."""
    p.add_argument(
        "--place-instrument",
        metavar="X0,Y0,Z0,X1,Y1,Z1",
        help="choose the tracker's (or a fixed camera's) position in this box [m] with the plan",
    )
    p.add_argument(
        "--place-steps",
        type=count("--place-steps"),
        metavar="N",
        help=f"grid positions per axis of the --place-instrument box (default {STEPS})",
    )
    p.add_argument(
        "--place-screen",
        type=_screen_type,
        metavar="N|all",
        help=f"positions of the --place-instrument box designed in full after the screen (default {SCREEN}; "
        "all: every position, the exhaustive search)",
    )
    p.add_argument(
        "--placement-plot",
        metavar="FILE.png",
        help="save the map of rho0 against the instrument's position over the box (--place-instrument)",
    )


def _starts_type(value: str) -> int | None:
    """--starts: a count, or ``auto`` (None: the adaptive number, :mod:`pincal.planning.stopping`)."""
    if value.strip().lower() == "auto":
        return None
    return count("--starts")(value)  # type: ignore[return-value]


def _screen_type(value: str) -> int | str:
    """--place-screen: a count, or ``all``."""
    if value.strip().lower() == "all":
        return "all"
    return count("--place-screen")(value)  # type: ignore[return-value]  # an int
