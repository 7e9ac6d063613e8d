"""Running the every-command fuzzer's cases (tests/support/fuzz_every.py) in forked children with bounded
CPU time, wall time and address space, checking the contract, and reading back what pincal wrote.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import random
import re
import resource
import signal
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from pincal.cli import main
from tests.support.fuzz_cli import NAN, NOT_TEXT_OUTPUT
from tests.support.fuzz_every import (
    BASES,
    EXPORT_SUFFIX,
    OUT_SUFFIX,
    Case,
    draw_inputs,
    make_case,
    option_table,
)
from tests.support.fuzz_inputs import Seeds

CPU_SECONDS = 30  # a case on rail_arm takes about a second; more is a run without end
WALL_SECONDS = 240  # the machine may be busy: wall time is only the last resort
MEMORY_BYTES = 2 << 30  # address space a case may add to the (forked) test process's
ALLOWED_CODES = (0, 2, 130, 143)


@dataclass
class Result:
    case: Case
    code: int | str  # the exit code, or 'signal N', 'timeout', 'cpu limit'
    stdout: str
    stderr: str
    problems: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _address_space() -> int:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def _hashes(folder: Path) -> dict[str, str]:
    out = {}
    for p in sorted(folder.rglob("*")):
        key = str(p.relative_to(folder))
        if p.is_symlink() or not p.exists():
            out[key] = "link"
        elif p.is_dir():
            out[key] = "dir"
        else:
            out[key] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _fill_outputs(case: Case, names: list[str]) -> list[str]:
    """The argv with ``{out}`` and the special outputs made paths in the case folder."""
    suffix = OUT_SUFFIX.get(case.command, ".csv")
    formats = [case.argv[i + 1] for i, t in enumerate(case.argv[:-1]) if t == "--format"]
    if case.command == "export" and formats:  # argparse keeps the last
        suffix = EXPORT_SUFFIX.get(formats[-1], ".out")
    named = [n for n in names if n.endswith((".json", ".stl"))] or names or ["none"]
    argv, k = [], 0
    for t in case.argv:
        if t == "{out}":
            prev = argv[-1] if argv else ""
            ext = {"--html": ".html", "--plot": ".png", "--placement-plot": ".png", "--campaign-plot": ".png",
                   "--accuracy-plot": ".png", "--save-true": ".urdf"}.get(prev, suffix)  # fmt: skip
            t, k = f"output{k}{ext}", k + 1
        t = t.replace("{@input}", (names or ["none"])[0]).replace("{@named}", named[-1])
        t = t.replace("{@folder}", ".").replace("{@missing}", "missing_folder")
        argv.append(t)
    return argv


def read_back(path: Path, robot: str | None) -> None:
    """Read a file pincal wrote with pincal's own readers (raises what they raise)."""
    import pincal
    from pincal.calibration import columns
    from pincal.cli.export import read_calibration
    from pincal.compensation.calibration_file import sidecar_path
    from pincal.errors import BadPlanFile
    from pincal.files import read_numeric_csv, read_text, read_yaml

    name = path.name.lower()
    data = path.read_bytes()
    if name.endswith(".png"):
        assert data.startswith(b"\x89PNG"), "not a PNG"
    elif name.endswith((".html", ".svg", ".pdf")):
        assert data, "empty figure"
    elif name.endswith(".csv"):
        read_numeric_csv(path, "output", BadPlanFile, may_be_empty=columns.may_be_empty)
    elif name.endswith(".calibration.json"):
        json.loads(read_text(path, "sidecar", ValueError), parse_constant=_no_constant)
    elif name.endswith((".yaml", ".yml")):
        read_yaml(path, "output", ValueError)
    elif name.endswith((".urdf", ".xml")):
        if sidecar_path(path).is_file():
            read_calibration(path)
        else:
            pincal.load_robot(path)
    elif name.endswith((".xacro", ".sdf")):
        from lxml import etree

        etree.parse(str(path))
    elif name.endswith(".json"):
        json.loads(data, parse_constant=_no_constant)


def _no_constant(name: str) -> float:
    raise ValueError(f"{name} in JSON")


def _child(argv: list[str], folder: Path, side: Path, memory: int) -> None:
    """In the forked child: limits, fds, run, read back; never returns."""
    code = 1
    try:
        os.setsid()
        resource.setrlimit(resource.RLIMIT_CPU, (CPU_SECONDS, CPU_SECONDS + 5))
        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.dup2(os.open(side / "stdout", os.O_WRONLY | os.O_CREAT, 0o600), 1)
        os.dup2(os.open(side / "stderr", os.O_WRONLY | os.O_CREAT, 0o600), 2)
        sys.stdout = open(1, "w", encoding="utf-8", errors="replace", closefd=False)  # noqa: SIM115
        sys.stderr = open(2, "w", encoding="utf-8", errors="replace", closefd=False)  # noqa: SIM115
        os.chdir(folder)
        before = set(os.listdir("."))
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        sys.stdout.flush()
        sys.stderr.flush()
        problems = []
        if code == 0:
            for name in sorted(set(os.listdir(".")) - before):
                try:
                    read_back(Path(name), None)
                except BaseException as exc:  # noqa: BLE001 - every failure is a finding
                    problems.append(f"{name} does not read back: {type(exc).__name__}: {str(exc)[:300]}")
        (side / "report").write_text(json.dumps({"code": code, "problems": problems}))
    except BaseException as exc:  # noqa: BLE001
        with contextlib.suppress(BaseException):
            (side / "report").write_text(json.dumps({"code": 1, "problems": [f"harness: {exc!r}"]}))
    finally:
        os._exit(code if isinstance(code, int) and 0 <= code < 256 else 1)


def _wait(pid: int) -> int | str:
    start = time.monotonic()
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() - start > WALL_SECONDS:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return "timeout"
        time.sleep(0.02)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        return "cpu limit" if sig == signal.SIGXCPU else f"signal {signal.Signals(sig).name}"
    with contextlib.suppress(ProcessLookupError):  # worker processes left behind
        os.killpg(pid, signal.SIGKILL)
    return os.WEXITSTATUS(status)


def run_case(case: Case, files: dict[str, bytes | None]) -> Result:
    with tempfile.TemporaryDirectory(prefix="pincal-every-") as tmp:
        folder, side = Path(tmp) / "case", Path(tmp) / "side"
        folder.mkdir()
        side.mkdir()
        for name, data in files.items():
            (folder / name).mkdir() if data is None else (folder / name).write_bytes(data)
        argv = _fill_outputs(case, [n for n in files if files[n] is not None])
        case.argv = argv
        before = _hashes(folder)
        memory = _address_space() + MEMORY_BYTES
        sys.stdout.flush()
        sys.stderr.flush()
        start = time.monotonic()
        pid = os.fork()
        if pid == 0:
            _child(argv, folder, side, memory)
        code = _wait(pid)
        seconds = time.monotonic() - start
        after = _hashes(folder)
        read = lambda n: (side / n).read_text(errors="replace") if (side / n).exists() else ""  # noqa: E731
        report = json.loads(read("report") or "{}")
        result = Result(case, code, read("stdout"), read("stderr"), report.get("problems", []), seconds)
        result.problems += contract(result, before, after, folder)
    return result


def contract(result: Result, before: dict, after: dict, folder: Path) -> list[str]:
    """What the run broke (empty: nothing)."""
    problems = []
    if result.code not in ALLOWED_CODES:
        tail = [line for line in result.stderr.splitlines() if line.strip()][-1:] or ["(no message)"]
        problems.append(f"exit {result.code}: {tail[0][:300]}")
    if "Traceback" in result.stderr or "internal error" in result.stderr:
        problems.append(
            "traceback or internal error: " + _line_with(result.stderr, ("internal error", "Error"))
        )
    changed = [n for n in before if after.get(n) != before[n]]
    if changed:
        problems.append(f"input(s) changed or replaced: {', '.join(changed)}")
    new = sorted(set(after) - set(before))
    if result.code == 2 and new:
        problems.append(f"exit 2 left new file(s): {', '.join(new)}")
    if NAN.search(result.stdout):
        problems.append("NaN/inf on stdout: " + _line_with(result.stdout, ("nan", "inf", "NaN", "Inf")))
    for name in new:
        path = folder / name
        if path.is_file():
            data = path.read_bytes()
            text = re.sub(r"<!--.*?-->", "", data.decode("utf-8", "replace"), flags=re.S)
            if not NOT_TEXT_OUTPUT.match(data) and not name.endswith(".html") and NAN.search(text):
                problems.append(f"NaN/inf in {name}")
    return problems


def _line_with(text: str, words: tuple[str, ...]) -> str:
    for line in text.splitlines():
        if any(w in line for w in words):
            return line.strip()[:300]
    return text.strip()[-300:]


@dataclass
class Tally:
    cases: Counter = field(default_factory=Counter)  # by command
    codes: Counter = field(default_factory=Counter)  # by (command, code)
    options: Counter = field(default_factory=Counter)  # by (command, option)
    findings: list[Result] = field(default_factory=list)


def run_many(seeds: Seeds, seed: int, cases: int, commands: list[str] | None = None, log=None) -> Tally:
    """``cases`` cases, round robin over ``commands`` (default: every command), from ``seed``."""
    table = option_table()
    commands = commands or sorted(BASES)
    missing = sorted(set(table) - set(BASES))
    assert not missing, f"commands without a base case: {missing}"
    tally = Tally()
    for i in range(cases):
        command = commands[i % len(commands)]
        rng = random.Random(f"{seed}:{i}")
        case = make_case(rng, command, i // len(commands), table[command], seed=seed)
        case.seed = i
        files = draw_inputs(rng, case, seeds)
        result = run_case(case, files)
        tally.cases[command] += 1
        tally.codes[command, result.code] += 1
        for option in case.options:
            tally.options[command, option] += 1
        if result.problems:
            tally.findings.append(result)
        if log is not None:
            log(result)
    return tally


def seeds_in(folder: Path) -> Seeds:
    from tests.support.fuzz_inputs import build_seeds

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        return build_seeds(folder)
