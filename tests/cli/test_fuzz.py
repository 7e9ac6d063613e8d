"""Property-based fuzzing of the whole CLI (issue 12): see tests/support/fuzz_cli.py for the strategies and
the property. Every command is run in-process through ``pincal.cli.main(argv)``.

Fast profile (default run, derandomized, about 40 s on 2 cores): FAST_EXAMPLES cases per command.
Long profile: ``pytest -m fuzz tests/cli/test_fuzz.py -s`` runs LONG_EXAMPLES per command (over 10 000
in all) and prints the cases per input kind; its figures are in benchmarks/RESULTS.md.

The every-command fuzzer (tests/support/fuzz_every.py; issue 32, item 7) reaches every command and
option (found from the parsers), the calibration sidecar, meshes, MJCF robots, the measurement kinds
and the export formats, each case in a forked child with CPU, time and memory limits: a short run in
the default profile (EVERY_FAST_CASES), and ``pytest -m fuzz tests/cli/test_fuzz.py -k every -s
--fuzz-cases N --fuzz-seed S`` (the cases by command and every finding printed).
"""

from __future__ import annotations

import collections
import random
import time

import pytest
from hypothesis import HealthCheck, given, settings

from pincal.model import xacro_expansion
from tests.support.fuzz_cli import BASE_ARGV, NAN, cases, fuzz_once

FAST_EXAMPLES = 25
XACRO_SECONDS = 5.0  # a runaway xacro expression is stopped after this (not 60 s); real ones take < 1 s
LONG_EXAMPLES = 1000
SETTINGS = dict(
    deadline=None,
    database=None,
    derandomize=True,  # the same cases on every run: CI is reproducible
    suppress_health_check=list(HealthCheck),
    print_blob=True,
)
TALLY: collections.Counter = collections.Counter()


@pytest.mark.parametrize("command", sorted(BASE_ARGV))
def test_cli_fuzz_fast(command, monkeypatch):
    monkeypatch.setattr(xacro_expansion, "XACRO_SECONDS", XACRO_SECONDS)

    @settings(max_examples=FAST_EXAMPLES, **SETTINGS)
    @given(cases(command))
    def run(case):
        fuzz_once(case)

    run()


@pytest.mark.fuzz
@pytest.mark.parametrize("command", sorted(BASE_ARGV))
def test_cli_fuzz_long(command, monkeypatch):
    monkeypatch.setattr(xacro_expansion, "XACRO_SECONDS", XACRO_SECONDS)
    start = time.perf_counter()
    codes: collections.Counter = collections.Counter()

    @settings(max_examples=LONG_EXAMPLES, **{**SETTINGS, "derandomize": False})
    @given(cases(command))
    def run(case):
        outcome = fuzz_once(case)
        codes[outcome.code] += 1
        TALLY["cases"] += 1
        for kind in case.mutated or {"valid"}:
            TALLY[kind] += 1

    run()
    print(
        f"\n{command}: {sum(codes.values())} cases, exit codes {dict(codes)}, "
        f"{time.perf_counter() - start:.0f} s; running tally {dict(TALLY)}"
    )


@pytest.mark.parametrize(
    "text, printed",
    [
        ("sigma: nan mm", True),
        ("± nan", True),
        ("±nan", True),
        ('xyz="-inf 0 0"', True),
        ('"sigma": NaN,', True),
        ("[1.0, -Infinity]", True),
        ("condition number inf.", True),
        ('<link name="tool-inf"/>', False),  # names a mutation made: not numbers
        ("joint-nan.tx", False),
        ("x.inf", False),
        ("nan_joint", False),
        ("condition number infinite (singular)", False),
    ],
)
def test_nan_oracle_reads_numbers_not_names(text, printed):
    # The long run flagged urdf-from-dh's stdout and identify's outputs for names such as 'tool-inf'.
    assert bool(NAN.search(text)) is printed


# ------------------------------------------------ every command and option (tests/support/fuzz_every.py)
EVERY_FAST_CASES = 48  # three per command, about 20 s; the long profile: pytest -m fuzz --fuzz-cases N


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    from tests.support.fuzz_runner import seeds_in

    return seeds_in(tmp_path_factory.mktemp("seeds"))


def test_every_command_and_option_is_drawn_from_the_parsers():
    from tests.support.fuzz_every import BASES, option_table, option_tokens, value_kind

    table = option_table()
    assert set(table) == set(BASES)  # a new command needs its base case
    for command, options in table.items():
        assert options, command
        for opt in options:
            kinds = {value_kind(opt)}
            for seed in range(20):
                tokens = option_tokens(random.Random(seed), opt)
                assert all(isinstance(t, str) for t in tokens), (command, opt.flag)
            assert kinds <= {"flag", "output", "choice", "int", "float", "list", "number", "text"} or next(
                iter(kinds)
            ).startswith("file:"), (command, opt.flag, kinds)
    # the options the issue names are reached, with the values they need
    flags = {(c, o.flag): value_kind(o) for c, opts in table.items() for o in opts}
    assert flags["compensate", "--calibration"] == "file:calibration"
    assert flags["export", "--format"] == "choice"
    assert flags["campaign", "--joint-speeds"] == "list"
    assert flags["design", "--place-steps"] == "int"
    assert flags["evaluate", "--constraints"] == "file:constraints"


def test_every_commands_base_case_runs(seeds):
    """The fuzzer starts from runs that work: every command's base case exits 0 and reads back."""
    from tests.support.fuzz_every import BASES, valid_case
    from tests.support.fuzz_runner import run_case

    for command in sorted(BASES):
        case, files = valid_case(random.Random(0), command, seeds)
        result = run_case(case, files)
        assert result.code == 0 and not result.problems, (case.describe(), result.stderr, result.problems)


def _report(tally) -> str:
    lines = [f"{sum(tally.cases.values())} cases"]
    for command in sorted(tally.cases):
        codes = {code: n for (c, code), n in tally.codes.items() if c == command}
        lines.append(f"  {command}: {tally.cases[command]} cases, exit codes {codes}")
    for result in tally.findings:
        lines.append(f"FINDING {result.case.describe()}\n    " + "\n    ".join(result.problems))
    return "\n".join(lines)


def test_every_command_fuzz_fast(seeds):
    from tests.support.fuzz_runner import run_many

    tally = run_many(seeds, seed=0, cases=EVERY_FAST_CASES)
    assert not tally.findings, _report(tally)


@pytest.mark.fuzz
def test_every_command_fuzz_long(seeds, request):
    """pytest -m fuzz tests/test_fuzz.py -k every --fuzz-cases N --fuzz-seed S -s"""
    from tests.support.fuzz_every import option_table
    from tests.support.fuzz_runner import run_many

    cases, seed = request.config.getoption("--fuzz-cases"), request.config.getoption("--fuzz-seed")
    start = time.process_time()
    tally = run_many(seeds, seed=seed, cases=cases)
    report = _report(tally)
    reached = {key for key in tally.options}
    every = {(c, o.flag) for c, opts in option_table().items() for o in opts}
    print(
        f"\n{report}\noptions reached: {len(reached & every)} of {len(every)}; parent CPU "
        f"{time.process_time() - start:.0f} s"
    )
    assert not tally.findings, report


@pytest.mark.parametrize(
    "code, stderr, changed, written, broken",
    [
        (0, "", False, b"x,y\n1,2\n", False),
        (2, "pincal: error: bad\n", False, None, False),
        (1, "pincal: internal error: ValueError: x\n", False, None, True),
        ("signal SIGSEGV", "", False, None, True),
        ("cpu limit", "", False, None, True),
        (0, "", True, None, True),  # an input rewritten
        (0, "", False, b"x,y\n1,nan\n", True),  # NaN written
        (2, "pincal: error: bad\n", False, b"x\n1\n", True),  # output left on an error
    ],
)
def test_the_every_command_contract_catches_what_it_names(tmp_path, code, stderr, changed, written, broken):
    from tests.support.fuzz_every import Case
    from tests.support.fuzz_runner import Result, contract

    before = {"in.csv": "hash"}
    after = {"in.csv": "other" if changed else "hash"}
    if written is not None:
        (tmp_path / "out.csv").write_bytes(written)
        after["out.csv"] = "new"
    result = Result(Case("params", []), code, "", stderr)
    assert bool(contract(result, before, after, tmp_path)) is broken
