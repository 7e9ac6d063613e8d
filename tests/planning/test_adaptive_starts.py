"""A multistart that knows when to stop (``starts=None``, :mod:`pincal.planning.stopping`): batches
of 8 starts until 3 match the best within 1 % or 128 have run; ``starts=N`` runs exactly N, as
before; start k draws from its own seed whatever the batching."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.planning import stopping as _stopping

pytestmark = pytest.mark.filterwarnings("ignore::pincal.errors.DegenerateOptimumWarning")

KR_Q0 = np.radians([0, -90, 90, 0, 45, 0])


@pytest.fixture(scope="module")
def lengths(planar):
    """The planar 2R arm's two lengths: every start reaches the closed-form optimum (easy)."""
    return planar.parameters("joint2.tx,tip.tx")


@pytest.fixture(scope="module")
def kr_params(kr270_marker):
    return kr270_marker.parameters("lengths,offsets").identifiable().identifiable


def hard(kr_params, **options):
    """KR 270, 4 configurations for one test pose, exchange only over a small pool: its starts end
    in many local optima (they disagree)."""
    search = pincal.Search(**{**dict(polish=False, pool=300, workers=1, seed=2), **options})
    safety = pincal.Safety(joint_margin=0, mount="none")
    return pincal.design(kr_params, 4, KR_Q0, sigma=1.0, search=search, safety=safety)


def same(a, b) -> None:
    """Two designs are the same bit for bit: plan, value, every start's record but its time."""
    np.testing.assert_array_equal(a.plan.q, b.plan.q)
    assert a.value == b.value and a.starts == b.starts
    strip = [{**h.as_dict(), "time_s": 0} for h in a.history]
    assert strip == [{**h.as_dict(), "time_s": 0} for h in b.history]


def test_matched_counts_the_starts_near_the_best():
    assert _stopping.TOLERANCE == 0.01
    assert _stopping.matched([1.0, 1.009, 1.011, math.inf]) == 2
    assert _stopping.matched([1.0, 1.004, 1.006], tolerance=0.005) == 2
    assert _stopping.matched([math.inf, math.inf]) == 0
    # D: log det M⁻¹, within the tolerance means det M⁻¹ within it (an additive log(1.01)).
    assert _stopping.matched([-42.0, -42.009, -41.99], log_scale=True) == 2
    assert _stopping.enough([2.0, 2.001, 2.019, 2.0]) and not _stopping.enough([2.0, 2.001, 3.0])


def test_explicit_starts_run_exactly_that_many(lengths, kr_params):
    for n in (1, 5, 8, 11):
        result = pincal.design(
            lengths, 2, test_pose=[0.0, 1.0], sigma=1.0, search=pincal.Search(starts=n, workers=1)
        )
        assert result.starts == len(result.history) == n and not result.adaptive
        assert "adaptive" not in result.message and result.as_dict()["starts_adaptive"] is False
    # A hard case where the adaptive default would add starts: still exactly 8.
    assert hard(kr_params, starts=8).starts == 8


def test_adaptive_default_stops_after_the_first_batch_when_the_starts_agree(lengths):
    auto = pincal.design(lengths, 2, test_pose=[0.0, 1.0], sigma=1.0, search=pincal.Search(workers=1))
    assert auto.adaptive and auto.starts == _stopping.BATCH
    assert auto.matched >= _stopping.AGREE
    assert f"adaptive: {auto.matched} within 1 % of the best" in auto.message
    # The first batch is a design of 8 starts: the same design bit for bit.
    same(
        auto,
        pincal.design(lengths, 2, test_pose=[0.0, 1.0], sigma=1.0, search=pincal.Search(workers=1, starts=8)),
    )
    data = auto.as_dict()
    assert (data["starts"], data["starts_adaptive"], data["starts_matched"]) == (8, True, auto.matched)


def test_adaptive_default_adds_batches_while_the_starts_disagree(kr_params):
    first = hard(kr_params, starts=_stopping.BATCH)
    assert _stopping.matched([h.value for h in first.history]) < _stopping.AGREE
    auto = hard(kr_params)
    assert auto.starts > _stopping.BATCH and auto.starts % _stopping.BATCH == 0
    assert auto.matched >= _stopping.AGREE or auto.starts == _stopping.CAP
    assert auto.value <= first.value
    # Start k draws its plan from its own seed whatever the batching: the adaptive design's starts
    # are those of a design with as many starts, one by one.
    same(auto, replace_adaptive(hard(kr_params, starts=auto.starts)))


def replace_adaptive(result):
    """``result`` as the adaptive design reports it (for comparing the starts)."""
    from dataclasses import replace

    return replace(result, adaptive=True)


def test_the_same_starts_whatever_the_workers(kr_params):
    serial = hard(kr_params)
    processes = hard(kr_params, workers=2)
    same(serial, processes)


def test_the_cap_holds(kr_params, monkeypatch):
    monkeypatch.setattr(_stopping, "AGREE", 10**6)  # never enough: the cap ends the search
    monkeypatch.setattr(_stopping, "CAP", 24)
    auto = hard(kr_params)
    assert auto.starts == len(auto.history) == 24 and auto.adaptive


def test_cli_starts_auto_and_its_report(cli):
    argv = ["design", "planar_2r", "-m", "2", "--test-pose=0,1", "--params", "joint2.tx,tip.tx"]
    argv += ["--workers", "1"]
    data = cli.json(*argv)
    assert (data["starts"], data["starts_adaptive"]) == (8, True) and data["starts_matched"] >= 3
    assert cli.json(*argv, "--starts", "auto")["plan"] == data["plan"]
    exact = cli.json(*argv, "--starts", "5")
    assert (exact["starts"], exact["starts_adaptive"]) == (5, False)
    code, out, _ = cli.run(*argv, "--no-progress")
    assert code == 0 and f"8 starts (auto: {data['starts_matched']} within 1 % of the best)" in out
    cli.fails(*argv, "--starts", "0", match="--starts")
