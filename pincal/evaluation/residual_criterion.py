r"""The test-pose criterion with a residual model: the error left at the test pose when the physical
parameters and a Gaussian-process residual are estimated together (docs/method.md §11.5).

A residual model from an earlier campaign (:class:`~pincal.model.residual.ResidualModel`) says how
the error no parameter explains is correlated over joint space: f ~ GP(0, k(q, q')·I), the same
kernel for every measured coordinate, independent coordinates. Measuring a plan q₁..q_m gives
y = Hx + f + ε, H the stacked parameter Jacobian (world-aligned rows, so that the isotropic
covariance is the same in every row's frame), ε the instrument's noise σ². The best linear unbiased
prediction of the error at a test pose q₀ (a GP with explicit basis functions, Rasmussen & Williams
2006, §2.7) leaves the covariance

    Σ₀ = K₀₀ − k₀ᵀK⁻¹k₀ + Rᵀ (HᵀK⁻¹H)⁻¹ R,      R = J₀ᵀ − HᵀK⁻¹k₀,

with K = K_f + σ²I the plan's covariance, k₀ its covariance with f(q₀) and K₀₀ = k(q₀, q₀)·I.
The criterion is tr Σ₀ (the mean over the test poses), in metres², reported as its root [m]: with
no residual (s → 0) it is σ² tr(J₀M⁻¹J₀ᵀ) = ρ0² again, and with one it values measuring near the
test pose exactly as much as the kernel says the residual is correlated there.

Because every coordinate has the same kernel, K = (K_q + σ²I_m) ⊗ I_r (K_q the m×m kernel matrix of
the configurations, r rows per configuration), so HᵀK⁻¹H = Σᵢⱼ (K_q + σ²I)⁻¹ᵢⱼ HᵢᵀHⱼ and
tr(k₀ᵀK⁻¹k₀) = r·k_qᵀ(K_q + σ²I)⁻¹k_q: one m×m Cholesky factor per plan.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from pincal.arguments import DEFAULT_SIGMA, positive_sigma
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, SingularPlan
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.region import resolve_test_poses
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.typing import ConfigurationsLike, PayloadLike

POINTS_ONLY = (
    "a residual model is a Gaussian process of the markers' positions, fitted to point residuals "
    "with one kernel for every coordinate: it says nothing of orientations, pixels or distances; "
    "with it, plans measure points with one sigma per coordinate (sigma=, or an instrument of points and "
    "PerCoordinate)"
)
"""Why a residual model goes with points only (designs, accuracy)."""


def check_points(instrument: object) -> None:
    """Refuse an instrument other than points with one σ (None: points) for a residual model.

    Raises:
        BadArgument: ``instrument`` measures something else (see :data:`POINTS_ONLY`).
    """
    if instrument is not None and not getattr(instrument, "is_default", False):
        raise BadArgument(POINTS_ONLY, argument="instrument")


class ResidualCriterion(Criterion):
    """tr Σ₀ at the test pose(s) of a plan, with a residual model (see module doc).

    Args:
        model: the residual model (its kernel; its training data are not used).
        J0: (k, r, P) world-aligned Jacobians at the test poses.
        q0: (k, nq) the test poses.
        sigma: the instrument's noise per coordinate [m].
        pool: (N, nq) the configurations of the pool the exchange search swaps from (or None).
    """

    name = "test-pose-gp"
    label = "expected error at the test pose(s) with the residual model"

    def __init__(
        self,
        model: ResidualModel,
        J0: np.ndarray,
        q0: np.ndarray,
        sigma: float,
        pool: np.ndarray | None = None,
    ) -> None:
        super().__init__(J0.shape[1])
        self.model = model
        self.J0 = np.asarray(J0, dtype=float)
        self.q0 = np.asarray(q0, dtype=float)
        self.sigma = float(sigma)
        self.pool = None if pool is None else np.asarray(pool, dtype=float)
        self.k00 = float(np.mean(np.diag(np.atleast_2d(model.kernel(self.q0, self.q0)))))

    # ---------------------------------------------------------------- the value
    def trace(self, J: np.ndarray, qs: np.ndarray) -> float:
        """tr Σ₀ [m²], the mean over the test poses, for world-aligned Jacobians J (m, r, P) at qs."""
        return float(np.mean(self.each(J, qs)))

    def each(self, J: np.ndarray, qs: np.ndarray, chunk: int = 1024) -> np.ndarray:
        """(k,) tr Σ₀ [m²] at each test pose, for the plan of world-aligned Jacobians J (m, r, P) at
        qs (the test poses ``chunk`` at a time: any number of them)."""
        m, r, P = J.shape
        A = self.model.kernel(qs, qs) + self.sigma**2 * np.eye(m)
        factor = cho_factor(A, lower=True)
        HW = np.einsum("ij,jrp->irp", cho_solve(factor, np.eye(m)), J)  # (A⁻¹ ⊗ I) H
        G = np.einsum("irp,irq->pq", J, HW)
        try:
            Gf = cho_factor(G, lower=True)
        except np.linalg.LinAlgError:
            raise SingularPlan(P, r, m) from None
        if np.min(np.abs(np.diag(Gf[0]))) ** 2 < 1e-14 * np.max(np.abs(np.diag(Gf[0]))) ** 2:
            raise SingularPlan(P, r, m)
        out = np.empty(len(self.q0))
        k00 = np.diag(np.atleast_2d(self.model.kernel(self.q0[:1], self.q0[:1])))[0]  # s², stationary
        for start in range(0, len(self.q0), chunk):
            q0, J0 = self.q0[start : start + chunk], self.J0[start : start + chunk]
            k = self.model.kernel(qs, q0)  # (m, n)
            a = cho_solve(factor, k)  # (m, n): K_q⁻¹ k_q per test pose
            R = J0.transpose(0, 2, 1) - np.einsum("in,irp->npr", a, J)  # (n, P, r)
            X = cho_solve(Gf, R.transpose(1, 0, 2).reshape(P, -1)).reshape(P, len(q0), r)
            out[start : start + len(q0)] = r * (k00 - np.einsum("in,in->n", k, a)) + np.einsum(
                "npr,pnr->n", R, X
            )
        return out

    def swapped_traces(
        self, J: np.ndarray, qs: np.ndarray, i: int, J_cand: np.ndarray, q_cand: np.ndarray
    ) -> np.ndarray:
        """(N,) tr Σ₀ of the plan (J, qs) with configuration i replaced by each of N candidates
        (their Jacobians (N, r, P) and configurations (N, nq)), batched; inf where the plan would
        be singular."""
        m, r, P = J.shape
        N = len(J_cand)
        s2 = self.model.amplitude**2 + self.sigma**2
        A = np.repeat((self.model.kernel(qs, qs) + self.sigma**2 * np.eye(m))[None], N, axis=0)
        kc = self.model.kernel(q_cand, qs)  # (N, m)
        A[:, i, :] = kc
        A[:, :, i] = kc
        A[:, i, i] = s2
        Js = np.repeat(J[None], N, axis=0)
        Js[:, i] = J_cand
        HW = np.linalg.solve(A, Js.reshape(N, m, r * P)).reshape(N, m, r, P)  # (A⁻¹ ⊗ I) H
        G = np.einsum("nirp,nirq->npq", Js, HW)
        d = np.sqrt(np.abs(np.einsum("npp->np", G)))
        scaled = G / (d[:, :, None] * d[:, None, :] + 1e-300)
        regular = np.linalg.eigvalsh(scaled)[:, 0] > 1e-12
        out = np.full(N, np.inf)
        if not regular.any():
            return out
        k0 = np.repeat(self.model.kernel(qs, self.q0).T[None], N, axis=0)  # (N, k, m)
        k0[:, :, i] = self.model.kernel(q_cand, self.q0)
        a = np.linalg.solve(A, k0.transpose(0, 2, 1))  # (N, m, k)
        total = np.zeros(N)
        for t in range(len(self.q0)):
            R = self.J0[t].T[None] - np.einsum("ni,nirp->npr", a[:, :, t], Js)  # (N, P, r)
            X = np.zeros_like(R)
            X[regular] = np.linalg.solve(G[regular], R[regular])
            total += r * (self.k00 - np.einsum("ni,ni->n", k0[:, t], a[:, :, t])) + np.einsum(
                "npr,npr->n", R, X
            )
        out[regular] = total[regular] / len(self.q0)
        return out

    def plan_value(self, J: np.ndarray, qs: np.ndarray) -> float:
        """F = log tr Σ₀ of the plan with world-aligned Jacobian rows J (m, r, P) at qs."""
        return float(np.log(self.trace(J, qs)))

    def report(self, F: float | np.ndarray) -> float | np.ndarray:
        """The expected error [m]: sqrt(tr Σ₀)."""
        return np.sqrt(np.exp(F))

    def describe(self, value: float) -> str:
        return f"expected error with the residual model {value * 1e3:.4g} mm"

    def value(self, M: np.ndarray, m: int) -> float:
        raise NotImplementedError("the residual criterion depends on the configurations: use plan_value")

    # ------------------------------------------------------------ the exchange search
    def exchange(self, J_pool: np.ndarray, index: np.ndarray) -> _ResidualExchange:
        """An exchange state that scores each candidate swap by the exact criterion (the kernel
        matrix gains a row and a column: not a low-rank update of M)."""
        if self.pool is None:
            raise ValueError("the residual criterion's exchange needs the pool's configurations (pool=)")
        return _ResidualExchange(self, J_pool, np.array(index))


BATCH = 256
"""Candidate swaps scored together by :meth:`ResidualCriterion.swapped_traces`."""


class _ResidualExchange:
    """The exchange state of :class:`ResidualCriterion` (the protocol of
    :class:`~pincal.evaluation.criterion.ExchangeState`), exact values for every swap."""

    def __init__(self, criterion: ResidualCriterion, J_pool: np.ndarray, index: np.ndarray) -> None:
        assert criterion.pool is not None  # exchange() checks it
        self.criterion, self.pool = criterion, criterion.pool
        self.J_pool = J_pool
        self.index = index
        self.resync()

    def resync(self) -> None:
        J = self.J_pool[self.index]
        flat = J.reshape(-1, J.shape[-1])
        self.M = flat.T @ flat
        self.F = self.criterion.plan_value(J, self.pool[self.index])

    def scores(self, i: int, allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        cand = np.flatnonzero(allowed)
        pool, values = self.pool, np.empty(len(cand))
        for start in range(0, len(cand), BATCH):  # bounded memory: (batch, m, r, P) arrays
            c = cand[start : start + BATCH]
            traces = self.criterion.swapped_traces(
                self.J_pool[self.index], pool[self.index], i, self.J_pool[c], pool[c]
            )
            with np.errstate(divide="ignore"):
                values[start : start + BATCH] = np.log(traces)
        keep = np.isfinite(values)
        self._last = cand[keep]
        return cand[keep], values[keep]

    def swap(self, i: int, best: int) -> None:
        self.index[i] = self._last[best]
        self.resync()


@keywords_after(4)
def expected_error(
    params: ParameterSet,
    plan: ConfigurationsLike,
    test_pose: ConfigurationsLike,
    residual_model: ResidualModel,
    *,
    sigma: float = DEFAULT_SIGMA,
    task_payload: PayloadLike = None,
) -> float:
    """sqrt(tr Σ₀) [m]: the expected error at the test pose(s) after calibrating with ``plan`` and
    predicting with ``residual_model``'s kernel (see module doc; the mean over several test poses).
    The plan's own payloads (:attr:`~pincal.Plan.payload`) and the task's enter the Jacobians."""
    qs = params.robot.configurations(plan)
    q0 = resolve_test_poses(params.robot, test_pose)[0]  # a region's or path's samples
    if len(residual_model.revolute) != params.robot.nq:
        raise BadArgument(
            f"the residual model is over {len(residual_model.revolute)} joints; the robot has "
            f"{params.robot.nq}"
        )
    sigma = positive_sigma(sigma)
    J = params.jacobian(qs, frame="world", payload=getattr(plan, "payload", None))
    J0 = params.jacobian(q0, frame="world", payload=task_payload)
    criterion = ResidualCriterion(residual_model, J0, q0, sigma)
    return float(np.sqrt(criterion.trace(J, qs)))
