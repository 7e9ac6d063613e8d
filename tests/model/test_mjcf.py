"""MJCF in and out: MuJoCo XML robots read through Pinocchio's parser as MuJoCo reads them, and
calibrations written back as MJCF that MuJoCo's own forward kinematics reproduces to 1e-9 m."""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from lxml import etree

import pincal
from pincal.cli import main
from pincal.errors import BadArgument, OverwriteRefused, PincalWarning, UrdfError
from pincal.export.mjcf import export_mjcf
from tests.conftest import ROOT

DATA = ROOT / "tests" / "data" / "mjcf"
TWO_LINK = DATA / "two_link.xml"
SIX_AXIS = DATA / "six_axis.xml"
MARKERS = [(0.05, 0.02, 0.1), (-0.03, 0.04, 0.02)]

try:
    import mujoco
except ImportError:  # an optional test dependency (pincal[test], Python 3.11+)
    mujoco = None
needs_mujoco = pytest.mark.skipif(
    mujoco is None,
    reason="the mujoco package is not installed (pip install mujoco): MuJoCo's own checks skipped",
)


def mujoco_model(path: Path):
    """MuJoCo's model of ``path`` (its mesh geoms left out: kinematics does not need them)."""
    tree = etree.parse(str(path))
    for element in [*tree.iter("mesh"), *(g for g in tree.iter("geom") if g.get("mesh"))]:
        element.getparent().remove(element)
    return mujoco.MjModel.from_xml_string(etree.tostring(tree, encoding="unicode"))


def mujoco_poses(model, joints, q):
    """{body or site name: (rotation, position)} in MuJoCo's world at joint values ``q`` (qpos)."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    for name, value in zip(joints, q, strict=True):
        data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)]] = value
    mujoco.mj_kinematics(model, data)
    out = {}
    for b in range(1, model.nbody):
        out[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)] = (
            data.xmat[b].reshape(3, 3),
            data.xpos[b],
        )
    for s in range(model.nsite):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, s)
        out[name] = (data.site_xmat[s].reshape(3, 3).copy(), data.site_xpos[s].copy())
    return out


def quiet_load(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PincalWarning)
        return pincal.load_robot(*args, **kwargs)


# --------------------------------------------------------------------------- reading


def test_two_link_closed_form():
    """The hand-made arm's tool is where the closed form puts it: ref="30" (degrees) honoured, the
    base body's placement kept, the limits converted from degrees."""
    robot = pincal.load_robot(TWO_LINK)
    assert robot.joint_names == ("j1", "j2") and robot.tip == "tool"
    assert np.allclose(robot.upper, np.radians([150, 150])) and np.allclose(robot.lower, -robot.upper)
    q = robot.random_configurations(50, 0)
    a, b = q[:, 0], q[:, 1] - np.radians(30)
    expected = np.stack(
        [0.1 + 0.4 * np.cos(a) + 0.3 * np.cos(a + b), 0.4 * np.sin(a) + 0.3 * np.sin(a + b), 0.2 + 0 * a], 1
    )
    assert np.abs(robot.points(q)[:, 0] - expected).max() < 1e-12


def test_tips_bodies_and_sites():
    """A site, a body without a joint and a body with one are tips; sites are markers' frames."""
    assert pincal.load_robot(SIX_AXIS).tip == "tcp"  # the tool-named site, fingers set aside
    for tip in ("tcp", "flange", "link6", "link4"):
        robot = pincal.load_robot(SIX_AXIS, tip=tip, markers=MARKERS)
        assert robot.tip == tip and robot.nq == (6 if tip != "link4" else 4)
    assert pincal.load_robot(SIX_AXIS, tip="finger_left").nq == 7  # the slide on the chain


PROBE = """<mujoco>{compiler}
  <default><geom size="0.02" mass="1"/><joint range="-120 120"/>{defaults}</default>
  <worldbody>
    <body name="base" {base}><geom/>
      <body name="l1" pos="0 0 0.5" {l1}>
        <geom/><joint name="j1" axis="0 0 1"/>
        <body name="l2" pos="1 0 0" {l2}>
          <geom/><joint name="j2" {j2}/>
          <site name="s" pos="0.5 0.1 0.2" {site}/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""
CASES = {
    "quat (unnormalised)": dict(l2='quat="1 0.2 0 1"'),
    "euler, degrees": dict(l2='euler="10 20 30"'),
    "euler, radians": dict(
        compiler='<compiler angle="radian"/>', l2='euler="0.1 0.2 0.3"', j2='range="-2 2"'
    ),
    "eulerseq XYZ (fixed axes)": dict(compiler='<compiler eulerseq="XYZ"/>', l2='euler="10 20 30"'),
    "eulerseq zyx": dict(compiler='<compiler eulerseq="zyx"/>', l2='euler="10 20 30"'),
    "axisangle (unnormalised axis)": dict(l2='axisangle="1 1 0 30"'),
    "xyaxes": dict(l2='xyaxes="0 1 0 -1 0 1"'),
    "zaxis": dict(l2='zaxis="0 1 1"', site='zaxis="1 0 1"'),
    "hinge ref, degrees": dict(j2='axis="0 1 0" ref="10"'),
    "joint pos": dict(j2='axis="0.3 0.5 0.2" pos="0.1 0 0.2"'),
    "slide ref and range, degrees": dict(j2='type="slide" axis="1 0 0" range="-0.1 0.2" ref="0.05"'),
    "top-level body placed": dict(base='pos="0.1 0.2 0.3" quat="1 0 0 1"'),
    "childclass": dict(
        defaults='<default class="a"><joint axis="1 0 0" ref="20"/></default>', l1='childclass="a"'
    ),
}


@needs_mujoco
@pytest.mark.parametrize("case", list(CASES))
def test_conventions_as_mujoco(tmp_path, case):
    """Every body and site frame Pinocchio's model gives (through pincal's reading) is MuJoCo's."""
    fields = dict(compiler="", defaults="", base="", l1="", l2="", j2='axis="0 1 0"', site="")
    fields.update(CASES[case])
    path = tmp_path / "probe.xml"
    path.write_text(PROBE.format(**fields))
    model = pincal.model.mjcf.read_mjcf(path)
    reference = mujoco_model(path)
    data = model.createData()
    names = [model.names[j] for j in range(1, model.njoints)]
    for q in np.random.default_rng(1).uniform(-1, 1, (20, model.nq)):
        pin.framesForwardKinematics(model, data, q)
        poses = mujoco_poses(reference, names, q)
        for name in ("base", "l1", "l2", "s"):
            R, p = poses[name]
            placed = data.oMf[model.getFrameId(name)]
            assert np.abs(placed.rotation - R).max() < 1e-12 and np.abs(placed.translation - p).max() < 1e-12
    j2 = model.getJointId("j2")
    expected = (-0.1, 0.2) if "slide" in case else (-2, 2) if "radians" in case else np.radians((-120, 120))
    assert np.allclose([model.lowerPositionLimit[j2 - 1], model.upperPositionLimit[j2 - 1]], expected)


def test_joints_without_limits_are_named(tmp_path):
    text = PROBE.format(
        compiler="", defaults="", base="", l1="", l2="", j2='axis="0 1 0" limited="false"', site=""
    )
    path = tmp_path / "open.xml"
    path.write_text(text)
    with pytest.warns(PincalWarning, match=r"without limits.*hinge\(s\) j2 move on one turn"):
        robot = pincal.load_robot(path, tip="s")
    assert np.allclose([robot.lower[1], robot.upper[1]], [-np.pi, np.pi])
    robot = pincal.load_robot(path, tip="s", joint_ranges={"j2": (-0.5, 0.5)})  # given: no warning
    assert robot.upper[1] == 0.5
    slide = PROBE.format(
        compiler="", defaults="", base="", l1="", l2="", j2='type="slide" range="0 0"', site=""
    )
    path.write_text(slide.replace('<joint range="-120 120"/>', "<joint/>").replace('range="0 0"', ""))
    with pytest.warns(PincalWarning, match=r"slide\(s\) j2 need a range"):
        with pytest.raises(pincal.errors.UnsupportedJoint, match="joint-range"):
            pincal.load_robot(path, tip="s")


def test_frames_and_bad_files_refused(tmp_path):
    path = tmp_path / "frame.xml"
    path.write_text('<mujoco><worldbody><frame pos="1 0 0"><body name="b"/></frame></worldbody></mujoco>')
    with pytest.raises(UrdfError, match="<frame> element"):
        pincal.load_robot(path)
    path.write_text("<mujoco><worldbody><body name='b'></worldbody></mujoco>")
    with pytest.raises(UrdfError, match="not well-formed"):
        pincal.load_robot(path)
    urdf = tmp_path / "robot.xml"  # a URDF saved as .xml is still a URDF
    urdf.write_text((Path(pincal.model.loading.ROBOTS_DIR) / "planar_2r.urdf").read_text())
    assert pincal.load_robot(urdf).nq == 2


# ------------------------------------------------------------------------- writing


def perturbed(path, tip=None, seed=1):
    robot = quiet_load(path, tip=tip, markers=MARKERS)
    params = robot.parameters("full,offsets,markers,base")
    return pincal.random_errors(params, seed=seed, error_std={"length": 2e-3, "angle": 5e-3}).robot


def worst_mujoco_error(path: Path, robot, n=100) -> float:
    """Largest distance [m] between MuJoCo's marker sites of ``path`` and ``robot.points``."""
    model = mujoco_model(path)
    qs = robot.random_configurations(n, np.random.default_rng(2))
    worst = 0.0
    for q, points in zip(qs, robot.points(qs), strict=True):
        poses = mujoco_poses(model, robot.joint_names, q)
        for k, p in enumerate(points):
            worst = max(worst, float(np.linalg.norm(poses[f"pincal_marker{k}"][1] - p)))
    return worst


@needs_mujoco
@pytest.mark.parametrize(
    ("source", "tip", "offsets"),
    [
        (TWO_LINK, None, "ref"),
        (SIX_AXIS, None, "ref"),  # a site tip
        (SIX_AXIS, "flange", "fold"),  # a body without a joint
        (SIX_AXIS, "link6", "ref"),  # a body with a joint: its correction folded into the markers
    ],
)
def test_export_is_mujocos_kinematics(tmp_path, source, tip, offsets):
    """MuJoCo's forward kinematics of the written file (qpos = the readings) puts the marker sites
    where the calibrated model puts the markers, to 1e-9 m at 100 configurations."""
    truth = perturbed(source, tip)
    out = export_mjcf(truth, tmp_path / "cal.xml", offsets=offsets)
    assert worst_mujoco_error(out, truth) < 1e-9
    side = json.loads((tmp_path / "cal.calibration.json").read_text())
    assert side["tip"] == truth.tip and side["urdf"] == "cal.xml"


def test_export_changes_only_geometry(tmp_path):
    """Only pos/quat of the chain's bodies and tip, the joints' ref and the marker sites change:
    actuators, defaults, the gripper, keyframes, sensors, comments are kept."""
    truth = perturbed(SIX_AXIS)
    out = export_mjcf(truth, tmp_path / "cal.xml")
    before = etree.parse(str(SIX_AXIS)).getroot()
    after = etree.parse(str(out)).getroot()
    kept = ("default", "contact", "actuator", "sensor", "keyframe", "option", "compiler")
    for tag in kept:
        assert [etree.tostring(e) for e in before.iter(tag)] == [
            etree.tostring(e) for e in after.iter(tag)
        ], tag
    comments = [c.text for c in before.iter(etree.Comment)]
    assert all(c in [d.text for d in after.iter(etree.Comment)] for c in comments)
    changed = set()
    for old, new in zip(before.find("worldbody").iter(), after.find("worldbody").iter(), strict=False):
        if old.tag is etree.Comment:
            continue
        assert old.tag == new.tag and old.get("name") == new.get("name")
        diff = {k for k in set(old.attrib) | set(new.attrib) if old.get(k) != new.get(k)}
        assert diff <= {"pos", "quat", "euler", "axisangle", "xyaxes", "ref"}, (old.get("name"), diff)
        if diff:
            changed.add(old.get("name"))
    assert changed <= {"pedestal", *(f"link{i}" for i in range(1, 7)), *truth.joint_names, "tcp"}
    sites = [s.get("name") for s in after.iter("site")]
    assert sites == ["tcp", "pincal_marker0", "pincal_marker1"]
    ref = float(after.find(".//joint[@name='joint2']").get("ref"))  # degrees, the file's unit
    assert ref == pytest.approx(-90 - np.degrees(truth.joint_offsets[1]), abs=1e-9)


def test_export_round_trips_through_pincal(tmp_path):
    """The written file, loaded by pincal with its sidecar's markers, is the calibrated robot."""
    truth = perturbed(SIX_AXIS)
    out = export_mjcf(truth, tmp_path / "cal.xml")
    side = json.loads((tmp_path / "cal.calibration.json").read_text())
    again = quiet_load(out, tip=side["tip"], markers=side["markers"])
    qs = truth.random_configurations(30, 4)
    assert np.abs(again.points(qs) - truth.points(qs)).max() < 1e-9
    with pytest.raises(OverwriteRefused):
        export_mjcf(truth, SIX_AXIS)


def test_identify_recovers_the_truth(tmp_path):
    """A simulated campaign on the MJCF arm: held-out errors within 3x the noise, and the written
    calibration is MuJoCo's (when mujoco is installed)."""
    nominal = quiet_load(SIX_AXIS, markers=MARKERS)
    params = nominal.parameters("full,offsets,markers")
    truth = pincal.random_errors(params, seed=7, error_std={"length": 1e-3, "angle": 2e-3})
    sigma = 1e-5
    rng = np.random.default_rng(3)
    plan = nominal.random_configurations(60, rng)
    data = pincal.simulate_measurements(truth, plan, sigma, seed=rng)
    result = pincal.identify(params, data, sigma=sigma)
    assert result.success
    held = nominal.random_configurations(40, rng)
    other = pincal.simulate_measurements(truth, held, sigma, seed=rng)
    validation = pincal.validate(result, other)
    rms = float(np.sqrt(np.mean(validation.after**2)))
    assert rms < 3 * sigma * np.sqrt(3), rms  # a point's distance: three coordinates of noise
    out = export_mjcf(result, tmp_path / "cal.xml")
    if mujoco is not None:
        assert worst_mujoco_error(out, result.robot) < 1e-9


@needs_mujoco
def test_calibrated_urdf_as_mjcf(tmp_path):
    """A URDF robot written as MJCF: every link a body (fixed ones too), offsets as ref, base and
    markers kept; MuJoCo's kinematics is the calibrated model's."""
    truth = perturbed("kr270")
    out = export_mjcf(truth, tmp_path / "kr270_cal.xml")
    model = mujoco_model(out)
    bodies = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)}
    assert {"base_link", "link_6", "tool0"} <= bodies  # tool0 hangs on a fixed joint
    assert worst_mujoco_error(out, truth) < 1e-9
    refs = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j): model.qpos0[j] for j in range(model.njnt)}
    assert np.allclose([refs[n] for n in truth.joint_names], -truth.joint_offsets)


def test_cli_identify_and_export(tmp_path, capsys):
    robot = quiet_load(TWO_LINK)
    truth = pincal.random_errors(
        robot.parameters("full,offsets"), seed=2, error_std={"length": 1e-3, "angle": 2e-3}
    )
    plan = robot.random_configurations(15, 0)
    pincal.simulate_measurements(truth, plan, 1e-5, seed=1).to_csv(tmp_path / "meas.csv")
    cal = tmp_path / "cal.xml"
    assert main(["identify", str(TWO_LINK), "--data", str(tmp_path / "meas.csv"), "--out", str(cal)]) == 0
    assert "calibrated MJCF written" in capsys.readouterr().out
    assert etree.parse(str(cal)).getroot().tag == "mujoco"
    urdf = tmp_path / "cal.urdf"
    assert main(["identify", str(TWO_LINK), "--data", str(tmp_path / "meas.csv"), "--out", str(urdf)]) == 2
    assert "give an output ending in .xml" in capsys.readouterr().err
    # a calibrated URDF to MJCF
    kr = quiet_load("kr270", markers=MARKERS[:1])
    kr_truth = pincal.random_errors(kr.parameters("full,offsets"), seed=2)
    pincal.simulate_measurements(kr_truth, kr.random_configurations(40, 0), 1e-5, seed=1).to_csv(
        tmp_path / "kr.csv"
    )
    args = ["identify", "kr270", "--data", str(tmp_path / "kr.csv"), "--marker", "0.05,0.02,0.1"]
    assert main([*args, "--out", str(urdf)]) == 0
    capsys.readouterr()
    assert main(["export", str(urdf), "--format", "mjcf", "--out", str(tmp_path / "cal.xml")]) == 2
    assert "sidecar" in capsys.readouterr().err  # cal.calibration.json is the calibration's own
    mj = tmp_path / "kr_mujoco.xml"
    assert main(["export", str(urdf), "--format", "mjcf", "--out", str(mj)]) == 0
    assert "checked" in capsys.readouterr().out
    side = json.loads((tmp_path / "kr_mujoco.calibration.json").read_text())
    again = quiet_load(mj, tip=side["tip"], markers=side["markers"])
    deployed = quiet_load(urdf, tip=side["tip"], markers=side["markers"])
    qs = deployed.random_configurations(20, 1)
    assert np.abs(again.points(qs) - deployed.points(qs)).max() < 1e-9


def test_writes_mjcf_choice():
    from pincal.export.mjcf import writes_mjcf

    robot = quiet_load(TWO_LINK)
    assert writes_mjcf(robot, "cal.xml") and writes_mjcf(robot, "cal")
    assert writes_mjcf(quiet_load("planar_2r"), "cal.xml") and not writes_mjcf(
        quiet_load("planar_2r"), "c.urdf"
    )
    with pytest.raises(BadArgument, match="MuJoCo"):
        writes_mjcf(robot, "cal.urdf")


MENAGERIE = os.environ.get("PINCAL_MENAGERIE")


@needs_mujoco
@pytest.mark.skipif(not MENAGERIE, reason="PINCAL_MENAGERIE (a mujoco_menagerie checkout) not set")
@pytest.mark.parametrize("arm", ["universal_robots_ur5e/ur5e.xml", "franka_emika_panda/panda.xml"])
def test_menagerie_arm(tmp_path, arm):
    """A published arm of MuJoCo Menagerie: read as MuJoCo reads it, written back as MuJoCo's."""
    path = Path(str(MENAGERIE)) / arm
    truth = perturbed(path)
    out = export_mjcf(truth, tmp_path / "cal.xml")
    assert worst_mujoco_error(out, truth) < 1e-9


def test_geometry_for_the_view_and_collisions(tmp_path):
    """The 3-D view and the self-collision constraint get Pinocchio's MJCF geometry; a geom whose
    mesh file cannot be found is left out and named."""
    from pincal.model.geometry import urdf_geometry

    robot = quiet_load(SIX_AXIS)
    visual = urdf_geometry(robot, pin.GeometryType.VISUAL)
    collision = urdf_geometry(robot, pin.GeometryType.COLLISION)
    assert visual.model.ngeoms >= 8 and not visual.missing
    assert {o.name for o in collision.model.geometryObjects} == {"finger_leftGeom_0", "finger_rightGeom_0"}
    text = SIX_AXIS.read_text().replace(
        "<worldbody>", '<asset><mesh name="shell" file="missing_shell.stl"/></asset>\n  <worldbody>'
    )
    path = tmp_path / "meshes.xml"
    path.write_text(
        text.replace('<geom type="cylinder" size="0.09 0.08"/>', '<geom type="mesh" mesh="shell"/>')
    )
    loaded = urdf_geometry(quiet_load(path), pin.GeometryType.VISUAL)
    assert loaded.missing == ("missing_shell.stl",) and loaded.model.ngeoms == visual.model.ngeoms - 1


@needs_mujoco
def test_export_with_a_root(tmp_path):
    """With --root, points are in the root's frame: the file places the robot so that MuJoCo's world
    is the instrument's, and the sidecar's base puts pincal's reloaded chain there too."""
    robot = quiet_load(SIX_AXIS, root="link1", markers=MARKERS)
    params = robot.parameters("full,offsets,markers,base")
    truth = pincal.random_errors(params, seed=1, error_std={"length": 2e-3, "angle": 5e-3}).robot
    out = export_mjcf(truth, tmp_path / "cal.xml")
    assert worst_mujoco_error(out, truth, n=30) < 1e-9
    side = json.loads((tmp_path / "cal.calibration.json").read_text())
    again = quiet_load(out, root="link1", tip=side["tip"], markers=side["markers"])
    again = again.replace(base=pin.SE3(np.array(side["base"]["matrix"])))
    qs = truth.random_configurations(20, 0)
    assert np.abs(again.points(qs) - truth.points(qs)).max() < 1e-9
