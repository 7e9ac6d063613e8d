"""Meshes found where the user says they are (issue 11, item 5): a URDF whose meshes are
``package://mypkg/meshes/cube.stl`` with ``--package-dir mypkg=PATH`` (``package_dirs=``). The
missing-mesh check, the 3-D view and the self-collision constraint all load them from there; without
it the meshes are named missing in one warning line, and nothing crashes. CI time: ~5 s."""

from __future__ import annotations

import base64
import importlib
import re
import struct
import warnings

import numpy as np
import pinocchio as pin
import pytest
import umsgpack

import pincal
from pincal.cli import main
from pincal.errors import BadArgument, BadConstraint, PincalWarning
from pincal.planning.constraints import Kinematics, SelfCollision

visualize = importlib.import_module("pincal.viewing.scene")  # the module (pincal.viewing.scene: the function)

CUBE = "package://mypkg/meshes/cube.stl"
FOLDED = np.array([0.0, np.pi / 2, 0.0])  # the last link's cube on the base's cube
STRETCHED = np.array([0.0, 0.0, 0.0])


def cube_stl(half: float) -> bytes:
    """A binary STL of the cube [-half, half]^3 (12 triangles)."""
    corners = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [
        (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
        (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
    ]  # fmt: skip
    out = [b"pincal test cube".ljust(80, b" "), struct.pack("<I", len(faces))]
    for face in faces:
        out.append(struct.pack("<3f", 0.0, 0.0, 0.0))
        for i in face:
            out.append(struct.pack("<3f", *corners[i]))
        out.append(struct.pack("<H", 0))
    return b"".join(out)


def _joint(name, parent, child, xyz, axis):
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        f'<limit lower="-2" upper="2" effort="1" velocity="1"/></joint>'
    )


def _link(name, mesh=""):
    if not mesh:
        return f'<link name="{name}"/>'
    geometry = f'<geometry><mesh filename="{mesh}"/></geometry>'
    return f'<link name="{name}"><visual>{geometry}</visual><collision>{geometry}</collision></link>'


ARM = (
    '<?xml version="1.0"?><robot name="arm">'
    + _link("base_link", CUBE)
    + _link("l1")
    + _link("l2")
    + _link("l3", CUBE)
    + _link("tool")
    + _joint("j1", "base_link", "l1", "0 0 0.1", "0 0 1")
    + _joint("j2", "l1", "l2", "0 0 0.2", "0 1 0")
    + _joint("j3", "l2", "l3", "0.3 0 0", "0 1 0")
    + '<joint name="tool_joint" type="fixed"><parent link="l3"/><child link="tool"/>'
    '<origin xyz="0.15 0 0.05"/></joint></robot>'
)


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    """(URDF path, package folder): the URDF in robot/, package mypkg in src/mypkg/, so that
    nothing above the URDF finds the package."""
    root = tmp_path_factory.mktemp("meshes")
    package = root / "src" / "mypkg"
    (package / "meshes").mkdir(parents=True)
    (package / "meshes" / "cube.stl").write_bytes(cube_stl(0.05))
    (root / "robot").mkdir()
    path = root / "robot" / "arm.urdf"
    path.write_text(ARM)
    return path, package


@pytest.fixture(scope="module")
def robot(arm):
    path, package = arm
    with warnings.catch_warnings():
        warnings.simplefilter("error", PincalWarning)  # every mesh found: no warning
        return pincal.load_robot(path, package_dirs={"mypkg": str(package)})


def test_the_robot_keeps_its_package_dirs(robot, arm):
    assert robot.package_dirs == (("mypkg", str(arm[1].resolve())),)
    assert robot.replace(name="other").package_dirs == robot.package_dirs


def test_the_scene_draws_the_mesh(robot):
    built = visualize.scene(robot, robot.random_configurations(6, 1), FOLDED * 0.5, sigma=3e-5)
    visual = built.viewer.window.node(f"/meshcat/{visualize.ROOT}/test_poses/test_1/robot/visuals")
    assert len(visual) == 2  # the two cubes: meshes, not the stick robot's cylinders
    for name in visual:
        (geometry,) = _geometries(visual[name])
        assert geometry["type"] == "_meshfile" and geometry["format"] == "stl"
        assert _raw(geometry["data"]) == cube_stl(0.05)  # the file in the package folder


def _geometries(node) -> list[dict]:
    """The meshcat geometries set in a scene-tree node and below it."""
    out = [] if node.object is None else umsgpack.unpackb(node.object)["object"]["geometries"]
    for child in node.values():
        out += _geometries(child)
    return out


def test_self_collision_sees_the_mesh_as_pinocchio_does(robot, arm):
    path, package = arm
    bound = SelfCollision(0.0).bind(robot)
    # Pinocchio's own reading of the URDF with the folder that holds the package folder.
    reference = pin.buildGeomFromUrdf(
        robot.model, str(path), pin.COLLISION, package_dirs=[str(package.parent)]
    )
    assert bound.exact.ngeoms == reference.ngeoms == 2
    for mine, theirs in zip(bound.exact.geometryObjects, reference.geometryObjects, strict=True):
        assert (mine.name, mine.parentJoint) == (theirs.name, theirs.parentJoint)
        assert mine.placement.isApprox(theirs.placement)
        assert mine.geometry.num_vertices == theirs.geometry.num_vertices == 8  # the cube's corners
        assert mine.geometry.num_tris == theirs.geometry.num_tris == 12
        np.testing.assert_allclose(mine.geometry.vertices(), theirs.geometry.vertices())
    reference.addCollisionPair(pin.CollisionPair(0, 1))
    data = robot.model.createData()
    for q, collides in ((FOLDED, True), (STRETCHED, False)):
        assert (
            pin.computeCollisions(robot.model, data, reference, reference.createData(), q, True) is collides
        )
        assert bool(bound.satisfied(Kinematics(robot, q[None]))[0]) is (not collides)
        # The hull distance is the cubes' distance: 0 when touching, else the true gap (beyond the
        # search's reach, a lower bound of it from the bounding spheres, beyond the reach too).
        gap, true = bound.margins(Kinematics(robot, q[None]))[0, 0], _cube_gap(robot, q)
        if collides:
            assert gap <= 0
        elif true < bound.reach:
            assert gap == pytest.approx(true, abs=1e-6)
        else:
            assert bound.reach <= gap <= true + 1e-9


def _cube_gap(robot, q):
    """Distance between the two axis-aligned cubes of side 0.1 at configuration q (j1 = 0)."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    centre = data.oMi[3].translation  # the cube of l3 (rotated about y only: q1 = 0)
    rotation = data.oMi[3].rotation
    extent = 0.05 * np.abs(rotation).sum(axis=1)
    gaps = np.maximum(np.abs(centre) - extent - 0.05, 0.0)
    return float(np.linalg.norm(gaps))


def test_without_the_package_dir_one_warning_and_no_crash(arm):
    path, _ = arm
    with pytest.warns(PincalWarning) as caught:
        robot = pincal.load_robot(path)
    assert len(caught) == 1 and "2 mesh file(s) not found" not in str(caught[0].message)
    assert "1 mesh file(s) not found (package://mypkg/meshes/cube.stl)" in str(caught[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the scene adds no second warning: it draws sticks
        built = visualize.scene(robot, robot.random_configurations(6, 1), FOLDED * 0.5, sigma=3e-5)
    visual = built.viewer.window.node(f"/meshcat/{visualize.ROOT}/test_poses/test_1/robot/visuals")
    assert {g["type"] for g in _geometries(visual)} == {"CylinderGeometry"}
    with pytest.raises(
        BadConstraint, match=r"1 collision mesh file\(s\) of arm.urdf not found .*--package-dir"
    ):
        SelfCollision(0.0).bind(robot)


def test_package_dirs_are_checked(arm):
    path, package = arm
    with pytest.raises(BadArgument, match=r"package folder .*nowhere.* is not a folder"):
        pincal.load_robot(path, package_dirs={"mypkg": str(package / "nowhere")})
    with pytest.raises(BadArgument, match="package_dirs: expected"):
        pincal.load_robot(path, package_dirs=[("mypkg", str(package))])


def test_cli_design_and_show_with_package_dir_and_self_collision(arm, tmp_path, capsys):
    path, package = arm
    constraints = tmp_path / "c.yaml"
    constraints.write_text("self_collision: {min_distance: 0.01}\n")
    plan, html = tmp_path / "plan.csv", tmp_path / "scene.html"
    robot_args = [str(path), "--package-dir", f"mypkg={package}"]
    design = ["design", *robot_args, "-m", "6", "--test-pose", "0.3,0.8,-0.5"]
    design += ["--constraints", str(constraints), "--starts", "2"]
    assert main([*design, "--no-progress", "--no-accuracy", "--out", str(plan)]) == 0
    assert capsys.readouterr().err == ""
    robot = pincal.load_robot(path, package_dirs={"mypkg": str(package)})
    qs = pincal.Plan.from_csv(plan).q
    assert SelfCollision(0.01).satisfied(robot, qs).all()
    assert (
        main(["show", *robot_args, "--plan", str(plan), "--html", str(html), "--test-pose", "0.3,0.8,-0.5"])
        == 0
    )
    assert capsys.readouterr().err == ""
    meshes = [g for g in _html_geometries(html.read_text()) if g["type"] == "_meshfile"]
    assert meshes and all(_raw(g["data"]) == cube_stl(0.05) for g in meshes)  # the file given
    # Without --package-dir: the warning, then one error line for the constraint; exit 2.
    without = [a for a in design if a not in robot_args[1:]]
    assert main([*without, "--no-progress"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and err[0].startswith("pincal: warning: arm.urdf: 1 mesh file(s) not found")
    assert err[1].startswith("pincal: error: self_collision: 1 collision mesh file(s) of arm.urdf not found")


def _html_geometries(html: str) -> list[dict]:
    """The geometries set by the meshcat commands inlined in a static page."""
    out = []
    for data in re.findall(r'fetch\("data:application/octet-binary;base64,([^"]+)"', html):
        command = umsgpack.unpackb(base64.b64decode(data))
        if command.get("type") == "set_object":
            out += command["object"].get("geometries", [])
    return out


def _raw(data) -> bytes:
    """The bytes of a msgpack binary field (umsgpack gives an Ext for typed arrays)."""
    return bytes(getattr(data, "data", data))
