"""The one forward kinematics (pincal.model.kinematics) against Pinocchio one configuration at a
time, its derivatives against finite differences, and the checks built on it: a calibrated robot
(a joint gain, a compliance, a payload) is mount- and collision-checked with its calibrated
kinematics, in cases built so that the nominal kinematics says clear and the calibrated ones not."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.campaign.schedule import plan_campaign
from pincal.model.collision import CollisionWorld
from pincal.model.kinematics import BATCH, ForwardKinematics, torque_derivative_bound
from pincal.model.statics import Payload, payload_rows
from pincal.planning.constraints import Kinematics, Mount, Obstacle, Workcell
from tests.support.kinematics_oracle import heights, oracle_frames, oracle_thetas

MARKERS = [(0.1, 0.05, 0.2), (-0.03, 0.02, 0.08)]
GAINS = np.array([0.0, 0.02, -0.015, 0.0, 0.01, 0.0])
COMPLIANCES = np.array([0.0, 2e-6, 3e-6, 0.0, 0.0, 0.0])  # rad/(N·m): industrial
BASE = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([1.0, -0.5, 0.2]))


@pytest.fixture(scope="module")
def nominal():
    return pincal.load_robot("kr270", markers=MARKERS)


@pytest.fixture(scope="module")
def calibrated(nominal):
    """The KR 270 as a calibration leaves it: offsets, gains, compliances (on joints a2, a3)."""
    offsets = np.array([1e-3, -2e-3, 1.5e-3, 0.0, 1e-3, -1e-3])
    return nominal.replace(joint_offsets=offsets, joint_gains=GAINS, joint_compliances=COMPLIANCES)


@pytest.mark.parametrize("which", ["nominal", "calibrated"])
def test_the_service_is_pinocchios_framesforwardkinematics_per_configuration(which, request):
    robot = request.getfixturevalue(which).replace(base=BASE)
    qs = robot.random_configurations(40, 3)
    payload = Payload(150.0, (0.0, 0.1, 0.2))
    rows = payload_rows(payload, len(qs))  # the service works below the payload door: rows
    forward = ForwardKinematics(robot)
    thetas = oracle_thetas(robot, qs, payload)
    np.testing.assert_allclose(forward.joint_values(qs, rows), thetas, rtol=0, atol=1e-12)
    placed = forward.placements(qs, rows)
    rotations, positions = forward.tip(qs, rows)
    markers = forward.markers(qs, rows)
    chain = forward.chain_points(qs[: BATCH - 1], rows[: BATCH - 1])  # Pinocchio's loop
    batch = forward.batch_chain_points(qs, rows)  # the batch
    for i, (joints, tip, points) in enumerate(oracle_frames(robot, thetas)):
        for j, joint in enumerate(joints):
            np.testing.assert_allclose(placed.joint_translations[i, j], joint.translation, atol=1e-12)
            np.testing.assert_allclose(placed.joint_rotations[i, j], joint.rotation, atol=1e-12)
        np.testing.assert_allclose(placed.tip_positions[i], tip.translation, atol=1e-12)
        np.testing.assert_allclose(placed.tip_rotations[i], tip.rotation, atol=1e-12)
        np.testing.assert_allclose(placed.markers[i], points, atol=1e-12)
        seen = BASE * tip  # the instrument frame
        np.testing.assert_allclose(rotations[i], seen.rotation, atol=1e-12)
        np.testing.assert_allclose(positions[i], seen.translation, atol=1e-12)
        np.testing.assert_allclose(markers[i], points @ BASE.rotation.T + BASE.translation, atol=1e-12)
        expected = np.vstack([[m.translation for m in joints[1:]], tip.translation, points])
        np.testing.assert_allclose(batch[i], expected, atol=1e-12)
        if i < BATCH - 1:
            np.testing.assert_allclose(chain[i], expected, atol=1e-12)
    # The robot's own points are the service's, to the bit.
    np.testing.assert_array_equal(robot.points(qs, payload=payload), markers)


def test_a_rigid_robots_joint_values_are_reading_plus_offset_to_the_bit(nominal):
    robot = nominal.replace(joint_offsets=np.linspace(-0.01, 0.01, 6))
    qs = robot.random_configurations(20, 1)
    forward = ForwardKinematics(robot)
    assert forward.rigid and forward.motion_scale() is None
    np.testing.assert_array_equal(forward.joint_values(qs, Payload(100.0)), qs + robot.joint_offsets)
    np.testing.assert_array_equal(forward.reading_jacobian(qs[0]), np.eye(6))


def test_frame_jacobian_is_the_derivative_along_the_readings(calibrated):
    """J with respect to the reading (gains and compliance under a payload) against central
    differences of the tip placement: log6(T(q)⁻¹ T(q + h eⱼ)) / h."""
    forward = ForwardKinematics(calibrated)
    payload = Payload(200.0, (0.0, 0.0, 0.15)).row[None]
    q = np.radians([10, -70, 80, 20, 40, -30])
    placement, J = forward.frame_jacobian(q, payload)
    h = 1e-6
    for j in range(6):
        step = np.eye(6)[j] * h
        plus, _ = forward.frame_jacobian(q + step, payload)
        minus, _ = forward.frame_jacobian(q - step, payload)
        column = (pin.log6(placement.actInv(plus)).vector - pin.log6(placement.actInv(minus)).vector) / (
            2 * h
        )
        np.testing.assert_allclose(J[:, j], column, rtol=0, atol=1e-7 * max(1.0, np.abs(column).max()))
    # The gain and the compliance show: the reading's Jacobian is not the joints'.
    theta = forward.joint_values(q[None], payload)[0]
    J_theta = pin.computeFrameJacobian(
        calibrated.model, calibrated.model.createData(), theta, calibrated.tip_frame
    )
    assert np.abs(J - J_theta).max() > 1e-3


def test_motion_scale_bounds_the_joints_move_and_the_torque_bound_holds(calibrated):
    """|θ(b) − θ(a)| ≤ S|b − a| on random straight moves (with the payload), and T̄ ≥ |∂τ/∂θ|
    (Pinocchio's gravity derivatives) at random configurations."""
    forward = ForwardKinematics(calibrated)
    payload = Payload(270.0, (0.0, 0.0, 0.3))
    S = forward.motion_scale(payload.row[None])
    assert S is not None and np.all(S >= 0)
    assert np.all(np.diag(S) >= np.abs(1 + GAINS))
    bound = torque_derivative_bound(calibrated, payload.row[None])
    gravity = calibrated.gravity_model()
    rng = np.random.default_rng(5)
    qs = calibrated.random_configurations(200, rng)
    for theta in forward.joint_values(qs, payload_rows(payload, len(qs))):
        assert np.all(np.abs(gravity.torque_derivatives(theta, payload.row)) <= bound + 1e-9)
    a, b = calibrated.random_configurations(100, rng), calibrated.random_configurations(100, rng)
    rows = payload_rows(payload, len(a))
    moved = np.abs(forward.joint_values(b, rows) - forward.joint_values(a, rows))
    assert np.all(moved <= np.abs(b - a) @ S.T + 1e-12)
    with pytest.raises(pincal.errors.BadArgument, match="too large to bound"):
        ForwardKinematics(calibrated.replace(joint_compliances=np.full(6, 1e-3))).motion_scale()


def test_a_calibrated_robot_is_mount_checked_with_its_calibrated_kinematics(nominal, calibrated):
    """A plane between the nominal robot's lowest point and the calibrated one's (at a pose reaching
    down): clear for the nominal kinematics, not for the calibrated ones; and a payload the
    compliant joints yield to takes the calibrated robot below a plane it clears unloaded."""
    q = np.radians([0, -10, 100, 0, 80, 0])
    keep = Mount("floor").bind(nominal).keep  # the points that move (the same for both)
    low_nominal, low_calibrated = heights(nominal, q)[keep].min(), heights(calibrated, q)[keep].min()
    assert low_nominal - low_calibrated > 5e-3  # the gains take the wrist 5 mm lower or more
    plane = Mount("plane", (0, 0, 1), 0.5 * (low_nominal + low_calibrated))
    assert plane.satisfied(nominal, q)[0]
    assert not plane.satisfied(calibrated, q)[0]
    bound = plane.bind(calibrated)
    np.testing.assert_array_equal(bound.keep, keep)
    margins = bound.margins(Kinematics(calibrated, q[None]))[0]
    np.testing.assert_allclose(margins, heights(calibrated, q)[keep] - plane.offset, rtol=0, atol=1e-12)
    heavy = Payload(270.0, (0.0, 0.0, 0.2))
    low_loaded = heights(calibrated, q, heavy)[keep].min()
    assert low_calibrated - low_loaded > 1e-4  # the compliances yield 0.1 mm or more
    loaded = Mount("plane", (0, 0, 1), 0.5 * (low_calibrated + low_loaded)).bind(calibrated)
    assert loaded.satisfied(Kinematics(calibrated, q[None]))[0]
    assert not loaded.satisfied(Kinematics(calibrated, q[None], payload=heavy.row[None]))[0]
    margins = loaded.margins(Kinematics(calibrated, q[None], payload=heavy.row[None]))[0]
    np.testing.assert_allclose(
        margins, heights(calibrated, q, heavy)[keep] - loaded.offset, rtol=0, atol=1e-12
    )


def test_a_calibrated_robot_is_collision_checked_with_its_calibrated_kinematics(nominal, calibrated):
    """A ball where the calibrated marker is, 2 mm across, farther from every nominal capsule than
    its radius and theirs: the nominal world clear, the calibrated one in contact; the world's
    floor, placements and campaign say the same."""
    q = np.radians([20, -50, 70, 10, 30, 0])
    forward = ForwardKinematics(calibrated)
    marker = forward.placements(q[None]).markers[0, 0]  # base frame (the robot has no base placement)
    ball = Obstacle("ball", "sphere", (1e-3,), tuple(marker))
    radius = 0.01
    worlds = [CollisionWorld(r, [ball.geometry_object()], link_radius=radius) for r in (nominal, calibrated)]
    clear, touching = (w.distances(q) for w in worlds)
    assert clear.min() > 0 and touching.min() < 0
    # The oracle: the nominal marker capsule's distance to the ball, from Pinocchio's placements.
    ((_, tip, points),) = oracle_frames(nominal, q[None] + nominal.joint_offsets)
    a, b = tip.translation, points[0]
    t = np.clip((marker - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
    gap = np.linalg.norm(a + t * (b - a) - marker) - 1e-3 - 0.25 * radius
    k = worlds[0].names.index("marker 0 (capsule) / ball")
    assert clear[k] == pytest.approx(gap, abs=1e-6) and gap > 0.01
    # The shapes are placed where the calibrated joints put them.
    ((joints, _, _),) = oracle_frames(calibrated, oracle_thetas(calibrated, q[None]))
    for obj, shape in zip(worlds[1].geom.geometryObjects, worlds[1].placements(q), strict=True):
        expected = joints[obj.parentJoint] * obj.placement
        np.testing.assert_allclose(shape.homogeneous, expected.homogeneous, atol=1e-12)
    # The campaign of that pose: clear for the nominal robot, not for the calibrated one.
    cell = Workcell((ball,), link_radius=radius)
    campaigns = [
        plan_campaign(r, q[None], constraints=[cell], mount="none", clearance=0.0, self_collision=False)
        for r in (nominal, calibrated)
    ]
    assert campaigns[0].pose_clearance[0] > 0 and campaigns[1].pose_clearance[0] < 0
    assert campaigns[1].pose_closest[0] == "marker 0 (capsule) / ball"


def test_the_motion_bound_of_a_calibrated_world_covers_its_moves(calibrated):
    """Along random straight moves of the readings, no corner of a shape's bounding box travels
    farther than Σ wⱼ|Δqⱼ| with the calibrated robot's weights (gains and compliance mapped)."""
    world = CollisionWorld(calibrated, [Obstacle("ball", "sphere", (0.1,), (3, 0, 0)).geometry_object()])
    rng = np.random.default_rng(0)
    objects = world.geom.geometryObjects
    for _ in range(4):
        a, b = calibrated.random_configurations(2, rng)
        path = a[None] + np.linspace(0, 1, 101)[:, None] * (b - a)[None]
        placed = [world.placements(q) for q in path]
        for k, pair in enumerate(world.pairs):
            if pair.kind != "obstacle":
                continue
            shape = objects[pair.a]
            shape.geometry.computeLocalAABB()
            lo, hi = shape.geometry.aabb_local.min_, shape.geometry.aabb_local.max_
            corners = np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
            positions = np.array([corners @ p[pair.a].rotation.T + p[pair.a].translation for p in placed])
            travelled = np.linalg.norm(np.diff(positions, axis=0), axis=2).sum(axis=0)
            assert travelled.max() <= world.weights[k] @ np.abs(b - a) + 1e-9, pair.name


def test_the_inverse_kinematics_of_a_region_solves_the_calibrated_robot(calibrated):
    reference = np.radians([0, -60, 60, 0, 45, 0])
    centre = calibrated.points(reference)[0, 0]
    region = pincal.cartesian_box(centre - 0.05, centre + 0.05, reference, samples=8, seed=1)
    poses = region.resolve(calibrated).poses
    assert len(poses) == 8
    reached = calibrated.points(poses)[:, 0]
    assert np.all(reached >= centre - 0.05 - 1e-8) and np.all(reached <= centre + 0.05 + 1e-8)
    rotations, _ = calibrated.tip_poses(poses)
    np.testing.assert_allclose(
        rotations, np.broadcast_to(calibrated.tip_poses(reference)[0], rotations.shape), atol=1e-8
    )


def test_the_collision_world_moved_to_the_model_and_the_old_path_still_works():
    import pincal.model.collision as home
    from pincal.planning.constraints import collision_world as old

    with pytest.warns(DeprecationWarning, match="use pincal.model.collision.CollisionWorld"):
        assert old.CollisionWorld is home.CollisionWorld
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        assert old.reach is home.reach
    with pytest.raises(AttributeError):
        old.nothing_here  # noqa: B018


def test_the_motion_bound_of_a_gain_is_the_gain_times_the_joints():
    """A planar arm held straight, its first joint (gain 5 %) turned alone: the marker capsule's
    far corner travels (1 + k) times the reading's angle at its distance from the axis, beyond the
    rigid weights and within the calibrated ones."""
    robot = pincal.load_robot("planar_2r", markers=[(0.1, 0.0, 0.0)])
    calibrated = robot.replace(joint_gains=np.array([0.05, 0.0]))
    ball = Obstacle("ball", "sphere", (0.1,), (3, 0, 0)).geometry_object()
    rigid, world = (CollisionWorld(r, [ball], link_radius=1e-4) for r in (robot, calibrated))
    k = world.names.index("marker 0 (capsule) / ball")
    np.testing.assert_allclose(world.weights[k], rigid.weights[k] * [1.05, 1.0], rtol=1e-15)
    a, b = np.zeros(2), np.array([0.5, 0.0])
    shape = world.geom.geometryObjects[world.pairs[k].a]
    shape.geometry.computeLocalAABB()
    lo, hi = shape.geometry.aabb_local.min_, shape.geometry.aabb_local.max_
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    placed = [world.placements(a + s * (b - a))[world.pairs[k].a] for s in np.linspace(0, 1, 2001)]
    positions = np.array([corners @ p.rotation.T + p.translation for p in placed])
    travelled = np.linalg.norm(np.diff(positions, axis=0), axis=2).sum(axis=0).max()
    assert rigid.weights[k] @ (b - a) < travelled <= world.weights[k] @ (b - a)
    assert travelled == pytest.approx(world.weights[k] @ (b - a), rel=1e-6)
