"""Synthetic data: "real" robots with known errors, and what an instrument would measure on them.

* :func:`random_errors` draws errors for a parameter set (geometric, gains, compliances) and gives
  the perturbed robot.
* :func:`simulate_measurements` measures a robot at a plan, with Gaussian noise per coordinate,
  under a payload per configuration, optionally with a smooth error no parameter models
  (:class:`SmoothField`: what a residual model is for).
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
import pinocchio as pin

from pincal.arguments import angle, generator, length, positive_sigma
from pincal.calibration.measurements import MeasurementData
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument
from pincal.instruments.given import measured, takes_instrument
from pincal.instruments.instrument import Instrument
from pincal.instruments.point import Point
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.model.statics import payload_rows
from pincal.typing import ConfigurationsLike, PayloadLike, SeedLike

DEFAULT_ERROR_STD = {"length": 1e-3, "angle": 1e-3}
"""Standard deviation of random geometric errors: 1 mm for lengths [m], 1 mrad for angles [rad]."""

GAIN_STD = 5e-4
"""Standard deviation of random joint gains (dimensionless): published gear-ratio errors are 1e-4 to
1e-3."""

COMPLIANCE_TIP_DEFLECTION = 3e-4
"""Random joint compliances move the tip by about this much [m] at their joint's reference torque
(the RMS gravity torque of the arm's own weight, :attr:`ParameterSet.scales`): |N(0, 1)| times this
over the reference torque and over the joint's lever to the tip, a few tenths of a millimetre, as a
real arm under its own weight (docs/method.md §11.2)."""

COMPLIANCE_RANGE = (1e-7, 1e-5)
"""The published range of industrial joint compliances [rad/(N·m)] (docs/method.md §11.2): a drawn
revolute compliance is clipped into it (a light wrist under its own weight alone would otherwise get
1e-4 and more, and a payload would bend it by degrees)."""

LINEAR_COMPLIANCE_RANGE = (1e-9, 1e-6)
"""The range of a drawn prismatic joint's compliance [m/N]: an axis of 1 to 1 000 N/µm."""

_LEVER_FLOOR = 0.05
"""The shortest lever [m] from a joint to the tip a draw assumes (a joint at the tip moves it little,
its compliance is still bounded by :data:`COMPLIANCE_RANGE`)."""


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


@keywords_after(1)
def random_errors(
    params: ParameterSet,
    *,
    error_std: Mapping[str, float] | None = None,
    seed: SeedLike = None,
    payload: PayloadLike = None,
) -> RandomErrors:
    """Draw independent Gaussian errors for every parameter of ``params``.

    Args:
        params: the parameters to perturb (errors elsewhere stay zero).
        error_std: ``{"length": s [m], "angle": s [rad]}``; default 1 mm and 1 mrad. Prismatic
            joint offsets count as lengths. Gains get :data:`GAIN_STD`; compliances are positive,
            of the size that moves the tip by :data:`COMPLIANCE_TIP_DEFLECTION` at each joint's
            reference torque, within :data:`COMPLIANCE_RANGE` (m/N: :data:`LINEAR_COMPLIANCE_RANGE`).
        seed: an int, a numpy Generator, or None for fresh entropy.
        payload: the heaviest payload the simulated measurements carry (a mass [kg], a
            :class:`~pincal.model.statics.Payload` or one row [[kg, x, y, z]]): the compliances'
            reference torques are then
            those under it, so that it bends the arm by tenths of a millimetre, not by degrees.

    Returns:
        the true errors and the true robot (``.robot``), a perturbed copy of ``params.robot``.
    """
    length, angle = error_std_pair(error_std)
    rng = generator(seed)
    kinds = [p.kind for p in params]
    compliant = np.array([kind == "compliance" for kind in kinds], dtype=bool)
    scale = np.array(
        [
            GAIN_STD if kind == "gain" else 1.0 if kind == "compliance" else length if unit == "m" else angle
            for kind, unit in zip(kinds, params.units)
        ]
    )
    if compliant.any():
        scale[compliant], low, high = _compliance_scales(params, compliant, payload)
    values = scale * rng.standard_normal(len(params))
    if compliant.any():  # a joint yields to its load, never against it; within the published range
        values[compliant] = np.clip(np.abs(values[compliant]), low, high)
    values.flags.writeable = False
    return RandomErrors(params, values, params.apply(values))


def _compliance_scales(
    params: ParameterSet, compliant: np.ndarray, payload: PayloadLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the std of each compliance's draw, its lowest and its highest value) [rad/(N·m) or m/N]:
    :data:`COMPLIANCE_TIP_DEFLECTION` over the reference torque (or force; under ``payload`` when
    given) and, for a revolute joint, over its lever: the RMS distance from the joint to the tip
    over the reference configurations."""
    robot = params.robot
    joints = [p.index for p, c in zip(params.parameters, compliant) if c]
    model, data = robot.model, robot.model.createData()
    qs = robot.random_configurations(REFERENCE_LEVERS, 0)
    levers = np.zeros((len(qs), robot.nq))
    for n, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        tip = data.oMf[robot.tip_frame].translation
        levers[n] = [np.linalg.norm(tip - data.oMi[j + 1].translation) for j in range(robot.nq)]
    lever = np.maximum(np.sqrt(np.mean(levers**2, axis=0)), _LEVER_FLOOR)
    revolute = np.asarray(robot.revolute, dtype=bool)[joints]
    torque = params.scales[compliant]
    if payload is not None:
        loads = np.repeat(payload_rows(payload, 1), len(qs), axis=0)
        loaded = np.sqrt(np.mean(robot.joint_torques(qs, payload=loads, check=False) ** 2, axis=0))[joints]
        torque = np.maximum(torque, loaded)
    std = COMPLIANCE_TIP_DEFLECTION / (torque * np.where(revolute, lever[joints], 1.0))
    low = np.where(revolute, COMPLIANCE_RANGE[0], LINEAR_COMPLIANCE_RANGE[0])
    high = np.where(revolute, COMPLIANCE_RANGE[1], LINEAR_COMPLIANCE_RANGE[1])
    return std, low, high


REFERENCE_LEVERS = 50
"""Configurations over which a joint's lever to the tip is averaged (seed 0: the same every draw)."""


@dataclass(frozen=True, eq=False)
class SmoothField:
    """A smooth position error over joint space that no parameter models (gear eccentricity,
    thermal drift): per coordinate, a sum of ``terms`` sinusoids, each of one or two joints turning
    once or twice per revolution, in the robot's base frame.

    Attributes:
        amplitude: its root-mean-square size per coordinate over random configurations [m].
        frequencies: (terms, nq) integer frequencies of each term.
        phases: (terms, 3) phases [rad].
        weights: (terms, 3) weights.
    """

    amplitude: float
    frequencies: np.ndarray
    phases: np.ndarray
    weights: np.ndarray

    @classmethod
    def random(cls, robot: Robot, amplitude: float, seed: SeedLike = None, terms: int = 6) -> SmoothField:
        """A field of RMS ``amplitude`` [m] per coordinate over ``robot``'s joints."""
        rng = generator(seed)
        frequencies = np.zeros((terms, robot.nq), dtype=int)
        for term in frequencies:  # one or two joints each, once or twice per turn (gear errors)
            joints = rng.choice(robot.nq, size=int(rng.integers(1, 3)), replace=False)
            term[joints] = rng.choice([-2, -1, 1, 2], size=len(joints))
        weights = rng.standard_normal((terms, 3))
        weights *= amplitude * np.sqrt(2.0 / np.sum(weights**2, axis=0))  # RMS of Σ w sin(.) = amplitude
        return cls(float(amplitude), frequencies, rng.uniform(0, 2 * np.pi, (terms, 3)), weights)

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """(m, 3) the error at joint readings ``q`` [m], in the robot's base frame."""
        angles = np.atleast_2d(q) @ self.frequencies.T  # (m, terms)
        return np.sum(np.sin(angles[:, :, None] + self.phases[None]) * self.weights[None], axis=1)


@keywords_after(3, ("seed", "payload", "unmodelled", "measure", "instrument"))
@takes_instrument
def simulate_measurements(
    true_robot: Robot | RandomErrors,
    plan: ConfigurationsLike,
    sigma: float | None = None,
    *,
    seed: SeedLike = None,
    payload: PayloadLike = None,
    unmodelled: SmoothField | None = None,
    instrument: Instrument | None = None,
) -> MeasurementData:
    """What an instrument with Gaussian noise would measure: the markers' points with i.i.d.
    ``sigma`` per coordinate, or what ``instrument`` measures, its noise drawn from its error model.

    Args:
        true_robot: the robot measured (a :class:`~pincal.Robot`, or :class:`RandomErrors`).
        plan: (m, nq) configurations [rad or m] or a :class:`~pincal.Plan`, within the limits.
        sigma: the points' noise standard deviation per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`); not with ``instrument``, but 0: exact
            values, of the points or of what ``instrument`` measures.
        seed: an int, a numpy Generator, or None for fresh entropy.
        payload: the payload at each configuration (:func:`~pincal.model.statics.payload_rows`;
            default a Plan's own); the data then carry it (the payload columns), and a compliant
            robot bends under it.
        unmodelled: a smooth error added to every measured point (rotated into the instrument's
            frame), as real robots have.
        instrument: what is measured and how well (:class:`pincal.instruments.Instrument`: a
            pose, part of one, distances, pixels or points, with the error model the noise is
            drawn from, ``PerCoordinate`` or ``Tracker``, taken at the true points); default the
            markers' points with ``sigma``.

    Returns:
        the measurements (in the true robot's base frame, i.e. the instrument's frame when
        ``true_robot.base`` is set); an image's points out of the camera's view are NaN.
    """
    robot = true_robot.robot if isinstance(true_robot, RandomErrors) else true_robot
    if not isinstance(robot, Robot):
        raise BadArgument(f"simulate_measurements needs a Robot, got {type(true_robot).__name__}")
    exact = instrument is not None and sigma is not None and positive_sigma(sigma, zero=True) == 0
    inst, sigma = measured(instrument, None if exact else sigma, zero=True)
    qs = robot.configurations(plan)
    payload = getattr(plan, "payload", None) if payload is None else payload  # a Plan's own payloads
    loads = None if payload is None else payload_rows(payload, len(qs))
    if inst is not None:
        if unmodelled is not None:
            raise BadArgument("unmodelled errors are simulated for points with sigma= only (no instrument)")
        return _simulate_kind(robot, qs, loads, seed, inst, exact)
    points = robot.points(qs, payload=loads)
    if unmodelled is not None:
        points = points + (unmodelled(qs) @ robot.base.rotation.T)[:, None, :]
    if sigma > 0:
        points = points + sigma * generator(seed).standard_normal(points.shape)
    return MeasurementData(qs, points, robot.joint_names, payload=loads)


def _simulate_kind(
    robot: Robot,
    qs: np.ndarray,
    loads: np.ndarray | None,
    seed: SeedLike,
    instrument: Instrument,
    exact: bool = False,
) -> MeasurementData:
    """:func:`simulate_measurements` of what ``instrument`` measures at configurations ``qs`` under
    payload rows ``loads``, noise drawn from its error model's covariance (none when ``exact``)."""
    kind = instrument.kind
    kind.check(robot)
    values = kind.predict(robot, qs, loads)
    if not exact:
        covariance = instrument.error.covariance(kind, robot, qs)
        white = generator(seed).standard_normal(values.shape)
        if covariance.std is not None:
            values = values + covariance.std * white
        else:
            assert covariance.factor is not None  # one of std and factor is given
            values = values + np.einsum("mij,mj->mi", covariance.factor, white)
    values = np.where(kind.seen(robot, qs, loads), values, np.nan)
    if isinstance(kind, Point):
        return MeasurementData(qs, values.reshape(len(qs), -1, 3), robot.joint_names, payload=loads)
    return MeasurementData(qs, values, robot.joint_names, payload=loads, kind=kind)
