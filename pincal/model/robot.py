"""Robots and the points measured on them (loading them: :mod:`pincal.model.loading`).

A :class:`Robot` is the kinematic chain from the base to a *tip* frame, with one or more measured
points (markers) fixed in the tip frame, as Pinocchio sees it. It is loaded from a URDF file, the
name of a robot pincal ships (``kr270``, ``planar_2r``), the name of an example-robot-data robot
(``ur10``, ``panda``, ...), or an existing ``pinocchio.Model``.

Joints that do not move the tip (grippers, other branches) are locked at their neutral value, so a
configuration holds exactly the joints of the chain, in chain order. A Robot never changes: the
perturbed robots of identification and simulation are new Robots holding their own model copy.

A configuration is the joints' *reading* q; a joint stands at q + offset for a rigid robot, and at
the static solution θ of :mod:`pincal.model.statics` when the robot has joint gains or compliances
(then the payload carried matters: ``payload=`` of :meth:`Robot.points`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.arguments import angle, generator, positive_int
from pincal.errors import BadArgument, BadConfiguration
from pincal.model.chain import frame_id
from pincal.model.fixtures import Fixture, checked_fixtures
from pincal.model.kinematics import marker_positions, tip_poses
from pincal.model.origins import Origin, chain_origins, motion_axes
from pincal.model.parameters import ParameterSet
from pincal.model.statics import Gravity, PayloadRows, carried, chain_mass, mounted, payload_rows
from pincal.typing import ArrayLike, ConfigurationsLike, PayloadLike, SeedLike

LIMIT_TOLERANCE = 1e-9
"""Slack [rad or m] allowed when checking configurations against joint limits."""


@dataclass(frozen=True, eq=False)
class Robot:
    """A kinematic chain from the base to a tip frame, and the points measured on it.

    Build one with :func:`load_robot`. All lengths in [m], angles in [rad].

    Attributes:
        model: the Pinocchio model of the chain (a private copy; never modify it).
        tip: name of the tip frame the markers are fixed to.
        markers: (K, 3) measured points in the tip frame [m].
        name: display name (URDF stem or robot name).
        urdf_path: the URDF this robot came from, if any (used by URDF export).
        joint_offsets: (nq,) joint zero errors [rad or m] added to every configuration.
        joint_gains: (nq,) joint gain errors (dimensionless): a joint reading q moves it by
            q·(1 + gain).
        joint_compliances: (nq,) joint compliances [rad/(N·m) or m/N]: the joint yields by
            compliance·τ to the gravity torque τ on it (:mod:`pincal.model.statics`).
        base: placement of the robot base in the measuring instrument's frame.
        root: the frame the chain starts from, when one was asked for (else None).
        package_dirs: ``((package name, folder), ...)`` resolving the URDF's ``package://NAME/``
            mesh paths (``load_robot``'s ``package_dirs``; a mapping is accepted): the 3-D view
            and the self-collision constraint load the meshes from there.
        fixtures: the parts of the measurement set-up identified with the robot (a camera, its
            target, a draw-wire's anchor; :mod:`pincal.model.fixtures`); none by default.
        floating: the robot has a floating base, held fixed at the chain's root (its base plane
            means nothing: a design keeps no mount plane by default).
    """

    model: pin.Model
    tip: str
    markers: np.ndarray
    name: str = "robot"
    urdf_path: Path | None = None
    joint_offsets: np.ndarray = field(default=None)  # type: ignore[arg-type]  # None: zeros (__post_init__)
    base: pin.SE3 = field(default_factory=pin.SE3.Identity)
    root: str | None = None
    package_dirs: tuple[tuple[str, str], ...] = ()
    joint_gains: np.ndarray = field(default=None)  # type: ignore[arg-type]  # None: zeros (__post_init__)
    joint_compliances: np.ndarray = field(default=None)  # type: ignore[arg-type]  # None: zeros (__post_init__)
    fixtures: tuple[Fixture, ...] = ()
    floating: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "fixtures", checked_fixtures(self.fixtures))
        dirs = tuple((str(name), str(folder)) for name, folder in dict(self.package_dirs).items())
        object.__setattr__(self, "package_dirs", dirs)
        markers = np.array(self.markers, dtype=float, copy=True).reshape(-1, 3)
        markers.flags.writeable = False
        object.__setattr__(self, "markers", markers)
        for name in ("joint_offsets", "joint_gains", "joint_compliances"):
            given = getattr(self, name)
            values = np.zeros(self.model.nq) if given is None else np.array(given, dtype=float, copy=True)
            values.flags.writeable = False
            object.__setattr__(self, name, values)

    # ----------------------------------------------------------------- structure
    @cached_property
    def tip_frame(self) -> int:
        """Pinocchio frame id of the tip."""
        return frame_id(self.model, self.tip)

    @cached_property
    def tip_joint(self) -> int:
        """Pinocchio id of the joint the tip frame is attached to."""
        return self.model.frames[self.tip_frame].parentJoint

    @property
    def nq(self) -> int:
        """Number of joints on the chain."""
        return self.model.nq

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the chain joints, in configuration order."""
        return tuple(self.model.names[1:])

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits [rad or m]."""
        return self.model.lowerPositionLimit.copy()

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits [rad or m]."""
        return self.model.upperPositionLimit.copy()

    @property
    def n_markers(self) -> int:
        """Number of measured points K (each gives 3 coordinates per configuration)."""
        return len(self.markers)

    @cached_property
    def revolute(self) -> np.ndarray:
        """(nq,) True where the joint turns (its values are angles [rad]), False where it slides
        (its values are lengths [m]); read-only. Degrees apply to the revolute joints only."""
        mask = np.linalg.norm(self.motion_axes[1:, 3:], axis=1) > 0.5
        mask.flags.writeable = False
        return mask

    def to_radians(self, values: ArrayLike) -> np.ndarray:
        """Joint values with the revolute ones given in degrees, in radians (prismatic joints stay
        in metres); a new array."""
        values = np.array(values, dtype=float)
        return np.where(self.revolute, np.radians(values), values)

    def to_degrees(self, values: ArrayLike) -> np.ndarray:
        """Joint values [rad or m] with the revolute ones in degrees (prismatic joints stay in
        metres); a new array."""
        values = np.array(values, dtype=float)
        return np.where(self.revolute, np.degrees(values), values)

    @cached_property
    def motion_axes(self) -> np.ndarray:
        """(njoints, 6) motion subspace of each joint in its own frame (row 0 unused)."""
        return motion_axes(self.model)

    @cached_property
    def origins(self) -> tuple[Origin, ...]:
        """The placements carrying errors: one per chain joint, then the tip frame's (named after
        the tip frame, or ``tip`` when the tip frame is named like a chain joint)."""
        return chain_origins(self.model, self.tip, self.tip_frame, self.tip_joint)

    # ------------------------------------------------------------- configurations
    def configurations(self, q: ConfigurationsLike, what: str = "configuration") -> np.ndarray:
        """Validate joint values; return a new (m, nq) float array.

        Args:
            q: (nq,) or (m, nq) joint values [rad or m], or a :class:`~pincal.planning.plan.Plan`.
            what: word used in error messages ("configuration", "test pose", ...).

        Raises:
            BadConfiguration: wrong shape, non-numeric or non-finite values, or a value outside
                its joint limits (the message names the joint, the value and the limits).
        """
        values = getattr(q, "q", q)
        try:
            arr = np.array(values, dtype=float, copy=True)
        except (TypeError, ValueError):
            raise BadConfiguration(f"{what}: joint values must be numbers, got {values!r}") from None
        if arr.ndim == 1:
            arr = arr[None, :]
        if arr.ndim != 2 or arr.shape[1] != self.nq:
            raise BadConfiguration(
                f"{what}: expected {self.nq} joint values ({', '.join(self.joint_names)}), "
                f"got shape {np.shape(values)}"
            )
        # The common case in one expression: every value within its limits (and finite: NaN and
        # ±inf fail the comparisons when the limits are finite); the slow path below finds and
        # names the first bad value.
        lower, upper, finite = self._tolerant_limits()
        inside = (arr >= lower) & (arr <= upper)
        if inside.all() and (finite or np.isfinite(arr).all()):
            return arr
        bad = ~np.isfinite(arr)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise BadConfiguration(f"{what} {i}: joint {self.joint_names[j]} is {arr[i, j]} (must be finite)")
        self.check_limits(arr, [f"{what} {i}" for i in range(len(arr))])
        return arr

    def _tolerant_limits(self) -> tuple[np.ndarray, np.ndarray, bool]:
        """(lower − tolerance, upper + tolerance, both finite) of the model's limits as they are
        now: kept with the limits' bytes, so that a limit changed in the model is seen at the next
        check (a few byte comparisons instead of four array operations per check)."""
        model = self.model
        lower, upper = model.lowerPositionLimit, model.upperPositionLimit
        key = lower.tobytes() + upper.tobytes()
        kept = self.__dict__.get("_limits")
        if kept is None or kept[0] != key:
            limits = (lower - LIMIT_TOLERANCE, upper + LIMIT_TOLERANCE)
            finite = bool(np.isfinite(lower).all() and np.isfinite(upper).all())
            kept = (key, *limits, finite)
            self.__dict__["_limits"] = kept  # a cache on the frozen dataclass, as cached_property
        return kept[1], kept[2], kept[3]

    def check_limits(self, q: np.ndarray, labels: Sequence[str], degrees: bool | None = None) -> None:
        """Raise :class:`BadConfiguration` naming the first joint value outside its limits.

        Args:
            q: (m, nq) joint values [rad or m] (converted from degrees already, if need be).
            labels: what each row is called in the message, e.g. ``plan file 'p.csv', line 3``.
            degrees: how the user wrote the values: True, in degrees (the message shows the value
                and the limits of a revolute joint in degrees); False, in radians from a file or
                the command line (the message hints at degrees when angles exceed 2π); None, from
                the API.

        Raises:
            BadConfiguration: with the row's label, the joint, the value and the valid range, in
                the user's unit (degrees, radians or metres).
        """
        lo, hi = self.model.lowerPositionLimit, self.model.upperPositionLimit
        out = (q < lo - LIMIT_TOLERANCE) | (q > hi + LIMIT_TOLERANCE)
        if not out.any():
            return
        i, j = np.argwhere(out)[0]
        turns = bool(self.revolute[j])
        shown = np.degrees if degrees and turns else float
        unit = ("degrees" if degrees else "radians") if turns else "metres"
        hint = ""
        if degrees is False and np.abs(q[:, self.revolute]).max(initial=0) > 2 * np.pi + 1e-9:
            hint = "; the values look like degrees: add --deg (degrees=True)"
        raise BadConfiguration(
            f"{labels[i]}: joint {self.joint_names[j]} = {shown(q[i, j]):.6g} is outside its "
            f"limits [{shown(lo[j]):.6g}, {shown(hi[j]):.6g}] ({unit}){hint}",
            argument=labels[i],
            joint=self.joint_names[j],
            value=float(shown(q[i, j])),
            valid=(float(shown(lo[j])), float(shown(hi[j]))),
        )

    def sampled_range(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) (nq,) the joint values random configurations are drawn from: the joint
        limits, a revolute joint's within one turn, ±π (a wrist that turns ±360° is drawn over one
        turn); a prismatic joint's are its limits, however long (a 6 m track is drawn over 6 m)."""
        lower, upper = self.model.lowerPositionLimit, self.model.upperPositionLimit
        turns = self.revolute
        lower = np.where(turns, np.maximum(lower, -np.pi), lower)
        return lower, np.where(turns, np.minimum(upper, np.pi), upper)

    def random_configurations(self, n: int, rng: SeedLike = None, margin: float = 0.0) -> np.ndarray:
        """Draw (n, nq) configurations uniformly within the joint limits (:meth:`sampled_range`)
        shrunk by ``margin``.

        Args:
            n: number of configurations.
            rng: a numpy Generator or a seed (an int; None draws fresh entropy).
            margin: distance kept from each limit [rad or m].
        """
        n = positive_int(n, "the number of configurations", low=0)
        margin = angle(margin, "margin", positive=False)
        rng = generator(rng)
        lo, hi = self.sampled_range()
        lo, hi = lo + margin, hi - margin
        if np.any(hi < lo):
            j = int(np.argmax(lo - hi))
            raise BadConfiguration(
                f"margin {margin} leaves no room between the limits of joint {self.joint_names[j]}"
            )
        return lo + (hi - lo) * rng.random((n, self.nq))

    # ------------------------------------------------------------------ kinematics
    def points(self, q: ConfigurationsLike, *, check: bool = True, payload: PayloadLike = None) -> np.ndarray:
        """Measured points at configurations ``q``, in the instrument (base) frame.

        Args:
            q: (nq,) or (m, nq) joint values.
            check: validate ``q`` (shape, finite, within the limits). ``check=False`` is for inner
                loops over an (m, nq) float array already checked, and for geometry outside the
                limits (finite differences, drawings).
            payload: the payload at each configuration (:func:`~pincal.model.statics.payload_rows`;
                default none); it matters only on a robot with joint compliances.

        Returns:
            (m, K, 3) positions [m] (the leading axis is kept even for one configuration).
        """
        return marker_positions(self, *self.tip_poses(q, check=check, payload=payload))

    def tip_poses(
        self,
        q: ConfigurationsLike,
        *,
        check: bool = True,
        data: pin.Data | None = None,
        payload: PayloadLike = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Tip orientations (m, 3, 3) and positions (m, 3) [m] in the instrument frame: the one
        forward-kinematics path (points, constraints and scenes use it;
        :class:`~pincal.model.kinematics.ForwardKinematics` gives the joints and the rest).

        Args:
            q: (nq,) or (m, nq) joint values; with ``check=False`` an (m, nq) float array, used as is.
            check: validate ``q`` first (see :meth:`points`).
            data: a ``pinocchio.Data`` of this robot's model to reuse (default: a new one).
            payload: the payload at each configuration (see :meth:`points`).
        """
        qs = self.configurations(q) if check else np.asarray(q, dtype=float)
        data = self.model.createData() if data is None else data
        return tip_poses(self, self.joint_values(qs, payload=payload, check=False), data, self.base)

    # --------------------------------------------------------------------- statics
    @property
    def is_elastic(self) -> bool:
        """True when the robot has joint gains or compliances: a joint's value is then not its
        reading plus its offset (see :meth:`joint_values`)."""
        return bool(self.joint_gains.any() or self.joint_compliances.any())

    @property
    def gravity(self) -> np.ndarray:
        """Gravity's acceleration in the robot's base frame [m/s²] (a new array); by default
        (0, 0, -9.81)."""
        return np.array(self.model.gravity.linear)

    @property
    def mass(self) -> float:
        """Total mass of the links the chain moves [kg] (0 for a URDF without inertias)."""
        return chain_mass(self.model)

    def with_gravity(self, gravity: ArrayLike) -> Robot:
        """A new Robot mounted so that gravity is ``gravity`` (3,) [m/s²] in its base frame (a
        tilted or wall-mounted base, a measured tilt); see :func:`~pincal.model.statics.mounted`."""
        return self.replace(model=mounted(self.model, gravity))

    def gravity_model(self) -> Gravity:
        """A new :class:`~pincal.model.statics.Gravity` of this robot's chain (one per thread)."""
        return Gravity(self.model, self.tip_joint, self.model.frames[self.tip_frame].placement)

    def joint_values(
        self,
        q: ConfigurationsLike,
        *,
        payload: PayloadLike = None,
        check: bool = True,
        gravity: Gravity | None = None,
    ) -> np.ndarray:
        """The joints' actual values θ (m, nq) at readings ``q`` [rad or m]: q + offsets for a rigid
        robot; with gains and compliances, θ = q + Δq + k⊙q + c⊙τ(θ, w) solved for the payload w
        (see :meth:`points`; :mod:`pincal.model.statics`). ``gravity``: a :meth:`gravity_model`
        of this robot to reuse."""
        qs = self.configurations(q) if check else np.asarray(q, dtype=float)
        # a door: the payload matters (and is checked) only when the joints yield to it
        loads = payload_rows(payload, len(qs)) if self.joint_compliances.any() else None
        return self.joint_values_under(qs, loads, gravity)

    def joint_values_under(
        self, qs: np.ndarray, loads: PayloadRows, gravity: Gravity | None = None
    ) -> np.ndarray:
        """:meth:`joint_values` at readings ``qs`` (m, nq) taken as they are, under the payload
        rows ``loads`` (m, 4) [kg, x, y, z] or None (none): the path below the door."""
        start = qs + self.joint_offsets
        if not self.is_elastic:
            return start
        start = start + self.joint_gains * qs
        if not self.joint_compliances.any():
            return start
        gravity = self.gravity_model() if gravity is None else gravity
        return gravity.deflected(start, self.joint_compliances, carried(loads, len(qs)))

    def joint_torques(
        self, q: ConfigurationsLike, *, payload: PayloadLike = None, check: bool = True
    ) -> np.ndarray:
        """(m, nq) torques [N·m, or N for a prismatic joint] gravity applies at each joint, through
        the links and the payload, at readings ``q`` (at the actual joint values
        :meth:`joint_values`): τ = -g(θ), g Pinocchio's generalized gravity."""
        qs = self.configurations(q) if check else np.asarray(q, dtype=float)
        gravity = self.gravity_model()
        loads = payload_rows(payload, len(qs))
        return gravity.torques(self.joint_values_under(qs, loads, gravity), loads)

    def folded_origin(self, o: int) -> pin.SE3:
        """The URDF ``<origin>`` of chain joint ``o`` (0-based) with its joint offset folded in,
        L·exp(S·Δq), S the joint's motion axis: what the calibrated URDF writes."""
        origin = self.origins[o]
        motion = pin.exp6(pin.Motion(self.motion_axes[origin.joint] * float(self.joint_offsets[o])))
        return origin.origin * motion

    def to_model(self) -> pin.Model:
        """A plain ``pinocchio.Model`` of this robot's chain (a new copy), joint offsets folded into
        the joint placements as in the exported URDF: ``pin.framesForwardKinematics(model, data, q)``
        then ``robot.base * data.oMf[model.getFrameId(robot.tip)]`` applied to each marker gives
        :meth:`points` (q the joint values as measured, no offset table) for a rigid robot. Joint
        gains and compliances are not geometry: they are not in the model (see
        :meth:`joint_values`).

        It is the calibrated chain only: its :attr:`nq` joints, from the root frame to the tip, in
        the order of :attr:`joint_names`; every other joint of the URDF (a panda's two finger
        joints: 7 of its 9 joints are here, a humanoid's other limbs, joints of zero range) is
        locked at the value it had when the robot was loaded and folded into the fixed placements,
        and the world frame is the chain's root. For the whole robot with every joint, write the
        calibrated URDF (:func:`pincal.export_urdf`) and load it:
        ``pin.buildModelFromUrdf("calibrated.urdf")``."""
        model = pin.Model(self.model)
        for o in range(self.nq):
            joint = self.origins[o].joint
            model.jointPlacements[joint] = self.origins[o].parent * self.folded_origin(o)
        return model

    def replace(self, **changes: object) -> Robot:
        """A new Robot with some fields changed (the model is copied if given)."""
        fields = {
            "model": self.model,
            "tip": self.tip,
            "markers": self.markers,
            "name": self.name,
            "urdf_path": self.urdf_path,
            "joint_offsets": self.joint_offsets,
            "base": self.base,
            "root": self.root,
            "package_dirs": self.package_dirs,
            "joint_gains": self.joint_gains,
            "joint_compliances": self.joint_compliances,
            "fixtures": self.fixtures,
            "floating": self.floating,
        }
        fields.update(changes)
        return Robot(**fields)

    def fixture(self, name: str) -> Fixture:
        """The fixture named ``name``.

        Raises:
            BadArgument: no fixture has that name (the message lists them).
        """
        for fixture in self.fixtures:
            if fixture.name == name:
                return fixture
        names = ", ".join(f.name for f in self.fixtures) or "none"
        raise BadArgument(f"{self.name} has no fixture {name!r} (fixtures: {names})", argument="fixture")

    def with_fixtures(self, *fixtures: Fixture) -> Robot:
        """A new Robot with ``fixtures`` added (one of the same name is replaced)."""
        names = {f.name for f in fixtures}
        return self.replace(fixtures=tuple(f for f in self.fixtures if f.name not in names) + fixtures)

    def parameters(self, spec: str | Iterable[str] = "full,offsets") -> ParameterSet:
        """The geometric parameters named by ``spec`` (see :class:`pincal.ParameterSet`)."""
        return ParameterSet.from_spec(self, spec)

    def __repr__(self) -> str:
        return (
            f"Robot({self.name!r}, tip={self.tip!r}, joints={list(self.joint_names)}, "
            f"markers={self.markers.tolist()})"
        )
