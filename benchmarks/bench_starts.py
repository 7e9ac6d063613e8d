"""The adaptive number of starts (issue 31, item 6), run by hand:

    python benchmarks/bench_starts.py [--seeds 0 1 2] [--best 256]

For two designs, each seed: the default design (``starts=None``: batches of 8 until 3 starts
match the best within 1 %, at most 128) against the best known value (``--best`` starts, the
same seed), with the starts it ran, how many matched, and its wall time; and 8 starts (the default
before) for comparison.

1. KR 270, off-axis marker (0.1, 0.05, 0.2) m, identifiable ``lengths,offsets``, one test pose
   (0, -90, 90, 0, 45, 0)°, m = 4, σ = 1, no safety margins (``joint_margin=0, mount="none"``):
   a small plan whose starts end in many local optima.
2. The README's design: KR 270, identifiable ``full,offsets``, m = 12, ``around((0, -60, 60, 0,
   45, 0)°, 10°)``, the safe defaults.

The figures are printed (one Markdown table per design); copy them into benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from _common import footer, header, timed  # benchmarks/ is on sys.path when run as a script

import pincal


def cases():
    robot = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
    small = robot.parameters("lengths,offsets").identifiable().identifiable
    readme = robot.parameters("full,offsets").identifiable().identifiable
    yield (
        "KR 270, m = 4, one test pose, sigma = 1, no safety margins",
        (small, 4, np.radians([0, -90, 90, 0, 45, 0])),
        dict(sigma=1.0, safety=pincal.Safety(joint_margin=0, mount="none")),
    )
    yield (
        "README design: KR 270, m = 12, around((0, -60, 60, 0, 45, 0) deg, 10 deg)",
        (readme, 12, pincal.around(np.radians([0, -60, 60, 0, 45, 0]), np.radians(10))),
        {},
    )


def timed_design(args, **kw):
    with timed() as clock:
        result = pincal.design(*args, **kw)
    return result, clock.wall  # the default workers: the pool's CPU is not this process's


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--best", type=int, default=256, help="starts of the best known value")
    opts = parser.parse_args()
    warnings.simplefilter("ignore")
    print("\n".join(header()) + "\n")
    for title, args, kw in cases():
        print(f"### {title}\n")
        print(
            f"| seed | best known ({opts.best} starts) | default: starts (matched) | default: value / best | "
            "default: wall [s] | 8 starts: value / best | 8 starts: wall [s] |"
        )
        print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
        for seed in opts.seeds:
            best, _ = timed_design(args, **kw, search=pincal.Search(starts=opts.best, seed=seed))
            auto, t_auto = timed_design(args, **kw, search=pincal.Search(seed=seed))
            eight, t_eight = timed_design(args, **kw, search=pincal.Search(starts=8, seed=seed))
            value = min(best.value, auto.value, eight.value)
            print(
                f"| {seed} | {value:.6g} | {auto.starts} ({auto.matched}) | {auto.value / value:.4f} | "
                f"{t_auto:.1f} | {eight.value / value:.4f} | {t_eight:.1f} |",
                flush=True,
            )
        print()
    print("\n".join(footer()))


if __name__ == "__main__":
    main()
