"""Identification from every measurement kind: simulated campaigns recover their known errors within
the predicted standard errors; data files of each kind; weights from the data's covariances and the
instruments' error models (docs/method.md §13)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal.calibration.noise import Noise
from pincal.errors import BadMeasurementData
from pincal.instruments.camera import Camera
from pincal.instruments.distance import Distance, anchors
from pincal.instruments.error_model import PerCoordinate, Tracker
from pincal.instruments.identifiability import identifiable
from pincal.instruments.image import Image, grid
from pincal.instruments.instrument import Instrument
from pincal.instruments.point import Point
from pincal.instruments.pose import Partial, Pose

CAMERA = Camera(600, 600, 320, 240, (0.05, -0.02, 0.0, 0.0, 0.0), 640, 480)


def seen_plan(robot, kind, m, seed, minimum=8):
    """m random configurations at which the kind reads at least ``minimum`` values."""
    pool = robot.random_configurations(40 * m, seed)
    return pool[kind.seen(robot, pool).sum(axis=1) >= minimum][:m]


def campaign(robot, kind, spec, m, error=None, seed=0, prefer=()):
    """(result, truth): identify simulated data of ``kind`` with known errors."""
    instrument = Instrument(kind, error or PerCoordinate())
    params = identifiable(robot.parameters(spec), instrument, prefer=prefer).identifiable
    truth = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=seed)
    qs = (
        seen_plan(robot, kind, m, seed + 1)
        if isinstance(kind, Image)
        else robot.random_configurations(m, seed + 1)
    )
    data = pincal.simulate_measurements(truth, qs, seed=seed + 2, instrument=instrument)
    return pincal.identify(params, data, instrument=instrument), truth


def assert_within_standard_errors(result, truth):
    assert result.status == "converged", result.message
    z = (result.values - truth.values) / result.std
    assert 0.5 < np.sqrt(np.mean(z**2)) < 1.6 and np.abs(z).max() < 4.5, z


def panda_camera(eye_in_hand=True):
    kind = Image(CAMERA, grid(6, 5, 0.03), eye_in_hand=eye_in_hand)
    if eye_in_hand:
        camera, target = (0.05, 0, 0.05), pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0, 0), np.array([0.5, 0, 0.0]))
    else:
        camera, target = pin.SE3(pin.rpy.rpyToMatrix(np.pi, 0, 0), np.array([0.5, 0, 1.6])), (0, 0, 0.05)
    return kind, pincal.load_robot("panda").with_fixtures(*kind.fixtures(camera, target))


@pytest.mark.parametrize(
    "kind,m",
    [(Pose(), 25), (Partial((("x", "y", "z", "rz"),)), 30), (Partial(("z",)), 60)],
    ids=["pose", "xyz-rz", "z"],
)
def test_pose_and_partial_campaigns_recover_the_errors(kind, m):
    ur10 = pincal.load_robot("ur10", markers=[(0.05, 0.02, 0.1)])
    result, truth = campaign(ur10, kind, "full,offsets", m)
    assert_within_standard_errors(result, truth)


def test_mocap_poses_in_the_instrument_frame_with_its_own_noise():
    """6-D motion capture on a UR10: positions 0.1 mm, angles 2 mrad, the base identified."""
    ur10 = pincal.load_robot("ur10").replace(
        base=pin.SE3(pin.rpy.rpyToMatrix(0, 0, 0.4), np.array([1.0, 0.5, 0]))
    )
    mocap = Instrument(Pose(), PerCoordinate(1e-4, 2e-3))
    params = identifiable(ur10.parameters("full,offsets,base"), mocap, prefer="base").identifiable
    truth = pincal.random_errors(params, seed=3)
    data = pincal.simulate_measurements(truth, ur10.random_configurations(30, 4), seed=5, instrument=mocap)
    result = pincal.identify(params.on(ur10.replace(base=pin.SE3.Identity())), data, instrument=mocap)
    assert result.status == "converged"
    assert np.allclose(result.robot.base.translation, truth.robot.base.translation, atol=1e-3)
    names = [n for n in params.names if not n.startswith("base")]
    idx = [params.index(n) for n in names]
    z = (result.values[idx] - truth.values[idx]) / result.std[idx]
    assert np.sqrt(np.mean(z**2)) < 1.6 and np.abs(z).max() < 4.5


def test_distance_campaign_identifies_the_anchors():
    ur10 = pincal.load_robot("ur10", markers=[(0.05, 0.02, 0.1)])
    wires = ur10.with_fixtures(*anchors((1.0, 1.0, 0.0), (-1.0, 1.5, 0.5), (1.5, -1, 1), (0.5, -1.5, 0.2)))
    result, truth = campaign(wires, Distance.to_anchors(4), "full,offsets,instrument", 40)
    assert_within_standard_errors(result, truth)
    assert "anchor3.z" in result.names and result.robot.fixture("anchor3").point


@pytest.mark.parametrize("eye_in_hand", [True, False], ids=["eye-in-hand", "eye-to-hand"])
def test_camera_campaign_identifies_the_camera_and_the_target(eye_in_hand):
    kind, robot = panda_camera(eye_in_hand)
    result, truth = campaign(robot, kind, "full,offsets,instrument", 30, seed=1)
    assert_within_standard_errors(result, truth)
    assert result.residual_rms_by_unit()["px"] < 1.0  # the 0.5 px noise per coordinate, ~0.7 per point
    assert result.as_dict()["fixtures"]["camera"]["on"] == ("tip" if eye_in_hand else "world")


@pytest.mark.parametrize("distance", [2.0, 10.0])
def test_tracker_campaign_weights_by_its_covariance(distance):
    kr270 = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    tracker = Tracker(at=(distance, 0.0, 1.0))
    result, truth = campaign(kr270, Point(), "full,offsets", 30, error=tracker)
    assert_within_standard_errors(result, truth)
    assert not result.sigma_estimated


def test_a_full_covariance_per_row_weighs_the_fit():
    """Correlated pose noise given with the data: the standard errors are (ΣJᵢᵀΣᵢ⁻¹Jᵢ)⁻¹'s."""
    ur10 = pincal.load_robot("ur10")
    params = identifiable(ur10.parameters("full,offsets"), Instrument(Pose())).identifiable
    truth = pincal.random_errors(params, seed=8)
    qs = ur10.random_configurations(25, 9)
    rng = np.random.default_rng(10)
    A = rng.normal(size=(6, 6)) * np.r_[[3e-5] * 3, [1e-4] * 3]
    cov = A @ A.T + np.diag(np.r_[[1e-10] * 3, [1e-9] * 3])
    L = np.linalg.cholesky(cov)
    values = Pose().predict(truth.robot, qs) + rng.standard_normal((25, 6)) @ L.T
    data = pincal.MeasurementData(
        qs, values, ur10.joint_names, kind=Pose(), covariance=np.broadcast_to(cov, (25, 6, 6))
    )
    result = pincal.identify(params, data)
    assert result.status == "converged" and not result.sigma_estimated
    from pincal.model.jacobian import JacobianEngine

    J = Pose().rows(JacobianEngine(params.on(result.robot)), qs)
    M = sum(j.T @ np.linalg.solve(cov, j) for j in J)
    assert np.allclose(result.std, np.sqrt(np.diag(np.linalg.inv(M))), rtol=2e-3)


def test_noise_whitens_block_by_block():
    ur10 = pincal.load_robot("ur10")
    qs = ur10.random_configurations(4, 0)
    tracker = Tracker(at=(3.0, 0.0, 1.0))
    data = pincal.simulate_measurements(ur10, qs, 0.0)
    noise = Noise.of([data], None, tracker, [ur10])
    assert noise.factor is not None and noise.known and noise.reference == tracker.reference
    r = np.random.default_rng(0).normal(size=12)
    cov = tracker.covariance(Point(), ur10, qs).matrices()
    e = noise.whiten(r)
    assert np.allclose(e @ e, sum(ri @ np.linalg.solve(c, ri) for ri, c in zip(r.reshape(4, 3), cov)))
    used = np.array([True, False, True, True])
    assert np.allclose(
        noise.whitening(used)(r.reshape(4, 3)[used].reshape(-1)), e.reshape(4, 3)[used].reshape(-1)
    )
    assert noise.count(used) == 9


def test_kind_files_round_trip(tmp_path):
    ur10 = pincal.load_robot("ur10", markers=[(0.05, 0.02, 0.1), (0.0, 0.0, 0.1)])
    qs = ur10.random_configurations(3, 0)
    for kind in (Pose(), Partial((("z",), ("x", "y"))), Partial(("z",))):
        data = pincal.simulate_measurements(
            ur10, qs, seed=1, instrument=Instrument(kind, PerCoordinate(1e-5))
        )
        path = tmp_path / f"{kind.name}.csv"
        data.to_csv(path, millimetres=True, robot=ur10)
        back = pincal.MeasurementData.from_csv(path, ur10, millimetres=True)
        assert type(back.measure) is type(kind) and np.allclose(back.values, data.values, atol=1e-12)
    panda_kind, panda = panda_camera()
    exact = Instrument(panda_kind)  # sigma=0: exact values, of what it measures too
    data = pincal.simulate_measurements(
        panda, seen_plan(panda, panda_kind, 3, 2, minimum=2), 0.0, instrument=exact
    )
    assert np.isnan(data.values).any()  # points out of view
    path = tmp_path / "image.csv"
    data.to_csv(path, robot=panda)
    assert ",," in path.read_text()
    back = pincal.MeasurementData.from_csv(path, panda, kind=panda_kind)
    assert np.array_equal(np.isnan(back.values), np.isnan(data.values))
    with pytest.raises(BadMeasurementData, match="--camera"):
        pincal.MeasurementData.from_csv(path, panda)


def test_quaternions_uncertainties_and_covariances_are_read(tmp_path):
    ur10 = pincal.load_robot("ur10")
    joints = ",".join(ur10.joint_names)
    q = "0,-1,1,-1,-1.5,0"
    half = np.sqrt(0.5)
    path = tmp_path / "pose.csv"
    path.write_text(
        f"{joints},x,y,z,qx,qy,qz,qw,s,srot,cov_x_y\n{q},1,2,3,0,0,{half},{half},0.1,0.002,0.004\n"
    )
    data = pincal.MeasurementData.from_csv(path, ur10, millimetres=True)
    assert isinstance(data.measure, Pose)
    assert np.allclose(data.values[0], [1e-3, 2e-3, 3e-3, 0, 0, np.pi / 2])
    assert np.allclose(np.diag(data.covariance[0]), [1e-8] * 3 + [4e-6] * 3)
    assert data.covariance[0, 0, 1] == pytest.approx(4e-9)
    path.write_text(f"{joints},x,y,z,qx,qy,qz,qw\n{q},1,2,3,0,0,0.5,0.5\n")
    with pytest.raises(BadMeasurementData, match="norm 0.707"):
        pincal.MeasurementData.from_csv(path, ur10)
    path.write_text(f"{joints},z,sq\n{q},1,0.1\n")
    with pytest.raises(BadMeasurementData, match="sq"):
        pincal.MeasurementData.from_csv(path, ur10)
    path.write_text(f"{joints},d0,d1\n{q},1,2\n")
    with pytest.raises(pincal.errors.BadArgument, match="--anchor"):
        pincal.MeasurementData.from_csv(path, ur10)
    two = ur10.with_fixtures(*anchors((1, 0, 0), (0, 1, 0)))
    assert pincal.MeasurementData.from_csv(path, two).measure == Distance(((0, 0), (0, 1)))


def test_point_files_read_as_always(tmp_path, kr270):
    """x,y,z columns of points keep their errors; a lone z is a height gauge's file."""
    joints = ",".join(kr270.joint_names)
    path = tmp_path / "p.csv"
    path.write_text(f"{joints},x,y,z0\n0,-1,0,0,0,0,1,2,3\n")
    with pytest.raises(BadMeasurementData, match="not a mix"):
        pincal.MeasurementData.from_csv(path, kr270)
    path.write_text(f"{joints},z\n0,-1,0,0,0,0,1\n")
    assert pincal.MeasurementData.from_csv(path, kr270).measure == Partial(("z",))
    path.write_text(f"{joints},x,y,z,srot\n0,-1,0,0,0,0,1,2,3,1\n")
    with pytest.raises(BadMeasurementData, match="not uncertainties of points"):
        pincal.MeasurementData.from_csv(path, kr270)
