"""The public evaluations' short paths (one small plan, a batch, kept reports and limits) against the plain
computations they replace: the same numbers bit for bit where the arithmetic is the same, and
within the stated precision against an SVD where it is not (the singular values of the criteria)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import pincal
from pincal.errors import BadConfiguration, SingularPlan
from pincal.evaluation import accuracy_samples
from pincal.evaluation.a_optimal import AOptimal
from pincal.evaluation.accuracy_report import ErrorSummary
from pincal.evaluation.classic import (
    EIGEN_CONDITION,
    criteria_of_jacobians,
    criteria_of_plans,
    singular_values,
)
from pincal.evaluation.condition import Condition
from pincal.evaluation.d_optimal import DOptimal
from pincal.evaluation.e_optimal import EOptimal
from pincal.evaluation.information import informations
from pincal.evaluation.plans import engine_for, jacobians
from pincal.evaluation.predicted_error import PredictedError
from pincal.evaluation.region import width_text
from pincal.evaluation.test_pose import TestPoseCriterion
from pincal.instruments import Point, Tracker
from pincal.instruments.instrument import Instrument
from pincal.kept import REPORTS
from pincal.model.jacobian import JacobianEngine
from tests.conftest import ROOT

SIGMA = 3e-5


@pytest.mark.parametrize("group", ["full", "full,offsets", "lengths,offsets", "full,offsets,markers,base"])
def test_the_regressor_columns_picked_are_the_product(kr270_marker, group):
    """KR 270's origins have their parent's axes: C picks one regressor column per parameter, and
    the picked (and scaled) columns are the matrix product's numbers, bit for bit; the one-step
    path of a rigid one-marker set gives the general path's Jacobian."""
    params = kr270_marker.parameters(group).identifiable().identifiable
    engine = JacobianEngine(params)
    assert engine.selection is not None
    qs = kr270_marker.random_configurations(40, np.random.default_rng(1))
    reg = engine.regressors(qs)[0]
    picked = engine._columns(reg)
    engine.selection = None
    assert np.array_equal(picked, engine._columns(reg))
    fast = JacobianEngine(params)
    general = JacobianEngine(params)
    general.plain = False
    for n in (1, 12, 16, 17, 40):  # one chunk of regressors and several
        assert np.array_equal(fast.jacobian(qs[:n]), general.jacobian(qs[:n]))
    assert np.array_equal(fast.jacobian(qs), params.jacobian(qs, frame="tip"))


def test_rotated_origins_keep_the_product():
    ur10 = pincal.load_robot("ur10", tip="tool0")
    assert JacobianEngine(ur10.parameters("full")).selection is None


def _svd_criteria(J: np.ndarray, m: int, rows: int):
    return criteria_of_plans(np.linalg.svd(J, compute_uv=False), m, rows)


def test_criteria_from_eigenvalues_agree_with_the_svd(kr270_marker):
    """The singular values of well-conditioned plans come from the eigenvalues of M: every σ within
    1e-9 (relative) of LAPACK's SVD of J, every printed criterion too; plans above
    EIGEN_CONDITION take the SVD itself, so their values are the SVD's bit for bit."""
    params = kr270_marker.parameters("full,offsets,gains").identifiable().identifiable
    rng = np.random.default_rng(4)
    good = kr270_marker.random_configurations(12 * 60, rng).reshape(60, 12, -1)
    # Poor plans: twelve configurations within a few hundredths of a radian of one another.
    centre = kr270_marker.random_configurations(3, rng)
    poor = centre[:, None, :] + rng.uniform(-0.02, 0.02, (3, 12, kr270_marker.nq))
    plans = np.concatenate([good, poor])
    J = jacobians(engine_for(params), plans)
    M = informations(J)
    S = singular_values(J, M)
    oracle = np.linalg.svd(J, compute_uv=False)
    cond = oracle[:, 0] / oracle[:, -1]
    assert (cond[:60] <= EIGEN_CONDITION).sum() >= 50 and (cond[60:] > EIGEN_CONDITION).all()
    well = cond <= 0.99 * EIGEN_CONDITION
    assert np.abs(S[well] / oracle[well] - 1).max() <= 1e-9
    assert np.array_equal(S[cond > 1.01 * EIGEN_CONDITION], oracle[cond > 1.01 * EIGEN_CONDITION])
    found = pincal.criteria(params, plans)
    expected = _svd_criteria(J, 12, 3)
    for c, e in zip(found, expected, strict=True):
        for key, value in c.as_dict().items():
            assert value == pytest.approx(e.as_dict()[key], rel=1e-9)
    # One plan alone takes its own path (one LAPACK call, Python floats): the same numbers within
    # the eigenvalue path's accuracy, checked against the SVD's for every plan of the batch.
    for i in (0, 1, 2, 61):
        one = pincal.criteria(params, plans[i]).as_dict()
        for key, value in expected[i].as_dict().items():
            assert one[key] == pytest.approx(value, rel=1e-9)


def test_criteria_of_a_zero_or_rank_deficient_jacobian_raise_singular_plan():
    """A plan whose Jacobian is zero, or has a zero column, is singular, named in its batch; the
    condition test (0 ≥ 0 for a zero M) does not let it through to log(0)."""
    rng = np.random.default_rng(7)
    J = rng.standard_normal((3, 36, 9))
    J[1] = 0.0
    with pytest.raises(SingularPlan, match="^plan 1: singular plan"):
        criteria_of_jacobians(J, 3, 12)
    J[1] = rng.standard_normal((36, 9))
    J[2, :, 4] = 0.0
    with pytest.raises(SingularPlan, match="^plan 2: singular plan"):
        criteria_of_jacobians(J, 3, 12)
    found = criteria_of_jacobians(J[:2], 3, 12)
    expected = _svd_criteria(J[:2], 12, 3)
    for c, e in zip(found, expected, strict=True):
        assert c.as_dict() == pytest.approx(e.as_dict(), rel=1e-9)


def test_criteria_of_plans_are_the_criteria_objects_numbers():
    S = np.sort(np.random.default_rng(5).uniform(0.01, 3.0, (7, 9)), axis=1)[:, ::-1]
    found = criteria_of_plans(S, 5, 3)
    columns = {
        "log_det": DOptimal(3).from_singular_values(S),
        "trace": AOptimal(9, 3).from_singular_values(S),
        "max_eig": EOptimal(3).from_singular_values(S),
        "cond": Condition(3).from_singular_values(S),
        "O1": np.exp(np.mean(np.log(S), axis=1)) / np.sqrt(5),
        "O4": S[:, -1] ** 2 / S[:, 0],
    }
    for i, c in enumerate(found):
        for key, values in columns.items():
            assert getattr(c, key) == values[i]


def test_error_summaries_of_rows_are_each_rows():
    rng = np.random.default_rng(6)
    rows = [(f"set {n}", rng.random(n)) for n in (1, 64, 64, 256, 7, 256, 2, 3, 1000, 1)]
    assert ErrorSummary.of_rows(rows) == [ErrorSummary.of(where, rho) for where, rho in rows]
    for _ in range(100):  # lengths and scales at random, one value included
        rows = [
            ("set", rng.random(int(n)) * 10 ** rng.uniform(-6, 0))
            for n in rng.integers(1, 300, size=rng.integers(1, 6))
            for _ in range(rng.integers(1, 4))
        ]
        assert ErrorSummary.of_rows(rows) == [ErrorSummary.of(where, rho) for where, rho in rows]


def test_a_limit_changed_in_the_model_is_seen():
    robot = pincal.load_robot("kr270", tip="tool0")  # its own model: changed below
    q = robot.random_configurations(3, np.random.default_rng(7))
    assert np.array_equal(robot.configurations(q), q)
    robot.model.upperPositionLimit[1] = q[:, 1].min() - 0.01
    with pytest.raises(BadConfiguration, match="configuration 0: .*joint_a2"):
        robot.configurations(q)
    for bad in (np.nan, np.inf, -np.inf):
        p = q.copy()
        p[2, 3] = bad
        with pytest.raises(BadConfiguration, match="configuration 2"):
            robot.configurations(p)


def test_one_small_plan_is_checked_and_gives_the_criterions_value(kr270_marker):
    params = kr270_marker.parameters("full").identifiable().identifiable
    rng = np.random.default_rng(8)
    plan = kr270_marker.random_configurations(12, rng)
    q0 = kr270_marker.random_configurations(1, rng)[0]
    expected = TestPoseCriterion(params, q0, SIGMA)(plan)
    assert pincal.rho0(params, plan, q0, sigma=SIGMA) == pytest.approx(expected, rel=1e-14)
    assert pincal.rho0(params, plan, q0, sigma=SIGMA) == pincal.rho0(params, plan[None], q0, sigma=SIGMA)[0]
    outside = plan.copy()
    outside[4, 2] = kr270_marker.upper[2] + 0.1
    with pytest.raises(BadConfiguration, match="configuration 4"):
        pincal.rho0(params, outside, q0, sigma=SIGMA)
    with pytest.raises(BadConfiguration, match="joint values"):
        pincal.rho0(params, plan[:, :4], q0, sigma=SIGMA)
    with pytest.raises(BadConfiguration, match="test pose"):
        pincal.rho0(params, plan, np.full(kr270_marker.nq, np.nan), sigma=SIGMA)


def test_one_plans_rho0_over_a_region_follows_the_region(kr270_marker):
    """One plan's ρ0 over a region, asked again and again, is that of the region as it is now:
    after its centre changes in place, the ρ0 over a new region at the new centre; and the value
    of a fresh criterion and of the batch path throughout."""
    params = kr270_marker.parameters("full").identifiable().identifiable
    rng = np.random.default_rng(9)
    plan = kr270_marker.random_configurations(12, rng)
    centre = np.radians([0.0, -60.0, 60.0, 0.0, 45.0, 0.0])
    region = pincal.around(centre, np.radians(10), samples=48)
    first = pincal.rho0(params, plan, region, sigma=SIGMA)
    assert first == pytest.approx(TestPoseCriterion(params, region, SIGMA)(plan), rel=1e-13)
    assert pincal.rho0(params, plan, region, sigma=SIGMA) == first
    centre[1] += 0.2  # the user's array, which the region holds, changed in place
    moved = pincal.rho0(params, plan, region, sigma=SIGMA)
    fresh = pincal.around(centre.copy(), np.radians(10), samples=48)
    assert moved != pytest.approx(first, rel=1e-3)
    assert moved == pytest.approx(TestPoseCriterion(params, fresh, SIGMA)(plan), rel=1e-13)
    assert moved == pytest.approx(pincal.rho0(params, plan[None], region, sigma=SIGMA)[0], rel=1e-12)
    assert pincal.rho0(params, plan, region, sigma=2 * SIGMA) == pytest.approx(2 * moved, rel=1e-13)


def test_an_equal_region_made_anew_finds_the_kept_criterion(kr270_marker, monkeypatch):
    """A script that makes its region anew for every call (``rho0(params, plan, around(q0, r))``)
    builds the region's criterion once: equal regions share it; another width, or the centre
    changed in place, builds its own."""
    module = importlib.import_module("pincal.evaluation.test_pose")
    built = []

    class Counted(module.TestPoseCriterion):
        def __init__(self, *args, **kwargs):
            built.append(args[1])
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(module, "TestPoseCriterion", Counted)
    params = kr270_marker.parameters("full").identifiable().identifiable
    plans = kr270_marker.random_configurations(36, np.random.default_rng(11)).reshape(3, 12, -1)
    centre = np.radians([10.0, -55.0, 65.0, 5.0, 40.0, 0.0])
    values = [pincal.rho0(params, p, pincal.around(centre, np.radians(10), samples=40)) for p in plans]
    assert len(built) == 1
    again = pincal.around(centre.copy(), np.radians(10), samples=40)
    assert pincal.rho0(params, plans[0], again) == values[0]
    assert len(built) == 1
    pincal.rho0(params, plans[0], pincal.around(centre, np.radians(12), samples=40))
    assert len(built) == 2
    region = pincal.around(centre, np.radians(10), samples=40)
    centre[2] += 0.1  # the array the region holds
    moved = pincal.rho0(params, plans[0], region)
    assert len(built) == 3 and moved != values[0]


def _rows(report) -> list[tuple]:
    return [
        (p.name, r.where, r.n, r.rms, r.median, r.p95, r.max, p.from_measurements, p.from_prior)
        for p in report.plans
        for r in p.rows
    ]


def test_accuracy_reports_kept_follow_their_arguments(kr270_marker):
    """accuracy keeps a report's configurations and Jacobians for the same test pose values,
    draws and σ: every call gives what a report computed afresh gives, in any order, for another
    seed, sample count, σ, parameter set, or the same test pose array changed in place."""
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    other = kr270_marker.parameters("full").identifiable().identifiable
    rng = np.random.default_rng(9)
    plan = kr270_marker.random_configurations(12, rng)
    q0 = kr270_marker.random_configurations(1, rng)[0]
    small = dict(samples=16, workspace=32)
    cases = [
        (params, dict(sigma=SIGMA, **small)),
        (params, dict(sigma=SIGMA, seed=1, **small)),
        (params, dict(sigma=SIGMA, samples=8, workspace=32)),
        (params, dict(sigma=2 * SIGMA, **small)),
        (other, dict(sigma=SIGMA, **small)),
        (params, dict(sigma=SIGMA, seed=np.random.default_rng(3), **small)),
    ]

    def fresh(p, kw):
        REPORTS.forget()
        if isinstance(kw.get("seed"), np.random.Generator):
            kw = dict(kw, seed=np.random.default_rng(3))
        return _rows(pincal.accuracy(p, plan, q0, **kw))

    expected = [fresh(p, kw) for p, kw in cases]
    assert len({tuple(rows) for rows in expected[:5]}) == 5  # every case is another report
    REPORTS.forget()
    for _ in range(2):
        for (p, kw), rows in zip(cases, expected, strict=True):
            if isinstance(kw.get("seed"), np.random.Generator):
                kw = dict(kw, seed=np.random.default_rng(3))
            assert _rows(pincal.accuracy(p, plan, q0, **kw)) == rows
    moved = q0.copy()
    before = _rows(pincal.accuracy(params, plan, moved, sigma=SIGMA, **small))
    moved[1] = 0.5 * (moved[1] + kr270_marker.upper[1])
    after = _rows(pincal.accuracy(params, plan, moved, sigma=SIGMA, **small))
    assert after != before
    REPORTS.forget()
    assert after == _rows(pincal.accuracy(params, plan, moved, sigma=SIGMA, **small))
    assert q0.flags.writeable and plan.flags.writeable  # the caller's arrays untouched


def test_a_batchs_rho0_by_bordered_factors_is_the_closed_form(planar):
    """A batch's mean ρ0 comes from one Cholesky factorisation of each bordered matrix
    [[M, W], [Wᵀ, βI]]: against the planar arm's closed form ρ0² = 2σ²(m − cos q20·S)/(m² − S²)
    within 1e-10, a plan of the batch that cannot identify the parameters is named, and more
    weight columns than BORDERED take the triangular solves (the same values within 1e-12)."""
    params = planar.parameters("joint2.tx,tip.tx")
    rng = np.random.default_rng(11)
    plans = rng.uniform(-np.pi, np.pi, (400, 5, 2))
    S = np.cos(plans[:, :, 1]).sum(axis=1)
    plans = plans[5**2 - S**2 > 1e-3 * 5**2]
    S = np.cos(plans[:, :, 1]).sum(axis=1)
    q0 = np.array([0.4, 1.1])
    expected = 2 * SIGMA**2 * (5 - np.cos(q0[1]) * S) / (5**2 - S**2)
    got = pincal.rho0(params, plans, q0, sigma=SIGMA) ** 2
    assert np.abs(got / expected - 1).max() <= 1e-10
    singular = plans[:4].copy()
    singular[1, :, 1] = 0.0  # the arm stretched in every configuration: S = m, M singular
    with pytest.raises(SingularPlan, match="plan 1"):
        pincal.rho0(params, singular, q0, sigma=SIGMA)
    poses = np.array([[0.4, 1.1], [0.1, -0.5], [1.0, 2.0], [0.3, 0.2], [-1.0, 0.7]])
    wide = pincal.rho0(params, plans[:50], poses, sigma=SIGMA)  # 10 weight columns > BORDERED
    one_by_one = [pincal.rho0(params, p, poses, sigma=SIGMA) for p in plans[:50]]
    np.testing.assert_allclose(wide, one_by_one, rtol=1e-12)


def test_batches_longer_than_a_block_are_each_plans_values(kr270_marker):
    """A batch is evaluated block by block (BLOCK plans): over several blocks, rho0 (mean by the
    bordered factors, worst, with a prior) and criteria give each plan's own value, and a singular
    plan in a later block is named by its index in the whole batch, by rho0 and by criteria."""
    from pincal.evaluation.plans import BLOCK

    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    rng = np.random.default_rng(21)
    k = 2 * BLOCK + 5
    plans = kr270_marker.random_configurations(k * 8, rng).reshape(k, 8, -1)
    q0 = kr270_marker.random_configurations(1, rng)
    for kw in ({}, {"aggregate": "worst"}, {"prior": pincal.Prior(1e-3, 1e-3)}):
        one = [pincal.rho0(params, p, q0, sigma=SIGMA, **kw) for p in plans]
        np.testing.assert_allclose(pincal.rho0(params, plans, q0, sigma=SIGMA, **kw), one, rtol=1e-12)
    for c, p in zip(pincal.criteria(params, plans), plans, strict=True):
        expected = pincal.criteria(params, p).as_dict()
        for key, value in c.as_dict().items():
            assert value == pytest.approx(expected[key], rel=1e-9)
    singular = plans.copy()
    singular[BLOCK + 3] = singular[BLOCK + 3][0]  # eight times the same configuration
    for evaluate in (
        lambda: pincal.rho0(params, singular, q0, sigma=SIGMA),
        lambda: pincal.criteria(params, singular),
    ):
        with pytest.raises(SingularPlan, match=f"^plan {BLOCK + 3}: singular plan") as info:
            evaluate()
        assert info.value.plan == BLOCK + 3
    with pytest.raises(SingularPlan, match="^plan 0: singular plan: 2 configuration") as info:
        pincal.criteria(params, plans[:, :2])  # fewer coordinates than parameters


def _boxes_drawn_one_by_one(robot, q0, deltas, samples, workspace, seed):
    """What an accuracy report drew before its boxes were drawn in one call: per box, a centre
    chosen (one test pose: no draw) and NumPy's uniform(-δ, δ), clipped; then the workspace."""
    rng = np.random.default_rng(seed)
    out = []
    for delta in deltas:
        centres = q0[None][rng.integers(1, size=samples)]
        out.append(np.clip(centres + rng.uniform(-delta, delta, centres.shape), robot.lower, robot.upper))
    return out + [robot.random_configurations(workspace, rng)]


@pytest.mark.parametrize("name", ["kr270", "rail", "long track"])
def test_an_accuracy_reports_draws_are_numpys_uniform_boxes(kr270_marker, name, tmp_path):
    """One test pose: the neighbourhoods' draws come from one call, the numbers NumPy's uniform
    draws box by box make of the same stream, bit for bit (a prismatic joint included, one of
    10 m too: the workspace is drawn over its whole length, as random configurations are)."""
    robot = kr270_marker if name == "kr270" else pincal.load_robot(ROOT / "robots" / "rail_arm.urdf")
    if name == "long track":
        text = (ROOT / "robots" / "rail_arm.urdf").read_text(encoding="utf-8")
        (tmp_path / "long.urdf").write_text(
            text.replace('lower="0.0" upper="1.5"', 'lower="-4.0" upper="6.0"')
        )
        robot = pincal.load_robot(tmp_path / "long.urdf")
        assert robot.upper[0] == 6.0
    per_radian = np.where(robot.revolute, 1.0, accuracy_samples.PRISMATIC_PER_RADIAN)
    for seed in range(20):
        q0 = robot.random_configurations(1, seed + 100)[0]
        widths = (np.radians(10), np.radians(20), np.radians(45))[: 1 + seed % 3]
        sets, poses, region = accuracy_samples.sample_sets(robot, q0, widths, 5 + seed, 7, seed)
        expected = _boxes_drawn_one_by_one(robot, q0, [w * per_radian for w in widths], 5 + seed, 7, seed)
        assert region is None and np.array_equal(poses, q0[None])
        prismatic = not robot.revolute.all()
        labels = [
            width_text(w, w * accuracy_samples.PRISMATIC_PER_RADIAN if prismatic else None) for w in widths
        ]
        assert [where for where, _ in sets[1:-1]] == labels
        for (_, drawn), reference in zip(sets[1:], expected, strict=True):
            assert np.array_equal(drawn, reference)


def test_an_accuracy_reports_jacobians_are_each_sets_own(kr270_marker):
    """The report's Jacobians from one pass over every set are each set's own, bit for bit, read-only;
    ρ over every set at once is each set's own; the test poses' split of ρ0² is TestPoseCriterion's
    (with a prior and an instrument too)."""
    module = importlib.import_module("pincal.evaluation.accuracy")
    params = kr270_marker.parameters("full").identifiable().identifiable
    engine = engine_for(params)
    assert engine.plain  # the one-pass path
    rng = np.random.default_rng(10)
    q0 = kr270_marker.random_configurations(2, rng)
    sets, _, _ = accuracy_samples.sample_sets(kr270_marker, q0, samples=40, workspace=90, seed=4)
    jacobians = module._set_jacobians(engine, sets, None)
    for (where, J), (name, qs) in zip(jacobians, sets, strict=True):
        assert where == name and not J.flags.writeable
        assert np.array_equal(J, engine.jacobian(qs, frame="tip"))
    plan = kr270_marker.random_configurations(14, rng)
    predicted = PredictedError(params, plan, SIGMA)
    views = [J for _, J in jacobians]
    for rho, J in zip(predicted.at_sets(views), views, strict=True):
        assert np.array_equal(rho, np.sqrt(predicted.squared_at(J)))
    for prior, instrument in (
        (None, None),
        (pincal.Prior(1e-3, 1e-3), None),
        (None, Instrument(Point(), Tracker(at=(3.0, 1.0, 0.5)))),
    ):
        measuring = {"sigma": SIGMA} if instrument is None else {"instrument": instrument}
        report = pincal.accuracy(params, plan, q0, prior=prior, samples=20, workspace=40, **measuring)
        sigma = SIGMA if instrument is None else None  # the instrument's own σ
        predicted = PredictedError(params, plan, sigma, prior, instrument=instrument)
        criterion = TestPoseCriterion(params, q0, sigma, "each", prior, instrument=instrument)
        noise, bias = criterion.split(predicted.information, len(plan))
        assert report.plans[0].from_measurements == float(np.sqrt(noise.mean()))
        assert report.plans[0].from_prior == float(np.sqrt(bias.mean()))


@pytest.mark.parametrize("markers", [2, 3])
def test_several_markers_regressors_kept_whole_are_the_rows_written_one_by_one(markers):
    """With several markers (no pose asked) the engine keeps each regressor whole and takes the
    linear rows at the end: the rows the pose path writes one configuration and marker at a time,
    bit for bit, and the Jacobian the finite differences give."""
    points = [(0.1, 0.05, 0.2), (-0.1, 0.02, 0.1), (0.0, 0.1, 0.05)][:markers]
    robot = pincal.load_robot("kr270", tip="tool0", markers=points)
    params = robot.parameters("full,offsets").identifiable().identifiable
    engine = JacobianEngine(params)
    assert not engine.plain
    for m in (1, 5, 40):  # within one chunk and across chunks
        qs = robot.random_configurations(m, np.random.default_rng(m))
        kept, rotations, _ = engine._regressors(qs, pose=False)
        assert rotations is None and kept.shape == (m, 3 * markers, 6 * robot.nq)
        assert np.array_equal(kept, engine._regressors(qs, pose=True)[0])
    # the tip-frame rows (this path) against central differences of the world points: each
    # configuration's rows differ by the tip's rotation, so their Gram matrices JᵢᵀJᵢ agree
    qs = robot.random_configurations(3, np.random.default_rng(11))
    tip = engine.jacobian(qs, frame="tip")
    fd = params.jacobian(qs, method="fd")
    gram = np.einsum("mrp,mrq->mpq", tip, tip)
    assert np.allclose(gram, np.einsum("mrp,mrq->mpq", fd, fd), rtol=0, atol=1e-6 * np.abs(gram).max())
