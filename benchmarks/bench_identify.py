"""Identification time and accuracy: scipy least_squares (trf, lm) on the same simulated data.

Problem: KUKA KR 270, marker (0.1, 0.05, 0.2) m on tool0, the identifiable base set of
`full,offsets` (27 parameters), 30 random configurations, σ = 3e-5 m, true errors 1 mm / 1 mrad;
five data sets (seeds 0..4). Prints the median CPU and wall time of ``pincal.identify``, the Jacobian
evaluations and the largest estimation error. Run it on an older checkout (PYTHONPATH) to compare
with the hand-written Gauss–Newton it replaced.

Run:  python benchmarks/bench_identify.py [METHOD ...]
"""

from __future__ import annotations

import argparse

import numpy as np
from _common import footer, header, timed  # benchmarks/ is on sys.path when run as a script

import pincal


def main(methods: list[str]) -> None:
    print("\n".join(header()))
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    for method in methods:
        cpu, wall, evaluations, errors = [], [], [], []
        for seed in range(5):
            truth = pincal.random_errors(params, seed=seed)
            data = pincal.simulate_measurements(
                truth.robot, robot.random_configurations(30, seed), 3e-5, seed=seed
            )
            kwargs = {} if method == "default" else {"method": method}
            with timed() as clock:
                result = pincal.identify(params, data, **kwargs)
            cpu.append(clock.cpu)
            wall.append(clock.wall)
            evaluations.append(result.iterations)
            errors.append(float(np.abs(result.values - truth.values).max()))
        print(
            f"{result.method:14s} median {np.median(cpu) * 1e3:6.1f} ms CPU, {np.median(wall) * 1e3:6.1f} ms "
            f"wall, Jacobians {evaluations}, max |estimate - truth| {max(errors):.3g}"
        )
    print("\n".join(footer()))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("methods", nargs="*", default=["trf", "lm"], help="least_squares methods, or default")
    main(parser.parse_args().methods)
