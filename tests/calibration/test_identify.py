"""Identification (pincal.identify) and measurement data (pincal.measurements).

Oracles: known parameters recovered from noise-free simulated data, the planar 2-link closed-form
covariance (docs/method.md §9.2), finite differences of the residuals.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal import (
    MeasurementData,
    identify,
    random_errors,
    simulate_measurements,
)
from pincal.calibration.noise import Noise
from pincal.calibration.problem import Problem
from pincal.errors import BadConfiguration, BadMeasurementData, IdentificationFailed, SingularPlan

MARKER = [(0.1, 0.05, 0.2)]


@pytest.fixture(scope="module")
def kr270_params(kr270_marker):
    return kr270_marker.parameters("full,offsets").identifiable().identifiable


def _data(robot, plan, sigma=0.0, seed=0):
    return simulate_measurements(robot, plan, sigma, seed=seed)


# ----------------------------------------------------------------------------- recovery
@pytest.mark.parametrize(
    "name, tip, markers, spec",
    [
        ("kr270", None, MARKER, "full,offsets"),
        ("kr270", None, [(0.1, 0.05, 0.2), (-0.05, 0.1, 0.15)], "full,offsets,markers"),
        ("ur10", None, [(0.05, 0.02, 0.1)], "full,offsets"),
        ("panda", "panda_hand", [(0.0, 0.05, 0.1)], "lengths,offsets"),
    ],
)
def test_recovers_known_parameters_from_exact_data(name, tip, markers, spec):
    robot = pincal.load_robot(name, tip=tip, markers=markers)
    params = robot.parameters(spec).identifiable().identifiable
    truth = random_errors(params, error_std={"length": 2e-3, "angle": 2e-3}, seed=1)
    plan = robot.random_configurations(3 * len(params), 2)
    result = identify(params, _data(truth.robot, plan))
    assert result.success, result.message
    assert result.method == "trf" and result.check.identifiable
    np.testing.assert_allclose(result.values, truth.values, rtol=0, atol=1e-9)
    assert result.residual_rms_after < 1e-12 < 1e-4 < result.residual_rms_before
    q = robot.random_configurations(10, 3)
    np.testing.assert_allclose(result.robot.points(q), truth.robot.points(q), rtol=0, atol=1e-10)


def test_column_order_of_the_data_does_not_matter(kr270_marker, kr270_params):
    truth = random_errors(kr270_params, seed=4)
    data = _data(truth.robot, kr270_marker.random_configurations(30, 5), sigma=3e-5, seed=6)
    order = [5, 2, 0, 4, 1, 3]
    shuffled = MeasurementData(data.q[:, order], data.points, [data.joint_names[i] for i in order])
    a, b = identify(kr270_params, data), identify(kr270_params, shuffled)
    np.testing.assert_allclose(a.values, b.values, rtol=0, atol=1e-13)


def test_unknown_base_far_away_and_rotated(kr270_marker):
    """Data in an instrument frame metres away and turned by 2.8 rad: base.* from a rigid fit."""
    params = kr270_marker.parameters("full,offsets,base").identifiable(prefer="base").identifiable
    assert [n for n in params.names if n.startswith("base.")] == [
        f"base.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")
    ]
    values = np.array(random_errors(params, seed=7).values)
    base = [params.index(f"base.{c}") for c in ("tx", "ty", "tz", "rx", "ry", "rz")]
    values[base] = [2.5, -1.2, 0.3, 0.2, -0.1, 2.8]
    truth = params.apply(values)
    for seed in (8, 9):  # two plans: what holds for any (the iteration count is the search's path)
        result = identify(params, _data(truth, kr270_marker.random_configurations(30, seed)))
        assert result.success and result.method == "trf", result.message
        np.testing.assert_allclose(result.values, values, rtol=0, atol=1e-9)
        # Issue 10: "before" is after the initial rigid fit of the base, not at a base at the
        # identity: the search starts centimetres from the answer, not metres.
        assert 1e-4 < result.residual_rms_before < 0.05


def test_instrument_frame_data_without_base_are_implausible_not_converged(kr270_marker, kr270_params):
    """Issue 10: data in a far, rotated frame without base.*: the first joint's origin would have
    to move by metres; that is no calibration, and the likely cause is named (behaviour changed:
    this used to 'converge' through Levenberg-Marquardt with joint_a1's origin moved by metres)."""
    truth = random_errors(kr270_params, seed=3).robot
    far = truth.replace(base=pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 2.5), np.array([-2.5, 1.0, 0.2])))
    result = identify(kr270_params, _data(far, kr270_marker.random_configurations(30, 1)))
    assert result.status == "implausible" and not result.success
    assert any("--base" in c for c in result.causes), result.causes


def test_scipy_errors_do_not_leak(kr270_marker, kr270_params, monkeypatch):
    def broken(*args, **kwargs):
        raise ValueError("`x0` is infeasible")

    # pincal imports scipy.optimize when it first needs it
    monkeypatch.setattr("scipy.optimize.least_squares", broken)
    truth = random_errors(kr270_params, seed=3).robot
    far = truth.replace(base=pin.SE3(pin.rpy.rpyToMatrix(0.1, -0.2, 2.5), np.array([-2.5, 1.0, 0.2])))
    result = identify(kr270_params, _data(far, kr270_marker.random_configurations(30, 1)))
    assert result.status == "failed" and not result.success
    assert "least_squares" in result.message and "infeasible" in result.message


def test_a_failed_or_rank_deficient_result_reports_what_was_asked(kr270_marker, kr270_params, monkeypatch):
    """The loss, method, prior, the data's own σ and the rows rejected of a fit that failed or could
    not start are those of the call (they were the defaults: linear, trf, no prior, σ estimated,
    nothing rejected)."""
    import scipy.optimize

    same = _data(kr270_marker, np.tile(kr270_marker.random_configurations(1, 3), (30, 1)))
    same = MeasurementData(same.q, same.points, same.joint_names, sigma=3e-5)
    prior = pincal.Prior(1e-3, 1e-3)
    deficient = identify(kr270_params, same, loss="huber", prior=prior)
    assert deficient.status == "rank_deficient"
    assert (deficient.loss, deficient.method, deficient.prior) == ("huber", "trf", prior)
    assert deficient.sigma == 3e-5 and not deficient.sigma_estimated
    assert deficient.as_dict()["loss"] == "huber" and deficient.as_dict()["prior"] == prior.as_dict()
    assert identify(kr270_params, same, method="lm").method == "lm"

    data = _data(
        random_errors(kr270_params, seed=4).robot, kr270_marker.random_configurations(30, 3), 3e-5, 2
    )
    points = np.array(data.points)
    points[7] += [0.0, 0.022, 0.0]
    real = scipy.optimize.least_squares

    def final_fit_fails(*args, **kwargs):  # reject's scoring fits (soft_l1) run, the last fit fails
        if kwargs["loss"] == "linear":
            raise ValueError("boom")
        return real(*args, **kwargs)

    monkeypatch.setattr("scipy.optimize.least_squares", final_fit_fails)
    failed = identify(kr270_params, MeasurementData(data.q, points, data.joint_names), reject=5)
    assert failed.status == "failed" and "boom" in failed.message
    assert [o.row for o in failed.rejected] == [7]
    assert failed.residual_rms_before < 0.01  # the 22 mm row rejected is left out of it


def test_non_convergence_is_a_status_not_an_exception(kr270_marker, kr270_params, tmp_path):
    truth = random_errors(kr270_params, error_std={"length": 1e-2, "angle": 1e-2}, seed=9)
    result = identify(kr270_params, _data(truth.robot, kr270_marker.random_configurations(30, 1)), maxiter=1)
    assert result.status == "not_converged" and not result.success
    assert "no convergence" in result.message
    assert np.all(np.isfinite(result.values))
    with pytest.raises(IdentificationFailed, match="no convergence"):
        pincal.export_urdf(result, tmp_path / "x.urdf")
    assert not (tmp_path / "x.urdf").exists()


def test_jacobian_in_total_coordinates_matches_finite_differences(kr270_marker):
    """Rotation errors compose as R·exp3(ω): the Jacobian uses the right Jacobian of exp3."""
    params = kr270_marker.parameters("full,offsets,base").identifiable(prefer="base").identifiable
    params = params.on(kr270_marker).select(",".join(params.names[:-2]) + ",base.rz")  # a partial base
    data = _data(kr270_marker, kr270_marker.random_configurations(6, 2))
    problem = Problem(params, [data], Noise.of([data], 1.0))
    x = 0.3 * np.random.default_rng(0).standard_normal(len(params))
    J = problem.jacobian(x)
    h = 1e-6
    fd = np.column_stack(
        [-(problem.residual(x + h * e) - problem.residual(x - h * e)) / (2 * h) for e in np.eye(len(x))]
    )
    assert np.abs(J - fd).max() < 1e-7 * np.abs(J).max()


# ------------------------------------------------------------------ standard errors
def test_standard_errors_match_the_planar_closed_form():
    """docs/method.md §9.2: cov(Δl1, Δl2) = σ²/(m² − S²)·[[m, −S], [−S, m]], S = Σ cos q2."""
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("joint2.tx,tip.tx")
    plan = robot.random_configurations(7, 11)
    sigma = 1e-4
    truth = params.apply([3e-3, -2e-3])
    result = identify(params, _data(truth, plan, sigma=sigma, seed=12), sigma=sigma)
    m, S = len(plan), np.cos(plan[:, 1]).sum()
    cov = sigma**2 / (m**2 - S**2) * np.array([[m, -S], [-S, m]])
    np.testing.assert_allclose(result.std, np.sqrt(np.diag(cov)), rtol=1e-9)
    np.testing.assert_allclose(result.correlation[0, 1], -S / m, rtol=1e-9)
    np.testing.assert_allclose(result.covariance, cov, rtol=1e-9)
    assert result.sigma == sigma and not result.sigma_estimated


def test_sigma_is_estimated_from_the_residuals(kr270_marker, kr270_params):
    truth = random_errors(kr270_params, seed=2).robot
    data = _data(truth, kr270_marker.random_configurations(200, 3), sigma=3e-5, seed=4)
    result = identify(kr270_params, data)
    assert result.sigma_estimated
    dof = 3 * 200 - len(kr270_params)
    assert abs(result.sigma / 3e-5 - 1) < 4 / np.sqrt(2 * dof)
    assert result.residuals.shape == (200, 1, 3)
    assert result.residual_rms_after == pytest.approx(np.sqrt(np.mean(np.sum(result.residuals**2, -1))))
    report = result.report()
    assert "joint_a2.tx" in report and "mm" in report and "mrad" in report
    summary = result.as_dict()
    assert set(summary["params"]) == set(kr270_params.names)
    assert summary["status"] == "converged" and summary["iterations"] == result.iterations


# ------------------------------------------------------------------ what cannot be done
def test_parameters_the_data_cannot_identify_are_left_nominal_and_named():
    """Issue 10 (changed behaviour: this was status rank_deficient): the set is reduced to what
    the data identify, the others named with the reason, and the rest is recovered exactly."""
    robot = pincal.load_robot("kr270")  # marker on A6's axis: joint_a6.offset is invisible
    params = robot.parameters("offsets,lengths")
    truth = random_errors(params.identifiable().identifiable, seed=1)
    result = identify(params, _data(truth.robot, robot.random_configurations(40, 2)))
    assert result.success, result.message
    assert list(result.dropped) == ["joint_a6.offset"] and "invisible" in result.dropped["joint_a6.offset"]
    assert "joint_a6.offset" in result.message and result.check.rank == len(params) - 1
    assert result.values[params.index("joint_a6.offset")] == 0.0
    true = truth.as_dict()
    np.testing.assert_allclose(result.values, [true.get(n, 0.0) for n in params.names], atol=1e-9)
    assert not np.isfinite(result.condition_number)


def test_identical_rows_are_not_outliers():
    """Issue 21: one measurement repeated 12 times; the plane's two coordinates are fitted exactly,
    the third keeps its noise (10 µm): the median residual is zero and each row scored 333 333
    robust σ, every row an outlier. Scored against σ when the robust scale is zero, none is; a
    gross error among exact rows is still found and rejected."""
    robot = pincal.load_robot("planar_2r")
    params = robot.parameters("joint2.tx,tip.tx")
    q = robot.random_configurations(1, 3)
    point = robot.points(q) + [0.0, 0.0, 1e-5]
    same = MeasurementData(np.tile(q, (12, 1)), np.tile(point, (12, 1, 1)), robot.joint_names)
    result = identify(params, same)
    assert result.success and result.outliers == () and "suspicious" not in result.report()
    assert identify(params, same, reject=3).rejected == ()
    exact = _data(params.apply([1e-3, -2e-3]), robot.random_configurations(12, 4))
    points = np.array(exact.points)
    points[5] += [2e-3, 0.0, 0.0]
    bad = MeasurementData(exact.q, points, exact.joint_names)
    assert [o.row for o in identify(params, bad).outliers] == [5]
    assert [o.row for o in identify(params, bad, reject=5).rejected] == [5]


def test_degenerate_data_are_rank_deficient(kr270_marker, kr270_params):
    same = np.tile(kr270_marker.random_configurations(1, 3), (30, 1))
    result = identify(kr270_params, _data(kr270_marker, same))
    assert result.status == "rank_deficient"
    assert (
        "1 distinct configuration" in result.message
        and "inseparable" in result.check.report()
        and "at least 9" in result.message
    )


def test_too_few_configurations_names_the_minimum(kr270_marker, kr270_params):
    with pytest.raises(SingularPlan, match="at least 9 configurations"):
        identify(kr270_params, _data(kr270_marker, kr270_marker.random_configurations(8, 3)))


def test_data_for_another_robot_are_refused(kr270_marker, kr270_params):
    planar = pincal.load_robot("planar_2r")
    with pytest.raises(BadMeasurementData, match="missing joint_a1"):
        identify(kr270_params, _data(planar, planar.random_configurations(30, 1)))
    two = pincal.load_robot("kr270", markers=[(0, 0, 0.1), (0, 0.1, 0)])
    with pytest.raises(BadMeasurementData, match="2 measured point"):
        identify(kr270_params, _data(two, two.random_configurations(30, 1)))
    with pytest.raises(pincal.PincalError, match="sigma"):
        identify(kr270_params, _data(kr270_marker, kr270_marker.random_configurations(30, 1)), sigma=-1.0)


# ----------------------------------------------------------------------- measurement data
def test_csv_round_trip_in_every_unit(tmp_path):
    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2), (-0.1, 0.0, 0.1)])
    data = _data(robot, robot.random_configurations(5, 1), sigma=1e-4)
    for degrees in (False, True):
        for mm in (False, True):
            path = tmp_path / f"m{degrees}{mm}.csv"
            data.to_csv(path, degrees=degrees, millimetres=mm, robot=robot)
            header = path.read_text().splitlines()[0]
            assert header == ",".join(robot.joint_names) + ",x0,y0,z0,x1,y1,z1"
            back = MeasurementData.from_csv(path, robot, degrees=degrees, millimetres=mm)
            np.testing.assert_allclose(back.q, data.q, rtol=1e-15, atol=1e-15)
            np.testing.assert_allclose(back.points, data.points, rtol=1e-15, atol=1e-15)
            assert back.lines == (2, 3, 4, 5, 6)


def test_csv_single_marker_columns_and_any_order(tmp_path, kr270_marker):
    path = tmp_path / "m.csv"
    path.write_text(
        "# tracker export\nz,joint_a6,joint_a5,joint_a4,joint_a3,joint_a2,joint_a1,y,x\n"
        "1000,0,0,0,0,-1.5,0,20,1500\n\n"
    )
    data = MeasurementData.from_csv(path, kr270_marker, millimetres=True)
    np.testing.assert_allclose(data.q, [[0, -1.5, 0, 0, 0, 0]])
    np.testing.assert_allclose(data.points, [[[1.5, 0.02, 1.0]]])


@pytest.mark.parametrize(
    "text, error, match",
    [
        ("", BadMeasurementData, "is empty"),
        ("joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n", BadMeasurementData, "no rows"),
        ("0,1,2\n", BadMeasurementData, "header"),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n0,-1,0,0,0,0,1,2,3\n0,-1,0,0,0,nan,1,2,3\n",
            BadMeasurementData,
            "line 3: column joint_a6 is nan",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n0,-1,0,0,0,0,1,2\n",
            BadMeasurementData,
            "line 2: 8 values, expected 9",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n0,-1,0,0,0,0,1,2,abc\n",
            BadMeasurementData,
            "line 2: column z is 'abc', not a number",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n0,-1,0,0,0,0,1,2,3\n0,1,0,0,0,0,1,2,3\n",
            BadConfiguration,
            r"line 3: joint joint_a2 = 1 is outside its limits",
        ),
        (
            "j1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n0,-1,0,0,0,0,1,2,3\n",
            BadMeasurementData,
            "missing joint_a1; unknown column.s. j1",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6\n0,-1,0,0,0,0\n",
            BadMeasurementData,
            "no measured columns",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z0\n0,-1,0,0,0,0,1,2,3\n",
            BadMeasurementData,
            "not a mix",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x0,y0,z0,x1,y1\n0,-1,0,0,0,0,1,2,3,4,5\n",
            BadMeasurementData,
            "missing z1",
        ),
        (
            "joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x0,y0,z0,x1,y1,z1\n0,-1,0,0,0,0,1,2,3,4,5,6\n",
            BadMeasurementData,
            "2 measured point.s. per configuration but the robot has 1 marker",
        ),
    ],
)
def test_bad_csv_files_are_refused_with_their_line(tmp_path, kr270_marker, text, error, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(error, match=match):
        MeasurementData.from_csv(path, kr270_marker)


def test_missing_file_and_degrees_hint(tmp_path, kr270_marker):
    with pytest.raises(BadMeasurementData, match="does not exist"):
        MeasurementData.from_csv(tmp_path / "none.csv", kr270_marker)
    path = tmp_path / "deg.csv"
    path.write_text("joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z\n10,-60,30,0,45,0,1,2,3\n")
    with pytest.raises(BadConfiguration, match="look like degrees"):
        MeasurementData.from_csv(path, kr270_marker)
    assert MeasurementData.from_csv(path, kr270_marker, degrees=True).q[0, 1] == pytest.approx(
        np.radians(-60)
    )


def test_measurement_data_is_a_value_that_copies_its_inputs():
    q, points = np.zeros((2, 2)), np.ones((2, 1, 3))
    data = MeasurementData(q, points, ("joint1", "joint2"))
    q[0, 0] = 5.0
    assert data.q[0, 0] == 0.0 and not data.q.flags.writeable and not data.points.flags.writeable
    with pytest.raises(BadMeasurementData, match="points must be"):
        MeasurementData(q, np.ones((3, 1, 3)), ("joint1", "joint2"))
    with pytest.raises(BadMeasurementData, match="finite"):
        MeasurementData(q, np.full((2, 1, 3), np.nan), ("joint1", "joint2"))
