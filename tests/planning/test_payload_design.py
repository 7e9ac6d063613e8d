"""Designs that choose a payload per configuration, and the test pose under the task's load."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal
from pincal.errors import BadArgument, DegenerateOptimumWarning
from pincal.evaluation import check_plan, rho0_split
from pincal.instruments import Instrument, PerCoordinate, Pose
from pincal.model.jacobian import JacobianEngine

SIGMA = 3e-5
PAYLOADS = [0.0, 135.0, 270.0]
TASK = pincal.Payload(270.0, (0.0, 0.0, 0.25))
Q0 = np.radians([0, -60, 60, 0, 45, 0])


@pytest.fixture(scope="module")
def params(kr270_marker):
    return (
        kr270_marker.parameters("lengths,offsets,gains,compliance")
        .identifiable(payloads=PAYLOADS)
        .identifiable
    )


@pytest.fixture(scope="module")
def designs(params):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateOptimumWarning)
        loaded = pincal.design(
            params,
            15,
            Q0,
            search=pincal.Search(pool=300, starts=2, seed=0),
            loads=pincal.Loads(payloads=PAYLOADS, task_payload=TASK),
        )
        bare = pincal.design(
            params,
            15,
            Q0,
            search=pincal.Search(pool=300, starts=2, seed=0),
            loads=pincal.Loads(payloads=[0.0], task_payload=TASK),
        )
    return loaded, bare


def test_a_payload_design_beats_a_payload_free_one_at_the_loaded_test_pose(params, designs):
    loaded, bare = designs
    assert set(loaded.plan.payload[:, 0]) > {0.0}  # it mounts payloads
    assert np.all(bare.plan.payload[:, 0] == 0.0)
    assert loaded.rho0 < bare.rho0 / 3  # measured: about 20 times on this robot
    # ρ0 is the core function's, under the task's payload and the plan's own payloads.
    assert loaded.rho0 == pytest.approx(
        pincal.rho0(params, loaded.plan, Q0, sigma=SIGMA, task_payload=TASK), rel=1e-9
    )
    # Without its payloads the same configurations separate compliance far worse.
    blind = pincal.Plan.for_robot(params.robot, loaded.plan.q)
    assert pincal.rho0(params, blind, Q0, sigma=SIGMA, task_payload=TASK) > 2 * loaded.rho0


def test_the_split_adds_up_and_says_what_the_payloads_bought(params, designs):
    loaded, bare = designs
    for design in designs:
        parts = rho0_split(params, design.plan, Q0, sigma=SIGMA, task_payload=TASK)
        assert parts["geometric"] + parts["elastic"] + parts["cross"] == pytest.approx(
            parts["total"], rel=1e-9
        )
        assert parts["total"] == pytest.approx(design.rho0**2, rel=1e-6)
    assert (
        rho0_split(params, bare.plan, Q0, sigma=SIGMA, task_payload=TASK)["elastic"]
        > 10 * rho0_split(params, loaded.plan, Q0, sigma=SIGMA, task_payload=TASK)["elastic"]
    )


def test_the_accuracy_report_is_under_the_plans_payloads_and_the_tasks(params, designs):
    loaded, bare = designs
    report = pincal.accuracy(
        params, loaded.plan, Q0, sigma=SIGMA, compare={"payload-free": bare.plan}, samples=32, workspace=64,
        task_payload=TASK,
    )  # fmt: skip
    assert report.plans[0].row("test pose").rms == pytest.approx(loaded.rho0, rel=1e-9)
    assert report.plans[1].row("test pose").rms == pytest.approx(bare.rho0, rel=1e-9)
    # Unloaded the same test pose is another number: the task's payload is what the report is under.
    unloaded = pincal.accuracy(params, loaded.plan, Q0, sigma=SIGMA, samples=32, workspace=64)
    assert unloaded.plans[0].row("test pose").rms == pytest.approx(
        pincal.rho0(params, loaded.plan, Q0, sigma=SIGMA), rel=1e-9
    )
    assert unloaded.plans[0].row("test pose").rms != pytest.approx(loaded.rho0, rel=1e-3)


def test_a_taught_pool_with_payloads(params):
    taught = params.robot.random_configurations(60, 4, margin=0.1)
    result = pincal.design(
        params,
        15,
        Q0,
        search=pincal.Search(pool=taught, starts=1, seed=0),
        loads=pincal.Loads(payloads=PAYLOADS, task_payload=TASK),
    )
    rows = {tuple(q) for q in np.round(taught, 12)}
    assert all(tuple(q) in rows for q in np.round(result.plan.q, 12))  # the plan is made of the pool's
    assert set(result.plan.payload[:, 0]) <= set(PAYLOADS)


def test_the_plan_file_carries_the_payloads(params, designs, tmp_path):
    loaded, _ = designs
    path = tmp_path / "plan.csv"
    loaded.plan.to_csv(path, degrees=True, robot=params.robot)
    assert path.read_text().splitlines()[0].endswith("payload_kg,payload_x,payload_y,payload_z")
    again = pincal.Plan.from_csv(path, params.robot, degrees=True)
    np.testing.assert_allclose(again.payload, loaded.plan.payload)
    np.testing.assert_allclose(again.q, loaded.plan.q, atol=1e-12)
    assert again.repeat(2).payload.shape == (30, 4)
    assert pincal.Plan.from_json(loaded.plan.to_json()).payload.tolist() == loaded.plan.payload.tolist()


def test_monte_carlo_at_the_loaded_test_pose_matches_the_prediction(params, designs):
    # Draw true robots (geometry, gains, compliances), measure the plan under its payloads, identify,
    # and compare the calibrated with the true robot at the test pose under the task's payload.
    # Then deploy each calibration as a user does (issue 20 item 6): compensate the test pose's joint
    # target under the task's payload and run the command on the true robot: the tool misses the
    # nominal target by the calibration's error, whose RMS is predicted by ρ0.
    loaded, _ = designs
    nominal = params.robot
    target = nominal.points(Q0)
    errors, compensated = [], []
    for trial in range(40):
        truth = pincal.random_errors(params, seed=100 + trial)
        data = pincal.simulate_measurements(
            truth, loaded.plan, SIGMA, seed=200 + trial, payload=loaded.plan.payload
        )
        result = pincal.identify(params, data, sigma=SIGMA)
        assert result.success
        error = result.robot.points(Q0, payload=TASK) - truth.robot.points(Q0, payload=TASK)
        errors.append(np.sum(error**2))
        command = pincal.compensate(result.robot, nominal, Q0[None], payload=TASK).commands
        compensated.append(np.sum((truth.robot.points(command, payload=TASK) - target) ** 2))
    measured, deployed = np.sqrt(np.mean(errors)), np.sqrt(np.mean(compensated))
    # 40 trials of a 3-coordinate error: the RMS is within ±25 % of ρ0 at 2 standard deviations.
    assert 0.75 * loaded.rho0 < measured < 1.3 * loaded.rho0
    assert 0.75 * loaded.rho0 < deployed < 1.3 * loaded.rho0
    # Uncompensated, the same command misses by the robot's own errors: millimetres, not ρ0.
    assert np.linalg.norm(truth.robot.points(Q0, payload=TASK) - target) > 20 * loaded.rho0


def test_monte_carlo_simulates_a_payload_plan_as_it_was_designed(params, designs):
    loaded, _ = designs
    mc = pincal.monte_carlo(params, loaded.plan, Q0, sigma=SIGMA, trials=12, seed=3, task_payload=TASK)
    assert mc.rho0_predicted == pytest.approx(loaded.rho0, rel=1e-9)
    assert mc.failures == 0 and mc.local_minima == 0
    # 12 trials of a 3-coordinate error: within a factor 1.6 of the prediction at 2 standard deviations.
    assert loaded.rho0 / 1.6 < mc.rho0_empirical < 1.6 * loaded.rho0
    # The same configurations measured without their payloads separate compliance far worse.
    blind = pincal.monte_carlo(params, loaded.plan.q, Q0, sigma=SIGMA, trials=2, seed=3, task_payload=TASK)
    assert blind.rho0_predicted > 2 * loaded.rho0


def test_a_compliance_the_data_cannot_separate_says_what_would(params):
    # Only the first joint moves: the gravity torque on joints 2-5 never changes, so each compliance
    # moves the points exactly as its joint's offset does, unless the payload changes.
    robot = params.robot
    offsets = robot.parameters("offsets,compliance").identifiable().identifiable
    plan = robot.random_configurations(30, 1)
    plan[:, 1:5] = plan[0, 1:5]
    check = check_plan(offsets, plan, sigma=SIGMA)
    dropped = [n for n in check.dropped if n.endswith(".compliance")]
    assert dropped and all("measure under several payloads" in check.dropped[n] for n in dropped)
    loads = np.column_stack([np.resize(PAYLOADS, 30), np.zeros((30, 3))])
    loaded = check_plan(offsets, pincal.Plan.for_robot(robot, plan, loads), sigma=SIGMA)
    assert not [n for n in loaded.dropped if n.endswith(".compliance")]


def test_bad_payload_designs_are_refused(params):
    with pytest.raises(BadArgument, match="payloads must be"):
        pincal.design(params, 15, Q0, loads=pincal.Loads(payloads=[]))
    with pytest.raises(BadArgument, match="exchange over a pool"):
        pincal.design(
            params, 15, Q0, search=pincal.Search(method="continuous"), loads=pincal.Loads(payloads=PAYLOADS)
        )
    with pytest.raises(BadArgument, match="mass"):
        pincal.design(params, 15, Q0, loads=pincal.Loads(payloads=[-5.0]))


# --------------------------------------------------------------------- other measurement kinds
MOCAP = PerCoordinate(SIGMA, 1e-4)  # 30 µm and 0.1 mrad


@pytest.fixture(scope="module")
def pose_params(kr270_marker):
    spec = kr270_marker.parameters("lengths,offsets,gains,compliance")
    return Instrument(Pose(), MOCAP).identifiable(spec, payloads=PAYLOADS).identifiable


def test_pose_rows_under_a_payload_match_finite_differences(pose_params):
    # The rows of a pose measured under three payloads, differenced, on a robot with geometric
    # errors (its compliances nominal: on a compliant robot the columns are first order only).
    params, kind, h = pose_params, Pose(), 1e-6
    qs = params.robot.random_configurations(3, 5)
    loads = np.column_stack([PAYLOADS, [[0.0, 0.0, 0.25]] * 3])
    values = pincal.random_errors(params, seed=2).values.copy()
    values[[p.kind in ("gain", "compliance") for p in params]] = 0.0
    on = params.on(params.apply(values))
    J = kind.rows(JacobianEngine(on), qs, loads)
    fd = np.empty_like(J)
    for c in range(len(on)):
        dx = np.zeros(len(on))
        dx[c] = h / on.scales[c]  # a compliance's step: a deflection of h at its reference torque
        plus, minus = (kind.predict(on.apply(s * dx), qs, loads) for s in (1, -1))
        fd[:, :, c] = kind.difference(plus, minus) / (2 * dx[c])
    assert np.abs(J - fd).max() < 1e-6 * np.abs(J).max()


def test_a_pose_design_with_payloads_recovers_the_parameters(pose_params):
    params = pose_params
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DegenerateOptimumWarning)
        result = pincal.design(
            params,
            12,
            Q0,
            orientation_length=0.2,
            instrument=pincal.instruments.Instrument(Pose(), MOCAP),
            search=pincal.Search(pool=300, starts=2, seed=1),
            loads=pincal.Loads(payloads=PAYLOADS, task_payload=TASK),
        )
    plan = result.plan
    assert plan.payload is not None and len(set(plan.payload[:, 0])) > 1  # it mounts several payloads
    assert isinstance(result.instrument, Instrument) and isinstance(result.instrument.kind, Pose)
    # The criterion the exchange minimised is the one pincal.rho0 evaluates on the plan.
    again = pincal.rho0(
        params, plan, Q0, task_payload=TASK, instrument=Instrument(Pose(), MOCAP), orientation_length=0.2
    )
    assert result.rho0 == pytest.approx(again, rel=1e-9)
    # Parameters recovered from one simulated campaign under the plan's payloads, within their
    # standard errors (z = (estimate - truth) / standard error: RMS about 1).
    truth = pincal.random_errors(params, seed=7)
    data = pincal.simulate_measurements(truth, plan, seed=8, instrument=Instrument(Pose(), MOCAP))
    fitted = pincal.identify(params, data, instrument=Instrument(Pose(), MOCAP))
    assert fitted.success
    z = (fitted.values - truth.values) / fitted.std
    assert np.sqrt(np.mean(z**2)) < 2.0 and np.abs(z).max() < 5.0


def test_a_residual_model_design_measures_points(params):
    with pytest.raises(BadArgument, match="orientations, pixels or distances"):
        pincal.design(
            params,
            15,
            Q0,
            residual_model=object(),
            instrument=pincal.instruments.Instrument(Pose(), pincal.instruments.PerCoordinate()),
        )  # type: ignore[arg-type]
    plan = params.robot.random_configurations(15, 3)
    with pytest.raises(BadArgument, match="orientations, pixels or distances"):
        pincal.accuracy(params, plan, Q0, residual_model=object(), instrument=Instrument(Pose()))  # type: ignore[arg-type]
