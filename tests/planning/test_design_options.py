"""design()'s options as values (Search, Safety, Loads, an Instrument): one pipeline for every
design, the flat keywords of pincal 0.1 still working (deprecated) with identical results, and what
the second driver let drift now refused the same way everywhere."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest

import pincal
from pincal import arguments
from pincal.errors import BadArgument
from pincal.instruments import Instrument, PerCoordinate, Point, Pose, Tracker
from pincal.model.residual import ResidualModel

Q0 = np.radians([0, -60, 60, 0, 45, 0])
SIGMA = 3e-5
pytestmark = pytest.mark.filterwarnings("ignore::pincal.errors.DegenerateOptimumWarning")


@pytest.fixture(scope="module")
def robot():
    return pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])


@pytest.fixture(scope="module")
def params(robot):
    return robot.parameters("lengths,offsets").identifiable().identifiable


@pytest.fixture(scope="module")
def loaded(robot):
    return robot.parameters("lengths,offsets,compliance").identifiable(payloads=[0, 100]).identifiable


def _residual_model(robot) -> ResidualModel:
    q = robot.random_configurations(5, 0)
    zeros = np.zeros((5, 3 * robot.n_markers))
    return ResidualModel(robot.revolute, q, zeros, 3e-4, np.full(2 * robot.nq, 0.6), 1e-5)


def _cases(robot):
    """name -> (which params, m, flat keywords of 0.1, the same as values)."""
    tracker = Tracker((3.0, 0.0, 1.5))
    fast = dict(starts=2, seed=3, workers=1, pool=200)
    return {
        "exchange": ("params", 8, dict(sigma=SIGMA, **fast), dict(sigma=SIGMA, search=pincal.Search(**fast))),
        "continuous": (
            "params", 8,
            dict(method="continuous", starts=2, seed=1, workers=1, keep=0.5, screen_iterations=3,
                 maxiter=400),
            dict(search=pincal.Search(method="continuous", starts=2, seed=1, workers=1, keep=0.5,
                                      screen_iterations=3, maxiter=400)),
        ),
        "safety": (
            "params", 8,
            dict(fast, clearance=0.02, joint_margin=0.05, mount="none", min_conditioning=1e-3),
            dict(search=pincal.Search(**fast),
                 safety=pincal.Safety((), 0.05, "none", 0.02, 1e-3)),
        ),
        "payloads": (
            "loaded", 10,
            dict(fast, payloads=[0, 100], task_payload=50.0, sigma=SIGMA),
            dict(sigma=SIGMA, search=pincal.Search(**fast), loads=pincal.Loads([0, 100], 50.0)),
        ),
        "a kind and an error model": (
            "params", 6,
            dict(fast, measure=Pose(), instrument=PerCoordinate(1e-4, 1e-3), sigma=1.0),  # sigma unused
            dict(instrument=Instrument(Pose(), PerCoordinate(1e-4, 1e-3)), search=pincal.Search(**fast)),
        ),
        "an error model alone": (
            "params", 8,
            dict(fast, instrument=tracker),
            dict(instrument=Instrument(Point(), tracker), search=pincal.Search(**fast)),
        ),
        "a residual model": (
            "params", 8,
            dict(fast, residual_model=_residual_model(robot), sigma=SIGMA),
            dict(sigma=SIGMA, residual_model=_residual_model(robot), search=pincal.Search(**fast)),
        ),
    }  # fmt: skip


CASE_NAMES = ("exchange", "continuous", "safety", "payloads", "a kind and an error model",
              "an error model alone", "a residual model")  # fmt: skip


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.plan.q, b.plan.q)
    assert (a.plan.payload is None) == (b.plan.payload is None)
    if a.plan.payload is not None:
        np.testing.assert_array_equal(a.plan.payload, b.plan.payload)
    assert (a.value, a.rho0, a.conditioning, a.criterion, a.sigma, a.seed) == (
        b.value, b.rho0, b.conditioning, b.criterion, b.sigma, b.seed,
    )  # fmt: skip
    assert [h.value for h in a.history] == [h.value for h in b.history]
    assert a.method == b.method and a.starts == b.starts
    assert repr(a.instrument) == repr(b.instrument)


@pytest.mark.parametrize("name", CASE_NAMES)
def test_the_flat_keywords_and_the_values_design_the_same_plan(robot, params, loaded, name):
    which, m, flat, values = _cases(robot)[name]
    p = {"params": params, "loaded": loaded}[which]
    with pytest.warns(
        DeprecationWarning,
        match=r"design\(\): (the flat keywords|measure= and an error model as instrument=) are deprecated",
    ) as caught:
        old = pincal.design(p, m, Q0, **flat)
    assert {w.filename for w in caught if w.category is DeprecationWarning} == {__file__}  # the caller's line
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = pincal.design(p, m, Q0, **values)
    _same(old, new)
    if name == "payloads":  # the plan chose payloads, ρ0 is under the task's
        assert set(new.plan.payload[:, 0]) <= {0.0, 100.0} and "payload" in new.method
        assert new.rho0 == pytest.approx(
            pincal.rho0(p, new.plan, Q0, sigma=SIGMA, task_payload=50.0), rel=1e-9
        )
    if name == "a residual model":
        assert new.criterion == "test-pose-gp" and new.value > 0


def test_the_warning_names_the_values_to_write(params):
    with pytest.warns(DeprecationWarning) as caught:
        pincal.design(params, 8, Q0, starts=1, workers=1, pool=100, clearance=0.02, payloads=[0.0])
    message = str(caught[0].message)
    parts = ("search=pincal.Search(starts=..., workers=..., pool=...)", "safety=pincal.Safety(clearance=...)")
    for part in (*parts, "loads=pincal.Loads(payloads=...)", "pincal 0.3"):
        assert part in message, message


def test_arguments_by_position_keep_their_0_1_meaning(params):
    # criterion, method, constraints, pool, starts, seed, sigma: pincal 0.1's order
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = pincal.design(params, 8, Q0, "D", "exchange", (), 200, 2, 4, SIGMA)
    assert {w.category for w in caught} == {DeprecationWarning}
    assert "passing criterion, method, constraints, pool, starts, seed, sigma by position" in str(
        caught[0].message
    )
    new = pincal.design(
        params, 8, Q0, criterion="D", sigma=SIGMA, search=pincal.Search(pool=200, starts=2, seed=4)
    )
    _same(old, new)


def test_a_flat_keyword_and_its_value_together_are_refused(params):
    with pytest.raises(TypeError, match=r"got starts and search=: put them in search="):
        pincal.design(params, 8, Q0, starts=2, search=pincal.Search(workers=1))


def test_the_values_are_checked(params):
    with pytest.raises(BadArgument, match=r"search= takes a pincal.Search\(...\)"):
        pincal.design(params, 8, Q0, search={"starts": 2})  # type: ignore[arg-type]
    with pytest.raises(BadArgument, match=r"safety= takes a pincal.Safety"):
        pincal.design(params, 8, Q0, safety=pincal.Search())  # type: ignore[arg-type]
    with pytest.raises(BadArgument, match="give sigma= .* or instrument= .*not both"):
        pincal.design(params, 8, Q0, sigma=SIGMA, instrument=Instrument(Pose(), PerCoordinate(1e-4)))
    with pytest.raises(BadArgument, match=r"instrument= takes a pincal.instruments.Instrument\("):
        pincal.design(params, 8, Q0, instrument=Pose())  # type: ignore[arg-type]
    with pytest.raises(BadArgument, match="sigma must be a positive number of metres"):
        pincal.design(params, 8, Q0, sigma=-1.0)


# ---------------------------------------------------------------- one pipeline, one set of rules
def test_a_zero_floor_without_a_prior_is_refused_with_payloads_too(robot, params, loaded):
    """The drift of the second driver: it accepted min_conditioning=0 without a prior; the one
    pipeline refuses it the same way whatever loads the robot or scores the plan."""
    zero = pincal.Safety(min_conditioning=0)
    fast = pincal.Search(starts=1, workers=1, pool=100)
    messages = []
    for p, extra in (
        (params, {}),
        (loaded, dict(loads=pincal.Loads([0, 100]))),
        (loaded, dict(loads=pincal.Loads(task_payload=50.0))),
        (params, dict(residual_model=_residual_model(robot))),
    ):
        with pytest.raises(BadArgument) as raised:
            pincal.design(p, 10, Q0, safety=zero, search=fast, **extra)
        messages.append(str(raised.value))
    assert len(set(messages)) == 1 and "min_conditioning (0 only with a prior)" in messages[0]
    # With a prior, 0 is the default floor and allowed: with payloads as without.
    prior = pincal.Prior(1e-3, 1e-3)
    for p, extra in ((params, {}), (loaded, dict(loads=pincal.Loads([0, 100])))):
        result = pincal.design(p, 6, Q0, sigma=SIGMA, prior=prior, safety=zero, search=fast, **extra)
        assert "conditioning floor 0" in result.message


def test_a_payload_design_runs_the_same_multistart(loaded):
    """The adaptive starts, the workers and the executor: a payload design is no serial copy."""
    loads = pincal.Loads([0, 100], 50.0)
    auto = pincal.design(loaded, 10, Q0, sigma=SIGMA, loads=loads, search=pincal.Search(pool=150, workers=1))
    assert auto.adaptive and auto.starts >= 8 and auto.matched is not None
    serial = pincal.design(
        loaded, 10, Q0, sigma=SIGMA, loads=loads, search=pincal.Search(pool=150, starts=3, workers=1)
    )
    parallel = pincal.design(
        loaded, 10, Q0, sigma=SIGMA, loads=loads, search=pincal.Search(pool=150, starts=3, workers=2)
    )
    _same(serial, parallel)
    with pytest.raises(BadArgument, match="continuous search cannot choose among discrete payloads"):
        pincal.design(loaded, 10, Q0, loads=loads, search=pincal.Search(polish=True))


def test_sigma_is_checked_once_at_the_door(params):
    """σ becomes an Instrument at design()'s door (its error model checks it) and nothing below
    the door checks it again; the final ρ0 is the evaluation's own public function (which checks
    what it is given)."""
    callers: list[str] = []
    code = arguments.positive_sigma.__code__

    def profile(frame, event, arg):
        if event == "call" and frame.f_code is code:
            callers.append(frame.f_back.f_code.co_filename.replace("\\", "/").split("/pincal/")[-1])

    sys.setprofile(profile)
    try:
        pincal.design(params, 8, Q0, sigma=SIGMA, search=pincal.Search(starts=2, workers=1, pool=200))
    finally:
        sys.setprofile(None)
    # the error model at the door; the final ρ0's criterion through the one door of what it is given
    assert sorted(callers) == ["instruments/error_model.py", "instruments/given.py"], callers
