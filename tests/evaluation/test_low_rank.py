"""The exchange's low-rank scoring (pincal.evaluation.low_rank) against exact values, for every
number of rows per configuration its algebra has a branch for (closed-form inverses up to 3 rows,
Cholesky factors beyond)."""

import numpy as np
import pytest

from pincal.evaluation import low_rank
from pincal.evaluation.registry import make_criterion


def _spd(rng, r, n, scale=1.0):
    A = rng.standard_normal((n, r, r + 2)) * scale
    return np.einsum("nak,nbk->abn", A, A)  # (r, r, n), symmetric positive definite


@pytest.mark.parametrize("r", [1, 2, 3, 4, 6])
def test_inverse_of_stacks_matches_numpy(r):
    rng = np.random.default_rng(r)
    E = _spd(rng, r, 50)
    E[..., 7] = -E[..., 7]  # negative definite
    if r > 1:
        E[1, 1, 9] = -E[1, 1, 9]  # not positive definite: a negative diagonal entry
    Einv, det, ok = low_rank.inverse(E)
    dense = E.transpose(2, 0, 1)
    pd = np.array([np.all(np.linalg.eigvalsh(M) > 0) for M in dense])
    np.testing.assert_array_equal(ok, pd)
    assert not ok[7] and ok.sum() == 50 - 1 - (r > 1)
    np.testing.assert_allclose(Einv.transpose(2, 0, 1)[ok], np.linalg.inv(dense[ok]), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(det[ok], np.linalg.det(dense[ok]), rtol=1e-10)
    assert np.all(det[~ok] == 1.0) and np.all(np.isfinite(Einv))


def test_products_and_forms_of_stacks():
    rng = np.random.default_rng(1)
    A, B = rng.standard_normal((2, 3, 3, 20))
    s = rng.standard_normal((3, 5, 20))
    dense_A, dense_B = A.transpose(2, 0, 1), B.transpose(2, 0, 1)
    np.testing.assert_allclose(low_rank.product(A, B).transpose(2, 0, 1), dense_A @ dense_B, rtol=1e-12)
    AtB = low_rank.product(A, B, transpose_a=True)
    np.testing.assert_allclose(AtB.transpose(2, 0, 1), dense_A.transpose(0, 2, 1) @ dense_B, rtol=1e-12)
    trace = np.trace(dense_A @ dense_B, axis1=1, axis2=2)
    np.testing.assert_allclose(low_rank.trace_product(A, B), trace, rtol=1e-12)
    quad = np.einsum("nac,nab,nbc->cn", s.transpose(2, 0, 1), dense_A, s.transpose(2, 0, 1))
    np.testing.assert_allclose(low_rank.quadratic_form(A, s), quad, rtol=1e-12)


@pytest.mark.parametrize("with_prior", [False, True])
@pytest.mark.parametrize("name", ["test-pose", "test-pose-worst", "D", "A"])
@pytest.mark.parametrize("r", [1, 2, 4])
def test_every_swap_scores_the_exact_value_of_the_swapped_plan(name, r, with_prior):
    """Random Jacobians of r rows (the kr270 test in test_criteria covers r = 3): each candidate
    swap's score is the criterion of the swapped plan computed from scratch, the swaps the state
    refuses are those that leave a singular plan, and the state after a swap is exact."""
    rng = np.random.default_rng(10 * r + len(name))
    P, N, m = 6, 40, max(2, -(-8 // r))
    J_pool = rng.standard_normal((N, r, P)) * rng.uniform(0.1, 3.0, P)
    J_pool[N - 1] = J_pool[0]  # a duplicate of a plan configuration
    J_pool[N - 2, :, 1:] = 0.0  # a candidate that only sees the first parameter
    J0 = rng.standard_normal((3, 3, P))
    prior = np.diag(rng.uniform(0.01, 0.1, P)) if with_prior else None
    criterion = make_criterion(name, P, r, J0, 1.0, prior)

    def exact(index):
        J = J_pool[list(index)].reshape(-1, P)
        return criterion.value(J.T @ J, len(index))

    index = np.arange(m)
    state = criterion.exchange(J_pool, index.copy())
    assert state.F == pytest.approx(exact(index), rel=1e-12)
    check_swaps(state, N, exact, range(m), rel=1e-9)


def check_swaps(state, N: int, exact, rows, rel: float) -> None:
    """For each configuration i of ``rows`` in turn: every candidate swap the exchange state scores
    has the exact value of the swapped plan (``exact(index)``, within ``rel``); then the best swap
    is made and the state's F is the exact value of the new plan."""
    allowed = np.ones(N, dtype=bool)
    allowed[state.index] = False
    for i in rows:
        cand, values = state.scores(i, allowed)
        assert len(cand) > 0
        for c, v in zip(cand, values, strict=True):
            trial = state.index.copy()
            trial[i] = c
            assert v == pytest.approx(exact(trial), rel=rel, abs=1e-10)
        best = int(np.argmin(values))
        out, into = int(state.index[i]), int(cand[best])
        state.swap(i, best)
        allowed[out], allowed[into] = True, False
        assert state.F == pytest.approx(exact(state.index), rel=1e-9, abs=1e-10)


def test_a_swap_that_leaves_a_singular_plan_is_refused():
    """With as many rows as parameters, swapping a configuration for one that repeats the other's
    directions leaves M singular: not scored; the others are, exactly."""
    rng = np.random.default_rng(3)
    P, r = 4, 2
    J_pool = rng.standard_normal((5, r, P))
    J_pool[3] = 2.0 * J_pool[1][::-1]  # the rows of configuration 1 again
    criterion = make_criterion("D", P, r)
    state = criterion.exchange(J_pool, np.array([0, 1]))
    allowed = np.array([False, False, True, True, True])
    cand, values = state.scores(0, allowed)
    assert 3 not in cand and 2 in cand and 4 in cand
    for c, v in zip(cand, values, strict=True):
        J = J_pool[[c, 1]].reshape(-1, P)
        assert v == pytest.approx(-np.linalg.slogdet(J.T @ J)[1], rel=1e-10)


def test_the_exchange_floor_check_decides_as_the_conditioning():
    """The exchange's fast floor check (a Cholesky factor) says what the smallest eigenvalue says,
    also for floors just below and just above the plan's conditioning."""
    from pincal.evaluation.information import conditioning
    from pincal.planning.exchange import _above

    rng = np.random.default_rng(5)
    for _ in range(20):
        J = rng.standard_normal((12, 8)) * rng.uniform(0.01, 10.0, 8)
        J[:, 0] += 0.999 * J[:, 1] * rng.uniform()  # nearly dependent columns: a small conditioning
        M = J.T @ J
        c = conditioning(M)
        near = [c * (1 + e) for e in (-1e-3, -1e-4, -1e-5, -1e-12, 0.0, 1e-12, 1e-5, 1e-4, 1e-3)]
        for floor in [1e-9, 1e-6, 1e-3, 0.5, 2.0, *near]:
            assert _above(M, floor) == (c > floor), (c, floor)
    J = rng.standard_normal((12, 8))
    J[:, 3] = 0.0  # a zero column: conditioning 0
    assert not _above(J.T @ J, 1e-3) and not _above(J.T @ J, 1e-9)


def test_the_exchange_spacing_bookkeeping_follows_the_distances():
    """The candidates the exchange lets replace configuration i are those at least the spacing
    from every other configuration of the plan, through a sequence of swaps; a spaced exchange's
    plan keeps the spacing."""
    from pincal.planning.exchange import _Crowding, fedorov

    rng = np.random.default_rng(6)
    pool = rng.uniform(-1.0, 1.0, (200, 3))
    index = rng.choice(200, 6, replace=False)
    crowding = _Crowding(pool, index, 0.5)
    for _ in range(30):
        for i in range(6):
            dist = np.linalg.norm(pool[:, None] - pool[np.delete(index, i)][None], axis=2)
            np.testing.assert_array_equal(crowding.far(i), np.all(dist >= 0.5, axis=1))
        i, c = rng.integers(6), rng.integers(200)
        index[i] = c
        crowding.moved(i, c)
    J_pool = rng.standard_normal((200, 2, 4))
    start = np.array([0, 1, 2, 3])
    while min(np.linalg.norm(pool[a] - pool[b]) for a in start for b in start if a < b) < 0.5:
        start = rng.choice(200, 4, replace=False)
    out = fedorov(make_criterion("D", 4, 2), J_pool, pool, start, spacing=0.5)
    assert out.swaps > 0
    plan = pool[out.index]
    assert min(np.linalg.norm(plan[a] - plan[b]) for a in range(4) for b in range(a)) >= 0.5


def test_the_exchange_takes_the_best_improving_swap_that_keeps_the_floor(monkeypatch):
    """The best improving candidate that passes the floor check, the lowest position among equal
    values, among the 32 best: what sorting every improving value (stably) and walking them gives."""
    from pincal.planning import exchange

    def reference(values, F, refused, tries=32):
        improving = np.flatnonzero(values < F - exchange.TOLERANCE)
        order = improving[np.argsort(values[improving], kind="stable")][:tries]
        return next((int(k) for k in order if int(k) not in refused), None)

    rng = np.random.default_rng(7)
    n = 300
    J_pool = np.arange(n, dtype=float).reshape(n, 1, 1)  # M' = 0 + c² − 0: names candidate c
    zero = np.zeros((1, 1))
    refused_pool: set[int] = set()
    monkeypatch.setattr(exchange, "_above", lambda M, floor: round(np.sqrt(M[0, 0])) not in refused_pool)
    for trial in range(200):
        values = np.round(rng.uniform(-1.0, 1.0, n), 1)  # many equal values
        cand = rng.permutation(n)
        refused = set(range(n)) if trial % 10 == 0 else set(rng.choice(n, rng.integers(0, 60)).tolist())
        refused_pool.clear()
        refused_pool.update(int(cand[k]) for k in refused)
        got = exchange._best_regular(values, 0.5, cand, zero, J_pool, zero, 1e-3)
        assert got == reference(values, 0.5, refused)
    assert exchange._best_regular(values, -2.0, cand, zero, J_pool, zero, 1e-3) is None


def test_d_scores_stay_exact_when_the_plan_barely_sees_a_parameter():
    """A plan whose configurations hardly move one parameter, and candidates that move it a
    thousand times more: adding such a candidate multiplies det M by ~1e6 (X_c ill-conditioned);
    the D score of every swap is still the exact value of the swapped plan."""
    rng = np.random.default_rng(0)
    P, r, N, m = 6, 3, 60, 4
    for _ in range(5):
        J_pool = rng.standard_normal((N, r, P))
        J_pool[:m, :, 0] = 1e-3 * (J_pool[:m, :, 0] + rng.standard_normal((m, r)))
        criterion = make_criterion("D", P, r)
        state = criterion.exchange(J_pool, np.arange(m))
        for i in range(m):
            cand, values = state.scores(i, np.arange(N) >= m)
            for c, v in zip(cand, values, strict=True):
                J = J_pool[[c if k == i else k for k in range(m)]].reshape(-1, P)
                assert v == pytest.approx(-np.linalg.slogdet(J.T @ J)[1], rel=1e-8)


@pytest.mark.parametrize("r", [1, 2, 3, 4])
def test_inverse_cholesky_factors_of_stacks(r):
    rng = np.random.default_rng(r)
    X = _spd(rng, r, 40)
    X[..., 5] = -X[..., 5]
    Q, det, ok = low_rank.factor_inverse(X)
    dense = X.transpose(2, 0, 1)
    assert not ok[5] and ok.sum() == 39 and np.all(np.isfinite(Q)) and np.all(np.isfinite(det))
    L = np.linalg.cholesky(dense[ok])
    np.testing.assert_allclose(Q.transpose(2, 0, 1)[ok], np.linalg.inv(L), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(det[ok], np.linalg.det(dense[ok]), rtol=1e-10)
