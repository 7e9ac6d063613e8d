"""Identification: the geometric errors that best explain measurements (SPEC §3).

The unknowns x are the values of a :class:`~pincal.ParameterSet`: the *total* errors of the real
robot relative to the set's (nominal) robot, in the parameter conventions (SPEC §2), so the
calibrated robot is ``params.apply(x)``. Weighted least squares over all configurations, markers
and sessions,

    x̂ = argmin Σᵢ ρ(‖(pᵢ − g(qᵢ, Π0 ⊕ x)) / σᵢ‖²)  [+ ‖x / σ_prior‖² with a prior],

solved by ``scipy.optimize.least_squares`` (``trf``, or ``lm`` without a robust loss) with the
analytic Jacobian (:mod:`pincal.calibration.problem`). σᵢ is the per-point uncertainty of the
data when they have one, else σ. Robust losses (``huber``, ``soft_l1``, ``cauchy``) take
``f_scale`` = :data:`ROBUST_SCALE` standard deviations: σ when it is known (given or per point),
else a robust estimate (1.4826·median|r|) from a plain least-squares fit.

The steps, each reported:

1. **Data identifiability** (:mod:`pincal.evaluation.data_check`): rank and condition number of
   the column-scaled Jacobian of *these* configurations, the weakest combinations, and the subset
   the data determine to better than 1 cm / 10 mrad; the others stay at their nominal value, named
   with the reason. With a :class:`~pincal.Prior` nothing is dropped: the fit is the MAP estimate.
2. **Fit**, from zero errors except each session's base, from a rigid fit (Kabsch) of the nominal
   points onto the measured ones when ``base.*`` is identified. The "before" residual is the
   residual there (after the rigid fit), not at a base at the identity.
3. **Outliers**: rows above :data:`~pincal.calibration.sanity.OUTLIER_SCORE` robust σ are named
   by file and line; with ``reject=K`` the rows above K robust σ (scored on a ``soft_l1`` fit) are
   dropped and the fit repeated until none is left.
4. **Sanity** (:mod:`pincal.calibration.sanity`): a fit with values or residuals no real robot has
   is ``implausible``, with its likely causes, never ``converged``.

Standard errors: cov(x̂) = (JᵀWJ + Σp⁻¹)⁻¹ at the solution; without per-point σ and without a
given σ, scaled by σ̂² = Σ residual² / (N − P) (σ estimated from the residuals).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from pincal.arguments import positive_sigma
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.problem import Problem, initial_values
from pincal.calibration.sanity import (
    OUTLIER_SCORE,
    Outlier,
    find_outliers,
    implausible,
    likely_causes,
    robust_sigma,
    row_scores,
)
from pincal.errors import BadArgument, BadMeasurementData, PincalError, SingularPlan
from pincal.evaluation.data_check import DataCheck, check_information
from pincal.evaluation.prior import Prior
from pincal.model.base_parameters import preference_order
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot

STATUSES = ("converged", "implausible", "rank_deficient", "not_converged", "failed")
"""Values of :attr:`IdentificationResult.status`; only ``"converged"`` gives a calibrated robot."""

DEFAULT_SIGMA = 3e-5
"""The instrument's σ per coordinate [m] assumed when none is given (a laser tracker): it sets the
data-identifiability limits and the sanity limits, never the standard errors (those use σ
estimated from the residuals unless σ is given)."""

LOSSES = ("linear", "huber", "soft_l1", "cauchy")
METHODS = ("trf", "lm")
ROBUST_SCALE = 2.0
"""``f_scale`` of a robust loss, in standard deviations of the whitened residuals."""

ERROR_SCALE = 1e-3
"""Typical size of a geometric error [m or rad]: trf's variable scale, so that its first trust
region (radius 1 in scaled variables) holds a step of the size real errors have."""

POOR_FIT = 1e-3
"""Residual RMS [m] after calibration above which the result's message warns that geometric
errors do not explain the data (non-geometric errors, a model that is too small)."""


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
            per-point σ when the data have them).
        sigma_estimated: True when ``sigma`` was estimated from the residuals.
        residuals: (m, K, 3) measured − calibrated model [m] (sessions stacked, rows rejected
            as outliers included).
        residuals_before: (m, K, 3) measured − nominal model [m], each session's base from the
            initial rigid fit when ``base.*`` is identified.
        iterations: Jacobian evaluations of the solver.
        status: one of :data:`STATUSES`.
        message: what happened, in words (why it failed and what to do, if it did).
        method: the scipy ``least_squares`` method, ``"trf"`` or ``"lm"``.
        robot: the robot of ``values`` (first session's base), ``params.apply(values)``.
        data: the measurements, in the robot's joint order (sessions stacked).
        check: the identifiability of ``params`` on these data (rank, condition number, ...).
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
    def condition_number(self) -> float:
        """Condition number of the column-scaled data Jacobian of the parameters asked for."""
        return self.check.condition_number if self.check is not None else float("nan")

    @property
    def residual_rms_before(self) -> float:
        """RMS distance between measured and nominal points [m] (over configurations and markers)."""
        return _rms(self.residuals_before[self._used])

    @property
    def residual_rms_after(self) -> float:
        """RMS distance between measured and calibrated points [m] (rejected rows excluded)."""
        return _rms(self.residuals[self._used])

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
            "markers": self.robot.markers.tolist(),
            "base": _pose(base),
            "bases": [_pose(b) for b in self.bases],
            "condition_number": _num(self.condition_number),
            "identifiability": self.check.as_dict() if self.check is not None else None,
            "dropped": dict(self.dropped),
            "outliers": [o.as_dict() for o in self.outliers],
            "rejected": [o.as_dict() for o in self.rejected],
            "causes": list(self.causes),
            "prior": self.prior.as_dict() if self.prior is not None else None,
        }

    def report(self) -> str:
        """A human-readable report: status, residuals, data identifiability, estimates ± standard
        errors (mm, mrad), outliers."""
        lines = [f"{self.status}: {self.message}"]
        lines += [f"  likely cause: {c}" for c in self.causes]
        lines += [
            f"residual RMS: {self.residual_rms_before * 1e3:.4g} mm before, "
            f"{self.residual_rms_after * 1e3:.4g} mm after ({self.data.m} configurations, "
            f"{self.data.n_markers} marker(s), {len(self.params)} parameters, {self.iterations} "
            f"iterations, {self.method}, loss {self.loss})",
            f"sigma: {self.sigma * 1e3:.4g} mm per coordinate"
            + (" (estimated from the residuals)" if self.sigma_estimated else " (given)"),
        ]
        if self.prior is not None:
            lines.append(f"prior: {self.prior} (MAP estimate)")
        if self.check is not None:
            lines.append(self.check.report())
        width = max(len(n) for n in self.names)
        for name, v, s, unit in zip(self.names, self.values, self.std, self.params.units, strict=True):
            shown = "mm" if unit == "m" else "mrad"
            if name in self.dropped:
                lines.append(f"  {name:{width}s} not identified (nominal)")
            else:
                lines.append(f"  {name:{width}s} {v * 1e3:+11.5f} ± {s * 1e3:.5f} {shown}")
        if self.rejected:
            lines.append(f"rejected {len(self.rejected)} row(s) and refitted:")
            lines += [f"  {o}" for o in self.rejected]
        if self.outliers:
            lines.append(f"suspicious rows (over {OUTLIER_SCORE:g} robust sigma):")
            lines += [f"  {o}" for o in self.outliers]
        return "\n".join(lines)


def _pose(placement: pin.SE3) -> dict:
    return {"xyz": placement.translation.tolist(), "rpy": pin.rpy.matrixToRpy(placement.rotation).tolist()}


def _rms(residuals: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(residuals**2, axis=-1))))


def _num(v: float) -> float | None:
    """A float for JSON (None for NaN or infinity)."""
    return float(v) if np.isfinite(v) else None


def _sessions(data: object, robot: Robot) -> list[MeasurementData]:
    items = [data] if isinstance(data, MeasurementData) else data
    if not isinstance(items, Sequence) or not items or not all(isinstance(d, MeasurementData) for d in items):
        raise BadMeasurementData(
            f"identify needs a MeasurementData or a list of them (one per session), got {type(data).__name__}"
        )
    return [d.for_robot(robot) for d in items]


def _stacked(sessions: list[MeasurementData]) -> MeasurementData:
    if len(sessions) == 1:
        return sessions[0]
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
    )


def _labels(sessions: list[MeasurementData]) -> list[str]:
    return [label for d in sessions for label in d.labels()]


def _coordinate_sigma(sessions: list[MeasurementData], sigma: float | None) -> tuple[np.ndarray, float, bool]:
    """(σ per coordinate, the reference σ, whether the data carry their own)."""
    per_point = [d.sigma is not None for d in sessions]
    if any(per_point) and not all(per_point):
        raise BadMeasurementData("either every data file has uncertainty columns (s or sx,sy,sz), or none")
    if all(per_point):
        values = np.concatenate([d.sigma.reshape(-1) for d in sessions])
        return values, float(np.median(values)), True
    reference = DEFAULT_SIGMA if sigma is None else sigma
    return np.full(sum(d.points.size for d in sessions), reference), reference, False


def identify(
    params: ParameterSet,
    data: MeasurementData | Sequence[MeasurementData],
    sigma: float | None = None,
    maxiter: int = 100,
    tol: float = 1e-10,
    *,
    prior: Prior | None = None,
    loss: str = "linear",
    method: str = "trf",
    reject: float | None = None,
    sanity: bool = True,
) -> IdentificationResult:
    """Identify the errors ``params`` from measurements (see the module doc).

    Args:
        params: the parameters to identify, on the nominal robot (e.g. the identifiable set
            ``robot.parameters(...).identifiable().identifiable``; add ``base`` with
            ``identifiable(prefer="base")`` when the data are in the instrument's frame). Those
            the data cannot identify are left at zero (nominal) unless a ``prior`` is given.
        data: the measurements (any joint column order; the robot's markers, in order), or a
            list of them, one per session: each measured from its own instrument placement (one
            base each when ``base.*`` is identified), all sharing the robot's parameters.
        sigma: the instrument's noise per coordinate [m]; default: estimated from the residuals
            for the standard errors, and :data:`DEFAULT_SIGMA` for the checks. Data with
            uncertainty columns use theirs.
        maxiter: the solver's function evaluations (``max_nfev``).
        tol: the solver's ``xtol`` (relative change of the estimate at convergence).
        prior: a prior on the errors (MAP estimate; every parameter kept); the base is left free
            unless the prior names it.
        loss: ``linear``, ``huber``, ``soft_l1`` or ``cauchy``.
        method: ``trf`` or ``lm`` (linear loss only).
        reject: drop the rows beyond this many robust σ and refit, until none is left.
        sanity: judge the result's plausibility (``False`` for simulations whose true errors are
            known to be what they are, e.g. Monte-Carlo with huge errors).

    Returns:
        the result; its ``status`` says whether it converged, and ``message`` (and ``causes``)
        why not.

    Raises:
        BadMeasurementData: data of the wrong joints or number of markers.
        BadConfiguration: a configuration outside the joint limits.
        SingularPlan: fewer measured coordinates than parameters (names the minimum number of
            configurations).
        PincalError: a bad argument (named, with the valid values).
    """
    robot = params.robot
    sessions = _sessions(data, robot)
    sigma = None if sigma is None else positive_sigma(sigma)
    if isinstance(maxiter, bool) or int(maxiter) != maxiter or maxiter < 1:
        raise BadArgument(
            f"maxiter must be a positive integer, got {maxiter!r}",
            argument="maxiter",
            value=maxiter,
        )
    if loss not in LOSSES:
        raise BadArgument(
            f"unknown loss {loss!r}; valid: {', '.join(LOSSES)}", argument="loss", value=loss, valid=LOSSES
        )
    if method not in METHODS:
        raise BadArgument(
            f"unknown method {method!r}; valid: {', '.join(METHODS)}",
            argument="method",
            value=method,
            valid=METHODS,
        )
    if method == "lm" and loss != "linear":
        raise BadArgument(
            f"method 'lm' takes the linear loss only; use method 'trf' with loss {loss!r}", argument="method"
        )
    if reject is not None and not (np.isfinite(reject) and reject > 0):
        raise BadArgument(
            f"reject must be a positive number of robust standard deviations, got {reject!r}",
            argument="reject",
            value=reject,
        )
    if prior is not None and not isinstance(prior, Prior):
        raise BadArgument(
            f"prior must be a pincal.Prior (e.g. Prior.parse('1mm,1mrad')), got {prior!r}", argument="prior"
        )
    m, rows = sum(d.m for d in sessions), 3 * robot.n_markers
    if m * rows < len(params):
        raise SingularPlan(len(params), rows, m)

    coordinate_sigma, reference, per_point = _coordinate_sigma(sessions, sigma)
    problem = Problem(params, sessions, coordinate_sigma)
    z0 = initial_values(problem)
    before = problem.residual(z0)
    J0 = problem.jacobian(z0) / coordinate_sigma[:, None]
    always = list(problem.base) + list(range(len(params), len(problem)))
    order = (
        preference_order(params, frozenset(params.names[i] for i in problem.base))
        + always[len(problem.base) :]
    )
    check = check_information(problem.names, problem.units, J0.T @ J0, order, m, reference, always=always)
    prior_std = _prior_std(prior, params, len(problem))
    free = np.arange(len(problem)) if prior is not None else np.array(check.kept, dtype=int)
    dropped = {} if prior is not None else dict(check.dropped)
    labels = _labels(sessions)
    distinct = len(np.unique(np.concatenate([d.q for d in sessions]), axis=0))
    minimum = SingularPlan(len(params), rows, m).min_configurations
    if free.size == 0 or (check.dropped and distinct < minimum):
        why = (
            f"the data cannot identify the parameters: {distinct} distinct configuration(s) for "
            f"{len(params)} parameters (rank {check.rank}); measure more varied configurations (at "
            f"least {minimum} are needed)"
        )
        return _result(problem, check, z0, None, before, "rank_deficient", why, 0, sigma, reference)

    def fit(used: np.ndarray, fit_loss: str, z_start: np.ndarray) -> tuple[np.ndarray, int, bool, str]:
        return _solve(
            problem,
            free,
            used,
            z_start,
            prior_std,
            fit_loss,
            method,
            maxiter,
            tol,
            per_point or sigma is not None,
        )

    used = np.ones(m, dtype=bool)
    rejected: list[Outlier] = []
    if reject is not None:
        for _ in range(10):
            z_scoring, *_ = fit(used, "soft_l1" if loss == "linear" else loss, z0)
            if z_scoring is None:
                break
            distance, score = row_scores(problem.residual(z_scoring), coordinate_sigma, m)
            score[~used] = 0.0
            new = [i for i in np.argsort(-score) if score[i] > reject]
            if not new:
                break
            rejected += [Outlier(int(i), labels[i], float(distance[i]), float(score[i])) for i in new]
            used[new] = False
        if used.sum() * rows < free.size:
            raise SingularPlan(free.size, rows, int(used.sum()))
    z, iterations, converged, note = fit(used, loss, z0)
    if z is None:
        failed = f"identification {note}"
        return _result(
            problem, check, z0, None, before, "failed", failed, iterations, sigma, reference, dropped
        )
    residual = problem.residual(z)
    keep = np.repeat(used, residual.size // m)
    outliers = tuple(
        o for o in find_outliers(np.where(keep, residual, 0.0), coordinate_sigma, labels) if used[o.row]
    )
    before_rms = _rms(before.reshape(m, -1, 3)[used])
    after_rms = _rms(residual.reshape(m, -1, 3)[used])
    problems = implausible(params, z[: len(params)], before_rms, after_rms, reference) if sanity else []
    if not converged:  # an unfinished estimate is judged by its data only
        problems = [p for p in problems if "before calibration" in p]
    causes: tuple[str, ...] = ()
    if problems:
        status = "implausible"
        causes = tuple(likely_causes(problem, z, problems))
        message = (
            "no real robot has this: "
            + "; ".join(problems)
            + " (not a calibration; --force writes it anyway)"
        )
    elif converged:
        status = "converged"
        message = f"{iterations} Jacobian evaluation(s) of scipy least_squares ({method}, loss {loss})"
        if dropped:
            message += (
                f"; {len(dropped)} parameter(s) the data cannot identify left nominal: {', '.join(dropped)}"
            )
        message += _warnings(
            after_rms, residual[keep], coordinate_sigma[keep], per_point or sigma is not None, len(free)
        )
    else:
        status = "not_converged"
        message = (
            f"no convergence after {iterations} Jacobian evaluation(s) ({note}); the last estimate is "
            f"not a calibration: allow more iterations (maxiter, --maxiter)"
        )
    return _result(
        problem, check, z0, z, before, status, message, iterations, sigma, reference, dropped,
        free=free, used=used, outliers=outliers, rejected=tuple(rejected), loss=loss, prior=prior,
        prior_std=prior_std, causes=causes, method=method, per_point=per_point,
    )  # fmt: skip


def _prior_std(prior: Prior | None, params: ParameterSet, n: int) -> np.ndarray:
    """(n,) prior std of every unknown (inf: none); bases free unless the prior names them."""
    std = np.full(n, np.inf)
    if prior is None:
        return std
    std[: len(params)] = prior.std(params)
    named = set()
    for key in prior.overrides:
        named.update(params.select(key).names if any(p.kind == "base" for p in params) else ())
    for i, p in enumerate(params):
        if p.kind == "base" and p.name not in named:
            std[i] = np.inf
    return std


def _solve(
    problem: Problem,
    free: np.ndarray,
    used: np.ndarray,
    z0: np.ndarray,
    prior_std: np.ndarray,
    loss: str,
    method: str,
    maxiter: int,
    tol: float,
    sigma_known: bool,
    robust_scale: float | None = None,
) -> tuple[np.ndarray | None, int, bool, str]:
    """(estimate or None, Jacobian evaluations, converged, scipy's message) of least_squares."""
    from scipy.optimize import least_squares  # imported on first use (it is slow to import)

    keep = np.repeat(used, problem.measured.size // len(used))
    w = 1.0 / problem.sigma[keep]
    priors = np.flatnonzero(np.isfinite(prior_std[free]))
    inv_prior = 1.0 / prior_std[free][priors]

    def unknowns(zf: np.ndarray) -> np.ndarray:
        z = z0.copy()
        z[free] = zf
        return z

    def fun(zf: np.ndarray) -> np.ndarray:
        z = unknowns(zf)
        e = -problem.residual(z)[keep] * w
        return np.concatenate([e, zf[priors] * inv_prior])

    def jac(zf: np.ndarray) -> np.ndarray:
        J = problem.jacobian(unknowns(zf))[np.ix_(keep, free)] * w[:, None]
        P = np.zeros((priors.size, free.size))
        P[np.arange(priors.size), priors] = inv_prior
        return np.vstack([J, P])

    f_scale = 1.0
    if loss != "linear" and not sigma_known:
        # σ unknown: its robust estimate from a plain fit, then from the robust fit, until stable
        z_prev, loss_prev, scale = z0, "linear", None
        for _ in range(5):
            z_prev, *_ = _solve(
                problem, free, used, z_prev, prior_std, loss_prev, method, maxiter, tol, True, scale
            )
            if z_prev is None:
                break
            new_scale = max(robust_sigma(-problem.residual(z_prev)[keep] * w), 1e-12)
            if scale is not None and abs(new_scale - scale) < 0.05 * scale:
                break
            scale, loss_prev = new_scale, loss
        f_scale = ROBUST_SCALE * (scale or 1.0)
    elif loss != "linear":
        f_scale = ROBUST_SCALE * (1.0 if robust_scale is None else robust_scale)
    if method == "lm" and fun(z0[free]).size < free.size:
        method = "trf"
    try:
        solution = least_squares(
            fun,
            z0[free],
            jac=jac,
            method=method,
            loss=loss,
            f_scale=f_scale,
            x_scale="jac" if method == "lm" else ERROR_SCALE,
            xtol=min(tol, 1e-8) if method == "lm" else tol,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=int(maxiter),
        )
    except (ValueError, ArithmeticError, np.linalg.LinAlgError, PincalError) as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        return None, 0, False, f"failed: least_squares stopped on {text}"
    njev = int(solution.njev or solution.nfev or 0)
    if not np.all(np.isfinite(solution.x)):
        return None, njev, False, "failed: least_squares diverged"
    return unknowns(solution.x), njev, solution.status > 0, solution.message


def _result(
    problem: Problem,
    check: DataCheck,
    z0: np.ndarray,
    z: np.ndarray | None,
    before: np.ndarray,
    status: str,
    message: str,
    iterations: int,
    sigma: float | None,
    reference: float,
    dropped: dict[str, str] | None = None,
    *,
    free: np.ndarray | None = None,
    used: np.ndarray | None = None,
    outliers: tuple[Outlier, ...] = (),
    rejected: tuple[Outlier, ...] = (),
    loss: str = "linear",
    prior: Prior | None = None,
    prior_std: np.ndarray | None = None,
    causes: tuple[str, ...] = (),
    method: str = "trf",
    per_point: bool = False,
) -> IdentificationResult:
    params, sessions = problem.params, list(problem.sessions)
    n, m = len(params), sum(d.m for d in sessions)
    estimated = sigma is None and not per_point
    shape = (m, params.robot.n_markers, 3)
    if z is None:
        values, std, correlation = np.full(n, np.nan), np.full(n, np.nan), np.full((n, n), np.nan)
        robot, residuals = problem.robot(z0), before.reshape(shape)
        sigma_out = np.nan if estimated else reference
        z_final = z0
    else:
        values, robot = z[:n].copy(), problem.robot(z)
        residuals = problem.residual(z).reshape(shape)
        used = np.ones(m, dtype=bool) if used is None else used
        keep = np.repeat(used, 3 * params.robot.n_markers)
        dof = int(keep.sum()) - len(free)
        per_coordinate = float(np.sqrt(np.sum(residuals.reshape(-1)[keep] ** 2) / dof)) if dof > 0 else np.nan
        sigma_out = per_coordinate if estimated else reference
        std, correlation = _covariance(
            problem, z, free, keep, prior_std, per_coordinate if estimated and prior is None else None
        )
        z_final = z
    bases = tuple(problem.robot(z_final, s).base for s in range(len(sessions))) if problem.base else ()
    initial_bases = tuple(problem.robot(z0, s).base for s in range(len(sessions))) if problem.base else ()
    for array in (values, std, correlation, residuals):
        array.flags.writeable = False
    before = before.reshape(shape)
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
        iterations=iterations,
        status=status,
        message=message,
        method=method,
        robot=robot,
        data=_stacked(sessions),
        check=check,
        dropped=dict(dropped or {}),
        outliers=outliers,
        rejected=rejected,
        loss=loss,
        prior=prior,
        causes=causes,
        sessions=tuple(sessions),
        bases=bases,
        initial_robot=problem.robot(z0),
        initial_bases=initial_bases,
    )


def _covariance(
    problem: Problem,
    z: np.ndarray,
    free: np.ndarray,
    keep: np.ndarray,
    prior_std: np.ndarray,
    scale_to: float | None,
) -> tuple[np.ndarray, np.ndarray]:
    """(std, correlation) of the parameters: (JᵀWJ + Σp⁻¹)⁻¹ over the free unknowns, scaled to
    σ̂² when σ is estimated; NaN for the parameters left out."""
    n = len(problem.params)
    J = problem.jacobian(z)[np.ix_(keep, free)] / problem.sigma[keep, None]
    M = J.T @ J + np.diag(np.where(np.isfinite(prior_std[free]), 1.0 / prior_std[free] ** 2, 0.0))
    d = np.sqrt(np.diag(M))
    d[d == 0] = 1.0
    std, correlation = np.full(n, np.nan), np.full((n, n), np.nan)
    try:
        cov = np.linalg.inv(M / np.outer(d, d)) / np.outer(d, d)
    except np.linalg.LinAlgError:
        return std, correlation
    if scale_to is not None:
        cov = cov * (scale_to / np.median(problem.sigma)) ** 2
    inside = free < n
    idx = free[inside]
    sub = cov[np.ix_(inside, inside)]
    std[idx] = np.sqrt(np.clip(np.diag(sub), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        correlation[np.ix_(idx, idx)] = sub / np.outer(std[idx], std[idx])
    return std, correlation


def _warnings(rms: float, r: np.ndarray, sigma: np.ndarray, known: bool, n_free: int) -> str:
    """What a converged fit's residuals say about the data, as a message suffix."""
    dof = r.size - n_free
    if dof <= 0:
        return "; as many parameters as measured coordinates: no residual degrees of freedom"
    chi = float(np.sqrt(np.sum((r / sigma) ** 2) / dof))
    if rms > POOR_FIT:
        return (
            f"; but the residuals stay at {rms * 1e3:.3g} mm RMS, more than geometric errors explain: "
            f"non-geometric errors (compliance, gear errors) or parameters missing from the set"
        )
    if known and chi > 3:
        return (
            f"; the residuals are {chi:.3g} times the instrument's sigma per coordinate: the data "
            f"hold errors the model does not"
        )
    return ""
