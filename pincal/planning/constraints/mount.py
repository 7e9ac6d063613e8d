"""The plane the robot is mounted on: nothing the joints move goes through it.

A fixed-base robot stands on (or hangs from, or is bolted to) a plane; a plan with the tool or an
elbow below that plane drives the robot into its own floor. :class:`Mount` keeps the measured
points, the tip frame and every link origin the joints move on the robot's side of the plane.

The plane is given in the robot's base frame (the chain's root link, before any base placement in
the instrument's frame). For ``floor``, ``wall`` and ``ceiling`` it is z = 0 of that frame with
the robot on the +z side: a URDF's base frame has its z axis out of the mounting surface however
the robot is installed, so the three name how the robot hangs (reports say which) and keep the
same plane; give another plane as a normal and an offset (``normal · p ≥ offset``), e.g. a robot
on a riser whose floor lies 0.8 m below its base: ``Mount.parse("0,0,1,-0.8")``.

The plane keeps a clearance: every checked point stays at least ``clearance`` [m] above it (a design
adds the default of :data:`~pincal.planning.constraints.defaults.DEFAULT_CLEARANCE`, 5 cm, which
covers the uncalibrated robot's error and the marker's own size; docs/method.md §12.5).

A point the joints cannot move off its height (the first joint's origin, every point of a planar
arm moving in its base plane) is where the robot is built, not a choice of the plan: it is left
out. Which points are checked is :attr:`MountBound.names`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pincal.errors import BadConstraint
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows
from pincal.planning.constraints.base import TOLERANCE, Bound, Constraint, Kinematics, number, vector

MOUNTS = ("floor", "wall", "ceiling", "none")
"""How a robot can be mounted (``none``: no plane kept, e.g. a robot on a pedestal that reaches
below its base, or a floating base)."""

MOVING = 1e-6
"""A point whose height above the plane varies by less than this [m] over random configurations
is not moved by the joints (left out of the check)."""


@dataclass(frozen=True)
class Mount(Constraint):
    """Keep what the joints move on the robot's side of its mounting plane (robot base frame).

    Example: ``Mount("floor")`` keeps the markers, the tip and every moving link origin at z ≥ 0
    of the base frame; ``Mount("plane", (0, 0, 1), -0.8)`` at z ≥ −0.8 m;
    ``Mount("floor", clearance=0.05)`` at z ≥ 5 cm.

    Attributes:
        kind: ``floor``, ``wall``, ``ceiling`` (the plane z = 0 of the base frame), ``plane``
            (``normal`` and ``offset`` as given) or ``none`` (nothing kept).
        normal: (3,) normal of the plane, towards the robot (normalised on construction).
        offset: the plane is ``normal · p = offset`` [m]; the robot's side ``normal · p ≥ offset``.
        clearance: how far above the plane every checked point stays [m] (≥ 0).
    """

    kind: str = "floor"
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    offset: float = 0.0
    clearance: float = 0.0
    key = "mount"
    reach = 0.05

    def __post_init__(self) -> None:
        valid = (*MOUNTS, "plane")
        if self.kind not in valid:
            raise BadConstraint(f"unknown mount {self.kind!r}; valid: {', '.join(valid)}")
        n = np.array(vector(self.normal, "mount normal"))
        if np.linalg.norm(n) < 1e-12:
            raise BadConstraint("mount normal must not be zero")
        if self.kind in ("floor", "wall", "ceiling") and (
            not np.allclose(n / np.linalg.norm(n), (0, 0, 1)) or self.offset != 0
        ):
            raise BadConstraint(
                f"a {self.kind} mount is the plane z = 0 of the base frame; give another as kind 'plane'"
            )
        object.__setattr__(self, "normal", tuple(float(v) for v in n / np.linalg.norm(n)))
        object.__setattr__(self, "offset", number(self.offset, "mount offset"))
        object.__setattr__(self, "clearance", number(self.clearance, "mount clearance", 0.0))

    @classmethod
    def parse(cls, text: str) -> Mount:
        """A mount from ``floor``, ``wall``, ``ceiling``, ``none`` or ``NX,NY,NZ,OFFSET`` (a plane
        ``normal · p ≥ offset`` of the base frame, metres).

        Raises:
            BadConstraint: anything else (the message lists what is valid).
        """
        word = str(text).strip().lower()
        if word in MOUNTS:
            return cls(word)
        cells = [c.strip() for c in word.split(",")]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            values = []
        if len(values) != 4:
            raise BadConstraint(
                f"mount {text!r}: expected {', '.join(MOUNTS)} or a plane NX,NY,NZ,OFFSET "
                f"(normal towards the robot, offset in metres: normal·p >= offset)"
            )
        return cls("plane", (values[0], values[1], values[2]), values[3])

    def describe(self) -> str:
        """``floor (z ≥ 0 m in the base frame)``: the mount in words (the plane; its clearance is
        :attr:`clearance`)."""
        if self.kind == "none":
            return "none"
        n = np.array(self.normal)
        if np.allclose(n, (0, 0, 1)):
            plane = f"z ≥ {self.offset:.4g} m"
        else:
            plane = f"({n[0]:.3g}, {n[1]:.3g}, {n[2]:.3g})·p ≥ {self.offset:.4g} m"
        return f"{self.kind} ({plane} in the base frame)"

    def bind(self, robot: Robot) -> MountBound:
        return MountBound(robot, self)


class MountBound(Bound):
    """The mount bound to a robot: the heights of the moving points above the plane.

    The points are the robot's forward kinematics' (:meth:`ForwardKinematics.chain_points
    <pincal.model.kinematics.ForwardKinematics.chain_points>`: at the joints' values, gains and
    compliances included, under the configurations' payload): many configurations at once (the
    random draws of a pool or of a baseline's plans, the continuous search's constraints and their
    differences) in one batch, which agrees with Pinocchio's forward kinematics to rounding,
    1e-15 m; fewer than :data:`~pincal.model.kinematics.BATCH` (the repair's bisection, a report's
    single pose) with Pinocchio one configuration at a time, cheaper there. The decisions and the
    margins come from the same heights.

    Attributes:
        names: what each checked point is (``joint_a3 origin``, ``tool0``, ``marker 0``).
        joints: the Pinocchio joints whose origins are checked.
    """

    reach = 0.05

    def __init__(self, robot: Robot, spec: Mount) -> None:
        self.robot, self.spec = robot, spec
        self.normal, self.offset = np.array(spec.normal), spec.offset
        self.clearance = spec.clearance
        self.forward = ForwardKinematics(robot)
        joints = list(range(1, robot.model.njoints))
        names = [f"{robot.model.names[j]} origin" for j in joints]
        names += [robot.tip] + [f"marker {k}" for k in range(robot.n_markers)]
        self.joints, self.names, self.keep = joints, names, np.arange(len(names))
        if spec.kind == "none":
            self.keep = np.arange(0)
        else:
            probe = robot.random_configurations(64, np.random.default_rng(0))
            heights = self.batch_points(probe) @ self.normal - self.offset
            self.keep = np.flatnonzero(np.ptp(heights, axis=0) > MOVING)
        self.names = [names[i] for i in self.keep]

    @property
    def empty(self) -> bool:
        return not len(self.keep)

    def points(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, n, 3) every candidate point (joint origins, tip, markers) in the base frame [m] at
        the readings ``qs``: :meth:`~pincal.model.kinematics.ForwardKinematics.chain_points`."""
        return self.forward.chain_points(qs, payload)

    def batch_points(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """:meth:`points` of all configurations in one batch (agrees to rounding)."""
        return self.forward.batch_chain_points(qs, payload)

    def heights(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, kept) the kept points' heights above the plane [m] at the readings ``qs``."""
        return self.points(qs, payload)[:, self.keep] @ self.normal - self.offset

    def margins(self, kin: Kinematics) -> np.ndarray:
        """(m, kept) the heights above the plane less the clearance [m]."""
        if not len(self.keep):
            return np.zeros((len(kin.qs), 0))
        return self.heights(kin.qs, kin.payload) - self.clearance

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        if not len(self.keep):
            return np.ones(len(kin.qs), dtype=bool)
        return np.all(self.heights(kin.qs, kin.payload) - self.clearance >= -TOLERANCE, axis=1)

    def strictly_satisfied(self, kin: Kinematics) -> np.ndarray:
        if not len(self.keep):
            return np.ones(len(kin.qs), dtype=bool)
        return np.all(self.heights(kin.qs, kin.payload) - self.clearance > 0, axis=1)
