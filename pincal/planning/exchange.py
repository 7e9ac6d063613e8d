"""Exchange search: the best m configurations of a pool of feasible candidates (Fedorov-style).

Starting from m pool configurations, each configuration of the plan in turn is exchanged for the
pool candidate that improves the criterion most, until no exchange improves it. An exchange
(remove i, add c) changes M by a rank-6K term, M' = M + U C Uᵀ with U = [J_cᵀ, J_iᵀ] and
C = diag(I, −I); with H = C + Uᵀ M⁻¹ U (6K×6K, K markers), Sherman–Morrison–Woodbury gives

    M'⁻¹ = M⁻¹ − M⁻¹ U H⁻¹ Uᵀ M⁻¹,       det M' / det M = (−1)^{3K} det H,

so every candidate is scored at once from a few batched 6K×6K solves — no P×P inversion:
trace criteria from tr(W M'⁻¹) = tr(W M⁻¹) − ⟨Q, H⁻¹Q⟩ with Q = Uᵀ M⁻¹ J0ᵀ, D from the
determinant ratio, E and cond from the eigenvalues of M' itself. An accepted exchange updates
M⁻¹ the same way; M⁻¹ is recomputed from M once per sweep to keep rounding from drifting.
Candidates already in the plan, or closer than the minimum spacing to another configuration of
it, are not considered, nor an exchange that would take the plan's conditioning (see
:func:`pincal.evaluation.information.conditioning`) below the floor.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve

from pincal.evaluation.information import conditioning, factor
from pincal.planning.objectives import Objective, TraceObjective

TOLERANCE = 1e-10
"""An exchange must lower the objective F (a log) by more than this."""

LOG_MIN_RATIO = np.log(1e-12)
"""Exchanges that shrink det M by more than this factor are taken as singular."""


@dataclass(frozen=True)
class ExchangeOutcome:
    """The end of one start of the exchange search.

    Attributes:
        index: (m,) pool indices of the plan.
        F: objective value (exact).
        sweeps: passes over the plan.
        swaps: exchanges made.
        time_s: wall time [s].
    """

    index: np.ndarray
    F: float
    sweeps: int
    swaps: int
    time_s: float


def _inverse(M: np.ndarray, rows: int, m: int) -> np.ndarray:
    L = factor(M, rows, m)
    return cho_solve((L, True), np.eye(len(M)))


def _best_regular(values, F, cand, M, J_pool, Ji, floor, tries: int = 32) -> int | None:
    """Index (into ``values``) of the best improving exchange that keeps the conditioning above
    ``floor``; None if there is none among the ``tries`` best."""
    improving = np.flatnonzero(values < F - TOLERANCE)
    if not len(improving):
        return None
    order = improving[np.argsort(values[improving], kind="stable")][:tries]
    if floor <= 0:
        return int(order[0])
    for k in order:
        Jc = J_pool[cand[k]]
        if conditioning(M + Jc.T @ Jc - Ji.T @ Ji) > floor:
            return int(k)
    return None


def _capacitance(S_cc: np.ndarray, A: np.ndarray, Ji: np.ndarray, Ai: np.ndarray) -> np.ndarray:
    """(N, 2r, 2r) the Woodbury capacitance matrices of swapping configuration i (rows Ji, Ai =
    Ji M⁻¹) for each candidate c (S_cc = J_c M⁻¹ J_cᵀ, A = J_c M⁻¹): their determinants are the
    ratios det M'/det M, and they solve the updates of M⁻¹ and of the weighted traces."""
    N, r, _ = A.shape
    H = np.empty((N, 2 * r, 2 * r))
    H[:, :r, :r] = S_cc + np.eye(r)
    H[:, :r, r:] = A @ Ji.T
    H[:, r:, :r] = np.swapaxes(H[:, :r, r:], 1, 2)
    H[:, r:, r:] = Ai @ Ji.T - np.eye(r)
    return H


def _trace_values(
    objective: Objective, t: np.ndarray, H: np.ndarray, AJ0: np.ndarray, AiJ0: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(values, traces) of a trace objective after each candidate swap (H, AJ0 = J_c M⁻¹ J0ᵀ of the
    candidates; AiJ0 = Ji M⁻¹ J0ᵀ of the configuration swapped out); inf where a trace would not
    stay positive."""
    n, r = len(H), AiJ0.shape[0]
    Q = np.concatenate([AJ0, np.broadcast_to(AiJ0, (n, r, AJ0.shape[2]))], axis=1)
    Y = np.linalg.solve(H, Q)
    red = np.einsum("nar,nar->nr", Q, Y).reshape(n, objective.k, -1).sum(axis=2)
    new_t = t - red
    values = objective.from_traces(new_t)
    values[~np.all(new_t > 0, axis=1)] = np.inf
    return values, new_t


def _pool_products(
    objective: Objective, J_pool: np.ndarray, Minv: np.ndarray, trace: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(A, S_cc, AJ0) of every pool candidate c for the current M⁻¹: A = J_c M⁻¹, S_cc = J_c M⁻¹ J_cᵀ
    and, for a trace objective, AJ0 = J_c M⁻¹ J0ᵀ (else None)."""
    N, r, P = J_pool.shape
    flat = J_pool.reshape(N * r, P)
    A = (flat @ Minv).reshape(N, r, P)  # J_c M⁻¹
    S_cc = np.einsum("nrp,nsp->nrs", A, J_pool)
    AJ0 = (flat @ (Minv @ objective.J0T)).reshape(N, r, -1) if trace else None
    return A, S_cc, AJ0


def _allowed(used: np.ndarray, dist: np.ndarray | None, i: int, spacing: float) -> np.ndarray:
    """(N,) the candidates that may replace configuration i: not in the plan and, with a minimum
    spacing (``dist``: (N, m) distances to the plan), at least ``spacing`` from the others."""
    allowed = ~used
    if dist is not None:
        others = np.delete(dist, i, axis=1)
        allowed &= np.all(others >= spacing, axis=1)
    return allowed


def _candidate_values(
    objective: Objective,
    cand: np.ndarray,
    F: float,
    t: np.ndarray | None,
    M: np.ndarray,
    Minv: np.ndarray,
    Ji: np.ndarray,
    H: np.ndarray,
    logdet: np.ndarray,
    AJ0: np.ndarray | None,
    JtJ: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """(values, traces or None) of the objective after swapping configuration Ji (rows) for each
    candidate ``cand``, each family its own way: the determinant ratio (logdet), the Woodbury
    update of the traces (trace), the eigenvalues of M' itself (spectral)."""
    if objective.family == "logdet":
        return F - logdet[cand], None
    if isinstance(objective, TraceObjective):
        return _trace_values(objective, t, H[cand], AJ0[cand], Ji @ (Minv @ objective.J0T))
    Mc = M + JtJ[cand] - Ji.T @ Ji
    return objective.from_eigenvalues(np.linalg.eigvalsh(objective.posterior(Mc))), None


def _swapped_inverse(Minv: np.ndarray, A_c: np.ndarray, Ai: np.ndarray, H_c: np.ndarray) -> np.ndarray:
    """M⁻¹ after the swap of configuration i (Ai = Ji M⁻¹) for candidate c (A_c = J_c M⁻¹, H_c its
    capacitance), by Woodbury: M'⁻¹ = M⁻¹ − M⁻¹ U H⁻¹ Uᵀ M⁻¹, symmetrised."""
    UtMinv = np.concatenate([A_c, Ai])  # Uᵀ M⁻¹, (2r, P)
    Minv = Minv - UtMinv.T @ np.linalg.solve(H_c, UtMinv)
    return 0.5 * (Minv + Minv.T)


def fedorov(
    objective: Objective,
    J_pool: np.ndarray,
    pool: np.ndarray,
    index: np.ndarray,
    spacing: float = 0.0,
    floor: float = 0.0,
    max_sweeps: int = 100,
) -> ExchangeOutcome:
    """Exchange search from the plan ``pool[index]``.

    Args:
        objective: the criterion.
        J_pool: (N, 3K, P) tip-frame Jacobians of the pool.
        pool: (N, nq) the candidate configurations.
        index: (m,) pool indices of the starting plan (its M must be regular).
        spacing: minimum joint-space distance between configurations of the plan [rad].
        floor: smallest conditioning an exchange may leave the plan with.
        max_sweeps: passes over the plan allowed.
    """
    t0 = time.perf_counter()
    N, r, P = J_pool.shape
    index = np.array(index)
    m = len(index)
    JtJ = np.einsum("nrp,nrs->nps", J_pool, J_pool) if objective.family == "spectral" else None
    trace = isinstance(objective, TraceObjective)

    def exact() -> tuple[np.ndarray, np.ndarray, float, np.ndarray | None]:
        Jd = J_pool[index].reshape(-1, P)
        M = Jd.T @ Jd
        Minv = _inverse(objective.posterior(M), r, m)
        return M, Minv, objective.value(M, m), objective.traces(M, m) if trace else None

    M, Minv, F, t = exact()
    used = np.zeros(N, dtype=bool)
    used[index] = True
    dist = np.linalg.norm(pool[:, None, :] - pool[index][None], axis=2) if spacing > 0 else None
    sign_c = (-1.0) ** r
    sweeps = swaps = 0
    stale = True
    while sweeps < max_sweeps:
        sweeps += 1
        improved = False
        for i in range(m):
            if stale:
                A, S_cc, AJ0 = _pool_products(objective, J_pool, Minv, trace)
                stale = False
            Ji = J_pool[index[i]]
            Ai = Ji @ Minv
            H = _capacitance(S_cc, A, Ji, Ai)
            sign, logdet = np.linalg.slogdet(H)
            ok = _allowed(used, dist, i, spacing) & (sign * sign_c > 0) & (logdet > LOG_MIN_RATIO)
            if not ok.any():
                continue
            cand = np.flatnonzero(ok)
            values, new_t = _candidate_values(objective, cand, F, t, M, Minv, Ji, H, logdet, AJ0, JtJ)
            best = _best_regular(values, F, cand, M, J_pool, Ji, floor)
            if best is None:
                continue
            c = int(cand[best])
            Minv = _swapped_inverse(Minv, A[c], Ai, H[c])
            M = M + J_pool[c].T @ J_pool[c] - Ji.T @ Ji
            used[index[i]] = False
            used[c] = True
            index[i] = c
            if dist is not None:
                dist[:, i] = np.linalg.norm(pool - pool[c], axis=1)
            F = float(values[best])
            if new_t is not None:
                t = new_t[best]
            swaps += 1
            improved = True
            stale = True
        M, Minv, F, t = exact()
        stale = True
        if not improved:
            break
    return ExchangeOutcome(index, F, sweeps, swaps, time.perf_counter() - t0)
