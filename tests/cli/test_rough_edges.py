"""A newcomer's first hour (issue 21), on the command line: one conditioning number, values that used
to end in an internal error, long names, and commands that leave all of their outputs or none. The
other stages' cases are tests/<stage>/test_rough_edges.py."""

from __future__ import annotations

import os

import pytest

import pincal
from pincal.outputs import all_or_nothing, atomic_write_text

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]


# ------------------------------------------------------------------ one conditioning number
def test_one_conditioning_number_across_commands(cell, cli):
    planar = [cell / "robot.urdf", *PLANAR]
    designed = cli.json("design", *planar, "-m", "3", "--test-pose=0.3,1.2", "--workers", "1",
                        "--out", cell / "d.csv")["conditioning"]  # fmt: skip
    evaluate = ["evaluate", *planar, "--plan", cell / "d.csv", "--test-pose=0.3,1.2"]
    assert cli.json(*evaluate)["data_check"]["conditioning"] == pytest.approx(designed, rel=1e-9)
    for argv in (evaluate, ["params", *planar, "--plan", cell / "d.csv"]):
        code, out, err = cli.run(*argv)
        assert code == 0, err
        assert f"conditioning {designed:.3g}" in out and "condition number" not in out
    for command in ("design", "evaluate", "params", "identify"):
        code, text, _ = cli.run(command, "--help")
        assert "Conditioning (every report, one number)" in text and "condition number" not in text


# ------------------------------------------------------- values that were internal errors
@pytest.mark.parametrize(
    "extra, fragment",
    [
        (["--sigma=1e308"], "argument --sigma: must be a positive number of metres from 1e-12 to 1000"),
        (["--around=1e308"], "--around '1e308': the angle must be a positive number of radians up to 1e+06"),
        (["--test-box=0,0,0,1e308,1,1"], "the box's upper corner[0] must be a number of metres in"),
        (["--joint-range", "joint_a2=-1e308,1e308"], "--joint-range 'joint_a2=-1e308,1e308': lower must be"),
    ],
)
def test_the_fuzzers_huge_values_are_refused_where_read(cli, tmp_path, extra, fragment):
    (tmp_path / "plan.csv").write_text(
        "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6\n" + "0,-1,1,0,0.5,0\n" * 4
    )
    if extra[0].startswith("--sigma"):
        argv = ["measure-sim", "kr270", "--plan", tmp_path / "plan.csv", "--error-std", "1e-3,1e-3",
                "--out", tmp_path / "m.csv", *extra]  # fmt: skip
    else:
        argv = ["evaluate", "kr270", "--plan", tmp_path / "plan.csv", "--test-pose=0,-1,1,0,0.5,0", *extra]
    cli.fails(*argv, match=fragment)
    assert not (tmp_path / "m.csv").exists()


# ------------------------------------------------------------- all outputs or none
def test_a_command_that_fails_leaves_none_of_its_outputs(cell, cli, monkeypatch):
    """measure-sim wrote --out, then failed on --save-true (exit 2): both outputs are now written
    at the end, together, or neither."""
    argv = ["measure-sim", cell / "robot.urdf", "--tip", "tip", "--plan", cell / "plan.csv"]
    argv += ["--error-std", "1e-3,1e-3", "--out", cell / "m.csv", "--save-true", cell / "true.urdf"]
    import pincal.cli.measure_sim as measure_sim

    def failing_export(*args, **kwargs):
        raise pincal.errors.CannotWrite("cannot write the output 'true.urdf': No space left on device")

    monkeypatch.setattr(measure_sim, "export_urdf", failing_export)
    cli.fails(*argv, match="No space left on device")
    assert sorted(p.name for p in cell.iterdir()) == ["plan.csv", "robot.urdf"]  # no temporary file either
    monkeypatch.undo()
    code, _, err = cli.run(*argv)
    assert code == 0, err
    assert (cell / "m.csv").exists() and (cell / "true.urdf").exists()


def test_an_unwritable_second_output_is_refused_before_any_work(cell, cli):
    """A folder the process cannot create files in (root passes os.access everywhere: /proc) is
    found by a real probe before the computation."""
    argv = ["measure-sim", cell / "robot.urdf", "--tip", "tip", "--plan", cell / "plan.csv"]
    argv += ["--error-std", "1e-3,1e-3", "--out", cell / "m.csv", "--save-true", "/proc/true.urdf"]
    cli.fails(*argv, match="cannot write --save-true '/proc/true.urdf'")
    assert not (cell / "m.csv").exists()


def test_all_or_nothing_keeps_the_old_files_on_failure(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    with pytest.raises(RuntimeError), all_or_nothing():
        atomic_write_text(tmp_path / "a.txt", "new a")
        atomic_write_text(tmp_path / "b.txt", "new b")
        assert (tmp_path / "a.txt").read_text() == "old a"  # nothing renamed before the end
        raise RuntimeError("the computation failed")
    assert sorted(os.listdir(tmp_path)) == ["a.txt"] and (tmp_path / "a.txt").read_text() == "old a"
    with all_or_nothing():
        atomic_write_text(tmp_path / "a.txt", "first")
        with all_or_nothing():  # joins the outer block
            atomic_write_text(tmp_path / "a.txt", "second")
        atomic_write_text(tmp_path / "b.txt", "b")
    assert (tmp_path / "a.txt").read_text() == "second" and sorted(os.listdir(tmp_path)) == ["a.txt", "b.txt"]
