"""What the workcell imposes on measurement configurations (docs/method.md §7.4).

Each constraint is a small frozen value object; a design keeps every configuration it returns
inside all of them. Lengths are in metres, in the instrument's frame (the robot's base frame unless
the robot has a base placement); angles in radians. :func:`load_constraints` reads them from YAML
(degrees allowed there, with ``_deg`` keys).

* :class:`JointLimits` — the URDF limits shrunk by a margin (always applied; a design keeps 2°,
  1 cm on prismatic joints, by default: :data:`DEFAULT_JOINT_LIMITS`).
* :class:`Mount` — the measured points, the tip and every moving link origin on the robot's side
  of its mounting plane, a clearance above it (a design keeps ``floor`` by default for a
  fixed-base robot, 5 cm above it: :data:`DEFAULT_CLEARANCE`).
* :class:`Clearance` — the distance kept from the mounting plane and from every obstacle (checked
  by the Mount and the Workcell; a design keeps :data:`DEFAULT_CLEARANCE` by default).
* :class:`WorkspaceBox` — every marker inside an axis-aligned box.
* :class:`HalfSpace` — every marker on one side of a plane (``normal · p ≥ offset``).
* :class:`Visibility` — a laser tracker at a known position sees every marker: distance within
  [min_range, max_range] and, if the marker's normal is given, the angle between that normal and
  the line of sight at most ``max_angle``.
* :class:`LineOfSight` — nothing of the chain crosses the line from an instrument to a marker (the
  URDF's collision geometry through coal).
* :class:`SelfCollision` — no two links of the chain closer than ``min_distance`` (the URDF's
  collision geometry through Pinocchio and coal; pairs of adjacent links are not checked).
* :class:`Workcell` — the robot's collision geometry (the URDF's, or capsules derived from the
  kinematics) at least ``min_distance`` from every obstacle of the cell (boxes, cylinders, spheres,
  meshes, a URDF of the cell; base frame).
* :class:`AvoidPoses` — every configuration a distance away from given ones (poses found
  unreachable).
* :class:`MinSpacing` — any two configurations of a plan at least ``distance`` apart in joint space
  (Euclidean norm of the joint differences [rad]).

A design adds the safe defaults with :func:`with_safety` (the joint margin, the mount, the
clearance from the mount and the obstacles, the robot against itself when its URDF has collision
geometry; see
:mod:`pincal.planning.constraints.defaults`).

Inside the continuous search the constraints are inequalities on the joint values (SLSQP): each
margin over its :attr:`reach` (5 cm, 0.05 rad, 2 cm for collisions), read up to the reach, must stay
non-negative; every plan returned is checked exactly.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from pincal.model.robot import Robot
from pincal.planning.constraints.avoid_poses import AvoidPoses
from pincal.planning.constraints.base import TOLERANCE, Bound, Constraint, Kinematics
from pincal.planning.constraints.clearance import Clearance
from pincal.planning.constraints.defaults import (
    DEFAULT_CLEARANCE,
    JointMargin,
    MountSpec,
    clearance_of,
    default_mount,
    joint_limits_of,
    joint_margins,
    mount_of,
    with_safety,
)
from pincal.planning.constraints.half_space import HalfSpace
from pincal.planning.constraints.joint_limits import DEFAULT_JOINT_LIMITS, JointLimits, LimitsBound
from pincal.planning.constraints.line_of_sight import LineOfSight
from pincal.planning.constraints.loading import constraints_from_dict, load_constraints
from pincal.planning.constraints.min_spacing import MinSpacing
from pincal.planning.constraints.mount import MOUNTS, Mount, MountBound
from pincal.planning.constraints.self_collision import SelfCollision
from pincal.planning.constraints.visibility import Visibility
from pincal.planning.constraints.workcell import Obstacle, Workcell
from pincal.planning.constraints.workspace_box import WorkspaceBox
from pincal.typing import ConfigurationsLike

AnyConstraint = Constraint | MinSpacing
"""Any constraint object: a per-configuration :class:`Constraint` or the plan-wide :class:`MinSpacing`."""

__all__ = [
    "DEFAULT_CLEARANCE",
    "DEFAULT_JOINT_LIMITS",
    "MOUNTS",
    "TOLERANCE",
    "AnyConstraint",
    "AvoidPoses",
    "Bound",
    "Clearance",
    "Constraint",
    "HalfSpace",
    "JointLimits",
    "JointMargin",
    "Kinematics",
    "LimitsBound",
    "LineOfSight",
    "MinSpacing",
    "Mount",
    "MountBound",
    "MountSpec",
    "Obstacle",
    "SelfCollision",
    "Visibility",
    "Workcell",
    "WorkspaceBox",
    "clearance_of",
    "constraints_from_dict",
    "default_mount",
    "joint_limits_of",
    "joint_margins",
    "load_constraints",
    "mount_of",
    "satisfied",
    "spacing_of",
    "with_safety",
]


def satisfied(
    robot: Robot, plan: ConfigurationsLike, constraints: Iterable[AnyConstraint] = ()
) -> np.ndarray:
    """(m,) True where a configuration of ``plan`` satisfies every constraint (and the joint
    limits); a configuration too close to an earlier one (MinSpacing) is marked False."""
    qs = robot.configurations(plan)
    ok = np.ones(len(qs), dtype=bool)
    for c in constraints:
        ok &= c.satisfied(robot, qs)
    return ok


def spacing_of(constraints: Iterable[AnyConstraint]) -> float:
    """The largest MinSpacing distance among ``constraints`` (0 if none)."""
    return max((c.distance for c in constraints if isinstance(c, MinSpacing)), default=0.0)
