"""Import time of ``import pincal`` and ``pincal --help`` (issue 17 item 5: under 0.3 s).

Each command runs in a fresh Python process with its byte code cached (as after ``pip install``),
the commands interleaved so that the machine's load falls on them alike; the figures are the
median and the best of ``--repeat`` runs [s]. Beside them, on the same run: an empty Python
(``-c pass``) and ``import numpy, pinocchio`` alone, the floor that a package importing Pinocchio
at ``import`` time could not go under; and what the first use of a name costs
(``pincal.load_robot``: the model stage, NumPy and Pinocchio imported then).

    python benchmarks/bench_import.py [--before /path/to/older/checkout] [--repeat 21] [--write]

``--before`` measures another checkout in the same run (each tree imports its own pincal through
PYTHONPATH). ``--write`` replaces the bench_import section of benchmarks/RESULTS.md.
"""

from __future__ import annotations

import argparse
import compileall
import os
import statistics
import subprocess
import sys
from pathlib import Path

from _common import footer, header, publish, timed  # benchmarks/ is on sys.path when run as a script

ROOT = Path(__file__).resolve().parents[1]

COMMANDS = {
    "python -c pass": ["-c", "pass"],
    "import numpy, pinocchio": ["-c", "import numpy, pinocchio"],
    "import pincal": ["-c", "import pincal"],
    "pincal --help": ["-m", "pincal", "--help"],
    "import pincal; pincal.load_robot": ["-c", "import pincal; pincal.load_robot"],
}
"""What is timed: label → the arguments of ``python``."""

TREE_COMMANDS = ("import pincal", "pincal --help", "import pincal; pincal.load_robot")
"""The commands that depend on the tree (the others are measured once)."""


def wall(tree: Path, argv: list[str]) -> float:
    """Wall time [s] of ``python argv`` importing pincal from ``tree``, byte code cached."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    with timed() as clock:
        subprocess.run([sys.executable, *argv], env=env, capture_output=True, check=True, cwd=tree)
    return clock.wall


def heaviest(tree: Path, argv: list[str], n: int = 6) -> list[tuple[str, float]]:
    """The top-level imports of ``python -X importtime argv`` by their cumulative time [s]."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    run = subprocess.run(
        [sys.executable, "-X", "importtime", *argv], env=env, capture_output=True, text=True, cwd=tree
    )
    out = []
    for line in run.stderr.splitlines():
        if not line.startswith("import time:") or "|" not in line:
            continue
        _, cumulative, raw = line.split(":", 1)[1].split("|")
        if cumulative.strip().isdigit() and raw[1:2] != " ":  # nested imports are indented
            out.append((raw.strip(), int(cumulative) * 1e-6))
    return sorted(out, key=lambda p: -p[1])[:n]


def main() -> list[str]:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--before", type=Path, help="a checkout of the code to compare with")
    parser.add_argument("--repeat", type=int, default=21, help="runs of each command")
    parser.add_argument("--write", action="store_true", help="replace the bench_import section of RESULTS.md")
    args = parser.parse_args()

    trees = {"this": ROOT} | ({"before": args.before.resolve()} if args.before else {})
    for tree in trees.values():
        compileall.compile_dir(tree / "pincal", quiet=1)
    runs = [(name, label) for label in COMMANDS for name in (trees if label in TREE_COMMANDS else ["this"])]
    times: dict[tuple[str, str], list[float]] = {run: [] for run in runs}
    lines = header()
    for _ in range(args.repeat):
        for name, label in runs:
            times[name, label].append(wall(trees[name], COMMANDS[label]))
    lines += [
        *footer(),
        "- Each command in a fresh process, byte code cached, the commands interleaved; median and best of "
        "the runs [s], wall time (a start-up is what a user waits for).",
        "",
        "| command | tree | median [s] | best [s] |",
        "| --- | --- | ---: | ---: |",
    ]
    for name, label in runs:
        t = times[name, label]
        lines.append(f"| `{label}` | {name} | {statistics.median(t):.3f} | {min(t):.3f} |")
    floor = statistics.median(times["this", "import numpy, pinocchio"])
    empty = statistics.median(times["this", "python -c pass"])
    lines += [""]
    for name in trees:
        imp = statistics.median(times[name, "import pincal"])
        helped = statistics.median(times[name, "pincal --help"])
        lines.append(
            f"- {name}: `import pincal` {imp:.3f} s ({imp - empty:+.3f} s over an empty Python), "
            f"`pincal --help` {helped:.3f} s; `import numpy, pinocchio` alone {floor:.3f} s "
            f"(ratio `import pincal` / numpy+pinocchio: {imp / floor:.2f})."
        )
    lines += ["", "Heaviest top-level imports (`python -X importtime`, this tree, one run):", ""]
    for label in ("import pincal", "pincal --help", "import pincal; pincal.load_robot"):
        shown = ", ".join(f"{n} {t:.3f} s" for n, t in heaviest(ROOT, COMMANDS[label]))
        lines.append(f"- `{label}`: {shown}.")
    publish(lines, "bench_import", args.write)
    return lines


if __name__ == "__main__":
    main()
