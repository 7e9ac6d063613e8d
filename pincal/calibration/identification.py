"""Identification: the geometric errors that best explain measurements (SPEC §3).

The unknowns x are the values of a :class:`~pincal.ParameterSet`: the *total* errors of the real
robot relative to the set's (nominal) robot, in the parameter conventions (SPEC §2), so the
calibrated robot is ``params.apply(x)``. Least squares over all configurations and markers,

    x̂ = argmin Σᵢ ‖pᵢ − g(qᵢ, Π0 ⊕ x)‖²,

by Gauss–Newton on the nonlinear model: linearise at the current estimate with the analytic
parameter Jacobian (a perturbation *on top of* the current robot, :meth:`ParameterSet.on`),
chained with the right Jacobian of exp3 for rotation errors, solve for the correction, repeat
until every component of the correction is below ``tol`` (relative to 1 + |x|). If a Gauss–Newton
step fails to decrease the sum of squares, or the iterations run out, Levenberg–Marquardt
(``scipy.optimize.least_squares(method="lm")``) takes over from the best estimate.

When ``base.*`` parameters are identified (measurements in the instrument's frame), the starting
base is the rigid fit (Kabsch) of the nominal points onto the measured ones, so the linearisation
holds even when the instrument is metres away and rotated.

Standard errors: cov(x̂) = σ² M⁻¹, M = JᵀJ at the solution, with σ the given noise per coordinate
or, by default, σ̂² = Σ residual² / (3Km − P).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData, PincalError, SingularPlan
from pincal.evaluation.information import RCOND
from pincal.model.jacobian import ZERO_COLUMN, JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot

STATUSES = ("converged", "rank_deficient", "not_converged", "failed")
"""Values of :attr:`IdentificationResult.status`; only ``"converged"`` gives a calibrated robot."""

POOR_FIT = 1e-3
"""Residual RMS [m] after calibration above which the result's message warns that geometric
errors do not explain the data (units, markers, base frame, non-geometric errors)."""


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    """The outcome of :func:`identify`.

    Attributes:
        params: the parameters identified, on the nominal robot.
        values: (P,) estimated errors relative to the nominal robot [m or rad]: the last
            estimate if the fit did not converge, NaN if the data are rank deficient.
        std: (P,) standard errors, sqrt(diag(σ² M⁻¹)) [m or rad].
        correlation: (P, P) correlations of the estimates.
        sigma: noise standard deviation per coordinate used for ``std`` [m].
        sigma_estimated: True when ``sigma`` was estimated from the residuals.
        residuals: (m, K, 3) measured − calibrated model [m].
        residuals_before: (m, K, 3) measured − nominal model [m].
        iterations: Gauss–Newton iterations plus Levenberg–Marquardt Jacobian evaluations.
        status: one of :data:`STATUSES`.
        message: what happened, in words (why it failed and what to do, if it did).
        method: ``"gauss-newton"`` or ``"levenberg-marquardt"`` (the one that finished).
        robot: the robot of ``values``, ``params.apply(values)`` (the calibrated robot when
            ``success``; the nominal robot when the data are rank deficient).
        data: the measurements, in the robot's joint order.
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
        """(P, P) covariance σ² M⁻¹ of the estimates [m², m·rad, rad²]."""
        return self.correlation * np.outer(self.std, self.std)

    @property
    def residual_rms_before(self) -> float:
        """RMS distance between measured and nominal points [m] (over configurations and markers)."""
        return _rms(self.residuals_before)

    @property
    def residual_rms_after(self) -> float:
        """RMS distance between measured and calibrated points [m]."""
        return _rms(self.residuals)

    def as_dict(self) -> dict:
        """JSON-ready summary: parameters (value, std, unit), residuals, status, markers, base."""
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
            "sigma": _num(self.sigma),
            "sigma_estimated": self.sigma_estimated,
            "m": self.data.m,
            "markers": self.robot.markers.tolist(),
            "base": {
                "xyz": base.translation.tolist(),
                "rpy": pin.rpy.matrixToRpy(base.rotation).tolist(),
            },
        }

    def report(self) -> str:
        """A human-readable report: status, residuals, estimates ± standard errors (mm, mrad)."""
        lines = [
            f"{self.status}: {self.message}",
            f"residual RMS: {self.residual_rms_before * 1e3:.4g} mm before, "
            f"{self.residual_rms_after * 1e3:.4g} mm after ({self.data.m} configurations, "
            f"{self.data.n_markers} marker(s), {len(self.params)} parameters, {self.iterations} "
            f"iterations, {self.method})",
            f"sigma: {self.sigma * 1e3:.4g} mm per coordinate"
            + (" (estimated from the residuals)" if self.sigma_estimated else " (given)"),
        ]
        width = max(len(n) for n in self.names)
        for name, v, s, unit in zip(self.names, self.values, self.std, self.params.units, strict=True):
            shown = "mm" if unit == "m" else "mrad"
            lines.append(f"  {name:{width}s} {v * 1e3:+11.5f} ± {s * 1e3:.5f} {shown}")
        return "\n".join(lines)


def _rms(residuals: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(residuals**2, axis=-1))))


def _num(v: float) -> float | None:
    """A float for JSON (None for NaN or infinity)."""
    return float(v) if np.isfinite(v) else None


class _Problem:
    """The least-squares problem r(x) = measured − g(q, params.apply(x)), with its Jacobian."""

    def __init__(self, params: ParameterSet, data: MeasurementData) -> None:
        self.params = params
        self.qs = np.array(data.q)
        self.measured = data.points.reshape(-1)
        # Rotation errors compose on the right, R·exp3(ω): the Jacobian with respect to ω is the
        # Jacobian of a perturbation on top of the current robot times the right Jacobian of exp3.
        # That needs all three rotation columns of each rotated placement (and of the base).
        groups: dict[tuple[str, int], list[int]] = {}
        for i, p in enumerate(params.parameters):
            if p.kind in ("placement", "base") and p.component >= 3:
                groups.setdefault((p.kind, p.index), []).append(i)
        prefix = {("base", 0): "base"}
        extra = []
        for kind, index in groups:
            name = prefix.get((kind, index)) or params.robot.origins[index].name
            extra += [f"{name}.{c}" for c in ("rx", "ry", "rz")]
        self.augmented = ParameterSet.from_spec(params.robot, list(params.names) + extra)
        self.D0 = np.zeros((len(self.augmented), len(params)))
        self.rotations = []  # (augmented columns of rx ry rz, set columns, their components 0..2)
        for i, name in enumerate(params.names):
            self.D0[self.augmented.index(name), i] = 1.0
        for (kind, index), cols in groups.items():
            name = prefix.get((kind, index)) or params.robot.origins[index].name
            aug = [self.augmented.index(f"{name}.{c}") for c in ("rx", "ry", "rz")]
            comps = [params.parameters[i].component - 3 for i in cols]
            self.rotations.append((aug, cols, comps))

    def robot(self, x: np.ndarray) -> Robot:
        return self.params.apply(x)

    def residual(self, x: np.ndarray) -> np.ndarray:
        return self.measured - self.robot(x).points(self.qs, check=False).reshape(-1)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(3Km, P) derivative of the model points with respect to x (= −∂r/∂x)."""
        J = JacobianEngine(self.augmented.on(self.robot(x))).jacobian(self.qs, frame="world")
        D = self.D0.copy()
        for aug, cols, comps in self.rotations:
            omega = np.zeros(3)
            omega[comps] = x[cols]
            Jr = pin.Jexp3(omega)
            for col, comp in zip(cols, comps, strict=True):
                D[aug, col] = Jr[:, comp]
        return J.reshape(-1, J.shape[-1]) @ D


def _rigid_fit(source: np.ndarray, target: np.ndarray) -> pin.SE3 | None:
    """The rigid motion T minimising Σ‖T·source − target‖² (Kabsch), or None if degenerate."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    A, B = source - cs, target - ct
    if np.linalg.matrix_rank(A, tol=1e-9 * max(np.abs(A).max(), 1e-300)) < 2:
        return None
    U, _, Vt = np.linalg.svd(A.T @ B)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return pin.SE3(R, ct - R @ cs)


def _initial(params: ParameterSet, data: MeasurementData) -> np.ndarray:
    """Zero errors, except the base components, from a rigid fit when base.* is identified."""
    x0 = np.zeros(len(params))
    base = {p.component: i for i, p in enumerate(params.parameters) if p.kind == "base"}
    if not base:
        return x0
    robot = params.robot
    fit = _rigid_fit(robot.points(data.q, check=False).reshape(-1, 3), data.points.reshape(-1, 3))
    if fit is None:
        return x0
    new = fit * robot.base
    twist = np.concatenate(
        [new.translation - robot.base.translation, pin.log3(robot.base.rotation.T @ new.rotation)]
    )
    for component, i in base.items():
        x0[i] = twist[component]
    return x0


def _scaled_lstsq(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    step, *_ = np.linalg.lstsq(J / scale, r, rcond=None)
    return step / scale


def _rank_deficiency(params: ParameterSet, J: np.ndarray, m: int, rows: int) -> str | None:
    """Why ``J`` (stacked, at the start) cannot identify ``params``, or None if it can."""
    norms = np.linalg.norm(J, axis=0)
    visible = norms > ZERO_COLUMN * max(norms.max(), 1e-300)
    scaled = np.where(visible, J / np.where(visible, norms, 1.0), 0.0)
    _, s, Vt = np.linalg.svd(scaled, full_matrices=False)
    threshold = np.sqrt(RCOND) * max(s[0], 1e-300)
    if s[-1] > threshold and np.all(visible):
        return None
    rank = int(np.sum(s > threshold))
    ident = params.identifiable()
    if ident.dropped:
        names = list(ident.dropped)
        shown = ", ".join(names[:10]) + (f", ... ({len(names)} in all)" if len(names) > 10 else "")
        return (
            f"the data cannot identify the requested parameters: {len(names)} of the {len(params)} "
            f"cannot be identified from position measurements at all ({shown}: "
            f"{ident.dropped[names[0]]}); identify the identifiable set instead "
            f"(params.identifiable().identifiable, --params {','.join(ident.identifiable.names)})"
        )
    null = np.abs(Vt[s <= threshold]).max(axis=0) if rank < len(params) else np.zeros(len(params))
    null[~visible] = 1.0
    names = [params.names[i] for i in np.flatnonzero(null > 0.1)]
    minimum = SingularPlan(len(params), rows, m).min_configurations
    return (
        f"the data cannot identify the requested parameters: the {m} configurations leave "
        f"{', '.join(names)} inseparable (rank {rank} < {len(params)} parameters); measure more "
        f"varied configurations (at least {minimum} are needed) or identify fewer parameters"
    )


def identify(
    params: ParameterSet,
    data: MeasurementData,
    sigma: float | None = None,
    max_iterations: int = 50,
    tol: float = 1e-10,
) -> IdentificationResult:
    """Identify the errors ``params`` from measurements (see the module doc).

    Args:
        params: the parameters to identify, on the nominal robot (use an identifiable set:
            ``robot.parameters(...).identifiable().identifiable``; add ``base`` with
            ``identifiable(prefer="base")`` when the data are in the instrument's frame).
        data: the measurements (any joint column order; the robot's markers, in order).
        sigma: measurement noise per coordinate [m] for the standard errors; default: estimated
            from the residuals.
        max_iterations: Gauss–Newton iterations; the Levenberg–Marquardt fallback may use
            2·max_iterations evaluations more.
        tol: convergence threshold on each component of the correction, relative to 1 + |x|
            [m or rad].

    Returns:
        the result; its ``status`` says whether it converged, and ``message`` why not (rank
        deficient data: which parameters and what to identify instead; no convergence).

    Raises:
        BadMeasurementData: data of the wrong joints or number of markers.
        BadConfiguration: a configuration outside the joint limits.
        SingularPlan: fewer measured coordinates than parameters (names the minimum number of
            configurations).
    """
    robot = params.robot
    if not isinstance(data, MeasurementData):
        raise BadMeasurementData(f"identify needs a MeasurementData, got {type(data).__name__}")
    data = data.for_robot(robot)
    if sigma is not None and not (np.isfinite(sigma) and sigma > 0):
        raise PincalError(f"sigma must be a positive number of metres, got {sigma!r}")
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise PincalError(f"max_iterations must be a positive integer, got {max_iterations!r}")
    n_params, rows, m = len(params), 3 * robot.n_markers, data.m
    if m * rows < n_params:
        raise SingularPlan(n_params, rows, m)

    problem = _Problem(params, data)
    before = data.points - robot.points(data.q, check=False)
    x = _initial(params, data)
    r = problem.residual(x)
    J = problem.jacobian(x)
    why = _rank_deficiency(params, J, m, rows)
    if why is not None:
        return _result(params, data, before, None, sigma, 0, "rank_deficient", why, "gauss-newton", problem)

    cost = float(r @ r)
    tiny = r.size * 1e-24  # (1e-12 m)² per coordinate: rounding
    iterations, converged, method = 0, False, "gauss-newton"
    for _ in range(int(max_iterations)):
        iterations += 1
        step = _scaled_lstsq(J, r)
        if not np.all(np.isfinite(step)):
            break
        x_new = x + step
        r_new = problem.residual(x_new)
        cost_new = float(r_new @ r_new)
        small = bool(np.all(np.abs(step) <= tol * (1.0 + np.abs(x_new))))
        if cost_new > cost * (1.0 + 1e-9) + tiny:
            break  # Gauss–Newton failed to decrease: Levenberg–Marquardt from x
        x, r, cost = x_new, r_new, cost_new
        if small:
            converged = True
            break
        J = problem.jacobian(x)

    note = ""
    if not converged:
        method = "levenberg-marquardt"
        x_lm, n_lm, converged, note = _levenberg_marquardt(problem, x, 2 * int(max_iterations), tol)
        iterations += n_lm
        if x_lm is not None:
            r_lm = problem.residual(x_lm)
            if float(r_lm @ r_lm) <= cost * (1.0 + 1e-9) + tiny:
                x, r, cost = x_lm, r_lm, float(r_lm @ r_lm)
    if converged:
        status = "converged"
        message = f"{iterations} iteration(s) of {method}"
        if method != "gauss-newton":
            message += f", after Gauss–Newton stalled ({note.rstrip('.')})"
    elif note.startswith("failed"):
        status, message = "failed", f"identification {note}"
    else:
        status = "not_converged"
        message = (
            f"no convergence after {iterations} iteration(s) ({note or 'iteration limit'}); the "
            f"last estimate is not a calibration. Check the data (units: --mm, --deg; markers; a "
            f"base frame: identify base.*) or allow more iterations"
        )
    return _result(params, data, before, x, sigma, iterations, status, message, method, problem)


def _levenberg_marquardt(
    problem: _Problem, x0: np.ndarray, max_nfev: int, tol: float
) -> tuple[np.ndarray | None, int, bool, str]:
    """(estimate or None, Jacobian evaluations, converged, note) of scipy's LM from ``x0``."""
    from scipy.optimize import least_squares  # imported on first use (it is slow to import)

    try:
        solution = least_squares(
            lambda x: -problem.residual(x),
            x0,
            jac=problem.jacobian,
            method="lm",
            x_scale="jac",
            xtol=min(tol, 1e-8),
            ftol=1e-15,
            gtol=1e-15,
            max_nfev=max(max_nfev, 1),
        )
    except (ValueError, ArithmeticError, np.linalg.LinAlgError, PincalError) as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        return None, 0, False, f"failed: Levenberg–Marquardt stopped on {text}"
    njev = int(solution.njev or 0)
    if not np.all(np.isfinite(solution.x)):
        return None, njev, False, "failed: Levenberg–Marquardt diverged"
    return solution.x, njev, solution.status > 0, solution.message


def _result(
    params: ParameterSet,
    data: MeasurementData,
    before: np.ndarray,
    x: np.ndarray | None,
    sigma: float | None,
    iterations: int,
    status: str,
    message: str,
    method: str,
    problem: _Problem,
) -> IdentificationResult:
    n = len(params)
    estimated = sigma is None
    if x is None:  # rank deficient: no estimate
        values, std, correlation = np.full(n, np.nan), np.full(n, np.nan), np.full((n, n), np.nan)
        robot, residuals = params.robot, before
        sigma = np.nan if estimated else sigma
    else:
        values, robot = x.copy(), problem.robot(x)
        residuals = data.points - robot.points(data.q, check=False)
        dof = residuals.size - n
        per_coordinate = float(np.sqrt(np.sum(residuals**2) / dof)) if dof > 0 else np.nan
        sigma = per_coordinate if estimated else sigma
        std, correlation = _covariance(problem.jacobian(x), float(sigma))
        if status == "converged":
            message += _warnings(_rms(residuals), per_coordinate, None if estimated else sigma)
    for array in (values, std, correlation, residuals, before):
        array.flags.writeable = False
    return IdentificationResult(
        params=params,
        values=values,
        std=std,
        correlation=correlation,
        sigma=float(sigma),
        sigma_estimated=estimated,
        residuals=residuals,
        residuals_before=before,
        iterations=iterations,
        status=status,
        message=message,
        method=method,
        robot=robot,
        data=data,
    )


def _warnings(rms: float, per_coordinate: float, sigma: float | None) -> str:
    """What a converged fit's residuals say about the data, as a message suffix."""
    if rms > POOR_FIT:
        return (
            f"; but the residuals stay at {rms * 1e3:.3g} mm RMS, more than geometric errors explain: "
            f"check the units (--mm, --deg), the marker position(s), and whether the data are in the "
            f"instrument's frame (identify base.*)"
        )
    if sigma is not None and per_coordinate > 3 * sigma:
        return (
            f"; the residuals ({per_coordinate * 1e3:.3g} mm per coordinate) are over 3 times the given "
            f"sigma: the data hold errors the model does not"
        )
    if np.isnan(per_coordinate):
        return "; as many parameters as measured coordinates: no residual degrees of freedom"
    return ""


def _covariance(J: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """(std, correlation) of σ² (JᵀJ)⁻¹, computed on the column-scaled Jacobian."""
    n = J.shape[1]
    d = np.linalg.norm(J, axis=0)
    d[d == 0] = 1.0
    try:
        inverse = np.linalg.inv((J / d).T @ (J / d))
    except np.linalg.LinAlgError:
        return np.full(n, np.inf), np.full((n, n), np.nan)
    cov = sigma**2 * inverse / np.outer(d, d)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation = cov / np.outer(std, std)
    return std, correlation
