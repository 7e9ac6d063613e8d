"""Identification: the geometric errors that best explain measurements (docs/method.md §5).

The unknowns x are the values of a :class:`~pincal.ParameterSet`: the *total* errors of the real
robot relative to the set's (nominal) robot, in the parameter conventions (docs/method.md §2), so the
calibrated robot is ``params.apply(x)``. Weighted least squares over all configurations, markers
and sessions,

    x̂ = argmin Σᵢ ρ(‖(pᵢ − g(qᵢ, Π0 ⊕ x)) / σᵢ‖²)  [+ ‖x / σ_prior‖² with a prior],

solved by ``scipy.optimize.least_squares`` (``trf``, or ``lm`` without a robust loss) with the
analytic Jacobian (:mod:`pincal.calibration.problem`, :mod:`pincal.calibration.solver`). σᵢ is
the per-point uncertainty of the data when they have one, else σ (:mod:`pincal.calibration.noise`).
Robust losses (``huber``, ``soft_l1``, ``cauchy``) take ``f_scale`` = :data:`ROBUST_SCALE`
standard deviations: σ when it is known (given or per point), else a robust estimate
(1.4826·median|r|) from a plain least-squares fit.

The steps, each reported:

1. **Data identifiability** (:mod:`pincal.evaluation.data_check`): rank and conditioning of *these*
   configurations, the weakest combinations, and the subset
   the data determine to better than 1 cm / 10 mrad; the others stay at their nominal value, named
   with the reason. With a :class:`~pincal.Prior` nothing is dropped: the fit is the MAP estimate.
2. **Fit**, from zero errors except each session's base, from a rigid fit (Kabsch) of the nominal
   points onto the measured ones when ``base.*`` is identified. The "before" residual is the
   residual there (after the rigid fit), not at a base at the identity.
3. **Outliers**: rows above :data:`~pincal.calibration.sanity.OUTLIER_SCORE` robust σ are named
   by file and line; with ``reject=K`` the rows above K robust σ (scored on a ``soft_l1`` fit, by
   ``trf`` whatever the method) are dropped and the fit repeated until none is left.
4. **Sanity** (:mod:`pincal.calibration.sanity`): a fit with values or residuals no real robot has
   is ``implausible``, never ``converged``; its message names the likely causes (``causes``).

Standard errors: cov(x̂) = (JᵀWJ + Σp⁻¹)⁻¹ at the solution; without per-point σ and without a
given σ, scaled by σ̂² = Σ residual² / (N − P) (σ estimated from the residuals).

Each step is a function of the frozen values of :mod:`pincal.calibration.state` (the settings, the
setup, the rows, the solver's solution, the verdict) and returns a new one;
:func:`~pincal.calibration.result.identification_result` builds the result from them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from pincal.arguments import positive_int, positive_sigma, ratio
from pincal.calibration.assembly import distance_unit, identification_result, residual_rms
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.noise import Noise
from pincal.calibration.problem import Problem, initial_values
from pincal.calibration.result import IdentificationResult
from pincal.calibration.sanity import (
    Outlier,
    find_outliers,
    implausible,
    implausible_noise,
    likely_causes,
    row_scores,
)
from pincal.calibration.solver import ERROR_SCALE, ROBUST_SCALE, solve
from pincal.calibration.state import Rows, Settings, Setup, Solution, Verdict
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, BadMeasurementData, SingularPlan
from pincal.evaluation.data_check import DataCheck, check_parameters
from pincal.evaluation.prior import Prior
from pincal.instruments.given import error_model_of, takes_instrument_of_data
from pincal.instruments.instrument import Instrument
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot
from pincal.typing import SeedLike

__all__ = [
    "ERROR_SCALE",
    "LOSSES",
    "METHODS",
    "POOR_FIT",
    "ROBUST_SCALE",
    "STATUSES",
    "IdentificationResult",
    "identify",
]

SYMPTOMS = 3
"""An implausible result's message names its likely causes first, then this many of its symptoms."""

STATUSES = ("converged", "implausible", "rank_deficient", "not_converged", "failed")
"""Values of :attr:`IdentificationResult.status`; only ``"converged"`` gives a calibrated robot."""

LOSSES = ("linear", "huber", "soft_l1", "cauchy")
METHODS = ("trf", "lm")

POOR_FIT = 1e-3
"""Residual RMS [m] after calibration above which the result's message warns that geometric
errors do not explain the data (non-geometric errors, a model that is too small)."""


@keywords_after(2)
@takes_instrument_of_data
def identify(
    params: ParameterSet,
    data: MeasurementData | Sequence[MeasurementData],
    *,
    sigma: float | None = None,
    maxiter: int = 100,
    tol: float = 1e-10,
    prior: Prior | None = None,
    loss: str = "linear",
    method: str = "trf",
    reject: float | None = None,
    sanity: bool = True,
    residual_model: str | None = None,
    instrument: Instrument | None = None,
    progress: bool = False,
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
            for the standard errors, and :data:`~pincal.arguments.DEFAULT_SIGMA` for the checks. Data with
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
        residual_model: ``"gp"``: after a converged fit, model what it leaves as a Gaussian
            process over joint space (:mod:`pincal.model.residual`, docs/method.md §11.5),
            hyperparameters by marginal likelihood on these data only (the rows kept); the
            result's :meth:`~IdentificationResult.predict` adds its mean. None: no residual model.
            Beyond 500 configurations it is approximate (FITC through 1 500 inducing
            configurations; :class:`~pincal.model.residual.Approximation`).
        instrument: what the data measure and how well (:class:`pincal.instruments.Instrument`,
            of the data's kind): its error model (``PerCoordinate``, ``Tracker``) weighs data
            without uncertainty columns (a tracker's at each point) and makes σ known; not with
            ``sigma``. Default ``sigma`` per length and pincal's default σ of angles and pixels.
        progress: report the residual model's fit on stderr (a bar on a terminal, else a line
            every few seconds).

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
    sessions = _sessions(data, params.robot)
    settings = _settings(
        sigma, maxiter, tol, prior=prior, loss=loss, method=method, reject=reject, sanity=sanity
    )
    if residual_model is not None and residual_model not in RESIDUAL_MODELS:
        raise BadArgument(
            f"unknown residual model {residual_model!r}; valid: {', '.join(RESIDUAL_MODELS)} (or None)",
            argument="residual_model",
            value=residual_model,
            valid=RESIDUAL_MODELS,
        )
    if residual_model is not None and not sessions[0].is_points:
        raise BadArgument(
            f"the residual model is fitted to points; these data measure {sessions[0].measure.name}",
            argument="residual_model",
        )
    settings = replace(
        settings, instrument=error_model_of(instrument, sigma, sessions[0].measure, params.robot)
    )
    m, per_row = sum(d.m for d in sessions), sessions[0].row_size
    if m * per_row < len(params):
        raise SingularPlan(len(params), per_row, m)
    if all(np.isnan(d.points).all() for d in sessions):  # images that see no target point at all
        raise BadMeasurementData(
            f"the measurements hold no measured value: none of the {m} images sees a target point (every "
            "pixel cell is empty); check where the camera and the target are (--camera) against the plan"
        )
    setup = _setup(_problem(params, sessions, settings), settings)
    why = _rank_deficiency(setup)
    if why is not None:
        return identification_result(setup, None, Rows.every(m), Verdict("rank_deficient", why))
    chosen = _reject_outliers(setup)
    solution = solve(setup, chosen.used, setup.z0, settings.loss)
    if solution.z is None:
        return identification_result(
            setup, solution, chosen, Verdict("failed", f"identification {solution.note}")
        )
    chosen = replace(chosen, outliers=_outliers(setup, solution.z, chosen.used))
    result = identification_result(setup, solution, chosen, _verdict(setup, solution, chosen))
    if residual_model is None or not result.success:
        return result
    return replace(result, residual_model=fit_residual_model(result, progress=progress))


RESIDUAL_MODELS = ("gp",)
"""The residual models ``identify(residual_model=...)`` fits."""


def fit_residual_model(
    result: IdentificationResult, seed: SeedLike = 0, *, progress: bool = False
) -> ResidualModel:
    """The Gaussian process of ``result``'s residuals at the rows it kept, each session's residual
    rotated into the robot's base frame (so that one model serves every instrument placement);
    ``progress`` on stderr."""
    used = np.ones(result.data.m, dtype=bool)
    used[[o.row for o in result.rejected]] = False
    starts = np.cumsum([0] + [d.m for d in result.sessions])
    rotations = [b.rotation for b in result.bases] or [result.robot.base.rotation] * len(result.sessions)
    residuals = np.concatenate(
        [result.residuals[a:b] @ R for a, b, R in zip(starts[:-1], starts[1:], rotations)]
    )
    return ResidualModel.fit(
        result.data.q[used],
        residuals[used].reshape(int(used.sum()), -1),
        result.robot.revolute,
        seed=seed,
        progress=progress,
    )


def _problem(params: ParameterSet, sessions: list[MeasurementData], settings: Settings) -> Problem:
    """The problem, its noise from the data or the error model: an error model that depends on where
    a point is (a tracker's) is taken where each session's start puts the points (its base fitted)."""
    error, S = settings.instrument, len(sessions)
    problem = Problem(params, sessions, Noise.of(sessions, settings.sigma, error, [params.robot] * S))
    if error is None or error.direction_free or not problem.base:
        return problem
    z0 = initial_values(problem)
    robots = [problem.robot(z0, s) for s in range(S)]
    return Problem(params, sessions, Noise.of(sessions, settings.sigma, error, robots))


def _sessions(data: MeasurementData | Sequence[MeasurementData], robot: Robot) -> list[MeasurementData]:
    items = [data] if isinstance(data, MeasurementData) else data
    if not isinstance(items, Sequence) or not items or not all(isinstance(d, MeasurementData) for d in items):
        raise BadMeasurementData(
            f"identify needs a MeasurementData or a list of them (one per session), got {type(data).__name__}"
        )
    return [d.for_robot(robot) for d in items]


def _settings(
    sigma: float | None,
    maxiter: int,
    tol: float,
    *,
    prior: Prior | None,
    loss: str,
    method: str,
    reject: float | None,
    sanity: bool,
) -> Settings:
    """The arguments of :func:`identify`, checked (a bad one named, with the valid values)."""
    sigma = None if sigma is None else positive_sigma(sigma)
    maxiter = positive_int(maxiter, "maxiter")
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
    if reject is not None:
        ratio(reject, "reject (robust standard deviations)")
    if prior is not None and not isinstance(prior, Prior):
        raise BadArgument(
            f"prior must be a pincal.Prior (e.g. Prior.parse('1mm,1mrad')), got {prior!r}", argument="prior"
        )
    return Settings(sigma, maxiter, tol, loss, method, reject, prior, sanity)


def _setup(problem: Problem, settings: Settings) -> Setup:
    """Steps 1 and 2: the start of the fit, what the data determine there, what the fit moves."""
    z0 = initial_values(problem)
    check = _data_check(problem, z0)
    if settings.prior is not None:  # MAP: every unknown moves
        free, dropped = np.arange(len(problem)), {}
    else:
        free, dropped = np.array(check.kept, dtype=int), dict(check.dropped)
    prior_std = _prior_std(settings.prior, problem.params, len(problem))
    return Setup(problem, settings, z0, problem.residual(z0), check, free, prior_std, dropped)


def _data_check(problem: Problem, z0: np.ndarray) -> DataCheck:
    """Step 1: what the data determine, at the start of the fit (the bases of every session always
    kept, the parameters in their order of preference)."""
    params = problem.params
    J0 = problem.noise.whiten(problem.jacobian(z0))
    extra = dict(zip(problem.names[len(params) :], problem.units[len(params) :], strict=True))
    return check_parameters(params, J0.T @ J0, problem.m, problem.noise.reference, extra)


def _rank_deficiency(setup: Setup) -> str | None:
    """Why the data cannot identify the parameters at all (None when they can)."""
    problem, check = setup.problem, setup.check
    params, m = problem.params, problem.m
    rows = problem.noise.row_size
    distinct = len(np.unique(np.concatenate([d.q for d in problem.sessions]), axis=0))
    minimum = SingularPlan(len(params), rows, m).min_configurations
    if setup.free.size == 0 or (check.dropped and distinct < minimum):
        return (
            f"the data cannot identify the parameters: {distinct} distinct configuration(s) for "
            f"{len(params)} parameters (rank {check.rank}); measure more varied configurations (at "
            f"least {minimum} are needed)"
        )
    return None


def _reject_outliers(setup: Setup) -> Rows:
    """Step 3: the rows the final fit uses; with ``reject``, the rows beyond ``reject`` robust σ of
    a robust fit are dropped and the fit repeated (at most 10 times) until none is left."""
    problem, reject, loss = setup.problem, setup.settings.reject, setup.settings.loss
    m, rows = problem.m, problem.noise.row_size
    used = np.ones(m, dtype=bool)
    rejected: list[Outlier] = []
    if reject is None:
        return Rows(used)
    free = setup.free
    for _ in range(10):
        z_scoring = solve(setup, used, setup.z0, "soft_l1" if loss == "linear" else loss).z
        if z_scoring is None:
            break
        distance, score = row_scores(problem.residual(z_scoring), problem.noise, problem.blocks)
        score[~used] = 0.0
        new = [i for i in np.argsort(-score) if score[i] > reject]
        if not new:
            break
        unit = distance_unit(problem)
        rejected += [
            Outlier(int(i), problem.labels[i], float(distance[i]), float(score[i]), unit) for i in new
        ]
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
    return Rows(used, tuple(rejected))


def _outliers(setup: Setup, z: np.ndarray, used: np.ndarray) -> tuple[Outlier, ...]:
    """The suspicious rows among those the fit at ``z`` used, worst first."""
    problem = setup.problem
    keep = problem.noise.coordinates(used)
    found = find_outliers(
        np.where(keep, problem.residual(z), 0.0),
        problem.noise,
        problem.labels,
        blocks=problem.blocks,
        unit=distance_unit(problem),
    )
    return tuple(o for o in found if used[o.row])


def _verdict(setup: Setup, solution: Solution, rows: Rows) -> Verdict:
    """Step 4: the verdict on a finished fit. What no real robot has makes it implausible, converged
    or not (an unfinished estimate is judged by its data only); a converged fit's message says what
    its residuals say about the data."""
    problem, settings, z = setup.problem, setup.settings, solution.z
    assert z is not None  # a finished fit (identify returns before when it failed)
    used = rows.used
    residual = problem.residual(z)
    after_rms = residual_rms(problem, residual, used)
    problems = _implausible(setup, z, residual, used) if settings.sanity else []
    if not solution.converged:
        problems = [p for p in problems if "before calibration" in p]
    if problems:
        conditioning = setup.check.conditioning if setup.check is not None else float("nan")
        found = _outliers(setup, z, used)
        causes = tuple(likely_causes(problem, z, problems, conditioning, found))
        shown = problems[:SYMPTOMS] + (
            [f"and {len(problems) - SYMPTOMS} more"] if len(problems) > SYMPTOMS else []
        )
        message = (
            ("likely cause: " if len(causes) == 1 else "likely causes: ")
            + "; ".join(causes)
            + " — no real robot has this: "
            + "; ".join(shown)
            + " (not a calibration; --force writes it anyway)"
        )
        return Verdict("implausible", message, causes)
    if solution.converged:
        message = (
            f"{solution.iterations} Jacobian evaluation(s) of scipy least_squares ({settings.method}, "
            f"loss {settings.loss})"
        )
        if setup.dropped:
            message += (
                f"; {len(setup.dropped)} parameter(s) the data cannot identify left nominal: "
                f"{', '.join(setup.dropped)}"
            )
        return Verdict("converged", message + _quality(setup, residual, used, after_rms))
    message = (
        f"no convergence after {solution.iterations} Jacobian evaluation(s) ({solution.note}); the last "
        f"estimate is not a calibration: allow more iterations (maxiter, --maxiter)"
    )
    return Verdict("not_converged", message)


def _implausible(setup: Setup, z: np.ndarray, residual: np.ndarray, used: np.ndarray) -> list[str]:
    """What no real robot has in a fit at ``z`` (see :func:`~pincal.calibration.sanity.implausible`)."""
    problem, params = setup.problem, setup.problem.params
    if problem.points:
        before, after = residual_rms(problem, setup.before, used), residual_rms(problem, residual, used)
        return implausible(params, z[: len(params)], before, after, problem.noise.reference)
    noise, keep = problem.noise, problem.noise.coordinates(used)
    count = max(noise.count(used), 1)
    before, after = (
        float(np.sqrt(np.sum(noise.whiten(r[keep], used) ** 2) / count)) for r in (setup.before, residual)
    )
    geometry = implausible(params, z[: len(params)], 0.0, 0.0, problem.noise.reference)
    return geometry + implausible_noise(before, after)


def _quality(setup: Setup, residual: np.ndarray, used: np.ndarray, rms: float) -> str:
    """What a converged fit's residuals (RMS ``rms`` [m] over the rows used) say about the data, as
    a message suffix."""
    noise = setup.problem.noise
    r = residual[noise.coordinates(used)]
    dof = noise.count(used) - len(setup.free)
    if dof <= 0:
        return "; as many parameters as measured coordinates: no residual degrees of freedom"
    chi = float(np.sqrt(np.sum(noise.whiten(r, used) ** 2) / dof))
    if setup.problem.points and rms > POOR_FIT:
        return (
            f"; but the residuals stay at {rms * 1e3:.3g} mm RMS, more than geometric errors explain: "
            f"non-geometric errors (compliance, gear errors) or parameters missing from the set"
        )
    if noise.known and chi > 3:
        return (
            f"; the residuals are {chi:.3g} times the instrument's sigma per coordinate: the data "
            f"hold errors the model does not"
        )
    return ""


def _prior_std(prior: Prior | None, params: ParameterSet, n: int) -> np.ndarray:
    """(n,) prior std of every unknown (inf: none); bases free unless the prior names them."""
    std = np.full(n, np.inf)
    if prior is None:
        return std
    std[: len(params)] = prior.std(params)
    named: set[str] = set()
    for key in prior.overrides:
        named.update(params.select(key).names if any(p.kind == "base" for p in params) else ())
    for i, p in enumerate(params):
        if p.kind == "base" and p.name not in named:
            std[i] = np.inf
    return std
