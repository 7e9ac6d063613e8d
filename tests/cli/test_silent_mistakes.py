"""Mistakes that used to pass in silence get one line (issue 32), on the command line: σ typed in
millimetres, an option misspelt. The measurement file without z and the plan in radians are
tests/calibration/ and tests/planning/test_silent_mistakes.py."""

from __future__ import annotations

import pytest

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]
TEST_POSE = "--test-pose=0.3,1.2"


def warnings_of(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("pincal: warning: ")]


# ---------------------------------------------------------------------- σ in millimetres
def test_sigma_in_millimetres_is_warned_about(cell, cli):
    evaluate = ["evaluate", cell / "robot.urdf", *PLANAR, "--plan", cell / "plan.csv", TEST_POSE]
    code, out, err = cli.run(*evaluate, "--sigma", "0.03")
    assert code == 0, err
    assert warnings_of(err) == [
        "pincal: warning: --sigma 0.03 is 30 mm per coordinate, which looks like millimetres: --sigma is "
        "in metres (a laser tracker's 0.03 mm is --sigma 3e-5)"
    ]
    code, _, err = cli.run(*evaluate, "--sigma", "3e-5")
    assert code == 0 and not warnings_of(err), err


# ------------------------------------------------------------------------ a misspelt option
@pytest.mark.parametrize(
    "argv, hint",
    [
        (["design", "kr270", "-m", "12", "--markers", "0.1,0.05,0.2"],
         "--markers 0.1,0.05,0.2 (did you mean --marker?)"),
        (["evaluate", "kr270", "--plan", "p.csv", "--sigmas=3e-5"], "--sigmas=3e-5 (did you mean --sigma?)"),
        (["params", "kr270", "--tips", "tool0"], "--tips tool0 (did you mean --tip?)"),
    ],
)  # fmt: skip
def test_a_misspelt_option_gets_a_close_match(cli, argv, hint):
    line = cli.fails(*argv)
    assert line == f"pincal: error: unrecognized arguments: {hint} (see 'pincal {argv[0]} --help')"


def test_an_unknown_option_without_a_close_match_is_refused_as_before(cli):
    line = cli.fails("params", "kr270", "--zzzz")
    assert line == "pincal: error: unrecognized arguments: --zzzz (see 'pincal --help')"
