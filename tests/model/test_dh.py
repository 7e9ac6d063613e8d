"""DH and modified-DH tables in, URDF out (issue 10, item 6).

Oracle: the DH product written out here with plain cos/sin (not pincal's), compared with Pinocchio's
forward kinematics of the URDF pincal writes, loaded through pincal.load_robot; the UR5 table
against example-robot-data's UR5 URDF; and a design → simulate → identify round trip that recovers
the errors put into the DH robot.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pinocchio as pin
import pytest
import yaml

import pincal
from pincal.cli import main
from pincal.model import shipped_dh_tables
from tests.conftest import ROOT

UR5_TABLE = shipped_dh_tables()["ur5_dh"]


# ------------------------------------------------------------------ the oracle
def rot_x(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_z(t):
    c, s = math.cos(t), math.sin(t)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def trans(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def rpy(r, p, y):
    """URDF rpy: R = Rz(y) Ry(p) Rx(r)."""
    cp, sp, cy, sy = math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Ry = np.array([[cp, 0, sp, 0], [0, 1, 0, 0], [-sp, 0, cp, 0], [0, 0, 0, 1.0]])
    Rz = np.array([[cy, -sy, 0, 0], [sy, cy, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    return Rz @ Ry @ rot_x(r)


def dh_product(rows, convention, q, base=None, tool=None):
    """base · Π ᵢ₋₁Tᵢ(q) · tool, rows in metres and radians."""
    T = np.eye(4) if base is None else base.copy()
    for row, qi in zip(rows, q, strict=True):
        theta = row["theta"] + (qi if row["type"] == "revolute" else 0.0)
        d = row["d"] + (qi if row["type"] == "prismatic" else 0.0)
        if convention == "standard":
            T = T @ rot_z(theta) @ trans(0, 0, d) @ trans(row["a"], 0, 0) @ rot_x(row["alpha"])
        else:
            T = T @ rot_x(row["alpha"]) @ trans(row["a"], 0, 0) @ rot_z(theta) @ trans(0, 0, d)
    return T if tool is None else T @ tool


def random_table(rng, convention, n=6):
    """Rows with random lengths and twists (some exactly 0 or ±90°), at least one prismatic joint."""
    rows = []
    for i in range(n):
        kind = "prismatic" if i in (1, n - 2) else "revolute"
        alpha = rng.choice([0.0, math.pi / 2, -math.pi / 2, rng.uniform(-math.pi, math.pi)])
        rows.append(
            {
                "name": f"j{i + 1}",
                "type": kind,
                "a": float(rng.choice([0.0, rng.uniform(-0.6, 0.6)])),
                "alpha": float(alpha),
                "d": float(rng.uniform(-0.4, 0.4)),
                "theta": float(rng.uniform(-math.pi, math.pi)),
                "limits": [-0.3, 0.5] if kind == "prismatic" else [-2.9, 2.9],
            }
        )
    content = {
        "name": f"random_{convention}",
        "convention": convention,
        "joints": rows,
        "base": {"xyz": rng.uniform(-1, 1, 3).tolist(), "rpy": rng.uniform(-3, 3, 3).tolist()},
        "tool": {
            "name": "tcp",
            "xyz": rng.uniform(-0.2, 0.2, 3).tolist(),
            "rpy": rng.uniform(-3, 3, 3).tolist(),
        },
        "markers": [[0.1, 0.05, 0.2], [-0.05, 0.1, 0.15]],
    }
    return content


def write_yaml(path, content):
    path.write_text(yaml.safe_dump(content, sort_keys=False))
    return path


# ------------------------------------------------------------- forward kinematics
@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_urdf_forward_kinematics_is_the_dh_product(tmp_path, convention, seed):
    rng = np.random.default_rng(seed)
    content = random_table(rng, convention)
    out = tmp_path / "robot.urdf"
    pincal.model.urdf_from_dh(write_yaml(tmp_path / "table.yaml", content), out)
    robot = pincal.load_robot(out, tip="tcp", markers=content["markers"])
    assert robot.joint_names == tuple(r["name"] for r in content["joints"])
    assert robot.nq == 6
    base = trans(*content["base"]["xyz"]) @ rpy(*content["base"]["rpy"])
    tool = trans(*content["tool"]["xyz"]) @ rpy(*content["tool"]["rpy"])
    data = robot.model.createData()
    qs = robot.random_configurations(40, rng)
    points = robot.points(qs)
    for q, measured in zip(qs, points, strict=True):
        expected = dh_product(content["joints"], convention, q, base, tool)
        pin.framesForwardKinematics(robot.model, data, q)
        got = data.oMf[robot.tip_frame]
        np.testing.assert_allclose(got.translation, expected[:3, 3], rtol=0, atol=1e-10)
        assert np.linalg.norm(pin.log3(got.rotation.T @ expected[:3, :3])) < 1e-10
        markers = expected[:3, :3] @ np.array(content["markers"]).T + expected[:3, 3:4]
        np.testing.assert_allclose(measured, markers.T, rtol=0, atol=1e-10)


def test_ur5_table_matches_the_ur5_urdf(tmp_path):
    """Universal Robots' published DH table and example-robot-data's UR5 URDF are one robot: the
    URDF's base_link is turned by 180° about z from DH frame 0."""
    content = yaml.safe_load(UR5_TABLE.read_text())
    content["base"] = {"rpy": [0, 0, 180]}  # degrees: the table's units
    out = tmp_path / "ur5_dh.urdf"
    pincal.model.urdf_from_dh(content, out)
    from_dh = pincal.load_robot(out)
    urdf = pincal.load_robot("ur5")
    assert from_dh.joint_names == urdf.joint_names
    qs = urdf.random_configurations(50, 3)
    np.testing.assert_allclose(from_dh.points(qs), urdf.points(qs), rtol=0, atol=1e-10)


def test_units_of_the_table(tmp_path):
    """The same table in mm and degrees gives the same URDF kinematics as in m and radians."""
    metric = {
        "convention": "modified",
        "joints": [
            {"a": 0.0, "alpha": 0.0, "d": 0.4, "theta": 0.0, "limits": [-2.5, 2.5]},
            {"a": 0.1, "alpha": -math.pi / 2, "d": 0.0, "theta": -math.pi / 2, "limits": [-1.5, 1.5]},
            {"type": "prismatic", "a": 0.5, "alpha": 0.3, "d": 0.05, "theta": 0.2, "limits": [0.0, 0.3]},
        ],
        "tool": {"xyz": [0.0, 0.0, 0.12], "rpy": [0.0, math.pi / 2, 0.0]},
        "markers": [[0.05, 0.0, 0.1]],
    }
    scaled = {
        "convention": "modified",
        "units": {"length": "mm", "angle": "deg"},
        "joints": [
            {"a": 0, "alpha": 0, "d": 400, "theta": 0, "limits": [math.degrees(-2.5), math.degrees(2.5)]},
            {"a": 100, "alpha": -90, "d": 0, "theta": -90, "limits": [math.degrees(-1.5), math.degrees(1.5)]},
            {"type": "prismatic", "a": 500, "alpha": math.degrees(0.3), "d": 50, "theta": math.degrees(0.2)}
            | {"limits": [0, 300]},
        ],
        "tool": {"xyz": [0, 0, 120], "rpy": [0, 90, 0]},
        "markers": [[50, 0, 100]],
    }
    a = pincal.load_robot(pincal.model.urdf_from_dh(metric, tmp_path / "a.urdf") and tmp_path / "a.urdf")
    b = pincal.load_robot(pincal.model.urdf_from_dh(scaled, tmp_path / "b.urdf") and tmp_path / "b.urdf")
    np.testing.assert_allclose(a.lower, b.lower, atol=1e-12)
    np.testing.assert_allclose(a.upper, b.upper, atol=1e-12)
    qs = a.random_configurations(20, 1)
    np.testing.assert_allclose(a.points(qs), b.points(qs), rtol=0, atol=1e-12)
    table = pincal.model.DHTable.from_dict(scaled)
    np.testing.assert_allclose(table.markers, [[0.05, 0.0, 0.1]])
    for q in qs:
        np.testing.assert_allclose(table.forward_kinematics(q), dh_product_of(metric, q), atol=1e-12)


def dh_product_of(content, q):
    rows = [{"type": "revolute", **r} for r in content["joints"]]
    tool = trans(*content["tool"]["xyz"]) @ rpy(*content["tool"]["rpy"])
    return dh_product(rows, content["convention"], q, tool=tool)


# ------------------------------------------------------------------ round trip
def test_dh_robot_round_trip_recovers_known_errors(tmp_path):
    """design → simulate → identify on a DH robot with a prismatic joint: the errors put in come back."""
    content = {
        "name": "rrprrr",
        "convention": "modified",
        "joints": [
            {"a": 0.0, "alpha": 0.0, "d": 0.5, "theta": 0.0, "limits": [-2.8, 2.8]},
            {"a": 0.15, "alpha": -math.pi / 2, "d": 0.0, "theta": -math.pi / 2, "limits": [-1.8, 1.2]},
            {"type": "prismatic", "a": 0.6, "alpha": 0.0, "d": 0.1, "theta": 0.0, "limits": [0.0, 0.4]},
            {"a": 0.12, "alpha": -math.pi / 2, "d": 0.6, "theta": 0.0, "limits": [-3.0, 3.0]},
            {"a": 0.0, "alpha": math.pi / 2, "d": 0.0, "theta": 0.0, "limits": [-2.0, 2.0]},
            {"a": 0.0, "alpha": -math.pi / 2, "d": 0.1, "theta": 0.0, "limits": [-3.0, 3.0]},
        ],
        "markers": [[0.1, 0.05, 0.2]],
    }
    out = tmp_path / "rrprrr.urdf"
    pincal.model.urdf_from_dh(content, out)
    robot = pincal.load_robot(out, markers=content["markers"])
    params = robot.parameters("full,offsets").identifiable().identifiable
    assert any(p.name == "joint3.offset" and p.unit == "m" for p in params)  # the prismatic joint's zero
    q0 = np.array([0.3, -0.6, 0.2, 0.4, 0.8, -0.2])
    sigma = 3e-5
    designed = pincal.design(
        params, 12, q0, sigma=sigma, search=pincal.Search(starts=2, seed=0, workers=1, polish=False)
    )
    truth = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=5)
    data = pincal.simulate_measurements(truth, designed.plan.repeat(3), sigma, seed=6)
    result = pincal.identify(params, data, sigma=sigma)
    assert result.status == "converged", result.message
    z = (result.values - truth.values) / result.std
    assert np.abs(z).max() < 5, dict(zip(params.names, z))
    assert np.sqrt(np.mean(z**2)) < 2
    # At the test pose, the calibrated robot is as good as ρ0 of the plan measured three times
    # (repeating divides ρ0² by 3); before calibration it was far off.
    rho0 = designed.rho0 / math.sqrt(3)
    assert np.linalg.norm(result.robot.points(q0) - truth.robot.points(q0)) < 4 * rho0
    assert np.linalg.norm(robot.points(q0) - truth.robot.points(q0)) > 30 * rho0


# ------------------------------------------------------------------------ CLI


def test_cli_writes_the_urdf_and_says_how_to_use_it(tmp_path, cli):
    out = tmp_path / "ur5_dh.urdf"
    code, text, err = cli.run("urdf-from-dh", UR5_TABLE, "--out", out)
    assert code == 0 and err == ""
    assert f"wrote {out}" in text and "--marker 0.05,0,0.1" in text
    robot = pincal.load_robot(out, markers=[(0.05, 0, 0.1)])
    assert robot.nq == 6 and robot.tip == "tool0"
    assert not list(tmp_path.glob(".*.tmp"))  # atomic write leaves nothing behind
    code, text, _ = cli.run("urdf-from-dh", UR5_TABLE, "--json")
    data = json.loads(text)
    assert (
        data["self_check"] < 1e-12 and data["urdf"].startswith("<?xml") and data["convention"] == "standard"
    )
    code, text, _ = cli.run("urdf-from-dh", UR5_TABLE)
    assert code == 0 and text == out.read_text()  # no --out: the URDF on stdout


BAD_TABLES = [
    ("joints: []", "'joints' must be a list"),
    ("convention: craig\njoints: [{a: 0, alpha: 0, d: 0, theta: 0}]", "convention 'craig' is not one of"),
    ("joints: [{a: 0, alpha: 0, d: 0, theta: 0}, {a: 0, alpha: 0, d: 0}]", "row 2 (joint2): missing theta"),
    ("joints: [{a: 0, alpha: 0, d: 0, theta: 0, lenght: 1}]", "row 1 (joint1): unknown key 'lenght'"),
    ("joints: [{name: j1, type: spherical, a: 0, alpha: 0, d: 0, theta: 0}]", "type 'spherical'"),
    ("joints: [{name: s, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}]", "row 1 (s): a prismatic"),
    ("joints: [{a: x, alpha: 0, d: 0, theta: 0}]", "row 1 (joint1): a must be a finite number, got 'x'"),
    ("joints: [{a: .nan, alpha: 0, d: 0, theta: 0}]", "joints[0].a is nan, not a finite number"),
    ("joints: [{a: 0, alpha: 0, d: 0, theta: 0, limits: [1, -1]}]", "lower < upper"),
    ("joints: [{a: 0, alpha: 0, d: 0, theta: 0, limits: [1]}]", "limits: expected a list of 2 numbers"),
    (
        "units: {length: inch}\njoints: [{a: 0, alpha: 0, d: 0, theta: 0}]",
        "length 'inch' is not one of m, mm",
    ),
    (
        "joints: [{name: a, a: 0, alpha: 0, d: 0, theta: 0}, {name: a, a: 0, alpha: 0, d: 0, theta: 0}]",
        "used more",
    ),
    ("tool: {name: link1}\njoints: [{a: 0, alpha: 0, d: 0, theta: 0}]", "taken by a generated frame"),
    ("markers: [[0, 0]]\njoints: [{a: 0, alpha: 0, d: 0, theta: 0}]", "markers[0]: expected a list of 3"),
    ("joint: []", "unknown key 'joint'"),
    ("joints: [{a: 0, alpha: 0\n", ", line 2: not valid YAML"),
    ("- just a list", "expected a mapping"),
]


@pytest.mark.parametrize("text, match", BAD_TABLES)
def test_bad_tables_one_line_exit_2(tmp_path, cli, text, match):
    table = tmp_path / "bad.yaml"
    table.write_text(text)
    out = tmp_path / "robot.urdf"
    code, _, err = cli.run("urdf-from-dh", table, "--out", out)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("pincal: error: "), err
    assert match in lines[0] and "Traceback" not in err
    assert not out.exists()
    with pytest.raises(pincal.errors.BadDHTable, match="DH table"):
        pincal.model.urdf_from_dh(table)


def test_cli_never_writes_over_the_table(tmp_path, cli):
    table = tmp_path / "t.yaml"
    table.write_text(UR5_TABLE.read_text())
    code, _, err = cli.run("urdf-from-dh", table, "--out", table)
    assert code == 2 and "overwrite" in err and table.read_text() == UR5_TABLE.read_text()
    code, _, err = cli.run("urdf-from-dh", tmp_path / "missing.yaml")
    assert code == 2 and "does not exist" in err


def test_help_shows_the_table_layout(capsys):
    with pytest.raises(SystemExit):
        main(["urdf-from-dh", "--help"])
    out = capsys.readouterr().out
    assert "examples:" in out and "convention: standard" in out and "prismatic" in out
    # The layout in --help is a table pincal reads.
    layout = out.split("TABLE.yaml (lengths")[1].split("\n\n")[0].split("\n", 1)[1]
    table = pincal.model.DHTable.from_dict(yaml.safe_load(layout))
    assert (
        table.nq == 3 and table.joints[2].type == "prismatic" and table.joints[2].upper == pytest.approx(0.3)
    )


def test_readme_table_is_the_help_table(capsys):
    """The README's example table reads, and is the one --help shows."""
    readme = (ROOT / "README.md").read_text()
    block = next(b for b in readme.split("```yaml\n")[1:] if "convention:" in b).split("```")[0]
    from_readme = pincal.model.DHTable.from_dict(yaml.safe_load(block))
    with pytest.raises(SystemExit):
        main(["urdf-from-dh", "--help"])
    layout = capsys.readouterr().out.split("TABLE.yaml (lengths")[1].split("\n\n")[0].split("\n", 1)[1]
    from_help = pincal.model.DHTable.from_dict(yaml.safe_load(layout))
    q = [0.3, -0.4, 0.1]
    np.testing.assert_allclose(from_readme.forward_kinematics(q), from_help.forward_kinematics(q), atol=1e-15)
    assert from_readme.joints == from_help.joints


def test_unwritable_out_is_one_line(tmp_path, cli):
    for out, reason in ((tmp_path / "missing" / "r.urdf", "its folder does not exist"), (tmp_path, "")):
        code, _, err = cli.run("urdf-from-dh", UR5_TABLE, "--out", out)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("pincal: error: cannot write"), err
        assert reason in lines[0]
    assert list(tmp_path.iterdir()) == []  # no temporary file left behind


def test_dh_robot_round_trip_on_the_command_line(tmp_path, cli):
    """urdf-from-dh → design --base → measure-sim in a tracker's frame → identify --base: converged,
    residuals at the noise, the tracker placement found, a calibrated URDF written."""
    table = tmp_path / "arm.yaml"
    table.write_text(
        "convention: modified\nunits: {length: mm, angle: deg}\njoints:\n"
        "  - {a: 0, alpha: 0, d: 500, theta: 0, limits: [-160, 160]}\n"
        "  - {a: 150, alpha: -90, d: 0, theta: -90, limits: [-100, 70]}\n"
        "  - {type: prismatic, a: 600, alpha: 0, d: 100, theta: 0, limits: [0, 400]}\n"
        "  - {a: 120, alpha: -90, d: 600, theta: 0, limits: [-170, 170]}\n"
        "  - {a: 0, alpha: 90, d: 0, theta: 0, limits: [-115, 115]}\n"
        "  - {a: 0, alpha: -90, d: 100, theta: 0, limits: [-170, 170]}\n"
    )
    urdf, plan, meas, cal = (tmp_path / n for n in ("arm.urdf", "plan.csv", "meas.csv", "cal.urdf"))
    marker = ["--marker", "0.1,0.05,0.2"]
    assert cli.run("urdf-from-dh", table, "--out", urdf)[0] == 0
    design = [urdf, "-m", "15", "--test-pose=0.3,-0.6,0.2,0.4,0.8,-0.2", "--sigma", "3e-5", "--base"]
    code, _, err = cli.run(
        "design", *design, *marker, "--starts", "2", "--workers", "1", "--no-polish", "--out", plan
    )
    assert code == 0, err
    tracker = [2.5, -1.0, 0.2, 0.05, -0.1, 1.2]
    code, _, err = cli.run(
        "measure-sim",
        urdf,
        "--plan",
        plan,
        "--error-std",
        "1e-3,1e-3",
        "--sigma",
        "3e-5",
        f"--base-pose={','.join(map(str, tracker))}",
        "--out",
        meas,
        *marker,
    )
    assert code == 0, err
    code, out, err = cli.run("identify", urdf, "--data", meas, "--base", "--out", cal, "--json", *marker)
    assert code == 0, err
    result = json.loads(out)
    assert result["status"] == "converged"
    # issue 10: with --base, "before" is the residual after the initial rigid fit (mm), not at
    # a base at the identity (metres)
    assert result["residual_rms_before"] > 30 * result["residual_rms_after"]
    assert result["residual_rms_after"] < 2 * math.sqrt(3) * 3e-5
    # The base found is the tracker placement, up to the joint-1 errors it absorbs (~1 mm, 1 mrad).
    np.testing.assert_allclose(result["base"]["xyz"], tracker[:3], atol=5e-3)
    np.testing.assert_allclose(result["base"]["rpy"], tracker[3:], atol=5e-3)
    assert pincal.load_robot(cal, markers=[(0.1, 0.05, 0.2)]).nq == 6


def test_dh_table_constructor_validates_and_is_read_only():
    joint = pincal.model.dh.DHJoint("j", "revolute", 0.5, 0.0, 0.0, 0.0, -1.0, 1.0)
    table = pincal.model.DHTable("arm", "standard", (joint,), np.eye(4), "tool0", np.eye(4), np.zeros((0, 3)))
    with pytest.raises(ValueError):
        table.base[0, 3] = 1.0  # read-only: a table never changes
    with pytest.raises(pincal.errors.BadDHTable, match="convention 'craig'"):
        pincal.model.DHTable("arm", "craig", (joint,), np.eye(4), "tool0", np.eye(4), np.zeros((0, 3)))
    with pytest.raises(pincal.errors.BadDHTable, match=r"\(4, 4\) placement"):
        pincal.model.DHTable("arm", "standard", (joint,), np.eye(3), "tool0", np.eye(4), np.zeros((0, 3)))
    np.testing.assert_allclose(table.forward_kinematics([0.0])[:3, 3], [0.5, 0, 0], atol=1e-15)


def test_a_shipped_table_by_name_from_any_folder(tmp_path, cli, monkeypatch):
    """`pincal urdf-from-dh ur5_dh` works wherever it runs (the table ships in the package, beside
    the robots), gives the URDF of the table's file, and an unknown name lists the shipped ones."""
    assert set(shipped_dh_tables()) == {"ur5_dh"} and UR5_TABLE.parent.name == "dh"
    assert UR5_TABLE.parent.parent == pincal.model.loading.ROBOTS_DIR
    monkeypatch.chdir(tmp_path)  # no table here
    for name in ("ur5_dh", "ur5_dh.yaml"):
        code, out, err = cli.run("urdf-from-dh", name, "--out", f"{name}.urdf")
        assert code == 0 and "wrote" in out, err
        assert (tmp_path / f"{name}.urdf").read_text() == pincal.model.urdf_from_dh(UR5_TABLE)
    assert (
        pincal.model.DHTable.from_yaml("ur5_dh").to_urdf()
        == pincal.model.DHTable.from_yaml(UR5_TABLE).to_urdf()
    )
    cli.fails("urdf-from-dh", "ur6_dh", match="nor is it a table pincal ships (ur5_dh: give the name alone)")
    cli.fails("urdf-from-dh", "missing/ur5_dh.yaml", match="does not exist")
    listed = cli.json("robots")["dh_tables"]
    assert listed == {"ur5_dh": str(UR5_TABLE)}
    code, out, _ = cli.run("urdf-from-dh", "--help")
    words = " ".join(out.split())  # argparse wraps the option's help
    assert "pincal urdf-from-dh ur5_dh --out ur5_dh.urdf" in words and "pincal ships: ur5_dh" in words
