"""Issue 19's validation figures: simulated campaigns of each instrument with known errors.

For each: the plan designed for the instrument, the parameters recovered from one simulated campaign
(RMS and largest z-score, (estimate − truth) / standard error), and a Monte-Carlo of the error at the
test pose against the predicted ρ0. Then the configurations a pose plan needs for a given ρ0 against
a point plan with one and with three markers (``--only pose``: a sweep of m = 3…30 for each kind on
a UR10 and a KR 270, the smallest m reaching each target ρ0, a Monte-Carlo of two plans per kind,
and, with matplotlib, benchmarks/pose_against_point.png), a tracker placed with the plan against
its default placement, and the line of sight's cost in the continuous polish (``--only sight``).

    python benchmarks/bench_instruments.py            # about 25 CPU minutes; prints Markdown

Times are CPU seconds (user + sys of this process and of its design workers, ``os.times``): the machine is shared,
so wall time says more about the neighbours than about pincal.
"""

from __future__ import annotations

import argparse
import os

import numpy as np
import pinocchio as pin
from _common import cpu_seconds, footer, header  # benchmarks/ is on sys.path when run as a script

import pincal
from pincal.errors import DegenerateOptimum, Infeasible, SingularPlan
from pincal.instruments import Camera, Image, Instrument, PerCoordinate, Point, Pose, Tracker, grid
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


def recovered(params, truth, plan, instrument, seed) -> tuple[float, float]:
    """(RMS z, max |z|) of one simulated campaign's estimates against the truth."""
    data = pincal.simulate_measurements(truth, plan, seed=seed, instrument=instrument)
    result = pincal.identify(params, data, instrument=instrument)
    assert result.status == "converged", result.message
    z = (result.values - truth.values) / result.std
    return float(np.sqrt(np.mean(z**2))), float(np.abs(z).max())


def campaign(name, params, m, q0, instrument, trials, seed, **design):
    """One row: design, recovery, Monte-Carlo."""
    t = cpu_seconds()
    result = pincal.design(params, m, q0, instrument=instrument, search=pincal.Search(seed=seed, **design))
    t_design = cpu_seconds() - t
    truth = pincal.random_errors(params, error_std=ERRORS, seed=seed + 1)
    z_rms, z_max = recovered(params, truth, result.plan, instrument, seed + 2)
    t = cpu_seconds()
    mc = pincal.monte_carlo(
        params,
        result.plan,
        q0,
        trials=trials,
        seed=seed + 3,
        error_std=ERRORS,
        instrument=instrument,
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
                         UR10_Q0, Instrument(Pose(), mocap), trials, 10))  # fmt: skip
    # An eye-in-hand camera on a Panda seeing a 6 × 5 grid (0.5 px).
    kind = Image(Camera(600, 600, 320, 240, (0.05, -0.02, 0.0, 0.0, 0.0), 640, 480), grid(6, 5, 0.03))
    target = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0, 0), np.array([0.5, 0, 0.0]))
    panda = pincal.load_robot("panda").with_fixtures(*kind.fixtures((0.05, 0, 0.05), target))
    pixels = PerCoordinate(sigma_px=0.5)
    params = identifiable(panda.parameters("full,offsets,instrument"), Instrument(kind, pixels))
    rows.append(campaign("Panda, eye-in-hand camera, 6 × 5 grid (0.5 px)", params.identifiable, 20, PANDA_Q0,
                         Instrument(kind, pixels), trials, 0, starts=2))  # fmt: skip
    # A laser tracker (AT500 defaults) at 2 m and at 10 m from a KR 270.
    kr270 = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = kr270.parameters("full").identifiable().identifiable
    for d in (2.0, 10.0):
        tracker = Tracker((d + 1.0, 0.0, 1.5))  # the robot reaches ~1 m towards it
        rows.append(campaign(f"KR 270, tracker {d:g} m in front", params, 12, KR270_Q0, Instrument(Point(), tracker),
                             trials, 30 + int(d)))  # fmt: skip
    return rows


M_SWEEP = (3, 4, 5, 6, 7, 8, 9, 10, 12, 14, 16, 18, 20, 24, 30)
"""The plan sizes designed for each kind in the pose-against-point section."""

THREE_MARKERS = (MARKER, (-0.06, 0.05, 0.08), (0.02, -0.07, 0.06))
"""Three markers on the tool (the first is the one-marker plans' marker) [m, tip frame]."""

SIGMA = 1e-4
"""Every kind's position σ [m] in the pose-against-point section (mocap's 0.1 mm; its angle σ 2 mrad)."""


def rho0_at_marker(params, plan, q0, instrument, single) -> float:
    """ρ0 [m] at the test pose of the first marker alone, whatever the plan measured (one or three
    points, or poses): √tr(J₀ M⁻¹ J₀ᵀ), M = Σ JᵢᵀΣᵢ⁻¹Jᵢ the plan's weighted information and J₀ the
    one marker's position rows (``single``, the same parameters on the one-marker robot)."""
    from pincal.model.jacobian import JacobianEngine

    J = instrument.engine(params).jacobian(plan.q, frame="world") / instrument.reference
    M = np.einsum("mri,mrj->ij", J, J)
    J0 = JacobianEngine(params.on(single)).jacobian(np.asarray(q0)[None], frame="tip")[0]
    return float(np.sqrt(np.trace(J0 @ np.linalg.solve(M, J0.T))))


def sweep(robot_name, q0, seed) -> dict:
    """For each kind: the designed plan of every m of :data:`M_SWEEP` it can identify with, its ρ0 at
    the one marker, the design's CPU."""
    single = pincal.load_robot(robot_name, markers=[MARKER])
    three = pincal.load_robot(robot_name, markers=list(THREE_MARKERS))
    mocap = PerCoordinate(SIGMA, 2e-3)
    kinds = {
        "point, 1 marker": (single, Instrument(pincal.instruments.Point(), PerCoordinate(SIGMA))),
        "point, 3 markers": (three, Instrument(pincal.instruments.Point(), PerCoordinate(SIGMA))),
        "pose (0.1 mm, 2 mrad)": (single, Instrument(Pose(), mocap)),
    }
    out = {}
    for name, (robot, instrument) in kinds.items():
        params = instrument.identifiable(robot.parameters("full,offsets")).identifiable
        rows = instrument.kind.size(robot)
        designs = {}
        for m in M_SWEEP:
            if m * rows < len(params):
                continue
            t = cpu_seconds()
            try:
                result = pincal.design(params, m, q0, instrument=instrument, search=pincal.Search(seed=seed, starts=4, workers=1))  # fmt: skip
            except (SingularPlan, Infeasible, DegenerateOptimum):
                continue
            designs[m] = (
                result,
                rho0_at_marker(params, result.plan, q0, instrument, single),
                cpu_seconds() - t,
            )
        out[name] = (params, instrument, designs)
    return out


def fewest(designs: dict, target: float) -> int | None:
    """The smallest m of the sweep whose designed plan reaches ρ0 ≤ target (None: none does)."""
    reached = [m for m, (_, rho, _) in designs.items() if rho <= target]
    return min(reached) if reached else None


def pose_against_point(trials: int) -> list[str]:
    """The configurations each kind needs for a given ρ0 at the test pose (issue 19 item 4)."""
    rows = _Printed([])
    figure = {}
    for robot_name, q0, seed in (("ur10", UR10_Q0, 1), ("kr270", KR270_Q0, 2)):
        t = cpu_seconds()
        kinds = sweep(robot_name, q0, seed)
        figure[robot_name] = kinds
        reference = kinds["point, 1 marker"][2][30][1]
        rows.append(f"**{robot_name}** (test pose {np.round(q0, 3).tolist()} rad; sweep CPU {cpu_seconds() - t:.0f} s; "
                    f"the 30-configuration one-marker point plan reaches ρ0 {reference * 1e3:.4g} mm)")  # fmt: skip
        rows.append("")
        rows.append("| ρ0 at the marker, m = | " + " | ".join(str(m) for m in M_SWEEP) + " |")
        rows.append("| --- | " + " | ".join("---:" for _ in M_SWEEP) + " |")
        for name, (params, _, designs) in kinds.items():
            cells = [f"{designs[m][1] * 1e3:.4g}" if m in designs else "–" for m in M_SWEEP]
            rows.append(f"| {name} ({len(params)} parameters) [mm] | " + " | ".join(cells) + " |")
        rows.append("")
        targets = [(f"{f:g} × (= {f * reference * 1e3:.3g} mm)", f * reference) for f in (2.0, 1.5, 1.1, 1.0)]
        targets += [(f"{v * 1e3:g} mm", v) for v in (0.1e-3, 0.05e-3)]
        rows.append("| target ρ0 | " + " | ".join(kinds) + " |")
        rows.append("| --- | " + " | ".join("---:" for _ in kinds) + " |")
        for label, target in targets:
            cells = []
            for _, _, designs in kinds.values():
                m = fewest(designs, target)
                cells.append("> 30" if m is None else str(m))
            rows.append(f"| {label} | " + " | ".join(cells) + " |")
        rows.append("")
        # Monte-Carlo of two plans per kind: the predicted ρ0 (of what the plan measures, at all its
        # markers) against whole simulated calibrations.
        rows.append("| Monte-Carlo | m | predicted ρ0 | Monte-Carlo error at q0 | MC / predicted | CPU |")
        rows.append("| --- | ---: | ---: | ---: | ---: | ---: |")
        for name, (params, instrument, designs) in kinds.items():
            for m in (min(designs), 12 if 12 in designs else max(designs)):
                t = cpu_seconds()
                mc = pincal.monte_carlo(params, designs[m][0].plan, q0, trials=trials, seed=seed + m,
                                        error_std=ERRORS, instrument=instrument)  # fmt: skip
                rows.append(
                    f"| {name} | {m} | {mc.rho0_predicted * 1e3:.4g} mm | {mc.rho0_empirical * 1e3:.4g} ± "
                    f"{mc.rho0_empirical_se * 1e3:.2g} mm ({mc.trials - mc.failures} trials) | "
                    f"{mc.rho0_empirical / mc.rho0_predicted:.3f} | {cpu_seconds() - t:.0f} s |"
                )
        rows.append("")
    _plot(figure)
    return rows


def _plot(figure: dict, path: str = "benchmarks/pose_against_point.png") -> None:
    """ρ0 at the marker against m, one panel per robot, one line per kind (matplotlib optional)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(matplotlib not installed: no plot)")
        return
    fig, axes = plt.subplots(1, len(figure), figsize=(5 * len(figure), 3.8))
    for ax, (robot_name, kinds) in zip(np.atleast_1d(axes), figure.items()):
        for name, (_, _, designs) in kinds.items():
            ms = sorted(designs)
            ax.semilogy(ms, [designs[m][1] * 1e3 for m in ms], "o-", label=name, markersize=3)
        ax.set_xlabel("configurations m")
        ax.set_ylabel("designed ρ0 at the marker [mm]")
        ax.set_title(robot_name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"(plot: {path})")


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


def sight() -> list[str]:
    """The line of sight in the continuous polish: one design with a tracker's visibility and line of
    sight, then a placement with the polish (run it with ``PYTHONPATH=OTHER_TREE`` for a before)."""
    from pincal.planning.constraints import LineOfSight, Visibility

    ur10 = pincal.load_robot("ur10", markers=[MARKER])
    params = ur10.parameters("full,offsets").identifiable().identifiable
    at = (3.0, 0.0, 0.75)
    constraints = (Visibility(at, 40.0, 1.0, (0, 0, 1), np.radians(30)), LineOfSight(at, 0.01))
    t = cpu_seconds()
    result = pincal.design(params, 12, UR10_Q0, instrument=pincal.instruments.Instrument(pincal.instruments.Point(), Tracker(at)), search=pincal.Search(starts=2, pool=500, seed=5, workers=1, polish=True), safety=pincal.Safety(constraints=constraints))  # fmt: skip
    rows = [f"- design with line of sight and polish: CPU {cpu_seconds() - t:.1f} s, rho0 {result.rho0!r} m "
            f"(pincal from {os.path.dirname(pincal.__file__)})"]  # fmt: skip
    t = cpu_seconds()
    placed = place_instrument(params, 12, UR10_Q0, ((1.5, 0.0, 0.75), (9.0, 0.0, 0.75)), steps=3, refine=1,
                              starts=2, pool=300, polish=True, seed=3, workers=1)  # fmt: skip
    rows.append(f"- placement on the 1.5-9 m line with polish: CPU {cpu_seconds() - t:.1f} s, at {placed.at.tolist()}, "
                f"rho0 {placed.result.value!r} m, every position's {placed.values.tolist()}")  # fmt: skip
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=100, help="Monte-Carlo trials per campaign")
    parser.add_argument("--only", choices=("campaigns", "pose", "placement", "sight"))
    args = parser.parse_args()
    print("\n".join(header()))
    sections = {
        "campaigns": lambda: campaigns(args.trials),
        "pose": lambda: pose_against_point(args.trials),
        "placement": placement,
        "sight": sight,
    }
    for name, run in sections.items():
        if args.only in (None, name):
            print(flush=True)
            rows = run()
            if not isinstance(rows, _Printed):
                print("\n".join(rows), flush=True)
    print("\n".join(footer()))


if __name__ == "__main__":
    main()
