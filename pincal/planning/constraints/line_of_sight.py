"""Nothing of the robot crosses the instrument's line of sight to a marker (the URDF's collision
geometry, through Pinocchio and coal; docs/method.md §13.4)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint
from pincal.model.geometry import convex_hulls
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number, vector
from pincal.planning.constraints.self_collision import collision_geometry


@dataclass(frozen=True)
class LineOfSight(Constraint):
    """The instrument at ``instrument`` sees every marker: no collision geometry of the chain
    comes closer than ``clearance`` to the segment from the instrument to the marker.

    The last ``skip`` of the segment, at the marker, is not checked (the marker sits on the tool's
    surface). The distances are to the geometries' convex hulls (coal): never more than the true
    ones, so a configuration kept is clear.

    Attributes:
        instrument: (x, y, z) the instrument's position in the instrument's frame [m].
        clearance: the sight line's radius [m] (the beam and a margin).
        skip: the length of the segment left unchecked at the marker [m].
        package_dirs: more folders holding package folders (as :class:`SelfCollision`'s).
    """

    instrument: tuple[float, float, float]
    clearance: float = 0.01
    skip: float = 0.05
    package_dirs: tuple[str, ...] = ()
    key = "line_of_sight"

    def __post_init__(self) -> None:
        object.__setattr__(self, "instrument", vector(self.instrument, "line_of_sight instrument"))
        object.__setattr__(self, "clearance", number(self.clearance, "line_of_sight clearance", 0.0))
        object.__setattr__(self, "skip", number(self.skip, "line_of_sight skip", 0.0))
        object.__setattr__(self, "package_dirs", tuple(str(p) for p in self.package_dirs))

    def bind(self, robot: Robot) -> Bound:
        return SightBound(robot, self)


def hull_geometry(robot: Robot, package_dirs: tuple[str, ...], what: str) -> pin.GeometryModel:
    """The convex hulls of the chain's collision geometry (one object per URDF ``<collision>``).

    Raises:
        BadConstraint: no URDF, no collision geometry, or meshes not found (``what`` names the
            constraint).
    """
    geometry = collision_geometry(robot, package_dirs, what)
    if not geometry.geometryObjects:
        raise BadConstraint(f"{what}: the URDF of {robot.name} has no collision geometry to check")
    return convex_hulls(geometry)


class SightBound(Bound):
    """The line of sight bound to a robot: the margins of every (configuration, marker, hull).

    The continuous search and the feasibility checks read a margin only below :attr:`reach` (and
    its sign), so a hull that a cheap bound keeps at least :attr:`reach` from a sight line is not
    passed to coal: spheres covering its bounding box (along the box's longest axis) give a lower
    bound on its distance to the segment, and that bound is its margin. Each configuration's
    hulls are placed once (Pinocchio), the segments of every marker are built at once (NumPy),
    and coal measures only the pairs within reach of a sphere.
    """

    reach = 0.02

    def __init__(self, robot: Robot, spec: LineOfSight) -> None:
        import coal

        self.coal = coal
        self.hulls = hull_geometry(robot, spec.package_dirs, "line_of_sight")
        self.hull_data = self.hulls.createData()
        self.model, self.forward = robot.model, ForwardKinematics(robot)
        self.base_inverse = robot.base.inverse()
        self.instrument = self.base_inverse.act(np.array(spec.instrument))  # in the robot's base frame
        self.spec = spec
        self.request = coal.DistanceRequest()
        self.radius = max(spec.clearance, 1e-6)  # the sight capsule's
        self.spheres = [_covering_spheres(obj.geometry) for obj in self.hulls.geometryObjects]

    def _segments(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The sight lines to ``points`` (..., 3) (robot base frame): (lengths, directions,
        rotations (..., 3, 3) whose z is the direction, centres); a length ≤ 0 when the instrument
        is within ``skip`` of the point (nothing to check)."""
        axis = points - self.instrument
        norm = np.linalg.norm(axis, axis=-1)
        length = norm - self.spec.skip
        z = axis / np.where(norm > 0, norm, 1.0)[..., None]
        helper = np.eye(3)[np.argmin(np.abs(z), axis=-1)]
        x = np.cross(helper, z)
        x /= np.linalg.norm(x, axis=-1)[..., None]
        R = np.stack([x, np.cross(z, x), z], axis=-1)
        centre = self.instrument + z * (length / 2)[..., None]
        return length, z, R, centre

    def _placements(self, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
        """(m, G, 3, 3), (m, G, 3) the hulls' placements at each configuration (one geometry update
        each, at the joints' values)."""
        H = np.empty((len(kin.qs), len(self.hulls.geometryObjects), 4, 4))
        data = self.forward.data
        for i, theta in enumerate(self.forward.joint_values(kin.qs, kin.payload)):
            pin.updateGeometryPlacements(self.model, data, self.hulls, self.hull_data, theta)
            H[i] = [placed.homogeneous for placed in self.hull_data.oMg]
        return H[:, :, :3, :3], H[:, :, :3, 3]

    def lower_bounds(self, kin: Kinematics) -> np.ndarray:
        """(m, K, G) bounds [m] from the hulls' covering spheres: where positive, never more than
        the margin (the sight capsule's distance to the hull); inf where there is no sight line."""
        return self._bounds(kin)[0]

    def _bounds(self, kin: Kinematics) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        points = (
            np.einsum("ij,mkj->mki", self.base_inverse.rotation, kin.points) + self.base_inverse.translation
        )
        length, z, R, centre = self._segments(points)
        rotations, translations = self._placements(kin)
        bounds = np.full(points.shape[:2] + (len(self.spheres),), np.inf)
        for g, (centres, radius) in enumerate(self.spheres):
            c = np.einsum("mij,sj->msi", rotations[:, g], centres) + translations[:, g, None]  # (m, S, 3)
            along = np.einsum("mki,msi->mks", z, c - self.instrument)  # (m, K, S)
            t = np.clip(along, 0.0, length[..., None])
            nearest = self.instrument + z[:, :, None, :] * t[..., None]
            gap = np.linalg.norm(c[:, None] - nearest, axis=-1) - radius - self.radius
            bounds[:, :, g] = np.where(length > 0, gap.min(axis=-1), np.inf)
        return bounds, (length, R, centre, rotations, translations)

    def margins(self, kin: Kinematics) -> np.ndarray:
        bounds, (length, R, centre, rotations, translations) = self._bounds(kin)
        out = bounds.copy()
        objects = self.hulls.geometryObjects
        coal, request = self.coal, self.request
        for i, k, g in zip(*(int_.tolist() for int_ in np.nonzero(bounds < self.reach)), strict=True):
            capsule = coal.Capsule(self.radius, float(length[i, k]))
            result = coal.DistanceResult()
            out[i, k, g] = coal.distance(
                capsule, coal.Transform3s(R[i, k], centre[i, k]), objects[g].geometry,
                coal.Transform3s(rotations[i, g], translations[i, g]), request, result,
            )  # fmt: skip
        return np.minimum(out.reshape(len(kin.qs), -1), 1e3)


def _covering_spheres(geometry) -> tuple[np.ndarray, float]:
    """((S, 3) centres, radius) [m, geometry frame] of S equal spheres that together cover the
    geometry's bounding box: the box cut into S slabs across its longest axis, a sphere round
    each slab (S about the longest half-extent over the other two's diagonal, at most 8)."""
    geometry.computeLocalAABB()
    lo, hi = np.array(geometry.aabb_local.min_), np.array(geometry.aabb_local.max_)
    half, middle = (hi - lo) / 2, (hi + lo) / 2
    axis = int(np.argmax(half))
    across = float(np.linalg.norm(np.delete(half, axis)))
    count = int(min(8, max(1, np.ceil(half[axis] / max(across, 1e-9)))))
    slab = half[axis] / count
    offsets = (2 * np.arange(count) - (count - 1)) * slab
    centres = np.tile(middle, (count, 1))
    centres[:, axis] += offsets
    return centres, float(np.sqrt(slab**2 + across**2))
