"""Designing measurement plans: the m configurations that minimise a criterion (docs/method.md §7).

:func:`design` is the one driver; the search method is chosen by name:

* ``"continuous"``: all m·nq joint values at once, by quasi-Newton methods (SLSQP with the
  constraints and the conditioning floor as inequalities; L-BFGS-B when there are none) with the
  analytic gradient of the criterion (:mod:`pincal.planning.continuous`), from many starts drawn
  inside the constraints. Every start first runs ``screen_iterations`` iterations; only the best
  ``keep`` fraction continues to convergence.
* ``"exchange"``: Fedorov-style exchange over a pool of feasible candidate configurations, with
  Sherman–Morrison–Woodbury updates (:mod:`pincal.planning.exchange`). The pool is drawn at random
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

import time
from collections.abc import Iterable, Sequence
from concurrent.futures import Executor
from dataclasses import replace

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, fraction, number, positive_int, positive_sigma, seed_entropy
from pincal.deprecation import keywords_after
from pincal.errors import (
    BadArgument,
    FloorUnreachable,
    Infeasible,
    SingularPlan,
)
from pincal.evaluation.data_check import MIN_DATA_CONDITIONING
from pincal.evaluation.prior import Prior
from pincal.evaluation.residual_criterion import check_points
from pincal.instruments.error_model import ErrorModel
from pincal.instruments.instrument import (
    Instrument,
    optional_instrument,
    orientation_length_of,
    pool_rows,
    rows_engine,
)
from pincal.instruments.kind import Kind
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.planning import multistart as _multistart
from pincal.planning import payloads as _payloads
from pincal.planning import stopping as _stopping
from pincal.planning.choice import SINGULAR_WARNING, choose, design_result
from pincal.planning.constraints import AnyConstraint, JointMargin, MountSpec, with_safety
from pincal.planning.feasibility import Feasibility
from pincal.planning.objectives import (
    checked_test_poses,
    criterion_name,
)
from pincal.planning.results import DesignResult
from pincal.planning.search import D_OPTIMAL, Pool, Settings, draw_starts, search
from pincal.typing import ConfigurationsLike, PayloadLike, PoolLike, SeedLike, TestPoseLike

METHODS = ("continuous", "exchange")
"""Names of the search methods."""

DEFAULT_POOL = 2000
"""Candidate configurations drawn when no pool is given."""

MAX_WORST_POSES = 2000
"""Test poses a worst-case design may take (each is a weighted trace of its own in the search)."""

MIN_CONDITIONING = 1e-2
"""Default floor of a plan's conditioning: the smallest eigenvalue of its Jacobi-scaled
information matrix (σ_min² of the stacked Jacobian with unit columns: 1e-2 keeps σ_min ≥ 10 %).
Measured (benchmarks/RESULTS.md, bench_floor: KR 270 and UR10, m = 12, one test pose): against
1e-4 it costs 1–4 % of ρ0 at the test pose and makes the error 10° away 5× smaller, 20° away 6×,
over the workspace 6–8×.
The test-pose criterion only needs the parameter combinations that move the test pose, so it
often improves towards singular plans; the floor keeps every parameter identifiable, and keeps
the search out of near-singular basins, where its local optima are poor."""

__all__ = ["DEFAULT_POOL", "METHODS", "MIN_CONDITIONING", "SINGULAR_WARNING", "design"]


# ------------------------------------------------------------------------------ driver
@keywords_after(3)
def design(
    params: ParameterSet,
    m: int,
    test_pose: TestPoseLike | None = None,
    *,
    criterion: str = "test-pose",
    method: str = "exchange",
    constraints: Iterable[AnyConstraint] = (),
    pool: PoolLike = None,
    starts: int | None = None,
    seed: SeedLike = 0,
    sigma: float = DEFAULT_SIGMA,
    executor: Executor | None = None,
    workers: int | None = None,
    init: Sequence[ConfigurationsLike] = (),
    polish: bool | None = None,
    keep: float = 0.25,
    screen_iterations: int = 20,
    maxiter: int = 3000,
    min_conditioning: float | None = None,
    prior: Prior | None = None,
    progress: bool = False,
    payloads: Sequence[PayloadLike] | None = None,
    task_payload: PayloadLike = None,
    residual_model: ResidualModel | None = None,
    measure: Kind | None = None,
    instrument: ErrorModel | None = None,
    orientation_length: float | None = None,
    joint_margin: JointMargin = None,
    mount: MountSpec = None,
    clearance: float | None = None,
    with_d_optimal: bool = False,
) -> DesignResult:
    """Find the m measurement configurations that minimise a criterion, within the constraints.

    Args:
        params: the parameters to identify (an identifiable set).
        m: number of configurations.
        test_pose: (nq,) or (k, nq) test pose(s) [rad or m], or where the robot works: a
            neighbourhood (:func:`pincal.around`), a path (:class:`pincal.TestPath`) or a Cartesian
            box (:func:`pincal.cartesian_box`) — the criteria then take the mean (``test-pose``)
            or the worst (``test-pose-worst``) over its sample configurations. Required by the
            test-pose criteria, used to report ρ0 otherwise.
        criterion: one of :data:`CRITERIA` (case-insensitive).
        method: ``"exchange"`` (default) or ``"continuous"`` (see module doc).
        constraints: constraint objects of :mod:`pincal.planning.constraints` (joint limits always
            apply), to which the safe defaults are added (see ``joint_margin`` and ``mount``).
        pool: candidates for the exchange method: (N, nq) configurations or a Plan (infeasible
            ones are dropped), or the number of random feasible candidates to draw (default
            2000; the continuous method draws its starts from it).
        starts: number of starts, run exactly; default (None) adaptive: batches of
            :data:`~pincal.planning.stopping.BATCH` starts, each searched and polished as a design
            of that many, until :data:`~pincal.planning.stopping.AGREE` starts match the best value
            within :data:`~pincal.planning.stopping.TOLERANCE` or
            :data:`~pincal.planning.stopping.CAP` starts have run (``result.starts`` says how many
            ran, ``result.matched`` how many matched); designs with payloads or a residual model
            run 8. See docs/method.md §7.6.
        seed: seed of every random choice: an int, or a numpy Generator (one int is drawn from
            it), or None (fresh entropy); the int used is ``result.seed``: pass it to repeat.
        sigma: measurement noise per coordinate [m]; ρ0 is proportional to it.
        executor: a ``concurrent.futures.Executor`` to run the starts on (see module doc).
        workers: processes of the default process pool (default: all CPUs; 1: serial).
        init: plans (each (m, nq), feasible) to use as extra first starts of the continuous
            method, e.g. an exchange design's plan.
        polish: exchange method: continue the best ``keep`` fraction of exchange results with the
            continuous search. Default: on for a generated pool, off for a given pool (polishing
            would leave the taught poses, so it cannot be asked for then).
        keep: fraction of starts run to convergence after screening (continuous), or polished.
        screen_iterations: iterations every start runs before the poor ones are dropped.
        maxiter: iterations allowed per start and stage of the continuous search.
        min_conditioning: floor of the plan's conditioning, the smallest eigenvalue of its
            Jacobi-scaled information matrix (in (0, 0.1); 0 is singular). No plan below it is
            returned; the continuous search keeps above it as a constraint. A plan that ends near
            a floor below :data:`SINGULAR_WARNING` comes with a :class:`DegenerateOptimumWarning`:
            the criterion would keep improving towards singular plans (ρ0 at a test pose at a
            singular limit does); near a higher floor, the result's message says the floor binds.
            Default :data:`MIN_CONDITIONING` (or half what a D-optimal plan of m configurations
            reaches, when that is less, but never below the
            :data:`~pincal.evaluation.data_check.MIN_DATA_CONDITIONING` the identification asks
            of the data: below it, FloorUnreachable says to add configurations); with a prior, 0
            (no floor: the prior keeps every plan's posterior regular). A floor given is
            honoured, or refused (FloorUnreachable). A plan whose conditioning is below
            :data:`SINGULAR_WARNING` is warned about whatever the floor.
        prior: the errors before calibration (:class:`pincal.Prior`, e.g. ``Prior(1e-3, 1e-3)``):
            every criterion is taken of the posterior information M + σ²Σp⁻¹ (the Bayesian
            criterion tr(J₀(M/σ² + Σp⁻¹)⁻¹J₀ᵀ) for the test pose), finite for every plan, so m may
            be below the number of parameters. ``sigma`` must then be the real noise [m].
        progress: report progress on stderr, stage by stage (starts searched, then polished; the
            best value so far in its units): a bar on a terminal, else a line every few seconds;
            designs with payloads or a residual model report their starts searched.
        payloads: the payloads the experiment can mount (masses [kg] or :class:`~pincal.Payload`,
            e.g. ``[0, 50, 100]``): each configuration is chosen with one of them, the plan carries
            them (:mod:`pincal.planning.payloads`: an exchange over (configuration, payload) pairs
            of a generated pool, or of ``pool`` if given; no polish or init: the continuous
            search cannot choose among discrete payloads).
        task_payload: the payload at the test pose(s), the task's load (with compliance
            parameters, ρ0 is then at that load); designs through the same exchange.
        residual_model: a residual model from an earlier campaign (``result.residual_model``): the
            plan minimises the expected error at the test pose(s) with it (tr Σ₀,
            :mod:`pincal.evaluation.residual_criterion`), through the same exchange; ``value`` is
            that error [m], ``rho0`` the plain ρ0 of the plan.
        measure: what the instrument measures (:mod:`pincal.instruments`: ``Pose``, ``Partial``,
            ``Distance``, ``Image``; default points): every criterion is
            of the information of its rows. ρ0 stays the markers' position error at the test pose.
        instrument: the instrument's error model (:mod:`pincal.instruments`: ``PerCoordinate``,
            ``Tracker``): the rows are weighted by Σᵢ⁻¹; ``sigma`` is then not used
            (the model's own reference σ scales the reports). Default ``sigma`` per coordinate.
        orientation_length: L [m]: the test-pose criteria also count L² times the expected
            squared orientation error of the tool (docs/method.md §13.3).
        joint_margin: kept inside every joint limit: a number [rad, or m on prismatic joints], an
            (angle [rad], length [m]) pair or a
            :class:`~pincal.planning.constraints.JointLimits`; default (None) 2°, 1 cm on prismatic
            joints, at most a tenth of a joint's range (or the JointLimits among ``constraints``);
            0 keeps none.
        mount: the plane the robot is mounted on, kept below everything the joints move (markers,
            tip, link origins): ``floor``, ``wall``, ``ceiling`` (z = 0 of the base frame),
            ``none``, a plane ``"NX,NY,NZ,OFFSET"`` or a
            :class:`~pincal.planning.constraints.Mount`; default (None) ``floor`` for a fixed-base
            robot measured from its URDF root, ``none`` otherwise (or the Mount among
            ``constraints``).
        clearance: kept from the mounting plane and from every obstacle of a workcell by the
            markers, the tip and the link origins (the obstacles: by the robot's collision
            geometry) [m]; default (None) 5 cm,
            :data:`~pincal.planning.constraints.DEFAULT_CLEARANCE` (the uncalibrated robot's
            error and the marker's size); 0: only what the Mount and Workcell ask themselves. The
            robot is also kept clear of itself when its URDF has collision geometry (a
            ``SelfCollision`` among ``constraints`` replaces that default).
        with_d_optimal: also design the D-optimal plan from the same starts, as the baseline to
            judge this plan against (the CLI's ``--baseline``): ``result.d_optimal`` is the design
            ``criterion="D"`` with the same arguments returns (the same starts, pool and floor:
            none of them depends on the criterion), at the cost of its own exchanges from the
            starts and its polish, which run on the executor with this design's. Exchange method.

    Returns:
        the best plan found, with its criterion value, ρ0 and the history of every start.

    Raises:
        SingularPlan: m is too small for the parameters (the message names the minimum), or
            no start could form a regular plan (a start that cannot is dropped and counted,
            ``result.dropped``, while another can).
        Infeasible: no configuration (or not enough) satisfies the constraints.
        DegenerateOptimum: every start ended on a plan below the conditioning floor (exchange).
        UnknownName: unknown criterion (the message lists the valid ones).
        PincalError: any other invalid argument.

    Example:
        >>> import math, pincal
        >>> params = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")
        >>> result = pincal.design(params, m=2, test_pose=[0.0, 1.0], sigma=1.0, starts=4, workers=1)
        >>> round(result.rho0**2 / ((1 + math.sin(1.0)) / 2), 9)  # docs/method.md §9.3, σ = 1
        1.0
    """
    if with_d_optimal and method != "exchange":
        raise BadArgument(
            "with_d_optimal searches the D-optimal plan from the exchange's starts: method='exchange' "
            "(or design with criterion='D' and the continuous method separately)"
        )
    if payloads is not None or task_payload is not None or residual_model is not None:
        if with_d_optimal:
            raise BadArgument("a design with payloads or a residual model has no D-optimal baseline")
        if method != "exchange" or init or polish:
            raise BadArgument(
                "a design with payloads or a residual model is an exchange over a pool of candidate "
                "configurations (generated, or yours: pool=): leave method, init and polish at their "
                "defaults (the continuous polish cannot choose among discrete payloads)"
            )
        measured = optional_instrument(measure, instrument, positive_sigma(sigma))
        if residual_model is not None:
            check_points(measured)
        with _multistart.single_threaded_blas():
            return _payloads.design_with_payloads(
                params, m, test_pose, [0.0] if payloads is None else payloads, task_payload=task_payload,
                criterion=criterion,
                constraints=with_safety(params.robot, constraints, joint_margin, mount, clearance=clearance),
                pool=1000 if pool is None else pool,  # type: ignore[arg-type]
                starts=_stopping.BATCH if starts is None else starts, seed=seed, sigma=sigma, prior=prior,
                min_conditioning=min_conditioning,
                residual_model=residual_model, instrument=measured,
                orientation_length=orientation_length_of(orientation_length), progress=progress,
            )  # fmt: skip
    with _multistart.single_threaded_blas():  # small matrices: BLAS threads only contend
        t_start = time.perf_counter()
        settings = _validate(
            params,
            m,
            test_pose,
            criterion,
            method=method,
            constraints=constraints,
            user_pool=pool is not None and not isinstance(pool, (int, np.integer)),
            starts=starts,
            seed=seed,
            sigma=sigma,
            workers=workers,
            polish=polish,
            keep=keep,
            screen_iterations=screen_iterations,
            maxiter=maxiter,
            min_conditioning=min_conditioning,
            prior=prior,
            instrument=optional_instrument(measure, instrument, positive_sigma(sigma)),
            orientation_length=orientation_length,
            safety=(joint_margin, mount, clearance),
        )
        pooled = _pool(params, settings, pool, init)
        engine = rows_engine(params, settings.instrument)
        J_pool = pool_rows(engine, pooled.candidates)
        d_optimal = with_d_optimal and settings.criterion != D_OPTIMAL  # else the design is its own
        outcomes = d_outcomes = None
        exchanged: dict = {}  # start 0's D-optimal exchange, drawn again if the floor adapts
        while outcomes is None:
            try:
                # Start 0 is drawn here, to adapt the floor before the workers draw the others.
                first = draw_starts(settings, J_pool, pooled.candidates, 0, 1, exchanged)
                outcomes, d_outcomes = search(
                    settings, params, engine, pooled, first, executor, progress, d_optimal
                )
            except FloorUnreachable as error:
                if min_conditioning is not None:  # a floor asked for is honoured, or refused
                    raise
                # The default floor adapts: half what the D-optimal plan of m configurations
                # reaches (each start's D-optimal exchange may end a little lower: adapt again),
                # never below what the identification asks of the data: a plan it would not
                # separate every parameter with is refused here, saying to add configurations.
                if settings.floor <= MIN_DATA_CONDITIONING or error.reached <= MIN_DATA_CONDITIONING:
                    raise FloorUnreachable(m, MIN_DATA_CONDITIONING, error.reached, for_data=True) from None
                settings = replace(settings, floor=max(error.reached / 2, MIN_DATA_CONDITIONING))
        choice = choose(settings, params, engine, outcomes)
        elapsed = time.perf_counter() - t_start
        result = design_result(settings, params, engine, pooled, outcomes, choice, elapsed)
        if not with_d_optimal:
            return result
        if d_outcomes is None:  # the design is the D-optimal one
            return replace(result, d_optimal=result)
        d_settings = replace(settings, criterion=D_OPTIMAL)
        d_choice = choose(d_settings, params, engine, d_outcomes)
        return replace(
            result,
            d_optimal=design_result(d_settings, params, engine, pooled, d_outcomes, d_choice, elapsed),
        )


# ------------------------------------------------------------------------- validate
def _validate(
    params: ParameterSet,
    m: object,
    test_pose: TestPoseLike | None,
    criterion: str,
    *,
    method: str,
    constraints: Iterable[AnyConstraint],
    user_pool: bool,
    starts: object,
    seed: SeedLike,
    sigma: object,
    workers: object,
    polish: bool | None,
    keep: object,
    screen_iterations: object,
    maxiter: object,
    min_conditioning: object,
    prior: Prior | None = None,
    instrument: Instrument | None = None,
    orientation_length: float | None = None,
    safety: tuple[JointMargin, MountSpec, float | None] = (None, None, None),
) -> Settings:
    """Check every argument (in the order of the signature) and settle the defaults."""
    criterion = criterion_name(criterion)
    if method not in METHODS:
        raise BadArgument(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if prior is not None and not isinstance(prior, Prior):
        raise BadArgument(f"prior must be a pincal.Prior (e.g. Prior.parse('1mm,1mrad')), got {prior!r}")
    sigma = positive_sigma(sigma) if instrument is None else instrument.reference
    if instrument is not None:
        instrument.kind.check(params.robot)
    information = None if prior is None else prior.information(params, sigma)
    m = _check_m(params, m, information, instrument)
    test_poses = checked_test_poses(params, test_pose, criterion)
    if criterion == "test-pose-worst" and test_poses is not None and len(test_poses) > MAX_WORST_POSES:
        raise BadArgument(
            f"the worst case is searched pose by pose: {len(test_poses)} test poses are too many (at most "
            f"{MAX_WORST_POSES}); take every k-th point of the path, or minimise the mean (test-pose), whose "
            "cost does not depend on the number of poses"
        )
    adaptive = starts is None
    starts = _stopping.BATCH if adaptive else positive_int(starts, "starts")
    workers = _multistart.default_workers() if workers is None else positive_int(workers, "workers")
    keep = fraction(keep, "keep", one=True)
    screen_iterations = positive_int(screen_iterations, "screen_iterations", 0)
    maxiter = positive_int(maxiter, "maxiter")
    floor = (MIN_CONDITIONING if prior is None else 0.0) if min_conditioning is None else min_conditioning
    name = "min_conditioning" + (" (0 only with a prior)" if prior is None else "")
    floor = number(floor, name, 0.0, 0.1, low_open=prior is None, high_open=True)
    margin, mount, clearance = safety
    constraints = with_safety(
        params.robot, constraints, margin, mount, clearance=clearance
    )  # safe by default
    feasibility = Feasibility(params.robot, constraints)
    entropy = seed_entropy(seed)
    if method == "continuous":
        if polish:
            raise BadArgument("polish refines exchange results; the continuous method needs none")
        polish = False
    elif polish is None:
        polish = not user_pool
    if user_pool:
        if method != "exchange":
            raise BadArgument("a pool of configurations is searched by method='exchange'")
        if polish:
            raise BadArgument("polish would move the plan off the given pool; use a generated pool to polish")
    return Settings(
        criterion=criterion,
        method=method,
        m=m,
        test_poses=test_poses,
        sigma=sigma,
        starts=starts,
        workers=workers,
        keep=float(keep),
        screen_iterations=screen_iterations,
        maxiter=maxiter,
        floor=float(floor),
        constraints=constraints,
        feasibility=feasibility,
        user_pool=user_pool,
        polish=bool(polish),
        entropy=entropy,
        prior=prior,
        prior_information=information,
        instrument=instrument,
        orientation_length=orientation_length_of(orientation_length),
        adaptive=adaptive,
    )


def _check_m(
    params: ParameterSet, m: object, prior: np.ndarray | None = None, instrument: Instrument | None = None
) -> int:
    m = positive_int(m, "m (number of configurations)")
    rows = 3 * params.robot.n_markers if instrument is None else instrument.kind.size(params.robot)
    unknown = len(params) if prior is None else int(np.sum(np.diag(prior) == 0))
    if m * rows < unknown:
        raise SingularPlan(len(params), rows, m)
    return m


# ----------------------------------------------------------------------------- pool
def _pool(
    params: ParameterSet, settings: Settings, pool: PoolLike, init: Sequence[ConfigurationsLike]
) -> Pool:
    """The candidate configurations (the user's feasible ones, or drawn) and the checked init plans."""
    robot, feasibility, m = params.robot, settings.feasibility, settings.m
    rejected = 0
    if settings.user_pool:
        candidates, rejected = feasibility.feasible_pool(pool, m)  # type: ignore[arg-type]  # user_pool: not a size
    else:
        size = DEFAULT_POOL if pool is None else positive_int(pool, "pool size", m)
        # Drawn strictly inside the constraints for a continuous search, as when its barrier needed
        # it (SLSQP needs feasible starts only): the same draws, so the same plans.
        strict = settings.method == "continuous" or settings.polish
        rng = np.random.default_rng(settings.seed_sequence(0))
        candidates = feasibility.sample(size, rng, minimum=m, strict=strict)
    plans = tuple(robot.configurations(q, what="init plan configuration") for q in init)
    if plans and settings.method != "continuous":
        raise BadArgument("init plans start the continuous method; use method='continuous'")
    for q in plans:
        if q.shape != (m, robot.nq) or not feasibility.plan_feasible(q):
            raise Infeasible(f"an init plan must hold {m} configurations within every constraint")
    return Pool(candidates, rejected, plans)
