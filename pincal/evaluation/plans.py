"""Evaluating one plan or many at once, near the cost of Pinocchio's own work.

The public evaluations (:func:`pincal.rho0`, :func:`pincal.criteria`, :func:`pincal.accuracy`)
take one plan (m, nq) — or a :class:`~pincal.Plan` — or a batch of k plans (k, m, nq) — or a
sequence of Plans — and return one value per plan. Every configuration of a batch is checked
once; then, block by block (:data:`BLOCK` plans), the Jacobians come from one pass of forward
kinematics and kinematic regressors (the floor: Pinocchio's own work), the information matrices
from one batched product, and the criteria from batched factorisations. The Jacobian engine of a parameter
set is built once per thread and kept while the set lives (it holds a ``pinocchio.Data``: one per
thread). Every evaluation runs with BLAS on one thread (:mod:`pincal.blas`), whatever the
caller's process has set: with a threaded BLAS on a busy machine even one ρ0 took 14× longer
(its waiting threads), and limiting costs a few microseconds.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import TypeVar

import numpy as np

from pincal.blas import single_threaded
from pincal.errors import BadConfiguration, SingularPlan
from pincal.instruments.instrument import Instrument, RowsEngine
from pincal.kept import ENGINES
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.typing import PlansLike

T = TypeVar("T")


def engine_for(params: ParameterSet, instrument: Instrument | None = None) -> JacobianEngine | RowsEngine:
    """The Jacobian engine of ``params`` for this thread, built on first use and kept
    (:data:`pincal.kept.ENGINES`): the markers' positions, or with ``instrument`` the rows it
    measures, whitened (:class:`~pincal.instruments.instrument.RowsEngine`)."""
    if instrument is None:
        return ENGINES.get((params,), "positions", lambda: JacobianEngine(params))
    return ENGINES.get((params, instrument), "rows", lambda: instrument.engine(params))


SMALL = 64
"""One plan with at most this many configurations (and test poses, for ρ0) is evaluated with BLAS as
the caller has it: every operation on it is on one thread at that size (ρ0's triangular solve is
BLAS trsm, not LAPACK trtrs, which OpenBLAS splits over its threads even for 27 unknowns), and
setting and restoring the thread count would cost more than the evaluation."""


def blas_for(configurations: int) -> AbstractContextManager:
    """One BLAS thread for an evaluation (of this many configurations: whatever their number)."""
    return single_threaded()


def plan_batch(params: ParameterSet, plan: PlansLike) -> tuple[np.ndarray, bool]:
    """((k, m, nq) checked joint values, batched): one plan ((m, nq), (nq,) or a Plan) is a batch of
    one, with ``batched`` False; a (k, m, nq) array or a sequence of Plans of one m is a batch.

    Raises:
        BadConfiguration: wrong shape, a non-finite value or a value outside its joint limits
            (naming the plan and the configuration).
    """
    robot = params.robot
    values = plan
    if isinstance(plan, (list, tuple)) and plan and all(hasattr(p, "q") for p in plan):
        values = [p.q for p in plan]
    values = getattr(values, "q", values)
    arr = np.asarray(values, dtype=float) if not isinstance(values, np.ndarray) else values
    if arr.ndim != 3:
        return robot.configurations(plan)[None], False
    k, m, nq = arr.shape
    if nq != robot.nq or m == 0 or k == 0:
        raise BadConfiguration(
            f"plans: expected (k, m, {robot.nq}) joint values ({', '.join(robot.joint_names)}), got shape "
            f"{arr.shape}"
        )
    flat = robot.configurations(arr.reshape(-1, nq), what="plan configuration")
    return flat.reshape(k, m, nq), True


def plan_payloads(plan: PlansLike, shape: tuple[int, int, int]) -> np.ndarray | None:
    """(k·m, 4) the payload rows of a plan or a sequence of Plans (:attr:`~pincal.Plan.payload`;
    none for a plan without), or None when no plan carries any; ``shape`` is (k, m, nq)."""
    plans = (
        list(plan)
        if isinstance(plan, (list, tuple)) and plan and all(hasattr(p, "q") for p in plan)
        else [plan]
    )
    loads = [getattr(p, "payload", None) for p in plans]
    if all(w is None for w in loads) or len(plans) != shape[0]:
        return None
    return np.vstack([np.zeros((shape[1], 4)) if w is None else w for w in loads])


def jacobians(
    engine: JacobianEngine | RowsEngine, qs: np.ndarray, payload: np.ndarray | None = None
) -> np.ndarray:
    """(k, m·r, P) tip-frame Jacobians of k plans (k, m, nq), in one pass (under the payload rows
    (k·m, 4) of their configurations, if any)."""
    k, m, nq = qs.shape
    J = engine.jacobian(qs.reshape(-1, nq), frame="tip", payload=payload)
    return J.reshape(k, -1, engine.n_params)


BLOCK = 32
"""Plans of a batch evaluated together (:func:`in_blocks`): their regressors and Jacobians stay in
cache (a few hundred kB), the memory of any batch is bounded, and NumPy's few calls per block cost
well under a microsecond per plan."""


def in_blocks(
    engine: JacobianEngine | RowsEngine,
    qs: np.ndarray,
    payload: np.ndarray | None,
    evaluate: Callable[[np.ndarray], T],
) -> list[T]:
    """[evaluate(J) for the Jacobians J (b, m·r, P) of each block of :data:`BLOCK` plans] of k plans
    ``qs`` (k, m, nq) under their payload rows (k·m, 4) or None.

    Raises:
        SingularPlan: from ``evaluate``, naming the plan by its index in the whole batch.
    """
    k, m, _ = qs.shape
    out = []
    for a in range(0, k, BLOCK):
        rows = None if payload is None else payload[a * m : (a + BLOCK) * m]
        try:
            out.append(evaluate(jacobians(engine, qs[a : a + BLOCK], rows)))
        except SingularPlan as error:
            if k > 1:
                error.of_plan(a + (error.plan or 0))
            raise
    return out
