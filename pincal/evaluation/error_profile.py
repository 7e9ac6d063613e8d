"""The predicted error against the distance from the test pose (:func:`error_profile`), for a
plot: median and 95th percentile of ρ on shells around the test pose(s)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pincal.arguments import angle, generator, positive_int
from pincal.deprecation import keywords_after
from pincal.evaluation.accuracy_samples import prismatic_per_radian
from pincal.evaluation.predicted_error import PredictedError
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import resolve_test_poses
from pincal.instruments.given import keywords, measured, takes_instrument
from pincal.instruments.instrument import Instrument
from pincal.model.parameters import ParameterSet
from pincal.typing import ConfigurationsLike, PayloadLike, TestPoseLike


@dataclass(frozen=True)
class ErrorProfile:
    """Predicted error against the distance from the test pose, for one plan.

    Attributes:
        name: the plan's name.
        distance: (n,) joint-space distances max_j |q_j − q0_j| [rad] (a prismatic joint's
            distance counted in radians through :data:`PRISMATIC_PER_RADIAN`).
        median, p95: (n,) of ρ over configurations at that distance [m].
    """

    name: str
    distance: np.ndarray
    median: np.ndarray
    p95: np.ndarray

    def as_dict(self) -> dict:
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}


ORDER_0_1 = (
    "sigma", "prior", "max_distance", "steps", "samples", "seed", "task_payload", "measure", "instrument",
)  # fmt: skip
"""error_profile()'s keywords in pincal 0.1's order (what arguments by position after the third meant)."""


@keywords_after(3, ORDER_0_1)
@takes_instrument
def error_profile(
    params: ParameterSet,
    plans: Mapping[str, ConfigurationsLike],
    test_pose: TestPoseLike,
    *,
    sigma: float | None = None,
    instrument: Instrument | None = None,
    prior: Prior | None = None,
    max_distance: float = math.radians(30),
    steps: int = 13,
    samples: int = 128,
    seed: int = 0,
    task_payload: PayloadLike = None,
) -> tuple[ErrorProfile, ...]:
    """Median and 95th percentile of ρ on shells at distance d = max_j |q_j − q0_j| from the test
    pose(s), for d in [0, max_distance] (``samples`` configurations per shell, the same for every
    plan; a test pose drawn per sample; clipped to the joint limits). ``sigma`` and
    ``instrument`` as for :func:`accuracy`."""
    inst, sigma = measured(instrument, sigma)
    max_distance = angle(max_distance, "max_distance")
    steps = positive_int(steps, "steps", 2)
    samples = positive_int(samples, "samples")
    robot = params.robot
    poses, _ = resolve_test_poses(robot, test_pose)
    rng = generator(seed)
    distance = np.linspace(0.0, max_distance, steps)
    shells = []
    for d in distance:
        u = rng.uniform(-1.0, 1.0, (samples, robot.nq))
        u /= np.abs(u).max(axis=1, keepdims=True)
        centres = poses[rng.integers(len(poses), size=samples)]
        step = np.where(robot.revolute, d, d * prismatic_per_radian(test_pose))
        shells.append(np.clip(centres + step * u, robot.lower, robot.upper))
    out = []
    for name, plan in plans.items():
        predicted = PredictedError(
            params, plan, prior=prior, task_payload=task_payload, **keywords(inst, sigma)
        )
        rho = np.array([np.sqrt(predicted.squared(s)) for s in shells])
        out.append(ErrorProfile(name, distance, np.median(rho, axis=1), np.percentile(rho, 95, axis=1)))
    return tuple(out)
