"""A later session's prediction carries its own base's uncertainty, not the first session's: a
session measured from a second instrument placement with few points knows its base less well,
and the error predicted there (IdentificationResult.point_variances / expected_error, validate's
``expected``) says so. Oracles: the same fit with the sessions given in the other order (its first
session is our second), and a Monte-Carlo of the delivered error."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import pincal
from pincal import identify, random_errors, simulate_measurements

SIGMA = 1e-4
FIRST = pin.SE3(pin.rpy.rpyToMatrix(0.05, -0.1, 2.0), np.array([-2.5, 1.0, 0.2]))
SECOND = pin.SE3(pin.rpy.rpyToMatrix(-0.1, 0.05, -1.0), np.array([1.5, 3.0, -0.4]))


@pytest.fixture(scope="module")
def robot(kr270_marker):
    return kr270_marker


@pytest.fixture(scope="module")
def params(robot):
    return robot.parameters("full,offsets,base").identifiable(prefer="base").identifiable


def _sessions(robot, params, trial):
    truth = random_errors(params, seed=100 + trial)
    q = robot.random_configurations(40, 1)
    a = simulate_measurements(truth.robot.replace(base=FIRST), q, SIGMA, seed=trial)
    b = simulate_measurements(
        truth.robot.replace(base=SECOND), robot.random_configurations(6, 2), SIGMA, seed=1000 + trial
    )
    return truth, a, b


def test_a_later_session_predicts_with_its_own_base(robot, params):
    _, a, b = _sessions(robot, params, 0)
    ab, ba = identify(params, [a, b], sigma=SIGMA), identify(params, [b, a], sigma=SIGMA)
    assert ab.success and ba.success
    q = robot.random_configurations(25, 9)
    later, swapped = ab.point_variances(q, session=1)[0], ba.point_variances(q, session=0)[0]
    np.testing.assert_allclose(later, swapped, rtol=1e-5)
    first = ab.point_variances(q, session=0)[0]
    assert later.mean() > 2 * first.mean()  # six points place the second base far less well
    np.testing.assert_allclose(first, ba.point_variances(q, session=1)[0], rtol=1e-5)
    np.testing.assert_allclose(ab.expected_error(q, session=1), ba.expected_error(q), rtol=1e-5)
    held = simulate_measurements(random_errors(params, seed=100).robot.replace(base=SECOND), q, SIGMA, seed=7)
    np.testing.assert_allclose(
        pincal.validate(ab, held, session=1).expected, pincal.validate(ba, held).expected, rtol=1e-5
    )
    with pytest.raises(pincal.errors.BadArgument, match="session must be between 0 and 1, got 2"):
        ab.point_variances(q, session=2)


def test_one_session_and_the_first_are_unchanged(robot, params):
    _, a, b = _sessions(robot, params, 0)
    alone = identify(params, a, sigma=SIGMA)
    assert alone.session_estimates == ()
    both = identify(params, [a, b], sigma=SIGMA)
    assert len(both.session_estimates) == 1
    x, C = both.session_estimates[0]
    chain = [i for i, p in enumerate(params) if p.kind != "base"]
    np.testing.assert_array_equal(x[chain], both.values[chain])  # the robot is shared
    assert C.shape == (len(params), len(params)) and not C.flags.writeable


def test_the_later_session_delivers_what_it_predicts(robot, params):
    """40 simulated calibrations: the RMS error delivered in the second session's frame, against the
    RMS predicted there (within 20 %; the first session's prediction was 1.7x too small)."""
    q = robot.random_configurations(30, 9)
    predicted, delivered = [], []
    for trial in range(40):
        truth, a, b = _sessions(robot, params, trial)
        fit = identify(params, [a, b], sigma=SIGMA)
        true = truth.robot.replace(base=SECOND).points(q)
        delivered.append(np.sum((fit.predict(q, session=1) - true) ** 2, axis=-1).mean())
        parameters, rest = fit.point_variances(q, session=1)
        predicted.append((parameters.sum(1) + rest.sum(1)).mean())
    ratio = np.sqrt(np.mean(delivered) / np.mean(predicted))
    assert 0.85 < ratio < 1.2, ratio
