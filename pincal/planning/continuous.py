"""Continuous search: all m·nq joint values at once, by bounded quasi-Newton (L-BFGS-B).

The gradient is analytic in M: with G = ∂F/∂M (from the criterion,
:meth:`pincal.evaluation.criterion.Criterion.plan_gradient`) and M = Σᵢ JᵢᵀJᵢ,
∂F/∂q_ij = 2⟨Jᵢ G, ∂Jᵢ/∂q_ij⟩ (plus the criterion's own ∂F/∂Jᵢ and ∂F/∂q, if any). Only
∂Jᵢ/∂q_ij comes from central differences on the joint values: the Jacobians at qᵢ ± h e_j for
every configuration and joint are computed in one batch with the plan's own (m·(2nq+1)
configurations, one forward-kinematics pass each).

Joint limits (with their margin) are the optimiser's box bounds. The other constraints add a
truncated logarithmic barrier (see :meth:`pincal.planning.feasibility.Feasibility.barrier`): starts are
strictly feasible and a step that leaves the feasible set gets a huge value, so the line search
never accepts it and every iterate stays feasible. The same kind of barrier keeps the plan
regular: the smallest eigenvalue of the Jacobi-scaled information matrix (the conditioning, see
:func:`conditioning`) stays above a floor, so that a criterion that improves all the way to a
singular plan (ρ0 at a test pose at a singular limit) stops at the floor instead. The barrier's
weight is lowered in stages, letting the plan approach the boundaries. A final exact check (and,
should it ever fail, a repair towards the start) guarantees the plan returned is feasible.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pincal.errors import SingularPlan
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.information import conditioning, jacobi_scaled
from pincal.instruments.instrument import RowsEngine
from pincal.model.jacobian import JacobianEngine
from pincal.planning.feasibility import Feasibility

STEP = 1e-5
"""Central-difference step on the joint values for ∂J/∂q [rad or m]."""

SINGULAR_VALUE = 1e10
"""Objective value returned for a singular or infeasible plan (the line search backs off)."""

WEIGHTS = (1e-2, 1e-5)
"""Barrier weights of the successive stages (the objective F is a log: dimensionless)."""

FTOL = 1e-13
"""L-BFGS-B stops when an iteration lowers F (a log: dimensionless) by less than this relative
amount. Measured on the README's design (KR 270, 27 parameters, m = 12, ±10° region): 1e-8 gives
the same polished ρ0 to 0.03 % with a third of the evaluations, but leaves the plan itself less
converged: a D-optimal 2-link plan's ρ0 then differs from the closed form by 1e-6 (first order in
the plan), where 1e-13 reaches it to 1e-12; kept for that."""

STALL = (40, 1e-5)
"""(iterations, drop): a stage stops once its last ``iterations`` L-BFGS-B iterations lowered F
(a log) by less than ``drop`` in all, ρ0 by about 0.0005 %: the tail after that rarely pays.
Measured on the README's design (5 seeds, its 20 polish stages and those of its D-optimal
baseline): 57 % of the evaluations of running to FTOL, each stage ending at most 1.5e-4 in F
(0.007 % in ρ0) above where FTOL stops it, 2e-5 on average; the 2-link closed forms converge
before it applies."""

SCREEN_POWER = 16.0
POWERS = (64.0, 512.0, 4096.0, 32768.0)
"""Power-mean exponents standing for the maximum (test-pose-worst): screening, then polishing."""
CONDITIONING_BAND = 10.0
"""The conditioning barrier acts between the floor and this many times the floor."""


@dataclass(frozen=True)
class Outcome:
    """The end of one start of the continuous search.

    Attributes:
        q: (m, nq) final configurations [rad or m].
        F: objective value (exact criterion, no penalty); inf if singular.
        score: F plus the barrier, used to rank starts after screening.
        feasible: the plan satisfies every constraint exactly.
        iterations: L-BFGS-B iterations.
        time_s: wall time [s].
        message: the optimiser's last message.
    """

    q: np.ndarray
    F: float
    score: float
    feasible: bool
    iterations: int
    time_s: float
    message: str


class PlanFunction:
    """Objective of a plan (plus the constraints' barrier) and its gradient with respect to the
    m·nq joint values.

    Args:
        engine: the Jacobian engine of the parameter set (or the instrument's rows engine).
        objective: the criterion (of M).
        feasibility: the constraints.
        m: number of configurations.
        floor: smallest conditioning allowed (see :func:`conditioning`).
    """

    def __init__(
        self,
        engine: JacobianEngine | RowsEngine,
        objective: Criterion,
        feasibility: Feasibility,
        m: int,
        floor: float = 1e-6,
    ) -> None:
        self.engine = engine
        self.floor = floor
        self.log_band = np.log(CONDITIONING_BAND)
        self.objective = objective
        self.feasibility = feasibility
        self.m = m
        self.nq = engine.model.nq
        self.weight = WEIGHTS[0]
        self.shifts = STEP * np.eye(self.nq)[:, None, :]  # (nq, 1, nq)
        self.bounds = list(zip(np.tile(feasibility.lower, m), np.tile(feasibility.upper, m), strict=True))

    def information(self, qs: np.ndarray) -> np.ndarray:
        J = self.engine.jacobian(qs, frame="tip").reshape(-1, self.engine.n_params)
        return J.T @ J

    def criterion(self, qs: np.ndarray) -> float:
        """F of the plan, exact (no penalty, true maximum); inf if singular."""
        try:
            return self.objective.plan_value(self.engine.jacobian(qs, frame="tip"), qs)
        except SingularPlan:
            return np.inf

    def __call__(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        m, nq, P = self.m, self.nq, self.engine.n_params
        qs = x.reshape(m, nq)
        barrier, bgrad = 0.0, None
        if not self.feasibility.trivial:
            barrier, bgrad = self.feasibility.barrier(qs, self.weight)
            if bgrad is None:
                return SINGULAR_VALUE, np.zeros_like(x)
        batch = np.concatenate([qs, (qs + self.shifts).reshape(-1, nq), (qs - self.shifts).reshape(-1, nq)])
        J = self.engine.jacobian(batch, frame="tip")
        J0 = J[:m]
        flat = J0.reshape(-1, P)
        M = flat.T @ flat
        try:
            slope = self.objective.plan_gradient(J0, qs)
            F, G = self._regular(M, slope.F, slope.dM)
        except SingularPlan:
            return SINGULAR_VALUE, np.zeros_like(x)
        dJ = (J[m : m + m * nq] - J[m + m * nq :]).reshape(nq, m, -1, P)
        grad = (2.0 / (2.0 * STEP)) * np.einsum("irp,jirp->ij", J0 @ G, dJ)
        if slope.dJ is not None:
            grad += (1.0 / (2.0 * STEP)) * np.einsum("irp,jirp->ij", slope.dJ, dJ)
        if slope.dq is not None:
            grad += slope.dq
        if bgrad is not None:
            F += barrier
            grad += bgrad
        return F, grad.ravel()

    def _regular(self, M: np.ndarray, F: float, G: np.ndarray) -> tuple[float, np.ndarray]:
        """Add the conditioning barrier: φ(x) = x − 1 − log x, x = log(λ/floor)/log(band), for
        λ = conditioning(M) below band·floor (∂λ/∂M = uuᵀ − λ diag(v²/diag M), u = D⁻¹v)."""
        if self.floor <= 0:  # no floor (a prior keeps every plan regular)
            return F, G
        d, scaled = jacobi_scaled(M)
        w = np.linalg.eigvalsh(scaled)
        lam = w[0]
        if lam >= self.floor * CONDITIONING_BAND:
            return F, G
        if lam <= self.floor:
            raise SingularPlan(len(M), self.engine.rows, self.m)
        w, V = np.linalg.eigh(scaled)
        v = V[:, 0]
        x = np.log(lam / self.floor) / self.log_band
        dphi = (1.0 - 1.0 / x) / (lam * self.log_band)
        u = v / d
        dlam = np.outer(u, u) - lam * np.diag(v**2 / np.diag(M))
        return F + self.weight * (x - 1.0 - np.log(x)), G + self.weight * dphi * dlam

    def minimise(self, q0: np.ndarray, maxiter: int) -> tuple[np.ndarray, int, str]:
        """L-BFGS-B from q0 within the joint limits, until it converges or stalls (:data:`STALL`);
        returns (q, iterations, message)."""
        window, drop = STALL
        values: list[float] = []

        def stalled(intermediate_result) -> None:
            values.append(float(intermediate_result.fun))
            if len(values) > window and values[-window - 1] - values[-1] < drop:
                raise StopIteration

        res = _minimize(
            self,
            np.ravel(q0),
            jac=True,
            method="L-BFGS-B",
            bounds=self.bounds,
            callback=stalled,
            options={"maxiter": int(maxiter), "ftol": FTOL, "gtol": 1e-10, "maxls": 50},
        )
        message = str(res.message)
        if len(values) > window and values[-window - 1] - values[-1] < drop:
            message = f"F fell by less than {drop:g} over the last {window} iterations"
        return res.x.reshape(self.m, self.nq), int(res.nit), message

    def set_power(self, power: float | None) -> None:
        self.objective = self.objective.with_power(power)

    def score(self, qs: np.ndarray) -> float:
        F = self.criterion(qs)
        if self.feasibility.trivial or not np.isfinite(F):
            return F
        return F + self.feasibility.barrier(qs, self.weight)[0]


def screen(fn: PlanFunction, q0: np.ndarray, iterations: int) -> Outcome:
    """A few iterations from q0 (first barrier weight), to rank starts."""
    t0 = time.perf_counter()
    fn.weight = WEIGHTS[0]
    fn.set_power(SCREEN_POWER)
    q, nit, message = fn.minimise(q0, iterations)
    fn.set_power(None)
    return Outcome(
        q,
        fn.criterion(q),
        fn.score(q),
        fn.feasibility.plan_feasible(q),
        nit,
        time.perf_counter() - t0,
        message,
    )


def polish(fn: PlanFunction, q0: np.ndarray, anchor: np.ndarray, maxiter: int) -> Outcome:
    """Run to convergence from q0 through the barrier stages; check the plan exactly.

    Args:
        fn: the plan function.
        q0: (m, nq) where to start (strictly feasible).
        anchor: a feasible plan (the start's original configurations) to repair towards, should
            the final plan fail the exact check.
        maxiter: L-BFGS-B iterations allowed per stage.
    """
    t0 = time.perf_counter()
    worst = fn.objective.smoothed
    trivial = fn.feasibility.trivial
    powers = POWERS if worst else (None,) * len(WEIGHTS)
    weights = WEIGHTS + (WEIGHTS[-1],) * (len(powers) - len(WEIGHTS))
    stages = list(zip(powers, weights, strict=True))
    q, total, message = np.array(q0), 0, ""
    for k, (power, weight) in enumerate(stages):
        if k and trivial and not worst and conditioning(fn.information(q)) >= fn.floor * CONDITIONING_BAND:
            break  # nothing for a lower barrier weight to change
        fn.set_power(power)
        fn.weight = weight
        q, nit, message = fn.minimise(q, maxiter)
        total += nit
    fn.set_power(None)
    fn.weight = WEIGHTS[0]
    feasible = fn.feasibility.plan_feasible(q)
    if not feasible:
        q = fn.feasibility.repair(anchor, q)
        feasible = fn.feasibility.plan_feasible(q)
        message = f"repaired towards the start ({message})"
    F = fn.criterion(q)
    return Outcome(q, F, F, feasible, total, time.perf_counter() - t0, message)


def _minimize(*args, **kwargs):
    """scipy.optimize.minimize, imported on first use (it is slow to import)."""
    return load_optimiser()(*args, **kwargs)


def load_optimiser():
    """scipy.optimize.minimize, imported now: a process about to fork its workers imports it once
    for them all (each worker importing it costs about 0.5 s of CPU)."""
    from scipy.optimize import minimize

    return minimize
