r"""The predicted error after calibrating with a plan, at any configuration, and its worst over a
region (docs/method.md §8.3).

* :class:`PredictedError` — ρ(q) = σ·sqrt(tr(J(q) C J(q)ᵀ)), C = (M + Λ)⁻¹, of one plan at any
  batch of configurations.
* :func:`worst_found` — the worst ρ over a region: the largest sampled value, then a local
  maximisation (L-BFGS-B over the region's unit cube) from the worst few samples. It is the worst
  *found*, a lower bound of the true maximum over a continuous region, with the pose where it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from pincal.arguments import positive_int
from pincal.deprecation import keywords_after
from pincal.evaluation.information import factor
from pincal.evaluation.plans import engine_for
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import ResolvedRegion
from pincal.instruments.given import measured
from pincal.instruments.instrument import Instrument
from pincal.lapack import trtrs
from pincal.model.parameters import ParameterSet
from pincal.model.statics import PayloadRows, payload_rows, repeated
from pincal.typing import ConfigurationsLike, PayloadLike


class PredictedError:
    """ρ(q) [m], the predicted position error after calibrating with ``plan``, at any q.

    Args:
        params: the parameters identified.
        plan: (m, nq) configurations or a Plan.
        sigma: measurement noise per coordinate [m], the shorthand for points (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`; not with ``instrument``).
        prior: the errors' prior, or None.
        task_payload: the load under which ρ(q) is asked (one for every q: a mass [kg] or a
            :class:`~pincal.Payload`), or None; the plan's own payloads (:attr:`Plan.payload`)
            enter its information.
        payload: the plan's payload rows (m, 4) (:func:`~pincal.model.statics.payload_rows`),
            instead of its own.
        instrument: what the plan measures and how well (its whitened rows; ``sigma`` is then its
            reference σ), or None: points with ``sigma``. ρ is the markers' position error.
        checked: ``plan`` is an (m, nq) array already checked against the joint limits (not
            checked again).

    Raises:
        SingularPlan: the plan cannot identify ``params`` (never with a prior on every parameter).
    """

    def __init__(
        self,
        params: ParameterSet,
        plan: ConfigurationsLike,
        sigma: float | None = None,
        prior: Prior | None = None,
        task_payload: PayloadLike = None,
        payload: PayloadRows = None,
        instrument: Instrument | None = None,
        checked: bool = False,
    ) -> None:
        self.params = params
        instrument, self.sigma = measured(instrument, sigma)  # the one door: not both
        self.prior = prior
        # the door of the task's load: one row (1, 4), carried at every q asked
        self.task_payload = None if task_payload is None else payload_rows(task_payload, 1)
        self.engine = engine_for(params)
        rows = engine_for(params, instrument)
        qs = np.asarray(plan) if checked else params.robot.configurations(plan)
        if payload is None:
            payload = getattr(plan, "payload", None)
        J = rows.jacobian(qs, frame="tip", payload=payload).reshape(-1, len(params))
        self.information = J.T @ J  # M, of the measurements alone
        self.m = len(qs)
        posterior = (
            self.information if prior is None else self.information + prior.information(params, self.sigma)
        )
        self.L = factor(posterior, rows.rows, self.m)

    def squared(self, qs: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """(n,) ρ² [m²] at configurations ``qs`` (trusted: within the limits)."""
        qs = np.atleast_2d(qs)
        out = np.empty(len(qs))
        for a in range(0, len(qs), chunk):
            n = len(qs[a : a + chunk])
            load = repeated(self.task_payload, n)
            J = self.engine.jacobian(qs[a : a + chunk], frame="tip", payload=load)
            out[a : a + len(J)] = self.squared_at(J)
        return out

    def squared_at(self, J: np.ndarray) -> np.ndarray:
        """(n,) ρ² [m²] at configurations of tip-frame Jacobians J (n, r, P), computed once for
        every plan compared on them."""
        # Jᵀ as a Fortran-ordered view: LAPACK's own order, copied once by the call (not twice)
        X = trtrs(self.L, J.reshape(-1, J.shape[-1]).T)
        return self.sigma**2 * np.einsum("ij,ij->j", X, X).reshape(len(J), -1).sum(axis=1)

    def at_sets(self, jacobians: list[np.ndarray]) -> list[np.ndarray]:
        """ρ [m] at the configurations of each set of tip-frame Jacobians (n, r, P): the numbers
        of ``sqrt(squared_at(J))`` set by set (one triangular solve per set), the rest of the
        arithmetic in one pass over every set."""
        r = jacobians[0].shape[1]
        t = np.empty(r * sum(len(J) for J in jacobians))
        start = 0
        for J in jacobians:
            X = trtrs(self.L, J.reshape(-1, J.shape[-1]).T)
            np.einsum("ij,ij->j", X, X, out=t[start : start + X.shape[1]])
            start += X.shape[1]
        rho = np.sqrt(self.sigma**2 * t.reshape(-1, r).sum(axis=1))
        ends = np.cumsum([len(J) for J in jacobians]).tolist()
        return [rho[end - len(J) : end] for J, end in zip(jacobians, ends, strict=True)]

    def __call__(self, qs: np.ndarray) -> np.ndarray:
        """(n,) ρ [m] at configurations ``qs``."""
        return np.sqrt(self.squared(qs))


@dataclass(frozen=True)
class WorstFound:
    """The worst predicted error found over a region.

    Attributes:
        rho: the largest ρ found [m] (≥ every sampled value).
        pose: (nq,) the configuration where it was found [rad or m].
        sampled: the largest ρ among the region's samples [m].
        searched: a local maximisation ran (continuous region), else the samples are the region.
    """

    rho: float
    pose: np.ndarray
    sampled: float
    searched: bool

    def as_dict(self) -> dict:
        return {
            "rho": self.rho,
            "pose": self.pose.tolist(),
            "sampled": self.sampled,
            "searched": self.searched,
        }


class SquaredError(Protocol):
    """What :func:`worst_found` maximises: ρ²(q) at a batch of configurations (a
    :class:`PredictedError`, or a calibration's expected error)."""

    def squared(self, qs: np.ndarray) -> np.ndarray:
        """(n,) ρ² [m²] at the (n, nq) configurations ``qs``."""
        ...


@keywords_after(2)
def worst_found(predicted: SquaredError, region: ResolvedRegion, *, starts: int = 3) -> WorstFound:
    """The worst ρ over a region: sampled, then maximised locally from the ``starts`` worst
    samples (continuous regions). See the module doc."""
    starts = positive_int(starts, "starts", 0)
    r2 = predicted.squared(region.poses)
    best = int(np.argmax(r2))
    sampled = float(np.sqrt(r2[best]))
    if not region.continuous:
        return WorstFound(sampled, np.array(region.poses[best]), sampled, False)
    from scipy.optimize import minimize

    to_q, unit_samples = region.to_configuration, region.unit_samples
    assert to_q is not None and unit_samples is not None  # a continuous region
    scale = 1.0 / max(float(r2[best]), 1e-300)
    h = 1e-6
    shifts = np.vstack(
        [np.zeros(region.dimension), h * np.eye(region.dimension), -h * np.eye(region.dimension)]
    )

    def negative(u: np.ndarray) -> tuple[float, np.ndarray]:
        # −ρ²(u) and its central-difference gradient, the 2d + 1 configurations in one batch.
        points = np.clip(u + shifts, 0.0, 1.0)
        qs = [to_q(p) for p in points]
        if any(q is None for q in qs):
            return 0.0, np.zeros_like(u)
        f = -predicted.squared(np.array(qs)) * scale
        d = region.dimension
        return float(f[0]), (f[1 : d + 1] - f[d + 1 :]) / np.maximum(
            points[1 : d + 1] - points[d + 1 :], h
        ).diagonal()

    best_value, best_pose = float(r2[best]), np.array(region.poses[best])
    bounds = [(0.0, 1.0)] * region.dimension
    for s in np.argsort(r2)[::-1][:starts]:
        u0 = unit_samples[s]
        result = minimize(negative, u0, jac=True, method="L-BFGS-B", bounds=bounds, options={"maxiter": 50})
        q = to_q(result.x)
        if q is None:
            continue
        value = float(predicted.squared(q[None])[0])
        if value > best_value:
            best_value, best_pose = value, q
    return WorstFound(math.sqrt(best_value), best_pose, sampled, True)
