"""The residual model: a Gaussian process of the residuals over joint space."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pincal.errors import BadArgument
from pincal.model.residual import ResidualModel, features

pytest.importorskip("sklearn")

REVOLUTE = np.array([True, True, True, False])
SIGMA = 2e-5


def field(q: np.ndarray) -> np.ndarray:
    """A smooth unmodelled error [m], periodic in the revolute joints: (m, 3)."""
    return 1e-3 * np.column_stack(
        [
            np.sin(q[:, 0] + 0.5 * q[:, 1]),
            0.6 * np.cos(2 * q[:, 1]) * np.sin(q[:, 2]),
            0.4 * np.cos(q[:, 0] - q[:, 2]) + 0.5 * q[:, 3],
        ]
    )


def draw(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = np.column_stack([rng.uniform(-np.pi, np.pi, (n, 3)), rng.uniform(0, 1, n)])
    return q, field(q) + rng.normal(0, SIGMA, (n, 3))


@pytest.fixture(scope="module")
def model():
    q, r = draw(150, 1)
    return ResidualModel.fit(q, r, REVOLUTE, seed=0)


def test_features_are_periodic_in_revolute_joints():
    q = np.array([[0.3, -1.0, 2.0, 0.5]])
    shifted = q + [2 * np.pi, -2 * np.pi, 0.0, 0.0]
    np.testing.assert_allclose(features(q, REVOLUTE), features(shifted, REVOLUTE), atol=1e-15)
    assert features(q, REVOLUTE).shape == (1, 7)


def test_the_model_lowers_held_out_error(model):
    q, r = draw(200, 2)  # data the model did not see
    before = np.sqrt(np.mean(r**2))
    after = np.sqrt(np.mean((r - model.mean(q)) ** 2))
    assert after < before / 5
    # The noise it learnt is the noise put in, within a factor of two.
    assert SIGMA / 2 < model.noise < 2 * SIGMA


def test_predictions_match_scikit_learn(model):
    # The same hyperparameters in scikit-learn's own GaussianProcessRegressor (no refit): the same
    # mean, and its predictive variance minus the noise is the model's variance.
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    kernel = ConstantKernel(model.amplitude**2, "fixed") * RBF(model.lengthscales, "fixed") + WhiteKernel(
        model.noise**2, "fixed"
    )
    reference = GaussianProcessRegressor(kernel, alpha=0.0, optimizer=None).fit(
        features(model.inputs, REVOLUTE), model.residuals
    )
    q, _ = draw(20, 3)
    mean, std = reference.predict(features(q, REVOLUTE), return_std=True)
    np.testing.assert_allclose(model.mean(q), mean, atol=1e-12 * np.abs(mean).max() + 1e-15)
    np.testing.assert_allclose(model.variance(q), std[:, 0] ** 2 - model.noise**2, rtol=1e-6, atol=1e-16)


def test_variance_is_small_near_data_and_the_prior_far_away(model):
    near = model.variance(model.inputs[:5])  # one measurement there: about the noise's variance
    assert np.all(near < model.noise**2)
    assert model.amplitude > 10 * model.noise
    far = model.variance(np.array([[0.0, 0.0, 0.0, 50.0]]))  # the slide 50 m out
    assert far[0] == pytest.approx(model.amplitude**2, rel=1e-6)


def test_round_trip_through_json(model):
    again = ResidualModel.from_dict(json.loads(json.dumps(model.as_dict())))
    q, _ = draw(5, 4)
    np.testing.assert_array_equal(again.mean(q), model.mean(q))
    np.testing.assert_array_equal(again.variance(q), model.variance(q))
    with pytest.raises(BadArgument, match="not a residual model"):
        ResidualModel.from_dict({"kind": "gp", "amplitude": 1.0})


def test_bad_training_data_is_refused():
    q, r = draw(10, 5)
    with pytest.raises(BadArgument, match="n ≥ 3"):
        ResidualModel.fit(q[:2], r[:2], REVOLUTE)
    with pytest.raises(BadArgument, match="finite"):
        ResidualModel.fit(q, np.where(np.arange(30).reshape(10, 3) == 4, np.nan, r), REVOLUTE)
    with pytest.raises(BadArgument, match="inputs must be"):
        ResidualModel(REVOLUTE, q[:, :3], r, 1e-3, np.ones(7), 1e-5)
