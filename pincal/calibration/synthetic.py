"""Synthetic data: "real" robots with known errors, and what an instrument would measure on them.

* :func:`random_errors` draws geometric errors for a parameter set and gives the perturbed robot.
* :func:`simulate_measurements` measures a robot at a plan, with Gaussian noise per coordinate.
* :func:`monte_carlo` repeats {random true robot → noisy measurements → identification} and
  compares the position error at the test pose(s) after compensation with the predicted ρ0
  (docs/method.md §6.8). For small errors the two agree within the Monte-Carlo statistical error; for large
  errors the linear prediction (made at the nominal geometry) stops holding, and the result says
  by how much (:attr:`MonteCarloResult.ratio`, :attr:`MonteCarloResult.note`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, Seed, angle, generator, length, positive_sigma
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadArgument
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot

DEFAULT_ERROR_STD = {"length": 1e-3, "angle": 1e-3}
"""Standard deviation of random geometric errors: 1 mm for lengths [m], 1 mrad for angles [rad]."""


@dataclass(frozen=True, eq=False)
class RandomErrors:
    """A synthetic "real" robot: the nominal robot with known errors.

    Attributes:
        params: the parameters perturbed (on the nominal robot).
        values: (P,) the true errors [m or rad].
        robot: ``params.apply(values)``, the true robot.
    """

    params: ParameterSet
    values: np.ndarray
    robot: Robot

    def as_dict(self) -> dict[str, float]:
        """``{name: true error}``."""
        return self.params.as_dict(self.values)


def error_std_pair(error_std: Mapping[str, float] | None) -> tuple[float, float]:
    """(length [m], angle [rad]) standard deviations of an ``error_std`` argument
    (``{"length": s, "angle": s}``, a missing key is 0; None: :data:`DEFAULT_ERROR_STD`).

    Raises:
        PincalError: not such a mapping, or a negative or non-finite value.
    """
    std = DEFAULT_ERROR_STD if error_std is None else error_std
    if not isinstance(std, Mapping) or set(std) - {"length", "angle"}:
        raise BadArgument(
            f"error std must be a mapping with keys 'length' [m] and 'angle' [rad], got {std!r}"
        )
    return (
        length(std.get("length", 0.0), "error std 'length'", positive=False),
        angle(std.get("angle", 0.0), "error std 'angle'", positive=False),
    )


def random_errors(
    params: ParameterSet,
    error_std: Mapping[str, float] | None = None,
    seed: Seed = None,
) -> RandomErrors:
    """Draw independent Gaussian errors for every parameter of ``params``.

    Args:
        params: the parameters to perturb (errors elsewhere stay zero).
        error_std: ``{"length": s [m], "angle": s [rad]}``; default 1 mm and 1 mrad. Prismatic
            joint offsets count as lengths.
        seed: an int, a numpy Generator, or None for fresh entropy.

    Returns:
        the true errors and the true robot (``.robot``), a perturbed copy of ``params.robot``.
    """
    length, angle = error_std_pair(error_std)
    rng = generator(seed)
    scale = np.array([length if unit == "m" else angle for unit in params.units])
    values = scale * rng.standard_normal(len(params))
    values.flags.writeable = False
    return RandomErrors(params, values, params.apply(values))


def simulate_measurements(
    true_robot: Robot | RandomErrors,
    plan: object,
    sigma: float = DEFAULT_SIGMA,
    seed: Seed = None,
) -> MeasurementData:
    """What an instrument with i.i.d. Gaussian noise ``sigma`` per coordinate would measure.

    Args:
        true_robot: the robot measured (a :class:`~pincal.Robot`, or :class:`RandomErrors`).
        plan: (m, nq) configurations [rad or m] or a :class:`~pincal.Plan`, within the limits.
        sigma: noise standard deviation per coordinate [m] (0: exact points).
        seed: an int, a numpy Generator, or None for fresh entropy.

    Returns:
        the measurements (points in the true robot's base frame, i.e. the instrument's frame
        when ``true_robot.base`` is set).
    """
    robot = true_robot.robot if isinstance(true_robot, RandomErrors) else true_robot
    if not isinstance(robot, Robot):
        raise BadArgument(f"simulate_measurements needs a Robot, got {type(true_robot).__name__}")
    sigma = positive_sigma(sigma, zero=True)
    qs = robot.configurations(plan)
    points = robot.points(qs)
    if sigma > 0:
        points = points + sigma * generator(seed).standard_normal(points.shape)
    return MeasurementData(qs, points, robot.joint_names)
