"""A multistart never aborts on one degenerate start: a start none of whose random plans is regular
is dropped and counted (the result's ``dropped``, its message, the JSON's ``dropped_starts``, the
CLI's report), the plan is the best of the others, and only when every start fails is the error
raised, saying so. The real case: an eye-in-hand camera on a Panda (notebook 05's rig) designing
from a pool of configurations drawn without looking at the target, where a random plan of 20
views often reads too little of the grid to be regular. A generated pool holds only views that
read enough of it (pincal.planning.views): the README's ``--camera rig.yaml`` design drops no
start."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.cli.example import example_text
from pincal.errors import SingularPlan
from pincal.instruments import Instrument, PerCoordinate, load_rig
from pincal.instruments.identifiability import identifiable
from pincal.planning import search as _search
from pincal.planning import starts as _starts
from pincal.planning.constraints import with_safety
from pincal.planning.feasibility import Feasibility

pytestmark = pytest.mark.filterwarnings("ignore::pincal.errors.DegenerateOptimumWarning")

RIG = example_text("rig")
"""Notebook 05's rig (the README's rig.yaml): a camera on the hand seeing a 6 x 5 grid on the floor."""

PANDA_Q0 = "0,-0.3,0,-2.2,0,2,0.8"

KR_Q0 = np.radians([0, -60, 60, 0, 45, 0])


@pytest.fixture(scope="module")
def rig_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("rig") / "rig.yaml"
    path.write_text(RIG)
    return path


@pytest.fixture(scope="module")
def camera(rig_file):
    """(parameters, measure, instrument) of the camera design."""
    rig = load_rig(rig_file)
    panda = pincal.load_robot("panda").with_fixtures(*rig.fixtures)
    pixels = PerCoordinate(sigma_px=rig.pixel_sigma)
    params = identifiable(panda.parameters("full,offsets,instrument"), Instrument(rig.kind, pixels))
    return params.identifiable, rig.kind, pixels


@pytest.fixture(scope="module")
def blind_pool(camera):
    """2000 feasible Panda configurations drawn without looking at the target (as a generated
    pool was before): one in nineteen reads enough of the grid."""
    robot = camera[0].robot
    return Feasibility(robot, with_safety(robot)).sample(2000, np.random.default_rng(1))


def _design(camera, search: pincal.Search) -> pincal.DesignResult:
    """The camera design of 20 views for the README's test pose."""
    params, kind, pixels = camera
    q0 = np.array([float(v) for v in PANDA_Q0.split(",")])
    return pincal.design(params, 20, q0, instrument=Instrument(kind, pixels), search=search)


@pytest.fixture(scope="module")
def kr_params(kr270_marker):
    return kr270_marker.parameters("lengths,offsets").identifiable().identifiable


@pytest.fixture
def singular_starts(monkeypatch):
    """``singular_starts({0, 2})``: those starts fail as a start none of whose plans is regular
    does (in this process and, forked, in the workers)."""

    def force(starts: set[int]) -> None:
        draw = _starts.draw_start

        def drawn(J, pool, m, spacing, seed, *args, **kwargs):
            if seed.spawn_key[1] in starts:
                raise SingularPlan(J.shape[2], J.shape[1], m, J.shape[2] - 1)
            return draw(J, pool, m, spacing, seed, *args, **kwargs)

        monkeypatch.setattr(_starts, "draw_start", drawn)  # the workers' (multistart)
        monkeypatch.setattr(_search, "draw_start", drawn)  # the parent's (the first starts)

    return force


def test_the_camera_design_drops_its_degenerate_starts(camera, blind_pool):
    result = _design(camera, pincal.Search(seed=0, starts=4, workers=1, pool=blind_pool))
    dropped = [h.start for h in result.history if h.message.startswith("degenerate, dropped")]
    assert 0 < result.dropped == len(dropped) < result.starts == 4
    assert f"{result.dropped} of 4 starts were degenerate and dropped" in result.message
    assert result.as_dict()["dropped_starts"] == result.dropped
    kept = [h for h in result.history if h.start not in dropped]
    assert result.value == pytest.approx(min(h.value for h in kept), rel=1e-9)
    assert all(np.isinf(result.history[s].value) for s in dropped)


def test_the_camera_design_draws_its_starts_where_the_grid_is_read(camera):
    # Before the generated pool held only views that read enough of the grid, 9 in 10 of its
    # candidates read nothing and every start of this design was degenerate (SingularPlan).
    params, kind, _ = camera
    result = _design(camera, pincal.Search(seed=1, starts=4, polish=False, workers=1))
    assert result.dropped == 0 and "degenerate" not in result.message
    assert all(np.isfinite(h.value) for h in result.history)
    # Unpolished, the plan is made of pool candidates: each reads (p >= 0.9) three corners or more,
    # not in a line (the grid's points span a plane)
    engine = pincal.model.jacobian.JacobianEngine(params)
    read = kind.weights(engine, result.plan.q, kind.rows(engine, result.plan.q))[:, ::2] > 0
    for corners in read:
        points = kind.points[corners]
        assert len(points) >= 3 and np.linalg.matrix_rank(points - points.mean(axis=0)) == 2


def test_the_readme_camera_command_reports_what_it_dropped(cli, rig_file, blind_pool, tmp_path):
    argv = ["design", "panda", "-m", "20", f"--test-pose={PANDA_Q0}", "--camera", rig_file]
    fast = ["--seed", "1", "--starts", "4", "--no-polish", "--workers", "1", "--no-progress"]
    data = cli.json(*argv, *fast)
    assert data["dropped_starts"] == 0 and "degenerate" not in data["message"]
    pool = tmp_path / "pool.csv"
    pincal.Plan.for_robot(pincal.load_robot("panda"), blind_pool).to_csv(pool)
    blind = ["--seed", "0", "--starts", "4", "--workers", "1", "--no-progress", "--pool", pool]
    code, out, err = cli.run(*argv, *blind, "--out", tmp_path / "plan.csv")
    assert code == 0, err
    assert "of 4 starts were degenerate and dropped" in out
    data = cli.json(*argv, *blind)
    assert 0 < data["dropped_starts"] < 4 and "were degenerate and dropped" in data["message"]


@pytest.mark.parametrize("method", ["exchange", "continuous"])
def test_the_best_of_the_other_starts_is_returned(kr_params, singular_starts, method):
    # each start's value is its plan's: no polish
    search = pincal.Search(
        starts=4, seed=5, method=method, workers=1, polish=False if method == "exchange" else None
    )
    kw = dict(test_pose=KR_Q0, search=search)
    whole = pincal.design(kr_params, 6, **kw)
    singular_starts({0, 2})
    some = pincal.design(kr_params, 6, **kw)
    assert some.dropped == 2 and whole.dropped == 0
    assert "2 of 4 starts were degenerate and dropped" in some.message
    assert "degenerate" not in whole.message
    for s in (0, 2):
        assert some.history[s].message.startswith("degenerate, dropped: singular plan")
        assert not some.history[s].continued
    if method == "continuous":  # which starts the screening continues depends on the others: the
        # design is the best of those that ended
        ended = [h.value for s, h in enumerate(some.history) if s in (1, 3) and h.continued]
        assert ended and some.value == pytest.approx(min(ended), rel=1e-9)
        return
    for s in (1, 3):  # the others end where they ended
        assert _ended(some.history[s]) == _ended(whole.history[s])
    best = min((1, 3), key=lambda s: whole.history[s].value)
    assert some.value == pytest.approx(whole.history[best].value, rel=1e-9)


def test_dropped_starts_on_workers_and_the_d_optimal_baseline(kr_params, singular_starts):
    singular_starts({1})
    kw = dict(test_pose=KR_Q0, with_d_optimal=True)
    serial = pincal.design(kr_params, 5, **kw, search=pincal.Search(starts=3, seed=3, workers=1))
    processes = pincal.design(
        kr_params, 5, **kw, search=pincal.Search(starts=3, seed=3, workers=2)
    )  # start 1 fails in a worker
    for result in (serial, processes, serial.d_optimal, processes.d_optimal):
        assert result.dropped == 1
    np.testing.assert_array_equal(serial.plan.q, processes.plan.q)
    np.testing.assert_array_equal(serial.d_optimal.plan.q, processes.d_optimal.plan.q)


@pytest.mark.parametrize("method", ["exchange", "continuous"])
def test_when_every_start_fails_the_error_says_so(kr_params, singular_starts, method):
    singular_starts({0, 1, 2})
    with pytest.raises(SingularPlan, match=r"all 3 starts were degenerate \(the first: singular plan"):
        pincal.design(kr_params, 6, KR_Q0, search=pincal.Search(starts=3, method=method, workers=1))


def test_a_design_with_payloads_drops_them_too(kr_params, singular_starts):
    # The same pipeline: its starts are drawn by the same draw_start, dropped the same way.
    kw = dict(search=pincal.Search(starts=3, seed=2, pool=200, workers=1), loads=pincal.Loads([0, 100]))
    whole = pincal.design(kr_params, 6, KR_Q0, **kw)
    singular_starts({1})
    some = pincal.design(kr_params, 6, KR_Q0, **kw)
    assert some.dropped == 1 and "1 of 3 starts were degenerate and dropped" in some.message
    assert some.history[1].message.startswith("degenerate, dropped")
    assert [_ended(some.history[s]) for s in (0, 2)] == [_ended(whole.history[s]) for s in (0, 2)]


def _ended(record) -> tuple:
    """Where a start ended (its record but the time it took)."""
    return record.value, record.screen_value, record.iterations, record.continued, record.message
