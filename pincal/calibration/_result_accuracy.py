"""The accuracy report of a calibration (:meth:`IdentificationResult.accuracy`): the error of its
predictions at the test pose(s), around them and over the workspace."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pincal.evaluation.accuracy_report import AccuracyReport, ErrorSummary, PlanAccuracy
from pincal.evaluation.accuracy_samples import (
    NEIGHBOURHOOD_SAMPLES,
    NEIGHBOURHOODS,
    WORKSPACE_SAMPLES,
    sample_sets,
)
from pincal.evaluation.predicted_error import worst_found
from pincal.model.statics import Payload, payload_rows
from pincal.typing import PayloadLike, TestPoseLike

if TYPE_CHECKING:
    from pincal.calibration.result import IdentificationResult


def calibration_accuracy(
    result: IdentificationResult,
    test_pose: TestPoseLike,
    *,
    payload: PayloadLike = None,
    neighbourhoods: tuple[float, ...] = NEIGHBOURHOODS,
    samples: int = NEIGHBOURHOOD_SAMPLES,
    workspace: int = WORKSPACE_SAMPLES,
    seed: int = 0,
) -> AccuracyReport:
    """:meth:`IdentificationResult.accuracy` of ``result`` (documented there)."""
    robot = result.params.robot
    load = None if payload is None else payload_rows(payload, 1)
    if load is not None and not isinstance(payload, Payload):
        payload = Payload(float(load[0, 0]), (float(load[0, 1]), float(load[0, 2]), float(load[0, 3])))
    sets, poses, region = sample_sets(robot, test_pose, neighbourhoods, samples, workspace, seed)
    rows = tuple(ErrorSummary.of(where, result.expected_error(qs, payload=payload)) for where, qs in sets)
    worst = None if region is None else worst_found(_SquaredError(result, payload), region)
    parameters, gp = (v.sum(axis=1) for v in result.point_variances(poses, payload=payload))
    calibrated = PlanAccuracy(
        "calibrated",
        rows,
        worst,
        float(np.sqrt(np.mean(parameters))),
        0.0,
        float(np.sqrt(np.mean(gp))),
        **({} if result.residual_model is not None else {"unexplained": _UNEXPLAINED}),
    )
    return AccuracyReport(
        (calibrated,),
        float(result.sigma),
        None,
        None,
        "test pose" if region is None else region.description,
        tuple(bool(r) for r in robot.revolute),
    )


_UNEXPLAINED = "what the fitted model does not explain (the residual level beyond the noise)"


class _SquaredError:
    """A calibration's squared expected error as :func:`~pincal.evaluation.predicted_error.worst_found`
    searches it."""

    def __init__(self, result: IdentificationResult, payload: PayloadLike) -> None:
        self.result, self.payload = result, payload

    def squared(self, qs: np.ndarray) -> np.ndarray:
        return self.result.expected_error(np.atleast_2d(qs), payload=self.payload) ** 2
