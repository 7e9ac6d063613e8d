"""The least-squares stage of identification: one run of ``scipy.optimize.least_squares``.

It minimises the whitened residuals of the rows used (:class:`~pincal.calibration.noise.Noise`)
over the free unknowns, the others held at their start, with the prior as pseudo-residuals x/σp,
and the analytic Jacobian of :class:`~pincal.calibration.problem.Problem`. A robust loss (``huber``,
``soft_l1``, ``cauchy``) is solved by ``trf`` with ``f_scale`` = :data:`ROBUST_SCALE` standard
deviations: σ when it is known, else the robust scale of the residuals of a plain fit, then of the
robust fit, until it settles.
"""

from __future__ import annotations

import numpy as np

from pincal.calibration.sanity import robust_scale
from pincal.calibration.state import Setup, Solution
from pincal.errors import PincalError

ROBUST_SCALE = 2.0
"""``f_scale`` of a robust loss, in standard deviations of the whitened residuals."""

ERROR_SCALE = 1e-3
"""Typical size of a geometric error [m or rad]: trf's variable scale, so that its first trust
region (radius 1 in scaled variables) holds a step of the size real errors have."""


def solve(setup: Setup, used: np.ndarray, z_start: np.ndarray, loss: str) -> Solution:
    """The least-squares fit of the rows ``used`` ((m,) mask) with ``loss``, from ``z_start``
    (its values of the unknowns not free are kept): the settings' method for the linear loss,
    ``trf`` for a robust one."""
    if loss == "linear":
        return _run(setup, used, z_start, loss, 1.0, setup.settings.method)
    if setup.problem.noise.known:
        return _run(setup, used, z_start, loss, ROBUST_SCALE, "trf")
    scale = _robust_scale(setup, used, z_start, loss)
    return _run(setup, used, z_start, loss, ROBUST_SCALE * (scale or 1.0), "trf")


def _robust_scale(setup: Setup, used: np.ndarray, z_start: np.ndarray, loss: str) -> float | None:
    """σ unknown: the robust scale (:func:`~pincal.calibration.sanity.robust_scale`) of the whitened
    residuals (in units of the reference σ) of a plain fit, then of the robust fit with that scale,
    until it changes by less than 5 % (at most 5 fits); None when the first fit fails."""
    whitened = setup.problem.noise.whitening(used)
    keep = setup.problem.noise.coordinates(used)
    z: np.ndarray | None = z_start
    fit_loss, scale = "linear", None
    for _ in range(5):
        f_scale = 1.0 if fit_loss == "linear" or scale is None else ROBUST_SCALE * scale
        z = _run(setup, used, z, fit_loss, f_scale, "trf").z if z is not None else None
        if z is None:
            break
        new_scale = robust_scale(whitened(-setup.problem.residual(z)[keep]))
        if scale is not None and abs(new_scale - scale) < 0.05 * scale:
            break
        scale, fit_loss = new_scale, loss
    return scale


def _run(
    setup: Setup, used: np.ndarray, z_start: np.ndarray, loss: str, f_scale: float, method: str
) -> Solution:
    """One call of least_squares (see :func:`solve`); ``lm`` gives way to ``trf`` when there are
    fewer residuals than free unknowns."""
    from scipy.optimize import least_squares  # imported on first use (it is slow to import)

    problem, settings, free = setup.problem, setup.settings, setup.free
    keep = problem.noise.coordinates(used)
    whitened = problem.noise.whitening(used)
    priors = np.flatnonzero(np.isfinite(setup.prior_std[free]))
    inv_prior = 1.0 / setup.prior_std[free][priors]

    def unknowns(zf: np.ndarray) -> np.ndarray:
        z = z_start.copy()
        z[free] = zf
        return z

    def fun(zf: np.ndarray) -> np.ndarray:
        e = whitened(-problem.residual(unknowns(zf))[keep])
        return np.concatenate([e, zf[priors] * inv_prior])

    def jac(zf: np.ndarray) -> np.ndarray:
        J = whitened(problem.jacobian(unknowns(zf))[np.ix_(keep, free)])
        P = np.zeros((priors.size, free.size))
        P[np.arange(priors.size), priors] = inv_prior
        return np.vstack([J, P])

    if method == "lm" and fun(z_start[free]).size < free.size:
        method = "trf"
    try:
        solution = least_squares(
            fun,
            z_start[free],
            jac=jac,
            method=method,
            loss=loss,
            f_scale=f_scale,
            x_scale="jac" if method == "lm" else ERROR_SCALE,
            xtol=min(settings.tol, 1e-8) if method == "lm" else settings.tol,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=int(settings.maxiter),
        )
    except (ValueError, ArithmeticError, np.linalg.LinAlgError, PincalError) as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        return Solution(None, 0, False, f"failed: least_squares stopped on {text}")
    njev = int(solution.njev or solution.nfev or 0)
    if not np.all(np.isfinite(solution.x)):
        return Solution(None, njev, False, "failed: least_squares diverged")
    return Solution(unknowns(solution.x), njev, solution.status > 0, solution.message)
