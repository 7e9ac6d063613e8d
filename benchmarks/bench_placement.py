"""Where to put the tracker (issue 32): the screened placement search against the exhaustive one.

Each case runs the ``pincal design ... --place-instrument`` command itself (a child process: its
wall time, and the CPU seconds of it and its worker processes), once screened (the default,
``--place-screen 3``) and, where affordable, designed in full at every position
(``--place-screen all``, the search before the screen). UR10, marker (0.05, 0.02, 0.1) m, 12
configurations, test pose (0, -1.2, 1.5, -1, -1.5, 0) rad, the AT500 tracker under its range, the
reflector's 30° acceptance angle and the line of sight, the design's defaults (8 starts, pool 2000,
every CPU), with the continuous polish (the default) or without (``--no-polish``: the exhaustive
search with the polish is a polished design, minutes of CPU with the line of sight, at each of 15
to 33 positions).

Usage: ``nice -n 10 python benchmarks/bench_placement.py [--only issue|coarse|readme]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

from _common import footer, header, load, timed  # benchmarks/ is on sys.path when run as a script

COMMON = ["design", "ur10", "-m", "12", "--test-pose=0,-1.2,1.5,-1,-1.5,0", "--marker", "0.05,0.02,0.1",
          "--instrument", "tracker", "--no-accuracy", "--no-progress", "--json"]  # fmt: skip
ISSUE_BOX = "1.5,-2,0,4,2,1.5"
README_BOX = "1.5,-2,0.75,9,2,0.75"

NO_POLISH = ["--no-polish"]
CASES = {
    "coarse": [
        ("the issue's box, 2 steps, no polish, screened", ISSUE_BOX, ["--place-steps", "2", *NO_POLISH]),
        ("the issue's box, 2 steps, no polish, every position in full", ISSUE_BOX,
         ["--place-steps", "2", "--place-screen", "all", *NO_POLISH]),
    ],
    "readme": [
        ("the README's box, 3 steps, no polish, screened", README_BOX, NO_POLISH),
        ("the README's box, 3 steps, no polish, every position in full", README_BOX, ["--place-screen", "all", *NO_POLISH]),
    ],
    "issue": [
        ("the issue's box, 3 steps, no polish, screened", ISSUE_BOX, NO_POLISH),
        ("the issue's box, 3 steps, screened", ISSUE_BOX, []),
    ],
}  # fmt: skip


def run(box: str, extra: list[str]) -> dict:
    """One command: its placement, wall time [s] and CPU seconds (the command and its workers)."""
    python = os.path.join(os.path.dirname(sys.executable), "python")
    with timed() as clock:
        done = subprocess.run([python, "-m", "pincal", *COMMON, "--place-instrument", box, *extra],
                              capture_output=True, text=True, check=True)  # fmt: skip
    wall, cpu = clock.wall, clock.cpu
    out = json.loads(done.stdout)
    placement = out["placement"]
    return {
        "at": out["instrument_at"],
        "rho0_mm": out["rho0"] * 1e3,
        "default_mm": None if placement["default_value"] is None else placement["default_value"] * 1e3,
        "positions": len(placement["values"]),
        "designed_in_full": sum(placement["designed_in_full"]),
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=tuple(CASES))
    args = parser.parse_args()
    print("\n".join(header()), flush=True)
    for name, cases in CASES.items():
        if args.only and name != args.only:
            continue
        for what, box, extra in cases:
            row = run(box, extra)
            print(f"- {what} (--place-instrument {box} {' '.join(extra)}): {json.dumps(row)}; "
                  f"load average {load()}", flush=True)  # fmt: skip
    print("\n".join(footer()))


if __name__ == "__main__":
    main()
