"""Safe by default: the constraints a design keeps unless told otherwise (docs/method.md §12.5).

:func:`with_safety` adds to a design's constraints

* a margin inside the joint limits, :data:`~pincal.planning.constraints.joint_limits.DEFAULT_JOINT_LIMITS`
  (2°, 1 cm on prismatic joints), unless the constraints hold a :class:`JointLimits` or a
  ``joint_margin`` is given (0 keeps none);
* the robot's mounting plane, ``Mount("floor")``, for a fixed-base robot whose chain starts at its
  URDF root, unless the constraints hold a :class:`Mount` or a ``mount`` is given (``"none"`` keeps
  none); a floating base (held at the chain's root) and a chain from another ``root`` link keep
  none by default: their base plane is not a floor;
* a **clearance** from that plane and from the obstacles of a workcell, :data:`DEFAULT_CLEARANCE`
  (5 cm: the uncalibrated robot's error and the marker's own size, docs/method.md §12.5), unless a
  ``clearance`` (or a :class:`Clearance` among the constraints) is given (0 keeps only what the
  constraints themselves ask): the Mount keeps its points that far above the plane, a Workcell at
  least that far from every obstacle (a larger ``min_distance`` of its own is kept); the Clearance
  stays among the constraints, so that adding the defaults again keeps it;
* the robot against itself, a :class:`SelfCollision` checked when the robot's URDF has collision
  geometry (``optional``: nothing is checked without it), unless the constraints hold one or
  ``self_collision=False`` is given: ``SelfCollision(enabled=False)`` among the constraints (what
  ``self_collision=False`` adds, ``--self-collision off``) turns it off, for a robot whose
  collisions are checked elsewhere.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace

import numpy as np

from pincal.arguments import MAX_LENGTH, number
from pincal.errors import BadArgument
from pincal.model.robot import Robot
from pincal.planning.constraints.base import Constraint
from pincal.planning.constraints.clearance import Clearance
from pincal.planning.constraints.joint_limits import DEFAULT_JOINT_LIMITS, JointLimits
from pincal.planning.constraints.min_spacing import MinSpacing
from pincal.planning.constraints.mount import Mount
from pincal.planning.constraints.self_collision import SelfCollision
from pincal.planning.constraints.workcell import Workcell

DEFAULT_CLEARANCE = 0.05
"""The clearance a design keeps from the mounting plane and from every obstacle [m] by default
(docs/method.md §12.5): the largest error of an uncalibrated industrial robot's tool (a few
millimetres; 1 mm and 1 mrad errors put a 2.7 m arm's tool up to about a centimetre off), a laser
tracker's reflector (a 1.5" ball: 19 mm from its centre, the measured point, to its surface) and
the floor's own unevenness, with room to spare."""

JointMargin = float | tuple[float, float] | JointLimits | None
"""What ``joint_margin`` accepts: a number (kept from every limit, [rad], or [m] for a prismatic
joint), an (angle [rad], length [m]) pair, a :class:`JointLimits`, or None (the default)."""

MountSpec = str | Mount | None
"""What ``mount`` accepts: ``floor``, ``wall``, ``ceiling``, ``none``, ``NX,NY,NZ,OFFSET``, a
:class:`Mount`, or None (the default)."""


def joint_limits_of(joint_margin: JointMargin) -> JointLimits:
    """The :class:`JointLimits` of a ``joint_margin`` argument (None: the default one).

    Raises:
        BadArgument: a value of another kind, or a negative or non-finite margin.
    """
    if joint_margin is None:
        return DEFAULT_JOINT_LIMITS
    if isinstance(joint_margin, JointLimits):
        return joint_margin
    if isinstance(joint_margin, (tuple, list)) and len(joint_margin) == 2:
        return JointLimits(joint_margin[0], joint_margin[1])
    if isinstance(joint_margin, (int, float, np.integer, np.floating)) and not isinstance(joint_margin, bool):
        return JointLimits(float(joint_margin))
    raise BadArgument(
        f"joint_margin must be a number [rad, or m on prismatic joints], an (angle, length) pair or a "
        f"JointLimits, got {joint_margin!r}",
        argument="joint_margin",
        value=joint_margin,
    )


def default_mount(robot: Robot) -> Mount:
    """``floor`` for a fixed-base robot measured from its URDF root, else ``none``."""
    return Mount("none") if robot.floating or robot.root is not None else Mount("floor")


def mount_of(robot: Robot, mount: MountSpec) -> Mount:
    """The :class:`Mount` of a ``mount`` argument (None: :func:`default_mount`)."""
    if mount is None:
        return default_mount(robot)
    if isinstance(mount, Mount):
        return mount
    if isinstance(mount, str):
        return Mount.parse(mount)
    raise BadArgument(
        f"mount must be floor, wall, ceiling, none, a plane 'NX,NY,NZ,OFFSET' or a Mount, got {mount!r}",
        argument="mount",
        value=mount,
    )


def clearance_of(clearance: float | None) -> float:
    """The clearance [m] of a ``clearance`` argument (None: :data:`DEFAULT_CLEARANCE`).

    Raises:
        BadArgument: not a finite number ≥ 0 (a boolean or text included).
    """
    if clearance is None:
        return DEFAULT_CLEARANCE
    return number(clearance, "clearance", 0.0, MAX_LENGTH, unit="m")


def with_safety(
    robot: Robot,
    constraints: Iterable[Constraint | MinSpacing] = (),
    joint_margin: JointMargin = None,
    mount: MountSpec = None,
    *,
    clearance: float | None = None,
    self_collision: bool | None = None,
) -> tuple[Constraint | MinSpacing, ...]:
    """``constraints`` with the safe defaults added (see the module doc); idempotent.

    Args:
        robot: the robot (its joints say which margins are angles; its base, whether it has a floor).
        constraints: the user's constraints.
        joint_margin: the margin kept inside the joint limits (see :data:`JointMargin`); None: the
            JointLimits among ``constraints``, else the default 2° / 1 cm.
        mount: the mounting plane (see :data:`MountSpec`); None: the Mount among ``constraints``,
            else :func:`default_mount`.
        clearance: kept from the mounting plane and from every obstacle [m] (None: the
            Clearance among ``constraints``, else :data:`DEFAULT_CLEARANCE`; 0: only what the
            Mount and the Workcell ask themselves).
        self_collision: False: the robot is not checked against itself (a
            ``SelfCollision(enabled=False)`` is added); None or True: the SelfCollision among
            ``constraints``, else the optional default check.

    Raises:
        BadArgument: a ``joint_margin`` (or ``mount``, ``clearance``) given both as an argument
            and among the constraints, or of the wrong kind.
    """
    constraints = tuple(constraints)
    limits = [c for c in constraints if isinstance(c, JointLimits)]
    mounts = [c for c in constraints if isinstance(c, Mount)]
    if joint_margin is not None and limits:
        raise BadArgument(
            "the joint margin is given twice (joint_margin and a JointLimits constraint): give it once",
            argument="joint_margin",
        )
    if mount is not None and mounts:
        raise BadArgument(
            "the mount is given twice (mount and a Mount constraint): give it once", argument="mount"
        )
    if len(mounts) > 1:
        raise BadArgument("a robot has one mount: give one Mount constraint", argument="mount")
    clearances = [c for c in constraints if isinstance(c, Clearance)]
    if clearance is not None and clearances:
        raise BadArgument(
            "the clearance is given twice (clearance and a Clearance constraint): give it once",
            argument="clearance",
        )
    if len(clearances) > 1:
        raise BadArgument("give one Clearance constraint", argument="clearance")
    selfs = [c for c in constraints if isinstance(c, SelfCollision)]
    if self_collision is not None and not isinstance(self_collision, (bool, np.bool_)):
        raise BadArgument(
            f"self_collision must be True, False or None, got {self_collision!r}",
            argument="self_collision",
            value=self_collision,
        )
    if self_collision is False and selfs and any(c.enabled for c in selfs):
        raise BadArgument(
            "self-collision is both turned off (self_collision=False) and asked for (a SelfCollision "
            "constraint): give one",
            argument="self_collision",
        )
    keep = clearances[0].distance if clearances else clearance_of(clearance)
    added: list[Constraint | MinSpacing] = []
    if not limits:
        added.append(joint_limits_of(joint_margin))
    if not mounts:
        added.append(mount_of(robot, mount))
    if not selfs:
        dirs = tuple(d for c in constraints if isinstance(c, Workcell) for d in c.package_dirs)
        added.append(SelfCollision(package_dirs=dirs, optional=True, enabled=self_collision is not False))
    if not clearances:
        added.append(Clearance(keep))
    return tuple(_with_clearance(c, keep) for c in constraints + tuple(added))


def _with_clearance(constraint: Constraint | MinSpacing, clearance: float) -> Constraint | MinSpacing:
    """A Mount or a Workcell keeping at least ``clearance`` [m]; any other constraint as it is."""
    if isinstance(constraint, Mount) and constraint.kind != "none" and constraint.clearance < clearance:
        return replace(constraint, clearance=clearance)
    if isinstance(constraint, Workcell) and constraint.min_distance < clearance:
        return replace(constraint, min_distance=clearance)
    return constraint


def joint_margins(robot: Robot, constraints: Iterable[Constraint | MinSpacing]) -> np.ndarray:
    """(nq,) the largest margin any :class:`JointLimits` among ``constraints`` keeps at each joint
    [rad or m] (0 where none)."""
    out = np.zeros(robot.nq)
    for c in constraints:
        if isinstance(c, JointLimits):
            out = np.maximum(out, c.margins_for(robot))
    return out
