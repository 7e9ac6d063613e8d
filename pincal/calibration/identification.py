"""Identification: the geometric errors that best explain measurements (docs/method.md §5).

The unknowns x are the values of a :class:`~pincal.ParameterSet`: the *total* errors of the real
robot relative to the set's (nominal) robot, in the parameter conventions (docs/method.md §2), so the
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
   by file and line; with ``reject=K`` the rows above K robust σ (scored on a ``soft_l1`` fit, by
   ``trf`` whatever the method) are dropped and the fit repeated until none is left.
4. **Sanity** (:mod:`pincal.calibration.sanity`): a fit with values or residuals no real robot has
   is ``implausible``, with its likely causes, never ``converged``.

Standard errors: cov(x̂) = (JᵀWJ + Σp⁻¹)⁻¹ at the solution; without per-point σ and without a
given σ, scaled by σ̂² = Σ residual² / (N − P) (σ estimated from the residuals).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, positive_int, positive_sigma
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.problem import Problem, initial_values
from pincal.calibration.result import IdentificationResult, _result, _rms, _warnings
from pincal.calibration.sanity import (
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

LOSSES = ("linear", "huber", "soft_l1", "cauchy")
METHODS = ("trf", "lm")
ROBUST_SCALE = 2.0
"""``f_scale`` of a robust loss, in standard deviations of the whitened residuals."""

ERROR_SCALE = 1e-3
"""Typical size of a geometric error [m or rad]: trf's variable scale, so that its first trust
region (radius 1 in scaled variables) holds a step of the size real errors have."""


def _sessions(data: object, robot: Robot) -> list[MeasurementData]:
    items = [data] if isinstance(data, MeasurementData) else data
    if not isinstance(items, Sequence) or not items or not all(isinstance(d, MeasurementData) for d in items):
        raise BadMeasurementData(
            f"identify needs a MeasurementData or a list of them (one per session), got {type(data).__name__}"
        )
    return [d.for_robot(robot) for d in items]


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
    sigma = _checked_arguments(sigma, maxiter, loss, method, reject, prior)
    m, rows = sum(d.m for d in sessions), 3 * robot.n_markers
    if m * rows < len(params):
        raise SingularPlan(len(params), rows, m)

    coordinate_sigma, reference, per_point = _coordinate_sigma(sessions, sigma)
    sigma_known = per_point or sigma is not None
    problem = Problem(params, sessions, coordinate_sigma)
    z0 = initial_values(problem)
    before = problem.residual(z0)
    check = _data_check(problem, z0, m, reference)
    prior_std = _prior_std(prior, params, len(problem))
    free = np.arange(len(problem)) if prior is not None else np.array(check.kept, dtype=int)
    dropped = {} if prior is not None else dict(check.dropped)
    labels = _labels(sessions)
    why = _rank_deficiency(problem, check, free, m)
    asked = dict(loss=loss, prior=prior, method=method, per_point=per_point)
    if why is not None:
        return _result(problem, check, z0, None, before, "rank_deficient", why, 0, sigma, reference, **asked)

    def fit(used: np.ndarray, fit_loss: str, z_start: np.ndarray) -> tuple[np.ndarray, int, bool, str]:
        how = method if fit_loss == "linear" else "trf"  # lm takes the linear loss only
        return _solve(problem, free, used, z_start, prior_std, fit_loss, how, maxiter, tol, sigma_known)

    used, rejected = _reject_outliers(problem, fit, z0, labels, free, loss, reject)
    z, iterations, converged, note = fit(used, loss, z0)
    if z is None:
        failed = f"identification {note}"
        return _result(
            problem, check, z0, None, before, "failed", failed, iterations, sigma, reference, dropped,
            rejected=tuple(rejected), **asked,
        )  # fmt: skip
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
    status, message, causes = _verdict(
        problem, z, problems, converged, iterations, note, method, loss, dropped,
        quality=lambda: _warnings(after_rms, residual[keep], coordinate_sigma[keep], sigma_known, len(free)),
    )  # fmt: skip
    return _result(
        problem, check, z0, z, before, status, message, iterations, sigma, reference, dropped,
        free=free, used=used, outliers=outliers, rejected=tuple(rejected), prior_std=prior_std,
        causes=causes, **asked,
    )  # fmt: skip


def _checked_arguments(
    sigma: float | None, maxiter: int, loss: str, method: str, reject: float | None, prior: Prior | None
) -> float | None:
    """``sigma`` checked (None stays None), after refusing any bad solver argument (named)."""
    sigma = None if sigma is None else positive_sigma(sigma)
    positive_int(maxiter, "maxiter")
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
    return sigma


def _data_check(problem: Problem, z0: np.ndarray, m: int, reference: float) -> DataCheck:
    """Step 1: what the data determine, at the start of the fit (bases and session unknowns always
    kept, the rest in the parameters' order of preference)."""
    params = problem.params
    J0 = problem.jacobian(z0) / problem.sigma[:, None]
    always = list(problem.base) + list(range(len(params), len(problem)))
    order = (
        preference_order(params, frozenset(params.names[i] for i in problem.base))
        + always[len(problem.base) :]
    )
    return check_information(problem.names, problem.units, J0.T @ J0, order, m, reference, always=always)


def _rank_deficiency(problem: Problem, check: DataCheck, free: np.ndarray, m: int) -> str | None:
    """Why the data cannot identify the parameters at all (None when they can)."""
    params, sessions = problem.params, problem.sessions
    rows = 3 * params.robot.n_markers
    distinct = len(np.unique(np.concatenate([d.q for d in sessions]), axis=0))
    minimum = SingularPlan(len(params), rows, m).min_configurations
    if free.size == 0 or (check.dropped and distinct < minimum):
        return (
            f"the data cannot identify the parameters: {distinct} distinct configuration(s) for "
            f"{len(params)} parameters (rank {check.rank}); measure more varied configurations (at "
            f"least {minimum} are needed)"
        )
    return None


def _reject_outliers(
    problem: Problem,
    fit: Callable[[np.ndarray, str, np.ndarray], tuple[np.ndarray | None, int, bool, str]],
    z0: np.ndarray,
    labels: list[str],
    free: np.ndarray,
    loss: str,
    reject: float | None,
) -> tuple[np.ndarray, list[Outlier]]:
    """Step 3: (rows used, rows rejected in order): with ``reject``, the rows beyond ``reject``
    robust σ of a robust fit are dropped and the fit repeated (at most 10 times) until none is left."""
    m, rows = len(labels), 3 * problem.params.robot.n_markers
    used = np.ones(m, dtype=bool)
    rejected: list[Outlier] = []
    if reject is None:
        return used, rejected
    for _ in range(10):
        z_scoring, *_ = fit(used, "soft_l1" if loss == "linear" else loss, z0)
        if z_scoring is None:
            break
        distance, score = row_scores(problem.residual(z_scoring), problem.sigma, m)
        score[~used] = 0.0
        new = [i for i in np.argsort(-score) if score[i] > reject]
        if not new:
            break
        rejected += [Outlier(int(i), labels[i], float(distance[i]), float(score[i])) for i in new]
        used[new] = False
        if used.sum() * rows < free.size:  # too few rows left to fit (or none: nothing to score)
            break
    if used.sum() * rows < free.size:
        left, needed = int(used.sum()), -(-free.size // rows)
        why = (
            f"reject {reject:g} dropped {len(rejected)} of the {m} configurations as outliers (beyond "
            f"{reject:g} robust sigma): the {left} left give {left * rows} measured coordinates for "
            f"{free.size} parameters (at least {needed} configurations are needed); give a larger "
            "reject (3 to 5 is usual), or check the data"
        )
        raise SingularPlan(free.size, rows, left, why=why)
    return used, rejected


def _verdict(
    problem: Problem,
    z: np.ndarray,
    problems: list[str],
    converged: bool,
    iterations: int,
    note: str,
    method: str,
    loss: str,
    dropped: dict[str, str],
    quality: Callable[[], str],
) -> tuple[str, str, tuple[str, ...]]:
    """Step 4: (status, message, likely causes) of a finished fit; ``problems`` (what no real robot
    has) make it implausible, converged or not; ``quality`` is what a converged fit's residuals say."""
    if problems:
        message = (
            "no real robot has this: "
            + "; ".join(problems)
            + " (not a calibration; --force writes it anyway)"
        )
        return "implausible", message, tuple(likely_causes(problem, z, problems))
    if converged:
        message = f"{iterations} Jacobian evaluation(s) of scipy least_squares ({method}, loss {loss})"
        if dropped:
            message += (
                f"; {len(dropped)} parameter(s) the data cannot identify left nominal: {', '.join(dropped)}"
            )
        return "converged", message + quality(), ()
    message = (
        f"no convergence after {iterations} Jacobian evaluation(s) ({note}); the last estimate is "
        f"not a calibration: allow more iterations (maxiter, --maxiter)"
    )
    return "not_converged", message, ()


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
