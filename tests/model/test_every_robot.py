"""Every robot 'pincal robots' lists designs and identifies, or is refused in one line (issue 11).

CI time: the CLI pass over every listed robot and the round trip on three of them take ~30 s of
CPU; the round trip on every loadable robot is `pytest -m slow` (~4 min; its figures are in
benchmarks/RESULTS.md, from benchmarks/bench_robots.py).
"""

from __future__ import annotations

import pytest

from pincal.cli import main
from pincal.errors import PincalError
from tests.support.robot_zoo import chain_of, listed_robots, rehearse

FAST = ["kinova", "so101", "talos_arm"]  # continuous joints; rounded vendor angles; hand + fingers


@pytest.mark.parametrize("name", listed_robots())
def test_cli_never_tracebacks(name, capsys):
    code = main(["params", name, "--marker", "0.05,0.02,0.03"])
    err = capsys.readouterr().err
    assert code in (0, 2)
    lines = err.splitlines()
    assert all(line.startswith(("pincal: error: ", "pincal: warning: ")) for line in lines), err
    if code == 2:  # refused: one line that says what to do
        assert len([line for line in lines if line.startswith("pincal: error")]) == 1
        assert any(hint in err for hint in ("--tip", "--joint-range", "URDF", "--root")), err


def _check(name: str) -> None:
    chain = chain_of(name)
    if chain.robot is None:
        assert "\n" not in chain.refused and chain.refused
        return
    try:
        result = rehearse(chain.robot)
    except PincalError as exc:  # the design refuses m = minimum + 2 in one line, saying what to do
        assert "\n" not in str(exc) and "conditioning floor" in str(exc)
        try:
            result = rehearse(chain.robot, extra=6)
        except PincalError as again:  # a weakly conditioned chain (bravo7: joint3.tx at 1.2e-2)
            assert "\n" not in str(again) and "conditioning floor" in str(again)
            return
    assert result.worst_z < 6  # identified errors within 6 standard errors of the truth
    assert result.error_after < max(6 * result.rho0, 1e-6)
    assert result.error_after < result.error_before


@pytest.mark.long
@pytest.mark.parametrize("name", FAST)
def test_round_trip(name):
    _check(name)


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in listed_robots() if n not in FAST])
def test_round_trip_every_robot(name):
    _check(name)
