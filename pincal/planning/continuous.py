"""Continuous search: all m·nq joint values at once, by quasi-Newton methods.

The gradient is analytic in M: with G = ∂F/∂M (from the criterion,
:meth:`pincal.evaluation.criterion.Criterion.plan_gradient`) and M = Σᵢ JᵢᵀJᵢ,
∂F/∂q_ij = 2⟨Jᵢ G, ∂Jᵢ/∂q_ij⟩ (plus the criterion's own ∂F/∂Jᵢ and ∂F/∂q, if any). Only
∂Jᵢ/∂q_ij comes from central differences on the joint values: the Jacobians at qᵢ ± h e_j for
every configuration and joint are computed in one batch with the plan's own (m·(2nq+1)
configurations, one forward-kinematics pass each).

Joint limits (with their margin) are box bounds. With no other constraint the search is L-BFGS-B.
The other constraints (the mount, obstacles, the minimum spacing, ...) are nonlinear inequalities
on the joint values: their margins, each over its reach, must stay non-negative
(:meth:`pincal.planning.feasibility.Feasibility.constraint_values`), and the search is sequential
quadratic programming (SLSQP), which follows a binding constraint instead of stopping at it. A
logarithmic barrier on those margins with L-BFGS-B, used before, stopped early: on the README's
design (mount floor, 2° joint margin) its polishes ended after 20–40 iterations, at 1.00–1.09
times the best value 64 starts found, each step that crossed the floor shrinking the next; SLSQP
reaches 0.99–1.02 of it from the same plans.

The plan is kept regular the same way: the smallest eigenvalue λ of the Jacobi-scaled information
matrix (the conditioning, see :func:`conditioning`) must stay above a floor, so that a criterion
that improves all the way to a singular plan (ρ0 at a test pose at a singular limit) stops at the
floor instead: log(λ/floor) ≥ 0 is one more constraint, with ∂λ/∂M = uuᵀ − λ diag(v²/diag M)
(v the eigenvector, u = D⁻¹v). Without a floor (a prior) nor other constraints, L-BFGS-B. A final
exact check (and, should it ever fail, a repair towards the start) guarantees the plan returned
is feasible.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pincal.errors import SingularPlan
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.information import jacobi_scaled
from pincal.instruments.instrument import RowsEngine
from pincal.model.jacobian import JacobianEngine
from pincal.planning.feasibility import Feasibility

STEP = 1e-5
"""Central-difference step on the joint values for ∂J/∂q [rad or m]."""

SINGULAR_VALUE = 1e10
"""Objective value returned for a singular plan (the line search backs off)."""

FLOOR_SLACK = 1e-6
"""The floor constraint is log(λ/floor) ≥ this: a plan SLSQP leaves on the floor (to its
tolerance) is still strictly above it."""

MARGIN_SLACK = 1e-3
"""Each other constraint is margin/reach ≥ this: a plan the search leaves on a boundary keeps
this fraction of the reach from it (50 µm from a mounting plane, 20 µm from an obstacle), so that
it stays feasible for a model that differs from the designed one by rounding (a vendor URDF's
angles) and strictly inside, where a later continuous search may start from it."""

FTOL = 1e-13
"""The search stops when an iteration lowers F (a log: dimensionless) by less than this (L-BFGS-B:
relative; SLSQP: absolute). Measured with L-BFGS-B on the README's design (KR 270, 27 parameters,
m = 12, ±10° region): 1e-8 gives the same polished ρ0 to 0.03 % with a third of the evaluations,
but leaves the plan itself less converged: a D-optimal 2-link plan's ρ0 then differs from the
closed form by 1e-6 (first order in the plan), where 1e-13 reaches it to 1e-12; kept for that."""

STALL = (20, 1e-4)
"""(iterations, drop): a stage stops once its last ``iterations`` iterations lowered F (a log) by
less than ``drop`` in all, ρ0 by about 0.005 % (SLSQP: at a feasible iterate). Measured on the
README's design with its D-optimal baseline (10 seeds, 8 starts, the polishes of both): 72 % of
the evaluations of (40, 1e-5), the same worst ρ0 (1.0032 times that of 64 starts of the search
before SLSQP); (20, 1e-3) takes 49 % and reaches 1.0084; the 2-link closed forms converge before
it applies."""

KEPT_SLACK = 1e-3
"""A polish that ends across a constraint (SLSQP's iterates hover about a binding floor or margin,
within its tolerance) returns instead its best iterate that kept this fraction of the slacks
(:data:`FLOOR_SLACK`, :data:`MARGIN_SLACK`): inside every constraint, above the floor."""

SCREEN_POWER = 16.0
POWERS = (64.0, 512.0, 4096.0, 32768.0)
"""Power-mean exponents standing for the maximum (test-pose-worst): screening, then polishing."""


@dataclass(frozen=True)
class Outcome:
    """The end of one start of the continuous search.

    Attributes:
        q: (m, nq) final configurations [rad or m].
        F: objective value (exact criterion); inf if singular. Ranks starts after screening.
        feasible: the plan satisfies every constraint exactly.
        iterations: iterations of the search.
        time_s: wall time [s].
        message: the optimiser's last message.
    """

    q: np.ndarray
    F: float
    feasible: bool
    iterations: int
    time_s: float
    message: str


class PlanFunction:
    """Objective of a plan and its gradient with respect to the m·nq joint values, and the
    constraints the search keeps (the floor, the other constraints).

    Args:
        engine: the Jacobian engine of the parameter set (or the instrument's rows engine).
        objective: the criterion (of M).
        feasibility: the constraints.
        m: number of configurations.
        floor: smallest conditioning allowed (see :func:`conditioning`); 0: none.
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
        self.objective = objective
        self.feasibility = feasibility
        self.m = m
        self.nq = engine.model.nq
        self.shifts = STEP * np.eye(self.nq)[:, None, :]  # (nq, 1, nq)
        self.bounds = list(zip(np.tile(feasibility.lower, m), np.tile(feasibility.upper, m), strict=True))
        self.constrained = floor > 0 or not feasibility.trivial
        self._floor: tuple[bytes, float, np.ndarray] | None = None  # (x, log(λ/floor), its gradient)

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
        batch = np.concatenate([qs, (qs + self.shifts).reshape(-1, nq), (qs - self.shifts).reshape(-1, nq)])
        J = self.engine.jacobian(batch, frame="tip")
        J0 = J[:m]
        flat = J0.reshape(-1, P)
        M = flat.T @ flat
        dJ = (J[m : m + m * nq] - J[m + m * nq :]).reshape(nq, m, -1, P)
        if self.floor > 0:
            lam, dlam = _smallest(M)
            value = np.log(max(lam, 1e-300) / self.floor)
            slope_lam = (2.0 / (2.0 * STEP)) * np.einsum("irp,jirp->ij", J0 @ dlam, dJ)
            self._floor = (x.tobytes(), value - FLOOR_SLACK, slope_lam.ravel() / max(lam, 1e-300))
        try:
            slope = self.objective.plan_gradient(J0, qs)
        except SingularPlan:
            return SINGULAR_VALUE, np.zeros_like(x)
        grad = (2.0 / (2.0 * STEP)) * np.einsum("irp,jirp->ij", J0 @ slope.dM, dJ)
        if slope.dJ is not None:
            grad += (1.0 / (2.0 * STEP)) * np.einsum("irp,jirp->ij", slope.dJ, dJ)
        if slope.dq is not None:
            grad += slope.dq
        return slope.F, grad.ravel()

    def minimise(self, q0: np.ndarray, maxiter: int, inside: bool = False) -> tuple[np.ndarray, int, str]:
        """From q0 within the joint limits and the constraints (SLSQP; with none, L-BFGS-B), until
        it converges or stalls (:data:`STALL`); returns (q, iterations, message). ``inside``: a
        search that ends across a constraint returns its best iterate inside them all
        (:data:`KEPT_SLACK`)."""
        window, drop = STALL
        values: list[float] = []
        kept: list[tuple[float, np.ndarray]] = []  # the best iterate within every constraint
        if self.constrained:
            method, options = "SLSQP", {"maxiter": int(maxiter), "ftol": FTOL}
            constraints = [self._constraints()]
        else:
            method, options = "L-BFGS-B", {"maxiter": int(maxiter), "ftol": FTOL, "gtol": 1e-10, "maxls": 50}
            constraints = []

        def within(x: np.ndarray, slack: float = 1.0) -> bool:
            """Every constraint holds at x, keeping ``slack`` times the search's slacks."""
            if not constraints:
                return True
            v = constraints[0]["fun"](x) + (1 - slack) * MARGIN_SLACK
            if self.floor > 0:
                v[0] += (1 - slack) * (FLOOR_SLACK - MARGIN_SLACK)
            return bool(np.all(v >= 0))

        def stalled(intermediate_result) -> None:
            # SLSQP's iterates may cross a constraint on the way: it stops at a feasible one only.
            values.append(float(intermediate_result.fun))
            x = intermediate_result.x
            if inside and constraints and (not kept or values[-1] < kept[0][0]) and within(x, KEPT_SLACK):
                kept[:] = [(values[-1], np.array(x))]
            if len(values) > window and values[-window - 1] - values[-1] < drop:
                if within(x):
                    raise StopIteration

        res = _minimize(
            self,
            np.ravel(q0),
            jac=True,
            method=method,
            bounds=self.bounds,
            constraints=constraints,
            callback=stalled,
            options=options,
        )
        message, x = str(res.message), res.x
        if len(values) > window and values[-window - 1] - values[-1] < drop:
            message = f"F fell by less than {drop:g} over the last {window} iterations"
        if kept and not within(x, KEPT_SLACK):  # ended across a constraint: its best iterate inside
            x, message = kept[0][1], message + "; the best iterate within the constraints"
        return x.reshape(self.m, self.nq), int(res.nit), message

    def _constraints(self) -> dict:
        """The constraints for SLSQP: the floor's log(λ/floor) (computed with the objective at the
        same point) and the other constraints' margins (:meth:`Feasibility.constraint_values`),
        each computed once per point (SLSQP asks for the values and the Jacobian separately)."""
        feasibility, shape = self.feasibility, (self.m, self.nq)
        kept: dict[str, tuple[bytes, np.ndarray]] = {}

        def floor(x: np.ndarray) -> tuple[float, np.ndarray]:
            if self._floor is None or self._floor[0] != x.tobytes():
                self(x)
            assert self._floor is not None  # set by the call
            return self._floor[1], self._floor[2]

        Of = Callable[[np.ndarray], np.ndarray]

        def once(name: str, compute: Of) -> Of:
            def value(x: np.ndarray) -> np.ndarray:
                key = x.tobytes()
                last = kept.get(name)
                if last is None or last[0] != key:
                    last = kept[name] = (key, compute(x.reshape(shape)))
                return last[1]

            return value

        margins = once("values", lambda qs: feasibility.constraint_values(qs) - MARGIN_SLACK)
        slopes = once("jacobian", feasibility.constraint_jacobian)
        if self.floor <= 0:
            return {"type": "ineq", "fun": margins, "jac": slopes}
        return {
            "type": "ineq",
            "fun": lambda x: np.concatenate([[floor(x)[0]], margins(x)]),
            "jac": lambda x: np.vstack([floor(x)[1][None], slopes(x)]),
        }

    def set_power(self, power: float | None) -> None:
        self.objective = self.objective.with_power(power)


def _smallest(M: np.ndarray) -> tuple[float, np.ndarray]:
    """(λ, ∂λ/∂M): the conditioning of M (the smallest eigenvalue of D⁻¹MD⁻¹, D = diag(M)^½) and
    its derivative uuᵀ − λ diag(v²/diag M), v the eigenvector, u = D⁻¹v."""
    d, scaled = jacobi_scaled(M)
    w, V = np.linalg.eigh(scaled)
    lam, v = float(w[0]), V[:, 0]
    u = v / d
    return lam, np.outer(u, u) - lam * np.diag(v**2 / d**2)


def screen(fn: PlanFunction, q0: np.ndarray, iterations: int) -> Outcome:
    """A few iterations from q0, to rank starts."""
    t0 = time.perf_counter()
    fn.set_power(SCREEN_POWER)
    q, nit, message = fn.minimise(q0, iterations)
    fn.set_power(None)
    F = fn.criterion(q)
    return Outcome(q, F, fn.feasibility.plan_feasible(q), nit, time.perf_counter() - t0, message)


def polish(fn: PlanFunction, q0: np.ndarray, anchor: np.ndarray, maxiter: int) -> Outcome:
    """Run to convergence from q0 (for the worst case, through the power-mean stages); check the
    plan exactly.

    Args:
        fn: the plan function.
        q0: (m, nq) where to start (feasible).
        anchor: a feasible plan (the start's original configurations) to repair towards, should
            the final plan fail the exact check.
        maxiter: iterations allowed per stage.
    """
    t0 = time.perf_counter()
    q, total, message = np.array(q0), 0, ""
    for power in POWERS if fn.objective.smoothed else (None,):
        fn.set_power(power)
        q, nit, message = fn.minimise(q, maxiter, inside=True)
        total += nit
    fn.set_power(None)
    feasible = fn.feasibility.plan_feasible(q)
    if not feasible:
        q = fn.feasibility.repair(anchor, q)
        feasible = fn.feasibility.plan_feasible(q)
        message = f"repaired towards the start ({message})"
    F = fn.criterion(q)
    return Outcome(q, F, feasible, total, time.perf_counter() - t0, message)


def _minimize(*args, **kwargs):
    """scipy.optimize.minimize, imported on first use (it is slow to import)."""
    return load_optimiser()(*args, **kwargs)


def load_optimiser():
    """scipy.optimize.minimize, imported now: a process about to fork its workers imports it once
    for them all (each worker importing it costs about 0.5 s of CPU)."""
    from scipy.optimize import minimize

    return minimize
