"""Every command the README shows, and every --help example, runs as written (issue 32).

The README's ``bash`` blocks run block by block, each in an empty folder, top to bottom, through the
installed ``pincal`` (``python -m pincal``): the files a block reads are the ones its own lines make
(``pincal example NAME``, a design's ``--out``, a rehearsal's ``measure-sim``). The --help examples of
each command run in order in one empty folder per command; a file an example reads and no earlier
example wrote is made the way the README says (the shipped ``pincal example``, or ``design`` /
``measure-sim`` / ``identify`` with the example's own robot, units and instrument). ``pincal show``
without --html serves its scene until stopped: it runs until it prints the viewer's address, then
gets Ctrl-C. Every command must exit 0.

Slow (a few minutes: every design runs as written): ``pytest -m slow tests/contracts/test_examples_run.py``.
"""

from __future__ import annotations

import importlib
import os
import re
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.cli import COMMANDS
from tests.conftest import ROOT

SETUP = ("python3 -m venv", ".venv/bin/")
"""The README's set-up lines (CI runs the first; the second is this suite)."""

OTHER_TOOLS = (".yaml", ".yml", ".bag", ".db3", ".mcap")
"""--data files of other tools (pincal.calibration.formats), which only their users have."""

EXAMPLE_FILES = {"rig.yaml": "rig", "cell.yaml": "cell", "fixture.stl": "fixture", "table.yaml": "table"}
"""Inputs the help examples read that ``pincal example`` ships under that name."""


def _commands(text: str) -> list[list[str]]:
    """The pincal command lines of a shell text: continuations joined, comments dropped, shell
    variables (``NAME=value`` lines, then ``$NAME``) expanded."""
    out, variables = [], {}
    for line in text.replace("\\\n", " ").splitlines():
        assignment = re.fullmatch(r"\s*([A-Z_]+)=(\S+)\s*", line)
        if assignment:
            variables[assignment.group(1)] = assignment.group(2)
            continue
        for name, value in variables.items():
            line = line.replace(f"${name}", value)
        words = shlex.split(line, comments=True)
        if words and words[0] == "pincal":
            out.append(words)
    return out


def readme_blocks() -> list[tuple[str, list[list[str]]]]:
    """(where, commands) of each README bash block holding pincal commands, set-up lines left out."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = []
    for match in re.finditer(r"```bash\n(.*?)```", text, re.S):
        if any(s in match.group(1) for s in SETUP):
            continue
        line = text[: match.start()].count("\n") + 2
        commands = _commands(match.group(1))
        if commands:
            blocks.append((f"README.md:{line}", commands))
    return blocks


def help_examples() -> list[tuple[str, list[list[str]]]]:
    """(command, its examples) of every command's --help, in order."""
    out = []
    for name, command in COMMANDS.items():
        examples = getattr(importlib.import_module(command.module), "EXAMPLES", "")
        commands = _commands(examples.split("\n\n")[0])
        if commands:
            out.append((name, commands))
    return out


def run(words: list[str], folder: Path, timeout: float = 900) -> subprocess.CompletedProcess:
    """Run ``pincal WORDS`` (``> FILE`` redirects stdout) in ``folder``; a serving ``show`` is stopped
    with Ctrl-C once it prints its address."""
    words = list(words)
    stdout_file = None
    if ">" in words:
        i = words.index(">")
        stdout_file, words = folder / words[i + 1], words[:i] + words[i + 2 :]
    argv = [sys.executable, "-m", "pincal", *words[1:]]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    if words[1] == "show" and "--html" not in words and "--json" not in words:
        process = subprocess.Popen(
            argv, cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
        )
        assert process.stdout is not None
        started = time.monotonic()
        seen = []
        for line in process.stdout:
            seen.append(line)
            if "http://" in line or time.monotonic() - started > timeout:
                break
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=60)
        return subprocess.CompletedProcess(argv, process.returncode, "".join(seen) + out, err)
    done = subprocess.run(argv, cwd=folder, capture_output=True, text=True, timeout=timeout, env=env)
    if stdout_file is not None and done.returncode == 0:
        stdout_file.write_text(done.stdout)
    return done


# ---------------------------------------------------------------------------------- inputs of help examples
CONTEXT = ("--deg", "--mm", "--base")
CONTEXT_VALUES = (
    "--marker",
    "--measure",
    "--camera",
    "--anchor",
    "--instrument",
    "--instrument-at",
    "--sigma",
    "--sigma-rot",
    "--root",
    "--tip",
    "--params",
)
"""The options that say what a robot measures and how its files are written: the files made for an
example follow them."""


def _options(words: list[str]) -> dict[str, list[str]]:
    """Each option of a command line with its values (``--x=v`` and ``--x v`` alike)."""
    out: dict[str, list[str]] = {}
    i = 2
    while i < len(words):
        word = words[i]
        if word.startswith("--"):
            name, _, value = word.partition("=")
            if not value and i + 1 < len(words) and not words[i + 1].startswith("--"):
                value = words[i + 1]
                i += 1
            out.setdefault(name, []).append(value)
        i += 1
    return out


def _context(words: list[str], options: dict[str, list[str]], measure: bool = True) -> list[str]:
    """The example's robot and its measuring options, for the commands that make its inputs."""
    out = [words[2]] if len(words) > 2 and not words[2].startswith("-") else []
    for name in CONTEXT_VALUES:
        if name in ("--params",) or (not measure and name in ("--sigma", "--sigma-rot")):
            continue
        for value in options.get(name, []):
            out += [f"{name}={value}"]
    return out


def _key(options: dict[str, list[str]], robot: str) -> tuple:
    """What a file made for an example depends on: its robot, units and instrument."""
    return (robot, *(tuple(options.get(name, [])) for name in (*CONTEXT, *CONTEXT_VALUES)))


def make_inputs(words: list[str], folder: Path, made: dict[str, tuple]) -> None:
    """Make in ``folder`` each file the example reads that is not there yet, or that was made (by an
    earlier example or here: ``made``, file → :func:`_key`) for another robot, unit or instrument."""
    options = _options(words)
    deg = ["--deg"] if "--deg" in options else []
    positional = words[2] if len(words) > 2 and not words[2].startswith("-") else ""
    robot = options["--robot"][0] if "--robot" in options else positional
    robot_args = ([robot] if robot and robot != positional else []) + _context(words, options)
    key = _key(options, robot)
    if robot.endswith(".urdf") and not (folder / robot).exists():  # "your URDF": the KR 270's
        (folder / robot).parent.mkdir(parents=True, exist_ok=True)
        (folder / robot).write_text(pincal.shipped_robots()["kr270"].read_text())

    def pincal_ok(*argv: str) -> None:
        done = run(["pincal", *argv], folder)
        assert done.returncode == 0, (argv, done.stderr[-2000:])

    def fresh(path: str) -> bool:
        """True when ``path`` must be made (missing, or made for another robot's context)."""
        return not (folder / path).exists() or bool(robot) and made.get(path, key) != key

    def plan(path: str, rows: int = 30) -> None:
        if not fresh(path):
            return
        made[path] = key
        if "--camera" in options:  # views that see the target: a design
            pincal_ok("design", *robot_args, "-m", "20", "--test-pose=0,-0.3,0,-2.2,0,2,0.8", *deg,
                      "--starts", "2", "--workers", "1", "--no-progress", "--out", path)  # fmt: skip
            return
        loaded = pincal.load_robot(folder / robot if robot.endswith(".urdf") else robot)
        qs = loaded.random_configurations(rows, 7)
        pincal.Plan.for_robot(loaded, qs).to_csv(folder / path, degrees=bool(deg))

    def data(path: str) -> None:
        if not fresh(path):
            return
        plan("_plan_for_data.csv")
        made[path] = key
        extra = ["--base-pose=2.5,-1.0,0.2,0,0,1.2"] if "--base" in options else []
        extra += ["--mm"] if "--mm" in options else []
        seed = str(sum(path.encode()))
        pincal_ok("measure-sim", *robot_args, "--plan", "_plan_for_data.csv", *deg,
                  "--error-std", "1e-3,1e-3", *extra, "--seed", seed, "--out", path)  # fmt: skip

    for values in options.values():  # the shipped examples first: the others may read them (a rig)
        for value in values:
            if value in EXAMPLE_FILES and not (folder / value).exists():
                pincal_ok("example", EXAMPLE_FILES[value], "--out", value)
            if value == "cell.yaml" and not (folder / "fixture.stl").exists():
                pincal_ok("example", "fixture", "--out", "fixture.stl")
    for name, values in options.items():
        for value in values:
            if not value or value in EXAMPLE_FILES:
                continue
            if name in ("--plan", "--compare", "--pool"):
                plan(value, 60 if name == "--pool" else 30)
            elif name in ("--data", "--validate") and fresh(value):
                data(value)
            elif name == "--targets" and not (folder / value).exists():
                pincal_ok("example", "program" if "program" in value else "points", "--out", value)
            elif name == "--test-path" and not (folder / value).exists():
                pincal_ok("example", "weld", "--out", value)
            elif name in ("--calibration", "--residual-model") and value.endswith(".urdf") and fresh(value):
                data("_data_for_cal.csv")
                made[value] = key
                pincal_ok("identify", *robot_args, "--data", "_data_for_cal.csv",
                          *deg, "--residual-model", "gp", "--no-progress", "--out", value)  # fmt: skip
            elif name == "--true" and fresh(value):
                plan("_plan_for_true.csv")
                made[value] = key
                pincal_ok("measure-sim", *robot_args, "--plan", "_plan_for_true.csv", *deg, "--error-std",
                          "1e-3,1e-3", "--save-true", value, "--out", "_true_data.csv")  # fmt: skip
    for word in words[2:]:  # a positional input: a DH table
        if word in EXAMPLE_FILES and not (folder / word).exists():
            pincal_ok("example", EXAMPLE_FILES[word], "--out", word)


def outputs_made(words: list[str], made: dict[str, tuple]) -> None:
    """Record the files an example wrote, with what they were made for (a shipped example is for
    whatever reads it: never made again)."""
    if words[1] == "example":
        return
    options = _options(words)
    positional = words[2] if len(words) > 2 and not words[2].startswith("-") else ""
    robot = options["--robot"][0] if "--robot" in options else positional
    for name in ("--out", "--save-true"):
        for value in options.get(name, []):
            made[value] = _key(options, robot)


# ----------------------------------------------------------------------------------------------- tests
@pytest.mark.slow
@pytest.mark.parametrize("where,commands", readme_blocks(), ids=[w for w, _ in readme_blocks()])
def test_readme_block_runs_as_written(where, commands, tmp_path):
    for words in commands:
        done = run(words, tmp_path)
        assert done.returncode == 0, f"{where}: {shlex.join(words)}\n{done.stderr[-3000:]}"


@pytest.mark.slow
@pytest.mark.parametrize("name,commands", help_examples(), ids=[n for n, _ in help_examples()])
def test_help_examples_run_as_written(name, commands, tmp_path):
    made: dict[str, tuple] = {}
    for words in commands:
        if any(value.endswith(OTHER_TOOLS) for value in _options(words).get("--data", [])):
            continue  # another tool's files (FIGAROH, ROS): tests/calibration/test_formats.py reads them

        make_inputs(words, tmp_path, made)
        done = run(words, tmp_path)
        outputs_made(words, made)
        assert done.returncode == 0, f"pincal {name} --help: {shlex.join(words)}\n{done.stderr[-3000:]}"


def test_every_example_file_is_read_by_its_command(tmp_path, cli):
    """What `pincal example` writes is what its commands read: the rig, the cell with its mesh, the
    program and the points, the path, the taught poses, the DH table, the ISO cycles."""
    from pincal.evaluation.pose_cycles import read_pose_cycles
    from pincal.instruments import load_rig
    from pincal.model.dh import DHTable
    from pincal.planning.constraints import load_constraints

    files = {"rig": "rig.yaml", "cell": "cell.yaml", "fixture": "fixture.stl", "program": "program.csv",
             "points": "points.csv", "weld": "weld.csv", "taught": "taught.csv", "table": "table.yaml",
             "cycles": "cycles.csv"}  # fmt: skip
    for name, file in files.items():
        assert cli.run("example", name, "--out", tmp_path / file).code == 0
    kr270, ur10 = pincal.load_robot("kr270"), pincal.load_robot("ur10")
    assert len(load_rig(tmp_path / "rig.yaml").fixtures) == 2
    assert len(load_constraints(tmp_path / "cell.yaml")) == 1  # the workcell, its mesh read beside it
    assert len(pincal.Plan.from_csv(tmp_path / "program.csv", robot=kr270, degrees=True)) == 8
    assert len(pincal.Plan.from_csv(tmp_path / "weld.csv", robot=kr270, degrees=True)) == 15
    assert len(pincal.Plan.from_csv(tmp_path / "taught.csv", robot=ur10)) == 60
    assert DHTable.from_yaml(tmp_path / "table.yaml").nq == 6
    cycles = read_pose_cycles(tmp_path / "cycles.csv", millimetres=True, degrees=True)
    assert sorted(set(cycles.pose)) == ["P1", "P2", "P3", "P4", "P5"] and len(cycles.pose) == 50
    np.testing.assert_allclose(np.loadtxt(tmp_path / "points.csv", delimiter=",", skiprows=1).shape, (5, 3))
    # The file names the help examples use are the ones it writes.
    line = cli.fails("example", "nope", match="unknown example 'nope'")
    assert "rig" in line and "iso_cubes" in line
