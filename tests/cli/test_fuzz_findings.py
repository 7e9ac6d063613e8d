"""What the long fuzz run found (issue 32, item 7), each case kept as a regression test with the
fuzz property (tests/support/fuzz_cli.py: exit 0 or 2, one ``pincal: error:`` line, every input unchanged,
no partial output, no NaN or inf written):

* a flat or zero-scale collision mesh, on the robot or in the workcell, killed ``design``,
  ``campaign`` and ``show`` (SIGSEGV: qhull on points that span no volume);
* files named inside other inputs were overwritten: a calibration's sidecar, a workcell's meshes
  and URDF, the robot's meshes;
* the calibration sidecar was not validated (a null base, a non-string tip, booleans read as
  numbers, a gain of −1, a malformed residual model, deeply nested JSON);
* ``campaign`` took non-physical speeds and times, wrote ``wait=inf``, and neither ``campaign
  --out`` nor ``compensate --out`` quoted joint names.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.cli.example import example_text
from pincal.model.geometry import THIN, thickened
from tests.conftest import ROOT
from tests.support.fuzz_cli import Outcome, _snapshot, check_run

PLANAR = (ROOT / "robots" / "planar_2r.urdf").read_text()
PLAN = "joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n"
FLAT_STL = """solid flat
facet normal 0 0 1
 outer loop
  vertex 0 0 0
  vertex 0.2 0 0
  vertex 0 0.2 0
 endloop
endfacet
facet normal 0 0 1
 outer loop
  vertex 0.2 0 0
  vertex 0.2 0.2 0
  vertex 0 0.2 0
 endloop
endfacet
endsolid flat
"""


def _cube_stl(size: float = 0.1) -> str:
    v = [(x, y, z) for x in (0, size) for y in (0, size) for z in (0, size)]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip
    facets = "".join(
        "facet normal 0 0 0\n outer loop\n"
        + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in (v[i] for i in f))
        + " endloop\nendfacet\n"
        for f in faces
    )
    return f"solid cube\n{facets}endsolid cube\n"


def _robot_with_mesh(mesh: str, scale: str) -> str:
    collision = (
        f'<link name="link2"><collision><origin xyz="0.4 0 0"/><geometry><mesh filename="{mesh}" '
        f'scale="{scale}"/></geometry></collision></link>'
    )
    return PLANAR.replace('<link name="link2"/>', collision)


def run_checked(folder: Path, argv: list[str], inputs: set[str], child: bool = False) -> Outcome:
    """Run ``pincal ARGV`` (in a child process with ``child``: a crash fails the test, not the
    suite) in ``folder`` and check the fuzz property on it; the outcome."""
    before = _snapshot(folder)
    if child:
        code = "import sys; from pincal.cli import main; sys.exit(main(sys.argv[1:]))"
        done = subprocess.run(
            [sys.executable, "-c", code, *argv], cwd=folder, capture_output=True, text=True, timeout=600
        )
        outcome = Outcome(done.returncode, done.stdout, done.stderr)
    else:
        from pincal.cli import main

        out, err = io.StringIO(), io.StringIO()
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                try:
                    code = main(argv)
                except SystemExit as exc:
                    code = exc.code if isinstance(exc.code, int) else 2
        finally:
            os.chdir(cwd)
        outcome = Outcome(code, out.getvalue(), err.getvalue())
    check_run(outcome, before, _snapshot(folder), inputs)
    return outcome


# ------------------------------------------------------------------ degenerate collision meshes
@pytest.mark.parametrize("points", [np.zeros((0, 3)), np.ones((1, 3)), np.array([[0, 0, 0], [1, 2, 3.0]]),
                                    np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])])  # fmt: skip
def test_points_spanning_no_volume_are_thickened(points):
    out = thickened(points)
    assert np.linalg.matrix_rank(out - out.mean(axis=0)) == 3
    spread = np.linalg.svd(out - out.mean(axis=0), compute_uv=False)
    assert spread.min() > 0.1 * THIN
    # the hull holds the given points (each the centre of its copies), each copy within THIN of it
    if len(points):
        copies = out.reshape(-1, len(points), 3)
        np.testing.assert_allclose(copies.mean(axis=0), points, atol=1e-12)
        assert np.abs(copies - points).max() <= THIN / 2 + 1e-12


def test_a_solid_mesh_is_kept_as_it_is():
    cube = np.array([(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    assert thickened(cube) is cube


@pytest.fixture
def meshes(tmp_path):
    (tmp_path / "flat.stl").write_text(FLAT_STL)
    (tmp_path / "cube.stl").write_text(_cube_stl())
    (tmp_path / "plan.csv").write_text(PLAN)
    (tmp_path / "cell.yaml").write_text(
        "workcell:\n  obstacles:\n    - {name: plate, mesh: flat.stl, xyz: [1.5, 0, 0.5]}\n"
    )
    for name, mesh, scale in (("zero", "cube.stl", "0 0 0"), ("flat", "cube.stl", "1 1 0")):
        (tmp_path / f"robot_{name}.urdf").write_text(_robot_with_mesh(mesh, scale))
    return tmp_path


COMMON = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]
COMPENSATE = ["compensate", str(ROOT / "robots" / "planar_2r.urdf"), "--tip", "tip",
              "--calibration", "cal.urdf", "--targets", "program.csv"]  # fmt: skip
DEGENERATE = {
    # the robot given, the command after it; each ran into SIGSEGV (exit 139, no message)
    "a flat workcell mesh, campaign": ("planar_2r", ["campaign", "--tip", "tip", "--plan", "plan.csv",
                                                     "--constraints", "cell.yaml"]),
    "a flat workcell mesh, show": ("planar_2r", ["show", *COMMON, "--plan", "plan.csv", "--constraints",
                                                 "cell.yaml", "--html", "scene.html"]),
    "a zero-scale robot mesh, design": ("robot_zero.urdf", [
        "design", *COMMON, "-m", "3", "--test-pose=0.3,1.2", "--starts", "2", "--workers", "1",
        "--pool-size", "40", "--no-progress", "--constraints", "cell.yaml", "--out", "out.csv"]),
    "a flat robot mesh, campaign": ("robot_flat.urdf", ["campaign", "--tip", "tip", "--plan", "plan.csv",
                                                        "--constraints", "cell.yaml"]),
}  # fmt: skip


@pytest.mark.parametrize("case", list(DEGENERATE))
def test_a_degenerate_collision_mesh_crashes_nothing(meshes, case):
    robot, argv = DEGENERATE[case]
    argv = [argv[0], robot, *argv[1:]]
    inputs = {"plan.csv", "cell.yaml", "flat.stl", "cube.stl", robot}
    outcome = run_checked(meshes, argv, inputs, child=True)
    assert outcome.code == 0, outcome.err


# ----------------------------------------------------------------- files named inside inputs
@pytest.fixture
def calibrated(tmp_path):
    robot = pincal.load_robot(ROOT / "robots" / "planar_2r.urdf", tip="tip")
    robot = robot.replace(joint_gains=[0.001, -0.002], joint_compliances=[1e-6, 2e-6])
    pincal.export_urdf(robot, tmp_path / "cal.urdf")
    (tmp_path / "program.csv").write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n")
    return tmp_path


def test_compensate_never_writes_over_the_calibrations_sidecar(calibrated):
    inputs = {"cal.urdf", "cal.calibration.json", "program.csv"}
    argv = [*COMPENSATE, "--out", "cal.calibration.json"]
    outcome = run_checked(calibrated, argv, inputs)
    assert outcome.code == 2 and "is the input cal.calibration.json" in outcome.err


@pytest.mark.parametrize("what", ["workcell mesh", "workcell urdf", "robot mesh"])
def test_no_output_replaces_a_file_an_input_names(meshes, what):
    (meshes / "cell.urdf").write_text(
        '<robot name="cell"><link name="world"><collision><geometry><mesh filename="cube.stl"/>'
        "</geometry></collision></link></robot>"
    )
    (meshes / "cell_urdf.yaml").write_text("workcell:\n  urdf: cell.urdf\n")
    (meshes / "robot_cube.urdf").write_text(_robot_with_mesh("cube.stl", "1 1 1"))
    robot, constraints, target = {
        "workcell mesh": ("planar_2r", "cell.yaml", "flat.stl"),
        "workcell urdf": ("planar_2r", "cell_urdf.yaml", "cell.urdf"),
        "robot mesh": ("robot_cube.urdf", "cell.yaml", "cube.stl"),
    }[what]
    argv = [
        "campaign",
        robot,
        "--tip",
        "tip",
        "--plan",
        "plan.csv",
        "--constraints",
        constraints,
        "--out",
        target,
    ]
    inputs = {"plan.csv", constraints, target, robot, "cube.stl", "flat.stl"}
    outcome = run_checked(meshes, argv, inputs)
    assert outcome.code == 2 and f"is the input {target}" in outcome.err.replace(str(meshes) + "/", "")
    if what == "workcell urdf":  # and the cell's own mesh
        outcome = run_checked(meshes, [*argv[:-1], "cube.stl"], inputs)
        assert outcome.code == 2 and "pincal never overwrites an input" in outcome.err


# ------------------------------------------------------------------------ the sidecar, checked
SIDECAR_MUTATIONS = {
    "a null base": (lambda s: s.update(base=None), "'base' must be the robot base"),
    "a base that is no rotation": (
        lambda s: s["base"].update(matrix=[[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
        "'base.matrix' must be a rigid transform",
    ),
    "a non-string tip": (lambda s: s.update(tip=5), "'tip' must be the name of the tip frame"),
    "a null tip": (lambda s: s.update(tip=None), "'tip' must be the name of the tip frame"),
    "a boolean gain": (lambda s: s["joint_gains"].update(joint1=True), "'joint_gains' must be"),
    "a gain of -1": (lambda s: s["joint_gains"].update(joint2=-1), "a gain error must lie within ±0.5"),
    "a string compliance": (
        lambda s: s["joint_compliances"].update(joint1="1e-6"), "'joint_compliances' must be"),
    "boolean markers": (lambda s: s.update(markers=[[True, 0, 0]]), "'markers' must be"),
    "flat markers": (lambda s: s.update(markers=[0.1, 0.2, 0.3]), "'markers' must be [[x, y, z], ...]"),
    "boolean gravity": (lambda s: s.update(gravity=[0, 0, False]), "'gravity' must be 3 numbers"),
    "a residual model that is a list": (
        lambda s: s.update(residual_model=[1, 2]), "'residual_model' must be"),
    "a residual model without its data": (
        lambda s: s.update(residual_model={"kind": "gp"}), "'residual_model':"),
    "a residual model of booleans": (
        lambda s: s.update(residual_model={"kind": "gp", "amplitude": True}),
        "'residual_model.amplitude' must be",
    ),
    "gains that are a list": (
        lambda s: s.update(joint_gains=[0.1, 0.2]), "joint_gains must map the chain's joints"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(SIDECAR_MUTATIONS))
def test_a_malformed_sidecar_is_one_line_naming_the_field(calibrated, case):
    change, expected = SIDECAR_MUTATIONS[case]
    side = calibrated / "cal.calibration.json"
    content = json.loads(side.read_text())
    change(content)
    side.write_text(json.dumps(content))
    argv = [*COMPENSATE, "--out", "out.csv"]
    outcome = run_checked(calibrated, argv, {"cal.urdf", "cal.calibration.json", "program.csv"})
    assert outcome.code == 2 and expected in outcome.err, outcome.err


@pytest.mark.parametrize(
    "text, expected",
    [("[" * 100_000 + "]" * 100_000, "nested too deeply"), ('{"tip": "tip", "gravity": [NaN, 0, 0]}', "NaN")],
)
def test_a_sidecar_that_is_no_json_object_is_one_line(calibrated, text, expected):
    (calibrated / "cal.calibration.json").write_text(text)
    argv = [*COMPENSATE, "--out", "out.csv"]
    outcome = run_checked(calibrated, argv, {"cal.urdf", "cal.calibration.json", "program.csv"})
    assert outcome.code == 2 and expected in outcome.err, outcome.err


def test_the_checked_sidecar_still_compensates(calibrated):
    argv = [*COMPENSATE, "--out", "out.csv"]
    outcome = run_checked(calibrated, argv, {"cal.urdf", "cal.calibration.json", "program.csv"})
    assert outcome.code == 0, outcome.err
    assert (calibrated / "out.csv").read_text().startswith("joint1,joint2\n")


# ------------------------------------------------------------------ a campaign's times and CSV
@pytest.mark.parametrize(
    "option, value, expected",
    [
        ("--joint-speeds", "1e-320", "--joint-speeds: speeds must be 2 numbers from 1e-06 to 1000"),
        ("--joint-speeds", "1e308", "--joint-speeds: speeds must be 2 numbers from 1e-06 to 1000"),
        (
            "--joint-accelerations",
            "1e-320",
            "--joint-accelerations: accelerations must be 2 numbers from 1e-06",
        ),
        ("--settle", "1e308", "--settle: settle must be seconds from 0 to 86400"),
        ("--dwell", "1e308", "--dwell: dwell must be seconds from 0 to 86400"),
        ("--speed", "1e-320", "--speed: speed_fraction must be from 0.001 to 1"),
    ],
)
def test_a_campaign_refuses_non_physical_times(tmp_path, option, value, expected):
    (tmp_path / "plan.csv").write_text(PLAN)
    argv = [
        "campaign",
        "planar_2r",
        "--tip",
        "tip",
        "--plan",
        "plan.csv",
        option,
        value,
        "--json",
        "--out",
        "c.csv",
    ]
    outcome = run_checked(tmp_path, argv, {"plan.csv"})
    assert outcome.code == 2 and expected in outcome.err, outcome.err


def test_joint_names_with_commas_are_quoted_in_every_program(tmp_path):
    (tmp_path / "comma.urdf").write_text(PLANAR.replace('"joint1"', '"a,b"'))
    (tmp_path / "plan.csv").write_text('"a,b",joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n')
    robot = pincal.load_robot(tmp_path / "comma.urdf", tip="tip")
    pincal.export_urdf(robot.replace(joint_gains=[0.001, -0.002]), tmp_path / "cal.urdf")
    inputs = {"comma.urdf", "plan.csv", "cal.urdf", "cal.calibration.json"}
    campaign = [
        "campaign",
        "comma.urdf",
        "--tip",
        "tip",
        "--plan",
        "plan.csv",
        "--settle",
        "86400",
        "--out",
        "c.csv",
    ]
    assert run_checked(tmp_path, campaign, inputs).code == 0
    lines = (tmp_path / "c.csv").read_text().splitlines()
    assert lines[1] == '"a,b",joint2,pose,wait' and all(len(line.split(",")) == 4 for line in lines[2:])
    assert float(lines[3].split(",")[-1]) == 86400 + 2  # settle and dwell, as they are: never inf
    compensate = ["compensate", "comma.urdf", "--tip", "tip", "--calibration", "cal.urdf",
                  "--targets", "plan.csv", "--out", "corrected.csv"]  # fmt: skip
    assert run_checked(tmp_path, compensate, inputs).code == 0
    back = pincal.Plan.from_csv(tmp_path / "corrected.csv", robot=robot)  # read back by name
    assert back.joint_names == ("a,b", "joint2") and len(back) == 3


# ------------------------------------------------------------------------ runs without an end
@pytest.mark.parametrize(
    "option, expected",
    [
        ("--campaign-m=6:1000000:1", "more than 50 sizes (each is a design); give 1 to 50 sizes"),
        ("--campaign-m=6:1000000000000000000000", "more than 50 sizes"),
        ("--campaign-m=" + ",".join(str(m) for m in range(6, 57)), "more than 50 sizes"),
    ],
)
def test_a_campaign_of_endless_sizes_is_refused(tmp_path, option, expected):
    argv = ["design", "planar_2r", "--tip", "tip", "-m", "3", "--test-pose=0.3,1.2", "--campaign", option,
            "--no-progress"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, set())
    assert outcome.code == 2 and expected in outcome.err, outcome.err


def test_fifty_sizes_are_still_taken():
    from pincal.campaign.tradeoff import MAX_SIZES, parse_sizes

    assert parse_sizes("1:50") == tuple(range(1, 51)) and MAX_SIZES == 50


@pytest.mark.parametrize(
    "box, steps, expected",
    [
        ("1,1,0,3,3,1", "1000", "1000 steps per axis make a grid of 1,000,000,000 positions"),
        ("1,1,0,3,3,1", "22", "at most 10,000 (steps from 1 to 21 on 3 axes)"),
        ("1,1,0.5,3,3,0.5", "101", "10,201 positions over the box's 2 axes of non-zero width"),
    ],
)
def test_a_placement_grid_beyond_ten_thousand_positions_is_refused(tmp_path, box, steps, expected):
    argv = ["design", "planar_2r", "--tip", "tip", "-m", "3", "--test-pose=0.3,1.2", "--place-instrument",
            box, "--place-steps", steps, "--no-progress"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, set())
    assert outcome.code == 2 and expected in outcome.err, outcome.err


def _chain_urdf(joints: int) -> str:
    """A serial chain of ``joints`` revolute joints, axes alternating z and y, 0.1 m apart."""
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" '
                'iyz="0"/></inertial>')  # fmt: skip
    parts = ['<robot name="chain"><link name="l0"/>']
    for i in range(joints):
        axis = "0 0 1" if i % 2 == 0 else "0 1 0"
        parts.append(
            f'<link name="l{i + 1}">{inertial}</link><joint name="j{i}" type="revolute"><parent link="l{i}"/>'
            f'<child link="l{i + 1}"/><origin xyz="0 0 0.1"/><axis xyz="{axis}"/>'
            '<limit lower="-3" upper="3" effort="10" velocity="1"/></joint>'
        )
    parts.append(f'<link name="tip"/><joint name="tip_joint" type="fixed"><parent link="l{joints}"/>'
                 '<child link="tip"/><origin xyz="0 0 0.1"/></joint></robot>')  # fmt: skip
    return "".join(parts)


def test_params_of_a_long_chain_solves_its_combinations_at_once(tmp_path, monkeypatch):
    # a 300-joint chain ran > 15 minutes: one least-squares solve per dropped column (~1 500 of
    # them against 600 rows); and per-joint forward kinematics, each on new Data, in the loader
    (tmp_path / "chain.urdf").write_text(_chain_urdf(120))
    calls = []
    lstsq = np.linalg.lstsq
    monkeypatch.setattr(np.linalg, "lstsq", lambda *a, **k: calls.append(1) or lstsq(*a, **k))
    argv = ["params", "chain.urdf", "--tip", "tip", "--json"]
    outcome = run_checked(tmp_path, argv, {"chain.urdf"})
    assert outcome.code == 0, outcome.err
    report = json.loads(outcome.out)
    assert len(report["params"]) > 700 and report["rank"] == len(report["identifiable"])
    assert len(report["combinations"]) > 100 and len(calls) <= 2


# ------------------------------------------------------------------------- next --reject nan
@pytest.mark.parametrize("command", ["next", "identify"])
@pytest.mark.parametrize("value", ["nan", "inf", "-1", "0"])
def test_a_reject_threshold_that_is_no_positive_number_is_refused(tmp_path, command, value):
    argv = [command, "planar_2r", "--tip", "tip", "--data", "m.csv", "--reject", value]
    argv += ["--test-pose=0.3,1.2"] if command == "next" else []
    outcome = run_checked(tmp_path, argv, set())
    assert outcome.code == 2 and "argument --reject: must be a positive number up to 1e+12" in outcome.err


# ---------------------------------------------------------------- measurement inputs, checked
RIG = """camera:
  fx: 600.0
  fy: 600.0
  cx: 320.0
  cy: 240.0
  width: 640
  height: 480
  mount: tool
  xyz: [0.05, 0.0, 0.05]
target:
  grid: {columns: 6, rows: 5, spacing: 0.03}
  xyz: [0.5, 0.0, 0.0]
  rpy_deg: [180, 0, 0]
pixel_sigma: 0.5
"""
RIG_BOOLEANS = {
    "fx": ("fx: 600.0", "fx: true", "camera fx must be a number, got True"),
    "width": ("width: 640", "width: true", "camera width must be a positive number of pixels, got True"),
    "xyz": ("xyz: [0.05, 0.0, 0.05]", "xyz: [true, 0.0, 0.05]", "camera xyz must be a list of finite"),
    "rpy_deg": ("rpy_deg: [180, 0, 0]", "rpy_deg: [180, false, 0]", "target rpy_deg must be a list of"),
    "spacing": ("spacing: 0.03", "spacing: true", "target grid spacing must be a number, got True"),
    "pixel_sigma": ("pixel_sigma: 0.5", "pixel_sigma: true", "pixel_sigma must be a positive number"),
    "a string": ("xyz: [0.5, 0.0, 0.0]", "xyz: ['0.5', 0.0, 0.0]", "target xyz must be a list of finite"),
    "points": ("grid: {columns: 6, rows: 5, spacing: 0.03}", "points: 5", "target points must be a list"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(RIG_BOOLEANS))
def test_a_rig_refuses_booleans_where_numbers_go(tmp_path, case):
    old, new, expected = RIG_BOOLEANS[case]
    assert old in RIG
    (tmp_path / "rig.yaml").write_text(RIG.replace(old, new))
    outcome = run_checked(tmp_path, ["params", "panda", "--camera", "rig.yaml"], {"rig.yaml"})
    assert outcome.code == 2 and expected in outcome.err, outcome.err


def test_the_checked_rig_still_loads(tmp_path):
    (tmp_path / "rig.yaml").write_text(RIG)
    assert run_checked(tmp_path, ["params", "panda", "--camera", "rig.yaml"], {"rig.yaml"}).code == 0


def _measured(folder: Path, *options: str) -> list[list[str]]:
    """measure-sim's planar_2r data of PLAN and three more (header first), as rows of strings."""
    (folder / "plan.csv").write_text(PLAN + "0.3,0.4\n-0.5,1.5\n0.7,-2\n")
    argv = ["measure-sim", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--error-std", "1e-3,1e-3",
            "--out", "m.csv", *options]  # fmt: skip
    assert run_checked(folder, argv, {"plan.csv"}).code == 0
    return [line.split(",") for line in (folder / "m.csv").read_text().splitlines()]


@pytest.mark.parametrize("other, expected", [("2e-10", "line 4: cov_x_y = 1e-10 and cov_y_x = 2e-10 differ"),
                                             ("1e-10", None)])  # fmt: skip
def test_a_covariance_given_twice_must_agree(tmp_path, other, expected):
    rows = _measured(tmp_path, "--measure", "x,y")
    rows[0] += ["s", "cov_x_y", "cov_y_x"]
    for i, row in enumerate(rows[1:]):
        row += ["3e-5", "1e-10", other if i == 2 else "1e-10"]  # the third row: line 4
    (tmp_path / "m.csv").write_text("\n".join(",".join(r) for r in rows) + "\n")
    argv = ["identify", "planar_2r", "--tip", "tip", "--data", "m.csv", "--measure", "x,y", "--params",
            "joint2.tx,tip.tx"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, {"m.csv"})
    if expected is None:
        assert outcome.code == 0, outcome.err
    else:
        assert outcome.code == 2 and expected in outcome.err, outcome.err


@pytest.mark.parametrize("output", [["--out", "cal.urdf"], ["--json"]])
def test_images_that_mostly_see_no_target_point_are_fitted_as_far_as_they_go(tmp_path, output):
    # a random Panda plan: 28 of the 30 images measure-sim writes see no target point, one sees
    # them all; identify ran into inf (a standard error of 0 in a numerically singular inverse)
    (tmp_path / "rig.yaml").write_text(RIG)
    panda = pincal.load_robot("panda")
    pincal.Plan(panda.random_configurations(30, 1), panda.joint_names).to_csv(tmp_path / "plan.csv")
    simulate = ["measure-sim", "panda", "--plan", "plan.csv", "--camera", "rig.yaml", "--error-std",
                "1e-3,1e-3", "--out", "images.csv"]  # fmt: skip
    assert run_checked(tmp_path, simulate, {"plan.csv", "rig.yaml"}).code == 0
    rows = (tmp_path / "images.csv").read_text().splitlines()[2:]
    assert sum(set(row.split(",")[7:]) == {""} for row in rows) > len(rows) // 2
    identify = ["identify", "panda", "--data", "images.csv", "--camera", "rig.yaml", *output]
    outcome = run_checked(tmp_path, identify, {"plan.csv", "rig.yaml", "images.csv"})
    assert outcome.code == 0, outcome.err
    if "--json" in output:
        assert json.loads(outcome.out)["dropped"]
    else:
        assert "expected error of a prediction: undetermined" in outcome.out


def _quaternion_rows(rows: list[list[str]]) -> list[list[str]]:
    """Pose rows with rx,ry,rz turned into a unit quaternion qx,qy,qz,qw (scalar last)."""
    from scipy.spatial.transform import Rotation

    out = [rows[0][:5] + ["qx", "qy", "qz", "qw"]]
    for row in rows[1:]:
        out.append(
            row[:5] + [repr(float(v)) for v in Rotation.from_rotvec([float(v) for v in row[5:8]]).as_quat()]
        )
    return out


MAGNITUDES = {
    # kind's options, the column (added with 3e-5 elsewhere when absent), its value, the message
    "z": (["--measure", "z"], "z", "1e308", "column z = 1e+308 m: pincal accepts up to 1e+06 m"),
    "d": (["--anchor", "2,2,0"], "d", "-1e308", "column d = -1e+308 m: pincal accepts up to 1e+06 m"),
    "rz": (["--measure", "pose"], "rz", "1e308", "column rz = 1e+308 rad: pincal accepts up to 1e+06 rad"),
    "qw": (["--measure", "pose"], "qw", "1e308", "column qw = 1e+308: pincal accepts up to 1e+06 (a unit"),
    "s": (["--measure", "z"], "s", "1e308", "column s = 1e+308 m: pincal accepts from 1e-12 to 1000 m"),
    "a tiny s": (["--measure", "z"], "sz", "1e-300", "column sz = 1e-300 m: pincal accepts from 1e-12"),
    "srz": (["--measure", "pose"], "srz", "1e308", "column srz = 1e+308 rad: pincal accepts from 1e-12"),
    "in mm": (["--measure", "z", "--mm"], "z", "1e308", "column z = 1e+308 mm: pincal accepts up to 1e+09"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(MAGNITUDES))
def test_a_non_physical_magnitude_is_refused_naming_its_column_and_line(tmp_path, case):
    options, column, value, expected = MAGNITUDES[case]
    simulated = [o for o in options if o != "--mm"]
    rows = _measured(tmp_path, *simulated)
    if column == "qw":
        rows = _quaternion_rows(rows)
    if column not in rows[0]:
        rows[0].append(column)
        for row in rows[1:]:
            row.append("3e-5")
    rows[3][rows[0].index(column)] = value  # line 4
    (tmp_path / "m.csv").write_text("\n".join(",".join(r) for r in rows) + "\n")
    argv = ["identify", "planar_2r", "--tip", "tip", "--data", "m.csv", *options]
    outcome = run_checked(tmp_path, argv, {"m.csv", "plan.csv"})
    assert outcome.code == 2 and f"'m.csv', line 4: {expected}" in outcome.err, outcome.err


def test_pixels_beyond_a_million_are_refused(tmp_path):
    (tmp_path / "rig.yaml").write_text(RIG)
    panda = pincal.load_robot("panda")
    q = panda.random_configurations(3, 0)
    pixels = [f"{c}{k}" for k in range(30) for c in "uv"]  # the rig's 6 x 5 grid; one point seen
    header = ",".join([*panda.joint_names, *pixels]) + "\n"
    rows = "".join(
        ",".join(f"{v:.6f}" for v in qi) + f",{u},240" + "," * 58 + "\n"
        for qi, u in zip(q, ["320", "1e308", "320"])
    )
    (tmp_path / "images.csv").write_text(header + rows)
    argv = ["identify", "panda", "--data", "images.csv", "--camera", "rig.yaml"]
    outcome = run_checked(tmp_path, argv, {"images.csv", "rig.yaml"})
    assert outcome.code == 2 and "line 3: column u0 = 1e+308 px: pincal accepts up to 1e+06 px" in outcome.err


# ------------------------------------------------ joints named like a measurement file's columns
def _renamed(folder: Path, name: str) -> None:
    """planar_2r with joint1 named ``name`` (j.urdf), and a plan of six configurations (plan.csv)."""
    (folder / "j.urdf").write_text(PLANAR.replace('"joint1"', json.dumps(name)))
    plan = PLAN + "0.3,0.4\n-0.5,1.5\n0.7,-2\n"
    quoted = f'"{name}"' if "," in name else name
    (folder / "plan.csv").write_text(plan.replace("joint1", quoted, 1))


@pytest.mark.parametrize("name", ["sx", "d0", "u0", "cov_x_y", "payload_kg", "a,b", "1", "srot"])
def test_joints_named_like_other_columns_make_the_round_trip(tmp_path, name):
    _renamed(tmp_path, name)
    simulate = ["measure-sim", "j.urdf", "--tip", "tip", "--plan", "plan.csv", "--error-std", "1e-3,1e-3",
                "--out", "m.csv"]  # fmt: skip
    assert run_checked(tmp_path, simulate, {"j.urdf", "plan.csv"}).code == 0
    identify = ["identify", "j.urdf", "--tip", "tip", "--data", "m.csv", "--params", "joint2.tx,tip.tx",
                "--json"]  # fmt: skip
    outcome = run_checked(tmp_path, identify, {"j.urdf", "plan.csv", "m.csv"})
    assert outcome.code == 0, outcome.err
    assert json.loads(outcome.out)["status"] == "converged"


@pytest.mark.parametrize(
    "name, options", [("x", []), ("z", ["--measure", "z"]), ("rz", ["--measure", "pose"])]
)
def test_a_joint_named_like_a_measured_column_is_refused_before_writing(tmp_path, name, options):
    _renamed(tmp_path, name)
    simulate = ["measure-sim", "j.urdf", "--tip", "tip", "--plan", "plan.csv", "--error-std", "1e-3,1e-3",
                "--out", "m.csv", *options]  # fmt: skip
    outcome = run_checked(tmp_path, simulate, {"j.urdf", "plan.csv"})
    assert outcome.code == 2 and f"joint {name!r} has the name of a measured column" in outcome.err


@pytest.mark.parametrize("name", ["nan", "NaN", "inf", "-Infinity"])
def test_a_joint_named_like_no_number_is_refused_at_load(tmp_path, name):
    _renamed(tmp_path, name)
    outcome = run_checked(tmp_path, ["params", "j.urdf", "--tip", "tip"], {"j.urdf", "plan.csv"})
    assert outcome.code == 2 and f"joint {name!r} is named like a number that is none" in outcome.err


def test_a_plan_without_its_header_is_still_refused(tmp_path):
    (tmp_path / "plan.csv").write_text("0.1,1.0\n0.5,-1.0\n")
    outcome = run_checked(
        tmp_path, ["campaign", "planar_2r", "--tip", "tip", "--plan", "plan.csv"], {"plan.csv"}
    )
    assert outcome.code == 2 and "the first row must be a header of column names, got 0.1,1.0" in outcome.err


# ------------------------------------------------------------ urdfdom's own lines, into pincal's
BAD_CELLS = {
    "a box of two sizes": ('<box size="1 1"/>', "", "Parser found 2 elements but 3 expected"),
    "a joint without child": ('<box size="1 1 1"/>',
                              '<joint name="j" type="fixed"><parent link="world"/></joint>',
                              "Failed to build tree: Joint [j] is missing a parent and/or child link"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(BAD_CELLS))
def test_a_malformed_workcell_urdf_is_one_line_without_urdfdoms(tmp_path, case):
    box, joint, expected = BAD_CELLS[case]
    (tmp_path / "cell.urdf").write_text(
        f'<robot name="cell"><link name="world"><collision><geometry>{box}</geometry></collision></link>'
        f"{joint}</robot>"
    )
    (tmp_path / "cell.yaml").write_text("workcell:\n  urdf: cell.urdf\n")
    (tmp_path / "plan.csv").write_text(PLAN)
    argv = ["campaign", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--constraints", "cell.yaml"]
    outcome = run_checked(tmp_path, argv, {"cell.urdf", "cell.yaml", "plan.csv"}, child=True)
    assert outcome.code == 2 and "workcell urdf 'cell.urdf': cannot read it: " + expected in outcome.err


def test_a_robot_collision_urdfdom_cannot_read_is_one_warning(tmp_path):
    bad = '<link name="link2"><collision><geometry><box size="1 1"/></geometry></collision></link>'
    (tmp_path / "robot.urdf").write_text(PLANAR.replace('<link name="link2"/>', bad))
    (tmp_path / "plan.csv").write_text(PLAN)
    argv = ["campaign", "robot.urdf", "--tip", "tip", "--plan", "plan.csv"]
    outcome = run_checked(tmp_path, argv, {"robot.urdf", "plan.csv"}, child=True)
    assert outcome.code == 0 and "Error:" not in outcome.err
    assert "leaves out what urdfdom could not read: Parser found 2 elements" in outcome.err


# ------------------------------------------------------------ plausible compliances in rehearsals
@pytest.mark.parametrize("name, load", [("kr270", 270.0), ("ur10", 10.0), ("panda", 3.0)])
def test_drawn_compliances_are_within_the_published_range(name, load):
    # a light wrist under its own weight alone drew 86 urad/(N m): 38 mm under the payload
    from pincal.calibration.synthetic import COMPLIANCE_RANGE

    robot = pincal.load_robot(name)
    params = robot.parameters("compliance")
    qs = robot.random_configurations(100, 3)
    for seed in range(3):
        truth = pincal.random_errors(params, seed=seed, payload=load)
        assert np.all((truth.values >= COMPLIANCE_RANGE[0]) & (truth.values <= COMPLIANCE_RANGE[1]))
        bent = np.linalg.norm(truth.robot.points(qs, payload=load) - robot.points(qs, payload=load), axis=-1)
        assert np.sqrt(np.mean(bent**2)) < 3e-3  # millimetres at the rated payload, never centimetres
        if name != "kr270":  # (its A2 and A3 at the range's floor, 1e-7, bend it by 1-2 mm)
            assert np.sqrt(np.mean(bent**2)) < 1e-3


def test_measure_sim_draws_compliances_for_the_plans_heaviest_payload(tmp_path):
    ur10 = pincal.load_robot("ur10")
    qs = ur10.random_configurations(8, 0)
    pincal.Plan.for_robot(ur10, qs, np.repeat([0.0, 10.0], 4)).to_csv(tmp_path / "plan.csv")
    argv = ["measure-sim", "ur10", "--plan", "plan.csv", "--params", "compliance", "--error-std", "0,0",
            "--sigma", "0", "--save-true", "true.urdf", "--out", "m.csv"]  # fmt: skip
    assert run_checked(tmp_path, argv, {"plan.csv"}).code == 0
    side = json.loads((tmp_path / "true.calibration.json").read_text())
    assert max(side["joint_compliances"].values()) <= 1e-5


def test_an_empty_calibration_name_is_refused(cli, tmp_path):
    """--residual-model '' (or --calibration ''): one line, not an internal error (fuzz, issue 32)."""
    plan = tmp_path / "plan.csv"
    plan.write_text("joint1,joint2\n0,1\n0.5,1.5\n")
    cli.fails(
        "evaluate", "planar_2r", "--plan", plan, "--test-pose=0.3,1.2", "--params", "joint2.tx,tip.tx",
        "--residual-model", "", match="is no file",
    )  # fmt: skip


# ------------------------------ the every-command fuzzer's findings (tests/support/fuzz_every.py)
def test_export_refuses_a_sidecar_nested_too_deeply(calibrated):
    """export read the sidecar's tip with a bare json.loads: RecursionError, an internal error."""
    (calibrated / "cal.calibration.json").write_text("[" * 100_000 + "]" * 100_000)
    argv = ["export", "cal.urdf", "--format", "urdf", "--out", "out.urdf"]
    outcome = run_checked(calibrated, argv, {"cal.urdf", "cal.calibration.json"})
    assert outcome.code == 2 and "nested too deeply" in outcome.err, outcome.err


@pytest.mark.parametrize("scale", ["1e100", "1e308"])
def test_a_robot_mesh_scaled_beyond_any_cell_is_refused_naming_its_scale(meshes, scale):
    """A robot's mesh scaled by 1e100 crashed qhull (SIGSEGV) in design, evaluate and campaign (a
    workcell's scale was already held within 1e6)."""
    (meshes / "robot_huge.urdf").write_text(_robot_with_mesh("cube.stl", f"{scale} {scale} {scale}"))
    argv = ["campaign", "robot_huge.urdf", "--tip", "tip", "--plan", "plan.csv", "--constraints", "cell.yaml"]
    inputs = {"plan.csv", "cell.yaml", "robot_huge.urdf", "cube.stl", "flat.stl"}
    outcome = run_checked(meshes, argv, inputs, child=True)
    assert outcome.code == 2 and "check its scale" in outcome.err, outcome.err


MJCF = """<mujoco model="arm"><compiler angle="radian"/><worldbody>
<body name="link1" quat="{quat}"><joint name="j1" type="hinge" axis="0 0 1" range="-1 1"/>
<body name="tip" pos="{pos}"/></body></worldbody></mujoco>
"""


@pytest.mark.parametrize("quat, code", [("1 0 0 0", 0), ("1e308 0 0 1e308", 2), ("1e300 0 0 0", 2)])
def test_an_mjcf_number_beyond_any_robot_is_one_line(tmp_path, quat, code):
    """A quat of 1e308 overflowed its norm: an internal error (robots, and every command's robot)."""
    (tmp_path / "arm.xml").write_text(MJCF.format(quat=quat, pos="1 0 0"))
    outcome = run_checked(tmp_path, ["robots", "arm.xml"], {"arm.xml"})
    assert outcome.code == code, outcome.err
    if code:
        assert "finite numbers within" in outcome.err, outcome.err


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["params", "planar_2r", "--tip", "tip", "--gravity", "-9.81,0,0"], None),  # a wall mount
        (["campaign", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--joint-speeds", "-1,2"], "speed"),
        (["campaign", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--home", "-0.5,0.2"], None),
    ],
)
def test_a_value_starting_with_a_minus_sign_is_a_value_of_every_option(tmp_path, argv, expected):
    """'--gravity -9.81,0,0' was 'expected one argument': only a hand list of options took a value
    starting with '-'; now every long option with one value does."""
    (tmp_path / "plan.csv").write_text(PLAN)
    outcome = run_checked(tmp_path, argv, {"plan.csv"})
    if expected is None:
        assert outcome.code == 0, outcome.err
    else:
        assert outcome.code == 2 and expected in outcome.err and "expected one argument" not in outcome.err


def test_images_that_see_no_target_point_at_all_are_one_line(tmp_path):
    """rail_arm's plans never show the example rig's target to its camera: measure-sim writes 8
    empty images, and identify stopped on 'Mean of empty slice' (an internal error)."""
    (tmp_path / "rig.yaml").write_text(example_text("rig"))  # the installed package's
    rows = "".join(
        f"{0.2 * k},{0.1 * k},0,0\n" for k in range(8)
    )  # the camera looks up, away from the target
    (tmp_path / "plan.csv").write_text("rail,waist,shoulder,elbow\n" + rows)
    simulate = ["measure-sim", "rail_arm", "--plan", "plan.csv", "--camera", "rig.yaml", "--error-std",
                "1e-3,1e-3", "--out", "images.csv"]  # fmt: skip
    assert run_checked(tmp_path, simulate, {"plan.csv", "rig.yaml"}).code == 0
    rows = (tmp_path / "images.csv").read_text().splitlines()[1:]
    assert all(set(row.split(",")[4:]) == {""} for row in rows if not row.startswith("#"))
    identify = ["identify", "rail_arm", "--data", "images.csv", "--camera", "rig.yaml", "--out", "cal.urdf"]
    outcome = run_checked(tmp_path, identify, {"plan.csv", "rig.yaml", "images.csv"})
    assert outcome.code == 2 and "none of the 8 images sees a target point" in outcome.err, outcome.err


@pytest.mark.parametrize("m, code", [(500, 0), (501, 2)])
def test_show_draws_at_most_five_hundred_poses(tmp_path, m, code):
    """show of a 266 928-pose plan (a 20 MB file) drew a robot per pose for minutes (CPU limit)."""
    q = np.random.default_rng(0).uniform(-3, 3, size=(m, 2))
    (tmp_path / "plan.csv").write_text("joint1,joint2\n" + "".join(f"{a},{b}\n" for a, b in q))
    argv = ["show", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--params", "joint2.tx,tip.tx",
            "--test-pose=0.3,1.2", "--no-accuracy", "--baseline", "2", "--html", "scene.html"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, {"plan.csv"})
    assert outcome.code == code, outcome.err
    if code:
        assert "at most 500" in outcome.err


@pytest.mark.parametrize("other", ["d", "x,y,z,rx,ry,rz"])
def test_validation_data_of_another_kind_is_one_line(tmp_path, other):
    """identify --data points --validate distances: an AttributeError on the column 'd'."""
    q = "0.1,1.0\n0.5,-1.0\n1.0,2.0\n1.5,0.3\n"
    (tmp_path / "points.csv").write_text(
        "joint1,joint2,x,y,z\n" + "".join(f"{row},{x},0.5,0\n" for row, x in zip(q.split(), (1, 2, 3, 4)))
    )
    values = ",".join(["0.5"] * len(other.split(",")))
    (tmp_path / "other.csv").write_text(
        f"joint1,joint2,{other}\n" + "".join(f"{row},{values}\n" for row in q.split())
    )
    argv = ["identify", "planar_2r", "--tip", "tip", "--params", "joint2.tx,tip.tx", "--data", "points.csv",
            "--validate", "other.csv"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, {"points.csv", "other.csv"})
    assert outcome.code == 2 and "a file of another kind of measurement" in outcome.err, outcome.err


@pytest.mark.parametrize("gravity", ["1e308,0,0", "1e200,1e200,0", "-1e308,1e-320,1e7"])
def test_a_gravity_beyond_float_range_is_one_line(tmp_path, gravity):
    """--gravity 1e308,...: the norm checked against 100 m/s² overflowed first (an internal error)."""
    (tmp_path / "plan.csv").write_text(PLAN)
    argv = ["measure-sim", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--error-std", "1e-3,1e-3",
            "--gravity", gravity, "--out", "m.csv"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, {"plan.csv"})
    assert outcome.code == 2 and "of at most 100 m/s²" in outcome.err, outcome.err


def _random_plan(path: Path, names: list[str], m: int) -> None:
    q = np.random.default_rng(0).uniform(0, 1, size=(m, len(names)))
    path.write_text(",".join(names) + "\n" + "".join(",".join(f"{v:.4f}" for v in row) + "\n" for row in q))


def test_a_campaign_orders_at_most_two_thousand_poses(tmp_path):
    """campaign of a 266 929-pose plan: a MemoryError asking for 2 TiB (every pair of poses); 600
    poses take 20 s of CPU, 300 poses 5 s."""
    _random_plan(tmp_path / "plan.csv", ["joint1", "joint2"], 2001)
    argv = ["campaign", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--no-check", "--no-progress"]
    outcome = run_checked(tmp_path, argv, {"plan.csv"})
    assert outcome.code == 2 and "a campaign orders at most 2000" in outcome.err, outcome.err


def test_a_jacobian_beyond_what_memory_holds_is_one_line(tmp_path):
    """simulate of a 266 928-pose plan measured by a camera: a MemoryError (3.6 GiB)."""
    (tmp_path / "rig.yaml").write_text(example_text("rig"))  # the installed package's
    _random_plan(tmp_path / "plan.csv", ["rail", "waist", "shoulder", "elbow"], 45_000)
    argv = ["simulate", "rail_arm", "--plan", "plan.csv", "--camera", "rig.yaml",
            "--test-pose=0.5,0.3,0.2,-0.4", "--trials", "5", "--no-progress"]  # fmt: skip
    outcome = run_checked(tmp_path, argv, {"plan.csv", "rig.yaml"})
    assert outcome.code == 2 and "a Jacobian of" in outcome.err and "give fewer configurations" in outcome.err


@pytest.mark.parametrize("option", ["--sigma-rot", "--sigma-px"])
@pytest.mark.parametrize("value", ["1e-320", "1e308"])
def test_an_orientation_or_pixel_noise_beyond_any_instrument_is_one_line(tmp_path, option, value):
    """evaluate --measure x,y,rz --sigma-rot 1e-320: whitening by it overflowed (an internal error)."""
    (tmp_path / "plan.csv").write_text(PLAN)
    argv = ["evaluate", "planar_2r", "--tip", "tip", "--plan", "plan.csv", "--measure", "x,y,rz",
            "--test-pose=0.3,1.2", option, value]  # fmt: skip
    outcome = run_checked(tmp_path, argv, {"plan.csv"})
    assert outcome.code == 2 and f"{option} must be a positive number from 1e-12" in outcome.err, outcome.err


@pytest.mark.parametrize("offsets", [{"joint1": ""}, {"joint1": True}, [0.1, 0.2], {"joint1": [1]}])
def test_export_of_corrections_checks_the_sidecars_joint_offsets(calibrated, offsets):
    """export --format robot_calibration of a sidecar whose joint offset was '': float('') raised."""
    side = calibrated / "cal.calibration.json"
    content = json.loads(side.read_text())
    content["joint_offsets"] = offsets
    side.write_text(json.dumps(content))
    source = str(ROOT / "robots" / "planar_2r.urdf")
    argv = ["export", "cal.urdf", "--format", "robot_calibration", "--source", source, "--out", "cal.yaml"]
    outcome = run_checked(calibrated, argv, {"cal.urdf", "cal.calibration.json"})
    assert outcome.code == 2, outcome.err


@pytest.mark.parametrize("pos, code", [("1 0 0", 0), ("1 0 1e308", 2), ("1e7 0 0", 2)])
def test_an_mjcf_body_placed_beyond_any_robot_is_one_line(tmp_path, pos, code):
    """A body's pos of 1e308 (one Pinocchio reads as it is, no orientation to rewrite) reached the
    Jacobian's column norms: an overflow, an internal error in evaluate."""
    (tmp_path / "arm.xml").write_text(MJCF.format(quat="1 0 0 0", pos=pos))
    outcome = run_checked(tmp_path, ["robots", "arm.xml"], {"arm.xml"})
    assert outcome.code == code, outcome.err
    if code:
        assert "from its parent, beyond 1e+06 m" in outcome.err, outcome.err
