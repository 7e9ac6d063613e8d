"""No two links of the chain closer than a distance (the URDF's collision geometry, through
Pinocchio and coal).

The check runs on the search's hot path (every margin evaluation of the continuous search, every
sampled configuration), so a pair is measured by coal only where it can matter: each shape's
bounding sphere (coal's ``aabb_center`` and ``aabb_radius`` about its placement on its joint) gives
a lower bound of the pair's distance for all configurations at once (the joints' placements in one
batch, :meth:`~pincal.model.kinematics.ForwardKinematics.batch_placements`); a pair whose bound is
beyond the search's reach (or beyond the clearance, for the exact check) cannot change the result
and is not measured. What is measured is measured as before (one coal call per pair, the same
requests), so feasibility and the search's steps are unchanged.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint, UrdfError
from pincal.model.collision import touching_at_reference
from pincal.model.geometry import convex_hulls, urdf_geometry
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows
from pincal.model.urdf import few
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, NothingChecked, number


@dataclass(frozen=True)
class SelfCollision(Constraint):
    """No two non-adjacent links of the chain closer than ``min_distance``.

    Uses the URDF's ``<collision>`` geometry (Pinocchio + coal). Pairs of geometries on the same
    link or on two links joined by one joint are not checked, nor pairs already in contact at the
    reference configuration (the zero clipped into the limits: they touch everywhere; the
    campaign's checks leave out the same). The exact test (coal collision with a security margin)
    decides feasibility; the continuous search steers by the distances between the geometries'
    convex hulls, which never exceed the true distances.

    ``SelfCollision(enabled=False)`` among a design's constraints turns the check off (for a robot
    whose collisions are checked elsewhere): the safe defaults then add none
    (:func:`~pincal.planning.constraints.with_safety`; ``--self-collision off`` on the command line).

    Attributes:
        min_distance: clearance kept between links [m] (0: only no contact).
        package_dirs: more folders holding package folders, searched for ``package://NAME/``
            mesh paths as ``DIR/NAME/...`` (the robot's own ``package_dirs`` and the folders
            above the URDF are searched too, as :func:`~pincal.load_robot` searches them).
        optional: check only when the robot has usable collision geometry, else nothing (the safe
            default a design adds, :func:`~pincal.planning.constraints.with_safety`); False: a
            robot without it is refused.
        enabled: False: nothing is checked (the opt-out of the default check).
    """

    min_distance: float = 0.0
    package_dirs: tuple[str, ...] = ()
    optional: bool = False
    enabled: bool = True
    key = "self_collision"

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "min_distance", number(self.min_distance, "self_collision min_distance", 0.0)
        )
        object.__setattr__(self, "package_dirs", tuple(str(p) for p in self.package_dirs))
        if not isinstance(self.enabled, (bool, np.bool_)):
            raise BadConstraint(f"self_collision enabled must be True or False, got {self.enabled!r}")
        object.__setattr__(self, "enabled", bool(self.enabled))

    def bind(self, robot: Robot) -> Bound:
        if not self.enabled:
            return SelfCollisionOff()
        if not self.optional:
            return CollisionBound(robot, self)
        try:
            return CollisionBound(robot, self)
        except (BadConstraint, RuntimeError):  # no usable geometry (coal: a mesh it cannot take)
            return NoCollisionGeometry()


class NoCollisionGeometry(NothingChecked):
    """The optional self-collision check of a robot without usable collision geometry: nothing."""


class SelfCollisionOff(NothingChecked):
    """The self-collision check turned off (``SelfCollision(enabled=False)``): nothing."""


CULL_SLACK = 1e-3
"""Room [m] left beyond a pair's threshold before its bounding spheres rule it out: far more than
coal's own tolerance and the rounding of the batched placements, so a pair left out could never
have changed a result."""


def memoryless(request: object) -> None:
    """A coal request that starts every GJK from its default guess, not from the pair's previous
    call: a pair's distance is then a function of the configuration alone, whichever pairs and
    configurations were measured before (and in whatever order a worker met them)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # coal's older name of the switch
        request.enable_cached_gjk_guess = False  # type: ignore[attr-defined]


class Spheres:
    """Each shape of a geometry model within a sphere fixed on its joint (coal's bounding sphere of
    the shape: ``aabb_center``, ``aabb_radius``), and the lower bound that two spheres give of the
    distance of the pairs ``pairs`` at many configurations at once."""

    def __init__(self, geom: pin.GeometryModel, pairs: list[tuple[int, int]]) -> None:
        centres, radii, joints = [], [], []
        for obj in geom.geometryObjects:
            obj.geometry.computeLocalAABB()
            centres.append(obj.placement.act(np.asarray(obj.geometry.aabb_center, dtype=float)))
            radii.append(float(obj.geometry.aabb_radius))
            joints.append(obj.parentJoint)
        self.centres, self.joints = np.array(centres).reshape(-1, 3), np.array(joints, dtype=int)
        a, b = (np.array(side, dtype=int) for side in zip(*pairs, strict=True))
        self.a, self.b = a, b
        self.radii = np.array(radii)[a] + np.array(radii)[b]

    def lower_bounds(self, rotations: np.ndarray, translations: np.ndarray) -> np.ndarray:
        """(m, pairs) a lower bound of each pair's distance [m], from the joints' placements
        (:meth:`~pincal.model.kinematics.ForwardKinematics.batch_placements`: (njoints, m, 3, 3),
        (njoints, m, 3))."""
        placed = np.einsum("smij,sj->msi", rotations[self.joints], self.centres)
        placed += translations[self.joints].transpose(1, 0, 2)
        return np.linalg.norm(placed[:, self.a] - placed[:, self.b], axis=2) - self.radii


def collision_geometry(robot: Robot, package_dirs: tuple[str, ...], what: str) -> pin.GeometryModel:
    """The chain's collision geometry from its URDF (Pinocchio's geometry model, meshes found as
    :func:`~pincal.load_robot` finds them).

    Raises:
        BadConstraint: no URDF, an unreadable one, or mesh files not found, in one line naming the
            constraint ``what``.
    """
    if robot.urdf_path is None:
        raise BadConstraint(f"{what} needs the robot's URDF (load the robot from a URDF file or name)")
    try:
        loaded = urdf_geometry(robot, pin.COLLISION, package_dirs)
    except UrdfError as exc:
        raise BadConstraint(f"{what}: {exc}") from None
    if loaded.missing:
        raise BadConstraint(
            f"{what}: {len(loaded.missing)} collision mesh file(s) of {Path(robot.urdf_path).name} not "
            f"found ({few(loaded.missing)}); give --package-dir NAME=PATH (load_robot's package_dirs) "
            f"to find them"
        )
    return loaded.model


class CollisionBound(Bound):
    reach = 0.02

    def __init__(self, robot: Robot, spec: SelfCollision) -> None:
        geom = collision_geometry(robot, spec.package_dirs, "self_collision")
        assert robot.urdf_path is not None  # collision_geometry refuses a robot without one
        urdf, model = Path(robot.urdf_path), robot.model
        objects = geom.geometryObjects
        pairs = []
        for a in range(len(objects)):
            for b in range(a + 1, len(objects)):
                ja, jb = objects[a].parentJoint, objects[b].parentJoint
                if ja == jb or model.parents[ja] == jb or model.parents[jb] == ja:
                    continue
                pairs.append((a, b))
        if not pairs:
            raise BadConstraint(
                f"self_collision: the URDF {urdf.name} has no collision geometry on non-adjacent links"
            )
        hulls = convex_hulls(geom)  # fast, smooth distances that never exceed the true ones
        touching = touching_at_reference(robot, hulls, pairs)
        self.skipped = [
            (objects[a].name, objects[b].name) for (a, b), t in zip(pairs, touching, strict=True) if t
        ]
        pairs = [p for p, t in zip(pairs, touching, strict=True) if not t]
        if not pairs:
            raise BadConstraint(
                f"self_collision: every pair of non-adjacent links of {urdf.name} is in contact at the "
                "zero configuration: nothing to check"
            )
        for a, b in pairs:
            geom.addCollisionPair(pin.CollisionPair(a, b))
            hulls.addCollisionPair(pin.CollisionPair(a, b))
        self.names = [(objects[a].name, objects[b].name) for a, b in pairs]
        self.model, self.forward = model, ForwardKinematics(robot)
        self.data = self.forward.data
        self.exact, self.exact_data = geom, geom.createData()
        for request in self.exact_data.collisionRequests:
            request.security_margin = spec.min_distance
        self.hulls, self.hull_data = hulls, hulls.createData()
        self.min_distance = spec.min_distance
        for request in [*self.hull_data.distanceRequests, *self.exact_data.collisionRequests]:
            memoryless(request)
        self.hull_spheres, self.exact_spheres = Spheres(hulls, pairs), Spheres(geom, pairs)

    def margins(self, kin: Kinematics) -> np.ndarray:
        """(m, pairs) the convex hulls' distances less ``min_distance`` [m]; a pair whose bounding
        spheres are farther apart than the reach (and the slack) gets the spheres' bound, a lower
        bound of its distance beyond the reach, where the search reads 1 either way."""
        thetas = self.forward.joint_values(kin.qs, kin.payload)
        out = self.hull_spheres.lower_bounds(*self.forward.batch_placements(thetas))
        near = out < self.min_distance + self.reach + CULL_SLACK
        model, data, hulls, hull_data = self.model, self.data, self.hulls, self.hull_data
        for i in np.flatnonzero(near.any(axis=1)):
            pin.updateGeometryPlacements(model, data, hulls, hull_data, thetas[i])
            for k in np.flatnonzero(near[i]).tolist():
                out[i, k] = pin.computeDistance(hulls, hull_data, k).min_distance
        return out - self.min_distance

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        """(m,) True where no pair's meshes are closer than ``min_distance`` (coal's collision
        test with that security margin, on the pairs whose bounding spheres come that close)."""
        model, data, geom, gdata = self.model, self.data, self.exact, self.exact_data
        thetas = self.forward.joint_values(kin.qs, kin.payload)
        bounds = self.exact_spheres.lower_bounds(*self.forward.batch_placements(thetas))
        near = bounds <= self.min_distance + CULL_SLACK
        ok = np.ones(len(thetas), dtype=bool)
        for i in np.flatnonzero(near.any(axis=1)):
            pin.updateGeometryPlacements(model, data, geom, gdata, thetas[i])
            ok[i] = not any(pin.computeCollision(geom, gdata, k) for k in np.flatnonzero(near[i]).tolist())
        return ok

    def colliding_pairs(self, q: np.ndarray, payload: PayloadRows = None) -> list[tuple[str, str]]:
        """Names of the geometry pairs in collision at one configuration (reading)."""
        theta = self.forward.joint_values(np.asarray(q, dtype=float)[None], payload)[0]
        pin.computeCollisions(self.model, self.data, self.exact, self.exact_data, theta, False)
        results = self.exact_data.collisionResults
        return [n for n, r in zip(self.names, results, strict=True) if r.isCollision()]
