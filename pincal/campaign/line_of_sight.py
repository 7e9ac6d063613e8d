"""Line of sight: the instrument sees each marker at each measurement pose, not through the robot
or the cell.

The segment from the tracker to a marker must keep clear of every shape of the collision world —
the robot's links (except the link carrying the marker: the target sits on it, and whether it
faces the tracker is the visibility constraint's incidence angle) and the cell's obstacles. The
last :data:`TARGET_GAP` of the segment at the marker is left out (the target's own mount).
Meshes are checked by their convex hulls first, then on the mesh when the hull is in the way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.model.collision import CollisionWorld

TARGET_GAP = 0.01
"""Length [m] of the line of sight at the marker that is not checked (the target's mount)."""

SIGHT_RADIUS = 0.002
"""Radius [m] of the line of sight (the tracker's beam, and rounding)."""


@dataclass(frozen=True)
class Occlusion:
    """A marker the instrument cannot see at a pose.

    Attributes:
        pose: the configuration (0-based index).
        marker: the marker (0-based).
        by: the shape in the way.
    """

    pose: int
    marker: int
    by: str

    def __str__(self) -> str:
        return f"pose {self.pose + 1}: marker {self.marker} hidden by {self.by}"

    def as_dict(self) -> dict:
        return {"pose": self.pose, "marker": self.marker, "by": self.by}


def occlusions(
    world: CollisionWorld, qs: np.ndarray, tracker: np.ndarray, payload: np.ndarray | None = None
) -> list[Occlusion]:
    """Every (pose, marker) whose line of sight from ``tracker`` (base frame [m]) is blocked
    (``payload``: (m, 4) each pose's payload row [kg, x, y, z]; default the world's)."""
    import coal

    robot = world.robot
    hulls, exact = world.geom.geometryObjects, world.exact.geometryObjects
    skip = {i for i in range(world.n_robot) if hulls[i].parentJoint == robot.tip_joint}
    shapes = [i for i in range(len(hulls)) if i not in skip]
    points = robot.points(qs, check=False, payload=world.payload if payload is None else payload)
    if robot.base is not None:  # the points in the base frame (the world's)
        inverse = robot.base.inverse()
        points = points @ inverse.rotation.T + inverse.translation
    out = []
    z = np.array([0.0, 0.0, 1.0])
    for i, q in enumerate(qs):
        placements = world.placements(q, None if payload is None else payload[i : i + 1])
        for k, p in enumerate(points[i]):
            d = np.asarray(tracker, dtype=float) - p
            length = float(np.linalg.norm(d)) - TARGET_GAP
            if length <= 0:
                continue
            u = d / np.linalg.norm(d)
            start = p + TARGET_GAP * u
            beam = coal.Capsule(SIGHT_RADIUS, length)
            rotation = pin.Quaternion.FromTwoVectors(z, u).toRotationMatrix()
            where = coal.Transform3s(rotation, start + 0.5 * length * u)
            for g in shapes:
                placed = coal.Transform3s(placements[g].rotation, placements[g].translation)
                if _distance(beam, where, hulls[g].geometry, placed) > 0:
                    continue
                if world.meshes[g] and _distance(beam, where, exact[g].geometry, placed) > 0:
                    continue  # the hull is in the way, the mesh is not
                out.append(Occlusion(i, k, hulls[g].name))
                break
    return out


def _distance(a, ta, b, tb) -> float:
    import coal

    request, result = coal.DistanceRequest(), coal.DistanceResult()
    return float(coal.distance(a, ta, b, tb, request, result))
