"""One carrier of what is measured and how well (pincal.instruments.given): every public function
takes ``instrument=`` (an Instrument) or its shorthand ``sigma=``, never both; pincal 0.1's
``measure=`` and error model as ``instrument=`` keep working, warned at the caller's line, with the
same numbers as the Instrument they stand for."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pincal
from pincal.errors import BadArgument
from pincal.instruments import Instrument, PerCoordinate, Point, Pose, Tracker
from pincal.instruments.given import instrument_of, measured, old_instrument
from pincal.planning.placement_options import old_placed

Q0 = np.array([0.0, -1.2, 1.5, -1.0, -1.5, 0.0])
OLD = (
    r"\w+\(\): measure= and an error model as instrument= are deprecated: write "
    r"instrument=pincal\.instruments\.Instrument\("
)
MOCAP = PerCoordinate(1e-4, 2e-3)
pytestmark = pytest.mark.ur10(markers=[(0.05, 0.02, 0.1)])  # the ur10 fixture (tests/conftest.py)


@pytest.fixture(scope="module")
def setting(ur10):
    params = ur10.parameters("full,offsets").identifiable().identifiable  # by points, so by poses too
    return ur10, params, ur10.random_configurations(14, 1)


def _families(ur10, params, plan):
    """(name, the call with the keywords of what is measured): one per public function."""
    return {
        "rho0": lambda **kw: pincal.rho0(params, plan, Q0, **kw),
        "rho0_each": lambda **kw: pincal.evaluation.rho0_each(params, plan, [Q0, Q0 * 0.5], **kw),
        "accuracy": lambda **kw: pincal.accuracy(params, plan, Q0, samples=8, workspace=8, **kw).as_dict(),
        "error_profile": lambda **kw: pincal.evaluation.error_profile(
            params, {"p": plan}, Q0, steps=2, samples=8, **kw
        )[0].as_dict(),
        "random_plans": lambda **kw: pincal.random_plans(params, 8, 4, Q0, seed=1, **kw).values,
        "simulate_measurements": lambda **kw: pincal.simulate_measurements(ur10, plan, seed=2, **kw).values,
        "monte_carlo": lambda **kw: pincal.monte_carlo(params, plan, Q0, trials=2, seed=3, **kw).as_dict(),
    }


def _equal(a, b) -> None:
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            _equal(a[key], b[key])
    elif isinstance(a, (list, tuple, np.ndarray)):
        np.testing.assert_array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object))
    else:
        assert a == b or (a != a and b != b), (a, b)  # NaN == NaN here


@pytest.mark.parametrize(
    "old, new",
    [
        (dict(measure=Pose(), sigma=1e-4), Instrument(Pose(), PerCoordinate(1e-4))),
        (dict(measure=Pose(), instrument=MOCAP), Instrument(Pose(), MOCAP)),
        (
            dict(instrument=Tracker(at=(3.0, 1.0, 0.5)), sigma=1e-5),
            Instrument(Point(), Tracker(at=(3.0, 1.0, 0.5))),
        ),
    ],
    ids=["a kind and sigma", "a kind and an error model", "an error model alone"],
)
def test_the_0_1_form_warns_and_gives_the_instrument_s_numbers(setting, old, new):
    for name, call in _families(*setting).items():
        with pytest.warns(DeprecationWarning, match=OLD) as caught:
            before = call(**old)
        assert {w.filename for w in caught} == {__file__}, name  # the caller's line
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            after = call(instrument=new)
        _equal(before, after)


def test_criteria_and_design_take_the_0_1_form_too(setting):
    ur10, params, plan = setting
    with pytest.warns(DeprecationWarning, match=OLD):
        old = pincal.criteria(params, plan, measure=Pose(), instrument=MOCAP)
    assert old == pincal.criteria(params, plan, instrument=Instrument(Pose(), MOCAP))
    search = pincal.Search(starts=1, workers=1, pool=100, seed=1, polish=False)
    with pytest.warns(DeprecationWarning, match=OLD):
        before = pincal.design(params, 8, Q0, measure=Pose(), instrument=MOCAP, search=search)
    after = pincal.design(params, 8, Q0, instrument=Instrument(Pose(), MOCAP), search=search)
    np.testing.assert_array_equal(before.plan.q, after.plan.q)
    assert (before.value, before.rho0) == (after.value, after.rho0)


def test_identify_pairs_a_0_1_error_model_with_the_data_s_kind(setting):
    ur10, params, plan = setting
    truth = pincal.random_errors(params, seed=4)
    data = pincal.simulate_measurements(truth, plan, seed=5, instrument=Instrument(Pose(), MOCAP))
    with pytest.warns(
        DeprecationWarning, match=r"identify\(\): .*Instrument\(<the data's kind>, PerCoordinate"
    ):
        old = pincal.identify(params, data, instrument=MOCAP)
    new = pincal.identify(params, data, instrument=Instrument(Pose(), MOCAP))
    np.testing.assert_array_equal(old.values, new.values)
    np.testing.assert_array_equal(old.std, new.std)
    with pytest.raises(
        BadArgument, match=r"the instrument measures .*point.*, but the data hold .*pose"
    ) as caught:
        pincal.identify(params, data, instrument=Instrument(Point(), MOCAP))
    assert caught.value.argument == "instrument"
    with pytest.raises(BadArgument, match="not both"):
        pincal.identify(params, data, sigma=1e-4, instrument=Instrument(Pose(), MOCAP))


def test_sigma_and_an_instrument_together_are_refused_everywhere(setting):
    tracker = Instrument(Point(), Tracker())
    for name, call in _families(*setting).items():
        with pytest.raises(BadArgument, match=r"give sigma= .* or instrument= .*not both") as caught:
            call(sigma=1e-5, instrument=tracker)
        assert caught.value.argument == "sigma", name
        with pytest.raises(
            BadArgument, match=r"instrument= takes a pincal\.instruments\.Instrument"
        ) as caught:
            call(instrument=Pose())
        assert caught.value.argument == "instrument", name


def test_sigma_given_by_position_is_folded_into_the_instrument(ur10):
    """simulate_measurements' σ is its third argument: pincal 0.1's kind beside it keeps its σ,
    and σ = 0 with an instrument is the exact values of what it measures."""
    plan = ur10.random_configurations(4, 2)
    with pytest.warns(DeprecationWarning, match=OLD):
        old = pincal.simulate_measurements(ur10, plan, 1e-4, seed=1, measure=Pose())
    new = pincal.simulate_measurements(ur10, plan, seed=1, instrument=Instrument(Pose(), PerCoordinate(1e-4)))
    np.testing.assert_array_equal(old.values, new.values)
    exact = pincal.simulate_measurements(ur10, plan, 0.0, instrument=Instrument(Pose()))
    np.testing.assert_array_equal(exact.values, Pose().predict(ur10, plan, None))
    with pytest.warns(DeprecationWarning, match=OLD):
        again = pincal.simulate_measurements(ur10, plan, 0.0, measure=Pose())
    np.testing.assert_array_equal(again.values, exact.values)


def test_the_door_itself():
    assert measured() == (None, pincal.arguments.DEFAULT_SIGMA)
    assert measured(None, 0.0, zero=True) == (None, 0.0)
    tracker = Instrument(Point(), Tracker())
    assert measured(tracker) == (tracker, tracker.reference)
    shorthand, plain = instrument_of(None, 2e-5)
    assert plain and shorthand.is_default and shorthand.reference == 2e-5
    assert instrument_of(tracker) == (tracker, False)
    # pincal 0.1's points with no error model are the sigma= shorthand, not an instrument
    assert old_instrument({"measure": Point()}, {"sigma": 1e-5}) == (
        {"sigma": 1e-5},
        old_instrument({"measure": None}, {})[1],
    )
    assert old_instrument({}, {"sigma": 1e-5}) == ({"sigma": 1e-5}, "")
    # place_instrument's default error model for a kind alone is a tracker's
    placed, hint = old_placed({"measure": Pose()}, {"sigma": 1e-5})
    assert isinstance(placed["instrument"].error, Tracker) and "sigma" not in placed and "Tracker" in hint


def test_the_data_check_covariance_and_compiled_evaluations_take_the_one_door_too(setting):
    """check_plan, position_covariance and the compiled evaluations (TestPoseCriterion,
    PredictedError): an Instrument, or sigma='s points (default σ), not both; points given as an
    Instrument are sigma='s numbers."""
    _, params, plan = setting
    points = Instrument(Point(), PerCoordinate(1e-5))
    calls = {
        "check_plan": lambda **kw: pincal.evaluation.check_plan(params, plan, **kw).as_dict(),
        "position_covariance": lambda **kw: pincal.evaluation.position_covariance(params, plan, Q0, **kw),
        "TestPoseCriterion": lambda **kw: pincal.evaluation.TestPoseCriterion(params, Q0, **kw)(plan),
        "PredictedError": lambda **kw: pincal.evaluation.PredictedError(params, plan, **kw)(Q0[None]),
    }
    for name, call in calls.items():
        with pytest.raises(BadArgument, match=r"give sigma= .* or instrument= .*not both"):
            call(sigma=1e-5, instrument=points)
        _equal(call(sigma=1e-5), call(instrument=points))
        _equal(call(), call(sigma=pincal.arguments.DEFAULT_SIGMA))
        assert name
    tracker = Instrument(Point(), Tracker())
    cov = pincal.evaluation.position_covariance(params, plan, Q0, instrument=tracker)
    assert np.trace(cov[0]) == pytest.approx(pincal.rho0(params, plan, Q0, instrument=tracker) ** 2, rel=1e-9)
