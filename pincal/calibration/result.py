"""The result of an identification: estimates, standard errors, status, what the data could not
identify, outliers and the calibrated robot (built by :func:`~pincal.calibration.identification.identify`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pinocchio as pin
from scipy.special import chdtri

from pincal.arguments import DEFAULT_SIGMA
from pincal.calibration._result_accuracy import calibration_accuracy
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.problem import Linearisation
from pincal.calibration.result_report import report_text, unexplained_text
from pincal.calibration.sanity import Outlier
from pincal.deprecation import moved_from
from pincal.errors import BadArgument
from pincal.evaluation.accuracy_report import AccuracyReport
from pincal.evaluation.accuracy_samples import (
    NEIGHBOURHOOD_SAMPLES,
    NEIGHBOURHOODS,
    WORKSPACE_SAMPLES,
)
from pincal.evaluation.data_check import DataCheck
from pincal.evaluation.prior import Prior
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot
from pincal.model.statics import payload_rows
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
        session_estimates: for each session after the first, when ``base.*`` was identified, the
            values of the parameters it uses (``values`` with its own base's) and their (P, P)
            covariance (with its base's uncertainty, not the first session's): what
            :meth:`point_variances` and :func:`~pincal.validate` predict with in that session.
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
    session_estimates: tuple[tuple[np.ndarray, np.ndarray], ...] = ()

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
        return _linearised(self.params, self.values)

    def _session(self, session: int) -> tuple[np.ndarray, np.ndarray]:
        """(std, covariance) of the parameter values session ``session`` uses (its own base's)."""
        if not 0 <= session < max(len(self.sessions), 1):
            raise BadArgument(
                f"session must be between 0 and {max(len(self.sessions), 1) - 1}, got {session}",
                argument="session",
            )
        if session == 0 or not self.session_estimates:
            return self.std, self.covariance
        C = self.session_estimates[session - 1][1]
        return np.sqrt(np.diag(C)), C

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
        self, q: ConfigurationsLike, *, payload: PayloadLike = None, session: int = 0
    ) -> tuple[np.ndarray, np.ndarray]:
        """((m, K), (m, K)) the variance [m²] of each predicted point (:meth:`predict`, in session
        ``session``'s instrument frame) at joint readings ``q``, summed over its three coordinates,
        from each source: the parameters' uncertainty, tr(J C Jᵀ) over the point's rows (J the
        Jacobian of the *fitted* model under ``payload``, with that session's base, the one C belongs
        to, so that where the URDF puts the base does not matter; C :attr:`covariance`, or for a
        later session with its own base that base's (:attr:`session_estimates`); a dropped
        parameter, held nominal, adds nothing; NaN when a parameter
        estimated has no standard error), and what the model
        does not explain: the residual model's posterior variance, 3·v(q), or without one the
        residual level beyond the instrument's noise, 3·:attr:`unexplained`. NaN without an
        estimate."""
        robot = self.params.robot
        qs = robot.configurations(q)
        K = robot.n_markers
        std, C = self._session(session)
        C = np.nan_to_num(C, nan=0.0)
        estimated = [name not in self.dropped for name in self.names]
        if not np.any(np.isfinite(std)) or not np.all(np.isfinite(std[estimated])):
            C = np.full_like(C, np.nan)  # a parameter estimated without a standard error: unknown
        fitted = self._fitted
        if session > 0 and self.session_estimates:
            fitted = _linearised(self.params, self.session_estimates[session - 1][0])
        linear, x, engine, mapping = fitted
        loads = None if payload is None else payload_rows(payload, len(qs))  # the door: rows below
        J = linear.points(x, qs, loads, engine, mapping).reshape(len(qs), K, 3, -1)
        parameters = np.einsum("mkip,pr,mkir->mk", J, C, J)
        if self.residual_model is not None:
            rest = np.repeat(3.0 * self.residual_model.variance(qs)[:, None], K, axis=1)
        else:
            rest = np.full((len(qs), K), 3.0 * self.unexplained)
        return parameters, rest

    def expected_error(
        self, q: ConfigurationsLike, *, payload: PayloadLike = None, session: int = 0
    ) -> np.ndarray:
        """(m,) the expected distance [m] between the points :meth:`predict` gives at joint readings
        ``q`` (all markers) and the robot's true ones (docs/method.md §11.6): sqrt(tr(J C Jᵀ) +
        3K·u²), the parameters' standard errors propagated to the points through the fitted model
        (the ρ of §8.3 with this fit's covariance) and what the model does not explain, u² per
        coordinate: with a residual model its posterior variance v(q) (small near the data it was
        fitted on, its amplitude s² far from them), without one the residual level measured on the
        data beyond the instrument's noise (:attr:`unexplained`). NaN when it cannot be known. In
        session ``session``'s instrument frame, as :meth:`predict`."""
        parameters, rest = self.point_variances(q, payload=payload, session=session)
        return np.sqrt(parameters.sum(axis=1) + rest.sum(axis=1))

    @cached_property
    def _expected_at_data(self) -> dict[str, float]:
        """RMS over the kept configurations of the expected error and its two parts [m]."""
        data, sessions = self.data, max(len(self.sessions), 1)
        session = np.repeat(np.arange(sessions), [d.m for d in self.sessions] or [data.m])
        parts = []
        for s in range(sessions):  # each session's points with its own base's uncertainty
            rows = self._used & (session == s)
            load = None if data.payload is None else data.payload[rows]
            parts.append(self.point_variances(data.q[rows], payload=load, session=s))
        parameters, rest = (np.concatenate([p[i] for p in parts]) for i in (0, 1))
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
        return calibration_accuracy(
            self,
            test_pose,
            payload=payload,
            neighbourhoods=neighbourhoods,
            samples=samples,
            workspace=workspace,
            seed=seed,
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
            return rms(self.residuals_before[self._used])
        return next(iter(self.residual_rms_by_unit(before=True).values()))

    @property
    def residual_rms_after(self) -> float:
        """RMS distance between measured and calibrated points [m] (rejected rows excluded); for
        another kind, of its values of the first unit (:meth:`residual_rms_by_unit`)."""
        if self.data.is_points:
            return rms(self.residuals[self._used])
        return next(iter(self.residual_rms_by_unit().values()))

    def residual_rms_by_unit(self, before: bool = False) -> dict[str, float]:
        """``{unit: RMS}`` of the residuals after (or before) calibration by unit, lengths first:
        over the rows used, the size of each block of values of that unit (a marker's position, a
        pose's orientation, a target point's pixels, a distance) [m, rad or px]."""
        residuals = (self.residuals_before if before else self.residuals).reshape(len(self._used), -1)
        if self.data.is_points:
            return {"m": rms(residuals[self._used].reshape(int(self._used.sum()), -1, 3))}
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

    def unexplained_words(self, e: dict[str, float] | None = None) -> str:
        """What a prediction without a residual model is made of, in words (with the figures of
        ``e``, :attr:`_expected_at_data`, when given)."""
        return unexplained_text(self, e)

    def report(self) -> str:
        """A human-readable report: status, residuals, data identifiability, estimates ± standard
        errors (mm, mrad), outliers."""
        return report_text(self)


def _linearised(
    params: ParameterSet, values: np.ndarray
) -> tuple[Linearisation, np.ndarray, JacobianEngine, np.ndarray]:
    """The linearisation of ``params`` at ``values`` (NaN: 0), the values, its engine and column map."""
    linear = Linearisation(params)
    x = np.nan_to_num(np.asarray(values, dtype=float), nan=0.0)
    return linear, x, linear.engine(x), linear.mapping(x)


def _pose(placement: pin.SE3) -> dict:
    return {"xyz": placement.translation.tolist(), "rpy": pin.rpy.matrixToRpy(placement.rotation).tolist()}


def rms(residuals: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(residuals**2, axis=-1))))


def _num(v: float) -> float | None:
    """A float for JSON (None for NaN or infinity)."""
    return float(v) if np.isfinite(v) else None


__getattr__ = moved_from(
    __name__,
    {
        "pincal.calibration.assembly": ("identification_result", "residual_rms", "distance_unit"),
        "pincal.calibration.result_report": ("SHOWN",),
    },
)
"""Names that moved out of this module in 0.2 (the result's assembly and its words have their own
modules)."""
