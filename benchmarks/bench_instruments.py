"""Issue 19's validation figures: simulated campaigns of each instrument with known errors.

For each: the plan designed for the instrument, the parameters recovered from one simulated campaign
(RMS and largest z-score, (estimate − truth) / standard error), and a Monte-Carlo of the error at the
test pose against the predicted ρ0. Then the configurations a pose plan needs for a given ρ0 against
a point plan, and a tracker placed with the plan against its default placement.

    python benchmarks/bench_instruments.py            # about 15 CPU minutes; prints Markdown

Times are CPU seconds (user + sys of this process and of its design workers, ``os.times``): the machine is shared,
so wall time says more about the neighbours than about pincal.
"""

from __future__ import annotations

import argparse

import numpy as np
import pinocchio as pin
from _common import cpu_seconds, load, machine  # benchmarks/ is on sys.path when run as a script

import pincal
from pincal.errors import Infeasible, SingularPlan
from pincal.instruments import Camera, Image, Instrument, PerCoordinate, Pose, Tracker, grid
from pincal.instruments.identifiability import identifiable
from pincal.planning import place_instrument

UR10_Q0 = np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0])
PANDA_Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
KR270_Q0 = np.radians([0.0, -90.0, 90.0, 0.0, 45.0, 0.0])
MARKER = (0.05, 0.02, 0.1)
ERRORS = {"length": 1e-3, "angle": 1e-3}


class _Printed(list):
    """A list of report lines that prints each as it is added (a long run shows its progress)."""

    def __init__(self, lines: list[str]) -> None:
        super().__init__()
        for line in lines:
            self.append(line)

    def append(self, line: str) -> None:
        print(line, flush=True)
        super().append(line)


def recovered(params, truth, plan, measure, error, seed) -> tuple[float, float]:
    """(RMS z, max |z|) of one simulated campaign's estimates against the truth."""
    data = pincal.simulate_measurements(truth, plan, seed=seed, measure=measure, instrument=error)
    result = pincal.identify(params, data, instrument=error)
    assert result.status == "converged", result.message
    z = (result.values - truth.values) / result.std
    return float(np.sqrt(np.mean(z**2))), float(np.abs(z).max())


def campaign(name, params, m, q0, measure, error, trials, seed, **design):
    """One row: design, recovery, Monte-Carlo."""
    t = cpu_seconds()
    result = pincal.design(params, m, q0, measure=measure, instrument=error, seed=seed, **design)
    t_design = cpu_seconds() - t
    truth = pincal.random_errors(params, error_std=ERRORS, seed=seed + 1)
    z_rms, z_max = recovered(params, truth, result.plan, measure, error, seed + 2)
    t = cpu_seconds()
    mc = pincal.monte_carlo(
        params,
        result.plan,
        q0,
        trials=trials,
        seed=seed + 3,
        error_std=ERRORS,
        measure=measure,
        instrument=error,
    )
    t_mc = cpu_seconds() - t
    return (
        f"| {name} | {len(params)} | {m} | {result.rho0 * 1e3:.4g} mm | {z_rms:.2f} / {z_max:.2f} | "
        f"{mc.rho0_empirical * 1e3:.4g} ± {mc.rho0_empirical_se * 1e3:.2g} mm ({mc.trials - mc.failures} trials) | "
        f"{mc.rho0_empirical / mc.rho0_predicted:.3f} | {t_design:.1f} s | {t_mc:.1f} s |"
    )


def campaigns(trials: int) -> list[str]:
    rows = _Printed(
        [
            "| campaign | parameters | m | designed ρ0 | recovery z: RMS / max | Monte-Carlo error at q0 | "
            "MC / predicted | design CPU | Monte-Carlo CPU |",
            "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
        ]
    )
    # 6-D motion capture on a UR10 (0.1 mm, 2 mrad), its frame the robot's base moved: base identified.
    ur10 = pincal.load_robot("ur10").replace(
        base=pin.SE3(pin.rpy.rpyToMatrix(0, 0, 0.4), np.array([1.0, 0.5, 0]))
    )
    mocap = PerCoordinate(1e-4, 2e-3)
    params = identifiable(ur10.parameters("full,offsets,base"), Instrument(Pose(), mocap), prefer="base")
    rows.append(campaign("UR10, 6-D mocap (0.1 mm, 2 mrad), base identified", params.identifiable, 20,
                         UR10_Q0, Pose(), mocap, trials, 10))  # fmt: skip
    # An eye-in-hand camera on a Panda seeing a 6 × 5 grid (0.5 px).
    kind = Image(Camera(600, 600, 320, 240, (0.05, -0.02, 0.0, 0.0, 0.0), 640, 480), grid(6, 5, 0.03))
    target = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0, 0), np.array([0.5, 0, 0.0]))
    panda = pincal.load_robot("panda").with_fixtures(*kind.fixtures((0.05, 0, 0.05), target))
    pixels = PerCoordinate(sigma_px=0.5)
    params = identifiable(panda.parameters("full,offsets,instrument"), Instrument(kind, pixels))
    rows.append(campaign("Panda, eye-in-hand camera, 6 × 5 grid (0.5 px)", params.identifiable, 20, PANDA_Q0,
                         kind, pixels, trials, 0, starts=2))  # fmt: skip
    # A laser tracker (AT500 defaults) at 2 m and at 10 m from a KR 270.
    kr270 = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = kr270.parameters("full").identifiable().identifiable
    for d in (2.0, 10.0):
        tracker = Tracker((d + 1.0, 0.0, 1.5))  # the robot reaches ~1 m towards it
        rows.append(campaign(f"KR 270, tracker {d:g} m in front", params, 12, KR270_Q0, None, tracker,
                             trials, 30 + int(d)))  # fmt: skip
    return rows


def configurations_for(params, q0, target, measure, error, seed) -> tuple[int, float]:
    """The fewest configurations whose designed plan reaches ρ0 ≤ target (and that ρ0), by
    bisection over m (a designed plan's ρ0 falls as m grows)."""

    def designed(m: int) -> float:
        try:
            result = pincal.design(params, m, q0, measure=measure, instrument=error, seed=seed, starts=4)
        except (SingularPlan, Infeasible):
            return float("inf")
        return result.rho0

    low, high = 2, 8
    while designed(high) > target:
        low, high = high, 2 * high
        if high > 256:
            return -1, float("nan")
    best = designed(high)
    while high - low > 1:
        mid = (low + high) // 2
        value = designed(mid)
        if value <= target:
            high, best = mid, value
        else:
            low = mid
    return high, best


def pose_against_point() -> list[str]:
    ur10 = pincal.load_robot("ur10", markers=[MARKER])
    mocap = PerCoordinate(1e-4, 2e-3)
    points = ur10.parameters("full,offsets").identifiable().identifiable
    poses = Instrument(Pose(), mocap).identifiable(ur10.parameters("full,offsets")).identifiable
    rows = [
        "| target ρ0 at q0 | point plan (σ 0.1 mm): m, ρ0 | pose plan (0.1 mm, 2 mrad): m, ρ0 | CPU |",
        "| ---: | ---: | ---: | ---: |",
    ]
    for target in (0.1e-3, 0.05e-3, 0.03e-3):
        t = cpu_seconds()
        m_point, r_point = configurations_for(points, UR10_Q0, target, None, mocap, 1)
        m_pose, r_pose = configurations_for(poses, UR10_Q0, target, Pose(), mocap, 1)
        rows.append(
            f"| {target * 1e3:g} mm | {m_point}, {r_point * 1e3:.4g} mm ({len(points)} parameters) | "
            f"{m_pose}, {r_pose * 1e3:.4g} mm ({len(poses)} parameters) | {cpu_seconds() - t:.0f} s |"
        )
    return rows


def placement() -> list[str]:
    ur10 = pincal.load_robot("ur10", markers=[MARKER])
    params = ur10.parameters("full,offsets").identifiable().identifiable
    t = cpu_seconds()
    placed = place_instrument(params, 12, UR10_Q0, ((1.5, -2.0, 0.75), (9.0, 2.0, 0.75)), steps=3, refine=1,
                              starts=4, pool=500, seed=5, workers=1)  # fmt: skip
    return [
        f"- Box x 1.5–9 m, y ±2 m, z 0.75 m; {len(placed.values)} positions tried "
        f"({int(np.sum(~np.isfinite(placed.values)))} without a feasible plan); CPU {cpu_seconds() - t:.0f} s.",
        *[f"- {line.strip()}" for line in placed.lines()],
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=100, help="Monte-Carlo trials per campaign")
    parser.add_argument("--only", choices=("campaigns", "pose", "placement"))
    args = parser.parse_args()
    print(f"- Machine: {machine()}; load average {load()} at start.")
    sections = {
        "campaigns": lambda: campaigns(args.trials),
        "pose": pose_against_point,
        "placement": placement,
    }
    for name, run in sections.items():
        if args.only in (None, name):
            print(flush=True)
            rows = run()
            if not isinstance(rows, _Printed):
                print("\n".join(rows), flush=True)


if __name__ == "__main__":
    main()
