"""Robustness on the command line (issue 12): outputs never replace inputs or special files, one
error format, bounded counts, NumPy floating-point warnings turned into checks, interrupted writes.
Each bad-input case is a regression example of a crash class the fuzzer (tests/cli/test_fuzz.py)
found or the issue reported. The robot-file and planning cases are tests/model/test_robustness.py
and tests/planning/test_robustness.py. Budget: about 15 s."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.cli import main
from pincal.model import shipped_dh_tables
from pincal.outputs import atomic_write_text, guard_inputs

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]


def snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file() and not p.is_symlink()}


def show(cell, *extra):
    return ["show", cell / "robot.urdf", "--plan", cell / "plan.csv", "--test-pose=0.3,1.2", *PLANAR, *extra]


# --------------------------------------------------------------- outputs never replace inputs
@pytest.mark.parametrize(
    "output, fragment",
    [
        ("plan.csv", "is the input --plan"),
        ("robot.urdf", "is the robot's URDF"),
        ("hardlink.csv", "is the input --plan"),  # the same file by inode
        ("symlink.csv", "is the input --plan"),
        (".", "it is a folder"),
        ("fifo", "not a regular file"),
        ("missing/scene.html", "its folder"),
        ("plan.csv/scene.html", "Not a directory"),
        ("", "the file name is empty"),
    ],
)
def test_show_html_never_replaces_an_input_or_special_file(cell, cli, output, fragment):
    os.link(cell / "plan.csv", cell / "hardlink.csv")
    os.symlink(cell / "plan.csv", cell / "symlink.csv")
    os.mkfifo(cell / "fifo")
    before = snapshot(cell)
    target = "" if output == "" else str(cell / output)
    cli.fails(*show(cell, "--html", target), match=fragment)
    assert snapshot(cell) == before and (cell / "fifo").is_fifo()


def test_every_writer_refuses_inputs_before_any_work(cell, cli):
    data = cell / "meas.csv"
    argv = ["measure-sim", cell / "robot.urdf", "--tip", "tip", "--plan", cell / "plan.csv"]
    assert main([str(a) for a in [*argv, "--error-std", "1e-3,1e-3", "--sigma", "1e-5", "--out", data]]) == 0
    before = snapshot(cell)
    identify = ["identify", cell / "robot.urdf", "--tip", "tip", "--data", data]
    cli.fails(*identify, "--out", data, match="is the input --data")
    cli.fails(*argv, "--error-std", "1e-3,1e-3", "--sigma", "0", "--out", cell / "plan.csv", match="--plan")
    cli.fails(
        *argv, "--error-std", "1e-3,1e-3", "--sigma", "0", "--out", data, "--save-true", data, match="output"
    )
    design = ["design", cell / "robot.urdf", "-m", "3", "--test-pose=0.3,1.2", *PLANAR, "--workers", "1"]
    cli.fails(*design, "--pool", cell / "plan.csv", "--out", cell / "plan.csv", match="is the input --pool")
    cli.fails(*design, "--plot", cell / "plot.xyz", match="valid: ")  # the format, before the design
    shutil.copy(shipped_dh_tables()["ur5_dh"], cell / "table.yaml")
    before["table.yaml"] = (cell / "table.yaml").read_bytes()
    cli.fails("urdf-from-dh", cell / "table.yaml", "--out", cell / "table.yaml", match="is the input TABLE")
    assert snapshot(cell) == before


def test_writes_refuse_files_read_in_the_same_run(cell):
    # The CLI guard covers inputs named indirectly (a shipped robot by name, a mesh folder...).
    with guard_inputs():
        pincal.Plan.from_csv(cell / "plan.csv", robot=pincal.load_robot(cell / "robot.urdf", tip="tip"))
        with pytest.raises(pincal.errors.OverwriteRefused, match="never overwrites an input"):
            atomic_write_text(cell / "robot.urdf", "x")
    assert atomic_write_text(cell / "robot.urdf", "x").read_text() == "x"  # outside: the API's choice


def test_unwritable_place_is_one_line(cell, cli):
    if os.geteuid() == 0:
        pytest.skip("root writes anywhere")
    locked = cell / "locked"
    locked.mkdir(mode=0o500)
    cli.fails(*show(cell, "--html", locked / "s.html"), match="permission denied in folder")


def test_inputs_that_are_not_files(cell, cli):
    os.mkfifo(cell / "fifo.csv")  # reading it would block forever
    base = ["evaluate", cell / "robot.urdf", "--test-pose=0,1", *PLANAR, "--plan"]
    cli.fails(*base, cell / "fifo.csv", match="not a regular file")
    cli.fails(*base, cell, match="is a folder")


# --------------------------------------------------------------------------- one error format
@pytest.mark.parametrize(
    "argv",
    [
        ["evaluate", "planar_2r"],  # required options missing
        ["nonsense"],
        [],
        ["design", "planar_2r", "-m", "x", "--test-pose=0,1"],
        ["params", "planar_2r", "--unknown"],
    ],
)
def test_usage_errors_are_one_line(capsys, argv):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and err.startswith("pincal: error: ") and err.count("\n") == 1, err
    assert "--help')" in err and "usage:" not in err


def test_identify_one_point_in_millimetres_is_a_verdict_not_a_crash(cell, cli, capsys):
    # The long fuzz run: one measured point has no spread, so the units cause divided by zero.
    (cell / "one.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n")
    argv = ["identify", cell / "robot.urdf", "--data", cell / "one.csv", *PLANAR, "--mm"]
    cli.fails(*argv, match="no real robot has this")
    # and with a marker 5 km away the outlier scores of an exact fit overflowed (a NumPy warning)
    argv = ["identify", cell / "robot.urdf", "--data", cell / "one.csv", *PLANAR, "--marker", "0,0,5394"]
    with np.errstate(all="raise"):
        code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert code in (0, 2) and "encountered in" not in err, err


def test_extreme_arguments_are_refused_not_run(cli):
    # was NumPy's ValueError
    cli.fails("params", "planar_2r", "--seed", "-1", match="argument --seed: must be an integer ≥ 0")
    base = ["baseline", "planar_2r", "-m", "3", "--test-pose=0.3,1.2", "--workers", "1", "--random"]
    cli.fails(*base, str(2**63), match="from 1 to 10,000,000")
    cli.fails(
        "simulate", "planar_2r", "--plan", "x.csv", "--test-pose=0,1", "--trials", str(10**30), match=""
    )


def test_identify_iteration_limit_is_a_bounded_count(cell, cli):
    # the long fuzz run: --max-iterations -1e30 was NumPy's TypeError (isfinite of a huge int)
    (cell / "one.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n")
    argv = ["identify", cell / "robot.urdf", "--tip", "tip", "--data", cell / "one.csv", *PLANAR[2:]]
    cli.fails(*argv, "--max-iterations", "-" + "9" * 30, match="--max-iterations: must be an integer from 1")
    params = pincal.load_robot(cell / "robot.urdf", tip="tip").parameters("joint2.tx,tip.tx")
    data = pincal.MeasurementData.from_csv(cell / "one.csv", params.robot)
    for bad in (float("inf"), "abc"):  # the API: int(inf) was an OverflowError, int('abc') a ValueError
        with pytest.raises(pincal.PincalError, match="maxiter must be an integer"):
            pincal.identify(params, data, maxiter=bad)


def test_reject_that_leaves_no_row_is_one_line(cell, cli):
    # the collecting fuzz driver: --reject 1e-9 rejected every row, and the next robust fit took the
    # median of nothing ('Mean of empty slice', an internal error since NumPy warnings are errors)
    (cell / "meas.csv").write_text(
        "joint1,joint2,x,y,z\n0,0,1.8,0,0\n0,1,1.43,0.67,0\n1,1,0.21,1.57,0\n0.5,-1,1.66,-0.38,0.001\n"
    )
    argv = ["identify", cell / "robot.urdf", "--tip", "tip", "--data", cell / "meas.csv", *PLANAR[2:]]
    cli.fails(*argv, "--reject", "1e-9", match="reject 1e-09 dropped 4 of the 4 configurations as outliers")


def test_measure_sim_refuses_a_negative_seed(cell, cli):
    # the long fuzz run: measure-sim --seed -1 was NumPy's ValueError (its generator was not checked)
    argv = ["measure-sim", cell / "robot.urdf", "--tip", "tip", "--plan", cell / "plan.csv"]
    argv += ["--error-std", "1e-3,1e-3", "--out", cell / "m.csv", "--seed", "-1"]
    cli.fails(*argv, match="argument --seed: must be an integer ≥ 0")
    assert not (cell / "m.csv").exists()


def test_error_cloud_size_is_a_bounded_count(cell, cli):
    # the long fuzz run: show --error-cloud 2**63 was NumPy's 'Maximum allowed dimension exceeded'
    cli.fails(
        *show(cell, "--plot", cell / "x.png", "--error-cloud", str(2**63)), match="from 1 to 10,000,000"
    )
    with pytest.raises(pincal.PincalError, match="number of configurations must be an integer"):
        pincal.load_robot("planar_2r").random_configurations(2**63)


def test_warnings_are_pincal_lines(cell, capsys):
    # A plan too small for the parameters: 'show' draws no ellipsoid and says why, as a warning line.
    (cell / "plan.csv").write_text("joint1,joint2\n0.1,1.0\n")
    assert (
        main([str(a) for a in show(cell, "--html", cell / "s.html")[:-2]] + ["--html", str(cell / "s.html")])
        == 0
    )
    err = capsys.readouterr().err
    assert all(line.startswith("pincal: warning: ") for line in err.splitlines()), err


def test_interrupted_write_leaves_old_output_and_no_temporary_file(cell, monkeypatch):
    target = cell / "out.csv"
    target.write_text("previous")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("os.replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_text(target, "new")
    assert target.read_text() == "previous"
    assert sorted(p.name for p in cell.iterdir()) == ["out.csv", "plan.csv", "robot.urdf"]


def test_reports_of_unidentifiable_data_print_no_inf_or_nan(cell, capsys):
    # The long fuzz run: one configuration for two lengths printed 'condition number inf'.
    (cell / "one.csv").write_text("joint1,joint2\n0,1\n")
    argv = [
        "evaluate",
        cell / "robot.urdf",
        "--plan",
        cell / "one.csv",
        "--test-pose=0.3,1.2",
        *PLANAR,
        "--sigma",
        "1",
    ]
    assert main([str(a) for a in argv]) == 0
    out = capsys.readouterr().out
    assert "kept none" in out
    assert not any(word in out.lower().split() for word in ("inf", "nan", "±nan")), out


# ------------------------------------------------- NumPy floating-point warnings become checks
def _overflowing_identifiable(self, *args, **kwargs):
    return np.float64(1e308) * 10  # NumPy: "overflow encountered in scalar multiply"


def _intended_inf(self, *args, **kwargs):
    with np.errstate(divide="ignore"):  # inf on purpose, as the objectives' singular plans are
        assert np.isinf(np.float64(1.0) / 0.0)
    return _real_identifiable(self, *args, **kwargs)


_real_identifiable = pincal.ParameterSet.identifiable


def test_numpy_overflow_is_one_internal_error_line_not_a_warning(cell, capfd, monkeypatch):
    monkeypatch.setattr(pincal.ParameterSet, "identifiable", _overflowing_identifiable)
    code = main(["params", str(cell / "robot.urdf"), *PLANAR])
    out, err = capfd.readouterr()
    assert code == 1 and err.count("\n") == 1, err
    assert err.startswith("pincal: internal error: NumPy floating-point error: overflow encountered in"), err
    assert "in pincal/cli/params.py:" in err, err  # the innermost pincal frame: where to look
    assert "Warning:" not in err and "Traceback" not in err


def test_numpy_overflow_inside_design_is_not_recorded_as_a_warning(cell, capfd, monkeypatch):
    # design and baseline record warnings to print them after the report; an overflow still stops
    monkeypatch.setattr("pincal.cli.design.design", _overflow_then_design)
    argv = ["design", cell / "robot.urdf", "-m", "3", "--test-pose=0.3,1.2", *PLANAR, "--workers", "1"]
    code = main([str(a) for a in argv])
    out, err = capfd.readouterr()
    assert code == 1 and err.startswith("pincal: internal error: NumPy floating-point error: overflow"), err


def _overflow_then_design(*args, **kwargs):
    np.exp(np.float64(1000))
    raise AssertionError("the overflow did not raise")


def test_inf_computed_on_purpose_still_runs(cell, capfd, monkeypatch):
    monkeypatch.setattr(pincal.ParameterSet, "identifiable", _intended_inf)
    assert main(["params", str(cell / "robot.urdf"), *PLANAR]) == 0
    assert capfd.readouterr().err == ""


def test_identify_without_residual_degrees_of_freedom_prints_no_nan_sigma(cell, capsys):
    # The long fuzz run: one point, three marker coordinates: the estimated σ printed 'sigma: nan mm'
    (cell / "one.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n")
    argv = [
        "identify",
        cell / "robot.urdf",
        "--tip",
        "tip",
        "--data",
        cell / "one.csv",
        "--params",
        "markers",
    ]
    assert main([str(a) for a in argv]) == 0
    out = capsys.readouterr().out
    assert "sigma: undetermined (no residual degrees of freedom" in out, out
    assert "nan" not in out.lower().split(), out


@pytest.mark.parametrize(
    "argv, fragment",
    [  # the fuzzer: each overflowed in the least squares or the Jacobians (a NumPy floating-point error)
        (["--data", "{far}"], "line 3: measured coordinate 1e+300 m, over the 1e+06 m"),
        (
            ["--data", "{data}", "--sigma", "1e-300"],
            "argument --sigma: must be a positive number of metres from 1e-12 to 1000",
        ),
        (["--data", "{data}", "--marker", "1e300,0,0"], "marker coordinate 1e+300 m, over"),
        (
            ["--data", "{data}", "--prior", "1e300,1e300"],
            "prior standard deviation of lengths (or inf: no prior) must be a positive number from",
        ),
    ],
)
def test_absurd_lengths_and_sigmas_are_refused_at_the_boundary(cell, cli, argv, fragment):
    (cell / "data.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n0,1,1.43,0.67,0\n1,1,0.21,1.57,0\n")
    (cell / "far.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n0,1,1.43,1e300,0\n")
    argv = [a.format(data=cell / "data.csv", far=cell / "far.csv") for a in argv]
    cli.fails(
        "identify", cell / "robot.urdf", "--tip", "tip", "--params", "joint2.tx,tip.tx", *argv, match=fragment
    )
