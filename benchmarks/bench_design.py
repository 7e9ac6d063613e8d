"""Benchmark of the design engine (issue 3), run by hand:

    python benchmarks/bench_design.py            # print the figures
    python benchmarks/bench_design.py --write    # and replace the "## bench_design" section of RESULTS.md

1. KR 270, off-axis marker, identifiable `lengths,offsets`, test pose (0, -90, 90, 0, 45, 0)°,
   σ = 0.03 mm, m = 4 and m = 12: the best value a long run finds (both methods, many starts), then
   for each method the time to reach within 1 % of it (the smallest number of starts, doubling
   from 2, whose design is within 1 %; median over seeds), against the targets 10 s and 60 s.
2. ρ0 of the designed plans against the random-plan median and the D-optimal plan.
3. ρ0 of the m = 4 plan measured 3 times against the plan designed for 12 configurations.
4. UR10, identifiable `full` set, m = 12, from one pool of 1000 random configurations: exchange on
   ρ0 against a D-optimal exchange on the same pool (time and ρ0).
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
from _common import footer, header, timed, write  # benchmarks/ is on sys.path when run as a script

import pincal
from pincal.planning.baselines import random_plans
from pincal.planning.driver import design

ROOT = Path(__file__).resolve().parents[1]
Q0 = np.radians([0, -90, 90, 0, 45, 0])
SIGMA = 3e-5
TARGET = {4: 10.0, 12: 60.0}


def quiet_design(*args, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = design(*args, **kwargs)
    return result, any(issubclass(w.category, pincal.errors.DegenerateOptimumWarning) for w in caught)


def mm(x: float) -> str:
    return f"{x * 1e3:.5f} mm"


def time_to_one_percent(params, m, best, method, seeds, max_starts, **kw):
    """Per seed: (starts, seconds) of the first run, doubling the starts from 2, within 1 % of best."""
    out = []
    for seed in seeds:
        starts = 2
        while True:
            with timed() as clock:
                result, _ = quiet_design(
                    params,
                    m,
                    Q0,
                    sigma=SIGMA,
                    search=pincal.Search(method=method, starts=starts, seed=seed, **kw),
                )
            elapsed = clock.wall  # workers=2: the pool's CPU is not this process's
            if result.value <= 1.01 * best or starts >= max_starts:
                out.append((starts, elapsed, result.value <= 1.01 * best))
                break
            starts *= 2
    return out


def main() -> list[str]:
    lines: list[str] = []

    def say(text: str = "") -> None:
        print(text, flush=True)
        lines.append(text)

    for line in header():
        say(line)
    say("- Workers: 2, the default (all CPUs); times are wall seconds.")
    say(
        "- Problem: KR 270, marker (0.1, 0.05, 0.2) m on tool0, identifiable `lengths,offsets` (12 parameters),"
    )
    say("  test pose (0, −90, 90, 0, 45, 0)°, σ = 0.03 mm; default conditioning floor 1e-4.")
    say()
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    plans = {}
    say("### Time to within 1 % of the best value found (KR 270)")
    say()
    say(
        "| m | best ρ0 (long run) | how it was found | method | starts needed (per seed) | time to 1 % (per seed) | median | target |"
    )
    say("| ---: | ---: | --- | --- | --- | --- | ---: | ---: |")
    for m in (4, 12):
        with timed() as clock:
            long_c, _ = quiet_design(
                params,
                m,
                Q0,
                sigma=SIGMA,
                search=pincal.Search(method="continuous", starts=256, keep=0.25, seed=1000),
            )
            long_e, _ = quiet_design(
                params,
                m,
                Q0,
                sigma=SIGMA,
                search=pincal.Search(method="exchange", polish=True, starts=128, keep=0.25, seed=1000),
            )
        long_time = clock.wall
        best = min(long_c.value, long_e.value)
        how = (
            f"min of continuous 256 starts ({mm(long_c.value)}) and exchange+polish 128 starts "
            f"({mm(long_e.value)}), {long_time:.0f} s"
        )
        plans[m] = long_c if long_c.value <= long_e.value else long_e
        for method, kw in (("continuous", {}), ("exchange", {"polish": True})):
            runs = time_to_one_percent(params, m, best, method, seeds=(0, 1, 2), max_starts=256, **kw)
            starts = ", ".join(f"{s}{'' if ok else ' (not reached)'}" for s, _, ok in runs)
            times = ", ".join(f"{t:.1f} s" for _, t, _ in runs)
            median = float(np.median([t for _, t, _ in runs]))
            name = "exchange + polish" if kw else method
            say(
                f"| {m} | {mm(best)} | {how} | {name} | {starts} | {times} | {median:.1f} s | ≤ {TARGET[m]:.0f} s |"
            )
            how = "″"
    say()
    say("### Designed plan against the baselines (KR 270)")
    say()
    say(
        "| m | designed ρ0 | conditioning | random plans (10000): min / median / max | D-optimal plan ρ0 | designed / median |"
    )
    say("| ---: | ---: | ---: | --- | ---: | ---: |")
    for m in (4, 12):
        stats = random_plans(params, m, 10000, Q0, sigma=SIGMA, seed=0)
        d_opt, _ = quiet_design(
            params, m, Q0, criterion="D", sigma=SIGMA, search=pincal.Search(starts=32, seed=0)
        )
        r = plans[m]
        say(
            f"| {m} | {mm(r.rho0)} | {r.conditioning:.2g} | {mm(stats.min)} / {mm(stats.median)} / {mm(stats.max)} "
            f"| {mm(d_opt.rho0)} | {r.rho0 / stats.median:.2f} |"
        )
    say()
    say("### Repeating a plan against designing for more configurations (KR 270)")
    say()
    rep = pincal.rho0(params, plans[4].plan.repeat(3), Q0, sigma=SIGMA)
    say(
        f"- m = 4 plan measured 3 times (12 measurements): ρ0 = {mm(rep)} (= ρ0(m=4)/√3 = {mm(plans[4].rho0 / np.sqrt(3))})."
    )
    say(
        f"- plan designed for m = 12: ρ0 = {mm(plans[12].rho0)}; ratio repeated / designed = {rep / plans[12].rho0:.3f}."
    )
    say()
    say("### UR10, identifiable `full`, m = 12, one pool of 1000 random configurations")
    say()
    ur = pincal.load_robot("ur10")
    full = ur.parameters("full").identifiable().identifiable
    q0 = np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0])
    pool = ur.random_configurations(1000, np.random.default_rng(0))
    say(
        f"- {len(full)} parameters; test pose {np.round(q0, 3).tolist()} rad; marker at the tool0 origin; σ = 0.03 mm."
    )
    say()
    say("| design on the pool | starts | time | ρ0 | conditioning |")
    say("| --- | ---: | ---: | ---: | ---: |")
    for name, crit in (("exchange on ρ0 (test-pose)", "test-pose"), ("D-optimal exchange", "D")):
        with timed() as clock:
            r, floor_hit = quiet_design(
                full,
                12,
                q0,
                criterion=crit,
                sigma=SIGMA,
                search=pincal.Search(method="exchange", pool=pool, starts=16, seed=0),
            )
        say(
            f"| {name} | 16 | {clock.wall:.1f} s | {mm(r.rho0)} | {r.conditioning:.2g}{' (at floor)' if floor_hit else ''} |"
        )
    say()
    for line in footer():
        say(line)
    return lines


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--write", action="store_true", help="replace the bench_design section of RESULTS.md")
    args = parser.parse_args()
    figures = main()
    if args.write:
        write(figures, "bench_design")
