"""Running the starts of a design: picklable work items, a per-process store of problems, executors.

A work item is a module-level function and a :class:`ProblemSpec` (plain data: the parameter set
with its robot and pinocchio.Model, the test poses, the constraints, the pool), so that any
``concurrent.futures.Executor`` can run it: a process pool on one machine, or for a cluster
``dask.distributed.Client(...).get_executor()`` or Ray's ``RayExecutor``. Each process builds the
problem (Jacobian engine, objective, constraint data) once per spec and keeps it in a small
thread-local store (:data:`pincal.kept.PROBLEMS`). Results come back in submission order, whatever
finishes first: the same seed gives the same design whatever the executor and the number of workers.

The process pools pincal makes itself end with it: an interrupted design (Ctrl-C, the CLI's SIGTERM,
an error) kills its workers rather than wait for their starts, and a worker whose parent dies,
SIGKILL included, dies with it (:func:`worker_start`). An executor passed in is left as it is.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from pincal.blas import single_threaded
from pincal.errors import PincalError
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.d_optimal import DOptimal
from pincal.evaluation.registry import TEST_POSE_CRITERIA, make_criterion
from pincal.evaluation.residual_criterion import ResidualCriterion
from pincal.instruments.instrument import Instrument, RowsEngine, pool_rows, rows_engine, tool_rows
from pincal.kept import PROBLEMS
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.planning import continuous as _continuous
from pincal.planning import exchange as _exchange
from pincal.planning import starts as _starts
from pincal.planning.constraints import AnyConstraint
from pincal.planning.feasibility import Feasibility


@dataclass(frozen=True, eq=False)
class ProblemSpec:
    """Everything a worker needs to rebuild a design problem (picklable).

    Attributes:
        params: the parameter set (carries the robot and its model).
        m: number of configurations.
        criterion: canonical criterion name.
        test_poses: (k, nq) test poses, or None.
        sigma: measurement noise per coordinate [m].
        constraints: the constraint objects.
        pool: (N, nq) candidate configurations (exchange), or None.
        floor: smallest conditioning of a plan (see
            :func:`pincal.evaluation.information.conditioning`); 0: none (with a prior).
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹, or None.
        entropy: the design's seed, from which a worker draws a start (see
            :func:`pincal.planning.starts.start_seed`).
        instrument: what is measured and how well, or None: points with ``sigma``.
        orientation_length: L [m] of the test-pose criterion's orientation part, or None.
        payload: (N, 4) the payload rows of the pool's candidates, or None (none).
        task_payload: (k, 4) the payload rows at the test poses, or None (none).
        residual_model: the criterion is then tr Σ₀ with this residual model
            (:class:`~pincal.evaluation.residual_criterion.ResidualCriterion`), or None.
        key: identifies the spec in the workers' caches.
    """

    params: ParameterSet
    m: int
    criterion: str
    test_poses: np.ndarray | None
    sigma: float
    constraints: tuple[AnyConstraint, ...]
    pool: np.ndarray | None = None
    floor: float = 1e-6
    prior: np.ndarray | None = None
    entropy: int = 0
    instrument: Instrument | None = None
    orientation_length: float | None = None
    payload: np.ndarray | None = None
    task_payload: np.ndarray | None = None
    residual_model: ResidualModel | None = None
    key: str = field(default_factory=lambda: uuid.uuid4().hex)

    def for_criterion(self, criterion: str) -> ProblemSpec:
        """The same problem with another criterion (a spec of its own in the workers' caches)."""
        return replace(self, criterion=criterion, key=uuid.uuid4().hex)


class Problem:
    """A design problem built from a spec, in one process."""

    def __init__(self, spec: ProblemSpec) -> None:
        self.spec = spec
        self.engine = rows_engine(spec.params, spec.instrument)
        self.objective: Criterion = objective_for(spec, self.engine)
        self.feasibility = Feasibility(spec.params.robot, spec.constraints)
        self.function = _continuous.PlanFunction(
            self.engine, self.objective, self.feasibility, spec.m, spec.floor
        )

    @cached_property
    def pool_jacobians(self) -> np.ndarray:
        assert self.spec.pool is not None  # an exchange's spec
        world = self.spec.residual_model is not None
        return candidate_rows(self.engine, self.spec.pool, self.spec.payload, world).copy()


def objective_for(spec: ProblemSpec, engine: JacobianEngine | RowsEngine) -> Criterion:
    """The criterion of ``spec`` (the same in the parent, for reporting, and in every worker): tr Σ₀
    with a residual model, else :func:`~pincal.evaluation.registry.make_criterion`'s, the test
    pose's rows under the task's payload."""
    if spec.residual_model is not None:
        assert spec.test_poses is not None  # the driver checked
        # The residual's covariance is isotropic in the world: world-aligned rows.
        world = JacobianEngine(spec.params).jacobian(
            spec.test_poses, frame="world", payload=spec.task_payload
        )
        return ResidualCriterion(spec.residual_model, world, spec.test_poses, spec.sigma, pool=spec.pool)
    J0 = None
    if spec.test_poses is not None and spec.criterion in TEST_POSE_CRITERIA:
        J0 = tool_rows(engine, spec.test_poses, spec.orientation_length, payload=spec.task_payload).copy()
    return make_criterion(spec.criterion, len(spec.params), engine.rows, J0, spec.sigma, spec.prior)


def candidate_rows(
    engine: JacobianEngine | RowsEngine,
    candidates: np.ndarray,
    payload: np.ndarray | None = None,
    world: bool = False,
) -> np.ndarray:
    """(N, r, P) the rows of a pool's candidates: :func:`~pincal.instruments.instrument.pool_rows`,
    or with payloads, the rows under each candidate's payload (``world``: world-aligned, as a
    residual model's isotropic covariance asks)."""
    if payload is None:
        return pool_rows(engine, candidates)
    return engine.jacobian(candidates, frame="world" if world else "tip", payload=payload)


def problem(spec: ProblemSpec) -> Problem:
    """The problem of ``spec``, built once per thread and kept (:data:`pincal.kept.PROBLEMS`)."""
    return PROBLEMS.get((), spec.key, lambda: Problem(spec))


def forget(spec: ProblemSpec) -> None:
    """Drop ``spec``'s problem from this thread's store."""
    PROBLEMS.drop((), spec.key)


def single_threaded_blas():
    """A context in which BLAS runs on one thread (see :func:`pincal.blas.single_threaded`): the
    matrices of a design are small, parallelism comes from the starts."""
    return single_threaded()


# ------------------------------------------------------------------------ work items
def screen_task(spec: ProblemSpec, q0: np.ndarray, iterations: int) -> _continuous.Outcome:
    """A few continuous iterations from q0."""
    with single_threaded_blas():
        return _continuous.screen(problem(spec).function, q0, iterations)


def polish_task(spec: ProblemSpec, q0: np.ndarray, anchor: np.ndarray, maxiter: int) -> _continuous.Outcome:
    """The continuous search from q0 to convergence (feasible, repaired towards ``anchor``)."""
    with single_threaded_blas():
        return _continuous.polish(problem(spec).function, q0, anchor, maxiter)


def exchange_task(
    spec: ProblemSpec, start: int, index: np.ndarray | None, also: ProblemSpec | None = None
) -> tuple[_exchange.ExchangeOutcome, _exchange.ExchangeOutcome | None] | CarriedError:
    """The exchange search over the spec's pool from the plan pool[index], or from the plan of
    start ``start`` drawn here (``index`` None): (its outcome, that of the same problem with
    another criterion ``also`` from the same plan, or None). A start that cannot be drawn comes
    back as a :class:`CarriedError`."""
    with single_threaded_blas():
        p = problem(spec)
        spacing, pool = p.feasibility.spacing, spec.pool
        assert pool is not None  # an exchange's spec
        exchanged: dict = {}  # the D-optimal exchange of the draw, if it made one
        if index is None:
            try:
                index = _starts.draw_start(
                    p.pool_jacobians,
                    pool,
                    spec.m,
                    spacing,
                    _starts.start_seed(spec.entropy, start),
                    spec.floor,
                    spec.prior,
                    exchanged,
                )
            except PincalError as error:
                return CarriedError.of(error)
        own = _exchange.fedorov(p.objective, p.pool_jacobians, pool, index, spacing, spec.floor)
        if also is None:
            return own, None
        other = problem(also).objective  # on this problem's pool Jacobians: the same pool
        drawn = _starts.exchange_of(index, exchanged)
        if isinstance(other, DOptimal) and also.prior is None and drawn is not None and drawn.converged:
            # The plan is where the same D-optimal search (no prior) stopped: no exchange improves it,
            # and a floor the plan is above only removes exchanges. Searched again it stays.
            return own, drawn.confirmed()
        return own, _exchange.fedorov(other, p.pool_jacobians, pool, index, spacing, spec.floor)


@dataclass(frozen=True)
class CarriedError:
    """A pincal error raised in a worker, carried back as plain data: an exception unpickles by
    calling its class with its message, which the errors that take their own arguments refuse."""

    kind: type[BaseException]
    args: tuple
    state: dict

    @classmethod
    def of(cls, error: BaseException) -> CarriedError:
        return cls(type(error), error.args, dict(error.__dict__))

    def error(self) -> BaseException:
        """The error again, to raise in the parent."""
        error = self.kind.__new__(self.kind)
        error.args = self.args
        error.__dict__.update(self.state)
        return error


# ------------------------------------------------------------------------- executors
def default_workers() -> int:
    """CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


@contextmanager
def executor_for(executor: Executor | None, workers: int, tasks: int):
    """The executor to use: the caller's, a process pool of ``workers``, or None (serial).

    The pool's workers die with this process (:func:`worker_start`); leaving the context on an
    exception (Ctrl-C, SIGTERM in the CLI, an error) kills them rather than wait for the starts
    they run. The caller's executor is used as it is."""
    if executor is not None:
        yield executor
        return
    if workers <= 1 or tasks <= 1:
        yield None
        return
    # The platform's default start method (fork on Linux before Python 3.14: fast, and scripts
    # need no ``if __name__ == "__main__"`` guard; elsewhere the usual guard applies).
    pool = ProcessPoolExecutor(
        max_workers=min(workers, tasks), initializer=worker_start, initargs=(os.getpid(),)
    )
    try:
        yield pool
    except BaseException:
        _kill_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _kill_workers(pool: ProcessPoolExecutor) -> None:
    """SIGKILL to every worker of ``pool`` (they hold nothing to clean up); the pool then finds
    itself broken, and its shutdown returns at once."""
    kill = getattr(pool, "kill_workers", None)  # Python 3.14
    if kill is not None:  # pragma: no cover - Python 3.14
        kill()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.kill()


PR_SET_PDEATHSIG = 1
"""Linux's prctl option: the signal the kernel sends a process when its parent dies."""

WATCH_S = 1.0
"""How often [s] a worker without PR_SET_PDEATHSIG checks that its parent lives."""


def worker_start(owner: int) -> None:
    """The first act of a worker of pincal's pool (its initializer): it ends with its parent.

    SIGTERM is the default again (a forked worker inherits the CLI's handler, which would raise
    inside a start, be carried back as its result, and leave the worker alive). On Linux the
    kernel sends the worker SIGKILL when its parent dies (PR_SET_PDEATHSIG); elsewhere a daemon
    thread ends it within :data:`WATCH_S` of its parent's death. The parent is ``owner``, the
    process that made the pool, under fork and spawn; under forkserver it is the fork server,
    which exits with its owner. An owner that died before this ran ends the worker now.
    """
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = os.getppid()
    if not _die_with_parent():
        threading.Thread(target=_watch, args=(parent,), name="pincal-parent-watch", daemon=True).start()
    if os.getppid() != parent or not _alive(owner):
        os._exit(1)


def _die_with_parent() -> bool:
    """Linux: ask the kernel for SIGKILL when the parent dies; False where that cannot be asked."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # pragma: no cover - a libc without prctl
        return False


def _watch(parent: int) -> None:
    """End this process once its parent is no longer ``parent`` (it died; the process was adopted)."""
    while os.getppid() == parent:
        time.sleep(WATCH_S)
    os._exit(1)


def _alive(pid: int) -> bool:
    """Process ``pid`` exists (POSIX; elsewhere assumed: Windows' os.kill would end it)."""
    if os.name != "posix":  # pragma: no cover
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - a process of another user
        return True
    return True


def run(
    executor: Executor | None,
    function: Callable,
    items: Sequence[tuple],
    done: Callable[[int, object], None] | None = None,
) -> list:
    """``[function(*item) for item in items]``, on ``executor`` if given; ``done(i, result)`` sees
    each result as it arrives (``i``: its item's index). Results are in the order of ``items``."""
    if executor is None:
        out = []
        for i, item in enumerate(items):
            out.append(function(*item))
            if done is not None:
                done(i, out[-1])
        return out
    futures = {executor.submit(function, *item): i for i, item in enumerate(items)}
    results: list = [None] * len(items)
    try:
        for future in as_completed(futures):
            i = futures[future]
            results[i] = future.result()
            if done is not None:
                done(i, results[i])
    except BaseException:
        for future in futures:
            future.cancel()
        raise
    return results
