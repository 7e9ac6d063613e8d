"""A stopped ``pincal`` leaves nothing behind: SIGTERM (what a scheduler, systemd, a container or a
CI timeout sends) ends a design like Ctrl-C — exit code 143, its worker processes gone, no output
and no temporary file — and SIGKILL, which no handler sees, still takes its workers with it
(:func:`pincal.planning.multistart.worker_start`). The processes are found in /proc: Linux only.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import pincal.cli
from tests.conftest import ROOT

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc (Linux)")

DESIGN = (
    "design kr270 -m 12 --test-pose=0,-60,60,0,45,0 --around 10deg --deg --marker 0.1,0.05,0.2 "
    "--baseline 2000 --workers 2 --starts 512 --no-progress --out plan.csv"
).split()
"""The README's design with 512 starts on 2 workers: minutes of work, stopped long before its end."""

STARTING_S = 120.0
"""How long the command may take to start its workers (imports, the robot, the pool; a busy machine)."""

ENDING_S = 60.0
"""How long its processes may take to end once it is stopped: a bound on a hang, not a speed (they end
in about a second on an idle machine; 20 s was exceeded once at load 15 on 2 cores)."""


def _stat(pid: int) -> tuple[int, str, int] | None:
    """(parent pid, state, start time in clock ticks) of process ``pid``, or None if there is none."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    fields = text[text.rindex(")") + 2 :].split()  # after "pid (comm) "
    return int(fields[1]), fields[0], int(fields[19])


def _descendants(root: int) -> dict[int, int]:
    """The living descendants of ``root``: {pid: start time} (its children, theirs, ...)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (stat := _stat(int(entry.name))) and stat[1] != "Z":
            parents[int(entry.name)] = stat
    found, frontier = {}, [root]
    while frontier:
        pid = frontier.pop()
        for child, (ppid, _, start) in parents.items():
            if ppid == pid and child not in found:
                found[child] = start
                frontier.append(child)
    return found


def _living(processes: dict[int, int]) -> list[int]:
    """Those of ``processes`` ({pid: start time}) still running (a zombie has ended; a pid taken
    since by another process, of another start time, too)."""
    return [
        pid
        for pid, start in processes.items()
        if (stat := _stat(pid)) is not None and stat[1] not in "ZX" and stat[2] == start
    ]


def _wait_for(condition, seconds: float, what: str):
    """Poll ``condition()`` until it is truthy (returned), or fail after ``seconds``."""
    deadline = time.monotonic() + seconds
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            pytest.fail(f"{what} after {seconds:g} s")
        time.sleep(0.1)


@pytest.fixture
def design_running(tmp_path):
    """A ``pincal design`` in tmp_path/run whose 2 workers run: (the process, its descendants
    {pid: start time}, the folder it runs in, the folder of its stdout and stderr)."""
    run, logs = tmp_path / "run", tmp_path / "logs"
    run.mkdir()
    logs.mkdir()
    with open(logs / "stdout", "wb") as out, open(logs / "stderr", "wb") as err:
        process = subprocess.Popen(
            [sys.executable, "-m", "pincal", *DESIGN],
            cwd=run,
            stdout=out,
            stderr=err,
            start_new_session=True,  # its own process group, which a test may signal whole
        )
    tree: dict[int, int] = {}
    try:

        def workers() -> dict[int, int] | None:
            if process.poll() is not None:
                pytest.fail(f"the design ended ({process.returncode}): {(logs / 'stderr').read_text()}")
            found = _descendants(process.pid)
            return found if len(found) >= 2 else None

        tree = _wait_for(workers, STARTING_S, "no two worker processes")
        yield process, tree, run, logs
    finally:
        if process.poll() is None:  # a failed test: stop what is left
            process.kill()
        process.wait()
        for pid in _living(tree):  # and the workers a failed test left
            os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("to", ["pincal", "its process group"])
def test_sigterm_stops_a_design_like_ctrl_c(design_running, to):
    """SIGTERM to pincal alone (docker stop, a kill), or to its whole group at once (systemd,
    Slurm): the workers dying of it first do not make it an internal error."""
    process, tree, run, logs = design_running
    if to == "pincal":
        process.send_signal(signal.SIGTERM)
    else:
        os.killpg(process.pid, signal.SIGTERM)
    code = process.wait(timeout=ENDING_S)
    assert code == 143, (logs / "stderr").read_text()
    assert "pincal: stopped (SIGTERM)" in (logs / "stderr").read_text()
    assert list(run.iterdir()) == []  # no plan.csv, no temporary file
    _wait_for(lambda: not _living(tree), ENDING_S, "processes of the stopped design still run")


def test_sigkill_takes_the_workers_along(design_running):
    process, tree, run, _ = design_running
    process.kill()
    assert process.wait(timeout=ENDING_S) == -signal.SIGKILL
    _wait_for(lambda: not _living(tree), ENDING_S, "workers outlive their killed parent")
    assert not (run / "plan.csv").exists()


def test_the_handler_is_the_cli_s_alone(monkeypatch):
    """main() takes SIGTERM while a command runs (143), and gives the handler back after."""
    import pincal.cli.params as command

    def run(args):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(10)  # the handler raises first
        return 0

    before = signal.getsignal(signal.SIGTERM)
    monkeypatch.setattr(command, "run", run)
    assert pincal.cli.main(["params", "planar_2r"]) == 143
    assert signal.getsignal(signal.SIGTERM) is before


def test_the_exit_codes_name_143():
    assert "143 stopped" in pincal.cli.EPILOG
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert "143 stopped (SIGTERM" in readme
