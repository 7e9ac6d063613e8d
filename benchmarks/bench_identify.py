"""Identification time and accuracy: scipy least_squares (trf, lm) on the same simulated data.

Problem: KUKA KR 270, marker (0.1, 0.05, 0.2) m on tool0, the identifiable base set of
`full,offsets` (27 parameters), 30 random configurations, σ = 3e-5 m, true errors 1 mm / 1 mrad;
five data sets (seeds 0..4). Prints the median wall time of ``pincal.identify``, the Jacobian
evaluations and the largest estimation error. Run it on an older checkout (PYTHONPATH) to compare
with the hand-written Gauss–Newton it replaced.

Run:  python benchmarks/bench_identify.py [METHOD ...]
"""

from __future__ import annotations

import sys
import time

import numpy as np

import pincal


def main(methods: list[str]) -> None:
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    for method in methods:
        times, evaluations, errors = [], [], []
        for seed in range(5):
            truth = pincal.random_errors(params, seed=seed)
            data = pincal.simulate_measurements(
                truth.robot, robot.random_configurations(30, seed), 3e-5, seed=seed
            )
            kwargs = {} if method == "default" else {"method": method}
            start = time.perf_counter()
            result = pincal.identify(params, data, **kwargs)
            times.append(time.perf_counter() - start)
            evaluations.append(result.iterations)
            errors.append(float(np.abs(result.values - truth.values).max()))
        print(
            f"{result.method:14s} median {np.median(times) * 1e3:6.1f} ms, Jacobians {evaluations}, "
            f"max |estimate - truth| {max(errors):.3g}"
        )


if __name__ == "__main__":
    main(sys.argv[1:] or ["trf", "lm"])
