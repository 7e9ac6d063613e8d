"""Measurement kinds: their rows against finite differences, what each makes identifiable, the
camera's projection, the error models' covariances (docs/method.md §13)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.errors import BadArgument
from pincal.instruments.camera import Camera
from pincal.instruments.distance import Distance, anchors
from pincal.instruments.error_model import PerCoordinate, Tracker
from pincal.instruments.identifiability import identifiable
from pincal.instruments.image import Image, grid
from pincal.instruments.instrument import Instrument
from pincal.instruments.point import Point
from pincal.instruments.pose import Partial, Pose, partial_from_text
from pincal.model.fixtures import Fixture
from pincal.model.jacobian import JacobianEngine

BASE = pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 0.3), np.array([2.0, -1.0, 0.3]))
CAMERA = Camera(800, 810, 320, 240, (0.1, -0.05, 0.001, 0.002, 0.01), 640, 480)


@pytest.fixture(scope="module")
def kr270_two():
    return pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2), (0.0, -0.1, 0.1)]).replace(base=BASE)


def eye_in_hand(robot):
    kind = Image(CAMERA, grid(4, 3, 0.03), eye_in_hand=True)
    camera = pin.SE3(pin.rpy.rpyToMatrix(0, 0, 0.2), np.array([0.05, 0, 0.05]))
    target = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0, 0), np.array([0.5, 0, 0]))
    return kind, robot.with_fixtures(*kind.fixtures(camera, target))


def eye_to_hand(robot):
    kind = Image(CAMERA, grid(4, 3, 0.03), eye_in_hand=False)
    camera = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0, 0), np.array([0.4, 0, 1.5]))
    target = pin.SE3(pin.rpy.rpyToMatrix(0.1, 0, 0.2), np.array([0.0, 0.02, 0.05]))
    return kind, robot.with_fixtures(*kind.fixtures(camera, target))


def fd_rows(kind, params, qs, h=1e-6):
    """Central differences of the kind's predictions, in the tangent of its difference."""
    out = np.empty((len(qs), kind.size(params.robot), len(params)))
    for c in range(len(params)):
        dx = np.zeros(len(params))
        dx[c] = h
        plus, minus = (kind.predict(params.apply(s * dx), qs) for s in (1, -1))
        out[:, :, c] = kind.difference(plus, minus) / (2 * h)
    return out


def cases():
    kr = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2), (0.0, -0.1, 0.1)]).replace(base=BASE)
    panda = pincal.load_robot("panda")
    with_anchors = kr.with_fixtures(*anchors((1.0, 1.0, 0.0), (-1.0, 1.5, 2.0), (2.5, -1, 1)))
    return [
        ("point", kr, Point(), "full,offsets,markers,base"),
        ("pose", kr, Pose(), "full,offsets,markers,base"),
        ("partial", kr, Partial((("z",), ("x", "y", "rz"))), "full,offsets,markers,base"),
        ("distance", with_anchors, Distance(((0, 0), (0, 1), (1, 2))), "full,offsets,markers,instrument"),
        ("eye-in-hand", eye_in_hand(panda)[1], eye_in_hand(panda)[0], "full,offsets,instrument"),
        ("eye-to-hand", eye_to_hand(panda)[1], eye_to_hand(panda)[0], "full,offsets,instrument,base"),
    ]


@pytest.mark.parametrize("name,robot,kind,spec", cases(), ids=[c[0] for c in cases()])
def test_rows_match_finite_differences(name, robot, kind, spec):
    params = robot.parameters(spec)
    qs = robot.random_configurations(3, 1)
    for on in (params, params.on(params.apply(pincal.random_errors(params, seed=2).values))):
        J = kind.rows(JacobianEngine(on), qs)
        assert J.shape == (3, kind.size(robot), len(params))
        assert np.abs(J - fd_rows(kind, on, qs)).max() < 1e-6 * np.abs(J).max()


@pytest.mark.parametrize("kind", [Point(), Pose()], ids=["point", "pose"])
def test_tip_rows_carry_the_same_information(kr270_two, kind):
    """A rotation-invariant kind's rows in the tip frame give the world rows' M = ΣJᵢᵀJᵢ."""
    engine = JacobianEngine(kr270_two.parameters("full,offsets,markers,base"))
    qs = kr270_two.random_configurations(5, 3)
    world, tip = (np.einsum("mrp,mrs->ps", J, J) for J in (kind.rows(engine, qs), kind.tip_rows(engine, qs)))
    assert np.allclose(world, tip, rtol=1e-12, atol=1e-12 * np.abs(world).max())


def test_frame_rows_of_a_marker_frame_are_its_point_rows(kr270_two):
    engine = JacobianEngine(kr270_two.parameters("full,offsets,markers,base"))
    qs = kr270_two.random_configurations(4, 4)
    J = engine.jacobian(qs, frame="tip")
    for k, marker in enumerate(kr270_two.markers):
        rows, R, p = engine.frame_rows(qs, pin.SE3(np.eye(3), marker))
        assert np.allclose(rows[:, :3] + engine.marker_columns()[k], J[:, 3 * k : 3 * k + 3], atol=1e-14)
        assert np.allclose(p, kr270_two.points(qs)[:, k], atol=1e-12)


def test_camera_projection_jacobian_matches_finite_differences():
    rng = np.random.default_rng(0)
    p = rng.uniform([-0.3, -0.2, 0.4], [0.3, 0.2, 1.5], (20, 3))
    J, h = CAMERA.jacobian(p), 1e-7
    fd = np.stack([(CAMERA.project(p + h * e) - CAMERA.project(p - h * e)) / (2 * h) for e in np.eye(3)], -1)
    assert np.abs(J - fd).max() < 1e-5 * np.abs(J).max()
    pinhole = Camera(500, 500, 320, 240)
    assert np.allclose(pinhole.project(np.array([0.1, -0.2, 2.0])), [345.0, 190.0])
    ahead_behind_aside = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [9.0, 0, 1.0]])
    assert pinhole.in_view(ahead_behind_aside).tolist() == [True, False, True]
    assert CAMERA.in_view(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [5.0, 0.0, 1.0]])).tolist() == [
        True,
        False,
        False,
    ]


def test_a_pose_reveals_the_offset_a_point_on_the_axis_hides():
    """A marker at the flange centre lies on A6's axis: its point never moves with A6's zero,
    its frame turns with it."""
    params = pincal.load_robot("kr270").parameters("full,offsets")
    point, pose = params.identifiable(), identifiable(params, Instrument(Pose()))
    assert "joint_a6.offset" not in point.identifiable
    assert point.dropped["joint_a6.offset"].startswith("invisible")
    assert "joint_a6.offset" in pose.identifiable
    assert set(point.identifiable.names) < set(pose.identifiable.names)
    assert "pose measurements" in pose.report()


def test_what_partial_distance_and_image_measurements_identify():
    ur = pincal.load_robot("ur10")
    params = ur.parameters("full,offsets")
    height = identifiable(params, Instrument(Partial(("z",))))
    assert len(height.identifiable) < len(params.identifiable().identifiable)
    # Four draw-wires to one point see what a point sees, less the rigid motion the anchors absorb.
    wires = ur.with_fixtures(*anchors((1.0, 1.0, 0.0), (-1.0, 1.5, 0.5), (1.5, -1, 1), (0.5, -1.5, 0.2)))
    d = identifiable(wires.parameters("full,offsets,instrument"), Instrument(Distance.to_anchors(4)))
    anchor_names = [n for n in d.identifiable.names if n.startswith("anchor")]
    assert len(anchor_names) == 12
    assert len(d.identifiable) - 12 == len(params.identifiable().identifiable) - 6
    kind, robot = eye_in_hand(pincal.load_robot("panda"))
    image = identifiable(robot.parameters("full,offsets,instrument"), Instrument(kind))
    assert {n.split(".")[0] for n in image.identifiable.names} >= {"camera", "target"}
    assert len([n for n in image.identifiable.names if n.startswith(("camera", "target"))]) == 12


def test_kinds_check_their_set_up(kr270_two):
    with pytest.raises(BadArgument, match="anchor"):
        Distance().check(kr270_two)
    with pytest.raises(BadArgument, match="camera fixture"):
        Image(CAMERA, grid(2, 2, 0.1)).check(kr270_two)
    with pytest.raises(BadArgument, match="3 masks for 2 marker"):
        Partial((("z",), ("x",), ("y",))).check(kr270_two)
    with pytest.raises(BadArgument, match="distinct components"):
        partial_from_text("x,w")
    assert partial_from_text("y,x/rz").masks == (("x", "y"), ("rz",))
    assert Partial((("z",),)).coordinates(kr270_two) == ("z0", "z1")
    with pytest.raises(BadArgument, match="not one of"):
        Fixture("base", pin.SE3.Identity())
    with pytest.raises(BadArgument, match="two fixtures"):
        kr270_two.replace(fixtures=(Fixture("a", (0, 0, 0)), Fixture("a", (1, 0, 0))))


def test_fixtures_are_parameters_that_move_only_what_they_carry(kr270_two):
    robot = kr270_two.with_fixtures(Fixture("camera", (0.1, 0, 0.05, 0, 0, 0.3), on="tip"))
    params = robot.parameters("offsets,camera")
    assert params.names[-6:] == tuple(f"camera.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz"))
    assert robot.parameters("instrument").names == params.names[-6:]
    moved = params.apply(np.r_[np.zeros(6), 1e-3, 0, 0, 0, 0, 2e-3])
    camera = moved.fixture("camera").placement
    assert np.allclose(camera.translation, [0.101, 0, 0.05])
    assert np.allclose(camera.rotation, pin.rpy.rpyToMatrix(0, 0, 0.3) @ pin.exp3(np.array([0, 0, 2e-3])))
    assert robot.fixture("camera").placement.translation[0] == 0.1  # the caller's robot is untouched
    qs = robot.random_configurations(2, 0)
    assert np.array_equal(moved.points(qs), robot.points(qs))
    assert not params.jacobian(qs)[:, :, 6:].any()


def test_tracker_covariance_is_radial_and_transverse():
    tracker = Tracker(at=(0.0, 0.0, 0.0))
    points = np.array([[2.0, 0.0, 0.0], [0.0, 10.0, 0.0]])
    cov = tracker.point_covariance(points)
    for p, c in zip(points, cov):
        d = np.linalg.norm(p)
        u = p / d
        radial, transverse = 5e-6 + 0.15e-6 * d, 7.5e-6 + 3e-6 * d
        assert u @ c @ u == pytest.approx(radial**2, rel=1e-12)
        w = np.eye(3)[2]
        assert w @ c @ w == pytest.approx(transverse**2, rel=1e-12)
    assert np.sqrt(np.linalg.eigvalsh(cov[1]))[[0, 2]] == pytest.approx([6.5e-6, 37.5e-6], rel=1e-12)
    robot = pincal.load_robot("ur10")
    with pytest.raises(BadArgument, match="points and poses"):
        tracker.covariance(Distance(), robot.with_fixtures(*anchors((1, 0, 0))), np.zeros((1, 6)))


def test_whitened_rows_weight_by_the_inverse_covariance(kr270_two):
    """s·L⁻¹J rows: their information is s²·Σ JᵢᵀΣᵢ⁻¹Jᵢ; plain points are today's rows exactly."""
    params = kr270_two.parameters("full,offsets,markers,base")
    qs = kr270_two.random_configurations(6, 5)
    default = Instrument().engine(params)
    assert np.array_equal(default.jacobian(qs), JacobianEngine(params).jacobian(qs, frame="tip"))
    tracker = Tracker(at=(1.0, 2.0, 0.5))
    engine = Instrument(Point(), tracker).engine(params)
    J = JacobianEngine(params).jacobian(qs, frame="world")
    cov = tracker.covariance(Point(), kr270_two, qs).matrices()
    M = sum(j.T @ np.linalg.solve(c, j) for j, c in zip(J, cov))
    W = engine.jacobian(qs)
    assert np.allclose(np.einsum("mrp,mrs->ps", W, W), tracker.reference**2 * M, rtol=1e-9)
    pose = Instrument(Pose(), PerCoordinate(3e-5, 1e-4)).engine(params)
    J6 = Pose().rows(JacobianEngine(params), qs)
    w = np.tile([1.0] * 3 + [0.3] * 3, 2)
    assert np.allclose(pose.jacobian(qs, frame="world"), J6 * w[:, None])


def test_an_instrument_describes_the_sigma_of_what_it_measures(kr270_two):
    """On a robot, an instrument's description shows the σ of the units it measures only: no
    mrad or px for points, mm and mrad for poses, px for images; without a robot, every σ."""
    error = PerCoordinate(2e-5, sigma_rot=3e-4, sigma_px=0.4)
    points = Instrument(Point(), error).describe(kr270_two)
    assert "0.02 mm" in points and "mrad" not in points and "px" not in points
    poses = Instrument(Pose(), error).describe(kr270_two)
    assert "0.02 mm" in poses and "0.3 mrad" in poses and "px" not in poses
    image = Instrument(Image(CAMERA, grid(4, 3, 0.03), eye_in_hand=True), error).describe(kr270_two)
    assert "0.4 px" in image and "mm" not in image.split(";")[1]
    assert error.describe() == "sigma 0.02 mm, 0.3 mrad, 0.4 px"
