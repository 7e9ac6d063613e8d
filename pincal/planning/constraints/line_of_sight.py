"""Nothing of the robot crosses the instrument's line of sight to a marker (the URDF's collision
geometry, through Pinocchio and coal; docs/method.md §13.4)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint
from pincal.model.geometry import convex_hulls
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
    reach = 0.02

    def __init__(self, robot: Robot, spec: LineOfSight) -> None:
        import coal

        self.coal = coal
        self.hulls = hull_geometry(robot, spec.package_dirs, "line_of_sight")
        self.hull_data = self.hulls.createData()
        self.model, self.data = robot.model, robot.model.createData()
        self.offsets = robot.joint_offsets
        self.base_inverse = robot.base.inverse()
        self.instrument = self.base_inverse.act(np.array(spec.instrument))  # in the robot's base frame
        self.spec = spec
        self.request = coal.DistanceRequest()

    def _segment(self, point: np.ndarray) -> tuple[object, object] | None:
        """The sight line to ``point`` (robot base frame) as a coal capsule and its placement, or
        None when the instrument is within ``skip`` of the point."""
        axis = point - self.instrument
        length = float(np.linalg.norm(axis)) - self.spec.skip
        if length <= 0:
            return None
        z = axis / np.linalg.norm(axis)
        helper = np.eye(3)[int(np.argmin(np.abs(z)))]
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        R = np.column_stack([x, np.cross(z, x), z])
        centre = self.instrument + z * (length / 2)
        capsule = self.coal.Capsule(max(self.spec.clearance, 1e-6), length)
        return capsule, self.coal.Transform3s(R, centre)

    def margins(self, kin: Kinematics) -> np.ndarray:
        objects = self.hulls.geometryObjects
        points = (
            np.einsum("ij,mkj->mki", self.base_inverse.rotation, kin.points) + self.base_inverse.translation
        )
        out = np.full((len(kin.qs), points.shape[1] * len(objects)), np.inf)
        for i, q in enumerate(kin.qs + self.offsets):
            pin.updateGeometryPlacements(self.model, self.data, self.hulls, self.hull_data, q)
            placed = [self.coal.Transform3s(p.rotation, p.translation) for p in self.hull_data.oMg]
            for k, point in enumerate(points[i]):
                segment = self._segment(point)
                if segment is None:
                    continue
                for g, obj in enumerate(objects):
                    result = self.coal.DistanceResult()
                    d = self.coal.distance(
                        segment[0], segment[1], obj.geometry, placed[g], self.request, result
                    )
                    out[i, k * len(objects) + g] = d
        return np.minimum(out, 1e3)
