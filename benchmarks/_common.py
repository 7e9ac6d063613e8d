"""What every benchmark shares: the machine and load header, CPU time, and writing a section of
RESULTS.md. Run the benchmarks as scripts (``python benchmarks/bench_x.py``): benchmarks/ is then
on sys.path and ``from _common import ...`` finds this module."""

from __future__ import annotations

import datetime
import os
import platform
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def machine() -> str:
    """CPU model, cores, Python, Pinocchio and NumPy versions."""
    import numpy
    import pinocchio

    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{model}, nproc {os.cpu_count()}, Python {platform.python_version()}, pinocchio "
        f"{pinocchio.__version__}, numpy {numpy.__version__}"
    )


def load() -> str:
    """The load average over 1, 5 and 15 minutes."""
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def header(command: str) -> list[str]:
    """The lines that open a RESULTS.md section: machine, load, command, date."""
    return [
        f"- Machine: {machine()}; load average at the start {load()} (1/5/15 min).",
        f"- Command: `{command}`; date {datetime.date.today()}.",
    ]


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process, all its threads, and of its finished children
    (a design's worker processes): the figure to trust on a shared machine, where wall time says
    how busy the others are."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def write(lines: list[str], name: str) -> None:
    """Replace (or append) the ``## name`` section of benchmarks/RESULTS.md with ``lines``."""
    path = ROOT / "benchmarks" / "RESULTS.md"
    text = path.read_text() if path.exists() else "# Benchmark results\n"
    section = f"## {name}\n\n" + "\n".join(lines).rstrip() + "\n"
    pattern = re.compile(rf"^## {re.escape(name)}\n.*?(?=^## |\Z)", re.S | re.M)
    if pattern.search(text):
        text = pattern.sub(lambda _: section + "\n", text).rstrip() + "\n"
    else:
        text = text.rstrip() + "\n\n" + section
    path.write_text(text)
