"""The result of an identification: estimates, standard errors, status, what the data could not
identify, outliers and the calibrated robot (built by :func:`~pincal.calibration.identification.identify`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pinocchio as pin
from scipy.special import chdtri

from pincal.arguments import DEFAULT_SIGMA
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.problem import Linearisation, Problem
from pincal.calibration.sanity import OUTLIER_SCORE, Outlier
from pincal.calibration.state import Rows, Setup, Solution, Verdict
from pincal.evaluation.accuracy_report import AccuracyReport, ErrorSummary, PlanAccuracy
from pincal.evaluation.accuracy_samples import (
    NEIGHBOURHOOD_SAMPLES,
    NEIGHBOURHOODS,
    WORKSPACE_SAMPLES,
    sample_sets,
)
from pincal.evaluation.data_check import DataCheck
from pincal.evaluation.predicted_error import worst_found
from pincal.evaluation.prior import Prior
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot
from pincal.model.statics import Payload, payload_rows
from pincal.typing import ConfigurationsLike, PayloadLike, TestPoseLike

UNEXPLAINED_TEST = 0.01
"""The residuals exceed a given σ, and the excess counts as what the model does not explain, when
their variance is beyond the χ² quantile 1 − this (docs/method.md §11.6): a fit of pure noise
then counts nothing 99 times in 100."""


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    """The outcome of :func:`identify`.

    Attributes:
        params: the parameters asked for, on the nominal robot.
        values: (P,) estimated errors relative to the nominal robot [m or rad]: the last
            estimate if the fit did not converge; 0 for a parameter the data cannot identify
            (``dropped``); NaN if nothing is identifiable.
        std: (P,) standard errors [m or rad] (NaN for a dropped parameter).
        correlation: (P, P) correlations of the estimates.
        sigma: noise standard deviation per coordinate used for ``std`` [m] (the median
            per-point σ when the data have them); NaN when it was to be estimated and the data
            leave no residual degrees of freedom.
        sigma_estimated: True when ``sigma`` was estimated from the residuals.
        residuals: (m, K, 3) measured − calibrated model [m] (sessions stacked, rows rejected
            as outliers included); (m, r) for another measurement kind [m, rad or px] (0 where
            nothing was measured).
        residuals_before: the same for the nominal model, each session's base from the initial
            rigid fit when ``base.*`` is identified.
        iterations: Jacobian evaluations of the solver.
        status: one of :data:`STATUSES`.
        message: what happened, in words (why it failed and what to do, if it did).
        method: the scipy ``least_squares`` method, ``"trf"`` or ``"lm"``.
        robot: the robot of ``values`` (first session's base), ``params.apply(values)``.
        data: the measurements, in the robot's joint order (sessions stacked).
        check: the identifiability of ``params`` on these data (rank, conditioning, ...).
        dropped: ``{name: reason}`` for the parameters the data cannot identify (left nominal).
        outliers: suspicious rows of the final fit, worst first.
        rejected: rows dropped by ``reject``, in the order they were dropped.
        loss: the loss function.
        prior: the prior of a MAP fit, or None.
        causes: the likely causes of an ``implausible`` result.
        sessions: the data of each session (one file each).
        bases: the instrument base of each session (``base`` of the robot in each instrument
            frame; the identity when ``base.*`` is not identified).
        initial_robot: the robot the "before" residuals are of (nominal, rigid-fit base).
        initial_bases: each session's base of the "before" residuals (the rigid fits).
        residual_model: the Gaussian process of what the fitted model leaves (``identify(...,
            residual_model="gp")``; its mean corrects :meth:`predict`, its variance is part of
            the predicted error), or None.
        residual_level: the residuals' standard deviation per coordinate over the rows used, with
            the degrees of freedom the fit leaves [m] (for another kind: the reference σ times the
            whitened residuals' RMS), whether σ was given or estimated; NaN without degrees of
            freedom. Beyond the instrument's σ it is what the model does not explain
            (:attr:`unexplained`).
        residual_dof: those degrees of freedom (coordinates used − unknowns fitted).
    """

    params: ParameterSet
    values: np.ndarray
    std: np.ndarray
    correlation: np.ndarray
    sigma: float
    sigma_estimated: bool
    residuals: np.ndarray
    residuals_before: np.ndarray
    iterations: int
    status: str
    message: str
    method: str
    robot: Robot
    data: MeasurementData
    check: DataCheck | None = None
    dropped: dict[str, str] = field(default_factory=dict)
    outliers: tuple[Outlier, ...] = ()
    rejected: tuple[Outlier, ...] = ()
    loss: str = "linear"
    prior: Prior | None = None
    causes: tuple[str, ...] = ()
    sessions: tuple[MeasurementData, ...] = ()
    bases: tuple[pin.SE3, ...] = ()
    initial_robot: Robot | None = None
    initial_bases: tuple[pin.SE3, ...] = ()
    residual_model: ResidualModel | None = None
    residual_level: float = float("nan")
    residual_dof: int = 0

    def predict(self, q: ConfigurationsLike, *, payload: PayloadLike = None, session: int = 0) -> np.ndarray:
        """(m, K, 3) the points the calibration predicts at joint readings ``q`` [m], in session
        ``session``'s instrument frame: the calibrated robot's (under ``payload``), plus the residual
        model's mean when there is one (it models the residual in the robot's base frame)."""
        robot = self.robot.replace(base=self.bases[session]) if self.bases else self.robot
        points = robot.points(q, payload=payload)
        if self.residual_model is None:
            return points
        qs = robot.configurations(q)
        mean = self.residual_model.mean(qs).reshape(points.shape)
        return points + mean @ robot.base.rotation.T

    @cached_property
    def _fitted(self) -> tuple[Linearisation, np.ndarray, JacobianEngine, np.ndarray]:
        """The Jacobian of the fitted model (first session's base): its linearisation, the values it
        is taken at, its engine and its column map, kept for every prediction of this result."""
        linear = Linearisation(self.params)
        x = np.nan_to_num(np.asarray(self.values, dtype=float), nan=0.0)
        return linear, x, linear.engine(x), linear.mapping(x)

    @property
    def instrument_sigma(self) -> float:
        """The instrument's own noise per coordinate [m]: σ when given (or from the data's
        uncertainty columns), else the default instrument's, a laser tracker's
        (:data:`~pincal.arguments.DEFAULT_SIGMA`): what the residuals are judged against."""
        return DEFAULT_SIGMA if self.sigma_estimated else self.sigma

    @property
    def unexplained(self) -> float:
        """The variance per coordinate of what the fitted model does not explain [m²]
        (docs/method.md §11.6): 0 with a residual model (its posterior variance says it, point by
        point); otherwise the residual level beyond the instrument's own σ,
        :attr:`residual_level`² − :attr:`instrument_sigma`², when the residuals exceed that σ
        beyond their scatter (a χ² test at 1 %), else 0. NaN when σ was to be estimated and the
        data leave no degrees of freedom: the prediction is then unknown."""
        if self.residual_model is not None:
            return 0.0
        level, dof, floor = self.residual_level, self.residual_dof, self.instrument_sigma
        if not (np.isfinite(level) and dof > 0):
            return float("nan") if self.sigma_estimated else 0.0  # σ given: nothing to judge by
        if not np.isfinite(floor) or level**2 <= floor**2 * float(chdtri(dof, UNEXPLAINED_TEST)) / dof:
            return 0.0
        return float(level**2 - floor**2)

    def point_variances(
        self, q: ConfigurationsLike, *, payload: PayloadLike = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """((m, K), (m, K)) the variance [m²] of each predicted point (:meth:`predict`) at joint
        readings ``q``, summed over its three coordinates, from each source: the parameters'
        uncertainty, tr(J C Jᵀ) over the point's rows (J the Jacobian of the *fitted* model under
        ``payload``, the one C belongs to, so that where the URDF puts the base does not matter;
        C :attr:`covariance`; a dropped parameter, held nominal, adds nothing; NaN when a parameter
        estimated has no standard error), and what the model
        does not explain: the residual model's posterior variance, 3·v(q), or without one the
        residual level beyond the instrument's noise, 3·:attr:`unexplained`. NaN without an
        estimate."""
        robot = self.params.robot
        qs = robot.configurations(q)
        K = robot.n_markers
        C = np.nan_to_num(self.covariance, nan=0.0)
        estimated = [name not in self.dropped for name in self.names]
        if not np.any(np.isfinite(self.std)) or not np.all(np.isfinite(self.std[estimated])):
            C = np.full_like(C, np.nan)  # a parameter estimated without a standard error: unknown
        linear, x, engine, mapping = self._fitted
        J = linear.points(x, qs, payload, engine, mapping).reshape(len(qs), K, 3, -1)
        parameters = np.einsum("mkip,pr,mkir->mk", J, C, J)
        if self.residual_model is not None:
            rest = np.repeat(3.0 * self.residual_model.variance(qs)[:, None], K, axis=1)
        else:
            rest = np.full((len(qs), K), 3.0 * self.unexplained)
        return parameters, rest

    def expected_error(self, q: ConfigurationsLike, *, payload: PayloadLike = None) -> np.ndarray:
        """(m,) the expected distance [m] between the points :meth:`predict` gives at joint readings
        ``q`` (all markers) and the robot's true ones (docs/method.md §11.6): sqrt(tr(J C Jᵀ) +
        3K·u²), the parameters' standard errors propagated to the points through the fitted model
        (the ρ of §8.3 with this fit's covariance) and what the model does not explain, u² per
        coordinate: with a residual model its posterior variance v(q) (small near the data it was
        fitted on, its amplitude s² far from them), without one the residual level measured on the
        data beyond the instrument's noise (:attr:`unexplained`). NaN when it cannot be known."""
        parameters, rest = self.point_variances(q, payload=payload)
        return np.sqrt(parameters.sum(axis=1) + rest.sum(axis=1))

    @cached_property
    def _expected_at_data(self) -> dict[str, float]:
        """RMS over the kept configurations of the expected error and its two parts [m]."""
        data = self.data
        used = self._used
        parameters, rest = self.point_variances(
            data.q[used], payload=None if data.payload is None else data.payload[used]
        )
        part = "residual_model" if self.residual_model is not None else "unexplained"
        out = {
            "rms": float(np.sqrt(np.mean(parameters.sum(axis=1) + rest.sum(axis=1)))),
            "parameters": float(np.sqrt(np.mean(parameters.sum(axis=1)))),
            part: float(np.sqrt(np.mean(rest.sum(axis=1)))),
        }
        if self.residual_model is not None:
            out["residual_model_far"] = float(
                np.sqrt(3 * self.robot.n_markers) * self.residual_model.amplitude
            )
        return out

    def accuracy(
        self,
        test_pose: TestPoseLike,
        *,
        payload: PayloadLike = None,
        neighbourhoods: tuple[float, ...] = NEIGHBOURHOODS,
        samples: int = NEIGHBOURHOOD_SAMPLES,
        workspace: int = WORKSPACE_SAMPLES,
        seed: int = 0,
    ) -> AccuracyReport:
        """The accuracy report of this calibration: the error of its predictions
        (:meth:`expected_error`: the parameters' standard errors and the residual model's variance)
        at the test pose(s) or region ``test_pose``, over ±10° and ±20° around them and over the
        workspace, with the task's ``payload`` (one load for every configuration) — the report
        :func:`pincal.accuracy` gives a plan before it is measured, now for what was measured.

        Args:
            test_pose: test pose(s) or a region/path (see :func:`pincal.rho0`).
            payload: the task's payload (a mass [kg] or a :class:`~pincal.Payload`), or None.
            neighbourhoods, samples, workspace, seed: as for :func:`pincal.accuracy`.
        """
        robot = self.params.robot
        load = None if payload is None else payload_rows(payload, 1)
        if load is not None and not isinstance(payload, Payload):
            payload = Payload(float(load[0, 0]), (float(load[0, 1]), float(load[0, 2]), float(load[0, 3])))
        sets, poses, region = sample_sets(robot, test_pose, neighbourhoods, samples, workspace, seed)
        rows = tuple(ErrorSummary.of(where, self.expected_error(qs, payload=payload)) for where, qs in sets)
        worst = None if region is None else worst_found(_SquaredError(self, payload), region)
        parameters, gp = (v.sum(axis=1) for v in self.point_variances(poses, payload=payload))
        calibrated = PlanAccuracy(
            "calibrated",
            rows,
            worst,
            float(np.sqrt(np.mean(parameters))),
            0.0,
            float(np.sqrt(np.mean(gp))),
            **({} if self.residual_model is not None else {"unexplained": _UNEXPLAINED}),
        )
        return AccuracyReport(
            (calibrated,),
            float(self.sigma),
            None,
            None,
            "test pose" if region is None else region.description,
            tuple(bool(r) for r in robot.revolute),
        )

    @property
    def success(self) -> bool:
        """True when the estimate converged (the calibrated robot can be used and exported)."""
        return self.status == "converged"

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in the order of ``values``."""
        return self.params.names

    @property
    def covariance(self) -> np.ndarray:
        """(P, P) covariance of the estimates [m², m·rad, rad²]."""
        return self.correlation * np.outer(self.std, self.std)

    @property
    def conditioning(self) -> float:
        """Conditioning of the data for the parameters asked for (the number every report gives:
        :attr:`pincal.evaluation.DataCheck.conditioning`)."""
        return self.check.conditioning if self.check is not None else float("nan")

    @property
    def condition_number(self) -> float:
        """Condition number of the column-scaled data Jacobian of the parameters asked for."""
        return self.check.condition_number if self.check is not None else float("nan")

    @property
    def residual_rms_before(self) -> float:
        """RMS distance between measured and nominal points [m] (over configurations and markers);
        for another kind, of its values of the first unit (:meth:`residual_rms_by_unit`)."""
        if self.data.is_points:
            return _rms(self.residuals_before[self._used])
        return next(iter(self.residual_rms_by_unit(before=True).values()))

    @property
    def residual_rms_after(self) -> float:
        """RMS distance between measured and calibrated points [m] (rejected rows excluded); for
        another kind, of its values of the first unit (:meth:`residual_rms_by_unit`)."""
        if self.data.is_points:
            return _rms(self.residuals[self._used])
        return next(iter(self.residual_rms_by_unit().values()))

    def residual_rms_by_unit(self, before: bool = False) -> dict[str, float]:
        """``{unit: RMS}`` of the residuals after (or before) calibration by unit, lengths first:
        over the rows used, the size of each block of values of that unit (a marker's position, a
        pose's orientation, a target point's pixels, a distance) [m, rad or px]."""
        residuals = (self.residuals_before if before else self.residuals).reshape(len(self._used), -1)
        if self.data.is_points:
            return {"m": _rms(residuals[self._used].reshape(int(self._used.sum()), -1, 3))}
        kind, robot = self.data.measure, self.robot
        units = np.array(kind.units(robot))
        seen = np.isfinite(self.data.values)[self._used]
        kept = residuals[self._used]
        out = {}
        for unit in sorted(set(units), key=("m", "rad", "px").index):
            sizes = [
                np.sqrt(np.sum(kept[:, [i for i in b if units[i] == unit]] ** 2, axis=1))[seen[:, b[0]]]
                for b in kind.blocks(robot)
                if units[b[0]] == unit or any(units[i] == unit for i in b)
            ]
            flat = np.concatenate(sizes) if sizes else np.zeros(0)
            out[unit] = float(np.sqrt(np.mean(flat**2))) if flat.size else float("nan")
        return out

    @property
    def _used(self) -> np.ndarray:
        used = np.ones(len(self.residuals), dtype=bool)
        used[[o.row for o in self.rejected]] = False
        return used

    def as_dict(self) -> dict:
        """JSON-ready summary: parameters (value, std, unit), residuals, status, markers, base,
        data identifiability, outliers."""
        base = self.robot.base
        return {
            "params": {
                name: {"value": _num(v), "std": _num(s), "unit": unit}
                for name, v, s, unit in zip(self.names, self.values, self.std, self.params.units, strict=True)
            },
            "residual_rms_before": _num(self.residual_rms_before),
            "residual_rms_after": _num(self.residual_rms_after),
            "iterations": self.iterations,
            "status": self.status,
            "message": self.message,
            "method": self.method,
            "loss": self.loss,
            "sigma": _num(self.sigma),
            "sigma_estimated": self.sigma_estimated,
            "m": self.data.m,
            **self._instrument_dict(),
            "markers": self.robot.markers.tolist(),
            "base": _pose(base),
            "bases": [_pose(b) for b in self.bases],
            "conditioning": _num(self.conditioning),
            "condition_number": _num(self.condition_number),
            "identifiability": self.check.as_dict() if self.check is not None else None,
            "dropped": dict(self.dropped),
            "outliers": [o.as_dict() for o in self.outliers],
            "rejected": [o.as_dict() for o in self.rejected],
            "causes": list(self.causes),
            "prior": self.prior.as_dict() if self.prior is not None else None,
            "residual_model": self.residual_model.summary() if self.residual_model is not None else None,
            "expected_error": {k: _num(v) for k, v in self._expected_at_data.items()},
        }

    def _instrument_dict(self) -> dict:
        """The JSON of what is not points: the kind, the residuals by unit, the fixtures."""
        out: dict = {}
        if not self.data.is_points:
            out["measure"] = self.data.measure.as_dict()
            out["residual_rms_by_unit"] = {u: _num(v) for u, v in self.residual_rms_by_unit().items()}
        if self.robot.fixtures:
            out["fixtures"] = {f.name: _pose(f.placement) | {"on": f.on} for f in self.robot.fixtures}
        return out

    def _sigma_line(self) -> str:
        if not np.isfinite(self.sigma):  # estimated from no residual degrees of freedom
            return "sigma: undetermined (no residual degrees of freedom to estimate it from)"
        how = " (estimated from the residuals)" if self.sigma_estimated else " (given)"
        return f"sigma: {self.sigma * 1e3:.4g} mm per coordinate{how}"

    def _expected_line(self) -> str:
        """The expected error of the calibration's predictions, saying what it is made of."""
        e = self._expected_at_data
        if not np.isfinite(e["rms"]):
            return "expected error of a prediction: undetermined (no standard errors)"
        head = f"expected error of a prediction at the measured configurations: {e['rms'] * 1e3:.4g} mm RMS"
        if self.residual_model is None:
            return f"{head} ({self.unexplained_words(e)})"
        return (
            f"{head} (the parameters' standard errors {e['parameters'] * 1e3:.4g} mm and the residual "
            f"model's variance {e['residual_model'] * 1e3:.4g} mm; far from the measured configurations "
            f"the residual model's part grows to {e['residual_model_far'] * 1e3:.4g} mm)"
        )

    def unexplained_words(self, e: dict[str, float] | None = None) -> str:
        """What a prediction without a residual model is made of, in words (with the figures of
        ``e``, :attr:`_expected_at_data`, when given)."""
        e = self._expected_at_data if e is None else e
        parts = (
            f"the parameters' standard errors {e['parameters'] * 1e3:.4g} mm"
            if e
            else "the parameters' standard errors"
        )
        u = self.unexplained
        if u > 0:
            whose = (
                "the default instrument's (a laser tracker's): give sigma (--sigma) for yours"
                if self.sigma_estimated
                else "the sigma given"
            )
            return (
                f"{parts} and what the model does not explain, {np.sqrt(u) * 1e3:.4g} mm per "
                f"coordinate: the residuals ({self.residual_level * 1e3:.4g} mm) exceed the instrument's "
                f"sigma {self.instrument_sigma * 1e3:.4g} mm ({whose}) beyond their scatter; a residual "
                "model (--residual-model gp) can say where"
            )
        return f"{parts}; the residuals are within the noise: the model explains the data"

    def report(self) -> str:
        """A human-readable report: status, residuals, data identifiability, estimates ± standard
        errors (mm, mrad), outliers."""
        lines = [f"{self.status}: {self.message}"]  # an implausible one names its likely causes
        if self.data.is_points:
            what = f"{self.data.m} configurations, {self.data.n_markers} marker(s)"
            rms = (
                f"{self.residual_rms_before * 1e3:.4g} mm before, "
                f"{self.residual_rms_after * 1e3:.4g} mm after"
            )
        else:
            what = f"{self.data.m} configurations, {self.data.measure.describe()}"
            before, after = self.residual_rms_by_unit(before=True), self.residual_rms_by_unit()
            rms = "; ".join(f"{_sized(before[u], u)} before, {_sized(after[u], u)} after" for u in after)
        lines += [
            f"residual RMS: {rms} ({what}, {len(self.params)} parameters, {self.iterations} "
            f"iterations, {self.method}, loss {self.loss})",
            self._sigma_line(),
        ]
        if self.prior is not None:
            lines.append(f"prior: {self.prior} (MAP estimate)")
        if self.check is not None:
            lines.append(self.check.report())
        width = max(len(n) for n in self.names)
        for name, v, s, unit in zip(self.names, self.values, self.std, self.params.units, strict=True):
            scale, shown = SHOWN[unit]
            if name in self.dropped:
                lines.append(f"  {name:{width}s} not identified (nominal)")
            elif np.isfinite(s):
                lines.append(f"  {name:{width}s} {v * scale:+11.5f} ± {s * scale:.5f} {shown}")
            else:  # no degrees of freedom left to estimate σ from (e.g. after --reject)
                lines.append(f"  {name:{width}s} {v * scale:+11.5f} (standard error undetermined) {shown}")
        if self.residual_model is not None:
            lines.append(self.residual_model.describe())
        lines.append(self._expected_line())
        if self.rejected:
            lines.append(f"rejected {len(self.rejected)} row(s) and refitted:")
            lines += [f"  {o}" for o in self.rejected]
        if self.outliers:
            lines.append(f"suspicious rows (over {OUTLIER_SCORE:g} robust sigma):")
            lines += [f"  {o}" for o in self.outliers]
        return "\n".join(lines)


_UNEXPLAINED = "what the fitted model does not explain (the residual level beyond the noise)"


class _SquaredError:
    """A calibration's squared expected error as :func:`~pincal.evaluation.predicted_error.worst_found`
    searches it."""

    def __init__(self, result: IdentificationResult, payload: PayloadLike) -> None:
        self.result, self.payload = result, payload

    def squared(self, qs: np.ndarray) -> np.ndarray:
        return self.result.expected_error(np.atleast_2d(qs), payload=self.payload) ** 2


SHOWN = {
    "m": (1e3, "mm"),
    "rad": (1e3, "mrad"),
    "1": (1e6, "ppm"),
    "rad/(N·m)": (1e6, "µrad/(N·m)"),
    "m/N": (1e6, "µm/N"),
}
"""How the report shows a value of each unit: (factor, unit shown)."""


def _sized(value: float, unit: str) -> str:
    """A residual for people: mm, mrad or px."""
    return {"m": f"{value * 1e3:.4g} mm", "rad": f"{value * 1e3:.4g} mrad"}.get(unit, f"{value:.4g} {unit}")


def residual_rms(problem: Problem, residual: np.ndarray, used: np.ndarray) -> float:
    """The RMS of a stacked (N,) residual over the rows ``used``: of the points' distances [m]; for
    another kind, of its whitened values times the reference σ (a length on the noise's scale)."""
    if problem.points:
        return _rms(residual.reshape(problem.m, -1, 3)[used])
    noise = problem.noise
    e = noise.whiten(residual[noise.coordinates(used)], used)
    return float(noise.reference * np.sqrt(np.sum(e**2) / max(noise.count(used), 1)))


def distance_unit(problem: Problem) -> str:
    """The unit of the outliers' distances: ``m``, or the first value's unit of a kind without lengths."""
    return "m" if problem.points or "m" in problem.value_units else problem.value_units[0]


def _pose(placement: pin.SE3) -> dict:
    return {"xyz": placement.translation.tolist(), "rpy": pin.rpy.matrixToRpy(placement.rotation).tolist()}


def _rms(residuals: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(residuals**2, axis=-1))))


def _num(v: float) -> float | None:
    """A float for JSON (None for NaN or infinity)."""
    return float(v) if np.isfinite(v) else None


def identification_result(
    setup: Setup, solution: Solution | None, rows: Rows, verdict: Verdict
) -> IdentificationResult:
    """The result of an identification from its state: the setup, the solver's solution (None
    when no fit ran: rank-deficient data), the rows and the verdict. Without an estimate (no fit,
    or a failed one) the values and standard errors are NaN and the residuals those at the start."""
    problem, settings, noise = setup.problem, setup.settings, setup.problem.noise
    params, sessions = problem.params, list(problem.sessions)
    n, m = len(params), problem.m
    estimated = not noise.known
    shape = (m, params.robot.n_markers, 3) if problem.points else (m, noise.row_size)
    z = None if solution is None else solution.z
    if z is None:
        values, std, correlation = np.full(n, np.nan), np.full(n, np.nan), np.full((n, n), np.nan)
        robot, residuals = problem.robot(setup.z0), setup.before.reshape(shape)
        sigma_out = np.nan if estimated else noise.reference
        z_final = setup.z0
        level, dof = np.nan, 0
    else:
        values, robot = z[:n].copy(), problem.robot(z)
        residuals = problem.residual(z).reshape(shape)
        dof = noise.count(rows.used) - len(setup.free)
        per_coordinate = _per_coordinate(problem, residuals.reshape(-1), rows.used, dof)
        level = per_coordinate
        sigma_out = per_coordinate if estimated else noise.reference
        std, correlation = _covariance(
            setup, z, rows.used, per_coordinate if estimated and settings.prior is None else None
        )
        z_final = z
    bases = tuple(problem.robot(z_final, s).base for s in range(len(sessions))) if problem.base else ()
    initial_bases = (
        tuple(problem.robot(setup.z0, s).base for s in range(len(sessions))) if problem.base else ()
    )
    for array in (values, std, correlation, residuals):
        array.flags.writeable = False
    before = setup.before.reshape(shape)
    before.flags.writeable = False
    return IdentificationResult(
        params=params,
        values=values,
        std=std,
        correlation=correlation,
        sigma=float(sigma_out),
        sigma_estimated=estimated,
        residuals=residuals,
        residuals_before=before,
        iterations=0 if solution is None else solution.iterations,
        status=verdict.status,
        message=verdict.message,
        method=settings.method,
        robot=robot,
        data=_stacked(sessions),
        check=setup.check,
        dropped={} if solution is None else dict(setup.dropped),
        outliers=rows.outliers,
        rejected=rows.rejected,
        loss=settings.loss,
        prior=settings.prior,
        causes=verdict.causes,
        sessions=tuple(sessions),
        bases=bases,
        initial_robot=problem.robot(setup.z0),
        initial_bases=initial_bases,
        residual_level=float(level),
        residual_dof=int(max(dof, 0)),
    )


def _per_coordinate(problem: Problem, residual: np.ndarray, used: np.ndarray, dof: int) -> float:
    """σ estimated from the residuals of the rows ``used`` [m] (NaN without degrees of freedom): of the
    points' coordinates; for another kind, the reference σ times the whitened residuals' RMS."""
    if dof <= 0:
        return np.nan
    keep = problem.noise.coordinates(used)
    if problem.points:
        return float(np.sqrt(np.sum(residual[keep] ** 2) / dof))
    e = problem.noise.whiten(residual[keep], used)
    return float(problem.noise.reference * np.sqrt(np.sum(e**2) / dof))


def _covariance(
    setup: Setup, z: np.ndarray, used: np.ndarray, scale_to: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """(std, correlation) of the parameters: (JᵀWJ + Σp⁻¹)⁻¹ over the free unknowns and the rows
    used, scaled to σ̂² = ``scale_to``² when σ is estimated; NaN for the parameters left out."""
    problem, free, prior_std = setup.problem, setup.free, setup.prior_std
    n = len(problem.params)
    J = problem.noise.whiten(problem.jacobian(z)[np.ix_(problem.noise.coordinates(used), free)], used)
    M = J.T @ J + np.diag(np.where(np.isfinite(prior_std[free]), 1.0 / prior_std[free] ** 2, 0.0))
    d = np.sqrt(np.diag(M))
    d[d == 0] = 1.0
    std, correlation = np.full(n, np.nan), np.full((n, n), np.nan)
    try:
        cov = np.linalg.inv(M / np.outer(d, d)) / np.outer(d, d)
    except np.linalg.LinAlgError:
        return std, correlation
    if scale_to is not None:
        cov = cov * (scale_to / problem.noise.reference) ** 2
    inside = free < n
    idx = free[inside]
    sub = cov[np.ix_(inside, inside)]
    # a variance that is not positive (or not finite) is rounding in the inverse of a numerically
    # singular M (data that barely see these parameters, e.g. one image of the target among many
    # empty ones): unknown, NaN, never a standard error of 0 or a correlation of inf
    variance = np.diag(sub)
    known = np.isfinite(variance) & (variance > 0)
    std[idx] = np.where(known, np.sqrt(np.where(known, variance, 1.0)), np.nan)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        block = sub / np.outer(std[idx], std[idx])
    correlation[np.ix_(idx, idx)] = np.where(np.isfinite(block), block, np.nan)
    return std, correlation


def _stacked(sessions: list[MeasurementData]) -> MeasurementData:
    if len(sessions) == 1:
        return sessions[0]
    if not sessions[0].is_points:
        return _stacked_values(sessions)
    sigma = None
    if any(d.sigma is not None for d in sessions):
        sigma = np.concatenate(
            [d.sigma if d.sigma is not None else np.full(d.points.shape, np.nan) for d in sessions]
        )
    return MeasurementData(
        np.concatenate([d.q for d in sessions]),
        np.concatenate([d.points for d in sessions]),
        sessions[0].joint_names,
        sigma=None if sigma is None or np.isnan(sigma).any() else sigma,
        source=" + ".join(str(d.source) for d in sessions),
        payload=_stacked_payload(sessions),
    )


def _stacked_payload(sessions: list[MeasurementData]) -> np.ndarray | None:
    """The sessions' payload rows stacked (no payload columns: none), or None if no session has any."""
    if all(d.payload is None for d in sessions):
        return None
    return np.concatenate([d.payload if d.payload is not None else np.zeros((d.m, 4)) for d in sessions])


def _stacked_values(sessions: list[MeasurementData]) -> MeasurementData:
    """The sessions of a kind other than points as one MeasurementData (their σ or covariances when
    every one has them)."""

    def joined(name: str) -> np.ndarray | None:
        parts = [getattr(d, name) for d in sessions]
        return None if any(p is None for p in parts) else np.concatenate(parts)

    return MeasurementData(
        np.concatenate([d.q for d in sessions]),
        np.concatenate([d.values for d in sessions]),
        sessions[0].joint_names,
        source=" + ".join(str(d.source) for d in sessions),
        sigma=joined("sigma"),
        payload=_stacked_payload(sessions),
        kind=sessions[0].kind,
        covariance=joined("covariance"),
    )
