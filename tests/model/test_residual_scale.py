"""The residual model at the size of real data: beyond a threshold, hyperparameters from a seeded
subset's exact likelihood and predictions through inducing points (FITC), against the exact GP."""

from __future__ import annotations

import json

import numpy as np
import pytest

import pincal.model._sparse_gp as sparse
import pincal.progress
from pincal.errors import BadArgument
from pincal.model.residual import Approximation, ResidualModel

REVOLUTE = np.ones(6, dtype=bool)
SIGMA = 1e-5
SMALL = Approximation(above=500, subset=400, inducing=600)
"""Small enough for a test on one core; the defaults (1 000 and 1 000) are in benchmarks/RESULTS.md."""


def field(q: np.ndarray) -> np.ndarray:
    """A smooth unmodelled error over six revolute joints [m]: (n, 3)."""
    return 1e-4 * np.column_stack(
        [
            np.sin(q[:, 0] + 0.5 * q[:, 1]) * np.cos(q[:, 3]),
            np.cos(q[:, 1] - q[:, 2]) + 0.3 * np.sin(q[:, 4]),
            np.sin(q[:, 2] + q[:, 5]) * np.cos(q[:, 0]),
        ]
    )


def draw(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (n, 6))
    return q, field(q) + rng.normal(0, SIGMA, (n, 3))


def held_out(model: ResidualModel, q: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """RMS of the held-out error [m] and of its z-scores (predictive variance: v + n²)."""
    error = r - model.mean(q)
    z = error / np.sqrt(model.variance(q) + model.noise**2)[:, None]
    return float(np.sqrt(np.mean(error**2))), float(np.sqrt(np.mean(z**2)))


def exact(model: ResidualModel) -> ResidualModel:
    """The exact GP on the same data with the same hyperparameters."""
    return ResidualModel(
        model.revolute, model.inputs, model.residuals, model.amplitude, model.lengthscales, model.noise
    )


@pytest.fixture(scope="module")
def approximate():
    q, r = draw(1200, 1)
    return ResidualModel.fit(q, r, REVOLUTE, seed=0, approximation=SMALL)


def test_beyond_the_threshold_the_model_is_approximate(approximate):
    assert approximate.inducing is not None and approximate.inducing.shape == (600, 6)
    assert approximate.subset == 400
    assert approximate.summary()["approximation"] == {
        "method": "FITC",
        "inducing": 600,
        "likelihood_subset": 400,
    }
    assert "FITC through 600 inducing configurations" in approximate.describe()
    q, r = draw(20, 9)
    small = ResidualModel.fit(q, r, REVOLUTE, seed=0, approximation=SMALL)
    assert small.inducing is None and small.summary()["approximation"] is None
    assert "exact" in small.describe()


def test_held_out_error_and_calibration_match_the_exact_gp(approximate):
    q, r = draw(1000, 2)
    rms, z = held_out(approximate, q, r)
    rms_exact, z_exact = held_out(exact(approximate), q, r)
    assert rms < SIGMA * 3  # it learnt the field (RMS 85 µm), down to about the noise
    assert abs(rms - rms_exact) < 0.05 * rms_exact
    assert 0.7 < z < 1.5 and 0.7 < z_exact < 1.5


def test_every_point_inducing_is_the_exact_posterior():
    q, r = draw(120, 3)
    model = ResidualModel.fit(
        q, r, REVOLUTE, approximation=Approximation(above=100, subset=120, inducing=120)
    )
    qs, _ = draw(30, 4)
    reference = exact(model)
    scale = np.abs(reference.mean(qs)).max()
    np.testing.assert_allclose(model.mean(qs), reference.mean(qs), atol=1e-6 * scale)
    np.testing.assert_allclose(model.variance(qs), reference.variance(qs), atol=1e-6 * model.amplitude**2)


def test_no_n_by_n_array(monkeypatch):
    shapes: list[tuple[int, ...]] = []
    correlation = sparse.correlation

    def recorded(A: np.ndarray, B: np.ndarray) -> np.ndarray:
        out = correlation(A, B)
        shapes.append(out.shape)
        return out

    monkeypatch.setattr(sparse, "correlation", recorded)
    monkeypatch.setattr(sparse, "BLOCK", 500)
    q, r = draw(1200, 5)
    model = ResidualModel.fit(
        q, r, REVOLUTE, approximation=Approximation(above=500, subset=200, inducing=150)
    )
    model.mean(q), model.variance(q)  # predictions at every configuration, a block at a time
    assert (200, 200) in shapes and (150, 500) in shapes and (500, 150) in shapes
    assert all(max(s) <= 500 for s in shapes)  # the subset, inducing points and blocks: never n
    assert model._fitc.largest == (150, 500) and model._fitc.weights.shape == (150, 3)
    assert "_factor" not in model.__dict__  # the exact n × n factor was never built


def test_round_trip_through_json(approximate):
    again = ResidualModel.from_dict(json.loads(json.dumps(approximate.as_dict())))
    assert again.subset == 400 and again.inducing is not None
    q, _ = draw(5, 6)
    np.testing.assert_allclose(again.mean(q), approximate.mean(q), rtol=1e-10, atol=1e-18)
    np.testing.assert_allclose(again.variance(q), approximate.variance(q), rtol=1e-10, atol=1e-22)


def test_progress_goes_to_stderr_when_asked(monkeypatch, capsys):
    monkeypatch.setattr(pincal.progress, "EVERY", 0.0)
    q, r = draw(80, 7)
    small = Approximation(above=50, subset=60, inducing=40)
    ResidualModel.fit(q, r, REVOLUTE, approximation=small, restarts=0)
    assert capsys.readouterr().err == ""
    ResidualModel.fit(q, r, REVOLUTE, approximation=small, restarts=0, progress=True)
    out = capsys.readouterr()
    assert out.out == ""
    assert "residual model: 1 of 200 evaluations of the likelihood (start 1 of 1; at most)" in out.err
    assert "residual model: 1 of 1 blocks of training configurations summed" in out.err


def test_likelihood_gradient_matches_finite_differences():
    rng = np.random.default_rng(0)
    X, theta = rng.normal(size=(40, 4)), rng.normal(size=6) * 0.5
    Y = np.sin(X[:, :2]) + 0.1 * rng.normal(size=(40, 2))
    _, gradient = sparse._negative_log_likelihood(theta, X, Y)
    h = 1e-6
    numeric = [
        (
            sparse._negative_log_likelihood(theta + e, X, Y)[0]
            - sparse._negative_log_likelihood(theta - e, X, Y)[0]
        )
        / (2 * h)
        for e in np.eye(len(theta)) * h
    ]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-6, atol=1e-6)


def test_bad_approximation_is_refused():
    with pytest.raises(BadArgument, match="inducing must be an integer"):
        Approximation(inducing=2)
    q, r = draw(10, 8)
    with pytest.raises(BadArgument, match="approximation must be"):
        ResidualModel.fit(q, r, REVOLUTE, approximation=500)  # type: ignore[arg-type]


def test_the_design_criterion_reads_the_kernel_not_the_training_data(approximate):
    """A top-up design's criterion (tr Σ₀) builds its matrices over the plan, from the kernel
    alone: a model of any size costs it nothing, and nothing over the training data is built."""
    import pincal
    from pincal.evaluation.residual_criterion import expected_error

    robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    params = robot.parameters("offsets").identifiable().identifiable
    loaded = ResidualModel.from_dict(approximate.as_dict())  # as `design --residual-model` loads it
    plan = robot.random_configurations(12, 1)
    value = expected_error(params, plan, plan[0] + 0.05, loaded, sigma=SIGMA)
    assert value == expected_error(params, plan, plan[0] + 0.05, exact(approximate), sigma=SIGMA)
    assert "_fitc" not in loaded.__dict__ and "_factor" not in loaded.__dict__
