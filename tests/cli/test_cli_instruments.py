"""The command line with every instrument: what is identifiable, simulated data of each kind, and
their calibration to a URDF (docs/method.md §13)."""

from __future__ import annotations

import json

import pytest

import pincal
from pincal.instruments.rig import load_rig

RIG = """\
camera:
  fx: 600.0
  fy: 600.0
  cx: 320.0
  cy: 240.0
  distortion: [0.05, -0.02, 0.0, 0.0, 0.0]
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

UR10_POSE = "0,-1.2,1.5,-1,-1.5,0"


def random_plan(tmp_path, robot, m, seed=0, keep=None):
    pool = robot.random_configurations(40 * m, seed)
    qs = pool if keep is None else pool[keep(pool)]
    path = tmp_path / "plan.csv"
    pincal.Plan(qs[:m], robot.joint_names).to_csv(path)
    return path


def test_params_per_kind(cli):
    point = cli.json("params", "kr270", "--json")
    pose = cli.json("params", "kr270", "--measure", "pose", "--json")
    assert "joint_a6.offset" not in point["identifiable"] and "joint_a6.offset" in pose["identifiable"]
    assert pose["instrument"]["measure"] == {"kind": "pose"}
    height = cli.json("params", "ur10", "--measure", "z", "--json")
    assert len(height["identifiable"]) < len(point["identifiable"])
    wires = cli.json(
        "params", "ur10", *("--anchor", "1,1,0", "--anchor", "-1,1.5,0.5", "--anchor", "1.5,-1,1"), "--json"
    )
    assert {"anchor0.x", "anchor2.z"} <= set(wires["identifiable"])
    cli.fails("params", "kr270", "--measure", "x,y/z", match="2 masks for 1 marker")


def test_mocap_poses_from_file_to_urdf(cli, tmp_path):
    ur10 = pincal.load_robot("ur10")
    plan = random_plan(tmp_path, ur10, 25)
    data = tmp_path / "mocap.csv"
    common = ("--sigma", "1e-4", "--sigma-rot", "2e-3")
    cli.run("measure-sim", "ur10", "--plan", plan, "--error-std", "1e-3,1e-3", "--measure", "pose", *common,
            "--out", data, "--base-pose=1,0.5,0,0,0,0.3")  # fmt: skip
    assert data.read_text().splitlines()[0].endswith(",x,y,z,rx,ry,rz")
    out = tmp_path / "cal.urdf"
    result = cli.json("identify", "ur10", "--data", data, "--base", *common, "--out", out, "--json")
    assert result["status"] == "converged" and result["measure"] == {"kind": "pose"}
    assert result["residual_rms_by_unit"]["m"] < 3e-4 and result["residual_rms_by_unit"]["rad"] < 6e-3
    assert out.exists()
    code, text, _ = cli.run("identify", "ur10", "--data", data, "--base", *common)
    assert code == 0 and "mrad before" in text and "pose" in text


def test_camera_rig_from_file_to_urdf(cli, tmp_path):
    rig = tmp_path / "rig.yaml"
    rig.write_text(RIG)
    loaded = load_rig(rig)
    panda = pincal.load_robot("panda").with_fixtures(*loaded.fixtures)
    plan = random_plan(tmp_path, panda, 30, keep=lambda qs: loaded.kind.seen(panda, qs).sum(axis=1) >= 8)
    data = tmp_path / "corners.csv"
    cli.run(
        "measure-sim", "panda", "--plan", plan, "--error-std", "1e-3,1e-3", "--camera", rig, "--out", data
    )
    assert ",u0,v0," in data.read_text().splitlines()[0]
    out = tmp_path / "cal.urdf"
    result = cli.json("identify", "panda", "--data", data, "--camera", rig, "--out", out, "--json")
    assert result["status"] == "converged" and result["residual_rms_by_unit"]["px"] < 1.0
    sidecar = json.loads(out.with_suffix(".calibration.json").read_text())
    assert sidecar["fixtures"]["camera"]["on"] == "tip" and sidecar["fixtures"]["target"]["on"] == "world"
    cli.fails("identify", "panda", "--data", data, match="--camera")


def test_draw_wires_and_tracker_from_file(cli, tmp_path):
    ur10 = pincal.load_robot("ur10", markers=[(0.05, 0.02, 0.1)])
    plan = random_plan(tmp_path, ur10, 40)
    wires = (
        "--anchor",
        "1,1,0",
        "--anchor",
        "-1,1.5,0.5",
        "--anchor",
        "1.5,-1,1",
        "--anchor",
        "0.5,-1.5,0.2",
    )
    data = tmp_path / "wires.csv"
    cli.run("measure-sim", "ur10", "--plan", plan, "--marker", "0.05,0.02,0.1", "--error-std", "1e-3,1e-3",
            *wires, "--out", data)  # fmt: skip
    assert data.read_text().splitlines()[0].endswith(",d0,d1,d2,d3")
    result = cli.json("identify", "ur10", "--data", data, "--marker", "0.05,0.02,0.1", *wires, "--json")
    assert result["status"] == "converged" and "anchor3.z" in result["params"]
    tracker = ("--instrument", "tracker", "--instrument-at", "3,0,1")
    points = tmp_path / "tracker.csv"
    cli.run("measure-sim", "ur10", "--plan", plan, "--marker", "0.05,0.02,0.1", "--error-std", "1e-3,1e-3",
            *tracker, "--out", points)  # fmt: skip
    result = cli.json("identify", "ur10", "--data", points, "--marker", "0.05,0.02,0.1", *tracker, "--json")
    assert result["status"] == "converged" and not result["sigma_estimated"]


def test_bad_instrument_arguments_are_one_line(cli, tmp_path):
    cli.fails("params", "ur10", "--measure", "volume", match="valid: point, pose, distance, image")
    cli.fails("params", "ur10", "--measure", "distance", match="--anchor X,Y,Z")
    cli.fails("params", "ur10", "--measure", "image", match="--camera RIG.yaml")
    cli.fails("params", "ur10", "--instrument-at", "1,2,3", match="add --instrument tracker")
    cli.fails("params", "ur10", "--instrument", "laser", match="valid: tracker")
    cli.fails("params", "ur10", "--instrument", "tracker", "--sigma", "1e-5", match="--tracker-sigma")
    cli.fails("params", "ur10", "--sigma-rot", "-1", match="--sigma-rot must be a positive")
    cli.fails("params", "ur10", "--anchor", "1,2", match="--anchor: expected X,Y,Z")
    rig = tmp_path / "rig.yaml"
    rig.write_text(RIG.replace("mount: tool", "mount: wall"))
    cli.fails("params", "panda", "--camera", rig, match="valid: tool")
    rig.write_text(RIG.replace("  fx: 600.0\n", "  fx: 600.0\n  focal: 3\n"))
    cli.fails("params", "panda", "--camera", rig, match="unknown key 'focal'")


@pytest.mark.parametrize("command", ["identify", "measure-sim", "params"])
def test_help_says_how_to_use_each_instrument(cli, command):
    code, out, _ = cli.run(command, "--help")
    assert code == 0 and "--camera" in out and "tracker" in out and "AT500" in out


def test_a_pose_design_with_payloads_from_the_command_line(cli, tmp_path):
    # design chooses a payload per configuration for poses; evaluate reads the plan CSV back and
    # gives the same rho0.
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    spec = robot.parameters("lengths,offsets,gains,compliance")
    poses = pincal.instruments.Instrument(pincal.instruments.Pose())
    names = poses.identifiable(spec, payloads=[0, 135, 270])
    common = ("--test-pose=0,-60,60,0,45,0", "--deg", "--marker", "0.1,0.05,0.2", "--params",
              ",".join(names.identifiable.names), "--task-payload", "270", "--payload-centre", "0,0,0.25",
              "--measure", "pose", "--sigma", "3e-5", "--sigma-rot", "1e-4", "--no-accuracy")  # fmt: skip
    plan = tmp_path / "plan.csv"
    designed = cli.json("design", "kr270", "-m", "12", "--payloads", "0,135,270", "--pool-size", "200",
                        "--starts", "2", "--out", plan, "--json", *common)  # fmt: skip
    assert designed["instrument"]["measure"] == {"kind": "pose"}
    assert plan.read_text().splitlines()[0].endswith("payload_kg,payload_x,payload_y,payload_z")
    evaluated = cli.json("evaluate", "kr270", "--plan", plan, "--json", *common)
    assert evaluated["rho0"] == pytest.approx(designed["rho0"], rel=1e-9)
