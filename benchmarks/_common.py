"""What every benchmark shares: the header of its figures (machine, load, command, commit, date), its
clock (CPU and wall), and writing its section of RESULTS.md.

Run the benchmarks as scripts (``python benchmarks/bench_x.py``): benchmarks/ is then on sys.path
and ``from _common import ...`` finds this module. A benchmark prints its lines and, with
``--write``, replaces its ``## bench_x`` section of benchmarks/RESULTS.md::

    lines = header()                       # machine, load at the start, command, commit, date
    with timed() as clock:
        result = pincal.design(...)
    lines.append(f"| ... | {clock.cpu:.1f} | {clock.wall:.1f} |")
    lines += footer()                      # the load at the end
    publish(lines, "bench_x", args.write)  # print, and write the section when asked

On a shared machine trust CPU seconds; wall time says how busy the others were (the header's load).
"""

from __future__ import annotations

import contextlib
import datetime
import os
import platform
import re
import shlex
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
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


def command() -> str:
    """The command that runs this benchmark, as typed from the repository's root."""
    script = Path(sys.argv[0]).resolve()
    try:
        script = script.relative_to(ROOT)
    except ValueError:
        pass
    return shlex.join(["python", str(script), *sys.argv[1:]])


def commit() -> str:
    """The checkout's commit (short hash), ``+changes`` when pincal/ or benchmarks/ differ from it;
    ``unknown`` outside a git checkout."""
    try:
        head = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        changed = subprocess.run(
            ["git", "-C", str(ROOT), "status", "--porcelain", "--", "pincal", "benchmarks"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+changes" if changed else "")


def header(command_line: str | None = None) -> list[str]:
    """The lines that open a RESULTS.md section: machine, load at the start, command (this run's
    unless given), commit, date."""
    return [
        f"- Machine: {machine()}; load average at the start {load()} (1/5/15 min).",
        f"- Command: `{command_line or command()}`; commit {commit()}; date {datetime.date.today()}.",
    ]


def footer() -> list[str]:
    """The line that closes a section: the load at the end (with the start's, how busy the machine was)."""
    return [f"- Load average at the end: {load()} (1/5/15 min)."]


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process, all its threads, and of its finished children
    (a design's worker processes): the figure to trust on a shared machine, where wall time says
    how busy the others are."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@dataclass
class Clock:
    """CPU seconds (:func:`cpu_seconds`: this process and its finished children) and wall seconds
    of a ``with timed() as clock:`` block; read them after the block."""

    cpu: float = 0.0
    wall: float = 0.0


@contextlib.contextmanager
def timed() -> Iterator[Clock]:
    """``with timed() as clock: ...`` then ``clock.cpu``, ``clock.wall`` [s]."""
    clock = Clock()
    cpu, wall = cpu_seconds(), time.perf_counter()
    try:
        yield clock
    finally:
        clock.cpu, clock.wall = cpu_seconds() - cpu, time.perf_counter() - wall


def write(lines: list[str], name: str, keep_notes: bool = False) -> None:
    """Replace (or append) the ``## name`` section of benchmarks/RESULTS.md with ``lines``.

    ``keep_notes``: keep what the section holds after its first table (notes written by hand under
    the figures), after the new lines.
    """
    path = ROOT / "benchmarks" / "RESULTS.md"
    text = path.read_text() if path.exists() else "# Benchmark results\n"
    section = f"## {name}\n\n" + "\n".join(lines).rstrip() + "\n"
    pattern = re.compile(rf"^## {re.escape(name)}\n.*?(?=^## |\Z)", re.S | re.M)
    found = pattern.search(text)
    if found and keep_notes:
        table = re.search(r"^\|.*?\|\n(?!\|)", found.group(0), re.S | re.M)
        if table:
            section += found.group(0)[table.end() :].rstrip() + "\n"
    if found:
        text = pattern.sub(lambda _: section + "\n", text).rstrip() + "\n"
    else:
        text = text.rstrip() + "\n\n" + section
    path.write_text(text)


def publish(lines: list[str], name: str, write_results: bool) -> None:
    """Print ``lines``; with ``write_results`` (the scripts' ``--write``) also replace the
    ``## name`` section of RESULTS.md with them."""
    print("\n".join(lines))
    if write_results:
        write(lines, name)
        print(f"wrote the {name} section of {ROOT / 'benchmarks' / 'RESULTS.md'}")
