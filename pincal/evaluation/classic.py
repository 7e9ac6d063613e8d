r"""The classic criteria of a plan, for comparison with ρ0 (docs/method.md §6.4, §6.5).

* D: log det(M⁻¹) = −log det M;  A: trace(M⁻¹);  E: λ_max(M⁻¹) = 1/σ_min(J)².
* cond: σ_max(J)/σ_min(J), the condition number of the stacked Jacobian.
* Observability indices, with σ₁ ≥ … ≥ σ_P the singular values of J and m configurations:
  O1 = (σ₁σ₂⋯σ_P)^{1/P}/√m (Borm & Menq),  O2 = σ_P/σ₁ (inverse condition number),
  O3 = σ_P (smallest singular value),  O4 = σ_P²/σ₁ (noise amplification index).

D, A, E and cond are *lower is better*; O1–O4 are *higher is better*. D, A and E mix units when the
set mixes lengths and angles (m² and rad²). D, A, E and cond are the criterion objects a design
minimises (:mod:`pincal.evaluation.d_optimal`, ...), here from the singular values of J.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.evaluation.information import factor, informations, raise_singular
from pincal.evaluation.plans import SMALL, blas_for, engine_for, in_blocks, plan_batch, plan_payloads
from pincal.instruments.given import measured, takes_instrument
from pincal.instruments.instrument import Instrument
from pincal.lapack import eigenvalues
from pincal.model.parameters import ParameterSet
from pincal.typing import PlansLike


@dataclass(frozen=True)
class Criteria:
    """The classic criteria of a plan (see module doc for the definitions).

    Attributes:
        log_det: D criterion, log det(M⁻¹) (lower is better).
        trace: A criterion, trace(M⁻¹) (lower is better).
        max_eig: E criterion, largest eigenvalue of M⁻¹ (lower is better).
        cond: condition number of the stacked Jacobian (lower is better, ≥ 1).
        O1: (σ₁⋯σ_P)^{1/P}/√m.   O2: σ_P/σ₁.   O3: σ_P.   O4: σ_P²/σ₁.  (higher is better)
        n_params: P.
        m: number of configurations.
    """

    log_det: float
    trace: float
    max_eig: float
    cond: float
    O1: float
    O2: float
    O3: float
    O4: float
    n_params: int
    m: int

    def by_criterion(self, name: str) -> float:
        """The value of the criterion ``name`` (``"D"``, ``"A"``, ``"E"`` or ``"cond"``)."""
        return getattr(self, {"D": "log_det", "A": "trace", "E": "max_eig", "cond": "cond"}[name])

    def as_dict(self) -> dict[str, float]:
        """The criteria by name (the keys of ``pincal evaluate --json``)."""
        return {k: getattr(self, k) for k in ("log_det", "trace", "max_eig", "cond", "O1", "O2", "O3", "O4")}


def criteria_from_jacobian(J: np.ndarray, m: int) -> Criteria:
    """Classic criteria of a stacked (rows, P) or (m, 3K, P) parameter Jacobian."""
    J = np.asarray(J)
    rows = J.shape[1] if J.ndim == 3 else J.shape[0] // max(m, 1)
    J2 = J.reshape(-1, J.shape[-1])
    factor(J2.T @ J2, rows, m)  # raises SingularPlan like ρ0 does
    return criteria_from_singular_values(np.linalg.svd(J2, compute_uv=False), m, rows)


def criteria_from_singular_values(s: np.ndarray, m: int, rows: int) -> Criteria:
    """Classic criteria from the singular values s (descending) of a regular plan's stacked
    Jacobian (m configurations, ``rows`` measured coordinates each)."""
    return criteria_of_plans(s[None], m, rows)[0]


def criteria_of_plans(S: np.ndarray, m: int, rows: int) -> tuple[Criteria, ...]:
    """Classic criteria of k regular plans from the singular values S (k, P) (each row
    descending) of their stacked Jacobians, every criterion computed for all k at once: the
    numbers of the criteria's own ``from_singular_values`` (DOptimal, AOptimal, EOptimal,
    Condition), each logarithm and inverse square formed once (a dozen NumPy calls for one plan
    instead of forty)."""
    n = S.shape[1]
    smallest, largest = S[:, -1], S[:, 0]
    log_sum = np.log(S).sum(axis=1)
    inverse_squares = 1.0 / (S * S)
    columns = (
        -2.0 * log_sum,  # D: log det M⁻¹
        inverse_squares.sum(axis=1),  # A: tr M⁻¹
        inverse_squares[:, -1],  # E: 1/σ_P²
        largest / smallest,  # cond
        np.exp(log_sum / n) / np.sqrt(m),  # O1
        smallest / largest,  # O2
        smallest,  # O3
        smallest * smallest / largest,  # O4
    )
    return tuple(
        Criteria(d, a, e, c, o1, o2, o3, o4, n, m)
        for d, a, e, c, o1, o2, o3, o4 in zip(*(c.tolist() for c in columns))
    )


EIGEN_CONDITION = 1e3
"""The singular values of a stacked Jacobian J whose condition number is at most this are taken
as the square roots of the eigenvalues of M = JᵀJ (about the cost of Pinocchio's own work for the
plan, against twice that for an SVD of J). Each eigenvalue is then exact to about ε·‖M‖, so each
σ to a relative ε·cond(J)² ≲ 2e-10 at this bound (measured: at most 0.6·ε·cond² on random plans
of KR 270 and UR10); plans above it take an SVD of J (ε·cond(J))."""


def singular_values(J: np.ndarray, M: np.ndarray) -> np.ndarray:
    """(k, P) the singular values, descending, of k stacked Jacobians J (k, rows, P) with
    information matrices M = JᵀJ (k, P, P): from the eigenvalues of M for the plans conditioned
    within :data:`EIGEN_CONDITION`, from an SVD of J for the others."""
    w = np.linalg.eigvalsh(M)[:, ::-1]
    S = np.sqrt(np.maximum(w, 0.0))
    poor = ~((w[:, -1] > 0) & (w[:, -1] * EIGEN_CONDITION**2 >= w[:, 0]))  # cond(J)² = λ_max/λ_min; NaN too
    if poor.any():
        S[poor] = np.linalg.svd(J[poor], compute_uv=False)
    return S


def criteria_of_jacobians(J: np.ndarray, rows: int, m: int) -> tuple[Criteria, ...]:
    """The classic criteria of k plans from their stacked Jacobians J (k, m·rows, P).

    Raises:
        SingularPlan: for the first singular plan, as :func:`~pincal.rho0` would (``plan i:``).
    """
    M = informations(J)
    if J.shape[1] < J.shape[2]:  # fewer coordinates than parameters: singular
        raise_singular(M, rows, m)
    S = singular_values(J, M)
    # A plan with cond(J) ≤ EIGEN_CONDITION passes factor's test (each Cholesky pivot over its M_ii
    # is at least λ_min/λ_max ≥ 1e-6): only the others (and any with σ_P = 0) are factored.
    regular = (S[:, -1] > 0) & (S[:, -1] * EIGEN_CONDITION >= S[:, 0])
    raise_singular(M, rows, m, np.flatnonzero(~regular))
    return criteria_of_plans(S, m, rows)


def _regular_plan(J: np.ndarray, m: int) -> Criteria | None:
    """The criteria of one plan from its stacked Jacobian J (m·r, P), if it is conditioned within
    :data:`EIGEN_CONDITION` (else None: :func:`criteria`'s batch path, with its SVD and its test
    of singularity): the numbers of :func:`criteria_of_plans` to rounding, in Python floats from
    one LAPACK call (on one plan's 27 numbers, NumPy's dozen calls cost more than that call)."""
    n = J.shape[1]
    if len(J) < n:
        return None
    w = eigenvalues(J.T @ J).tolist()  # ascending
    if not (w[0] > 0 and w[0] * EIGEN_CONDITION**2 >= w[-1]):
        return None
    s = [math.sqrt(x) for x in w]
    smallest, largest = s[0], s[-1]
    log_sum = sum(map(math.log, s))
    return Criteria(
        -2.0 * log_sum,
        sum(1.0 / (x * x) for x in s),
        1.0 / (smallest * smallest),
        largest / smallest,
        math.exp(log_sum / n) / math.sqrt(m),
        smallest / largest,
        smallest,
        smallest * smallest / largest,
        n,
        m,
    )


@takes_instrument
def criteria(
    params: ParameterSet,
    plan: PlansLike,
    *,
    instrument: Instrument | None = None,
) -> Criteria | tuple[Criteria, ...]:
    """The classic criteria (D, A, E, cond, O1–O4) of ``plan`` for ``params``; of each plan of a
    batch ((k, m, nq) or a sequence of Plans: a tuple of k, see :mod:`pincal.evaluation.plans`).
    With an ``instrument`` (:class:`pincal.instruments.Instrument`, see :func:`pincal.rho0`), of
    the whitened rows it measures, scaled by its reference σ (σ·L⁻¹J): points with one σ are
    unchanged.

    The singular values come from the eigenvalues of M where cond(J) ≤ :data:`EIGEN_CONDITION`
    (exact to about ε·cond(J)², at most 2e-10 relative), else from an SVD of J. One plan alone
    and the same plan in a batch take different LAPACK calls: their numbers agree to that
    precision, not bit for bit."""
    qs, batched = plan_batch(params, plan)
    k, m, _ = qs.shape
    engine = engine_for(params, measured(instrument)[0])
    rows = engine.rows

    def evaluate(J: np.ndarray) -> tuple[Criteria, ...]:
        return criteria_of_jacobians(J, rows, m)

    payload = plan_payloads(plan, qs.shape)  # a Plan's own payloads
    if k == 1 and m <= SMALL:  # one small plan: no batch machinery (see SMALL)
        J = engine.jacobian(qs[0], frame="tip", payload=payload).reshape(-1, engine.n_params)
        one = _regular_plan(J, m) or evaluate(J[None])[0]
        return (one,) if batched else one
    with blas_for(k * m):
        blocks = in_blocks(engine, qs, payload, evaluate)
    found = tuple(c for block in blocks for c in block)
    return found if batched else found[0]
