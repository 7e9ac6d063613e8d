"""The Monte-Carlo check of a plan: does calibration deliver the predicted ρ0?

:func:`monte_carlo` repeats {random true robot → noisy measurements → identification} and
compares the position error at the test pose(s) after compensation with the predicted ρ0
(docs/method.md §6.8). For small errors the two agree within the Monte-Carlo statistical error; for large
errors the linear prediction (made at the nominal geometry) stops holding, and the result says
by how much (:attr:`MonteCarloResult.ratio`, :attr:`MonteCarloResult.note`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import pinocchio as pin

from pincal.arguments import generator, positive_int
from pincal.calibration.identification import IdentificationResult, identify
from pincal.calibration.synthetic import error_std_pair, random_errors, simulate_measurements
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument
from pincal.evaluation.test_pose import rho0
from pincal.instruments.given import keywords, measured, takes_instrument
from pincal.instruments.instrument import Instrument, orientation_length_of
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.model.statics import payload_rows
from pincal.planning.plan import Plan
from pincal.progress import Steps
from pincal.typing import ConfigurationsLike, PayloadLike, SeedLike

QUANTILES = (0.5, 0.9, 0.95, 0.99)
"""Quantiles of the error at the test pose(s) reported by :func:`monte_carlo`."""

AGREEMENT = 3.0
"""Empirical and predicted ρ0 agree when they differ by less than this many standard errors."""

LOCAL_MINIMUM = 3.0
"""A converged trial whose residuals exceed this many σ per coordinate found a local minimum."""


@dataclass(frozen=True, eq=False)
class MonteCarloResult:
    """What :func:`monte_carlo` found.

    Attributes:
        rho0_predicted: ρ0 of the plan at the nominal geometry [m] (root mean square over the
            test poses), σ·sqrt(trace(J0 M⁻¹ J0ᵀ)).
        rho0_empirical: root mean square, over trials and test poses, of the position error at
            the test pose(s) after compensation [m] (all markers: sqrt of Σ_k ‖error_k‖²).
        rho0_empirical_se: standard error of ``rho0_empirical`` [m] (from the trials' spread).
        rho0_at_truth: root mean square over trials of ρ0 linearised at each true robot [m].
        errors: (trials,) error of each converged trial at the test pose(s) [m] (RMS over poses).
        errors_before: (trials,) the same without calibration (nominal model) [m].
        quantiles: ``{q: error quantile [m]}`` for q in :data:`QUANTILES`.
        trials: trials run.
        failures: trials whose identification did not converge (left out of the statistics).
        local_minima: trials that converged to a wrong solution, residuals over
            :data:`LOCAL_MINIMUM` σ per coordinate (left out of the statistics).
        sigma: measurement noise per coordinate [m].
        error_std: the std of the random geometric errors (``{"length", "angle"}``).
        nonlinear: True when the empirical ρ0 departs from the prediction by more than
            :data:`AGREEMENT` standard errors, or trials failed or found local minima.
        note: a sentence on agreement and, if any, nonlinearity.
    """

    rho0_predicted: float
    rho0_empirical: float
    rho0_empirical_se: float
    rho0_at_truth: float
    errors: np.ndarray = field(repr=False)
    errors_before: np.ndarray = field(repr=False)
    quantiles: dict[float, float]
    trials: int
    failures: int
    local_minima: int
    sigma: float
    error_std: dict[str, float]
    nonlinear: bool
    note: str

    @property
    def ratio(self) -> float:
        """rho0_empirical / rho0_predicted (1 in the linear regime)."""
        return self.rho0_empirical / self.rho0_predicted

    @property
    def ratio_se(self) -> float:
        """Standard error of :attr:`ratio`."""
        return self.rho0_empirical_se / self.rho0_predicted

    def as_dict(self) -> dict:
        """JSON-ready summary (metres)."""
        return {
            "rho0_predicted": self.rho0_predicted,
            "rho0_empirical": self.rho0_empirical,
            "rho0_empirical_se": self.rho0_empirical_se,
            "rho0_at_truth": self.rho0_at_truth,
            "ratio": self.ratio,
            "trials": self.trials,
            "failures": self.failures,
            "local_minima": self.local_minima,
            "quantiles": {f"{q:g}": v for q, v in self.quantiles.items()},
            "error_before_rms": float(np.sqrt(np.mean(self.errors_before**2))),
            "sigma": self.sigma,
            "error_std": dict(self.error_std),
            "nonlinear": self.nonlinear,
            "note": self.note,
        }


ORDER_0_1 = (
    "sigma", "trials", "seed", "error_std", "task_payload", "measure", "instrument", "orientation_length",
    "progress",
)  # fmt: skip
"""monte_carlo()'s keywords in pincal 0.1's order (what arguments by position after the third meant)."""


@keywords_after(3, ORDER_0_1)
@takes_instrument
def monte_carlo(
    params: ParameterSet,
    plan: ConfigurationsLike,
    test_pose: ConfigurationsLike,
    *,
    sigma: float | None = None,
    instrument: Instrument | None = None,
    trials: int = 200,
    seed: SeedLike = None,
    error_std: Mapping[str, float] | None = None,
    task_payload: PayloadLike = None,
    orientation_length: float | None = None,
    progress: bool = False,
) -> MonteCarloResult:
    """Check a plan by simulation: does calibration deliver the predicted ρ0 at the test pose(s)?

    Each trial draws a true robot (:func:`random_errors`, errors of ``params`` only), measures it
    at ``plan`` with noise ``sigma`` (:func:`simulate_measurements`), identifies ``params`` from
    the nominal robot (:func:`~pincal.identify`), and records the distance between the calibrated
    and the true points at the test pose(s). A plan with payloads (:attr:`~pincal.Plan.payload`)
    is measured under them, and the test pose(s) are taken under ``task_payload``, as
    :func:`pincal.rho0` predicts (with gains and compliances among ``params``, the true robots
    carry random ones too).

    Args:
        params: the parameters (an identifiable set).
        plan: (m, nq) configurations or a :class:`~pincal.Plan`.
        test_pose: (nq,) or (k, nq) test configuration(s).
        sigma: the shorthand for points measured with this noise per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`); not with ``instrument``.
        instrument: what is measured and how well (:class:`pincal.instruments.Instrument`: a
            pose, part of one, distances, pixels or points, with an error model): the trials
            simulate and identify it, its error model both drawing the noise and weighing the
            fit; the error at the test pose is still the markers'. The result's σ is then its
            reference σ.
        trials: number of trials (the relative statistical error of ρ0 is about 1/sqrt(2·trials)
            or more).
        seed: a numpy Generator or a seed; one seed gives one result.
        error_std: ``{"length": [m], "angle": [rad]}`` of the random errors; default 1 mm, 1 mrad.
        task_payload: the payload at the test pose(s) (a mass [kg] or a :class:`~pincal.Payload`),
            or None.
        orientation_length: L [m]: the error at the test pose also counts L times the tool's
            orientation error (and the prediction its expectation), as the test-pose criterion does.
        progress: report the trials done on stderr (a bar on a terminal, else a line every few
            seconds).

    Returns:
        the comparison; ``nonlinear`` and ``note`` say whether the linear prediction held.

    Raises:
        SingularPlan: the plan cannot identify ``params``.
        BadConfiguration: a configuration or test pose outside the limits.
    """
    inst, sigma = measured(instrument, sigma)
    trials = positive_int(trials, "trials", 2)
    length_std, angle_std = error_std_pair(error_std)
    robot = params.robot
    qs = robot.configurations(plan)
    q0 = robot.configurations(test_pose, what="test pose")
    loads = getattr(plan, "payload", None)  # a Plan's payload: rows already (Plan is a door)
    task = None if task_payload is None else payload_rows(task_payload, len(q0))
    predicted = float(
        rho0(
            params,
            _planned(robot, qs, loads),
            q0,
            task_payload=task,
            orientation_length=orientation_length,
            **keywords(inst, sigma),
        )
    )
    errors = {"length": length_std, "angle": angle_std}
    length = orientation_length_of(orientation_length)
    check = _Check(params, qs, q0, float(sigma), errors, int(trials), loads, task, inst, length)
    runs = _run_trials(check, generator(seed), Steps(progress, "monte carlo", "trial"))
    n = len(runs.errors)
    if n < 2:
        raise BadArgument(
            f"monte carlo: {runs.failures + runs.local_minima} of {trials} identifications failed or found "
            f"local minima; the geometric errors (std {length_std:g} m, {angle_std:g} rad) are too large",
            argument="error_std",
            value={"length": length_std, "angle": angle_std},
        )
    squared = runs.errors**2
    empirical = float(np.sqrt(squared.mean()))
    se = float(squared.std(ddof=1) / np.sqrt(n) / (2.0 * empirical)) if empirical > 0 else 0.0
    truth_rms = float(np.sqrt(np.mean(np.square(runs.at_truth))))
    result = MonteCarloResult(
        rho0_predicted=predicted,
        rho0_empirical=empirical,
        rho0_empirical_se=se,
        rho0_at_truth=truth_rms,
        errors=runs.errors,
        errors_before=runs.before,
        quantiles={q: float(np.quantile(runs.errors, q)) for q in QUANTILES},
        trials=int(trials),
        failures=runs.failures,
        local_minima=runs.local_minima,
        sigma=float(sigma),
        error_std={"length": length_std, "angle": angle_std},
        nonlinear=bool(abs(empirical - predicted) > AGREEMENT * se or runs.failures or runs.local_minima),
        note="",
    )
    return replace(result, note=_note(result))


@dataclass(frozen=True, eq=False)
class _Check:
    """What one Monte-Carlo check simulates: the parameters, the plan and test poses [rad or m],
    the noise [m], the std of the random errors, the number of trials."""

    params: ParameterSet
    qs: np.ndarray
    q0: np.ndarray
    sigma: float
    error_std: dict[str, float]
    trials: int
    payload: np.ndarray | None = None
    task_payload: np.ndarray | None = None
    instrument: Instrument | None = None
    orientation_length: float | None = None


@dataclass(frozen=True, eq=False)
class _Runs:
    """What the trials gave: the errors after and before calibration and ρ0 at the true robot of
    each trial that found the truth [m]; the failed identifications and the local minima."""

    errors: np.ndarray
    before: np.ndarray
    at_truth: list[float]
    failures: int
    local_minima: int


def _run_trials(check: _Check, rng: np.random.Generator, steps: Steps) -> _Runs:
    """Each trial: draw the truth, simulate, identify, score (see :func:`monte_carlo`); each a step."""
    params, qs, q0, sigma = check.params, check.qs, check.q0, check.sigma
    task, plan = check.task_payload, _planned(params.robot, qs, check.payload)
    errors, before, at_truth = [], [], []
    failures = local_minima = 0
    inst, length = check.instrument, check.orientation_length
    measuring = keywords(inst, sigma)
    for _ in steps.each("done", range(check.trials)):
        truth = random_errors(params, error_std=check.error_std, seed=rng)
        data = simulate_measurements(truth.robot, qs, seed=rng, payload=check.payload, **measuring)
        result = identify(params, data, sanity=False, **measuring)
        if not result.success:
            failures += 1
            continue
        if _local_minimum(result, inst, sigma):
            local_minima += 1
            continue
        errors.append(_error_at(result.robot, truth.robot, q0, length, task))
        before.append(_error_at(params.robot, truth.robot, q0, length, task))
        at_truth.append(
            float(
                rho0(
                    params.on(truth.robot),
                    plan,
                    q0,
                    task_payload=task,
                    orientation_length=length,
                    **measuring,
                )
            )
        )
    return _Runs(np.array(errors), np.array(before), at_truth, failures, local_minima)


def _planned(robot, qs: np.ndarray, payload: np.ndarray | None) -> np.ndarray | Plan:
    """The plan's configurations with their payloads (a Plan), or the bare configurations."""
    return qs if payload is None else Plan.for_robot(robot, qs, payload)


def _local_minimum(result: IdentificationResult, inst: Instrument | None, sigma: float) -> bool:
    """A converged fit whose residuals per degree of freedom exceed :data:`LOCAL_MINIMUM` σ (of
    another instrument: its whitened residuals, :data:`LOCAL_MINIMUM`) found a wrong solution."""
    dof = max(int(np.isfinite(result.data.values).sum()) - len(result.params), 1)
    if inst is None:
        return bool(np.sqrt(np.sum(result.residuals**2) / dof) > LOCAL_MINIMUM * sigma)
    qs, kind = result.data.q, result.data.measure
    covariance = inst.error.covariance(kind, result.robot, qs)
    e = covariance.whiten(result.residuals.reshape(len(qs), -1), np.isfinite(result.data.values))
    return bool(np.sqrt(np.sum(e**2) / dof) > LOCAL_MINIMUM)


def _error_at(
    robot: Robot, truth: Robot, q0: np.ndarray, length: float | None, task: np.ndarray | None = None
) -> float:
    """sqrt(mean over test poses of Σ over markers ‖p − p_true‖² (under the task's payload), plus
    L²‖δθ‖² of the tool's orientation with ``length`` L)."""
    squared = np.sum((robot.points(q0, payload=task) - truth.points(q0, payload=task)) ** 2, axis=(1, 2))
    if length is not None:
        R, R_true = robot.tip_poses(q0, payload=task)[0], truth.tip_poses(q0, payload=task)[0]
        angles = np.array([np.linalg.norm(pin.log3(a @ b.T)) for a, b in zip(R, R_true)])
        squared = squared + (length * angles) ** 2
    return float(np.sqrt(np.mean(squared)))


def _note(result: MonteCarloResult) -> str:
    """A sentence on agreement between the empirical and the predicted ρ0 and, if any,
    nonlinearity."""
    predicted, empirical, se = result.rho0_predicted, result.rho0_empirical, result.rho0_empirical_se
    at_truth, failures, minima = result.rho0_at_truth, result.failures, result.local_minima
    ratio, ratio_se = empirical / predicted, se / predicted
    text = f"empirical/predicted rho0 = {ratio:.3f} ± {ratio_se:.3f}"
    agree = abs(empirical - predicted) <= AGREEMENT * se
    if agree and not failures and not minima:
        return (
            text + f": agreement within {AGREEMENT:g} standard errors; errors of this size are in "
            "the linear regime, where rho0 predicts the accuracy after calibration"
        )
    parts = [text]
    if failures or minima:
        parts.append(
            f"nonlinearity: of {result.trials} identifications started at the nominal geometry, "
            f"{failures} did not converge and {minima} converged to a wrong solution (local "
            f"minimum); errors this large need a better start (a coarse calibration first)"
        )
    if not agree:
        if abs(empirical - at_truth) <= AGREEMENT * se:
            parts.append(
                f"nonlinearity: rho0 linearised at the true robots ({at_truth:.3g} m) matches: errors "
                f"this large change the Jacobian, so rho0 at the nominal geometry is "
                f"{'optimistic' if ratio > 1 else 'pessimistic'}"
            )
        else:
            parts.append(
                f"nonlinearity: rho0 linearised at the true robots ({at_truth:.3g} m) does not match "
                f"either: the estimator itself is nonlinear at this error size (bias)"
            )
    elif failures or minima:
        parts.append("the converged trials agree with the prediction")
    return "; ".join(parts)
