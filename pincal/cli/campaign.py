"""pincal campaign: a plan as a technician runs it — ordered for the least time from home and back,
every move checked against the robot itself, the cell and the floor, timed."""

from __future__ import annotations

import argparse
import sys

from pincal.campaign.schedule import plan_campaign
from pincal.campaign.timing import DEFAULT_SETTLE, DWELLS, Timing
from pincal.campaign.tradeoff import DEFAULT_SIZES, accuracy_vs_time, parse_sizes
from pincal.cli import COMMANDS
from pincal.cli._common import (
    add_command,
    add_output_arguments,
    add_progress_argument,
    add_robot_arguments,
    emit_json,
    parse_configuration,
    parse_floats,
    read_plan,
    recorded_warnings,
    robot_from_args,
)
from pincal.cli._safety import SAFETY_HELP, add_safety_arguments, safe_constraints_from_args
from pincal.cli._types import seed_type
from pincal.errors import BadArgument
from pincal.planning.safety import safety_margins
from pincal.viewing import plots

HELP = COMMANDS["campaign"].help
MAX_CAMPAIGN_POSES = 2000
"""Most poses a campaign orders: the order weighs every pair of poses, in a time that grows as their
square (planar_2r: 300 poses 5 s of CPU, 600 poses 20 s, so 2000 some 4 minutes: real campaigns, the
IPA UR10 series of 600 poses among them, fit); a 266 928-pose plan asked for 2 TiB."""
EXAMPLES = f"""\
examples:
  pincal campaign kr270 --plan plan.csv --deg --marker 0.1,0.05,0.2 --out campaign.csv
  pincal campaign kr270 --plan plan.csv --deg --home=0,-90,90,0,0,0 --constraints cell.yaml --json
  pincal campaign ur10 --plan plan.csv --dwell probe --speed 0.5 --settle 1 --html campaign.html
  pincal campaign kr270 --plan plan.csv --deg --joint-speeds 1,1,1,2,2,3 --joint-accelerations 2 --no-check

Order: the tour from --home (default: the URDF zero when within the limits and clear, else the
plan's first pose) through every pose and back with the least move time: exact (dynamic programming) up to 12
poses, 2-opt/Or-opt beyond; the report gives the time saved against the plan's own order.
Time: a move takes its slowest joint's time, |dq|/v (with --joint-accelerations a, the trapezoid
|dq|/v + v/a, or 2 sqrt(|dq|/a) when it never reaches v); speeds from the URDF's <limit velocity>
(or --joint-speeds, rad/s or m/s), times --speed; then --settle (default {DEFAULT_SETTLE:g} s) and the
instrument's --dwell at each pose (tracker {DWELLS["tracker"]:g} s, probe {DWELLS["probe"]:g} s, or seconds).
Checks: every move between consecutive configurations is certified collision-free against the
robot itself, the workcell of --constraints and the floor (--mount) by a motion bound (no point of a
link moves farther than the joints' motion allows; only stretches that bound does not clear are
bisected), with the URDF's collision geometry or capsules derived from the kinematics (the report
says which); a move that is not clear gets a detour through a clear intermediate configuration, or
is named. With a visibility constraint, the line of sight from its tracker is checked at each pose.
--out: the robot program, every waypoint in order (home, via points, poses): the joint columns
(radians, degrees with --deg), 'pose' (the plan row measured there, 1-based; 0 for home and via
points) and 'wait' (seconds spent there).

{SAFETY_HELP.rstrip()}
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = add_command(sub, "campaign", HELP, EXAMPLES)
    add_robot_arguments(p, params=False)
    p.add_argument("--plan", required=True, metavar="PLAN.csv", help="the measurement configurations")
    p.add_argument("--deg", action="store_true", help="joint values in degrees (plan, --home, --out)")
    p.add_argument(
        "--home",
        metavar="Q",
        help="configuration the campaign starts and ends at (default: the URDF zero when within the "
        "limits and clear, else the plan's first pose)",
    )
    p.add_argument(
        "--joint-speeds",
        metavar="V1,V2,...",
        help="joint speed limits, rad/s (m/s for prismatic joints), one per joint or one for all "
        "(default: the URDF's velocity limits)",
    )
    p.add_argument(
        "--joint-accelerations",
        metavar="A1,A2,...",
        help="joint acceleration limits, rad/s² (m/s²), one per joint or one for all (default: none)",
    )
    p.add_argument(
        "--speed", type=float, default=1.0, metavar="FRACTION", help="fraction of the speeds (default 1)"
    )
    p.add_argument(
        "--settle",
        type=float,
        default=DEFAULT_SETTLE,
        metavar="S",
        help=f"seconds the robot settles at each pose (default {DEFAULT_SETTLE:g})",
    )
    p.add_argument(
        "--dwell",
        default="tracker",
        metavar="KIND|S",
        help=f"the instrument's time per pose: tracker ({DWELLS['tracker']:g} s, the default), "
        f"probe ({DWELLS['probe']:g} s) or seconds",
    )
    p.add_argument("--constraints", metavar="FILE.yaml", help="the cell (workcell, visibility, ...; YAML)")
    add_safety_arguments(p)
    p.add_argument("--no-check", action="store_true", help="order and time only: no collision checks")
    p.add_argument(
        "--no-self-collision", action="store_true", help="check the moves against the cell and the floor only"
    )
    p.add_argument(
        "--seed", type=seed_type(), default=0, help="seed of the detours' random draws (default 0)"
    )
    p.add_argument(
        "--out", metavar="CAMPAIGN.csv", help="write the robot program (every waypoint), atomically"
    )
    p.add_argument(
        "--html",
        metavar="FILE.html",
        help="write the campaign as an animation in one self-contained HTML file (poses numbered in order)",
    )
    add_progress_argument(p)
    add_output_arguments(p)
    p.set_defaults(run=run)


def timing_from_args(robot, args: argparse.Namespace) -> Timing:
    """The time model of --joint-speeds, --joint-accelerations, --speed, --settle, --dwell."""

    def values(text: str | None, what: str):
        return None if text is None else parse_floats(text, what)

    try:
        return Timing.for_robot(
            robot,
            values(args.joint_speeds, "--joint-speeds"),
            values(args.joint_accelerations, "--joint-accelerations"),
            speed_fraction=args.speed,
            settle=args.settle,
            dwell=args.dwell,
        )
    except BadArgument as exc:
        option = {
            "speeds": "--joint-speeds",
            "accelerations": "--joint-accelerations",
            "speed_fraction": "--speed",
            "settle": "--settle",
            "dwell": "--dwell",
        }.get(str(exc.argument), "")
        raise BadArgument(
            f"{option}: {exc}" if option else str(exc), argument=option or exc.argument
        ) from None


def run(args: argparse.Namespace) -> int:
    robot = robot_from_args(args)
    plan = read_plan(robot, args.plan, args.deg)
    if plan.m > MAX_CAMPAIGN_POSES:
        raise BadArgument(
            f"--plan {args.plan}: {plan.m} poses; a campaign orders at most {MAX_CAMPAIGN_POSES} (it "
            "weighs every pair): split the plan",
            argument="--plan",
        )
    home = parse_configuration(robot, args.home, args.deg, "--home") if args.home else None
    timing = timing_from_args(robot, args)
    constraints = safe_constraints_from_args(robot, args)
    with recorded_warnings() as records:
        result = plan_campaign(
            robot,
            plan,
            home=home,
            timing=timing,
            constraints=constraints,
            check=not args.no_check,
            self_collision=not args.no_self_collision,
            seed=args.seed,
            progress=args.progress,
        )
        safety = safety_margins(robot, plan, constraints)
        if args.html:
            from pincal.viewing.animation import campaign_scene

            campaign_scene(result, constraints=constraints).save_html(args.html)
    if args.out:
        result.to_csv(args.out, degrees=args.deg)
    if args.json:
        payload = {"robot": robot.name, "plan": args.plan, "out": args.out, "html": args.html}
        payload.update(result.as_dict())
        payload["safety"] = safety.as_dict()
        emit_json(payload)
    else:
        print(f"{robot.name}: {len(plan)} poses of {args.plan}")
        print("\n".join(result.lines()))
        print("\n".join(safety.lines()))
        if args.out:
            print(f"wrote {args.out} (the robot program: {len(result.waypoints())} waypoints)")
        if args.html:
            print(f"wrote {args.html}: the campaign as an animation, one self-contained file")
    sys.stdout.flush()
    for w in records:
        print(f"pincal: warning: {w.message}", file=sys.stderr)
    return 0


# ----------------------------------------------------------------- design --campaign (trade-off)
TRADEOFF_HELP = """\
--campaign: also design plans of m = 6 ... 30 poses (--campaign-m to choose) with the same options,
order each into a campaign (URDF speeds, --dwell at each pose) and report the predicted error over the
test region next to the campaign's minutes; --campaign-plot FILE.png draws it.
"""


def add_tradeoff_arguments(p: argparse.ArgumentParser) -> None:
    """--campaign, --campaign-m, --campaign-plot, --dwell (of design)."""
    p.add_argument(
        "--campaign",
        action="store_true",
        help="report accuracy against campaign time for m = 6 ... 30 (and this plan's campaign time)",
    )
    p.add_argument("--campaign-m", metavar="SIZES", help="plan sizes of --campaign: 6:30:3 or 6,12,24")
    p.add_argument("--campaign-plot", metavar="FILE.png", help="save the --campaign figure")
    p.add_argument(
        "--dwell",
        default=None,
        metavar="KIND|S",
        help="the instrument's time per pose for --campaign: tracker (2 s), probe (10 s) or seconds",
    )


def check_tradeoff_arguments(args: argparse.Namespace, robot, test_pose) -> tuple | None:
    """(sizes, timing) of --campaign, checked before any work; None without --campaign."""
    if not args.campaign:
        if args.campaign_m or args.campaign_plot or args.dwell is not None:
            raise BadArgument("--campaign-m, --campaign-plot and --dwell go with --campaign")
        return None
    if test_pose is None:
        raise BadArgument("--campaign reports the predicted error over the test region: give --test-pose")
    sizes = parse_sizes(args.campaign_m) if args.campaign_m else DEFAULT_SIZES
    try:
        timing = Timing.for_robot(robot, dwell=args.dwell)
    except BadArgument as exc:
        raise BadArgument(f"--dwell: {exc}", argument="--dwell") from None
    return sizes, timing


def report_tradeoff(args: argparse.Namespace, params, test_pose, plan, sigma: float, keywords: dict):
    """(this plan's campaign, the trade-off) of --campaign, the figure saved; (None, None) without it.
    ``keywords``: the design's (its search, safety, prior and instrument are the trade-off's)."""
    checked = check_tradeoff_arguments(args, params.robot, test_pose)
    if checked is None:
        return None, None
    sizes, timing = checked
    search, safety = keywords["search"], keywords["safety"]
    campaign = plan_campaign(params.robot, plan, timing=timing, constraints=safety.constraints, check=False)
    measured = {k: keywords[k] for k in ("instrument", "orientation_length") if k in keywords}
    tradeoff = accuracy_vs_time(
        params, test_pose, sizes, timing=timing, prior=keywords.get("prior"), search=search, safety=safety,
        **(measured if "instrument" in measured else dict(measured, sigma=sigma)),
    )  # fmt: skip
    if args.campaign_plot:
        rows = tradeoff.rows
        fig = plots.accuracy_vs_time(
            [r.m for r in rows], [r.minutes for r in rows], [r.predicted for r in rows]
        )
        plots.save_figure(fig, args.campaign_plot)
    return campaign, tradeoff
