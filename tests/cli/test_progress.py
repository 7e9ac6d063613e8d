"""Progress on long runs: one --progress/--no-progress option, the same on every command that
searches or repeats trials, and progress written to stderr only (stdout keeps the report or JSON)."""

from __future__ import annotations

import io
import json

import pytest

import pincal.progress
from pincal.cli import COMMANDS, build_parser
from pincal.progress import Steps

PLAN = "joint1,joint2\n0.3,1.2\n1.0,-0.8\n-0.6,1.9\n2.0,0.4\n0.1,-1.5\n"

LONG = {
    "design": ["planar_2r", "-m", "3"],
    "baseline": ["planar_2r", "-m", "3", "--random", "10"],
    "campaign": ["planar_2r", "--plan", "plan.csv"],
    "next": ["planar_2r", "--data", "data.csv"],
    "simulate": ["planar_2r", "--plan", "plan.csv", "--test-pose=0.3,1.2"],
    "identify": ["planar_2r", "--data", "data.csv"],
}
"""The commands that can run for long (a search, designs, certified moves, Monte-Carlo trials),
each with its required arguments (identify: a residual model on many configurations). The others
take seconds (measure-sim, evaluate, ...)."""


def test_every_long_command_takes_the_same_progress_option():
    parser = build_parser()
    for name, argv in LONG.items():
        assert parser.parse_args([name, *argv]).progress is True, name
        assert parser.parse_args([name, *argv, "--no-progress"]).progress is False, name
        assert parser.parse_args([name, *argv, "--no-progress", "--progress"]).progress is True, name
    helps = {
        name: {a.help for a in sub._actions if "--no-progress" in a.option_strings}
        for name, sub in parser.commands.items()
    }
    assert {name for name, h in helps.items() if h} == set(LONG)
    assert len(set.union(*helps.values())) == 1  # one option, written once
    assert set(LONG) <= set(COMMANDS)


@pytest.fixture
def every_step(monkeypatch):
    """A progress line for every step (not every few seconds), so short runs show theirs."""
    monkeypatch.setattr(pincal.progress, "EVERY", 0.0)


def test_campaign_progress_goes_to_stderr_only(tmp_path, cli, every_step):
    plan = tmp_path / "plan.csv"
    plan.write_text(PLAN)
    code, out, err = cli.run("campaign", "planar_2r", "--plan", plan, "--json")
    assert code == 0
    payload = json.loads(out)  # stdout is the JSON alone
    moves = len(payload["moves"])
    lines = [line for line in err.splitlines() if line.startswith("pincal: campaign:")]
    assert [line.split(",")[0] for line in lines] == [
        f"pincal: campaign: {k} of {moves} moves certified" for k in range(1, moves + 1)
    ]
    code, out, err = cli.run("campaign", "planar_2r", "--plan", plan, "--json", "--no-progress")
    assert code == 0 and json.loads(out) == payload and "pincal: campaign:" not in err


def test_simulate_and_design_progress_go_to_stderr_only(tmp_path, cli, every_step):
    plan = tmp_path / "plan.csv"
    plan.write_text(PLAN)
    argv = ["simulate", "planar_2r", "--plan", plan, "--test-pose=0.3,1.2", "--trials", "3", "--json"]
    code, out, err = cli.run(*argv)
    assert code == 0 and json.loads(out)["trials"] == 3
    assert "pincal: monte carlo: 3 of 3 trials done" in err
    code, out, err = cli.run(*argv, "--no-progress")
    assert code == 0 and "pincal: monte carlo" not in err
    argv = ["design", "planar_2r", "-m", "8", "--test-pose=0.3,1.2", "--starts", "2", "--workers", "1"]
    code, out, err = cli.run(*argv, "--json")
    assert code == 0, err
    assert len(json.loads(out)["plan"]) == 8
    assert "pincal: design test-pose: 2 of 2 starts searched, best ρ0" in err
    code, out, err = cli.run(*argv, "--json", "--no-progress")
    assert code == 0 and "pincal: design" not in err


def test_steps_draw_a_bar_on_a_terminal_and_nothing_when_off(every_step):
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    screen = Terminal()
    steps = Steps(True, "campaign", "move", screen)
    assert list(steps.each("certified", [1, 2, 3])) == [1, 2, 3]
    assert screen.getvalue().startswith("\rcampaign: certified:   0%") and "0/3" in screen.getvalue()
    quiet = io.StringIO()
    off = Steps(False, "campaign", "move", quiet)
    assert list(off.each("certified", [1, 2])) == [1, 2] and quiet.getvalue() == ""
    log = io.StringIO()
    lines = Steps(True, "monte carlo", "trial", log)
    list(lines.each("done", range(2)))
    assert log.getvalue().splitlines()[-1].startswith("pincal: monte carlo: 2 of 2 trials done, ")


def test_payload_top_up_and_placement_designs_report_progress(tmp_path, cli, every_step):
    """The designs that went without a word: with payloads, a residual model's top-up, and the
    instrument's placement (its positions screened, then designed in full)."""
    payloads = ["design", "planar_2r", "-m", "6", "--test-pose=0.3,1.2", "--payloads", "0,1", "--starts", "2",
                "--pool-size", "50", "--no-accuracy", "--json"]  # fmt: skip
    code, out, err = cli.run(*payloads)
    assert code == 0 and len(json.loads(out)["plan"]) == 6
    assert "pincal: design test-pose: 2 of 2 starts searched, best ρ0" in err
    code, out, err = cli.run(*payloads, "--no-progress")
    assert code == 0 and "pincal: design" not in err
    ur10 = ["ur10", "-m", "12", "--test-pose=0,-1.2,1.5,-1,-1.5,0", "--marker", "0.05,0.02,0.1"]
    placed = ["design", *ur10, "--place-instrument", "1.5,0,0.75,9,0,0.75", "--place-steps", "2",
              "--no-polish", "--pool-size", "300", "--starts", "2", "--workers", "1", "--no-accuracy",
              "--json"]  # fmt: skip
    code, out, err = cli.run(*placed, "--place-screen", "1")
    assert code == 0 and json.loads(out)["placement"]["screen"] == 1
    lines = [line.split(",")[0] for line in err.splitlines() if line.startswith("pincal: placement:")]
    assert lines[:2] == [f"pincal: placement: {k} of 2 positions screened" for k in (1, 2)]
    assert "pincal: placement: 1 of 2 positions designed in full" in lines  # the best, the default
    assert "pincal: design test-pose: 2 of 2 starts searched, best ρ0" in err  # a full design's own
    code, out, err = cli.run(*placed, "--place-screen", "1", "--no-progress")
    assert code == 0 and "pincal: placement" not in err and "pincal: design" not in err


def test_a_top_up_design_reports_progress(tmp_path, cli, every_step):
    pytest.importorskip("sklearn")
    import pincal

    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("full,offsets").identifiable().identifiable
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=1), robot.random_configurations(40, 3), 1e-5, seed=4
    )
    data.to_csv(tmp_path / "meas.csv")
    cal = tmp_path / "cal.urdf"
    code, _, err = cli.run("identify", "planar_2r", "--data", tmp_path / "meas.csv", "--residual-model", "gp",
                           "--out", cal, "--no-progress")  # fmt: skip
    assert code == 0, err
    top_up = ["design", "planar_2r", "-m", "6", "--test-pose=0.3,1.2", "--residual-model", cal,
              "--starts", "2", "--pool-size", "50", "--no-accuracy", "--json"]  # fmt: skip
    code, out, err = cli.run(*top_up)
    assert code == 0 and json.loads(out)["criterion"] == "test-pose-gp"
    assert "pincal: design test-pose-gp: 2 of 2 starts searched, best expected error" in err
    code, out, err = cli.run(*top_up, "--no-progress")
    assert code == 0 and "pincal: design" not in err
