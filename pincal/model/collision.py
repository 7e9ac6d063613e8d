"""The robot and its cell as Pinocchio collision models (coal), with what a motion check needs.

:func:`robot_geometry` gives the robot's collision geometry on its chain: the URDF's
``<collision>`` shapes and meshes when it has them (and they are found), else **capsules derived
from the kinematics** — one between consecutive joint origins on each link (a sphere where two
origins coincide, as at a spherical wrist), a column from the base to the first joint, and a thin
one from the tip to each marker — of radius :data:`LINK_RADIUS` times the robot's reach unless
given. Which was used is :attr:`RobotGeometry.source`, and every report says it.

:class:`CollisionWorld` puts that geometry with the cell's obstacles into one
``pinocchio.GeometryModel`` and lists the pairs to check:

* robot / obstacle: every robot shape the joints move, against every obstacle;
* robot / robot (``self_collision=True``): shapes on two links not joined by one joint (with
  capsules, at least three joints apart: closer links are kept apart by the joint limits their
  maker set, which the capsules' rough outline would not respect), and not already in contact at
  the reference configuration (the zero configuration clipped into the limits: shapes that touch
  there, like two capsules meeting at a wrist, touch everywhere);
* the floor (a :class:`~pincal.planning.constraints.mount.Mount`): the points the mount checks.

Everything is placed by the robot's forward kinematics (:mod:`pincal.model.kinematics`): at the
joints' values θ, with the robot's joint gains and compliances under the payload, so that a
calibrated robot is checked with its calibrated kinematics.

:meth:`CollisionWorld.distances` gives one distance per pair [m] at a configuration, a lower
bound of the true distance: meshes are first replaced by their convex hulls, which contain them
(fast), and a pair whose hulls come closer than :data:`REFINE_BELOW` is measured again on the
meshes themselves (exact, a few milliseconds per pair); and
:attr:`CollisionWorld.weights` the motion bound of each pair: along a straight joint-space move
of Δq, no point of the pair's moving shape moves farther, relative to the other, than
Σⱼ weights[pair, j]·|Δqⱼ| [m]. For a shape on link k, joint j ≤ k contributes the largest
distance of the shape from joint j's axis (bounded by the link lengths between them plus the
shape's radius around its own joint), or 1 for a prismatic joint; a self pair counts only the
joints between its two links (Schwarzer, Saha & Latombe, IEEE T-RO 2005). These bound the motion
for a move of the joints' values; with gains or compliances the readings' move is mapped onto
them (:meth:`~pincal.model.kinematics.ForwardKinematics.motion_scale`: |Δθ| ≤ S |Δq|, weights·S).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import pinocchio as pin

from pincal.errors import UrdfError
from pincal.model.geometry import convex_hull, urdf_geometry
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows


class FloorPoints(Protocol):
    """The points a mount keeps above its plane (a bound
    :class:`~pincal.planning.constraints.mount.MountBound`)."""

    keep: np.ndarray
    """Indices of the checked points among the joint origins, the tip and the markers."""
    joints: list[int]
    """The Pinocchio joints whose origins are candidates."""
    names: list[str]
    """What each checked point is."""

    def heights(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, kept) the checked points' heights above the plane [m] at the readings ``qs``."""
        ...


LINK_RADIUS = 0.04
"""Radius of the capsules derived from the kinematics, as a fraction of the robot's reach (the sum
of its link offsets: 0.14 m for the KR 270, 0.08 m for a UR10)."""

REFINE_BELOW = 0.05
"""Mesh pairs whose convex hulls are closer than this [m] are measured again on the meshes."""


TOUCHING = 1e-6
"""How far apart [m] two meshes that coal finds in contact are reported, at most: negative, so
that a contact is never taken for a clearance of 0 (coal gives 0, not a depth, for meshes that
intersect)."""


def with_exact(hull: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """The distances of mesh pairs from their convex hulls' (``hull``, a lower bound, signed) and
    the meshes' own (``exact``, 0 when they intersect) [m]: the meshes' where they are apart, else
    negative (the hulls' depth, at least :data:`TOUCHING`)."""
    return np.where(exact > 0, np.maximum(hull, exact), np.minimum(hull, -TOUCHING))


MARKER_RADIUS = 0.25
"""Radius of the capsule from the tip to a marker, as a fraction of the link radius."""


def reach(robot: Robot) -> float:
    """A length scale of the robot [m]: the sum of its link offsets and the farthest marker."""
    model = robot.model
    links = sum(np.linalg.norm(model.jointPlacements[j].translation) for j in range(1, model.njoints))
    tip = model.frames[robot.tip_frame].placement
    markers = np.linalg.norm(robot.markers @ tip.rotation.T + tip.translation, axis=1).max()
    return float(max(links + markers, 1e-3))


@dataclass(frozen=True, eq=False)
class RobotGeometry:
    """The robot's collision geometry on its chain.

    Attributes:
        model: the shapes, attached to the robot's joints (joint 0: the base).
        source: what they are, in words (for reports).
        capsules: True when derived from the kinematics.
        link_radius: the capsules' radius [m] (None for URDF geometry).
    """

    model: pin.GeometryModel
    source: str
    capsules: bool
    link_radius: float | None = None


def _body_name(model: pin.Model, joint: int) -> str:
    for frame in model.frames:
        if frame.type == pin.BODY and frame.parentJoint == joint:
            return frame.name
    return model.names[joint]


def segment_placement(start: object, end: object) -> tuple[pin.SE3, float]:
    """(placement, length [m]) of a shape along the segment from ``start`` to ``end``: centred on
    it, its z axis along it (coal's capsules and cylinders lie along z)."""
    a, b = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    length = float(np.linalg.norm(b - a))
    if length < 1e-9:
        return pin.SE3(np.eye(3), a.copy()), 0.0
    rotation = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), (b - a) / length).toRotationMatrix()
    return pin.SE3(rotation, 0.5 * (a + b)), length


def capsule_geometry(robot: Robot, radius: float) -> pin.GeometryModel:
    """Capsules of ``radius`` [m] between consecutive joint origins (see the module doc)."""
    import coal

    model = robot.model
    geom = pin.GeometryModel()

    def segment(name: str, joint: int, start: np.ndarray, end: np.ndarray, r: float) -> None:
        placement, length = segment_placement(start, end)
        shape = coal.Capsule(r, length) if length > 0 else coal.Sphere(r)
        geom.addGeometryObject(pin.GeometryObject(name, joint, placement, shape))

    origin = np.zeros(3)
    segment(f"{_body_name(model, 0)} (capsule)", 0, origin, model.jointPlacements[1].translation, radius)
    tip = model.frames[robot.tip_frame].placement
    for j in range(1, model.njoints):
        end = model.jointPlacements[j + 1].translation if j + 1 < model.njoints else tip.translation
        segment(f"{_body_name(model, j)} (capsule)", j, origin, end, radius)
    for k, marker in enumerate(robot.markers):
        segment(
            f"marker {k} (capsule)", robot.tip_joint, tip.translation, tip * marker, MARKER_RADIUS * radius
        )
    return geom


def robot_geometry(
    robot: Robot, link_radius: float | None = None, search: Iterable[str] = ()
) -> RobotGeometry:
    """The URDF's collision geometry of ``robot``'s chain, or capsules when it has none (or when
    some of its meshes cannot be found): see the module doc.

    Args:
        robot: the robot.
        link_radius: the capsules' radius [m] (default :data:`LINK_RADIUS` × reach).
        search: more folders holding package folders, for ``package://`` mesh paths.
    """
    why = "the URDF has no collision geometry"
    if robot.urdf_path is not None:
        try:
            loaded = urdf_geometry(robot, pin.COLLISION, search)
        except UrdfError as exc:
            loaded, why = None, f"the URDF's collision geometry cannot be read ({exc})"
        if loaded is not None and loaded.missing:
            why = f"{len(loaded.missing)} collision mesh file(s) cannot be found"
        elif loaded is not None and any(o.parentJoint > 0 for o in loaded.model.geometryObjects):
            return RobotGeometry(loaded.model, "the URDF's collision geometry", False)
    else:
        why = "the robot has no URDF"
    radius = LINK_RADIUS * reach(robot) if link_radius is None else float(link_radius)
    source = f"capsules of radius {radius * 1e3:.3g} mm between the joint origins ({why})"
    return RobotGeometry(capsule_geometry(robot, radius), source, True, radius)


def _extent(obj: pin.GeometryObject) -> float:
    """Largest distance [m] of any point of ``obj`` from its joint's origin (a bound: the corners
    of its local bounding box, placed)."""
    geometry = obj.geometry
    geometry.computeLocalAABB()
    lo, hi = np.array(geometry.aabb_local.min_), np.array(geometry.aabb_local.max_)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    placed = corners @ obj.placement.rotation.T + obj.placement.translation
    return float(np.linalg.norm(placed, axis=1).max())


def motion_weights(robot: Robot, joint: int, extent: float, after: int = 0) -> np.ndarray:
    """(nq,) w with ‖δp‖ ≤ Σⱼ wⱼ|Δqⱼ| for every point within ``extent`` [m] of joint ``joint``'s
    origin on a straight joint-space move, relative to link ``after`` (0: the base): joint j ≤
    ``after`` contributes nothing, a prismatic joint 1, a revolute joint j the largest distance
    of the point from its axis, bounded by the link lengths from j to ``joint`` plus ``extent``."""
    model = robot.model
    w = np.zeros(robot.nq)
    if joint == 0:
        return w
    travel = np.maximum(np.abs(model.lowerPositionLimit), np.abs(model.upperPositionLimit))
    if robot.joint_gains.any():
        travel = travel * np.abs(1.0 + robot.joint_gains)
    travel = travel + np.abs(robot.joint_offsets)
    # lengths[i]: how far joint i's origin can be from joint i-1's (placement, plus a slide).
    lengths = np.zeros(model.njoints)
    for i in range(1, model.njoints):
        lengths[i] = np.linalg.norm(model.jointPlacements[i].translation)
        if not robot.revolute[i - 1]:
            lengths[i] += travel[i - 1]
    for j in range(max(after, 0) + 1, joint + 1):
        w[j - 1] = 1.0 if not robot.revolute[j - 1] else lengths[j + 1 : joint + 1].sum() + extent
    return w


def touching_at_reference(
    robot: Robot, geom: pin.GeometryModel, pairs: Sequence[tuple[int, int]]
) -> list[bool]:
    """For each pair of shapes of ``geom`` (on ``robot``'s joints), whether they touch or overlap at
    the reference configuration (the zero clipped into the joint limits): such a pair, like two
    shapes meeting at a wrist, touches everywhere and is not checked."""
    import coal

    reference = np.clip(np.zeros(robot.nq), robot.model.lowerPositionLimit, robot.model.upperPositionLimit)
    gdata = geom.createData()
    ForwardKinematics(robot).place_geometry(geom, gdata, reference)
    out = []
    for a, b in pairs:
        request, result = coal.DistanceRequest(), coal.DistanceResult()
        d = coal.distance(
            geom.geometryObjects[a].geometry,
            coal.Transform3s(gdata.oMg[a].rotation, gdata.oMg[a].translation),
            geom.geometryObjects[b].geometry,
            coal.Transform3s(gdata.oMg[b].rotation, gdata.oMg[b].translation),
            request,
            result,
        )
        out.append(bool(d <= 1e-9))
    return out


@dataclass(frozen=True)
class Pair:
    """Two shapes whose distance is checked.

    Attributes:
        a: the robot's shape (index in the world's geometry model).
        b: the other shape (robot or obstacle).
        kind: ``self`` or ``obstacle``.
        name: ``link_4 (capsule) / table``.
    """

    a: int
    b: int
    kind: str
    name: str


def _pair_weights(robot: Robot, objects, n_robot: int, pairs: list[Pair]) -> list[np.ndarray]:
    """The motion weights of each pair (:func:`motion_weights`): those of the robot's shape against
    an obstacle; for two shapes of the robot, only those of the joints between their links."""
    extents = [_extent(o) for o in objects[:n_robot]]
    weights = []
    for p in pairs:
        ja, jb = objects[p.a].parentJoint, objects[p.b].parentJoint
        if p.kind == "obstacle":
            weights.append(motion_weights(robot, ja, extents[p.a]))
        else:  # relative motion: only the joints between the two links move one against the other
            low, high = (p.a, p.b) if ja <= jb else (p.b, p.a)
            jl, jh = objects[low].parentJoint, objects[high].parentJoint
            weights.append(motion_weights(robot, jh, extents[high], after=jl))
    return weights


class CollisionWorld:
    """The robot's collision geometry with the cell's obstacles, and the floor (see the module doc).

    Holds Pinocchio/coal data: one per thread or process.

    Args:
        robot: the robot.
        obstacles: ``pin.GeometryObject`` s of the cell, placed in the robot's base frame.
        self_collision: check pairs of the robot's own shapes.
        mount_points: a bound :class:`~pincal.planning.constraints.mount.MountBound` whose points
            are checked against its plane (:class:`FloorPoints`), or None.
        link_radius: the capsules' radius [m] when the URDF has no collision geometry.
        search: more folders for ``package://`` mesh paths.
        payload: what the robot carries during the checks, one payload row (1, 4) [kg, x, y, z]
            (:func:`~pincal.model.statics.payload_rows`; default none): it matters on a robot with
            joint compliances, whose joints yield to it.
    """

    def __init__(
        self,
        robot: Robot,
        obstacles: Sequence[pin.GeometryObject] = (),
        *,
        self_collision: bool = True,
        mount_points: FloorPoints | None = None,
        link_radius: float | None = None,
        search: Iterable[str] = (),
        payload: PayloadRows = None,
    ) -> None:
        import coal

        self.robot, self.payload = robot, payload
        self.geometry = robot_geometry(robot, link_radius, search)
        geom, exact = pin.GeometryModel(), pin.GeometryModel()
        mesh = []
        shapes = [o.copy() for o in self.geometry.model.geometryObjects]
        self.n_robot = len(shapes)
        for obj in obstacles:
            obj = obj.copy()
            obj.parentJoint = 0
            shapes.append(obj)
        for obj in shapes:
            exact.addGeometryObject(obj.copy())
            mesh.append(isinstance(obj.geometry, coal.BVHModelBase))
            if mesh[-1]:  # a mesh: its convex hull, a lower bound of its distances
                obj.geometry = convex_hull(obj.geometry, obj.name)
            geom.addGeometryObject(obj)
        objects = geom.geometryObjects
        self.model, self.forward = robot.model, ForwardKinematics(robot)
        parents = robot.model.parents
        pairs: list[Pair] = []
        for a in range(self.n_robot):
            ja = objects[a].parentJoint
            if ja == 0:
                continue  # the base never moves: its distance to the cell is not the plan's
            for b in range(self.n_robot, geom.ngeoms):
                pairs.append(Pair(a, b, "obstacle", f"{objects[a].name} / {objects[b].name}"))
        self.skipped: list[str] = []
        if self_collision:
            candidates = []
            for a in range(self.n_robot):
                for b in range(a + 1, self.n_robot):
                    ja, jb = objects[a].parentJoint, objects[b].parentJoint
                    if ja == jb or parents[ja] == jb or parents[jb] == ja:
                        continue
                    if self.geometry.capsules and abs(ja - jb) < 3:
                        continue
                    candidates.append(Pair(a, b, "self", f"{objects[a].name} / {objects[b].name}"))
            touching = self._touching_at_reference(geom, candidates)
            self.skipped = [p.name for p, t in zip(candidates, touching, strict=True) if t]
            pairs += [p for p, t in zip(candidates, touching, strict=True) if not t]
        for p in pairs:
            geom.addCollisionPair(pin.CollisionPair(p.a, p.b))
            exact.addCollisionPair(pin.CollisionPair(p.a, p.b))
        self.geom, self.gdata = geom, geom.createData()
        self.exact, self.exact_data = exact, exact.createData()
        self.meshes = np.array(mesh, dtype=bool)  # which shapes are meshes (checked by their hulls first)
        self.refinable = np.array([mesh[p.a] or mesh[p.b] for p in pairs], dtype=bool)
        self.pairs = pairs
        weights = _pair_weights(robot, objects, self.n_robot, pairs)
        self.mount = mount_points
        points = []
        if mount_points is not None and len(mount_points.keep):
            radius = self._point_extents(mount_points)
            points = [motion_weights(robot, j, r) for j, r in radius]
        self.n_points = len(points)
        self._joint_weights = np.array(weights + points).reshape(-1, robot.nq)
        self.weights = self.weights_under(payload)
        self.names = [p.name for p in pairs] + [f"{n} / floor" for n in getattr(mount_points, "names", [])]
        self.kinds = [p.kind for p in pairs] + ["floor"] * self.n_points

    def weights_under(self, payload: PayloadRows) -> np.ndarray:
        """(size, nq) the motion weights of the readings while the robot carries ``payload`` (None,
        or (r, 4) rows [kg, x, y, z]: under any of them): the weights bound
        a move of θ, mapped onto that of the readings
        (:meth:`~pincal.model.kinematics.ForwardKinematics.motion_scale`)."""
        scale = self.forward.motion_scale(payload)
        return self._joint_weights if scale is None else self._joint_weights @ scale

    def _point_extents(self, mount: FloorPoints) -> list[tuple[int, float]]:
        """(joint, distance from its origin [m]) of each point the mount checks."""
        robot = self.robot
        tip = robot.model.frames[robot.tip_frame].placement
        out = []
        for i in mount.keep:
            if i < len(mount.joints):
                out.append((mount.joints[i], 0.0))
            elif i == len(mount.joints):
                out.append((robot.tip_joint, float(np.linalg.norm(tip.translation))))
            else:
                marker = robot.markers[i - len(mount.joints) - 1]
                out.append((robot.tip_joint, float(np.linalg.norm(tip * marker))))
        return out

    def _touching_at_reference(self, geom: pin.GeometryModel, candidates: list[Pair]) -> list[bool]:
        return touching_at_reference(self.robot, geom, [(p.a, p.b) for p in candidates])

    @property
    def size(self) -> int:
        """Number of distances per configuration (pairs, then floor points)."""
        return len(self.pairs) + self.n_points

    def distances(self, q: np.ndarray, refine: bool = True, payload: PayloadRows = None) -> np.ndarray:
        """(size,) distances [m] at the reading ``q`` (lower bounds; ≤ 0 when shapes touch or
        overlap, negative when a point is below the floor); ``refine=False``: convex hulls only;
        ``payload``: the one carried (default the world's)."""
        payload = self.payload if payload is None else payload
        return self._distances(q, self.forward.joint_values(q[None], payload)[0], refine, payload)

    def _distances(self, q: np.ndarray, theta: np.ndarray, refine: bool, payload: PayloadRows) -> np.ndarray:
        """:meth:`distances` at the reading ``q`` whose joints stand at ``theta``."""
        out = np.empty(self.size)
        if self.pairs:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                pin.updateGeometryPlacements(self.model, self.forward.data, self.geom, self.gdata, theta)
                pin.computeDistances(self.geom, self.gdata)
            out[: len(self.pairs)] = [r.min_distance for r in self.gdata.distanceResults]
            if refine:
                near = np.flatnonzero(self.refinable & (out[: len(self.pairs)] < REFINE_BELOW))
                out[near] = with_exact(out[near], self._exact(theta, near))
        if self.n_points:
            assert self.mount is not None  # n_points counts the mount's points
            out[len(self.pairs) :] = self.mount.heights(q[None], payload)[0]
        return out

    def exact_distances(self, q: np.ndarray, pairs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """Distances [m] of the given pairs (indices below ``len(self.pairs)``) at the reading
        ``q``, on the meshes themselves rather than their hulls (a few milliseconds per mesh pair)."""
        pairs = np.asarray(pairs, dtype=int)
        if not len(pairs):
            return np.empty(0)
        payload = self.payload if payload is None else payload
        return self._exact(self.forward.joint_values(q[None], payload)[0], pairs)

    def _exact(self, theta: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        if not len(pairs):
            return np.empty(0)
        pin.updateGeometryPlacements(self.model, self.forward.data, self.exact, self.exact_data, theta)
        out = np.empty(len(pairs))
        for i, k in enumerate(pairs):
            pin.computeDistance(self.exact, self.exact_data, int(k))
            out[i] = self.exact_data.distanceResults[int(k)].min_distance
        return out

    def distances_many(self, qs: np.ndarray, refine: bool = True, payload: PayloadRows = None) -> np.ndarray:
        """(m, size) :meth:`distances` at each of the readings ``qs`` (``payload``: (m, 4) the row
        of each configuration; default the world's)."""
        loads = payload
        if loads is None and self.payload is not None:
            loads = np.repeat(self.payload, len(qs), axis=0)
        thetas = self.forward.joint_values(qs, loads)
        out = [
            self._distances(q, theta, refine, None if loads is None else loads[i : i + 1])
            for i, (q, theta) in enumerate(zip(qs, thetas, strict=True))
        ]
        return np.array(out).reshape(len(qs), self.size)

    def placements(self, q: np.ndarray, payload: PayloadRows = None) -> list[pin.SE3]:
        """Placement of every shape at the reading ``q`` (robot shapes, then obstacles), base frame."""
        payload = self.payload if payload is None else payload
        self.forward.place_geometry(self.geom, self.gdata, q, payload)
        return [pin.SE3(m) for m in self.gdata.oMg]
