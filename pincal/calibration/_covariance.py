"""The covariance of an identification's estimates: (JᵀWJ + Σp⁻¹)⁻¹ over the free unknowns and the
rows used, as standard errors and correlations."""

from __future__ import annotations

import numpy as np

from pincal.calibration.state import Setup


def covariance(
    setup: Setup, z: np.ndarray, used: np.ndarray, scale_to: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """(std, correlation) of the unknowns (the parameters, then the bases of sessions after the
    first: ``problem.names``): (JᵀWJ + Σp⁻¹)⁻¹ over the free unknowns and the rows used, scaled to
    σ̂² = ``scale_to``² when σ is estimated; NaN for the unknowns left out."""
    problem, free, prior_std = setup.problem, setup.free, setup.prior_std
    n = len(problem.names)
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
