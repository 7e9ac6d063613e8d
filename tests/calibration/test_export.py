"""Calibrated URDF export (pincal.export): the exported URDF, loaded by Pinocchio, reproduces the
calibrated model; everything but the corrected origins is preserved; inputs are never overwritten."""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
import pytest
from lxml import etree

import pincal
from pincal import export_urdf, identify, random_errors, simulate_measurements
from pincal.errors import OverwriteRefused, UrdfError

MARKERS = [(0.1, 0.05, 0.2), (-0.05, 0.1, 0.15)]


def _round_trip_error(robot, path) -> float:
    exported = pincal.load_robot(path, tip=robot.tip, markers=robot.markers).replace(base=robot.base)
    q = robot.random_configurations(50, np.random.default_rng(11))
    return float(np.abs(exported.points(q) - robot.points(q)).max())


def test_identified_kr270_round_trips_to_1e_9(tmp_path):
    robot = pincal.load_robot("kr270", markers=MARKERS)
    params = robot.parameters("full,offsets,markers").identifiable().identifiable
    truth = random_errors(params, seed=1)
    data = simulate_measurements(truth.robot, robot.random_configurations(30, 2), 3e-5, seed=3)
    result = identify(params, data)
    assert result.success
    out = export_urdf(result, tmp_path / "kr270_calibrated.urdf")
    assert out == tmp_path / "kr270_calibrated.urdf"
    assert _round_trip_error(result.robot, out) <= 1e-9
    # no temporary file left; the sidecar (issue 10) next to the URDF
    assert sorted(os.listdir(tmp_path)) == ["kr270_calibrated.calibration.json", "kr270_calibrated.urdf"]
    text = out.read_text()
    assert "Calibrated by pincal" in text and "joint_a2.offset" in text and "+/-" in text
    assert f"{result.robot.markers[1][0]:.9g}" in text  # markers are reported, not lost


@pytest.mark.parametrize("name, tip", [("kr270", None), ("ur10", None), ("panda", "panda_hand")])
def test_every_parameter_of_the_chain_round_trips(tmp_path, name, tip):
    """All placement errors (identifiable or not), offsets folded in, large enough to matter."""
    robot = pincal.load_robot(name, tip=tip, markers=MARKERS[:1])
    truth = random_errors(
        robot.parameters("full,offsets,markers"), error_std={"length": 1e-2, "angle": 5e-2}, seed=2
    )
    out = export_urdf(truth.robot, tmp_path / f"{name}.urdf")
    assert _round_trip_error(truth.robot, out) <= 1e-9
    assert _round_trip_error(robot, out) > 1e-3  # the file did change


def _items(root):
    """Document-order (tag, attributes, text) of every element and comment."""
    return [(str(e.tag), dict(e.attrib), (e.text or "").strip()) for e in root.iter()]


def test_everything_but_the_chain_origins_is_preserved(tmp_path):
    robot = pincal.load_robot("ur10", markers=MARKERS[:1])
    truth = random_errors(robot.parameters("full,offsets"), seed=4)
    out = export_urdf(truth.robot, tmp_path / "ur10.urdf")
    source = etree.parse(str(robot.urdf_path)).getroot()
    exported = etree.parse(str(out)).getroot()
    chain = {o.urdf_joint for o in robot.origins}
    assert len(chain) == 7
    before, after = _items(source), _items(exported)
    assert "Calibrated by pincal" in after[1][2]
    del after[1]  # the calibration comment
    assert len(before) == len(after)
    n_origins = 0
    for element, a, b in zip(source.iter(), before, after, strict=True):
        parent = element.getparent()
        if element.tag == "origin" and parent.tag == "joint" and parent.get("name") in chain:
            assert a[0] == b[0] and a[1] != b[1]
            n_origins += 1
        else:
            assert a == b
    assert n_origins == 7
    assert len(exported.findall("gazebo")) == len(source.findall("gazebo")) > 0
    assert len(exported.findall("transmission")) == len(source.findall("transmission")) > 0


def test_joint_offset_is_folded_into_the_origin(tmp_path):
    robot = pincal.load_robot("kr270")
    params = robot.parameters("joint_a2.offset,joint_a4.offset")
    calibrated = params.apply([0.01, -0.02])
    out = export_urdf(calibrated, tmp_path / "k.urdf")
    joints = {j.get("name"): j.find("origin") for j in etree.parse(str(out)).getroot().iter("joint")}
    # joint_a2 turns about +y: rpy (0, 0.01, 0), xyz unchanged; joint_a4 about -x: roll +0.02.
    np.testing.assert_allclose(
        [float(v) for v in joints["joint_a2"].get("rpy").split()], [0, 0.01, 0], atol=1e-15
    )
    np.testing.assert_allclose(
        [float(v) for v in joints["joint_a2"].get("xyz").split()], [0.35, 0, 0], atol=1e-15
    )
    np.testing.assert_allclose(
        [float(v) for v in joints["joint_a4"].get("rpy").split()], [0.02, 0, 0], atol=1e-15
    )
    assert joints["joint_a1"].get("rpy") == "0 0 0"  # untouched text
    exported = pincal.load_robot(out)
    q = robot.random_configurations(5, 1)
    np.testing.assert_allclose(exported.points(q), robot.points(q + [0, 0.01, 0, -0.02, 0, 0]), atol=1e-12)


def test_the_source_is_never_overwritten(tmp_path):
    source = tmp_path / "robot.urdf"
    source.write_text(pincal.shipped_robots()["kr270"].read_text())
    robot = pincal.load_robot(source)
    calibrated = robot.parameters("offsets").apply(np.full(6, 1e-3))
    original = source.read_text()
    with pytest.raises(OverwriteRefused, match="refusing to overwrite"):
        export_urdf(calibrated, source)
    with pytest.raises(OverwriteRefused):
        export_urdf(calibrated, tmp_path / "." / "robot.urdf")
    os.symlink(source, tmp_path / "link.urdf")
    with pytest.raises(OverwriteRefused):
        export_urdf(calibrated, tmp_path / "link.urdf")
    assert source.read_text() == original


def test_source_urdf_is_required_and_must_hold_the_chain(tmp_path):
    kr270 = pincal.load_robot("kr270")
    from_model = pincal.load_robot(kr270.model, tip="tool0")
    with pytest.raises(UrdfError, match="source_urdf"):
        export_urdf(from_model, tmp_path / "a.urdf")
    export_urdf(from_model, tmp_path / "a.urdf", source_urdf=pincal.shipped_robots()["kr270"])
    with pytest.raises(UrdfError, match="no joint.s. joint_a1, joint_a2"):
        export_urdf(kr270, tmp_path / "b.urdf", source_urdf=pincal.shipped_robots()["planar_2r"])
    with pytest.raises(UrdfError, match="does not exist"):
        export_urdf(kr270, tmp_path / "c.urdf", source_urdf=tmp_path / "none.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/></robot>")
    with pytest.raises(UrdfError):
        export_urdf(kr270, tmp_path / "d.urdf", source_urdf=bad)
    assert not any((tmp_path / n).exists() for n in ("b.urdf", "c.urdf", "d.urdf"))


def test_tip_without_a_fixed_joint_cannot_carry_tip_errors(tmp_path):
    """link_6 is the child link of joint_a6 itself: no fixed joint whose origin could move it."""
    robot = pincal.load_robot("kr270", tip="link_6", markers=[(0.3, 0.1, 0.0)])
    assert robot.origins[-1].urdf_joint is None
    moved = robot.parameters("joint_a6.tx,joint_a6.offset").apply([1e-3, 1e-3])
    assert _round_trip_error(moved, export_urdf(moved, tmp_path / "ok.urdf")) <= 1e-9
    tip_moved = robot.parameters("link_6.tx").apply([1e-3])
    with pytest.raises(UrdfError, match="no fixed joint of its own"):
        export_urdf(tip_moved, tmp_path / "bad.urdf")
    assert not (tmp_path / "bad.urdf").exists()


def test_relative_mesh_paths_still_resolve(tmp_path):
    text = (
        pincal.shipped_robots()["planar_2r"]
        .read_text()
        .replace(
            '<link name="link1"/>',
            '<link name="link1"><visual><geometry><mesh filename="meshes/link1.stl"/>'
            "</geometry></visual></link>",
        )
    )
    (tmp_path / "src").mkdir()
    (tmp_path / "out").mkdir()
    (tmp_path / "src" / "arm.urdf").write_text(text)
    robot = pincal.load_robot(tmp_path / "src" / "arm.urdf")
    out = export_urdf(robot.parameters("joint1.offset").apply([0.1]), tmp_path / "out" / "arm.urdf")
    mesh = etree.parse(str(out)).getroot().find("link/visual/geometry/mesh")
    assert mesh.get("filename") == os.path.join("..", "src", "meshes", "link1.stl")


def test_base_and_markers_go_in_the_comment(tmp_path):
    robot = pincal.load_robot("kr270", markers=MARKERS[:1])
    params = robot.parameters("full,offsets,base").identifiable(prefer="base").identifiable
    values = np.zeros(len(params))
    values[params.index("base.tx")] = 2.5
    values[params.index("base.rz")] = 0.5
    calibrated = params.apply(values)
    out = export_urdf(calibrated, tmp_path / "k.urdf")
    text = out.read_text()
    assert 'robot base in the instrument frame: xyz="2.5 0 0" rpy="0 0 0.5"' in text
    model = pin.buildModelFromUrdf(str(out))  # the base is not written as geometry
    np.testing.assert_allclose(model.jointPlacements[1].translation, [0, 0, 0.675])
