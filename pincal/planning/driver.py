"""Designing measurement plans: the m configurations that minimise a criterion (SPEC §5).

:func:`design` is the one driver; the search method is chosen by name:

* ``"continuous"``: all m·nq joint values at once, by bounded quasi-Newton (L-BFGS-B) with the
  analytic gradient of the criterion (:mod:`pincal._continuous`), from many starts drawn inside
  the constraints. Every start first runs ``screen_iterations`` iterations; only the best
  ``keep`` fraction continues to convergence.
* ``"exchange"``: Fedorov-style exchange over a pool of feasible candidate configurations, with
  Sherman–Morrison–Woodbury updates (:mod:`pincal._exchange`). The pool is drawn at random
  (seeded, feasible) or given: real cells often have taught, known-safe poses and want the best m
  of them. With a generated pool the best exchange results are then polished by the continuous
  search (``polish``, on by default): the default method, fastest to the best plans we know.

Both minimise any criterion of :data:`CRITERIA`: ``test-pose`` (ρ0, the mean over several test
poses), ``test-pose-worst`` (the worst test pose), ``D``, ``A``, ``E``, ``cond``.

Starts run in parallel through any ``concurrent.futures.Executor``: by default a process pool of
``workers`` processes (all CPUs) when there is more than one start; ``workers=1`` runs serially.
For more than one machine, pass a cluster's executor, e.g. with dask.distributed::

    from dask.distributed import Client
    with Client("scheduler:8786") as client:
        result = pincal.design(params, m=12, test_pose=q0, starts=512,
                               executor=client.get_executor())

or with Ray (``from ray.util.concurrent.futures.ray_executor import RayExecutor``;
``executor=RayExecutor()``). The work items are plain picklable data; each worker rebuilds the
problem once. Per-start seeds come from ``numpy.random.SeedSequence(seed).spawn``, so the same
seed gives the same plan whatever the executor and the number of workers.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np

from pincal.errors import DegenerateOptimum, DegenerateOptimumWarning, Infeasible, PincalError, SingularPlan
from pincal.evaluation.classic import criteria_from_jacobian
from pincal.evaluation.information import conditioning, factor, rank
from pincal.evaluation.test_pose import TestPoseCriterion
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.planning import multistart as _multistart
from pincal.planning.constraints import AnyConstraint
from pincal.planning.feasibility import Feasibility
from pincal.planning.objectives import CRITERIA, TEST_POSE_CRITERIA, criterion_name, make_objective
from pincal.planning.plan import Plan

METHODS = ("continuous", "exchange")
"""Names of the search methods."""

DEFAULT_POOL = 2000
"""Candidate configurations drawn when no pool is given."""

MIN_CONDITIONING = 1e-4
"""Default floor of a plan's conditioning: the smallest eigenvalue of its Jacobi-scaled
information matrix (σ_min² of the stacked Jacobian with unit columns: 1e-4 keeps σ_min ≥ 1 %).
The test-pose criterion only needs the parameter combinations that move the test pose, so it
often improves towards singular plans; the floor keeps every parameter identifiable, and keeps
the search out of near-singular basins, where its local optima are poor."""

__all__ = [
    "CRITERIA",
    "METHODS",
    "DegenerateOptimum",
    "DegenerateOptimumWarning",
    "DesignResult",
    "RandomPlans",
    "StartRecord",
    "design",
    "random_plans",
]


@dataclass(frozen=True)
class StartRecord:
    """What one start of the search did (for convergence plots).

    Attributes:
        start: index of the start.
        value: criterion value at its end, in the criterion's units (inf if singular).
        screen_value: value after the screening iterations (continuous method), else None.
        iterations: optimiser iterations (continuous) or exchange sweeps (exchange).
        time_s: wall time of this start [s].
        continued: run to convergence (False: dropped after screening).
        feasible: its plan satisfies every constraint.
        message: the optimiser's last message.
    """

    start: int
    value: float
    screen_value: float | None
    iterations: int
    time_s: float
    continued: bool
    feasible: bool
    message: str = ""

    def as_dict(self) -> dict:
        d = dict(self.__dict__)
        d["value"] = _finite(self.value)
        d["screen_value"] = None if self.screen_value is None else _finite(self.screen_value)
        return d


@dataclass(frozen=True)
class DesignResult:
    """A designed measurement plan.

    Attributes:
        plan: the m configurations [rad or m].
        value: the criterion's value (units: ρ0 [m] for the test-pose criteria; log det M⁻¹,
            tr M⁻¹, λ_max(M⁻¹), cond for D, A, E, cond), as :func:`pincal.rho0` and
            :func:`pincal.criteria` compute it.
        criterion: the criterion minimised.
        rho0: ρ0 at the test pose(s) [m] for ``sigma`` (root mean square over several; worst for
            ``test-pose-worst``); None without a test pose.
        rho0_each: (k,) ρ0 at each test pose [m], or None.
        sigma: measurement noise per coordinate [m].
        method: the search method.
        starts: starts run.
        continued: starts run to convergence.
        seed: the entropy of the seed sequence (pass it as ``seed`` to repeat the design).
        time_s: wall time [s].
        history: one record per start.
        pool_size: candidate configurations (the exchange's pool, or where starts were drawn).
        pool_rejected: configurations of a user pool dropped as infeasible.
        conditioning: the plan's conditioning, the smallest eigenvalue of its Jacobi-scaled
            information matrix (in (0, 1]; see ``min_conditioning`` of :func:`design`).
        message: a one-line summary.
    """

    plan: Plan
    value: float
    criterion: str
    rho0: float | None
    rho0_each: np.ndarray | None
    sigma: float
    method: str
    starts: int
    continued: int
    seed: int
    time_s: float
    history: tuple[StartRecord, ...]
    pool_size: int
    pool_rejected: int
    conditioning: float
    message: str

    @property
    def m(self) -> int:
        """Number of configurations."""
        return len(self.plan)

    def as_dict(self) -> dict:
        """A JSON-ready dict (radians, metres)."""
        return {
            "plan": self.plan.q.tolist(),
            "joint_names": list(self.plan.joint_names),
            "m": self.m,
            "criterion": self.criterion,
            "value": _finite(self.value),
            "rho0": self.rho0,
            "rho0_per_test_pose": None if self.rho0_each is None else self.rho0_each.tolist(),
            "sigma": self.sigma,
            "method": self.method,
            "starts": self.starts,
            "continued": self.continued,
            "seed": self.seed,
            "time_s": self.time_s,
            "pool_size": self.pool_size,
            "pool_rejected": self.pool_rejected,
            "conditioning": self.conditioning,
            "message": self.message,
            "history": [h.as_dict() for h in self.history],
        }


@dataclass(frozen=True)
class RandomPlans:
    """The distribution of a criterion over random feasible plans (the baseline).

    Attributes:
        criterion: the criterion (``test-pose`` or ``test-pose-worst``: ρ0 [m]).
        m: configurations per plan.
        n: plans drawn.
        n_singular: plans with a singular information matrix (no finite value).
        values: (n − n_singular,) the finite values, in draw order, read-only.
        sigma: measurement noise per coordinate [m].
    """

    criterion: str
    m: int
    n: int
    n_singular: int
    values: np.ndarray
    sigma: float

    @property
    def min(self) -> float:
        return float(self.values.min()) if len(self.values) else math.nan

    @property
    def mean(self) -> float:
        return float(self.values.mean()) if len(self.values) else math.nan

    @property
    def median(self) -> float:
        return float(np.median(self.values)) if len(self.values) else math.nan

    @property
    def max(self) -> float:
        return float(self.values.max()) if len(self.values) else math.nan

    def as_dict(self) -> dict:
        """``{min, mean, median, max, n, n_singular, m, criterion, sigma}`` (NaN as None)."""
        return {
            "min": _finite(self.min),
            "mean": _finite(self.mean),
            "median": _finite(self.median),
            "max": _finite(self.max),
            "n": self.n,
            "n_singular": self.n_singular,
            "m": self.m,
            "criterion": self.criterion,
            "sigma": self.sigma,
        }


def _finite(v: float) -> float | None:
    return float(v) if v is not None and np.isfinite(v) else None


# ------------------------------------------------------------------------- validation
def _positive_int(value: object, name: str, low: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise PincalError(f"{name} must be an integer ≥ {low}, got {value!r}")
    return int(value)


def _check_m(params: ParameterSet, m: object) -> int:
    m = _positive_int(m, "m (number of configurations)")
    rows = 3 * params.robot.n_markers
    if m * rows < len(params):
        raise SingularPlan(len(params), rows, m)
    return m


def _test_poses(params: ParameterSet, test_pose: object, criterion: str) -> np.ndarray | None:
    if test_pose is None:
        if criterion in TEST_POSE_CRITERIA:
            raise PincalError(f"criterion {criterion!r} needs a test pose (test_pose=...)")
        return None
    return params.robot.configurations(test_pose, what="test pose")


def _sigma(sigma: float) -> float:
    try:
        s = float(sigma)
    except (TypeError, ValueError):
        s = math.nan
    if not (math.isfinite(s) and s > 0):
        raise PincalError(f"sigma must be a positive number of metres, got {sigma!r}")
    return s


# ------------------------------------------------------------------------------ starts
def _pick(
    J: np.ndarray, pool: np.ndarray, m: int, spacing: float, rng: np.random.Generator, floor: float
) -> np.ndarray:
    """Indices of m pool configurations forming a regular plan (conditioning above ``floor``, spaced),
    at random."""
    N, rows, P = J.shape
    best_rank = 0
    for _ in range(100):
        order = rng.permutation(N)
        if spacing > 0:
            chosen: list[int] = []
            for c in order:
                if all(np.linalg.norm(pool[c] - pool[k]) >= spacing for k in chosen):
                    chosen.append(int(c))
                    if len(chosen) == m:
                        break
            if len(chosen) < m:
                raise Infeasible(
                    f"cannot place {m} configurations at least {spacing:.4g} rad apart among the "
                    f"{N} feasible candidates; lower min_spacing"
                )
            index = np.array(chosen)
        else:
            index = order[:m]
        stacked = J[index].reshape(-1, P)
        M = stacked.T @ stacked
        try:
            factor(M, rows, m)
            if conditioning(M) > 2 * floor:
                return index
        except SingularPlan:
            pass
        best_rank = max(best_rank, rank(M))
    if best_rank == P:
        raise Infeasible(
            f"no random plan of {m} configurations reaches twice the conditioning floor {floor:g}; "
            f"lower min_conditioning or add configurations"
        )
    raise SingularPlan(P, rows, m, best_rank)


def _user_pool(robot, pool: object, feasibility: Feasibility, m: int) -> tuple[np.ndarray, int]:
    qs = robot.configurations(pool, what="pool configuration")
    ok = feasibility.feasible(qs)
    if ok.sum() < m:
        raise Infeasible(
            f"only {int(ok.sum())} of the {len(qs)} pool configurations satisfy the constraints; "
            f"{m} are needed"
        )
    return qs[ok], int((~ok).sum())


# ------------------------------------------------------------------------------ driver
def design(
    params: ParameterSet,
    m: int,
    test_pose: object = None,
    criterion: str = "test-pose",
    *,
    method: str = "exchange",
    constraints: Iterable[AnyConstraint] = (),
    pool: object = None,
    starts: int = 32,
    seed: int | None = 0,
    sigma: float = 1.0,
    executor: Executor | None = None,
    workers: int | None = None,
    init: Sequence[object] = (),
    polish: bool | None = None,
    keep: float = 0.25,
    screen_iterations: int = 20,
    maxiter: int = 3000,
    min_conditioning: float = MIN_CONDITIONING,
    progress: bool = False,
) -> DesignResult:
    """Find the m measurement configurations that minimise a criterion, within the constraints.

    Args:
        params: the parameters to identify (an identifiable set).
        m: number of configurations.
        test_pose: (nq,) or (k, nq) test pose(s) [rad or m]; required by the test-pose criteria,
            used to report ρ0 otherwise.
        criterion: one of :data:`CRITERIA` (case-insensitive).
        method: ``"exchange"`` (default) or ``"continuous"`` (see module doc).
        constraints: constraint objects of :mod:`pincal.constraints` (joint limits always apply).
        pool: candidates for the exchange method: (N, nq) configurations or a Plan (infeasible
            ones are dropped), or the number of random feasible candidates to draw (default
            2000; the continuous method draws its starts from it).
        starts: number of starts.
        seed: seed of every random choice (None: fresh entropy, reported in ``result.seed``).
        sigma: measurement noise per coordinate [m]; ρ0 is proportional to it.
        executor: a ``concurrent.futures.Executor`` to run the starts on (see module doc).
        workers: processes of the default process pool (default: all CPUs; 1: serial).
        init: plans (each (m, nq), feasible) to use as extra first starts of the continuous
            method, e.g. an exchange design's plan.
        polish: exchange method: continue the best ``keep`` fraction of exchange results with the
            continuous search. Default: on for a generated pool, off for a given pool (polishing
            would leave the taught poses, so it cannot be asked for then).
        keep: fraction of starts run to convergence after screening (continuous), or polished.
        screen_iterations: L-BFGS-B iterations every start runs before the poor ones are dropped.
        maxiter: L-BFGS-B iterations allowed per start and stage.
        min_conditioning: floor of the plan's conditioning, the smallest eigenvalue of its
            Jacobi-scaled information matrix (in (0, 0.1); 0 is singular). No plan below it is
            returned; the continuous search keeps above it with a barrier. A plan that ends near
            the floor comes with a :class:`DegenerateOptimumWarning`: the criterion would keep
            improving towards singular plans (ρ0 at a test pose at a singular limit does).
        progress: show a progress bar on stderr (starts done, best value so far).

    Returns:
        the best plan found, with its criterion value, ρ0 and the history of every start.

    Raises:
        SingularPlan: m is too small for the parameters (the message names the minimum), or
            no regular plan can be formed.
        Infeasible: no configuration (or not enough) satisfies the constraints.
        DegenerateOptimum: every start ended on a plan below the conditioning floor (exchange).
        UnknownName: unknown criterion (the message lists the valid ones).
        PincalError: any other invalid argument.

    Example:
        >>> import math, pincal
        >>> params = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")
        >>> result = pincal.design(params, m=2, test_pose=[0.0, 1.0], starts=4, workers=1)
        >>> round(result.rho0**2 / ((1 + math.sin(1.0)) / 2), 9)  # SPEC §6 closed form, σ = 1
        1.0
    """
    floor = min_conditioning
    with _multistart.single_threaded_blas():  # small matrices: BLAS threads only contend
        t_start = time.perf_counter()
        criterion = criterion_name(criterion)
        if method not in METHODS:
            raise PincalError(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
        m = _check_m(params, m)
        robot = params.robot
        test_poses = _test_poses(params, test_pose, criterion)
        sigma = _sigma(sigma)
        starts = _positive_int(starts, "starts")
        workers = _multistart.default_workers() if workers is None else _positive_int(workers, "workers")
        if not (isinstance(keep, (int, float)) and 0 < keep <= 1):
            raise PincalError(f"keep must be a fraction in (0, 1], got {keep!r}")
        screen_iterations = _positive_int(screen_iterations, "screen_iterations", 0)
        maxiter = _positive_int(maxiter, "maxiter")
        if not (isinstance(floor, (int, float)) and 0 < floor < 0.1):
            raise PincalError(f"min_conditioning must be a number in (0, 0.1), got {floor!r}")
        constraints = tuple(constraints)
        feasibility = Feasibility(robot, constraints)
        if seed is not None:
            seed = _positive_int(seed, "seed", 0)
        sequence = np.random.SeedSequence(seed)
        pool_seq, start_seq = sequence.spawn(2)

        user_pool = pool is not None and not isinstance(pool, (int, np.integer))
        if method == "continuous":
            if polish:
                raise PincalError("polish refines exchange results; the continuous method needs none")
            polish = False
        elif polish is None:
            polish = not user_pool
        rejected = 0
        if user_pool:
            if method != "exchange":
                raise PincalError("a pool of configurations is searched by method='exchange'")
            if polish:
                raise PincalError(
                    "polish would move the plan off the given pool; use a generated pool to polish"
                )
            polish = False
            candidates, rejected = _user_pool(robot, pool, feasibility, m)
        else:
            size = DEFAULT_POOL if pool is None else _positive_int(pool, "pool size", m)
            # The continuous search starts strictly inside the constraints (Feasibility.barrier).
            strict = method == "continuous" or polish
            candidates = feasibility.sample(size, np.random.default_rng(pool_seq), minimum=m, strict=strict)
        init = [robot.configurations(q, what="init plan configuration") for q in init]
        if init and method != "continuous":
            raise PincalError("init plans start the continuous method; use method='continuous'")
        for q in init:
            if (
                q.shape != (m, robot.nq)
                or not feasibility.plan_feasible(q)
                or not feasibility.strictly_feasible(q).all()
            ):
                raise Infeasible(
                    f"an init plan must hold {m} configurations strictly inside every constraint"
                )

        engine = JacobianEngine(params)
        J_pool = engine.jacobian(candidates, frame="tip")
        rngs = [np.random.default_rng(s) for s in start_seq.spawn(starts)]
        indices = [_pick(J_pool, candidates, m, feasibility.spacing, rng, floor) for rng in rngs]
        spec = _multistart.ProblemSpec(
            params,
            m,
            criterion,
            test_poses,
            sigma,
            constraints,
            candidates if method == "exchange" else None,
            floor,
        )
        J0 = engine.jacobian(test_poses, frame="tip").copy() if test_poses is not None else None
        objective = make_objective(
            criterion, len(params), engine.rows, J0 if criterion in TEST_POSE_CRITERIA else None, sigma
        )
        n_starts = len(init) + starts
        n_keep = n_starts if keep >= 1 else max(1, math.ceil(keep * n_starts))
        bar = _progress_bar(
            progress, n_starts + (n_keep if (method == "continuous" and n_keep < n_starts) or polish else 0)
        )
        best = [math.inf]

        def done(outcome) -> None:
            if bar is None:
                return
            feasible = getattr(outcome, "feasible", True)
            if feasible and np.isfinite(outcome.F):
                best[0] = min(best[0], float(objective.report(outcome.F)))
            bar.update(1)
            bar.set_postfix_str(f"best {criterion} {best[0]:.6g}")

        records: dict[int, dict] = {}
        finals: dict[int, tuple[np.ndarray, float, bool]] = {}
        try:
            with _multistart.executor_for(executor, workers, n_starts) as ex:
                if method == "continuous":
                    x0s = list(init) + [candidates[i] for i in indices]
                    _continuous_search(
                        spec, ex, x0s, n_keep, screen_iterations, maxiter, objective, records, finals, done
                    )
                else:
                    outcomes = _multistart.run(
                        ex, _multistart.exchange_task, [(spec, i) for i in indices], done
                    )
                    for s, o in enumerate(outcomes):
                        q = candidates[o.index]
                        records[s] = dict(
                            start=s,
                            value=float(objective.report(o.F)),
                            screen_value=None,
                            iterations=o.sweeps,
                            time_s=o.time_s,
                            continued=True,
                            feasible=True,
                            message=f"{o.swaps} exchanges",
                        )
                        finals[s] = (q, o.F, True)
                    if polish:
                        order = sorted(finals, key=lambda s: (finals[s][1], s))[:n_keep]
                        items = [(spec, finals[s][0], finals[s][0], maxiter) for s in order]
                        polished = _multistart.run(ex, _multistart.polish_task, items, done)
                        for s, o in zip(order, polished, strict=True):
                            records[s].update(
                                value=float(objective.report(o.F)),
                                iterations=records[s]["iterations"] + o.iterations,
                                time_s=records[s]["time_s"] + o.time_s,
                                feasible=o.feasible,
                                message=records[s]["message"] + "; polished: " + o.message,
                            )
                            if o.feasible and o.F <= finals[s][1] and _conditioning(engine, o.q) > floor:
                                finals[s] = (o.q, o.F, True)
        finally:
            if bar is not None:
                bar.close()
            _multistart.forget(spec)

        usable = [s for s in sorted(finals) if finals[s][2] and np.isfinite(finals[s][1])]
        if not usable:
            raise Infeasible(
                f"none of the {n_starts} starts ended in a feasible, regular plan; "
                "relax the constraints or add starts"
            )
        # No plan below the conditioning floor is returned (the exchange can end there; the
        # continuous search keeps above it). A winner near the floor means the criterion improves
        # towards singular plans: say so.
        cond = {s: _conditioning(engine, finals[s][0]) for s in usable}
        regular = [s for s in usable if cond[s] > floor]
        for s in usable:
            if s not in regular:
                records[s]["message"] = f"below the conditioning floor {floor:g}; " + records[s]["message"]
        if not regular:
            raise DegenerateOptimum(criterion, m, floor)
        winner = min(regular, key=lambda s: (finals[s][1], s))
        q = finals[winner][0]
        J = engine.jacobian(q, frame="tip")
        near_floor = cond[winner] < 2 * floor  # within twice the floor: the floor binds
        if near_floor:
            warnings.warn(
                f"the plan sits at the conditioning floor ({cond[winner]:.3g}; min_conditioning {floor:g}): "
                f"the {criterion} criterion keeps improving towards singular plans, so its infimum is not "
                f"attained; add configurations or test poses, or lower min_conditioning",
                DegenerateOptimumWarning,
                stacklevel=2,  # the caller of design()
            )
        plan = Plan.for_robot(robot, q)
        value, rho0, rho0_each = _report(params, plan, criterion, test_poses, sigma, J)
        history = tuple(StartRecord(**records[s]) for s in sorted(records))
        continued = sum(h.continued for h in history)
        elapsed = time.perf_counter() - t_start
        message = (
            f"{method}: best of {n_starts} starts (start {winner}), {continued} run to convergence, "
            f"{criterion} = {value:.6g} in {elapsed:.3g} s"
            + (
                f"; {len(usable) - len(regular)} start(s) ended below the conditioning floor"
                if len(regular) < len(usable)
                else ""
            )
            + (
                "; WARNING: the plan sits at the conditioning floor (infimum not attained)"
                if near_floor
                else ""
            )
        )
        return DesignResult(
            plan=plan,
            value=value,
            criterion=criterion,
            rho0=rho0,
            rho0_each=rho0_each,
            sigma=sigma,
            method=method + ("+polish" if polish else ""),
            starts=n_starts,
            continued=continued,
            seed=int(sequence.entropy),
            time_s=elapsed,
            history=history,
            pool_size=len(candidates),
            pool_rejected=rejected,
            conditioning=cond[winner],
            message=message,
        )


def _continuous_search(
    spec, ex, x0s, n_keep, screen_iterations, maxiter, objective, records, finals, done
) -> None:
    """Screen every start, continue the best ``n_keep`` to convergence (fills records/finals)."""
    n = len(x0s)
    if n_keep < n and screen_iterations > 0:
        screened = _multistart.run(
            ex, _multistart.screen_task, [(spec, x0, screen_iterations) for x0 in x0s], done
        )
        order = sorted(range(n), key=lambda s: (screened[s].score, s))
        kept = sorted(order[:n_keep])
        for s, o in enumerate(screened):
            value = float(objective.report(o.F)) if np.isfinite(o.F) else math.inf
            records[s] = dict(
                start=s,
                value=value,
                screen_value=value,
                iterations=o.iterations,
                time_s=o.time_s,
                continued=False,
                feasible=o.feasible,
                message="dropped after screening",
            )
        starts_from = {s: screened[s].q for s in kept}
    else:
        kept = list(range(n))
        starts_from = {s: x0s[s] for s in kept}
        for s in kept:
            records[s] = dict(
                start=s,
                value=math.inf,
                screen_value=None,
                iterations=0,
                time_s=0.0,
                continued=True,
                feasible=False,
                message="",
            )
    items = [(spec, starts_from[s], x0s[s], maxiter) for s in kept]
    for s, o in zip(kept, _multistart.run(ex, _multistart.polish_task, items, done), strict=True):
        value = float(objective.report(o.F)) if np.isfinite(o.F) else math.inf
        records[s].update(
            value=value,
            iterations=records[s]["iterations"] + o.iterations,
            time_s=records[s]["time_s"] + o.time_s,
            continued=True,
            feasible=o.feasible,
            message=o.message,
        )
        finals[s] = (o.q, o.F, o.feasible)


def _conditioning(engine: JacobianEngine, q: np.ndarray) -> float:
    """Conditioning of the plan q (see :func:`pincal._continuous.conditioning`)."""
    J = engine.jacobian(q, frame="tip").reshape(-1, engine.n_params)
    return conditioning(J.T @ J)


def _report(params, plan, criterion, test_poses, sigma, J) -> tuple[float, float | None, np.ndarray | None]:
    """(value, ρ0, ρ0 per test pose) of the final plan, from the core's own functions."""
    rho0 = each = None
    if test_poses is not None:
        each = TestPoseCriterion(params, test_poses, sigma, aggregate="each")(plan.q)
        rho0 = float(each.max()) if criterion == "test-pose-worst" else float(np.sqrt(np.mean(each**2)))
    if criterion in TEST_POSE_CRITERIA:
        return rho0, rho0, each
    c = criteria_from_jacobian(J, len(plan))
    value = {"D": c.log_det, "A": c.trace, "E": c.max_eig, "cond": c.cond}[criterion]
    return float(value), rho0, each


def _progress_bar(progress: bool, total: int):
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="design", unit="start", leave=False, dynamic_ncols=True)


# --------------------------------------------------------------------------- baseline
def random_plans(
    params: ParameterSet,
    m: int,
    n: int = 1000,
    test_pose: object = None,
    *,
    criterion: str = "test-pose",
    sigma: float = 1.0,
    constraints: Iterable[AnyConstraint] = (),
    seed: int | None = 0,
    pool: object = None,
) -> RandomPlans:
    """The distribution of a criterion over ``n`` random feasible plans of m configurations.

    Configurations are drawn uniformly within the joint limits and kept if they satisfy the
    constraints — or, with a ``pool``, m distinct configurations are drawn from the pool's
    feasible ones, the baseline of a design over that pool; plans breaking the minimum spacing
    are drawn again. All plans are evaluated in batches (one Jacobian pass over all n·m
    configurations, batched eigen-decompositions).

    Args:
        params: the parameters to identify.
        m: configurations per plan.
        n: number of plans.
        test_pose: (nq,) or (k, nq) test pose(s) (required by the test-pose criteria).
        criterion: one of :data:`CRITERIA` (default ρ0, the mean over the test poses).
        sigma: measurement noise per coordinate [m].
        constraints: as for :func:`design`.
        seed: seed of the draws.
        pool: (N, nq) configurations or a Plan (e.g. taught poses) to draw the plans from, as
            :func:`design` searches them (infeasible ones are dropped); default: the joint limits.

    Returns:
        the values (ρ0 [m] for the test-pose criteria) and their min / mean / median / max.

    Example:
        >>> import pincal
        >>> params = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")
        >>> taught = [[0.0, 0.5], [0.0, 1.5], [0.0, 2.5]]
        >>> randoms = pincal.random_plans(params, 2, 50, test_pose=[0.0, 1.0], pool=taught)
        >>> randoms.n, randoms.n_singular
        (50, 0)
    """
    with _multistart.single_threaded_blas():
        return _random_plans(params, m, n, test_pose, criterion, sigma, tuple(constraints), seed, pool)


def _random_plans(params, m, n, test_pose, criterion, sigma, constraints, seed, pool) -> RandomPlans:
    criterion = criterion_name(criterion)
    m = _positive_int(m, "m (number of configurations)")
    n = _positive_int(n, "n (number of random plans)")
    test_poses = _test_poses(params, test_pose, criterion)
    sigma = _sigma(sigma)
    feasibility = Feasibility(params.robot, constraints)
    rng = np.random.default_rng(seed)
    if pool is None:

        def draw(k: int) -> np.ndarray:
            return feasibility.sample(k * m, rng).reshape(k, m, -1)
    else:
        candidates, _ = _user_pool(params.robot, pool, feasibility, m)

        def draw(k: int) -> np.ndarray:
            return np.stack([candidates[rng.choice(len(candidates), m, replace=False)] for _ in range(k)])

    qs = draw(n)
    for _ in range(50):
        bad = [i for i in range(n) if not feasibility.spacing_ok(qs[i])]
        if not bad:
            break
        qs[bad] = draw(len(bad))
    else:
        raise Infeasible(f"random plans of {m} configurations rarely satisfy min_spacing; lower it")
    engine = JacobianEngine(params)
    P, rows = len(params), engine.rows
    J0 = engine.jacobian(test_poses, frame="tip").copy() if test_poses is not None else None
    objective = make_objective(criterion, P, rows, J0 if criterion in TEST_POSE_CRITERIA else None, sigma)
    chunk = max(1, 2_000_000 // (m * rows * P + P * P))
    F = np.empty(n)
    for a in range(0, n, chunk):
        block = qs[a : a + chunk]
        J = engine.jacobian(block.reshape(-1, block.shape[2]), frame="tip").reshape(len(block), m * rows, P)
        F[a : a + len(block)] = objective.batch_values(np.einsum("nrp,nrs->nps", J, J))
    finite = np.isfinite(F)
    values = np.asarray(objective.report(F[finite]), dtype=float)
    values.flags.writeable = False
    return RandomPlans(criterion, m, n, int((~finite).sum()), values, sigma)
