r"""The criteria by name: what a design can minimise and a baseline can report (docs/method.md §6, §7.1).

=====================  ==============================================  =======================================
criterion              F(M), M the posterior information               reported value
=====================  ==============================================  =======================================
``test-pose``          log mean_k tr(J0k M⁻¹ J0kᵀ)                     ρ0 = σ·sqrt(exp F) [m]
``test-pose-worst``    log max_k tr(J0k M⁻¹ J0kᵀ)                      ρ0 at the worst test pose [m]
``D``                  −log det M                                      log det M⁻¹
``A``                  log tr M⁻¹                                      tr M⁻¹
``E``                  −log λ_min(M)                                   λ_max(M⁻¹)
``cond``               ½ log(λ_max(M)/λ_min(M))                        σ_max(J)/σ_min(J)
=====================  ==============================================  =======================================

Each is one :class:`~pincal.evaluation.criterion.Criterion` in its own file
(:mod:`~pincal.evaluation.test_pose`, :mod:`~pincal.evaluation.test_pose_worst`,
:mod:`~pincal.evaluation.d_optimal`, :mod:`~pincal.evaluation.a_optimal`,
:mod:`~pincal.evaluation.e_optimal`, :mod:`~pincal.evaluation.condition`); :func:`make_criterion`
builds one by name. The reported values are those of :func:`pincal.rho0` and
:func:`pincal.criteria` (``log_det``, ``trace``, ``max_eig``, ``cond``).
"""

from __future__ import annotations

import numpy as np

from pincal.arguments import DEFAULT_SIGMA
from pincal.errors import BadArgument, UnknownName
from pincal.evaluation.a_optimal import AOptimal
from pincal.evaluation.condition import Condition
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.d_optimal import DOptimal
from pincal.evaluation.e_optimal import EOptimal
from pincal.evaluation.test_pose import TestPoseMean
from pincal.evaluation.test_pose_worst import TestPoseWorst

CRITERIA = ("test-pose", "test-pose-worst", "D", "A", "E", "cond")
"""Names of the criteria a design can minimise."""

TEST_POSE_CRITERIA = ("test-pose", "test-pose-worst")
"""The criteria that need a test pose."""

_ALIASES = {
    "test-pose": "test-pose",
    "testpose": "test-pose",
    "rho0": "test-pose",
    "test-pose-mean": "test-pose",
    "test-pose-worst": "test-pose-worst",
    "worst": "test-pose-worst",
    "d": "D",
    "log_det": "D",
    "logdet": "D",
    "a": "A",
    "trace": "A",
    "e": "E",
    "max_eig": "E",
    "cond": "cond",
}


def criterion_name(name: str) -> str:
    """The canonical name of a criterion (case and ``_``/``-`` insensitive).

    Raises:
        UnknownName: the name is not a criterion; the message lists the valid ones.
    """
    key = str(name).strip().lower().replace("_", "-")
    key = {"log-det": "log_det", "max-eig": "max_eig"}.get(key, key)
    if key not in _ALIASES:
        raise UnknownName("criterion", str(name), CRITERIA)
    return _ALIASES[key]


def make_criterion(
    criterion: str,
    n_params: int,
    rows: int,
    J0: np.ndarray | None = None,
    sigma: float = DEFAULT_SIGMA,
    prior: np.ndarray | None = None,
) -> Criterion:
    """The criterion object of a canonical name.

    Args:
        criterion: a canonical name (see :func:`criterion_name`).
        n_params: P.
        rows: measured coordinates per configuration.
        J0: (k, r, P) tip-frame Jacobians at the test poses (the test-pose criteria need them).
        sigma: measurement noise per coordinate [m] (scales the reported ρ0).
        prior: (P, P) the prior's information Λ = σ²Σp⁻¹ (:meth:`pincal.Prior.information`), or None.
    """
    if criterion in TEST_POSE_CRITERIA:
        if J0 is None:
            raise BadArgument(f"criterion {criterion!r} needs a test pose")
        cls = TestPoseMean if criterion == "test-pose" else TestPoseWorst
        return cls(J0, sigma, rows, prior)
    if criterion == "A":
        return AOptimal(n_params, rows, prior)
    if criterion == "D":
        return DOptimal(rows, prior)
    if criterion == "E":
        return EOptimal(rows, prior)
    if criterion == "cond":
        return Condition(rows, prior)
    raise UnknownName("criterion", str(criterion), CRITERIA)
