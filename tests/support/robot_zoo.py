"""Every robot ``pincal robots`` lists, and one calibration rehearsal on a chain of it.

Shared by tests/model/test_every_robot.py and benchmarks/bench_robots.py (issue 11, items 1 and 7).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

import pincal
from pincal.model.loading import chain_ends, example_robot_data_names

SIGMA = 3e-5
"""Instrument noise per coordinate [m] (a laser tracker)."""

MARKER = [(0.05, 0.02, 0.03)]
"""One measured point, off every joint axis, in the tip frame [m]."""


def listed_robots() -> list[str]:
    """The names ``pincal robots`` lists."""
    return [*pincal.shipped_robots(), *example_robot_data_names()]


@dataclass(frozen=True)
class Chain:
    """The chain a rehearsal uses: the default one, or the longest arm when the tip is ambiguous."""

    robot: pincal.Robot | None
    refused: str = ""  # the one-line reason when the robot cannot be loaded


def chain_of(name: str) -> Chain:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.PincalWarning)
        try:
            return Chain(pincal.load_robot(name, markers=MARKER))
        except pincal.errors.AmbiguousTip as exc:
            ends = chain_ends(name)
            arms = [c for c in ends.candidates if not c.finger] or list(ends.candidates)
            if not arms:  # nothing moves: the refusal says so
                return Chain(None, str(exc))
            tip = max(arms, key=lambda c: c.joints).frame
            try:
                return Chain(pincal.load_robot(name, tip=tip, markers=MARKER))
            except pincal.PincalError as exc:
                return Chain(None, str(exc))
        except pincal.PincalError as exc:
            return Chain(None, str(exc))


@dataclass(frozen=True)
class Rehearsal:
    """Figures of one design + simulate + identify round trip."""

    identifiable: int
    total: int
    m: int
    design_seconds: float
    rho0: float  # predicted error at the test pose after calibration [m]
    worst_z: float  # max |identified - true| / std over the parameters
    error_after: float  # position error at the test pose after calibration [m]
    error_before: float  # ... before calibration [m]


def rehearse(robot: pincal.Robot, seed: int = 0, starts: int = 2, extra: int = 2) -> Rehearsal:
    """Design with m = minimum + ``extra``, simulate measurements on a perturbed robot, identify.

    Raises the design's one-line PincalError when no plan of m configurations reaches the
    conditioning floor."""
    full = robot.parameters("full,offsets")
    params = full.identifiable().identifiable
    m = -(-len(params) // (3 * robot.n_markers)) + extra
    q0 = robot.random_configurations(1, seed)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pincal.errors.DegenerateOptimumWarning)
        design = pincal.design(
            params, m, test_pose=q0, sigma=SIGMA, search=pincal.Search(starts=starts, seed=seed)
        )
    seconds = time.perf_counter() - start
    truth = pincal.random_errors(params, seed=seed + 1)
    data = pincal.simulate_measurements(truth, design.plan, sigma=SIGMA, seed=seed + 2)
    fit = pincal.identify(params, data, sigma=SIGMA)
    if not fit.success:
        raise AssertionError(f"{robot.name}: identification failed: {fit.message}")
    true_point = truth.robot.points(q0)
    return Rehearsal(
        identifiable=len(params),
        total=len(full),
        m=m,
        design_seconds=seconds,
        rho0=float(design.value),
        worst_z=float(np.max(np.abs(fit.values - truth.values) / fit.std)),
        error_after=float(np.linalg.norm(fit.robot.points(q0) - true_point)),
        error_before=float(np.linalg.norm(robot.points(q0) - true_point)),
    )
