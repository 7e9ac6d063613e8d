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
poses), ``test-pose-worst`` (the worst test pose), ``D``, ``A``, ``E``, ``cond``; with a residual
model, the expected error with it (tr Σ₀, :mod:`pincal.evaluation.residual_criterion`).

Every design runs one pipeline: validate (once), draw the pool, search the starts (the same
multistart: executor, progress, degenerate starts dropped, adaptive starts), choose, report. The pool
is of (configuration, payload) candidates: without :class:`~pincal.planning.options.Loads`, every
candidate carries none (0 kg); with payloads, every configuration is paired with every payload
(docs/method.md §11.3), each pair checked under its payload (a robot with joint compliances
yields to it: a pair it breaks a constraint under is left out), and the exchange chooses them
with the configurations (the continuous search cannot choose among discrete payloads: no polish,
no continuous method).

The options are a few frozen values (:mod:`pincal.planning.options`): :class:`~pincal.Search`,
:class:`~pincal.Safety`, :class:`~pincal.Loads`, and the :class:`~pincal.instruments.Instrument`
(``sigma=`` its shorthand for points). The flat keywords of pincal 0.1 still work until 0.3, with
a DeprecationWarning.

Starts run in parallel through any ``concurrent.futures.Executor``: by default a process pool of
``workers`` processes (all CPUs) when there is more than one start; ``workers=1`` runs serially.
For more than one machine, pass a cluster's executor, e.g. with dask.distributed::

    from dask.distributed import Client
    with Client("scheduler:8786") as client:
        result = pincal.design(params, m=12, test_pose=q0,
                               search=pincal.Search(starts=512, executor=client.get_executor()))

or with Ray (``from ray.util.concurrent.futures.ray_executor import RayExecutor``;
``executor=RayExecutor()``). The work items are plain picklable data; each worker rebuilds the
problem once. Per-start seeds come from ``numpy.random.SeedSequence(seed).spawn``, so the same
seed gives the same plan whatever the executor and the number of workers.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from pincal.arguments import fraction, number, positive_int, seed_entropy
from pincal.deprecation import keywords_after, moved_keywords
from pincal.errors import BadArgument, FloorUnreachable, Infeasible, SingularPlan
from pincal.evaluation.data_check import MIN_DATA_CONDITIONING
from pincal.evaluation.prior import Prior
from pincal.evaluation.residual_criterion import check_points
from pincal.instruments.given import instrument_of, takes_instrument
from pincal.instruments.instrument import Instrument, orientation_length_of, rows_engine
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.statics import payload_rows
from pincal.planning import multistart as _multistart
from pincal.planning import stopping as _stopping
from pincal.planning.choice import SINGULAR_WARNING, choose, design_result
from pincal.planning.constraints import with_safety
from pincal.planning.feasibility import Feasibility
from pincal.planning.objectives import checked_test_poses, criterion_name
from pincal.planning.options import (
    FLAT,
    ORDER_0_1,
    Loads,
    Safety,
    Search,
    check_value,
    regroup,
)
from pincal.planning.results import DesignResult
from pincal.planning.search import draw_starts, search
from pincal.planning.settings import D_OPTIMAL, Pool, Settings
from pincal.planning.views import draw_candidates
from pincal.typing import ConfigurationsLike, PoolLike, TestPoseLike

METHODS = ("continuous", "exchange")
"""Names of the search methods."""

DEFAULT_POOL = 2000
"""Candidate configurations drawn when no pool is given."""

LOADED_POOL = 1000
"""Candidate configurations drawn when no pool is given and each is paired with every payload (or
scored with a residual model, whose exchange values every swap exactly)."""

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

__all__ = ["DEFAULT_POOL", "LOADED_POOL", "METHODS", "MIN_CONDITIONING", "SINGULAR_WARNING", "design"]


# ------------------------------------------------------------------------------ driver
@keywords_after(3, ORDER_0_1)
@moved_keywords(FLAT, regroup)
@takes_instrument
def design(
    params: ParameterSet,
    m: int,
    test_pose: TestPoseLike | None = None,
    *,
    criterion: str = "test-pose",
    instrument: Instrument | None = None,
    sigma: float | None = None,
    prior: Prior | None = None,
    search: Search | None = None,
    safety: Safety | None = None,
    loads: Loads | None = None,
    residual_model: ResidualModel | None = None,
    orientation_length: float | None = None,
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
        instrument: what is measured and how well (:class:`pincal.instruments.Instrument`: a kind,
            ``Pose``, ``Partial``, ``Distance``, ``Image`` or points, with an error model,
            ``PerCoordinate`` or ``Tracker``): every criterion is of the information of its rows,
            weighted by Σᵢ⁻¹, and scaled by its reference σ. ρ0 stays the markers' position error
            at the test pose. Default: points, ``sigma`` per coordinate.
        sigma: the shorthand for points measured with this noise per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`); ρ0 is proportional to it. Not with
            ``instrument``.
        prior: the errors before calibration (:class:`pincal.Prior`, e.g. ``Prior(1e-3, 1e-3)``):
            every criterion is taken of the posterior information M + σ²Σp⁻¹ (the Bayesian
            criterion tr(J₀(M/σ² + Σp⁻¹)⁻¹J₀ᵀ) for the test pose), finite for every plan, so m may
            be below the number of parameters; σ must then be the real noise [m]. The
            conditioning floor is then 0 by default.
        search: how the plan is searched (:class:`pincal.Search`: method, starts, seed, pool,
            init, polish, keep, screen_iterations, maxiter, executor, workers, progress; see
            docs/method.md §7). Default ``Search()``: the exchange over 2000 drawn candidates,
            polished, adaptive starts, seed 0, all CPUs.
        safety: how the plan is kept safe and regular (:class:`pincal.Safety`: constraints,
            joint_margin, mount, clearance, min_conditioning). Default ``Safety()``: joint limits
            with a 2° margin, the mounting plane and 5 cm of clearance, self-collision when the
            URDF has geometry, the conditioning floor :data:`MIN_CONDITIONING` (or half what a
            D-optimal plan of m configurations reaches when that is less, never below
            :data:`~pincal.evaluation.data_check.MIN_DATA_CONDITIONING`). A floor given is
            honoured, or refused (FloorUnreachable); a plan below :data:`SINGULAR_WARNING` comes
            with a :class:`DegenerateOptimumWarning`.
        loads: what loads the robot (:class:`pincal.Loads`: the payloads the experiment can mount,
            one chosen with each configuration, and the task's payload at the test pose(s)): the
            pool is then every configuration paired with every payload (1000 configurations by
            default) that it satisfies the constraints under (a compliant robot yields to it),
            the plan carries its payloads, ρ0 is under the task's payload. An exchange without
            polish (the continuous search cannot choose among discrete payloads).
        residual_model: a residual model from an earlier campaign (``result.residual_model``): the
            plan minimises the expected error at the test pose(s) with it (tr Σ₀,
            :mod:`pincal.evaluation.residual_criterion`; the test-pose criterion, points, no
            prior); ``value`` is that error [m], ``rho0`` the plain ρ0 of the plan. An exchange as
            with ``loads``, whose generated pool also draws a quarter more around the test poses.
        orientation_length: L [m]: the test-pose criteria also count L² times the expected
            squared orientation error of the tool (docs/method.md §13.3).
        with_d_optimal: also design the D-optimal plan from the same starts, as the baseline to
            judge this plan against (the CLI's ``--baseline``): ``result.d_optimal`` is the design
            ``criterion="D"`` with the same arguments returns, at the cost of its own exchanges
            and polish, run on the executor with this design's. Exchange method; with payloads
            too (over the same pairs), not with a residual model.

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
        >>> result = pincal.design(params, m=2, test_pose=[0.0, 1.0], sigma=1.0,
        ...                        search=pincal.Search(starts=4, workers=1))
        >>> round(result.rho0**2 / ((1 + math.sin(1.0)) / 2), 9)  # docs/method.md §9.3, σ = 1
        1.0
    """
    search, safety, loads = _values(search, safety, loads)
    measured, plain = instrument_of(instrument, sigma)  # σ checked here, once
    with _multistart.single_threaded_blas():  # small matrices: BLAS threads only contend
        t_start = time.perf_counter()
        settings = _validate(
            params, m, test_pose, criterion, search, safety, loads, measured, plain, prior,
            residual_model, orientation_length, with_d_optimal,
        )  # fmt: skip
        pooled = _pool(params, settings, search.pool, search.init)
        engine = rows_engine(params, settings.measured)
        world = settings.residual_model is not None  # its covariance is isotropic in the world
        J_pool = _multistart.candidate_rows(engine, pooled.candidates, pooled.payload, world)
        d_optimal = with_d_optimal and settings.criterion != D_OPTIMAL  # else the design is its own
        outcomes = d_outcomes = None
        exchanged: dict = {}  # start 0's D-optimal exchange, drawn again if the floor adapts
        while outcomes is None:
            try:
                # Start 0 is drawn here, to adapt the floor before the workers draw the others.
                first = draw_starts(settings, J_pool, pooled.candidates, 0, 1, exchanged)
                outcomes, d_outcomes = _search_stage(
                    settings, params, engine, pooled, first, search, d_optimal
                )
            except FloorUnreachable as error:
                if safety.min_conditioning is not None:  # a floor asked for is honoured, or refused
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


def _values(search: object, safety: object, loads: object) -> tuple[Search, Safety, Loads]:
    """The option values, their defaults for None, each checked to be of its type."""
    out = []
    for value, kind, name in (
        (search, Search, "search"),
        (safety, Safety, "safety"),
        (loads, Loads, "loads"),
    ):
        value = kind() if value is None else value
        check_value(value, kind, name)
        out.append(value)
    return out[0], out[1], out[2]  # type: ignore[return-value]


def _search_stage(settings, params, engine, pooled, first, options: Search, d_optimal: bool):
    """:func:`~pincal.planning.search.search` with the run options of ``Search``."""
    return search(settings, params, engine, pooled, first, options.executor, options.progress, d_optimal)


# ------------------------------------------------------------------------- validate
def _validate(
    params: ParameterSet,
    m: object,
    test_pose: TestPoseLike | None,
    criterion: str,
    search: Search,
    safety: Safety,
    loads: Loads,
    instrument: Instrument,
    plain: bool,
    prior: Prior | None,
    residual_model: ResidualModel | None,
    orientation_length: float | None,
    with_d_optimal: bool,
) -> Settings:
    """Check every argument (in the order of the signature) and settle the defaults."""
    criterion = criterion_name(criterion)
    if prior is not None and not isinstance(prior, Prior):
        raise BadArgument(f"prior must be a pincal.Prior (e.g. Prior.parse('1mm,1mrad')), got {prior!r}")
    instrument.kind.check(params.robot)
    information = None if prior is None else prior.information(params, instrument.reference)
    m = _check_m(params, m, information, None if plain else instrument)
    test_poses = checked_test_poses(params, test_pose, criterion)
    if criterion == "test-pose-worst" and test_poses is not None and len(test_poses) > MAX_WORST_POSES:
        raise BadArgument(
            f"the worst case is searched pose by pose: {len(test_poses)} test poses are too many (at most "
            f"{MAX_WORST_POSES}); take every k-th point of the path, or minimise the mean (test-pose), whose "
            "cost does not depend on the number of poses"
        )
    rows, task = _loads(loads, residual_model, test_poses)
    if residual_model is not None:
        check_points(None if plain else instrument)
        if criterion != "test-pose" or prior is not None or test_poses is None or with_d_optimal:
            raise BadArgument(
                "a residual model designs for the test-pose criterion, with a test pose, no prior and no "
                "D-optimal baseline"
            )
    user_pool = search.pool is not None and not isinstance(search.pool, (int, np.integer))
    run = _search_settings(search, user_pool, rows is not None, with_d_optimal)
    floor = (
        (MIN_CONDITIONING if prior is None else 0.0)
        if safety.min_conditioning is None
        else safety.min_conditioning
    )
    name = "min_conditioning" + (" (0 only with a prior)" if prior is None else "")
    floor = number(floor, name, 0.0, 0.1, low_open=prior is None, high_open=True)
    constraints = with_safety(
        params.robot, safety.constraints, safety.joint_margin, safety.mount, clearance=safety.clearance
    )  # safe by default
    return Settings(
        criterion=criterion,
        m=m,
        test_poses=test_poses,
        instrument=instrument,
        floor=float(floor),
        constraints=constraints,
        feasibility=Feasibility(params.robot, constraints),
        entropy=seed_entropy(search.seed),
        prior=prior,
        prior_information=information,
        plain=plain,
        orientation_length=orientation_length_of(orientation_length),
        loads=rows,
        task_payload=task,
        residual_model=residual_model,
        **run,
    )


def _search_settings(search: Search, user_pool: bool, loaded: bool, with_d_optimal: bool) -> dict:
    """The checked settings of ``search`` (Settings' fields), its defaults settled."""
    method, polish = search.method, search.polish
    if method not in METHODS:
        raise BadArgument(f"unknown method {method!r}; valid: {', '.join(METHODS)}")
    if with_d_optimal and method != "exchange":
        raise BadArgument(
            "with_d_optimal searches the D-optimal plan from the exchange's starts: method='exchange' "
            "(or design with criterion='D' and the continuous method separately)"
        )
    if loaded and (method != "exchange" or search.init or polish):
        raise BadArgument(
            "a design with payloads or a residual model is an exchange over a pool of (configuration, "
            "payload) candidates (generated, or yours: pool=): leave method, init and polish at their "
            "defaults (the continuous search cannot choose among discrete payloads)"
        )
    adaptive = search.starts is None
    if method == "continuous":
        if polish:
            raise BadArgument("polish refines exchange results; the continuous method needs none")
        polish = False
    elif polish is None:
        polish = not user_pool and not loaded
    if user_pool:
        if method != "exchange":
            raise BadArgument("a pool of configurations is searched by method='exchange'")
        if polish:
            raise BadArgument("polish would move the plan off the given pool; use a generated pool to polish")
    workers = search.workers
    return dict(
        method=method,
        starts=_stopping.BATCH if adaptive else positive_int(search.starts, "starts"),
        workers=_multistart.default_workers() if workers is None else positive_int(workers, "workers"),
        keep=float(fraction(search.keep, "keep", one=True)),
        screen_iterations=positive_int(search.screen_iterations, "screen_iterations", 0),
        maxiter=positive_int(search.maxiter, "maxiter"),
        user_pool=user_pool,
        polish=bool(polish),
        adaptive=adaptive,
    )


def _loads(
    loads: Loads, residual_model: ResidualModel | None, test_poses: np.ndarray | None
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(the (n, 4) payload rows each configuration chooses among, the (k, 4) rows at the test
    poses): None, None without payloads or a residual model (the candidates carry none)."""
    if not loads.given and residual_model is None:
        return None, None
    payloads = [0.0] if loads.payloads is None else loads.payloads
    if isinstance(payloads, (str, bytes)) or not isinstance(payloads, Sequence) or not len(payloads):
        raise BadArgument(
            f"payloads must be a list of the masses [kg] (or Payloads) you can mount, got {payloads!r}",
            argument="payloads",
        )
    rows = np.vstack([payload_rows(p, 1) for p in payloads])
    task = None if test_poses is None else payload_rows(loads.task_payload, len(test_poses))
    return rows, task


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
    """The candidates (the user's feasible configurations, or drawn; each paired with every payload
    of a loaded design it satisfies the constraints under) and the checked init plans."""
    robot, feasibility, m, loads = params.robot, settings.feasibility, settings.m, settings.loads
    rejected = 0
    # Drawn strictly inside the constraints for a continuous search, as when its barrier needed
    # it (SLSQP needs feasible starts only): the same draws, so the same plans.
    strict = settings.method == "continuous" or settings.polish
    if settings.user_pool:
        candidates, rejected = feasibility.feasible_pool(pool, m, loads)  # type: ignore[arg-type]  # user_pool: not a size
    else:
        default = DEFAULT_POOL if loads is None else LOADED_POOL
        size = default if pool is None else positive_int(pool, "pool size", m)
        rng = np.random.default_rng(settings.seed_sequence(0))
        candidates = draw_candidates(
            feasibility, settings.instrument.kind, params, size, rng, m, strict, loads
        )
        if settings.residual_model is not None and settings.test_poses is not None:
            # also where the residual is correlated with the test pose's
            near = _near(robot, feasibility, settings.test_poses, size // 4, rng)
            candidates = np.vstack([candidates, near])
    plans = tuple(robot.configurations(q, what="init plan configuration") for q in init)
    if plans and settings.method != "continuous":
        raise BadArgument("init plans start the continuous method; use method='continuous'")
    for q in plans:
        if q.shape != (m, robot.nq) or not feasibility.plan_feasible(q):
            raise Infeasible(f"an init plan must hold {m} configurations within every constraint")
    if loads is None:
        return Pool(candidates, rejected, plans)
    # Each configuration with every payload it is feasible under: with compliances the payload
    # bends the robot towards the floor, the cell or itself (each candidate holds one at least).
    pairs, rows = feasibility.feasible_pairs(candidates, loads, strict)
    return Pool(pairs, rejected, plans, rows)


NEAR = 0.3
"""Half-width [rad or m] of the box around the test poses a residual-model design also draws
candidates from (a quarter of the pool)."""


def _near(
    robot, feasibility: Feasibility, test_poses: np.ndarray, n: int, rng: np.random.Generator
) -> np.ndarray:
    """Up to n feasible configurations drawn around the test poses (within ±NEAR of one)."""
    centres = test_poses[rng.integers(len(test_poses), size=n)]
    qs = np.clip(centres + rng.uniform(-NEAR, NEAR, centres.shape), robot.lower, robot.upper)
    return qs[feasibility.feasible(qs)]
