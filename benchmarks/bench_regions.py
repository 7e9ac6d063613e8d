"""Benchmark of designs for where the robot works (issue 9), run by hand:

    python benchmarks/bench_regions.py            # print the figures
    python benchmarks/bench_regions.py --write    # and replace the "## bench_regions" section of RESULTS.md

For the KR 270 (shipped) and the UR10 (example-robot-data), marker (0.1, 0.05, 0.2) m on tool0,
identifiable `lengths,offsets`, σ = 0.03 mm, m = 12:

1. five designs — for the test pose alone with the conditioning floor 1e-4 (the default before
   issue 9) and with 1e-2 (the default now), for the neighbourhood q0 ± 10° (``pincal.around``),
   for a 1 000-point joint-space path through q0 (``pincal.TestPath``), and D-optimal — and the
   predicted error each leaves at q0, over ±10° and ±20° around q0 (RMS of 512 configurations),
   along the path (RMS) and over the workspace (median of 2 000), all from ``pincal.accuracy``;
2. the time to design for a path of 10 points and of 10 000 points (same starts and seed): the
   mean criterion over a path is one precomputed P×P weight, so the two should cost the same.
"""

from __future__ import annotations

import argparse
import math
import timeit
import warnings

import numpy as np
from _common import footer, header, timed, write  # benchmarks/ is on sys.path when run as a script
from bench_design import mm

import pincal

SIGMA = 3e-5
M = 12
STARTS = 16
MARKER = [(0.1, 0.05, 0.2)]
ROBOTS = {
    "kr270": np.radians([0, -60, 60, 0, 45, 0]),
    "ur10": np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0]),
}
SWEEP = np.radians([30, 10, -10, 20, 15, 30])
"""The path: q0 + t·SWEEP for t in [-1, 1] (a seam through the test pose)."""


def path(q0: np.ndarray, n: int) -> np.ndarray:
    return q0 + np.linspace(-1.0, 1.0, n)[:, None] * SWEEP


def quiet(function, *args, **kwargs):
    """Call ``function`` with the degenerate-optimum warning silenced (it is what is compared)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.errors.DegenerateOptimumWarning)
        return function(*args, **kwargs)


def timed_design(params, test_pose, **kwargs):
    with timed() as clock:
        search = pincal.Search(starts=STARTS, seed=0)
        result = quiet(pincal.design, params, M, test_pose, sigma=SIGMA, search=search, **kwargs)
    return result, clock.wall  # workers=2: the pool's CPU is not this process's


def main() -> list[str]:
    lines: list[str] = []

    def say(text: str = "") -> None:
        print(text, flush=True)
        lines.append(text)

    for line in header():
        say(line)
    say("- Workers: 2 (all CPUs); design times are wall seconds.")
    say(
        f"- Problem: marker (0.1, 0.05, 0.2) m on tool0, identifiable `lengths,offsets`, σ = 0.03 mm, m = {M}, "
        f"{STARTS} starts, seed 0; path = q0 + t·(30, 10, −10, 20, 15, 30)°, t ∈ [−1, 1]."
    )
    say(
        "- Predicted error after calibration (`pincal.accuracy`): RMS at q0, over ±10° and ±20° boxes around q0"
    )
    say(
        "  (512 configurations each) and along the 1 000-point path; median over 2 000 workspace configurations."
    )
    for name, q0 in ROBOTS.items():
        robot = pincal.load_robot(name, tip="tool0", markers=MARKER)
        params = robot.parameters("lengths,offsets").identifiable().identifiable
        long_path = path(q0, 1000)
        designs = {
            "test pose (floor 1e-4)": timed_design(params, q0, safety=pincal.Safety(min_conditioning=1e-4)),
            "test pose, floor 1e-2": timed_design(params, q0, safety=pincal.Safety(min_conditioning=1e-2)),
            "neighbourhood ±10°": timed_design(params, pincal.around(q0, math.radians(10))),
            "path (1 000 points)": timed_design(params, pincal.TestPath(long_path)),
            "D-optimal": timed_design(params, q0, criterion="D"),
        }
        plans = {label: result.plan for label, (result, _) in designs.items()}
        first, *others = plans
        report = pincal.accuracy(params, plans[first], q0, sigma=SIGMA, compare={k: plans[k] for k in others})
        say()
        say(
            f"### {name}: q0 = ({', '.join(f'{math.degrees(v):.0f}' for v in q0)})°, {len(params)} parameters"
        )
        say()
        say(
            "| design for | at q0 | ±10° | ±20° | along the path | workspace median | ±10° / q0 | cond | design time |"
        )
        say("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        for (label, (result, seconds)), accuracy in zip(designs.items(), report.plans, strict=True):
            at = {row.where: row for row in accuracy.rows}
            along = pincal.rho0(params, result.plan, long_path, sigma=SIGMA)
            conditioning = pincal.criteria(params, result.plan).cond
            say(
                f"| {label} | {mm(at['test pose'].rms)} | {mm(at['±10°'].rms)} | {mm(at['±20°'].rms)} | {mm(along)} "
                f"| {mm(at['workspace'].median)} | {at['±10°'].rms / at['test pose'].rms:.1f} | {conditioning:.0f} | {seconds:.1f} s |"
            )
        say()
        times = {n: timed_design(params, pincal.TestPath(path(q0, n)))[1] for n in (10, 10_000, 10)}
        plan = designs["path (1 000 points)"][0].plan.q
        setup, call = {}, {}
        for n in (10, 10_000):
            with timed() as clock:
                criterion = pincal.evaluation.TestPoseCriterion(params, pincal.TestPath(path(q0, n)), SIGMA)
            setup[n] = clock.wall
            call[n] = min(timeit.repeat(lambda c=criterion, q=plan: c(q), number=200, repeat=5)) / 200
        say(
            f"Design time for a path of 10 points: {times[10]:.2f} s; of 10 000 points: {times[10_000]:.2f} s "
            f"(ratio {times[10_000] / times[10]:.2f}; {STARTS} starts, seed 0, the 10-point run repeated last so "
            "that warm-up does not favour it). One evaluation of the mean criterion over the path: "
            f"{call[10] * 1e6:.0f} µs for 10 points, {call[10_000] * 1e6:.0f} µs for 10 000 (best of 5 × 200 calls); "
            f"building it (the path's Jacobians, once): {setup[10] * 1e3:.1f} ms and {setup[10_000] * 1e3:.0f} ms."
        )
    say()
    for line in footer():
        say(line)
    return lines


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--write", action="store_true", help="replace the bench_regions section of RESULTS.md"
    )
    args = parser.parse_args()
    figures = main()
    if args.write:
        write(figures, "bench_regions")
