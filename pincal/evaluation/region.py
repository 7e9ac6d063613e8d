r"""Where the robot works: test regions and paths (docs/method.md §8.2).

A robot works in a region or along a path, not at one point. Each of these describes the test
configurations a criterion averages over (the mean of ρ0², the V/I-optimal design) or takes the
worst of:

* :func:`around` — a joint-space neighbourhood ``q0 ± δ`` of a test pose (each joint, clipped to
  its limits): q0 itself plus ``samples − 1`` Latin-hypercube points of the box (seeded).
* :class:`TestPath` — configurations given one by one (a welding or drilling program; any length).
* :func:`cartesian_box` — configurations whose measured point (marker 0) lies in a box of the
  instrument frame, at the user's tool orientation (the tip's orientation at a reference
  configuration, or a given rotation). Found by **inverse kinematics**: Latin-hypercube targets in the box,
  each solved by damped least squares on Pinocchio's frame Jacobian and SE(3) log
  (``pin.computeFrameJacobian``, ``pin.log6``, ``pin.Jlog6``) from the reference configuration,
  within the joint limits; targets without a solution on that branch are dropped (and counted).

``region.resolve(robot)`` gives a :class:`ResolvedRegion`: the sample configurations and, for a
continuous region, the map from the unit cube onto the region that the local search for the worst
pose walks on (see :func:`pincal.evaluation.predicted_error.worst_found`).

    >>> import numpy as np, pincal
    >>> robot = pincal.load_robot("kr270", markers=[(0.1, 0.05, 0.2)])
    >>> region = pincal.around(np.radians([0, -60, 60, 0, 45, 0]), np.radians(10), samples=64)
    >>> region.resolve(robot).poses.shape
    (64, 6)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.arguments import MAX_ANGLE, generator, number, positive_int
from pincal.arguments import angle as _angle
from pincal.arguments import length as _length
from pincal.arguments import point as _point
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, Infeasible
from pincal.kept import REGIONS
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.typing import ArrayLike, ConfigurationsLike, JointValues, PointsLike, TestPoseLike

DEFAULT_SAMPLES = 256
"""Sample configurations of a continuous region."""

IK_TOLERANCE = 1e-9
"""Norm of the SE(3) log of the tip's pose error at which inverse kinematics has converged."""


@dataclass(frozen=True, eq=False)
class ResolvedRegion:
    """A region on one robot.

    Attributes:
        poses: (n, nq) the sample configurations [rad or m], read-only.
        description: a short text, e.g. ``"±10° around the test pose (256 samples)"``.
        dimension: dimension of the region's unit cube (0 for a path: nothing to walk on).
        to_configuration: maps a point u of [0, 1]^dimension to a configuration of the region, or
            None where there is none (inverse kinematics failed); None for a path.
        unit_samples: (n, dimension) the unit-cube points of the samples (None for a path).
        dropped: sample targets without a configuration (Cartesian box).
    """

    poses: np.ndarray
    description: str
    dimension: int = 0
    to_configuration: Callable[[np.ndarray], np.ndarray | None] | None = None
    unit_samples: np.ndarray | None = None
    dropped: int = 0

    @property
    def continuous(self) -> bool:
        """True for a region one can walk on (a neighbourhood, a Cartesian box)."""
        return self.to_configuration is not None


SHARED = REGIONS.size
"""Regions resolved most recently, kept for an equal region made anew (``rho0(params, plan,
around(q0, r))`` in a loop draws the samples once; :data:`pincal.kept.REGIONS`); their samples are
read-only and their draws seeded, so equal regions on one robot resolve to equal samples."""


class TestRegion:
    """Where the robot works: a set of test configurations (see the module doc)."""

    __test__ = False  # not a pytest class

    def resolve(self, robot: Robot) -> ResolvedRegion:
        """The region's sample configurations (and unit-cube map) on ``robot``: resolved once and
        kept while the region's values and the robot's joint limits are those it was resolved
        with (a script that evaluates many plans over one region draws its samples, or solves its
        inverse kinematics, once; an array of the region changed in place is resolved again)."""
        return self.keyed_resolve(robot)[1]

    def keyed_resolve(self, robot: Robot) -> tuple[tuple, ResolvedRegion]:
        """(key, :meth:`resolve`): the key names what the region was resolved from (its kind, its
        values and the robot's joint limits): on one robot, equal keys are equal regions, even
        of two region objects."""
        model = robot.model
        key = (
            type(self).__name__,
            model.lowerPositionLimit.tobytes(),
            model.upperPositionLimit.tobytes(),
            self._values(),
        )
        kept = self.__dict__.setdefault("_resolved", {})  # a cache on the frozen dataclass
        found = kept.get(id(robot))
        if found is not None and found[0] is robot and found[1] == key:
            return key, found[2]
        resolved = REGIONS.get((robot,), key, lambda: self._read_only(robot))  # or an equal region's
        kept[id(robot)] = (robot, key, resolved)
        return key, resolved

    def _read_only(self, robot: Robot) -> ResolvedRegion:
        """:meth:`_resolve`, its unit samples made read-only, as its poses: kept and shared."""
        resolved = self._resolve(robot)
        if resolved.unit_samples is not None:
            resolved.unit_samples.flags.writeable = False
        return resolved

    def _resolve(self, robot: Robot) -> ResolvedRegion:
        raise NotImplementedError

    def _values(self) -> tuple:
        """The region's fields as plain values (an array as its shape, type and bytes), or a new
        object (never equal to a kept one) when one cannot be read as such."""
        out: list = []
        for name in self.__dataclass_fields__:  # type: ignore[attr-defined]  # every region is a dataclass
            value = getattr(self, name)
            value = getattr(value, "q", value)  # a Plan: its joint values
            if isinstance(value, (list, tuple)):
                try:
                    value = np.asarray(value, dtype=float)
                except (TypeError, ValueError):
                    return (object(),)
            if isinstance(value, np.ndarray):
                value = (value.shape, value.dtype.str, value.tobytes())
            out.append(value)
        return tuple(out)


def _latin_hypercube(dimension: int, n: int, seed: int) -> np.ndarray:
    """n points of [0, 1]^dimension, one in each of n equal slices of every axis (seeded)."""
    rng = generator(seed)
    slices = np.argsort(rng.random((dimension, n)), axis=1).T
    return (slices + rng.random((n, dimension))) / max(n, 1)


def _samples(samples: object) -> int:
    return positive_int(samples, "samples")


def width_text(angle: float | None, length: float | None) -> str:
    """'±10°', '±2 cm' or '±10°/±2 cm'."""
    parts = [] if angle is None else [f"±{math.degrees(angle):.3g}°"]
    if length is not None:
        parts.append(f"±{length * 100:.3g} cm" if length < 1 else f"±{length:.3g} m")
    return "/".join(parts)


@dataclass(frozen=True, eq=False)
class Neighbourhood(TestRegion):
    """The joint-space box q0 ± δ (clipped to the joint limits). Build it with :func:`around`.

    Attributes:
        center: (nq,) the test pose q0 [rad or m].
        angle: half-width of the revolute joints [rad], or (nq,) half-widths joint by joint, each
            in its joint's unit [rad or m]; None: no revolute joint may move.
        length: half-width of the prismatic joints [m], or None (with a scalar ``angle``, the
            robot must then have no prismatic joint).
        samples: sample configurations (q0 first).
        seed: seed of the sampling.
    """

    center: np.ndarray
    angle: float | np.ndarray | None
    length: float | None = None
    samples: int = DEFAULT_SAMPLES
    seed: int = 0

    def half_widths(self, robot: Robot) -> np.ndarray:
        """(nq,) δ of each joint of ``robot`` [rad or m]: ``angle`` for the revolute joints,
        ``length`` for the prismatic ones (or the per-joint ``angle``).

        Raises:
            BadArgument: a kind of joint the robot has was given no half-width, or a per-joint
                ``angle`` of the wrong size.
        """
        if isinstance(self.angle, np.ndarray):
            if self.angle.shape != (robot.nq,):
                raise BadArgument(
                    f"around(): {self.angle.size} half-widths for the {robot.nq} joints of {robot.name} "
                    f"({', '.join(robot.joint_names)})"
                )
            return self.angle
        revolute = np.asarray(robot.revolute)
        for kind, value, mask, how in (
            ("revolute", self.angle, revolute, "an angle: around(q0, angle) (--around 10deg)"),
            ("prismatic", self.length, ~revolute, "a length in metres: around(q0, angle, length=0.02) "
             "(--around 10deg,2cm)"),
        ):  # fmt: skip
            if value is None and mask.any():
                names = ", ".join(n for n, k in zip(robot.joint_names, mask) if k)
                raise BadArgument(
                    f"the neighbourhood of the test pose gives no half-width for the {kind} joint(s) "
                    f"{names} of {robot.name}: give {how}",
                    argument="length" if kind == "prismatic" else "angle",
                )
        return np.where(revolute, self.angle or 0.0, self.length or 0.0)

    def bounds(self, robot: Robot) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of the box on ``robot``, within its joint limits."""
        q0 = robot.configurations(self.center, what="test pose")[0]
        delta = self.half_widths(robot)
        return np.maximum(q0 - delta, robot.lower), np.minimum(q0 + delta, robot.upper)

    @property
    def width(self) -> str:
        """The half-width in words: '±10°', '±10°/±2 cm' (revolute/prismatic), or '± δ'."""
        if isinstance(self.angle, np.ndarray):
            return "± δ"
        return width_text(self.angle, self.length)

    def _resolve(self, robot: Robot) -> ResolvedRegion:
        lo, hi = self.bounds(robot)
        q0 = robot.configurations(self.center, what="test pose")[0]
        u = np.vstack(
            [
                (q0 - lo) / np.where(hi > lo, hi - lo, 1.0),
                _latin_hypercube(robot.nq, self.samples - 1, self.seed),
            ]
        )
        poses = lo + u * (hi - lo)
        poses[0] = q0
        poses.flags.writeable = False
        return ResolvedRegion(
            poses,
            f"{self.width} around the test pose ({self.samples} samples)",
            robot.nq,
            lambda u: lo + np.clip(u, 0.0, 1.0) * (hi - lo),
            u,
        )


def around(
    q0: TestPoseLike,
    angle: float | ArrayLike | None = None,
    *,
    length: float | ArrayLike | None = None,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
) -> Neighbourhood:
    """The joint-space neighbourhood q0 ± δ of a test pose (clipped to the joint limits): each
    revolute joint within ±``angle``, each prismatic joint within ±``length``.

    Args:
        q0: (nq,) the test pose [rad or m].
        angle: half-width of the revolute joints [rad]; or (nq,) half-widths joint by joint, each
            in its joint's unit [rad or m] (then no ``length``).
        length: half-width of the prismatic joints [m]; needed when the robot has one.
        samples: configurations the criteria average over (q0 and Latin-hypercube points of the box).
        seed: seed of the sampling.

    Raises:
        PincalError: a half-width that is not positive and finite (up to 1e6 rad or m), samples
            < 1; when the region is used on a robot, a kind of joint it has without a half-width.
    """
    if angle is None and length is None:
        raise BadArgument("around() needs a half-width: angle [rad] and, for prismatic joints, length [m]")
    if angle is not None and np.ndim(angle) == 1:
        if length is not None:
            raise BadArgument("around(): give per-joint half-widths (an array) or angle and length, not both")
        widths = [
            number(d, f"the neighbourhood's half-width of joint {i}", 0.0, MAX_ANGLE, low_open=True)
            for i, d in enumerate(np.asarray(angle, dtype=object))
        ]
        array = np.array(widths)
        array.flags.writeable = False
        checked: float | np.ndarray | None = array
    else:
        checked = None if angle is None else _angle(angle, "the neighbourhood's half-width (angle)")
    size = None if length is None else _length(length, "the neighbourhood's half-width (length)")
    return Neighbourhood(_vector(q0, "q0"), checked, size, _samples(samples), _seed(seed))


def _seed(seed: object) -> int:
    return positive_int(seed, "seed", 0, None)


def _vector(value: object, what: str) -> np.ndarray:
    try:
        return np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise BadArgument(f"{what} must be joint values [rad or m], got {value!r}") from None


@dataclass(frozen=True, eq=False)
class TestPath(TestRegion):
    """Test configurations given one by one, e.g. the poses of a welding or drilling program.

    Read one from CSV like a plan: ``TestPath(pincal.Plan.from_csv("path.csv", robot, what="test
    path"))``. The mean criterion over a path costs the same for 10 or 10 000 points (see
    :func:`pincal.evaluation.test_pose.mean_weight_factor`).

    Attributes:
        q: (n, nq) configurations [rad or m] (or a Plan).
    """

    q: ConfigurationsLike

    def _resolve(self, robot: Robot) -> ResolvedRegion:
        poses = robot.configurations(self.q, what="test path configuration")
        poses.flags.writeable = False
        return ResolvedRegion(poses, f"test path ({len(poses)} configurations)")


@dataclass(frozen=True, eq=False)
class CartesianBox(TestRegion):
    """Configurations whose measured point lies in a box, at the user's tool orientation.
    Build it with :func:`cartesian_box`.

    Attributes:
        lower, upper: (3,) corners of the box of marker 0, in the instrument frame [m].
        reference: (nq,) configuration giving the tool orientation (unless ``rotation`` is given)
            and the inverse-kinematics branch (every solution starts from it).
        rotation: (3, 3) tool (tip frame) orientation in the instrument frame, or None.
        samples: targets drawn in the box.
        seed: seed of the sampling.
    """

    lower: np.ndarray
    upper: np.ndarray
    reference: np.ndarray
    rotation: np.ndarray | None = None
    samples: int = DEFAULT_SAMPLES
    seed: int = 0

    def _resolve(self, robot: Robot) -> ResolvedRegion:
        q_ref = robot.configurations(self.reference, what="reference configuration")[0]
        solver = _InverseKinematics(robot, self.rotation, q_ref)
        lo, hi = np.array(self.lower), np.array(self.upper)  # copies: the region may be shared

        def to_configuration(u: np.ndarray, start: np.ndarray = q_ref) -> np.ndarray | None:
            return solver.solve(lo + np.clip(u, 0.0, 1.0) * (hi - lo), start)

        U = _latin_hypercube(3, self.samples, self.seed)
        solved = [to_configuration(u) for u in U]
        ok = [q is not None for q in solved]
        if not any(ok):
            raise Infeasible(
                f"no configuration puts the measured point in the box {lo.tolist()}..{hi.tolist()} m at "
                f"the tool orientation of the reference configuration (inverse kinematics from it failed "
                f"for all {self.samples} targets); check the box is reachable with that orientation"
            )
        poses = np.array([q for q in solved if q is not None])
        poses.flags.writeable = False
        dropped = len(solved) - len(poses)
        return ResolvedRegion(
            poses,
            f"Cartesian box {np.round(lo, 4).tolist()}..{np.round(hi, 4).tolist()} m at the tool orientation "
            f"({len(poses)} configurations by inverse kinematics"
            + (f", {dropped} unreachable targets dropped)" if dropped else ")"),
            3,
            to_configuration,
            U[np.array(ok)],
            dropped,
        )


@keywords_after(3)
def cartesian_box(
    lower: PointsLike,
    upper: PointsLike,
    reference: JointValues,
    *,
    rotation: ArrayLike | None = None,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
) -> CartesianBox:
    """Configurations whose measured point (marker 0) lies in the box [lower, upper] of the
    instrument frame, with the tool at a fixed orientation (found by inverse kinematics; see the
    module doc).

    Args:
        lower, upper: (3,) corners of the box [m].
        reference: (nq,) configuration whose tip orientation is kept (unless ``rotation``) and from
            which inverse kinematics starts (so the solutions stay on its branch: elbow up, ...).
        rotation: (3, 3) tool orientation in the instrument frame, instead of the reference's.
        samples: targets drawn in the box (Latin hypercube).
        seed: seed of the sampling.
    """
    lo = _point(lower, "the box's lower corner")
    hi = _point(upper, "the box's upper corner")
    if not np.all(hi >= lo):
        raise BadArgument(f"box: need lower <= upper on every axis [m], got {lo.tolist()} and {hi.tolist()}")
    R = None
    if rotation is not None:
        try:
            R = np.array(rotation, dtype=float).reshape(3, 3)
        except (TypeError, ValueError):
            raise BadArgument(f"rotation must be a 3×3 rotation matrix, got {rotation!r}") from None
        if (
            not np.all(np.isfinite(R))
            or not np.allclose(R.T @ R, np.eye(3), atol=1e-6)
            or np.linalg.det(R) < 0
        ):
            raise BadArgument("rotation must be a 3×3 rotation matrix")
    return CartesianBox(lo, hi, _vector(reference, "reference"), R, _samples(samples), _seed(seed))


class _InverseKinematics:
    """Damped least squares on the tip's SE(3) error (Pinocchio's CLIK), within the joint limits,
    on the joints' readings: the tip at the joints' values θ and its Jacobian with respect to the
    reading (:class:`~pincal.model.kinematics.ForwardKinematics`: a calibrated robot's gains and
    compliances included)."""

    def __init__(
        self,
        robot: Robot,
        rotation: np.ndarray | None,
        reference: np.ndarray,
        iterations: int = 200,
        damping: float = 1e-8,
    ) -> None:
        self.robot = robot
        self.forward = ForwardKinematics(robot)
        if rotation is None:  # the tool's orientation at the reference configuration
            R, p = self.forward.tip(np.asarray(reference, dtype=float)[None], instrument=False)
            rotation = (robot.base * pin.SE3(R[0], p[0])).rotation
        self.rotation = np.array(rotation)
        self.iterations = iterations
        self.damping = damping

    def solve(self, point: np.ndarray, start: np.ndarray) -> np.ndarray | None:
        """Joint values putting marker 0 at ``point`` (instrument frame) with the tool at
        ``rotation``; None if not found within the limits."""
        robot, forward = self.robot, self.forward
        tip_position = point - self.rotation @ robot.markers[0]
        # The tip frame's target placement in the robot base frame (the model's world).
        target = robot.base.inverse() * pin.SE3(self.rotation, tip_position)
        offsets = robot.joint_offsets
        lo, hi = robot.lower, robot.upper
        q = np.array(start, dtype=float)
        for _ in range(self.iterations):
            placement, J = forward.frame_jacobian(q)
            error_placement = placement.actInv(target)
            error = pin.log6(error_placement).vector
            if np.linalg.norm(error) < IK_TOLERANCE:
                return q
            J = -pin.Jlog6(error_placement.inverse()) @ J
            step = -J.T @ np.linalg.solve(J @ J.T + self.damping * np.eye(6), error)
            if forward.rigid:
                q = np.clip(pin.integrate(forward.model, q + offsets, step) - offsets, lo, hi)
            else:  # the step is one of the readings
                q = np.clip(pin.integrate(forward.model, q, step), lo, hi)
        return None


def resolve_test_poses(robot: Robot, test_pose: TestPoseLike) -> tuple[np.ndarray, ResolvedRegion | None]:
    """(k, nq) test configurations of a test pose, several of them, or a :class:`TestRegion`;
    and the resolved region (None for plain configurations)."""
    if isinstance(test_pose, TestRegion):
        region = test_pose.resolve(robot)
        return np.array(region.poses), region
    return robot.configurations(test_pose, what="test pose"), None
