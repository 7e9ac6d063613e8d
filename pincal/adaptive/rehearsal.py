"""Rehearse a campaign on a simulated robot: a plan fixed in advance against the adaptive loop.

A real campaign rarely goes as planned: the instrument's noise differs from the data sheet and
grows with the distance to it (heteroscedastic), a reading is wrong (an outlier), a planned pose
cannot be reached or seen. :class:`Faults` describes them; :func:`rehearse` runs both ways of
measuring on the same simulated robot (random geometric errors), with the same rule to stop — the
predicted error over the test region, from the data so far (outliers dropped, at the instrument's
real mean σ: noise beyond the σ a campaign assumes would count as what the model does not explain),
is below the target — and counts the poses each measured:

* **one-shot**: the smallest plan whose predicted error (at the instrument's nominal σ) meets the
  target, designed in advance and measured; when the data then miss the target, the plan is
  measured again (the whole plan: a plan repeated k times divides ρ0² by k), until they do;
* **adaptive**: a first plan of the fewest poses that identify the parameters (plus
  ``first_extra``), then :func:`~pincal.adaptive.loop.next_poses`, ``k`` at a time, until the
  data say the target is reached.

Each result also gives the error the data truly leave (the prediction with the simulated noise of
each pose, which the campaign does not know), to check that stopping was honest.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from pincal.adaptive.loop import NEXT_SEARCH, _predicted, assess, next_poses
from pincal.adaptive.measured import MeasuredPrior
from pincal.arguments import DEFAULT_SIGMA, generator
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.synthetic import random_errors
from pincal.deprecation import moved_keywords
from pincal.evaluation.region import resolve_test_poses
from pincal.model.parameters import ParameterSet
from pincal.planning.driver import design
from pincal.planning.options import FLAT, Search, check_value, regroup
from pincal.planning.plan import Plan
from pincal.typing import TestPoseLike


@dataclass(frozen=True)
class Faults:
    """What goes wrong in a simulated campaign.

    Attributes:
        noise_scale: the instrument's true noise, on average, in units of its nominal σ.
        tracker: (x, y, z) the instrument's position [m]; the noise of a pose grows with its
            distance to it: σᵢ = noise_scale · σ · dᵢ / d̄ (d̄: the mean distance over the workspace).
        outlier: size of one gross error in the first batch of measurements [m] (0: none).
        unreachable: planned poses of the first batch that cannot be measured.
    """

    noise_scale: float = 1.5
    tracker: tuple[float, float, float] = (3.0, 0.0, 1.0)
    outlier: float = 2e-3
    unreachable: int = 1


@dataclass(frozen=True)
class Rehearsal:
    """How one way of measuring went.

    Attributes:
        poses: poses measured when it stopped (rows of data: outliers included, unreachable ones not).
        predicted: the predicted error over the test region at the stop, as the campaign saw it [m].
        true_error: the error the data truly leave over the test region [m] (with the simulated
            noise of each pose; outliers dropped).
        rounds: batches measured (one-shot: times the plan was measured; adaptive: 1 + next steps).
        reached: it stopped because the target was reached (not at ``max_poses``).
    """

    poses: int
    predicted: float
    true_error: float
    rounds: int
    reached: bool


class _Instrument:
    """The simulated robot and instrument: measures configurations with the faults."""

    def __init__(self, params: ParameterSet, sigma: float, faults: Faults, seed: int) -> None:
        self.rng = generator(seed)
        self.truth = random_errors(params, seed=self.rng)
        self.robot = params.robot
        self.sigma, self.faults = sigma, faults
        tracker = np.asarray(faults.tracker, dtype=float)
        sample = self.robot.points(self.robot.random_configurations(2000, 0))[:, 0]
        self.mean_distance = float(np.linalg.norm(sample - tracker, axis=1).mean())
        self.first = True

    def noise(self, qs: np.ndarray) -> np.ndarray:
        """(m,) σᵢ of each configuration [m]."""
        d = np.linalg.norm(self.robot.points(qs)[:, 0] - np.asarray(self.faults.tracker), axis=1)
        return self.faults.noise_scale * self.sigma * d / self.mean_distance

    def measure(self, qs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(configurations measured, points, their σᵢ): the first batch loses ``unreachable`` poses
        and gets one outlier."""
        qs = np.asarray(qs, dtype=float)
        if self.first and self.faults.unreachable:
            lost = self.rng.choice(len(qs), size=min(self.faults.unreachable, len(qs) - 1), replace=False)
            qs = np.delete(qs, lost, axis=0)
        s = self.noise(qs)
        points = self.truth.robot.points(qs)
        points = points + s[:, None, None] * self.rng.standard_normal(points.shape)
        if self.first and self.faults.outlier > 0:
            i = int(self.rng.integers(len(qs)))
            direction = self.rng.standard_normal(3)
            points[i] += self.faults.outlier * direction / np.linalg.norm(direction)
        self.first = False
        return qs, points, s


def _true_error(
    params: ParameterSet, test_pose: TestPoseLike, qs: np.ndarray, s: np.ndarray, used: np.ndarray
) -> float:
    rows = 3 * params.robot.n_markers
    measured = MeasuredPrior.from_measurements(params, qs[used], np.repeat(s[used], rows))
    return _predicted(params, test_pose, DEFAULT_SIGMA, measured)


@moved_keywords(FLAT, functools.partial(regroup, function="one_shot_plan"))
def one_shot_plan(
    params: ParameterSet, test_pose: TestPoseLike, target: float, sigma: float, max_m: int = 60, **options
) -> Plan:
    """The smallest plan whose predicted error over the test region (at ``sigma``) meets ``target``
    (``options``: :func:`pincal.design`'s keywords, e.g. ``search=pincal.Search(...)``; its flat
    keywords of pincal 0.1 keep working until pincal 0.3, with a DeprecationWarning)."""
    rows = 3 * params.robot.n_markers
    m = -(-len(params) // rows) + 1
    while True:
        result = design(params, m, test_pose, sigma=sigma, **options)
        rho0 = result.rho0
        assert rho0 is not None  # a design for a test pose reports its rho0
        if rho0 <= target or m >= max_m:
            return result.plan
        # ρ² falls roughly as 1/m: jump close to the size that meets the target, then step.
        m = max(m + 1, min(max_m, int(m * (rho0 / target) ** 2 * 0.9)))


def _design_options(flat: dict, kwargs: dict) -> tuple[dict, str]:
    """rehearse()'s ``search=`` for the ``design_options=`` dict of pincal 0.1 (see
    :func:`pincal.deprecation.moved_keywords`)."""
    if "design_options" not in flat:
        return kwargs, ""
    if "search" in kwargs:
        raise TypeError("rehearse() got design_options= and search=: put them in search=")
    options = {"starts": 4, "workers": 1, "seed": kwargs.get("seed", 0), **(flat["design_options"] or {})}
    return dict(kwargs, search=Search(**options)), "search=pincal.Search(...) for design_options={...}"


@moved_keywords(("design_options",), _design_options)
def rehearse(
    params: ParameterSet,
    test_pose: TestPoseLike,
    target: float,
    *,
    sigma: float = DEFAULT_SIGMA,
    faults: Faults = Faults(),
    seed: int = 0,
    plan: Plan | None = None,
    k: int = 3,
    first_extra: int = 2,
    max_poses: int = 120,
    search: Search | None = None,
) -> dict[str, Rehearsal]:
    """Rehearse the one-shot and the adaptive campaign on one simulated robot (see the module doc).

    Args:
        params: the parameters identified.
        test_pose: where the robot works (a region: :func:`pincal.around`, ...).
        target: the predicted error over the test region to reach [m].
        sigma: the instrument's nominal noise per coordinate [m] (what the one-shot plan assumes).
        faults: what goes wrong.
        seed: the simulated robot's errors and every random draw.
        plan: the one-shot plan (default: :func:`one_shot_plan`, designed with ``design_options``).
        k: poses the adaptive campaign adds at each step.
        first_extra: poses beyond the fewest that identify the parameters in its first batch.
        max_poses: a campaign stops there, target reached or not.
        search: how every design searches, and the adaptive steps' starts, workers, pool and
            polish (:class:`pincal.Search`; default 4 starts, 1 worker, ``seed``).
            ``design_options=`` (a dict of its fields) keeps working until pincal 0.3, with a
            DeprecationWarning.

    Returns:
        ``{"one-shot": Rehearsal, "adaptive": Rehearsal}``.
    """
    search = Search(starts=4, workers=1, seed=seed) if search is None else search
    check_value(search, Search, "search")
    resolve_test_poses(params.robot, test_pose)  # checked once, up front
    plan = one_shot_plan(params, test_pose, target, sigma, search=search) if plan is None else plan
    robot = params.robot
    out = {}
    # Both campaigns are told the instrument's real noise level (not its spread over the cell, the
    # outlier or the unreachable pose): residuals beyond the σ a campaign assumes count as what the
    # model does not explain (docs/method.md §11.6), and this robot has nothing of the kind.
    told = faults.noise_scale * sigma

    # One-shot: measure the plan, again and again until the data say the target is reached.
    instrument = _Instrument(params, sigma, faults, seed)
    qs, points, s = np.empty((0, robot.nq)), np.empty((0, robot.n_markers, 3)), np.empty(0)
    rounds = 0
    while True:
        q, p, e = instrument.measure(plan.q)
        qs, points, s, rounds = np.vstack([qs, q]), np.vstack([points, p]), np.concatenate([s, e]), rounds + 1
        data = MeasurementData(qs, points, robot.joint_names)
        a = assess(params, data, test_pose, plan=plan.q, sigma=told)
        if a.predicted <= target or len(qs) + len(plan) > max_poses:
            break
    out["one-shot"] = Rehearsal(
        len(qs), a.predicted, _true_error(params, test_pose, qs, s, a.used), rounds, a.predicted <= target
    )

    # Adaptive: a first batch that identifies the parameters, then k at a time.
    instrument = _Instrument(params, sigma, faults, seed)
    rows = 3 * robot.n_markers
    first = design(params, -(-len(params) // rows) + first_extra, test_pose, sigma=sigma, search=search).plan
    qs, points, s = instrument.measure(first.q)
    attempted, rounds = first.q, 1
    while True:
        data = MeasurementData(qs, points, robot.joint_names)
        step = next_poses(
            params,
            data,
            test_pose,
            k,
            plan=attempted,
            target=target,
            sigma=told,
            search=_next_search(search, seed + rounds),
        )
        if step.stop or len(qs) + k > max_poses:
            break
        q, p, e = instrument.measure(step.plan.q)
        qs, points, s = np.vstack([qs, q]), np.vstack([points, p]), np.concatenate([s, e])
        attempted, rounds = np.vstack([attempted, step.plan.q]), rounds + 1
    used = assess(params, data, test_pose, plan=attempted, sigma=told).used
    out["adaptive"] = Rehearsal(
        len(qs), step.predicted, _true_error(params, test_pose, qs, s, used), rounds, step.stop
    )
    return out


def _next_search(search: Search, seed: int) -> Search:
    """An adaptive step's search: ``search``'s starts, workers, pool and polish, at ``seed``
    (:func:`next_poses`'s own starts and workers where ``search`` leaves them to the design:
    adaptive starts, every CPU)."""
    return Search(
        starts=NEXT_SEARCH.starts if search.starts is None else search.starts,
        seed=seed,
        workers=NEXT_SEARCH.workers if search.workers is None else search.workers,
        pool=search.pool,
        polish=search.polish,
    )


def summary(results: list[dict[str, Rehearsal]], target: float) -> dict[str, dict[str, float]]:
    """Mean poses, the fraction that reached the target, and the mean true error over target,
    for each way of measuring, over many rehearsals."""
    out = {}
    for name in results[0]:
        runs = [r[name] for r in results]
        out[name] = {
            "poses_mean": float(np.mean([r.poses for r in runs])),
            "poses_median": float(np.median([r.poses for r in runs])),
            "reached": float(np.mean([r.reached for r in runs])),
            "true_over_target_mean": float(np.mean([r.true_error / target for r in runs])),
            "true_within_10_percent": float(np.mean([r.true_error <= 1.1 * target for r in runs])),
        }
    out["adaptive_fewer"] = {
        "fraction": float(np.mean([r["adaptive"].poses < r["one-shot"].poses for r in results])),
        "ratio": float(
            np.mean([r["adaptive"].poses for r in results]) / np.mean([r["one-shot"].poses for r in results])
        ),
    }
    return out
