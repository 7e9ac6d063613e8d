"""The state of one identification, as frozen values passed between its stages.

:func:`~pincal.calibration.identification.identify` runs in stages; each is a function of these
values that returns a new one, none is changed in place:

1. :class:`Settings`: the checked arguments;
2. :class:`Setup`: the problem (the data, their noise, the residuals and their Jacobian), where the
   fit starts, what the data determine there (the data check) and which unknowns the fit moves;
3. :class:`Rows`: the rows the final fit uses (``reject`` drops some) and, after it, the suspicious
   ones;
4. :class:`Solution`: one least-squares run (:func:`~pincal.calibration.solver.solve`);
5. :class:`Verdict`: the status, in words, with the likely causes of an implausible result.

:func:`~pincal.calibration.result.identification_result` builds the
:class:`~pincal.calibration.result.IdentificationResult` from them.

The unknowns z = (x, b₂, ..., b_S) are the values of the parameter set (every kind the set holds)
then one base per extra session (:class:`~pincal.calibration.problem.Problem`); a row is one
measured configuration, its coordinates weighted through :class:`~pincal.calibration.noise.Noise`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.calibration.problem import Problem
from pincal.calibration.sanity import Outlier
from pincal.evaluation.data_check import DataCheck
from pincal.evaluation.prior import Prior
from pincal.instruments.error_model import ErrorModel


def _read_only(array: np.ndarray) -> np.ndarray:
    array = np.asarray(array)
    if array.flags.writeable:
        array = array.copy()
        array.flags.writeable = False
    return array


@dataclass(frozen=True)
class Settings:
    """The checked arguments of one identification (see :func:`~pincal.identify`).

    Attributes:
        sigma: the σ given per coordinate [m], or None (estimated from the residuals).
        maxiter: the solver's function evaluations.
        tol: the solver's ``xtol``.
        loss: ``linear``, ``huber``, ``soft_l1`` or ``cauchy``.
        method: ``trf`` or ``lm``.
        reject: rows beyond this many robust σ are dropped and the fit repeated; None: none are.
        prior: the prior of a MAP fit, or None.
        sanity: judge the result's plausibility.
        instrument: the instrument's error model (:mod:`pincal.instruments.error_model`), or None
            (``sigma``, or the default, per unit).
    """

    sigma: float | None
    maxiter: int
    tol: float
    loss: str
    method: str
    reject: float | None
    prior: Prior | None
    sanity: bool
    instrument: ErrorModel | None = None


@dataclass(frozen=True, eq=False)
class Setup:
    """What every least-squares run of one identification shares (steps 1 and 2).

    Attributes:
        problem: the residuals and their Jacobian over the sessions, with the noise of the data.
        settings: the checked arguments.
        z0: (n,) the unknowns the fit starts from: zero errors, each session's base from a rigid
            fit when ``base.*`` is identified [m or rad], read-only.
        before: (N,) the residual at ``z0`` [m], read-only.
        check: what the data determine at ``z0``.
        free: the indices of the unknowns the fit moves (every one with a prior; else those the
            data determine), read-only.
        prior_std: (n,) the prior standard deviation of each unknown [m or rad] (inf: none),
            read-only.
        dropped: ``{name: reason}`` of the parameters left nominal (none with a prior).
    """

    problem: Problem
    settings: Settings
    z0: np.ndarray
    before: np.ndarray
    check: DataCheck
    free: np.ndarray
    prior_std: np.ndarray
    dropped: dict[str, str]

    def __post_init__(self) -> None:
        for name in ("z0", "before", "free", "prior_std"):
            object.__setattr__(self, name, _read_only(getattr(self, name)))


@dataclass(frozen=True, eq=False)
class Rows:
    """The measured rows (configurations) of the final fit.

    Attributes:
        used: (m,) True for each row the fit uses, read-only.
        rejected: the rows ``reject`` dropped, in the order it dropped them.
        outliers: the suspicious rows of the final fit, worst first (found after it).
    """

    used: np.ndarray
    rejected: tuple[Outlier, ...] = ()
    outliers: tuple[Outlier, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "used", _read_only(self.used))

    @classmethod
    def every(cls, m: int) -> Rows:
        """All m rows used, none rejected."""
        return cls(np.ones(m, dtype=bool))


@dataclass(frozen=True, eq=False)
class Solution:
    """One run of the least-squares solver.

    Attributes:
        z: (n,) the unknowns it ended at, read-only; None when it failed.
        iterations: its Jacobian evaluations.
        converged: it met its tolerance.
        note: scipy's message, or why it failed.
    """

    z: np.ndarray | None
    iterations: int
    converged: bool
    note: str

    def __post_init__(self) -> None:
        if self.z is not None:
            object.__setattr__(self, "z", _read_only(self.z))


@dataclass(frozen=True)
class Verdict:
    """What the identification came to.

    Attributes:
        status: one of :data:`~pincal.calibration.identification.STATUSES`.
        message: what happened, in words (why it failed and what to do, if it did).
        causes: the likely causes of an ``implausible`` result, most likely first.
    """

    status: str
    message: str
    causes: tuple[str, ...] = ()
