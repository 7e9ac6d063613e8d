r"""Deploying a calibration: the joint commands that put the tool where the nominal model says
(docs/method.md §11.4).

A controller that cannot load a URDF moves its joints to the targets of its program, computed with
the nominal model. For each target, the tool pose T* the nominal model gives (or a Cartesian target
position with the tool's orientation kept), the corrected command q_c is the one whose *actual* tool
pose, under the calibrated geometry, the joint gains, the compliance under the program's payload
and the residual model's mean, equals T*. It is found by Newton's method from the target (or a
``init``): the step solves J(θ)·(dθ/dq)·Δq = −e in the least-squares sense, with e the tool's
position error and, for a chain of six joints or more, its orientation error (log₃ of
R_actual·R*ᵀ), J the calibrated model's tool Jacobian (world-aligned) at the actual joint values θ
and dθ/dq = (I − C ∂τ/∂θ)⁻¹(I + K) (differentiating the static equation; ∂τ/∂θ from Pinocchio's
gravity derivatives). The residual model's own slope is left out of the step (it is small against
the arm's lever), so the last steps converge linearly by that ratio; two to four steps reach far
below any instrument's noise.

Everything is in the robot's base frame: the instrument's placement (the base identified by the
calibration) is not part of a joint command. The residual model predicts the error of the measured
point (marker 0) in the robot's base frame; it corrects the tool's position by that error, which
holds where the marker is near the tool.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.arguments import positive_int
from pincal.deprecation import renamed_keyword
from pincal.errors import BadArgument
from pincal.model.kinematics import ForwardKinematics
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot
from pincal.model.statics import payload_rows
from pincal.typing import ArrayLike, ConfigurationsLike, PayloadLike

TOLERANCE = 1e-10
"""Newton stops when the tool's position error is below this [m] and its orientation error below
this [rad]."""

MAX_ITERATIONS = 20
"""Newton steps after which a target is reported as not converged."""

HALVINGS = 8
"""Times a Newton step that would increase the error is halved before it is taken anyway."""


@dataclass(frozen=True, eq=False)
class Compensation:
    """Corrected joint commands for a program.

    Attributes:
        joint_names: the chain's joints, in column order.
        targets: (m, nq) the nominal joint targets [rad or m] (for Cartesian targets: the nominal
            model's own solution for them).
        commands: (m, nq) the corrected commands [rad or m]: send these to the controller.
        position_error: (m,) the tool's remaining position error under the calibrated model [m].
        orientation_error: (m,) its remaining orientation error [rad] (0 when not matched).
        iterations: (m,) Newton steps taken.
        outside_limits: indices of the targets whose corrected command leaves the joint limits.
    """

    joint_names: tuple[str, ...]
    targets: np.ndarray
    commands: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    iterations: np.ndarray
    outside_limits: tuple[int, ...]

    @property
    def corrections(self) -> np.ndarray:
        """(m, nq) commands − targets [rad or m]."""
        return self.commands - self.targets

    @property
    def converged(self) -> bool:
        """Every target reached within :data:`TOLERANCE`."""
        return bool(np.all(self.position_error <= TOLERANCE) and np.all(self.orientation_error <= TOLERANCE))


class _Tool:
    """The tool pose and Jacobian of one robot in its own base frame (no instrument placement)."""

    def __init__(self, robot: Robot, residual: ResidualModel | None) -> None:
        self.robot = robot
        self.forward = ForwardKinematics(robot)
        self.model, self.data = robot.model, self.forward.data
        self.frame = robot.tip_frame
        self.residual = residual

    def pose(self, q: np.ndarray, load: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position, rotation, 6×nq world-aligned Jacobian with respect to the command) at command q
        under the payload row ``load`` [kg, x, y, z]."""
        theta = self.forward.joint_values(q[None], load[None])[0]
        pin.computeJointJacobians(self.model, self.data, theta)
        pin.updateFramePlacements(self.model, self.data)
        placement = self.data.oMf[self.frame]
        J = pin.getFrameJacobian(self.model, self.data, self.frame, pin.LOCAL_WORLD_ALIGNED)
        position = placement.translation.copy()
        if self.residual is not None:
            position += self.residual.mean(q[None])[0, :3]
        # dθ/dq = (I - C ∂τ/∂θ)⁻¹ (I + K): the gains scale the reading, the compliance yields to it.
        return position, placement.rotation.copy(), J @ self.forward.reading_jacobian(theta, load)


def _solve(tool: _Tool, start: np.ndarray, goal: tuple, load: np.ndarray, steps: int):
    """Newton from ``start`` to the tool pose ``goal`` = (position, rotation or None) under ``load``,
    halving a step that would increase the error (near a wrist singularity the full step
    overshoots): (q, position error [m], orientation error [rad], steps taken)."""
    position, rotation = goal

    def error(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, R, J = tool.pose(q, load)
        if rotation is None:
            return p - position, J[:3]
        return np.r_[p - position, pin.log3(R @ rotation.T)], J

    q = start.copy()
    e, J = error(q)
    for step in range(steps + 1):
        distance, angle = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
        if (distance <= TOLERANCE and angle <= TOLERANCE) or step == steps:
            return q, distance, angle, step
        delta = np.linalg.lstsq(J, e, rcond=None)[0]
        for _ in range(HALVINGS):
            e_new, J_new = error(q - delta)
            if np.linalg.norm(e_new) < np.linalg.norm(e):
                break
            delta = delta / 2
        q, e, J = q - delta, e_new, J_new
    raise AssertionError("unreachable")


@renamed_keyword(
    "seed",
    "init",
    "seed= is a random seed everywhere else in pincal; init= starts a search, as Search(init=)",
)
def compensate(
    calibrated: Robot,
    nominal: Robot,
    targets: ArrayLike,
    *,
    payload: PayloadLike = None,
    residual_model: ResidualModel | None = None,
    cartesian: bool = False,
    init: ConfigurationsLike | None = None,
    max_iterations: int = MAX_ITERATIONS,
) -> Compensation:
    """Corrected joint commands for a program (see the module doc).

    Args:
        calibrated: the calibrated robot (identified geometry, offsets, gains, compliances and
            gravity: ``result.robot`` of :func:`~pincal.identify`, or one loaded from a calibrated
            URDF and its sidecar).
        nominal: the robot the program was written for (its nominal model).
        targets: (m, nq) nominal joint targets [rad or m]; with ``cartesian``, (m, 3) tool
            positions in the robot's base frame [m].
        payload: what the tool carries during the program (a mass [kg], a
            :class:`~pincal.Payload`, or one per target); it bends a compliant robot.
        residual_model: the calibration's residual model, whose mean corrects the tool position.
        cartesian: the targets are tool positions; the tool keeps the nominal orientation it has at
            ``init``, and each target starts from the previous one's solution.
        init: (nq,) a configuration near the first Cartesian target, where Newton's method starts
            (required with ``cartesian``); or (m, nq), one per target. Named ``seed=`` in pincal
            0.1 (it keeps working until pincal 0.3, with a DeprecationWarning).
        max_iterations: Newton steps per target.

    Returns:
        the corrected commands and how well each target is reached.

    Raises:
        BadArgument: robots of different chains, targets of the wrong shape or outside the joint
            limits, a Cartesian program without ``init``.
    """
    if nominal.joint_names != calibrated.joint_names or nominal.tip != calibrated.tip:
        raise BadArgument(
            f"the calibrated robot ({', '.join(calibrated.joint_names)}; tip {calibrated.tip}) and the "
            f"nominal one ({', '.join(nominal.joint_names)}; tip {nominal.tip}) must be the same chain"
        )
    max_iterations = positive_int(max_iterations, "max_iterations", low=1, high=1000)
    orient = calibrated.nq >= 6
    rigid_nominal = nominal.replace(base=pin.SE3.Identity())
    if cartesian:
        goals = _positions(targets)
        starts = _starts(nominal, init, len(goals))
        rotations, _ = rigid_nominal.tip_poses(starts[:1], check=False)
        rotations = np.repeat(rotations, len(goals), axis=0)
    else:
        starts = nominal.configurations(targets, "target")
        rotations, goals = rigid_nominal.tip_poses(starts, check=False)
    loads = payload_rows(payload, len(goals))
    nominal_tool = _Tool(rigid_nominal, None)
    tool = _Tool(calibrated, residual_model)
    per_row = init is not None and np.ndim(init) == 2
    commands, planned = np.empty((len(goals), calibrated.nq)), np.empty((len(goals), calibrated.nq))
    distance, angle, steps = np.empty(len(goals)), np.empty(len(goals)), np.empty(len(goals), dtype=int)
    for i, (goal, rotation) in enumerate(zip(goals, rotations)):
        start = starts[i] if (not cartesian or per_row or i == 0) else planned[i - 1]
        pose = (goal, rotation if orient else None)
        planned[i] = _solve(nominal_tool, start, pose, loads[i], max_iterations)[0] if cartesian else start
        commands[i], distance[i], angle[i], steps[i] = _solve(
            tool, planned[i], pose, loads[i], max_iterations
        )
    lo, hi = calibrated.lower - 1e-9, calibrated.upper + 1e-9
    outside = tuple(int(i) for i in np.flatnonzero(np.any((commands < lo) | (commands > hi), axis=1)))
    return Compensation(calibrated.joint_names, planned, commands, distance, angle, steps, outside)


def _positions(targets: ArrayLike) -> np.ndarray:
    try:
        goals = np.array(targets, dtype=float).reshape(-1, 3)
    except (TypeError, ValueError):
        raise BadArgument(
            f"Cartesian targets must be (m, 3) tool positions [m], got {np.shape(targets)}",
            argument="targets",
        ) from None
    if not np.all(np.isfinite(goals)):
        raise BadArgument("Cartesian targets must be finite", argument="targets")
    return goals


def _starts(robot: Robot, init: ConfigurationsLike | None, m: int) -> np.ndarray:
    """(m, nq) where each Cartesian target's search starts, from ``init`` (one, or one per target)."""
    if init is None:
        raise BadArgument(
            "Cartesian targets need a seed: a configuration near the first target (init=, --seed-pose), "
            "which also gives the tool orientation kept",
            argument="init",
        )
    seeds = robot.configurations(init, "seed")
    if len(seeds) not in (1, m):
        raise BadArgument(f"give one seed or one per target ({m}), got {len(seeds)}", argument="init")
    return np.repeat(seeds, m, axis=0) if len(seeds) == 1 else seeds
