"""The accuracy report with a residual model from an earlier calibration (:func:`pincal.evaluation.
accuracy`'s ``residual_model``): sqrt tr Σ₀ at every configuration, the parameters and the
residual estimated together from each plan (docs/method.md §11.5)."""

from __future__ import annotations

import numpy as np

from pincal.errors import BadArgument
from pincal.evaluation.accuracy_report import AccuracyReport, ErrorSummary, PlanAccuracy
from pincal.evaluation.plans import blas_for, engine_for, plan_payloads
from pincal.evaluation.predicted_error import worst_found
from pincal.evaluation.residual_criterion import ResidualCriterion
from pincal.model.residual import ResidualModel
from pincal.model.statics import PayloadRows, repeated


def with_residual_model(
    params, batch, batched, plan, compare, sets, region, sigma, prior, task_payload, model
) -> AccuracyReport | tuple[AccuracyReport, ...]:
    """:func:`accuracy` with a residual model: sqrt tr Σ₀ at every configuration of ``sets``."""
    if prior is not None:
        raise BadArgument("the expected error with a residual model takes no prior")
    robot = params.robot
    if len(model.revolute) != robot.nq:
        raise BadArgument(
            f"the residual model is over {len(model.revolute)} joints; the robot has {robot.nq}"
        )
    engine = engine_for(params)
    loads = plan_payloads(plan, batch.shape)

    def rows(q: np.ndarray, load: PayloadRows, name: str) -> PlanAccuracy:
        error = _ResidualError(
            engine, model, sigma, q, engine.jacobian(q, frame="world", payload=load), task_payload
        )
        out = tuple(ErrorSummary.of(where, np.sqrt(error.squared(qs))) for where, qs in sets)
        worst = None if region is None else worst_found(error, region)
        return PlanAccuracy(name, out, worst, out[0].rms, 0.0)

    with blas_for(sum(len(qs) for _, qs in sets)):
        compared = tuple(
            rows(robot.configurations(q), getattr(q, "payload", None), name)
            for name, q in (compare or {}).items()
        )
        reports = tuple(
            AccuracyReport(
                (rows(q, None if loads is None else loads[i * len(q) : (i + 1) * len(q)], "plan"),)
                + compared,
                float(sigma),
                None,
                None,
                "test pose" if region is None else region.description,
                tuple(bool(r) for r in robot.revolute),
                residual_model=True,
            )
            for i, q in enumerate(batch)
        )
    return reports if batched else reports[0]


class _ResidualError:
    """ρ²(q) = tr Σ₀ at any configurations after calibrating with one plan, the parameters and a
    residual model's residual estimated together (a :class:`SquaredError`, so that
    :func:`worst_found` searches it as it searches the geometric ρ²).

    Args:
        engine: the parameters' Jacobian engine.
        model: the residual model.
        sigma: the instrument's noise per coordinate [m].
        q: (m, nq) the plan; J: (m, r, P) its world-aligned rows (under its payloads).
        task_payload: the load under which ρ(q) is asked, one row (1, 4), or None.
    """

    def __init__(
        self,
        engine,
        model: ResidualModel,
        sigma: float,
        q: np.ndarray,
        J: np.ndarray,
        task_payload: PayloadRows,
    ):
        self.engine, self.model, self.sigma = engine, model, sigma
        self.q, self.J, self.task_payload = q, J, task_payload

    def squared(self, qs: np.ndarray) -> np.ndarray:
        """(n,) ρ² [m²] at the (n, nq) configurations ``qs``."""
        J_at = self.engine.jacobian(qs, frame="world", payload=repeated(self.task_payload, len(qs)))
        return np.maximum(ResidualCriterion(self.model, J_at, qs, self.sigma).each(self.J, self.q), 0.0)
