"""The baseline a design is judged against: the distribution of a criterion over random feasible
plans, evaluated in batches."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from pincal.arguments import generator, positive_int
from pincal.errors import Infeasible
from pincal.evaluation.prior import Prior
from pincal.evaluation.registry import make_criterion
from pincal.instruments.given import measured, takes_instrument
from pincal.instruments.instrument import Instrument, orientation_length_of, rows_engine, tool_rows
from pincal.model.parameters import ParameterSet
from pincal.planning.constraints import AnyConstraint
from pincal.planning.feasibility import Feasibility
from pincal.planning.multistart import single_threaded_blas
from pincal.planning.objectives import TEST_POSE_CRITERIA, checked_test_poses, criterion_name
from pincal.planning.results import RandomPlans
from pincal.typing import PoolLike, SeedLike, TestPoseLike

__all__ = ["random_plans"]


@takes_instrument
def random_plans(
    params: ParameterSet,
    m: int,
    n: int = 1000,
    test_pose: TestPoseLike | None = None,
    *,
    criterion: str = "test-pose",
    sigma: float | None = None,
    instrument: Instrument | None = None,
    prior: Prior | None = None,
    constraints: Iterable[AnyConstraint] = (),
    seed: SeedLike = 0,
    pool: PoolLike = None,
    orientation_length: float | None = None,
) -> RandomPlans:
    """The distribution of a criterion over ``n`` random feasible plans of m configurations.

    Configurations are drawn uniformly within the joint limits and kept if they satisfy the
    constraints — or, with a ``pool``, m distinct configurations are drawn from the pool's
    feasible ones, the baseline of a design over that pool; plans breaking the minimum spacing
    are drawn again. All plans are evaluated in batches (one Jacobian pass over all n·m
    configurations, batched eigen-decompositions).

    Args:
        params: the parameters to identify.
        m: configurations per plan.
        n: number of plans.
        test_pose: (nq,) or (k, nq) test pose(s) (required by the test-pose criteria).
        criterion: one of :data:`CRITERIA` (default ρ0, the mean over the test poses).
        sigma: the shorthand for points measured with this noise per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`); not with ``instrument``.
        instrument: what is measured and how well (:class:`pincal.instruments.Instrument`), as
            for :func:`design`.
        prior: the errors' prior: the Bayesian criterion, as :func:`pincal.design` minimises it.
        constraints: as for :func:`design`.
        seed: seed of the draws (an int, a numpy Generator, or None for fresh entropy).
        pool: (N, nq) configurations or a Plan (e.g. taught poses) to draw the plans from, as
            :func:`design` searches them (infeasible ones are dropped); default: the joint limits.
        orientation_length: the test-pose criterion's orientation length, as for :func:`design`.

    Returns:
        the values (ρ0 [m] for the test-pose criteria) and their min / mean / median / max.

    Example:
        >>> import pincal
        >>> params = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")
        >>> taught = [[0.0, 0.5], [0.0, 1.5], [0.0, 2.5]]
        >>> randoms = pincal.random_plans(params, 2, 50, test_pose=[0.0, 1.0], pool=taught)
        >>> randoms.n, randoms.n_singular
        (50, 0)
    """
    inst, sigma = measured(instrument, sigma)
    length = orientation_length_of(orientation_length)
    with single_threaded_blas():
        return _random_plans(
            params, m, n, test_pose, criterion, sigma, tuple(constraints), seed, pool, prior, inst, length
        )


def _random_plans(
    params, m, n, test_pose, criterion, sigma, constraints, seed, pool, prior=None, inst=None, length=None
) -> RandomPlans:
    criterion = criterion_name(criterion)
    m = positive_int(m, "m (number of configurations)")
    n = positive_int(n, "n (number of random plans)")
    test_poses = checked_test_poses(params, test_pose, criterion)
    feasibility = Feasibility(params.robot, constraints)
    rng = generator(seed)
    if pool is None:

        def draw(k: int) -> np.ndarray:
            return feasibility.sample(k * m, rng).reshape(k, m, -1)
    else:
        candidates, _ = feasibility.feasible_pool(pool, m)

        def draw(k: int) -> np.ndarray:
            return np.stack([candidates[rng.choice(len(candidates), m, replace=False)] for _ in range(k)])

    qs = draw(n)
    for _ in range(50):
        bad = [i for i in range(n) if not feasibility.spacing_ok(qs[i])]
        if not bad:
            break
        qs[bad] = draw(len(bad))
    else:
        raise Infeasible(f"random plans of {m} configurations rarely satisfy min_spacing; lower it")
    engine = rows_engine(params, inst)
    P, rows = len(params), engine.rows
    J0 = tool_rows(engine, test_poses, length).copy() if test_poses is not None else None
    information = None if prior is None else prior.information(params, sigma)
    objective = make_criterion(
        criterion, P, rows, J0 if criterion in TEST_POSE_CRITERIA else None, sigma, information
    )
    chunk = max(1, 2_000_000 // (m * rows * P + P * P))
    F = np.empty(n)
    for a in range(0, n, chunk):
        block = qs[a : a + chunk]
        J = engine.jacobian(block.reshape(-1, block.shape[2]), frame="tip").reshape(len(block), m * rows, P)
        F[a : a + len(block)] = objective.batch_values(np.einsum("nrp,nrs->nps", J, J))
    finite = np.isfinite(F)
    values = np.asarray(objective.report(F[finite]), dtype=float)
    values.flags.writeable = False
    return RandomPlans(criterion, m, n, int((~finite).sum()), values, sigma)
