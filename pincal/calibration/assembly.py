"""The result of an identification assembled from its state (:func:`identification_result`: the
setup, the solver's solution, the rows and the verdict), with the residuals' RMS and the σ they
estimate. The covariance of the estimates is :mod:`._covariance`'s, the sessions stacked
:mod:`._sessions`'."""

from __future__ import annotations

import numpy as np

from pincal.calibration._covariance import covariance
from pincal.calibration._sessions import stacked
from pincal.calibration.problem import Problem
from pincal.calibration.result import IdentificationResult, rms
from pincal.calibration.state import Rows, Setup, Solution, Verdict


def residual_rms(problem: Problem, residual: np.ndarray, used: np.ndarray) -> float:
    """The RMS of a stacked (N,) residual over the rows ``used``: of the points' distances [m]; for
    another kind, of its whitened values times the reference σ (a length on the noise's scale)."""
    if problem.points:
        return rms(residual.reshape(problem.m, -1, 3)[used])
    noise = problem.noise
    e = noise.whiten(residual[noise.coordinates(used)], used)
    return float(noise.reference * np.sqrt(np.sum(e**2) / max(noise.count(used), 1)))


def distance_unit(problem: Problem) -> str:
    """The unit of the outliers' distances: ``m``, or the first value's unit of a kind without lengths."""
    return "m" if problem.points or "m" in problem.value_units else problem.value_units[0]


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
        later: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
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
        std, correlation = covariance(
            setup, z, rows.used, per_coordinate if estimated and settings.prior is None else None
        )
        later = _session_estimates(problem, z, std, correlation)
        std, correlation = std[:n].copy(), correlation[:n, :n].copy()
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
        data=stacked(sessions),
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
        session_estimates=later,
    )


def _session_estimates(
    problem: Problem, z: np.ndarray, std: np.ndarray, correlation: np.ndarray
) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """(x_s, C_s) for each session after the first: the parameter values it uses (its own base's)
    and their covariance, from the (std, correlation) of every unknown (its base's block in place
    of the first session's)."""
    n, nb = len(problem.params), len(problem.base)
    if not nb or len(problem.sessions) < 2:
        return ()
    full = correlation * np.outer(std, std)
    out = []
    for s in range(1, len(problem.sessions)):
        index = np.arange(n)
        index[problem.base] = n + (s - 1) * nb + np.arange(nb)
        x, C = problem.session_values(z, s), full[np.ix_(index, index)]
        x.flags.writeable = C.flags.writeable = False
        out.append((x, C))
    return tuple(out)


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
