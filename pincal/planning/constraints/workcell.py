"""The workcell: obstacles the robot must keep clear of (boxes, cylinders, spheres, meshes, or a
URDF of the cell), in the robot's base frame.

The cell is checked with Pinocchio's collision models (coal) against the robot's collision
geometry — the URDF's ``<collision>`` shapes, or capsules derived from the kinematics when it has
none (see :mod:`pincal.model.collision`; every report says which). Meshes,
the robot's and the cell's, are checked by their convex hulls: the distances are lower bounds of
the true ones; a pair whose hulls come within a few centimetres is measured on the meshes.

In a constraints file::

    workcell:
      min_distance: 0.02          # clearance kept between the robot and every obstacle [m]
      link_radius: 0.15           # the capsules' radius, when the robot's URDF has no collision geometry
      obstacles:
        - {name: table, box: [1.2, 0.8, 0.05], xyz: [1.6, 0, 0.5]}          # full sizes x, y, z [m]
        - {name: column, cylinder: [0.15, 2.0], xyz: [0, -1.5, 1.0]}      # radius, length (along z)
        - {name: ball, sphere: 0.1, xyz: [1, 1, 1]}
        - {name: fixture, mesh: fixture.stl, scale: 0.001, xyz: [2, 0, 0], rpy: [0, 0, 1.57]}
      urdf: cell.urdf             # a rigid URDF of the cell: its links' collision geometry

Paths are relative to the constraints file; ``rpy`` in radians (``rpy_deg`` in degrees).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint
from pincal.model.collision import CollisionWorld
from pincal.model.robot import Robot
from pincal.model.urdf import captured_stderr, first_error
from pincal.outputs import note_input
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number, vector
from pincal.planning.constraints.mount import MountBound

SHAPES = ("box", "cylinder", "sphere", "capsule", "mesh")
"""The kinds of obstacle a workcell takes (and ``urdf``: a whole cell)."""


@dataclass(frozen=True)
class Obstacle:
    """One obstacle of the cell, in the robot's base frame.

    Attributes:
        name: what reports call it.
        shape: one of :data:`SHAPES`.
        size: the box's full sizes (x, y, z); the cylinder's or capsule's (radius, length), along
            its z axis; the sphere's (radius,); a mesh's scale (x, y, z) [m].
        xyz: position of its centre (a mesh: of its origin) [m].
        rpy: orientation, roll-pitch-yaw as in URDF [rad].
        mesh: the mesh file (STL, OBJ, DAE, ...), for ``shape="mesh"``.
    """

    name: str
    shape: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mesh: str | None = None

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise BadConstraint(
                f"obstacle {self.name!r}: unknown shape {self.shape!r}; valid: {', '.join(SHAPES)}"
            )
        count = {"box": 3, "cylinder": 2, "capsule": 2, "sphere": 1, "mesh": 3}[self.shape]
        size = vector(self.size, f"obstacle {self.name!r} {self.shape} size", count)
        if any(not (v > 0) for v in size):
            raise BadConstraint(f"obstacle {self.name!r}: sizes must be positive, got {size}")
        object.__setattr__(self, "size", size)
        object.__setattr__(self, "xyz", vector(self.xyz, f"obstacle {self.name!r} xyz"))
        object.__setattr__(self, "rpy", vector(self.rpy, f"obstacle {self.name!r} rpy"))
        if (self.shape == "mesh") != (self.mesh is not None):
            raise BadConstraint(f"obstacle {self.name!r}: a mesh file goes with shape 'mesh' only")
        if self.mesh is not None:
            object.__setattr__(self, "mesh", os.fspath(self.mesh))
            if not Path(self.mesh).is_file():
                raise BadConstraint(f"obstacle {self.name!r}: mesh file {self.mesh!r} not found")
            note_input(self.mesh)  # an input: no output of the command may replace it

    @property
    def placement(self) -> pin.SE3:
        """Its placement in the base frame."""
        return pin.SE3(pin.rpy.rpyToMatrix(*self.rpy), np.array(self.xyz))

    def geometry_object(self) -> pin.GeometryObject:
        """The coal shape, as a Pinocchio geometry object on the base (joint 0)."""
        import coal

        s = self.size
        if self.shape == "box":
            shape = coal.Box(*s)
        elif self.shape == "cylinder":
            shape = coal.Cylinder(s[0], s[1])
        elif self.shape == "capsule":
            shape = coal.Capsule(s[0], s[1])
        elif self.shape == "sphere":
            shape = coal.Sphere(s[0])
        else:
            try:
                shape = coal.MeshLoader().load(self.mesh, np.array(s))
            except Exception as exc:  # coal raises RuntimeError/ValueError with long texts
                first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
                raise BadConstraint(
                    f"obstacle {self.name!r}: cannot read mesh {self.mesh!r}: {first}"
                ) from None
        return pin.GeometryObject(self.name, 0, self.placement, shape)


def urdf_obstacles(path: str | os.PathLike, package_dirs: tuple[str, ...] = ()) -> list[pin.GeometryObject]:
    """The collision geometry of a rigid URDF of the cell, placed in its root frame (= the robot's
    base frame).

    Raises:
        BadConstraint: the file cannot be read, has a joint that moves, or no collision geometry.
    """
    path = Path(path)
    if not path.is_file():
        raise BadConstraint(f"workcell urdf {str(path)!r} not found")
    failure = None
    with captured_stderr() as stderr:  # urdfdom's own multi-line reports: into pincal's one line
        try:
            model = pin.buildModelFromUrdf(str(path))
            geom = pin.buildGeomFromUrdf(
                model, str(path), pin.COLLISION, package_dirs=[str(path.parent), *package_dirs]
            )
        except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with long texts
            failure = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    # an error urdfdom reports, even when it builds a model: a part of the cell left out
    reported = first_error(stderr)
    if failure is not None or reported is not None:
        raise BadConstraint(f"workcell urdf {str(path)!r}: cannot read it: {reported or failure}")
    if model.nq:
        raise BadConstraint(
            f"workcell urdf {str(path)!r}: a cell must be rigid, but joint {model.names[1]!r} moves "
            "(make it fixed, or put the moving part in its own position)"
        )
    if geom.ngeoms == 0:
        raise BadConstraint(f"workcell urdf {str(path)!r} has no <collision> geometry")
    for name in [path, *(obj.meshPath for obj in geom.geometryObjects if obj.meshPath)]:
        note_input(name)  # the cell's files: no output of the command may replace them
    out = []
    for obj in geom.geometryObjects:
        obj = obj.copy()
        obj.placement = (
            model.jointPlacements[obj.parentJoint] * obj.placement if obj.parentJoint else obj.placement
        )
        obj.parentJoint = 0
        out.append(obj)
    return out


@dataclass(frozen=True)
class Workcell(Constraint):
    """Keep the robot ``min_distance`` clear of every obstacle of the cell (see the module doc).

    Attributes:
        obstacles: the cell's shapes (:class:`Obstacle`).
        urdf: a rigid URDF of the cell, in the base frame (its collision geometry), or None.
        min_distance: clearance kept between the robot and every obstacle [m].
        link_radius: radius of the capsules derived from the kinematics when the robot's URDF has
            no collision geometry [m] (None: 4 % of the robot's reach).
        package_dirs: folders holding the packages of the meshes (of the robot or the cell URDF).
    """

    obstacles: tuple[Obstacle, ...] = ()
    urdf: str | None = None
    min_distance: float = 0.0
    link_radius: float | None = None
    package_dirs: tuple[str, ...] = field(default=())
    key = "workcell"

    def __post_init__(self) -> None:
        obstacles = tuple(self.obstacles)
        if not all(isinstance(o, Obstacle) for o in obstacles):
            raise BadConstraint("workcell obstacles must be pincal Obstacle objects")
        object.__setattr__(self, "obstacles", obstacles)
        object.__setattr__(self, "min_distance", number(self.min_distance, "workcell min_distance", 0.0))
        if self.link_radius is not None:
            object.__setattr__(
                self, "link_radius", number(self.link_radius, "workcell link_radius", 0.0, strict=True)
            )
        if self.urdf is not None:
            object.__setattr__(self, "urdf", os.fspath(self.urdf))
        object.__setattr__(self, "package_dirs", tuple(str(p) for p in self.package_dirs))
        if not obstacles and self.urdf is None:
            raise BadConstraint("a workcell needs obstacles or a urdf of the cell")

    def geometry_objects(self) -> list[pin.GeometryObject]:
        """Every obstacle as a Pinocchio geometry object on the base."""
        out = [o.geometry_object() for o in self.obstacles]
        if self.urdf is not None:
            out += urdf_obstacles(self.urdf, self.package_dirs)
        return out

    def world(
        self, robot: Robot, self_collision: bool = False, mount_points: MountBound | None = None
    ) -> CollisionWorld:
        """The robot and this cell as one collision world."""
        return CollisionWorld(
            robot,
            self.geometry_objects(),
            self_collision=self_collision,
            mount_points=mount_points,
            link_radius=self.link_radius,
            search=self.package_dirs,
        )

    def bind(self, robot: Robot) -> Bound:
        return WorkcellBound(self.world(robot), self.min_distance)

    def closest(
        self, robot: Robot, qs: np.ndarray, payload: np.ndarray | None = None
    ) -> tuple[float, int, str, str]:
        """(distance [m], configuration index, pair) of the robot/obstacle pair closest over
        ``qs`` (``payload``: (m, 4) each configuration's payload row [kg, x, y, z], or None), and
        which robot geometry was used (its :attr:`RobotGeometry.source`)."""
        world = self.world(robot)
        d = world.distances_many(qs, payload=payload)
        if not d.size:
            return np.inf, -1, "", world.geometry.source
        i, k = np.unravel_index(int(np.argmin(d)), d.shape)
        return float(d[i, k]), int(i), world.names[k], world.geometry.source


class WorkcellBound(Bound):
    reach = 0.05

    def __init__(self, world: CollisionWorld, min_distance: float) -> None:
        self.world, self.min_distance = world, min_distance

    def margins(self, kin: Kinematics) -> np.ndarray:
        # The continuous search reads the convex hulls' distances: smooth, and never above the true ones.
        distances = self.world.distances_many(kin.qs, refine=False, payload=kin.payload)
        return distances - self.min_distance

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        distances = self.world.distances_many(kin.qs, payload=kin.payload)
        return np.all(distances - self.min_distance >= -1e-9, axis=1)


def workcell_from_dict(entry: object, folder: Path | None = None) -> Workcell:
    """A :class:`Workcell` from the ``workcell:`` mapping of a constraints file (see the module doc);
    relative paths are taken from ``folder``."""
    if not isinstance(entry, dict):
        raise BadConstraint("workcell must be a mapping of min_distance, link_radius, obstacles, urdf")
    valid = ("min_distance", "link_radius", "obstacles", "urdf", "package_dirs")
    unknown = [k for k in entry if k not in valid]
    if unknown:
        raise BadConstraint(f"workcell: unknown key {unknown[0]!r}; valid: {', '.join(valid)}")

    def where(p: object) -> str:
        if not isinstance(p, str):
            raise BadConstraint(f"workcell: a path must be text, got {p!r}")
        return str((folder / p) if folder is not None and not Path(p).is_absolute() else Path(p))

    items = entry.get("obstacles", [])
    if not isinstance(items, list):
        raise BadConstraint("workcell obstacles must be a list of mappings")
    obstacles = [_obstacle(item, i, where) for i, item in enumerate(items)]
    dirs = entry.get("package_dirs", [])
    dirs = [where(d) for d in (dirs if isinstance(dirs, list) else [dirs])]
    return Workcell(
        tuple(obstacles),
        where(entry["urdf"]) if "urdf" in entry else None,
        entry.get("min_distance", 0.0),
        entry.get("link_radius"),
        tuple(dirs),
    )


def _obstacle(item: object, i: int, where) -> Obstacle:
    if not isinstance(item, dict):
        raise BadConstraint(f"workcell obstacle {i + 1} must be a mapping, got {item!r}")
    valid = ("name", *SHAPES, "scale", "xyz", "rpy", "rpy_deg")
    unknown = [k for k in item if k not in valid]
    if unknown:
        raise BadConstraint(
            f"workcell obstacle {i + 1}: unknown key {unknown[0]!r}; valid: {', '.join(valid)}"
        )
    shapes = [s for s in SHAPES if s in item]
    if len(shapes) != 1:
        raise BadConstraint(f"workcell obstacle {i + 1}: give exactly one shape of {', '.join(SHAPES)}")
    shape = shapes[0]
    name = str(item.get("name", f"{shape} {i + 1}"))
    if "rpy" in item and "rpy_deg" in item:
        raise BadConstraint(f"workcell obstacle {name!r}: give rpy (radians) or rpy_deg (degrees), not both")
    rpy = item.get("rpy", (0.0, 0.0, 0.0))
    if "rpy_deg" in item:
        rpy = tuple(math.radians(v) for v in vector(item["rpy_deg"], f"obstacle {name!r} rpy_deg"))
    if shape == "mesh":
        scale = item.get("scale", 1.0)
        size = (scale,) * 3 if isinstance(scale, (int, float)) else scale
        return Obstacle(name, shape, size, item.get("xyz", (0.0, 0.0, 0.0)), rpy, where(item["mesh"]))
    size = item[shape]
    size = (size,) if isinstance(size, (int, float)) else size
    return Obstacle(name, shape, size, item.get("xyz", (0.0, 0.0, 0.0)), rpy)
