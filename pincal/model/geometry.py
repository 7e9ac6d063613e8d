"""The URDF's geometry on a robot's chain (its visual or collision shapes and meshes), as a
Pinocchio ``GeometryModel``, with the mesh files found where :func:`~pincal.load_robot` finds
them: the robot's ``package_dirs`` (``--package-dir NAME=PATH``), then the folders above the URDF.

The 3-D view and the self-collision constraint both load geometry here, so a mesh the loader
found is the mesh they draw and check. Each ``<mesh filename=...>`` is replaced by the absolute
path of the file found before Pinocchio reads the URDF text; a ``<visual>`` or ``<collision>``
whose mesh cannot be found is left out and named in :attr:`UrdfGeometry.missing`.
"""

from __future__ import annotations

import copy
import itertools
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal.errors import UrdfError, warn
from pincal.model.mjcf import build_geometry, geometry_text, is_mjcf
from pincal.model.robot import Robot
from pincal.model.urdf import captured_stderr, first_error, read_tree, resolve_mesh
from pincal.outputs import note_input


@dataclass(frozen=True, eq=False)
class UrdfGeometry:
    """The geometry of one kind that a robot's URDF gives its chain.

    Attributes:
        model: Pinocchio's geometry model (the shapes, and the meshes found), attached to the
            robot's model; empty when the robot has no URDF.
        missing: the ``filename`` of each mesh that cannot be found (sorted; its ``<visual>`` or
            ``<collision>`` is not in ``model``).
    """

    model: pin.GeometryModel
    missing: tuple[str, ...]


def robot_tree(robot: Robot) -> etree._Element | None:
    """The XML tree of the robot's URDF (a xacro source expanded again), or None without one (or
    with an MJCF file)."""
    if robot.urdf_path is None or is_mjcf(robot.urdf_path):
        return None
    return read_tree(Path(robot.urdf_path), dict(robot.package_dirs))


def urdf_geometry(
    robot: Robot, kind: pin.GeometryType, search: Iterable[str] = (), tree: etree._Element | None = None
) -> UrdfGeometry:
    """The robot's URDF geometry of ``kind`` (``pin.GeometryType.VISUAL`` or ``COLLISION``).

    Args:
        robot: a robot loaded from a URDF (its ``urdf_path`` and ``package_dirs`` are used).
        kind: which geometry.
        search: more folders holding package folders (``DIR/NAME/...`` for ``package://NAME/``).
        tree: :func:`robot_tree` of ``robot``, when the caller has read it already (not modified).

    Raises:
        UrdfError: the URDF cannot be read again, or a mesh file found cannot be read (one line).
    """
    if robot.urdf_path is None:
        return UrdfGeometry(pin.GeometryModel(), ())
    path = Path(robot.urdf_path)
    if is_mjcf(path):  # a MuJoCo robot: Pinocchio's MJCF geometry (docs/method.md §5.9)
        return _mjcf_geometry(robot, path, kind)
    dirs = [str(d) for d in search]
    root = copy.deepcopy(tree) if tree is not None else robot_tree(robot)
    assert root is not None  # the robot has a URDF (above)
    tag = "visual" if kind == pin.GeometryType.VISUAL else "collision"
    named = dict(robot.package_dirs)
    missing: set[str] = set()
    for element in [e for e in root.iter(tag) if getattr(e.getparent(), "tag", None) == "link"]:
        for mesh in element.iter("mesh"):
            name = mesh.get("filename") or ""
            found = resolve_mesh(name, path, named, dirs) if name else None
            if found is None:
                missing.add(name)
                element.getparent().remove(element)  # type: ignore[union-attr]  # a link's child
                break
            mesh.set("filename", str(found.resolve()))
            note_input(found)
    failure = None
    with captured_stderr() as stderr:  # urdfdom's own multi-line reports: into pincal's one line
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # Pinocchio's notes on the meshes it reads
                geometry = pin.buildGeomFromUrdfString(
                    robot.model, etree.tostring(root, encoding="unicode"), kind, package_dirs=dirs
                )
        except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with long texts
            failure = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    reported = first_error(stderr)
    if failure is not None:
        raise UrdfError(f"cannot read the {tag} geometry of {str(path)!r}: {reported or failure}")
    if reported is not None:  # built without the element urdfdom could not parse
        warn(f"the {tag} geometry of {str(path)!r} leaves out what urdfdom could not read: {reported}")
    return UrdfGeometry(geometry, tuple(sorted(missing)))


def _mjcf_geometry(robot: Robot, path: Path, kind: pin.GeometryType) -> UrdfGeometry:
    """The geometry of ``kind`` of a MuJoCo robot (Pinocchio sorts its geoms into visual and
    collision ones), the geoms whose mesh file cannot be found left out and named."""
    text, missing = geometry_text(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            geometry = build_geometry(robot.model, text, kind)
    except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with long texts
        said = str(exc).split("message:", 1)[-1].strip()
        first = said.splitlines()[0] if said else type(exc).__name__
        raise UrdfError(f"cannot read the geometry of {str(path)!r}: {first}") from None
    return UrdfGeometry(geometry, missing)


def convex_hulls(geometry: pin.GeometryModel) -> pin.GeometryModel:
    """A copy of ``geometry`` whose meshes are replaced by their convex hulls (qhull, through coal):
    fast, smooth distances that never exceed the true ones (a hull contains its mesh); primitive
    shapes are kept as they are."""
    import coal

    hulls = pin.GeometryModel()
    for obj in geometry.geometryObjects:
        obj = obj.copy()
        if isinstance(obj.geometry, coal.BVHModelBase):
            obj.geometry = convex_hull(obj.geometry, obj.name)
        hulls.addGeometryObject(obj)
    return hulls


THIN = 1e-3
"""Thickness given to a flat mesh's hull [m] (a plate, a zero scale on one axis): qhull cannot
build the hull of points that span no volume (coal crashes the process on them)."""

FLAT = 1e-6
"""A mesh whose vertices spread less than this fraction of their largest spread along some axis
(their smallest singular value against their largest) is flat: its hull is built thickened."""


MAX_MESH_EXTENT = 1e6
"""Largest distance of a mesh vertex from its frame [m] (1000 km: a mesh in millimetres without its
scale is well within): qhull crashes the process on coordinates near the float range (a scale of
1e100), so a mesh beyond this is refused, naming its scale."""


def convex_hull(mesh, name: str = "a mesh"):
    """The convex hull of a coal mesh (qhull), or the mesh itself when qhull cannot build one (some
    published meshes: "Too many neighbors"): its distances are then its own, exact where apart and
    0 where it meets another shape, never more than the true ones either.

    A flat mesh (a plate, a line, a point: a zero scale on some axis) has the hull of its vertices
    thickened by :data:`THIN` across its flat directions: it contains the mesh, so its distances
    stay lower bounds of the true ones."""
    import coal

    points = np.asarray(mesh.vertices(), dtype=float).reshape(-1, 3)
    extent = float(np.max(np.abs(points), initial=0.0)) if np.all(np.isfinite(points)) else np.inf
    if not extent <= MAX_MESH_EXTENT:
        raise UrdfError(
            f"the collision mesh {name!r} reaches {extent:.3g} m from its frame, beyond the "
            f"{MAX_MESH_EXTENT:g} m a cell holds: check its scale"
        )
    thick = thickened(points)
    if thick is not points:
        mesh = coal.BVHModelOBBRSS()
        mesh.beginModel(0, len(thick))
        mesh.addVertices(thick)
        mesh.endModel()
    try:
        mesh.buildConvexHull(True, "Qt")
    except RuntimeError:
        return mesh
    return mesh.convex


def thickened(points: np.ndarray) -> np.ndarray:
    """``points`` (n, 3) [m] when they span a volume; else (no points, one, a line or a plane)
    the points offset by ±:data:`THIN`/2 along each direction they do not span (a new array)."""
    if len(points) == 0:
        return np.array(list(itertools.product((-THIN / 2, THIN / 2), repeat=3)))
    centred = points - points.mean(axis=0)
    # three zero rows: three singular values and axes whatever the number of points
    _, spread, axes = np.linalg.svd(np.vstack([centred, np.zeros((3, 3))]), full_matrices=False)
    flat = [axes[k] for k in range(3) if not spread[k] > FLAT * spread[0]]
    if not flat:
        return points
    offsets = [
        sum(s * THIN / 2 * a for s, a in zip(signs, flat))
        for signs in itertools.product((-1, 1), repeat=len(flat))
    ]
    return np.vstack([points + offset for offset in offsets])
