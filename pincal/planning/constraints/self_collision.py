"""No two links of the chain closer than a distance (the URDF's collision geometry, through
Pinocchio and coal)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint, UrdfError
from pincal.model.collision import touching_at_reference
from pincal.model.geometry import convex_hulls, urdf_geometry
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.urdf import few
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, NothingChecked, number
from pincal.typing import PayloadLike


@dataclass(frozen=True)
class SelfCollision(Constraint):
    """No two non-adjacent links of the chain closer than ``min_distance``.

    Uses the URDF's ``<collision>`` geometry (Pinocchio + coal). Pairs of geometries on the same
    link or on two links joined by one joint are not checked, nor pairs already in contact at the
    reference configuration (the zero clipped into the limits: they touch everywhere; the
    campaign's checks leave out the same). The exact test (coal collision with a security margin)
    decides feasibility; the continuous search steers by the distances between the geometries'
    convex hulls, which never exceed the true distances.

    Attributes:
        min_distance: clearance kept between links [m] (0: only no contact).
        package_dirs: more folders holding package folders, searched for ``package://NAME/``
            mesh paths as ``DIR/NAME/...`` (the robot's own ``package_dirs`` and the folders
            above the URDF are searched too, as :func:`~pincal.load_robot` searches them).
        optional: check only when the robot has usable collision geometry, else nothing (the safe
            default a design adds, :func:`~pincal.planning.constraints.with_safety`); False: a
            robot without it is refused.
    """

    min_distance: float = 0.0
    package_dirs: tuple[str, ...] = ()
    optional: bool = False
    key = "self_collision"

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "min_distance", number(self.min_distance, "self_collision min_distance", 0.0)
        )
        object.__setattr__(self, "package_dirs", tuple(str(p) for p in self.package_dirs))

    def bind(self, robot: Robot) -> Bound:
        if not self.optional:
            return CollisionBound(robot, self)
        try:
            return CollisionBound(robot, self)
        except (BadConstraint, RuntimeError):  # no usable geometry (coal: a mesh it cannot take)
            return NoCollisionGeometry()


class NoCollisionGeometry(NothingChecked):
    """The optional self-collision check of a robot without usable collision geometry: nothing."""


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

    def margins(self, kin: Kinematics) -> np.ndarray:
        out = np.empty((len(kin.qs), len(self.names)))
        for i, theta in enumerate(self.forward.joint_values(kin.qs, kin.payload)):
            pin.updateGeometryPlacements(self.model, self.data, self.hulls, self.hull_data, theta)
            pin.computeDistances(self.hulls, self.hull_data)
            out[i] = [r.min_distance for r in self.hull_data.distanceResults]
        return out - self.min_distance

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        model, data, geom, gdata = self.model, self.data, self.exact, self.exact_data
        thetas = self.forward.joint_values(kin.qs, kin.payload)
        return np.array(
            [not pin.computeCollisions(model, data, geom, gdata, theta, True) for theta in thetas], dtype=bool
        )

    def colliding_pairs(self, q: np.ndarray, payload: PayloadLike = None) -> list[tuple[str, str]]:
        """Names of the geometry pairs in collision at one configuration (reading)."""
        theta = self.forward.joint_values(np.asarray(q, dtype=float)[None], payload)[0]
        pin.computeCollisions(self.model, self.data, self.exact, self.exact_data, theta, False)
        results = self.exact_data.collisionResults
        return [n for n, r in zip(self.names, results, strict=True) if r.isCollision()]
