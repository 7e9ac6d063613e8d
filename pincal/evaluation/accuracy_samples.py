"""Where an accuracy report looks (:func:`pincal.evaluation.accuracy`): the test pose(s), boxes
around them and the workspace, drawn once and shared by every plan compared."""

from __future__ import annotations

import math

import numpy as np

from pincal.arguments import angle, generator, positive_int
from pincal.evaluation.region import Neighbourhood, ResolvedRegion, resolve_test_poses, width_text
from pincal.typing import TestPoseLike

NEIGHBOURHOODS = (math.radians(10), math.radians(20))
"""Half-widths of the neighbourhoods every report covers [rad]."""

WORKSPACE_SAMPLES = 2000
"""Configurations drawn uniformly within the joint limits for the workspace statistics."""

NEIGHBOURHOOD_SAMPLES = 512
"""Configurations drawn in each neighbourhood."""

PRISMATIC_PER_RADIAN = 0.01 / math.radians(10)
"""How far a prismatic joint moves in the neighbourhoods and error profiles where a revolute
joint turns by one radian [m/rad]: 1 cm for 10°, unless the test region is a neighbourhood with a
length of its own (``around(q0, angle, length=...)``), whose ratio is then used."""


def prismatic_per_radian(test_pose: TestPoseLike) -> float:
    """[m/rad] the test region's own ratio of length to angle, else :data:`PRISMATIC_PER_RADIAN`."""
    if isinstance(test_pose, Neighbourhood) and test_pose.length is not None:
        angle = test_pose.angle
        if angle is not None and not isinstance(angle, np.ndarray):
            return test_pose.length / angle
    return PRISMATIC_PER_RADIAN


def _neighbourhood(
    robot, centers: np.ndarray, delta: np.ndarray, n: int, rng: np.random.Generator
) -> np.ndarray:
    """n configurations uniform in the boxes centres ± δ ((nq,) [rad or m]; a centre drawn per
    sample), clipped to the joint limits."""
    c = centers[rng.integers(len(centers), size=n)]
    return np.clip(c + rng.uniform(-delta, delta, c.shape), robot.lower, robot.upper)


def sample_sets(
    robot,
    test_pose: TestPoseLike,
    neighbourhoods: tuple[float, ...] = NEIGHBOURHOODS,
    samples: int = NEIGHBOURHOOD_SAMPLES,
    workspace: int = WORKSPACE_SAMPLES,
    seed: int = 0,
) -> tuple[list[tuple[str, np.ndarray]], np.ndarray, ResolvedRegion | None]:
    """The configurations an accuracy report covers (see :func:`accuracy`): ([(where, (n, nq)), ...]
    for the test pose(s), each neighbourhood and the workspace, the test poses, the resolved region
    or None)."""
    neighbourhoods = tuple(angle(d, "neighbourhoods (half-width)") for d in neighbourhoods)
    samples = positive_int(samples, "samples")
    workspace = positive_int(workspace, "workspace")
    poses, region = resolve_test_poses(robot, test_pose)
    rng = generator(seed)
    first = "test region" if region is not None else "test pose" if len(poses) == 1 else "test poses"
    sets = [(first, poses)]
    per_radian = prismatic_per_radian(test_pose)
    revolute = robot.revolute
    prismatic = not revolute.all()
    labels, deltas = [], []
    for delta in neighbourhoods:
        # around each test pose: beyond a region's edge
        width = width_text(delta, delta * per_radian if prismatic else None)
        labels.append(f"region {width}" if region is not None else width)
        deltas.append(np.where(revolute, delta, delta * per_radian))
    if len(poses) > 1 or not deltas:
        sets.extend(
            (label, _neighbourhood(robot, poses, d, samples, rng)) for label, d in zip(labels, deltas)
        )
        sets.append(("workspace", robot.random_configurations(workspace, rng)))
        return sets, poses, region
    # One centre: choosing it draws nothing, so the boxes' and the workspace's uniform draws are
    # one call, and the numbers NumPy's uniform(-δ, δ) (-δ + (δ - (-δ))·u, clipped to the limits)
    # and Robot.random_configurations (lo + (hi - lo)·u over Robot.sampled_range) make of them.
    n = len(deltas) * samples
    u = rng.random((n + workspace, robot.nq))
    lower, upper = robot.lower, robot.upper
    delta_q = np.array(deltas)[:, None, :]
    boxes = np.clip(
        poses[0] + (-delta_q + (delta_q + delta_q) * u[:n].reshape(len(deltas), samples, -1)), lower, upper
    )
    sets.extend(zip(labels, boxes, strict=True))
    low, high = robot.sampled_range()
    sets.append(("workspace", low + (high - low) * u[n:]))
    return sets, poses, region
