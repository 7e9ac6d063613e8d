"""A newcomer's first hour (issue 21): xacro robots export, figures without matplotlib, --around on
prismatic joints, one conditioning number, the URDF a RobotWrapper carries, values that used to
end in an internal error, malformed input said in one line, and commands that leave all of their
outputs or none."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.files import all_or_nothing, atomic_write_text
from tests.test_chains import XACRO_ARM

ROOT = Path(__file__).resolve().parents[1]
PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]


@pytest.fixture
def cell(tmp_path):
    shutil.copy(ROOT / "robots" / "planar_2r.urdf", tmp_path / "robot.urdf")
    (tmp_path / "plan.csv").write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n")
    return tmp_path


# ------------------------------------------------------------------- xacro robots export
XACRO = XACRO_ARM  # planar 2-joint arm: properties, a macro, ${pi} limits


def test_a_xacro_robot_is_calibrated_and_exported_end_to_end(tmp_path, cli):
    """identify on a xacro robot exported 'has no joints' (the xacro source was parsed as the
    URDF): the export starts from the expansion loading uses, and the file loads back."""
    pytest.importorskip("xacro")
    src = tmp_path / "arm.urdf.xacro"
    src.write_text(XACRO)
    robot = pincal.load_robot(src, markers=[(0.05, 0.02, 0.1)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    true = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=1)
    plan = pincal.Plan.for_robot(robot, robot.random_configurations(30, 2))
    data = pincal.simulate_measurements(true, plan, sigma=1e-6, seed=3)
    data.to_csv(tmp_path / "meas.csv")
    out = tmp_path / "calibrated.urdf"
    argv = ["identify", src, "--marker", "0.05,0.02,0.1", "--params", ",".join(params.names)]
    code, stdout, err = cli.run(*argv, "--data", tmp_path / "meas.csv", "--out", out)
    assert code == 0, err
    back = pincal.load_robot(out, markers=[(0.05, 0.02, 0.1)])
    assert back.joint_names == ("j1", "j2")
    qs = robot.random_configurations(20, 4)
    # the exported URDF reproduces the true robot's points (to the noise), not the nominal one's
    np.testing.assert_allclose(back.points(qs), true.robot.replace(base=back.base).points(qs), atol=2e-5)
    assert np.abs(back.points(qs) - robot.points(qs)).max() > 1e-4
    assert json.loads(out.with_name("calibrated.calibration.json").read_text())["conditioning"] > 0


def test_a_missing_xacro_package_names_the_extra_not_ros(tmp_path, monkeypatch):
    from pincal.model import xacro_expansion

    path = tmp_path / "arm.urdf.xacro"
    path.write_text(XACRO)
    monkeypatch.setattr(
        xacro_expansion, "expand", lambda *a, **k: xacro_expansion.Expansion(None, "no xacro")
    )
    with pytest.raises(pincal.errors.UrdfError, match=r'without ROS.*pip install "pincal\[xacro\]"'):
        pincal.load_robot(path)


# ----------------------------------------------------------------- a RobotWrapper's URDF
@pytest.mark.filterwarnings("ignore:.*mesh file:pincal.PincalWarning")  # the copy is not beside the meshes
def test_export_finds_the_urdf_a_robot_wrapper_carries(tmp_path):
    erd = pytest.importorskip("example_robot_data")
    wrapper = erd.load("ur5")
    robot = pincal.load_robot(wrapper, tip="tool0")
    assert robot.urdf_path is not None and Path(robot.urdf_path) == Path(wrapper.urdf).resolve()
    params = robot.parameters("lengths").identifiable().identifiable
    moved = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 0.0}, seed=0).robot
    path = pincal.export_urdf(moved, tmp_path / "ur5_moved.urdf")  # no source_urdf=
    back = pincal.load_robot(path, tip="tool0")
    qs = robot.random_configurations(5, 1)
    np.testing.assert_allclose(back.points(qs), moved.points(qs), atol=1e-9)
    bare = pincal.load_robot(wrapper.model, tip="tool0")  # a pin.Model carries no file
    with pytest.raises(pincal.errors.UrdfError, match="give source_urdf"):
        pincal.export_urdf(bare, tmp_path / "x.urdf")


def test_to_model_is_the_chain_and_says_so():
    panda = pincal.load_robot("panda")
    model = panda.to_model()
    assert model.nq == 7 and "panda_finger_joint1" not in list(model.names)
    assert "locked" in pincal.Robot.to_model.__doc__ and "export_urdf" in pincal.Robot.to_model.__doc__


# --------------------------------------------------------------- figures without matplotlib
HIDE_MATPLOTLIB = """
import sys

class Hidden:
    def find_spec(self, name, path=None, target=None):
        if name == "matplotlib" or name.startswith("matplotlib."):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None

for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
    del sys.modules[name]
sys.meta_path.insert(0, Hidden())
from pincal.cli import main
code = main(sys.argv[1:])
assert "matplotlib" not in sys.modules
sys.exit(code)
"""


NEEDS_MATPLOTLIB = 'needs matplotlib, which is not installed: pip install "pincal[plot]"'


@pytest.mark.parametrize("command", ["design", "evaluate", "identify", "simulate"])
def test_every_figure_without_matplotlib_is_one_line_naming_the_extra(cell, command):
    """The top-level package hidden by a meta-path finder in a fresh interpreter (as after the
    README's install without the extra): exit 2, one line, and no output written."""
    planar = [cell / "robot.urdf", *PLANAR]
    argv = {
        "design": ["design", *planar, "-m", "3", "--test-pose=0.3,1.2", "--workers", "1", "--out",
                   cell / "out.csv", "--plot", cell / "fig.png"],
        "evaluate": ["evaluate", *planar, "--plan", cell / "plan.csv", "--test-pose=0.3,1.2",
                     "--accuracy-plot", cell / "fig.png"],
        "identify": ["identify", *planar, "--data", cell / "meas.csv", "--holdout", "0.3", "--out",
                     cell / "out.urdf", "--plot", cell / "fig.png"],
        "simulate": ["simulate", *planar, "--plan", cell / "plan.csv", "--test-pose=0.3,1.2",
                     "--trials", "3", "--plot", cell / "fig.png"],
    }[command]  # fmt: skip
    (cell / "meas.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n0,1,1.43,0.67,0\n1,1,0.21,1.57,0\n")
    before = sorted(os.listdir(cell))
    done = subprocess.run(
        [sys.executable, "-c", HIDE_MATPLOTLIB, *map(str, argv)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 2, done.stderr
    flag = "--accuracy-plot" if command == "evaluate" else "--plot"
    assert done.stderr == f"pincal: error: {flag} (a figure) {NEEDS_MATPLOTLIB}\n"
    assert sorted(os.listdir(cell)) == before


def test_the_plots_module_without_matplotlib_names_the_extra():
    code = HIDE_MATPLOTLIB.split("from pincal.cli")[0] + (
        "import pincal.viewing.plots\n"
        "try:\n"
        "    pincal.viewing.plots.rho0_histogram([1e-4, 2e-4], 1e-4)\n"
        "except pincal.errors.MissingDependency as exc:\n"
        "    print(exc)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout == f"pincal.viewing.plots {NEEDS_MATPLOTLIB}\n"


# ------------------------------------------------------------ --around on prismatic joints
def test_around_takes_a_length_for_prismatic_joints(cli):
    rail = pincal.load_robot("rail_arm")
    q0 = [0.8, 0.3, 0.4, -0.6]
    with pytest.raises(
        pincal.errors.BadArgument, match=r"no half-width for the prismatic joint\(s\) rail.*10deg,2cm"
    ):
        pincal.around(q0, math.radians(10)).resolve(rail)
    region = pincal.around(q0, math.radians(10), length=0.02, samples=200).resolve(rail)
    spread = np.abs(region.poses - q0).max(axis=0)
    assert spread[0] <= 0.02 + 1e-12 and spread[0] > 0.015  # the rail: ±2 cm
    np.testing.assert_array_less(spread[1:], math.radians(10) + 1e-12)
    assert spread[1:].min() > math.radians(8)
    assert region.description.startswith("±10°/±2 cm around the test pose")
    # the CLI: a length is needed, and the plan table gives each column's unit
    names = ",".join(rail.parameters("full,offsets").identifiable().identifiable.names)
    base = ["design", "rail_arm", "-m", "8", "--test-pose=0.8,17,23,-34", "--deg", "--starts", "2",
            "--workers", "1", "--pool-size", "300", "--no-accuracy", "--params", names]  # fmt: skip
    cli.fails(*base, "--around", "10deg", match="prismatic joint(s) rail")
    cli.fails(*base, "--around", "10deg,2kg", match="unknown unit 'kg'")
    code, out, err = cli.run(*base, "--around", "10deg,2cm")
    assert code == 0, err
    lines = out.splitlines()
    table = lines.index("plan:")
    assert lines[table + 1].split() == ["rail", "waist", "shoulder", "elbow"]
    assert lines[table + 2].split() == ["[m]", "[deg]", "[deg]", "[deg]"]


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


def test_a_long_robot_name_is_refused_as_a_name(cli):
    cli.fails("robots", "a" * 300, match="is 300 characters long, more than the 200 a name may have")
    cli.fails("params", "b" * 300 + ".urdf", match="File name too long")


# ------------------------------------------------------ malformed input said in one line
def _chain_urdf(n: int, loop_at: int | None = None) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = ""
    for i in range(n):
        parent, child = f"l{i}", f"l{i + 1}"
        if i == loop_at:
            child = parent
        joints += (
            f'<joint name="j{i + 1}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>'
            f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        )
    return f'<robot name="chain">{links}{joints}</robot>'


def test_a_joint_from_a_link_to_itself_is_refused(tmp_path, cli):
    (tmp_path / "ok.urdf").write_text(_chain_urdf(7))
    assert pincal.load_robot(tmp_path / "ok.urdf").nq == 7
    (tmp_path / "loop.urdf").write_text(_chain_urdf(7, loop_at=4))  # was a 4-joint robot, tip l4
    cli.fails("params", tmp_path / "loop.urdf", match="joint 'j5' has link 'l4' as both parent and child")
    broken = _chain_urdf(3).replace('<link name="l2"/>', "")
    (tmp_path / "undefined.urdf").write_text(broken)
    cli.fails("params", tmp_path / "undefined.urdf", match="names child link 'l2', which the URDF does not")
    (tmp_path / "forest.urdf").write_text(_chain_urdf(3).replace("</robot>", '<link name="stray"/></robot>'))
    cli.fails("params", tmp_path / "forest.urdf", match="2 links without a parent (l0, stray)")


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("joint_limits: {margin_deg: true}", "joint_limits margin_deg must be a number"),
        ("min_spacing: {distance_deg: yes}", "min_spacing distance_deg must be a number"),
        ("workspace_box: {lower: [0, 0, true], upper: [1, 1, 1]}", "workspace_box lower[2] must be"),
        ("visibility: {tracker: [4, 0, 1], max_range: false}", "visibility max_range must be"),
        ("self_collision: {min_distance: true}", "self_collision min_distance must be"),
    ],
)
def test_yaml_booleans_are_not_numbers(cell, cli, text, fragment):
    (cell / "cell.yaml").write_text(text)
    argv = ["design", cell / "robot.urdf", "-m", "3", "--test-pose=0.3,1.2", *PLANAR, "--workers", "1"]
    err = cli.fails(*argv, "--constraints", cell / "cell.yaml", match=fragment)
    assert "got True" in err or "got False" in err


def test_joint_names_with_commas_and_hashes_survive_a_plan_file(tmp_path, cli):
    text = (ROOT / "robots" / "planar_2r.urdf").read_text()
    text = text.replace('"joint1"', '"a,b"').replace('"joint2"', '"#2 &quot;q&quot;"')
    (tmp_path / "odd.urdf").write_text(text)
    robot = pincal.load_robot(tmp_path / "odd.urdf", tip="tip")
    assert robot.joint_names == ("a,b", '#2 "q"')
    plan = pincal.Plan.for_robot(robot, [[0.1, 1.0], [0.5, -1.0], [1.0, 2.0]])
    plan.to_csv(tmp_path / "plan.csv")
    back = pincal.Plan.from_csv(tmp_path / "plan.csv", robot=robot)
    np.testing.assert_array_equal(back.q, plan.q)
    data = pincal.simulate_measurements(robot, plan, sigma=0.0)
    data.to_csv(tmp_path / "meas.csv")
    assert pincal.MeasurementData.from_csv(tmp_path / "meas.csv", robot).joint_names == robot.joint_names
    argv = ["design", tmp_path / "odd.urdf", "--tip", "tip", "-m", "6", "--test-pose=0.3,1.2"]
    argv += ["--workers", "1", "--starts", "2", "--pool-size", "200", "--no-accuracy"]
    code, _, err = cli.run(*argv, "--out", tmp_path / "d.csv")
    assert code == 0, err
    assert pincal.Plan.from_csv(tmp_path / "d.csv", robot=robot).m == 6


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
