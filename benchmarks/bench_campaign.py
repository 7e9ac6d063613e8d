"""From plan to campaign (issue 16), run by hand:

    python benchmarks/bench_campaign.py            # print the figures
    python benchmarks/bench_campaign.py --write    # and replace the "## bench_campaign" section of RESULTS.md

* Ordering: Held–Karp against brute force (time, same optimum) for n = 6 … 9 random KR 270 poses;
  Held–Karp's time up to 12; the 2-opt/Or-opt local search against the optimum on 20 instances of 12
  poses; the time a campaign saves against the design's own order (KR 270, 12-pose designs).
* Certified moves: for the campaigns of designed plans (KR 270 with capsules and a table in the
  cell; UR10 with its URDF's collision meshes), the distance evaluations and time per move, the
  certified bound against the smallest distance found by sampling each move at 1000 points, and
  the detours.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import warnings
from pathlib import Path

import numpy as np

import pincal
from pincal.campaign.ordering import held_karp, improve, tour_cost
from pincal.campaign.result import HOME
from pincal.campaign.schedule import plan_campaign
from pincal.campaign.timing import Timing
from pincal.planning.constraints import Mount, Obstacle, Workcell, with_safety
from pincal.planning.feasibility import Feasibility

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import footer, header, publish, timed  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
Q0 = np.radians([0, -60, 60, 0, 45, 0])


def ordering(robot) -> list[str]:
    timing = Timing.for_robot(robot)
    feasible = Feasibility(robot, with_safety(robot))
    rng = np.random.default_rng(0)
    lines = ["### Ordering (KR 270, URDF speeds, random feasible poses, home at the first)", ""]
    lines += [
        "| poses | Held–Karp [CPU s] | brute force [CPU s] | same optimum |",
        "| ---: | ---: | ---: | --- |",
    ]
    for n in (6, 7, 8, 9):
        cost = timing.matrix(feasible.sample(n + 1, rng))
        with timed() as exact_clock:
            exact = held_karp(cost)
        with timed() as brute_clock:
            brute = min(tour_cost(cost, p) for p in itertools.permutations(range(1, n + 1)))
        same = abs(exact.cost - brute) < 1e-12
        lines.append(f"| {n} | {exact_clock.cpu:.4f} | {brute_clock.cpu:.2f} | {same} |")
        print(lines[-1], flush=True)
    for n in (10, 12):
        cost = timing.matrix(feasible.sample(n + 1, rng))
        with timed() as clock:
            held_karp(cost)
        lines.append(f"| {n} | {clock.cpu:.4f} | – | – |")
    gaps = []
    for _ in range(20):
        cost = timing.matrix(feasible.sample(13, rng))
        gaps.append(tour_cost(cost, improve(cost, list(range(1, 13)))) / held_karp(cost).cost - 1)
    lines += [
        "",
        f"2-opt/Or-opt from the given order against the optimum, 20 instances of 12 poses: gap mean "
        f"{100 * np.mean(gaps):.2f} %, max {100 * np.max(gaps):.2f} %, optimal in {np.mean(np.array(gaps) < 1e-9):.0%}.",
    ]
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    saved = []
    for seed in range(5):
        plan = pincal.design(
            params,
            12,
            pincal.around(Q0, np.radians(10)),
            search=pincal.Search(seed=seed, starts=8, workers=1),
        ).plan
        c = plan_campaign(robot, plan, check=False)
        saved.append((c.given_time - c.tour_time, c.given_time, c.move_time))
    s = np.array(saved)
    lines.append(
        f"Designed 12-pose plans (±10° region, 5 seeds), campaign from home and back with a tracker's 2 s dwell: "
        f"the optimal order saves {s[:, 0].mean():.2f} s on average ({100 * (s[:, 0] / s[:, 1]).mean():.1f} % of "
        f"the campaign, {100 * (s[:, 0] / (s[:, 0] + s[:, 2])).mean():.0f} % of the moving time)."
    )
    print("\n".join(lines[-3:]), flush=True)
    return lines


def certification(name: str, robot, constraints, m: int) -> list[str]:
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    q0 = Q0 if name == "kr270" else np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0])
    plan = pincal.design(
        params,
        m,
        pincal.around(q0, np.radians(10)),
        search=pincal.Search(seed=0, starts=8, workers=1),
        safety=pincal.Safety(constraints=constraints),
    ).plan
    with timed() as clock:
        c = plan_campaign(robot, plan, constraints=constraints)
    elapsed = clock.cpu
    cell = [x for x in constraints if isinstance(x, Workcell)]
    world = (cell[0] if cell else Workcell((Obstacle("far", "sphere", (0.01,), (100, 0, 0)),))).world(
        robot, self_collision=True, mount_points=Mount("floor").bind(robot)
    )
    ratios, evals = [], []
    for mv in c.moves:
        if mv.check is None or mv.detour is not None or not mv.check.clear or mv.start == mv.end:
            continue
        a = c.home if mv.start == HOME else c.plan.q[mv.start]
        b = c.home if mv.end == HOME else c.plan.q[mv.end]
        if np.allclose(a, b):
            continue
        dense = world.distances_many(a[None] + np.linspace(0, 1, 1000)[:, None] * (b - a)[None]).min()
        ratios.append(mv.check.certified / dense)
        evals.append(mv.check.evaluations)
    detours = sum(mv.detour is not None for mv in c.moves)
    return [
        f"| {name} | {c.geometry.split(' (')[0]} | {len(c.moves)} | {np.mean(evals):.0f} (max {np.max(evals)}) | "
        f"{elapsed / len(c.moves):.3f} | {np.min(ratios):.2f} / {np.median(ratios):.2f} | {detours} | {len(c.blocked)} |"
    ]


def main() -> list[str]:
    warnings.simplefilter("ignore")
    lines = header() + [
        "- Times are CPU seconds (user + sys, of this process and its finished children; every design here",
        "  runs with `workers=1`), not wall clock: the machine is shared.",
        "",
    ]
    kr = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
    lines += ordering(kr)
    lines += [
        "",
        "### Certified moves (campaigns of 12-pose designs for the ±10° region)",
        "",
        "Certified bound: the lower bound of the smallest distance the certification states for a clear move,",
        "over the smallest distance found by sampling the move at 1000 points (≤ 1: the bound holds).",
        "",
        "| robot | geometry | moves | evaluations per move | CPU s per move | certified / sampled (min / median) | detours | blocked |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    table = Workcell((Obstacle("table", "box", (1.0, 1.0, 0.1), (1.9, 0.0, 0.4)),), min_distance=0.02)
    lines += certification("kr270", kr, (table,), 12)
    print(lines[-1], flush=True)
    ur = pincal.load_robot("ur10", markers=[(0.1, 0.05, 0.2)])
    lines += certification("ur10", ur, (), 12)
    print(lines[-1], flush=True)
    lines += ["", *footer()]
    return lines


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--write", action="store_true", help="replace the bench_campaign section of RESULTS.md"
    )
    args = parser.parse_args()
    publish(main(), "bench_campaign", args.write)
