"""A regression snapshot of pincal's public results, for refactors that must not change them.

Runs a fixed list of CLI sessions (design with every search, criterion, kind of measurement, payloads,
a residual model, regions; evaluate, measure-sim, identify, next, campaign, compensate, export,
iso9283) in a scratch folder, in this process, and records every JSON output (times left out) and
the SHA-256 of every file written. ``record FILE`` writes the snapshot; ``compare FILE`` runs again
and prints every output that differs (exit 1), or says all are bit-identical (exit 0).

    python benchmarks/snapshot.py record /tmp/base.json      # on the commit before the change
    python benchmarks/snapshot.py compare /tmp/base.json     # on the change

Results are bit-identical only on one machine with one BLAS: this is a tool for a refactor, run by
hand, not a test. ``--only NAME`` runs the sessions whose name contains NAME.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import re
import sys
import tempfile
import time
import warnings
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

KR = ["kr270", "--test-pose=0,-60,60,0,45,0", "--deg", "--marker", "0.1,0.05,0.2"]
UR = ["ur10", "--test-pose=0,-1.2,1.5,-1,-1.5,0"]
FAST = ["--starts", "4", "--workers", "1", "--no-progress"]
PAYLOAD_PARAMS = "lengths,offsets,compliance"

# Each session: a name and its commands, run in order in one scratch folder (later commands read
# earlier outputs). A command's "--json" output is recorded; files written are hashed.
SESSIONS: list[tuple[str, list[list[str]]]] = [
    ("params", [["params", "kr270", "--marker", "0.1,0.05,0.2", "--json"]]),
    ("design-exchange", [["design", *KR, "-m", "10", *FAST, "--json", "--out", "plan.csv"]]),
    ("design-adaptive", [["design", *KR, "-m", "10", "--workers", "1", "--no-progress", "--json"]]),
    ("design-continuous", [["design", *KR, "-m", "10", "--method", "continuous", *FAST, "--json"]]),
    ("design-region", [["design", *KR, "-m", "10", "--around", "10deg", *FAST, "--json"]]),
    (
        "design-worst",
        [["design", *KR, "-m", "10", "--criterion", "test-pose-worst", "--around", "10deg", *FAST, "--json"]],
    ),
    *[(f"design-{c}", [["design", *KR, "-m", "10", "--criterion", c, *FAST, "--json"]]) for c in "DAE"],
    ("design-cond", [["design", *KR, "-m", "10", "--criterion", "cond", *FAST, "--json"]]),
    (
        "design-prior",
        [["design", *KR, "-m", "4", "--prior", "1mm,1mrad", "--sigma", "3e-5", *FAST, "--json"]],
    ),
    ("design-baseline", [["design", *KR, "-m", "10", "--baseline", "100", *FAST, "--json"]]),
    ("design-pose", [["design", *UR, "-m", "12", "--measure", "pose", "--base", *FAST, "--json"]]),
    ("design-z", [["design", *KR, "-m", "30", "--measure", "z", *FAST, "--json"]]),
    ("design-tracker", [["design", *KR, "-m", "10", "--instrument", "tracker", "--base", *FAST, "--json"]]),
    (
        "design-payloads",
        [
            [
                "design",
                *KR,
                "-m",
                "12",
                "--params",
                PAYLOAD_PARAMS,
                "--payloads",
                "0,135,270",
                "--task-payload",
                "270",
                *FAST,
                "--json",
                "--out",
                "plan.csv",
            ]
        ],
    ),
    (
        "design-pool",
        [
            ["design", *KR, "-m", "30", *FAST, "--json", "--out", "pool.csv"],
            ["design", *KR, "-m", "9", "--pool", "pool.csv", *FAST, "--json"],
        ],
    ),
    (
        "calibrate",
        [
            ["design", *KR, "-m", "10", *FAST, "--out", "plan.csv"],
            ["evaluate", *KR, "--plan", "plan.csv", "--sigma", "3e-5", "--json"],
            [
                "measure-sim",
                *KR[:1],
                *KR[2:],
                "--plan",
                "plan.csv",
                "--error-std",
                "1e-3,1e-3",
                "--sigma",
                "3e-5",
                "--seed",
                "3",
                "--out",
                "meas.csv",
            ],
            ["identify", *KR[:1], *KR[2:], "--data", "meas.csv", "--out", "cal.urdf", "--json"],
            ["next", *KR, "--data", "meas.csv", "--plan", "plan.csv", "-k", "2", "--json", "--no-progress"],
            ["campaign", *KR[:1], *KR[2:], "--plan", "plan.csv", "--json", "--out", "order.csv"],
            ["export", "cal.urdf", "--format", "yaml", "--out", "cal.yaml", "--json"],
            ["export", "cal.urdf", "--format", "mjcf", "--out", "mj.xml", "--json"],
            ["example", "program", "--out", "program.csv"],
            [
                "compensate",
                "kr270",
                "--marker",
                "0.1,0.05,0.2",
                "--calibration",
                "cal.urdf",
                "--targets",
                "program.csv",
                "--deg",
                "--out",
                "corrected.csv",
                "--json",
            ],
        ],
    ),
    (
        "calibrate-residual",
        [
            ["design", *KR, "-m", "40", *FAST, "--out", "plan.csv"],
            [
                "measure-sim",
                *KR[:1],
                *KR[2:],
                "--plan",
                "plan.csv",
                "--error-std",
                "1e-3,1e-3",
                "--sigma",
                "3e-5",
                "--seed",
                "4",
                "--out",
                "meas.csv",
            ],
            [
                "identify",
                *KR[:1],
                *KR[2:],
                "--data",
                "meas.csv",
                "--residual-model",
                "gp",
                "--out",
                "cal.urdf",
                "--json",
                "--no-progress",
            ],
            ["design", *KR, "-m", "10", "--residual-model", "cal.urdf", *FAST, "--json"],
        ],
    ),
    (
        "iso9283",
        [["example", "cycles", "--out", "cycles.csv"], ["iso9283", "--data", "cycles.csv", "--json"]],
    ),
]

TIMES = re.compile(r" in [0-9.e+-]+ ?(s|ms|min)\b")
VOLATILE = {"time_s", "elapsed_s", "seconds", "wall_s", "cpu_s", "time", "elapsed"}


def _clean(value: object) -> object:
    """JSON output without the keys that measure time, and without the scratch folder's path."""
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [_clean(v) for v in value]
    if isinstance(value, str) and value.startswith("/"):
        return Path(value).name
    if isinstance(value, str):
        return TIMES.sub(" in ~ s", value)
    return value


def run_session(commands: list[list[str]]) -> list[object]:
    from pincal.cli import main

    records: list[object] = []
    with tempfile.TemporaryDirectory() as folder:
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            for argv in commands:
                before = {p: p.stat().st_mtime_ns for p in Path(".").iterdir()}
                out, err = io.StringIO(), io.StringIO()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                        try:
                            code = main(list(argv))
                        except SystemExit as exit_:
                            code = exit_.code
                text = out.getvalue()
                record: dict[str, object] = {"argv": " ".join(argv), "exit": code}
                if "--json" in argv and code == 0:
                    record["json"] = _clean(json.loads(text))
                elif code != 0:
                    record["stderr"] = err.getvalue().strip().splitlines()[-1:]
                record["files"] = {
                    p.name: hashlib.sha256(p.read_bytes()).hexdigest()[:16]
                    for p in sorted(Path(".").iterdir())
                    if p.is_file() and before.get(p) != p.stat().st_mtime_ns and not p.name.endswith(".json")
                }
                records.append(record)
        finally:
            os.chdir(cwd)
    return records


def take(only: str | None) -> dict[str, object]:
    snapshot: dict[str, object] = {}
    for name, commands in SESSIONS:
        if only and only not in name:
            continue
        t = time.perf_counter()
        snapshot[name] = run_session(commands)
        print(f"snapshot: {name} ({time.perf_counter() - t:.0f} s)", file=sys.stderr)
    return snapshot


def _differences(old: object, new: object, where: str) -> list[str]:
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for key in sorted(set(old) | set(new)):
            if key not in old or key not in new:
                out.append(f"{where}.{key}: only in {'new' if key in new else 'old'}")
            else:
                out.extend(_differences(old[key], new[key], f"{where}.{key}"))
        return out
    if isinstance(old, list) and isinstance(new, list):
        if len(old) != len(new):
            return [f"{where}: {len(old)} items -> {len(new)}"]
        return [d for i, (a, b) in enumerate(zip(old, new)) for d in _differences(a, b, f"{where}[{i}]")]
    return [] if old == new else [f"{where}: {old!r} -> {new!r}"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("record", "compare"))
    parser.add_argument("file", type=Path)
    parser.add_argument("--only", help="run only the sessions whose name contains this")
    args = parser.parse_args()
    snapshot = take(args.only)
    if args.action == "record":
        args.file.write_text(json.dumps(snapshot, indent=1, sort_keys=True) + "\n")
        print(f"snapshot: {len(snapshot)} sessions written to {args.file}")
        return 0
    old = json.loads(args.file.read_text())
    if args.only:
        old = {k: v for k, v in old.items() if k in snapshot}
    differences = _differences(old, json.loads(json.dumps(snapshot)), "")
    for line in differences[:200]:
        print(line)
    print(
        f"snapshot: {len(snapshot)} sessions, {len(differences)} differences"
        + (" (bit-identical)" if not differences else "")
    )
    return 1 if differences else 0


if __name__ == "__main__":
    sys.exit(main())
