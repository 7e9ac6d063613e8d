"""Every robot 'pincal robots' lists, vendor URDFs and vendor-like ones, through one calibration
rehearsal (issue 11, item 7). Run by hand:

    python benchmarks/bench_robots.py            # print the table (markdown)
    python benchmarks/bench_robots.py --write    # and replace the "## bench_robots" section of RESULTS.md

For each robot: the chain (default, or the longest arm when the tip is ambiguous), its joints,
the identifiable / total parameters of ``full,offsets`` with one off-axis marker, the minimum
number of configurations ceil(P/3), the design time with m = minimum + 2 (exchange, 2 starts,
σ = 30 µm), and the round trip: errors drawn (1 mm, 1 mrad), measurements simulated with σ,
identified; worst |identified − true| / std, and the position error at the test pose before and
after calibration against the predicted ρ0.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _common import footer, header, write  # noqa: E402  benchmarks/ is on sys.path as a script

import pincal  # noqa: E402
from tests.support.robot_zoo import MARKER, chain_of, listed_robots, rehearse  # noqa: E402
from tests.support.vendor_like import z_axis_urdf  # noqa: E402

VENDOR = [
    (
        "Kinova Gen3 7-DoF, ros_kortex as published (rpy 1.5708, 3.1416)",
        "GEN3-7DOF-NOVISION_FOR_URDF_ARM_V12.urdf",
    ),
]
"""Real vendor URDFs copied into tests/data/vendor/ (with their licences), meshes missing."""


def vendor() -> list[tuple[str, Path]]:
    return [(label, ROOT / "tests" / "data" / "vendor" / name) for label, name in VENDOR]


def vendor_like(folder: Path) -> list[tuple[str, Path]]:
    """kr270 and ur10 with z-axis joint frames and rpy rounded to 4 digits; the UR10 with its
    wrist 3 made continuous."""
    out = []
    for name, continuous in (("kr270", ()), ("ur10", ()), ("ur10", ("wrist_3_joint",))):
        robot = pincal.load_robot(name, markers=MARKER)
        label = f"{name} z-axis rpy 4 digits" + (", continuous wrist 3" if continuous else "")
        path = folder / f"{name}{'_cont' if continuous else ''}_r4.urdf"
        path.write_text(z_axis_urdf(robot, 4, continuous=continuous))
        out.append((label, path))
    return out


def row(label: str, robot: pincal.Robot | None, refused: str) -> str:
    if robot is None:
        return f"| {label} | refused: {refused} | | | | | |"
    chain = f"{robot.root or robot.model.frames[1].name} → {robot.tip}"
    note = ""
    try:
        r = rehearse(robot)
    except pincal.PincalError as exc:  # no plan of minimum + 2 reaches the conditioning floor
        note = f" (m = min + 2 refused: {exc}; m = min + 6 shown)"
        try:
            r = rehearse(robot, extra=6)
        except pincal.PincalError as again:
            return (
                f"| {label} | {chain} | {robot.nq} | | | | design refused at min + 2 and min + 6: {again} |"
            )
    return (
        f"| {label} | {chain} | {robot.nq} | {r.identifiable}/{r.total} | {-(-r.identifiable // 3)} "
        f"| {r.design_seconds:.1f} | {r.worst_z:.2f} σ; {r.error_before * 1e3:.3g} → "
        f"{r.error_after * 1e3:.3g} mm (ρ0 {r.rho0 * 1e3:.3g} mm){note} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write the section into RESULTS.md")
    args = parser.parse_args()
    intro = header() + [
        "- Marker (0.05, 0.02, 0.03) m in the tip frame; σ = 30 µm; errors 1 mm / 1 mrad; seed 0.",
        "",
    ]
    print("\n".join(intro), flush=True)
    lines = [
        "| robot | chain | nq | parameters identifiable/total | minimum m | design s (m = min + 2) "
        "| identify round trip: worst error; test-pose error before → after (predicted ρ0) |",
        "| --- | --- | ---: | ---: | ---: | ---: | --- |",
    ]
    for name in listed_robots():
        chain = chain_of(name)
        lines.append(row(name, chain.robot, chain.refused))
        print(lines[-1], flush=True)
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.PincalWarning)  # the vendor files' missing meshes
        for label, path in vendor() + vendor_like(Path(folder)):
            lines.append(row(label, pincal.load_robot(path, markers=MARKER), ""))
            print(lines[-1], flush=True)
    print("\n".join(footer()))
    if args.write:  # the header and the table are replaced; the notes written under the table are kept
        write([*intro[:-2], *footer(), *intro[-2:], *lines], "bench_robots", keep_notes=True)


if __name__ == "__main__":
    main()
