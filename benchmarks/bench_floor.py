"""Where the conditioning floor's default belongs (issue 9), run by hand:

    python benchmarks/bench_floor.py            # print the figures
    python benchmarks/bench_floor.py --write    # and replace the "## bench_floor" section of RESULTS.md

For KR 270 and UR10 (tip tool0, off-axis marker (0.1, 0.05, 0.2) m, identifiable `lengths,offsets`,
σ = 0.03 mm, m = 12, one test pose), a design (exchange + polish, 16 starts, seed 0) for each
floor of the conditioning, and for comparison a design for the ±10° neighbourhood of the test pose
(floor 1e-4) and a Bayesian design with a 1 mm / 1 mrad prior (no floor). For each plan, the
predicted error after calibration (pincal.accuracy, linear: σ·sqrt(tr(J C Jᵀ))) at the test pose,
rms over ±10° and ±20° around it, and the median over the workspace (2000 configurations within
the joint limits), and whether the design warned (floor binding / effectively singular).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

import pincal

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import footer, header, publish, timed  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SIGMA = 3e-5
M = 12
FLOORS = (1e-8, 1e-6, 1e-4, 1e-3, 3e-3, 1e-2, 3e-2)
ROBOTS = {
    "kr270": np.radians([0, -60, 60, 0, 45, 0]),
    "ur10": np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0]),
}


def run_one(params, q0, **kw):
    with timed() as clock, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = pincal.design(
            params, M, sigma=SIGMA, **kw, search=pincal.Search(starts=16, seed=0, workers=1)
        )
    elapsed = clock.cpu  # workers=1: all of it in this process
    report = pincal.accuracy(params, result.plan, q0, sigma=SIGMA, prior=kw.get("prior"), samples=512)
    rows = {r.where: r for r in report.plans[0].rows}
    warned = (
        "yes" if any(issubclass(w.category, pincal.errors.DegenerateOptimumWarning) for w in caught) else ""
    )
    return (
        f"{rows['test pose'].rms * 1e3:.4f} | {rows['±10°'].rms * 1e3:.4f} | {rows['±20°'].rms * 1e3:.4f} | "
        f"{rows['workspace'].median * 1e3:.4f} | {result.conditioning:.3g} | {warned} | {elapsed:.1f}"
    )


def main() -> list[str]:
    lines = header() + [
        "",
        "Predicted error after calibration [mm] (σ = 0.03 mm, m = 12, 16 starts): at the test pose, rms over",
        "±10° and ±20° around it, workspace median; the plan's conditioning; whether design() warned; CPU time.",
    ]
    for name, q0 in ROBOTS.items():
        robot = pincal.load_robot(name, tip="tool0", markers=[(0.1, 0.05, 0.2)])
        params = robot.parameters("lengths,offsets").identifiable().identifiable
        lines += [
            "",
            f"### {name}, test pose {np.round(np.degrees(q0), 1).tolist()}°, {len(params)} parameters",
            "",
            "| design | at q0 | ±10° | ±20° | workspace median | conditioning | warned | CPU [s] |",
            "| --- | ---: | ---: | ---: | ---: | ---: | --- | ---: |",
        ]
        for floor in FLOORS:
            lines.append(
                f"| test pose, floor {floor:g} | "
                + run_one(params, q0, test_pose=q0, safety=pincal.Safety(min_conditioning=floor))
                + " |"
            )
            print(lines[-1], flush=True)
        region = pincal.around(q0, np.radians(10))
        lines.append(
            "| ±10° neighbourhood, floor 1e-4 | "
            + run_one(params, q0, test_pose=region, safety=pincal.Safety(min_conditioning=1e-4))
            + " |"
        )
        print(lines[-1], flush=True)
        prior = pincal.Prior(1e-3, 1e-3)
        lines.append(
            "| test pose, prior 1 mm / 1 mrad, no floor | "
            + run_one(params, q0, test_pose=q0, prior=prior)
            + " |"
        )
        print(lines[-1], flush=True)
        with timed() as clock:
            d = pincal.design(
                params, M, criterion="D", sigma=SIGMA, search=pincal.Search(starts=16, seed=0, workers=1)
            )
        rep = pincal.accuracy(params, d.plan, q0, sigma=SIGMA, samples=512)
        rows = {r.where: r for r in rep.plans[0].rows}
        lines.append(
            f"| D-optimal | {rows['test pose'].rms * 1e3:.4f} | {rows['±10°'].rms * 1e3:.4f} | {rows['±20°'].rms * 1e3:.4f} | "
            f"{rows['workspace'].median * 1e3:.4f} | {d.conditioning:.3g} | | {clock.cpu:.1f} |"
        )
        print(lines[-1], flush=True)
    return lines + ["", *footer()]


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="replace the bench_floor section of RESULTS.md")
    args = parser.parse_args()
    publish(main(), "bench_floor", args.write)
