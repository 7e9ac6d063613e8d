r"""A residual model: what no physical term explains, as a Gaussian process over joint space
(docs/method.md §11.5).

After the physical fit, the residuals at the measured configurations (gear eccentricity, thermal
drift, the instrument's own errors), expressed in the robot's base frame so that one model serves
every instrument placement, are smooth in the joint values. They are modelled as a
zero-mean Gaussian process f(q) ∈ R^{3K} (the K markers' x, y, z, independent with one shared
covariance)

    cov(f(q), f(q')) = s² exp(−½ Σ_i (φ_i(q) − φ_i(q'))² / ℓ_i²),

on the features φ(q): (cos q_j, sin q_j) of each revolute joint (so that q_j and q_j + 2π are the same
place) and q_j of each prismatic one, one lengthscale ℓ_i per feature, plus independent noise n²
per coordinate. The hyperparameters (s, ℓ, n) maximise the marginal likelihood of the *training*
residuals (scikit-learn's GaussianProcessRegressor: the ``gp`` extra, ``pip install "pincal[gp]"``);
the predictions are then plain linear algebra on the stored training data, with no scikit-learn
needed: the mean f̂(q) = k(q)ᵀ K⁻¹ Y corrects the model, and the posterior variance
v(q) = s² − k(q)ᵀ K⁻¹ k(q) per coordinate is what it still cannot say (K = s² R + n² I the training
covariance, k(q) the covariance between f(q) and the training points).

That is O(n³) time and O(n²) memory (scikit-learn's likelihood gradient O(n² d)): beyond
:attr:`Approximation.above` configurations (500) the model is approximate instead
(:mod:`pincal.model._sparse_gp`): the hyperparameters maximise the exact marginal likelihood of a
seeded subset of :attr:`Approximation.subset` configurations (1 000), and the predictions use every
configuration through :attr:`Approximation.inducing` inducing configurations (1 500, the first of
the same seeded order) by FITC: O(n m²) time, O(block·m) memory. Up to the threshold nothing
changes; :meth:`ResidualModel.summary` and :meth:`ResidualModel.describe` say which was used.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from pincal.arguments import generator
from pincal.errors import BadArgument
from pincal.model._sparse_gp import LENGTHSCALE_BOUNDS, Fitc, fit_hyperparameters, one_thread
from pincal.optional import require
from pincal.progress import Steps
from pincal.typing import SeedLike

RESTARTS = 1
"""Restarts of the marginal-likelihood optimiser from random hyperparameters (the first start is
the fixed default)."""


@dataclass(frozen=True)
class Approximation:
    """When and how the residual model approximates the Gaussian process (module doc).

    Attributes:
        above: more training configurations than this: the approximation; up to it, the exact GP.
        subset: configurations (a seeded subset) whose exact marginal likelihood chooses the
            hyperparameters of an approximate model.
        inducing: inducing configurations (the first of the same seeded order) through which an
            approximate model predicts from every training configuration.
    """

    above: int = 500
    subset: int = 1000
    inducing: int = 1500

    def __post_init__(self) -> None:
        for name in ("above", "subset", "inducing"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 3:
                raise BadArgument(
                    f"residual model: {name} must be an integer ≥ 3, got {value!r}", argument=name
                )


def features(q: np.ndarray, revolute: np.ndarray) -> np.ndarray:
    """(m, d) features φ(q): (cos q_j, sin q_j) for each revolute joint, q_j for each prismatic one."""
    q = np.asarray(q, dtype=float)
    columns = []
    for j, turns in enumerate(revolute):
        columns += [np.cos(q[:, j]), np.sin(q[:, j])] if turns else [q[:, j]]
    return np.column_stack(columns)


@dataclass(frozen=True, eq=False)
class ResidualModel:
    """A fitted Gaussian process of the residuals over joint space (see module doc).

    Build one with :meth:`fit`. Read-only.

    Attributes:
        revolute: (nq,) which joints turn (their features are cos and sin).
        inputs: (n, nq) the training joint values [rad or m].
        residuals: (n, 3K) the training residuals, measured − modelled [m].
        amplitude: s, the standard deviation of f per coordinate [m].
        lengthscales: (d,) ℓ of each feature.
        noise: n, the standard deviation of the independent noise per coordinate [m].
        log_marginal_likelihood: of the training residuals at these hyperparameters (of the
            subset's, for an approximate model).
        inducing: (m, nq) the inducing configurations of an approximate model (FITC); None: exact.
        subset: configurations whose likelihood chose the hyperparameters (None: all of them).
    """

    revolute: np.ndarray
    inputs: np.ndarray
    residuals: np.ndarray
    amplitude: float
    lengthscales: np.ndarray
    noise: float
    log_marginal_likelihood: float = field(default=float("nan"))
    inducing: np.ndarray | None = None
    subset: int | None = None

    def __post_init__(self) -> None:
        for name in ("revolute", "inputs", "residuals", "lengthscales", "inducing"):
            if getattr(self, name) is None:
                continue
            value = np.array(getattr(self, name), dtype=bool if name == "revolute" else float)
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        d = len(features(np.zeros((1, len(self.revolute))), self.revolute)[0])
        if (
            self.inputs.ndim != 2
            or self.inputs.shape[1] != len(self.revolute)
            or self.lengthscales.shape != (d,)
        ):
            raise BadArgument(
                f"residual model: inputs must be (n, {len(self.revolute)}) and lengthscales ({d},), got "
                f"{self.inputs.shape} and {self.lengthscales.shape}"
            )
        if self.residuals.shape[0] != len(self.inputs) or self.residuals.ndim != 2:
            raise BadArgument(
                f"residual model: residuals must be ({len(self.inputs)}, 3K), got {self.residuals.shape}"
            )
        if self.inducing is not None and (
            self.inducing.ndim != 2 or self.inducing.shape[1] != len(self.revolute) or len(self.inducing) < 1
        ):
            raise BadArgument(
                f"residual model: inducing configurations must be (m, {len(self.revolute)}), got "
                f"{self.inducing.shape}"
            )
        if not (self.amplitude > 0 and self.noise > 0 and np.all(self.lengthscales > 0)):
            raise BadArgument("residual model: amplitude, noise and lengthscales must be positive")

    # -------------------------------------------------------------------- fitting
    @classmethod
    def fit(
        cls,
        q: np.ndarray,
        residuals: np.ndarray,
        revolute: np.ndarray,
        *,
        seed: SeedLike = 0,
        restarts: int = RESTARTS,
        approximation: Approximation = Approximation(),
        progress: bool = False,
    ) -> ResidualModel:
        """Hyperparameters by maximum marginal likelihood of ``residuals`` at ``q`` (training data only).

        Up to ``approximation.above`` configurations, the exact GP (scikit-learn); beyond, the
        approximation of the module doc.

        Args:
            q: (n, nq) joint values of the training configurations [rad or m].
            residuals: (n, 3K) measured − modelled points there [m] (or (n, K, 3)).
            revolute: (nq,) which joints turn.
            seed: seed of the optimiser's random restarts.
            restarts: restarts from random hyperparameters, beyond the default start.
            approximation: when and how to approximate.
            progress: report an approximate fit's likelihood evaluations and blocks on stderr
                (the exact fit has none to report).

        Raises:
            MissingDependency: scikit-learn is not installed (the ``gp`` extra) for an exact fit.
            BadArgument: shapes that do not match, fewer than 3 configurations, non-finite values.
        """
        q = np.asarray(q, dtype=float)
        Y = np.asarray(residuals, dtype=float).reshape(len(q), -1)
        revolute = np.asarray(revolute, dtype=bool)
        if q.ndim != 2 or q.shape[1] != len(revolute) or len(q) < 3:
            raise BadArgument(
                f"residual model: needs (n, {len(revolute)}) joint values with n ≥ 3, got shape {q.shape}"
            )
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(Y))):
            raise BadArgument("residual model: joint values and residuals must be finite")
        if not isinstance(approximation, Approximation):
            raise BadArgument(
                f"approximation must be a residual.Approximation, got {approximation!r}",
                argument="approximation",
            )
        scale = float(np.sqrt(np.mean(Y**2))) or 1.0
        X = features(q, revolute)
        if len(q) > approximation.above:
            return cls._fit_approximate(
                q, Y, revolute, scale, generator(seed), restarts, approximation, progress
            )
        gp = require("sklearn.gaussian_process", "the residual model (--residual-model gp)", "pincal[gp]")
        kernels = require("sklearn.gaussian_process.kernels", "the residual model", "pincal[gp]")
        kernel = kernels.ConstantKernel(1.0, (1e-4, 1e2)) * kernels.RBF(
            np.ones(X.shape[1]), LENGTHSCALE_BOUNDS
        ) + kernels.WhiteKernel(0.1, (1e-6, 10.0))
        rng = generator(seed)
        regressor = gp.GaussianProcessRegressor(
            kernel, alpha=0.0, n_restarts_optimizer=restarts, random_state=int(rng.integers(2**31 - 1))
        )
        exceptions = require("sklearn.exceptions", "the residual model", "pincal[gp]")
        with threadpool_limits(limits=1, user_api="blas"), warnings.catch_warnings():
            # A lengthscale at its upper bound is a joint the residual does not depend on: an answer.
            warnings.simplefilter("ignore", exceptions.ConvergenceWarning)
            regressor.fit(X, Y / scale)  # one BLAS thread: small matrices, threads only contend
        fitted = regressor.kernel_
        return cls(
            revolute=revolute,
            inputs=q,
            residuals=Y,
            amplitude=float(np.sqrt(fitted.k1.k1.constant_value)) * scale,
            lengthscales=np.atleast_1d(fitted.k1.k2.length_scale),
            noise=float(np.sqrt(fitted.k2.noise_level)) * scale,
            log_marginal_likelihood=float(regressor.log_marginal_likelihood_value_),
        )

    @classmethod
    def _fit_approximate(
        cls,
        q: np.ndarray,
        Y: np.ndarray,
        revolute: np.ndarray,
        scale: float,
        rng: np.random.Generator,
        restarts: int,
        approximation: Approximation,
        progress: bool,
    ) -> ResidualModel:
        """The approximate fit of the module doc (``Y`` (n, 3K) [m], ``scale`` its RMS)."""
        order = rng.permutation(len(q))
        subset = order[: approximation.subset]
        X = features(q[subset], revolute)
        with one_thread():
            steps = Steps(progress, "residual model", "evaluation")
            s2, ell, n2, lml = fit_hyperparameters(X, Y[subset] / scale, rng, restarts, steps)
        model = cls(
            revolute=revolute,
            inputs=q,
            residuals=Y,
            amplitude=float(np.sqrt(s2)) * scale,
            lengthscales=ell,
            noise=float(np.sqrt(n2)) * scale,
            log_marginal_likelihood=lml,
            inducing=q[order[: approximation.inducing]],
            subset=len(subset),
        )
        model.__dict__["_fitc"] = model._posterior(Steps(progress, "residual model", "block"))
        return model

    # ------------------------------------------------------------------ predicting
    def kernel(self, qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
        """(ma, mb) covariance of f per coordinate between configurations ``qa`` and ``qb`` [m²]."""
        A = features(np.atleast_2d(qa), self.revolute) / self.lengthscales
        B = features(np.atleast_2d(qb), self.revolute) / self.lengthscales
        d2 = np.sum(A**2, axis=1)[:, None] + np.sum(B**2, axis=1)[None, :] - 2 * A @ B.T
        return self.amplitude**2 * np.exp(-0.5 * np.maximum(d2, 0.0))

    @cached_property
    def _factor(self) -> tuple[np.ndarray, bool]:
        from scipy.linalg import cho_factor  # on first use: scipy.linalg is slow to import

        K = self.kernel(self.inputs, self.inputs) + self.noise**2 * np.eye(len(self.inputs))
        return cho_factor(K, lower=True)

    @cached_property
    def _weights(self) -> np.ndarray:
        from scipy.linalg import cho_solve

        return cho_solve(self._factor, self.residuals)

    def _scaled(self, q: np.ndarray) -> np.ndarray:
        return features(np.atleast_2d(q), self.revolute) / self.lengthscales

    def _posterior(self, steps: Steps) -> Fitc:
        """The approximate model's FITC posterior (:class:`pincal.model._sparse_gp.Fitc`)."""
        assert self.inducing is not None  # an approximate model's
        nu = (self.noise / self.amplitude) ** 2
        with one_thread():
            return Fitc.build(
                self._scaled(self.inputs), self.residuals, self._scaled(self.inducing), nu, steps
            )

    @cached_property
    def _fitc(self) -> Fitc:
        return self._posterior(Steps(False, "residual model", "block"))

    def mean(self, q: np.ndarray) -> np.ndarray:
        """(m, 3K) the residual predicted at configurations ``q`` [m]: add it to the model's points."""
        if self.inducing is not None:
            return self._fitc.mean(self._scaled(q))
        return self.kernel(q, self.inputs) @ self._weights

    def variance(self, q: np.ndarray) -> np.ndarray:
        """(m,) posterior variance of f per coordinate at ``q`` [m²]: what the residual model still
        cannot say there (s² far from the training data; about n²/(number of nearby points) on it)."""
        from scipy.linalg import solve_triangular

        if self.inducing is not None:
            return self.amplitude**2 * self._fitc.variance(self._scaled(q))
        k = self.kernel(q, self.inputs)
        v = solve_triangular(self._factor[0], k.T, lower=True)
        return np.maximum(self.amplitude**2 - np.sum(v**2, axis=0), 0.0)

    def summary(self) -> dict[str, object]:
        """JSON-ready hyperparameters (without the training data)."""
        return {
            "kind": "gp",
            "amplitude": self.amplitude,
            "noise": self.noise,
            "lengthscales": self.lengthscales.tolist(),
            "configurations": len(self.inputs),
            "log_marginal_likelihood": self.log_marginal_likelihood,
            "approximation": None
            if self.inducing is None
            else {"method": "FITC", "inducing": len(self.inducing), "likelihood_subset": self.subset},
        }

    def describe(self) -> str:
        """One line for a report."""
        how = (
            "exact, hyperparameters by marginal likelihood"
            if self.inducing is None
            else f"FITC through {len(self.inducing)} inducing configurations, hyperparameters by the "
            f"marginal likelihood of {self.subset}"
        )
        return (
            f"residual model: Gaussian process over joint space, {len(self.inputs)} configurations, "
            f"amplitude {self.amplitude * 1e3:.3g} mm, noise {self.noise * 1e3:.3g} mm per coordinate "
            f"({how})"
        )

    @property
    def rows(self) -> int:
        """Coordinates per configuration (3 per marker)."""
        return self.residuals.shape[1]

    # -------------------------------------------------------------- serialising
    def as_dict(self) -> dict[str, object]:
        """JSON-ready: the kernel's hyperparameters and the training data (a calibration's sidecar)."""
        out: dict[str, object] = {
            "kind": "gp",
            "revolute": self.revolute.tolist(),
            "amplitude": self.amplitude,
            "lengthscales": self.lengthscales.tolist(),
            "noise": self.noise,
            "log_marginal_likelihood": self.log_marginal_likelihood,
            "inputs": self.inputs.tolist(),
            "residuals": self.residuals.tolist(),
        }
        if self.inducing is not None:  # an exact model's description is as before
            out |= {"inducing": self.inducing.tolist(), "likelihood_subset": self.subset}
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ResidualModel:
        """The model :meth:`as_dict` wrote."""
        try:
            if data.get("kind") != "gp":
                raise KeyError("kind")
            return cls(
                revolute=np.array(data["revolute"], dtype=bool),
                inputs=np.array(data["inputs"], dtype=float),
                residuals=np.array(data["residuals"], dtype=float),
                amplitude=float(data["amplitude"]),
                lengthscales=np.array(data["lengthscales"], dtype=float),
                noise=float(data["noise"]),
                log_marginal_likelihood=float(data.get("log_marginal_likelihood", float("nan"))),
                inducing=None if data.get("inducing") is None else np.array(data["inducing"], dtype=float),
                subset=None if data.get("likelihood_subset") is None else int(data["likelihood_subset"]),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise BadArgument(f"not a residual model description (missing or bad {exc})") from None
