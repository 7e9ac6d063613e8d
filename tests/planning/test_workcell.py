"""The workcell and the collision world: distances against hand-built scenes whose distances are
known, the motion bound against the displacements forward kinematics gives, and designs that keep
clear of the cell."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.errors import BadConstraint
from pincal.model.collision import CollisionWorld, capsule_geometry, reach
from pincal.planning.constraints import Mount, Obstacle, Workcell, load_constraints, with_safety
from pincal.planning.safety import safety_margins

R = 0.05  # capsule radius used in the hand-built scenes [m]


def planar_world(obstacles, **kw) -> CollisionWorld:
    robot = pincal.load_robot("planar_2r")
    cell = Workcell(tuple(obstacles), link_radius=R)
    return cell.world(robot, **kw)


def test_capsules_follow_the_kinematics():
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    geom = capsule_geometry(robot, 0.1)
    names = [o.name for o in geom.geometryObjects]
    assert names[0] == "base_link (capsule)" and names[-1] == "marker 0 (capsule)"
    # The upper arm: a capsule 1.15 m long (A2 to A3) on link_2; the wrist links are spheres.
    arm = geom.geometryObjects[names.index("link_2 (capsule)")]
    assert arm.geometry.halfLength == pytest.approx(1.15 / 2) and arm.geometry.radius == 0.1
    assert type(geom.geometryObjects[names.index("link_5 (capsule)")].geometry).__name__ == "Sphere"
    world = CollisionWorld(robot)
    assert world.geometry.capsules and "capsules of radius" in world.geometry.source
    assert world.geometry.link_radius == pytest.approx(0.04 * reach(robot))


def test_distances_of_a_box_and_a_sphere_are_the_hand_computed_ones():
    # The arm stretched along x (q = 0): link capsules from 0 to 1 and 1 to 1.8 m, radius R.
    box = Obstacle("lid", "box", (0.2, 0.1, 0.2), (0.5, 0.35, 0.0))  # its face at y = 0.3
    ball = Obstacle("ball", "sphere", (0.1,), (2.2, 0.0, 0.0))  # 0.4 m beyond the tip
    world = planar_world([box, ball])
    d = dict(zip(world.names, world.distances(np.zeros(2)), strict=True))
    assert d["link1 (capsule) / lid"] == pytest.approx(0.3 - R, abs=1e-6)
    assert d["link2 (capsule) / ball"] == pytest.approx(2.2 - 0.1 - 1.8 - R, abs=1e-6)
    # Turned towards the lid's centre, the first link goes through it: they overlap.
    turned = world.distances(np.array([math.atan2(0.35, 0.5), 0.0]))
    assert dict(zip(world.names, turned, strict=True))["link1 (capsule) / lid"] < 0


def test_cell_from_yaml_with_a_mesh_and_a_urdf(tmp_path):
    # A 0.2 m cube as a mesh, centred at (0.5, 0.4, 0): its face at y = 0.3, as the box above.
    v = [(x, y, z) for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)]
    faces = [
        (1, 3, 2), (2, 3, 4), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5),
        (3, 7, 8), (3, 8, 4), (1, 5, 7), (1, 7, 3), (2, 4, 8), (2, 8, 6),
    ]  # fmt: skip
    obj = "".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {a} {b} {c}\n" for a, b, c in faces)
    (tmp_path / "cube.obj").write_text(obj)
    (tmp_path / "cell.urdf").write_text(
        """<robot name="cell"><link name="world"/><link name="post">
        <collision><origin xyz="0 -0.8 0"/>
        <geometry><cylinder radius="0.1" length="1"/></geometry></collision>
        </link><joint name="fix" type="fixed"><parent link="world"/><child link="post"/>
        <origin xyz="0.5 0 0"/></joint></robot>"""
    )
    (tmp_path / "cell.yaml").write_text(
        "workcell:\n  link_radius: 0.05\n  min_distance: 0.01\n"
        "  obstacles: [{name: cube, mesh: cube.obj, xyz: [0.5, 0.4, 0]}]\n  urdf: cell.urdf\n"
    )
    (cell,) = load_constraints(tmp_path / "cell.yaml")
    assert cell.min_distance == 0.01 and cell.obstacles[0].mesh == str(tmp_path / "cube.obj")
    world = cell.world(pincal.load_robot("planar_2r"))
    d = dict(zip(world.names, world.distances(np.zeros(2)), strict=True))
    assert d["link1 (capsule) / cube"] == pytest.approx(0.3 - R, abs=1e-6)
    # The cell's post: a cylinder of radius 0.1 at (0.5, -0.8): 0.7 m from the first link's axis.
    post = next(k for k in d if k.startswith("link1") and "post" in k)
    assert d[post] == pytest.approx(0.8 - 0.1 - R, abs=1e-6)


@pytest.mark.parametrize(
    "entry, match",
    [
        ({"obstacles": [{"box": [1, 1]}]}, "box size must be 3 numbers"),
        ({"obstacles": [{"box": [1, 1, 1], "sphere": 1}]}, "exactly one shape"),
        ({"obstacles": [{"cone": [1, 1]}]}, "unknown key 'cone'"),
        ({"obstacles": [{"mesh": "nowhere.stl"}]}, "not found"),
        ({"min_distance": -1, "obstacles": [{"sphere": 1}]}, "min_distance must be a number from 0"),
        ({}, "needs obstacles or a urdf"),
        ({"urdf": "nowhere.urdf"}, "not found"),
    ],
)
def test_bad_workcells_are_refused_in_one_line(entry, match):
    from pincal.planning.constraints.workcell import workcell_from_dict

    with pytest.raises(BadConstraint, match=match):
        workcell_from_dict(entry).geometry_objects()


def test_motion_weights_bound_every_path():
    """Along random straight moves of the KR 270, no corner of a shape's bounding box travels
    farther than the world's bound Σ wⱼ|Δqⱼ| (path lengths measured with forward kinematics)."""
    import pinocchio as pin

    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    world = CollisionWorld(robot, [Obstacle("ball", "sphere", (0.1,), (3, 0, 0)).geometry_object()])
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(0)
    objects = world.geom.geometryObjects
    for _ in range(10):
        a, b = robot.random_configurations(2, rng)
        path = a[None] + np.linspace(0, 1, 201)[:, None] * (b - a)[None]
        for k, pair in enumerate(world.pairs):
            if pair.kind != "obstacle":
                continue
            shape = objects[pair.a]
            shape.geometry.computeLocalAABB()
            lo, hi = shape.geometry.aabb_local.min_, shape.geometry.aabb_local.max_
            corners = np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
            local = corners @ shape.placement.rotation.T + shape.placement.translation
            positions = []
            for q in path:
                pin.forwardKinematics(model, data, q)
                frame = data.oMi[shape.parentJoint]
                positions.append(local @ frame.rotation.T + frame.translation)
            travelled = np.linalg.norm(np.diff(np.array(positions), axis=0), axis=2).sum(axis=0)
            assert travelled.max() <= world.weights[k] @ np.abs(b - a) + 1e-9, pair.name


def test_design_keeps_clear_of_the_cell(kr270_marker):
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    table = Obstacle("table", "box", (1.2, 1.6, 0.1), (1.7, 0.0, 0.6))
    cell = Workcell((table,), min_distance=0.05)
    q0 = np.radians([0, -60, 60, 0, 45, 0])
    result = pincal.design(
        params,
        8,
        test_pose=q0,
        search=pincal.Search(starts=2, workers=1, pool=300, seed=2),
        safety=pincal.Safety(constraints=[cell]),
    )
    world = cell.world(kr270_marker)
    assert world.distances_many(result.plan.q).min() >= 0.05 - 1e-9
    report = safety_margins(kr270_marker, result.plan, with_safety(kr270_marker, [cell]))
    assert report.obstacle.value >= 0.05 - 1e-9 and report.obstacle.required == 0.05 and report.ok
    assert "capsules" in report.note
    text = "\n".join(report.lines())
    assert "obstacle: " in text and "/ table" in text


def test_floor_points_of_the_world_are_the_mounts(kr270_marker):
    bound = Mount("floor").bind(kr270_marker)
    world = CollisionWorld(kr270_marker, self_collision=False, mount_points=bound)
    q = np.radians([[30, -60, 20, 0, 0, 0]])
    heights = bound.margins(pincal.planning.constraints.Kinematics(kr270_marker, q))[0]
    np.testing.assert_allclose(world.distances(q[0])[-len(heights) :], heights)
    assert world.names[-1] == "marker 0 / floor" and world.kinds[-1] == "floor"
