"""The core CLI commands: pincal params, pincal evaluate, pincal robots."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pincal
from pincal.cli import main

KR_Q0 = "0,-90,90,0,45,0"


@pytest.fixture
def kr_plan(tmp_path, kr270_marker):
    path = tmp_path / "plan.csv"
    pincal.Plan.for_robot(kr270_marker, kr270_marker.random_configurations(12, 1)).to_csv(path, degrees=True)
    return path


@pytest.fixture
def planar_plan(tmp_path):
    path = tmp_path / "planar.csv"
    path.write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n")
    return path


def test_evaluate_json_matches_library(cli, kr_plan, kr270_marker):
    out = cli.json(
        "evaluate", "kr270", "--plan", kr_plan, "--deg", "--test-pose", KR_Q0, "--marker", "0.1,0.05,0.2",
        "--sigma", "3e-5",
    )  # fmt: skip
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    plan = pincal.Plan.from_csv(kr_plan, robot=kr270_marker, degrees=True)
    q0 = np.radians([0, -90, 90, 0, 45, 0])
    assert out["rho0"] == pytest.approx(pincal.rho0(params, plan, q0, sigma=3e-5), rel=1e-12)
    assert out["n_params"] == 27 and out["params"] == list(params.names)
    assert set(out["criteria"]) == {"log_det", "trace", "max_eig", "cond", "O1", "O2", "O3", "O4"}
    assert out["criteria"]["cond"] == pytest.approx(pincal.criteria(params, plan).cond, rel=1e-12)


def test_evaluate_planar_closed_form_and_negative_test_pose(cli, planar_plan):
    # --test-pose=-0.3,1.2 (and the space-separated form) must parse negative values.
    for form in (["--test-pose=-0.3,1.2"], ["--test-pose", "-0.3,1.2"]):
        out = cli.json("evaluate", "planar_2r", "--plan", planar_plan, "--params", "joint2.tx,tip.tx", *form)
        q2 = np.array([1.0, -1.0, 2.0])
        m, S = 3, np.cos(q2).sum()
        sigma = 3e-5  # the default: a laser tracker's
        closed_form = 2 * (m - np.cos(1.2) * S) / (m * m - S * S)
        assert out["rho0"] ** 2 == pytest.approx(sigma**2 * closed_form, rel=1e-10)
        assert out["sigma"] == sigma


def test_evaluate_several_test_poses_mean_and_worst(cli, planar_plan):
    argv = [
        "evaluate",
        "planar_2r",
        "--plan",
        str(planar_plan),
        "--params",
        "lengths",
        "--test-pose=0,0.5",
        "--test-pose=0,2.5",
    ]
    mean = cli.json(*argv)
    worst = cli.json(*argv, "--worst")
    each = np.array(mean["rho0_per_test_pose"])
    assert mean["rho0"] == pytest.approx(np.sqrt(np.mean(each**2)))
    assert worst["rho0"] == pytest.approx(each.max())


def test_evaluate_text_output(cli, kr_plan):
    code, out, _ = cli.run(
        "evaluate", "kr270", "--plan", kr_plan, "--deg", "--test-pose", KR_Q0, "--marker", "0.1,0.05,0.2",
        "--sigma", "3e-5",
    )  # fmt: skip
    assert code == 0
    assert "rho0 at the test pose" in out and "mm" in out and "O4" in out


def test_params_json(cli):
    out = cli.json("params", "kr270")
    assert len(out["identifiable"]) == 25
    assert out["dropped"]["joint_a6.offset"].startswith("invisible")
    out = cli.json("params", "kr270", "--marker", "0.1,0.05,0.2", "--params", "full")
    assert len(out["identifiable"]) == 27
    assert len(out["params"]) == 42


def test_robots_lists_shipped_and_erd(cli):
    out = cli.json("robots")
    assert "kr270" in out["shipped"] and "ur10" in out["example_robot_data"]


def test_help_has_examples(capsys):
    for argv in (["--help"], ["evaluate", "--help"], ["params", "--help"]):
        with pytest.raises(SystemExit) as exit_:
            main(argv)
        assert exit_.value.code == 0
        assert "example" in capsys.readouterr().out


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


BAD = [
    # (argv builder, expected fragment of the one-line error)
    (lambda t: ["params", str(t / "missing.urdf")], "does not exist"),
    (lambda t: ["params", _write(t, "bad.urdf", "<robot name='x'><link></robot")], "cannot read URDF"),
    (lambda t: ["params", "kr27"], "did you mean kr270"),
    (lambda t: ["params", "kr270", "--tip", "tool1"], "unknown frame 'tool1'"),
    (lambda t: ["params", "kr270", "--params", "full,offsetz"], "unknown parameter or group 'offsetz'"),
    (lambda t: ["params", "kr270", "--params", "joint_a9.tx"], "valid:"),
    (lambda t: ["params", "kr270", "--marker", "0.1,0.2"], "X,Y,Z"),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,0.2,0.3\n"),
            "--test-pose=0,1",
        ],
        "line 2: 3 values, expected 2",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,x\n"),
            "--test-pose=0,1",
        ],
        "not a number",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,nan\n"),
            "--test-pose=0,1",
        ],
        "must be finite",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,4\n"),
            "--test-pose=0,1",
        ],
        "joint2 = 4 is outside its limits",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,0.5\n"),
            "--test-pose=0,1,2",
        ],
        "expected 2",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,0.5\n"),
            "--test-pose=0,inf",
        ],
        "finite",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,0\n0.2,0\n"),
            "--test-pose=0,1",
            "--params",
            "lengths",
        ],
        "degenerate",
    ),
    (
        lambda t: [
            "evaluate",
            "kr270",
            "--plan",
            _write(t, "p.csv", "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6\n0,-1,1,0,1,0\n"),
            "--test-pose=0,-1,1,0,1,0",
        ],
        "at least 9 configurations",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,0.5\n"),
            "--test-pose=0,1",
            "--params",
            "joint1.offset,joint1.rz",
        ],
        "joint1.rz cannot be identified",
    ),
    (
        lambda t: [
            "evaluate",
            "planar_2r",
            "--plan",
            _write(t, "p.csv", "joint1,joint2\n0.1,0.5\n"),
            "--test-pose=0,1",
            "--sigma",
            "-1",
        ],
        "--sigma must be a positive",
    ),
]


@pytest.mark.parametrize("case", range(len(BAD)))
def test_bad_input_one_line_exit_2(tmp_path, cli, case):
    build, fragment = BAD[case]
    cli.fails(*build(tmp_path), match=fragment)  # exit 2, one 'pincal: error:' line, no traceback


def test_usage_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["evaluate", "kr270"])  # --plan and --test-pose missing
    assert exit_.value.code == 2
    with pytest.raises(SystemExit) as exit_:
        main(["nonsense"])
    assert exit_.value.code == 2


def test_console_script_and_module_entry_points():
    import subprocess
    import sys
    from importlib.metadata import entry_points

    scripts = {e.name: e.value for e in entry_points(group="console_scripts")}
    assert scripts.get("pincal") == "pincal.cli:main"
    result = subprocess.run(
        [sys.executable, "-m", "pincal", "params", "planar_2r", "--json"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["robot"] == "planar_2r"
