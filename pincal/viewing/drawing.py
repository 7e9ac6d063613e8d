"""Drawing in a meshcat scene: the robot's geometry (the URDF's meshes, or sticks between the joint
frames), points, ellipsoids, labels, the instrument and the camera. :mod:`pincal.viewing.scene`
composes these into the scene of a plan."""

from __future__ import annotations

import colorsys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal.errors import UrdfError, warn
from pincal.model.collision import segment_placement
from pincal.model.geometry import robot_tree, urdf_geometry
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot

ROOT = "pincal"
"""Name of the scene's root node (under meshcat's ``/meshcat``)."""

MIN_DRAWN_AXIS = 0.02
"""A semi-axis is drawn at least this fraction of the largest one (a planar robot's ellipsoid is
flat: its third axis is zero). :attr:`Scene.ellipsoid_radii` keeps the true values."""

ELLIPSOID_COLOR = "#f59b00"
"""Colour of the error ellipsoid (amber; the ghosts' palette leaves it out)."""

_STICK_LINK = 0.018
_STICK_JOINT = 0.032
_STICK_JOINT_LENGTH = 0.085
_POINT_RADIUS = 0.012
"""Sizes of the stick robot and of the point spheres, as fractions of the robot's reach."""


def rgb(color: str) -> tuple[float, float, float]:
    return tuple(int(color[i : i + 2], 16) / 255.0 for i in (1, 3, 5))  # type: ignore[return-value]


def _hex_int(color: str) -> int:
    return int(color[1:], 16)


# ---------------------------------------------------------------------------- geometry
def geometry_models(robot: Robot, reach: float) -> tuple[pin.GeometryModel, pin.GeometryModel]:
    """(test-pose model, ghost model): the URDF's visual and collision meshes, or sticks."""
    try:
        tree = robot_tree(robot)  # read once for both kinds (a xacro source is expanded again)
    except UrdfError as exc:
        warn(f"{exc}; the 3-D view draws sticks")
        tree = None
    visual = None if tree is None else _urdf_geometry(robot, pin.GeometryType.VISUAL, tree)
    if visual is None:
        sticks = _stick_geometry(robot, reach)
        return sticks, sticks
    assert tree is not None  # the visual geometry came from it
    collision = _urdf_geometry(robot, pin.GeometryType.COLLISION, tree)
    return visual, collision if collision is not None else visual


def _urdf_geometry(robot: Robot, kind: pin.GeometryType, tree: etree._Element) -> pin.GeometryModel | None:
    """The URDF's geometry model of ``kind`` on the robot's chain, or None if it has none, or if
    some of its meshes cannot be found (:func:`~pincal.load_robot` has named them in its warning
    then, which says the view draws sticks).

    Meshes are found as the loader finds them: ``Robot.package_dirs`` (``--package-dir``), then
    the folders above the URDF (the example-robot-data layout, and a ROS workspace's).
    """
    try:
        loaded = urdf_geometry(robot, kind, tree=tree)
    except UrdfError as exc:  # unreadable mesh files
        warn(f"{exc}; the 3-D view draws sticks")
        return None
    geom = loaded.model
    if loaded.missing or geom.ngeoms == 0:
        return None
    try:
        import coal
    except ImportError:  # pragma: no cover - pin ships coal
        return geom
    for obj in geom.geometryObjects:
        if isinstance(obj.geometry, coal.BVHModelBase) and Path(obj.meshPath).suffix.lower() == ".dae":
            # Pinocchio's MeshcatVisualizer sends a Collada (.dae) file as is, and meshcat then
            # ignores the colour asked for. Without its path the mesh goes as the triangles coal
            # loaded (already scaled), which take the colour and the transparency.
            obj.meshPath = ""
            obj.meshScale = np.ones(3)
    return geom


def _stick_geometry(robot: Robot, reach: float) -> pin.GeometryModel:
    """Cylinders between consecutive joint frames (and to the tip and markers), and one along
    each joint axis, so that a kinematic-only robot is never invisible."""
    import coal

    model = robot.model
    geom = pin.GeometryModel()

    def cylinder(name: str, joint: int, start: np.ndarray, end: np.ndarray, radius: float) -> None:
        placement, length = segment_placement(start, end)
        if length > 0:
            geom.addGeometryObject(pin.GeometryObject(name, joint, placement, coal.Cylinder(radius, length)))

    origin = np.zeros(3)
    for j in range(1, model.njoints):
        link = model.jointPlacements[j].translation
        cylinder(f"link_{j}", model.parents[j], origin, link, _STICK_LINK * reach)
        axis = robot.motion_axes[j]
        direction = axis[3:] if np.linalg.norm(axis[3:]) > 0.5 else axis[:3]
        half = 0.5 * _STICK_JOINT_LENGTH * reach * direction / np.linalg.norm(direction)
        cylinder(f"joint_{j}", j, -half, half, _STICK_JOINT * reach)
    tip = model.frames[robot.tip_frame].placement
    cylinder("tip", robot.tip_joint, origin, tip.translation, _STICK_LINK * reach)
    for k, marker in enumerate(robot.markers):
        cylinder(f"marker_{k}", robot.tip_joint, tip.translation, tip * marker, 0.5 * _STICK_LINK * reach)
    return geom


# ---------------------------------------------------------------------------- drawing
def add_robot(vis, robot: Robot, geom: pin.GeometryModel, q: np.ndarray, path: str, rgba):
    """The robot drawn with ``geom`` at ``q`` under ``path``; returns Pinocchio's
    ``MeshcatVisualizer`` holding it (its nodes: ``viz.getViewerNodeName``)."""
    from pinocchio.visualize import MeshcatVisualizer

    viz = MeshcatVisualizer(robot.model, None, geom)
    viz.initViewer(viewer=vis)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # meshcat's own deprecation chatter
        viz.loadViewerModel(rootNodeName=path, visual_color=list(rgba))
    vis[path].set_transform(robot.base.homogeneous)
    viz.display(ForwardKinematics(robot).joint_values(np.asarray(q, dtype=float)[None])[0])
    return viz


def material(color: str, opacity: float = 1.0):
    import meshcat.geometry as mg

    return mg.MeshPhongMaterial(color=_hex_int(color), opacity=opacity, transparent=opacity < 1.0)


def _translation(p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


def add_points(vis, node: str, points: np.ndarray, reach: float, color: str, size: float = 1.0) -> None:
    import meshcat.geometry as mg

    for j, p in enumerate(points):
        path = f"{node}/marker_{j}"
        vis[path].set_object(mg.Sphere(size * _POINT_RADIUS * reach), material(color))
        vis[path].set_transform(_translation(p))


def error_colors(values: np.ndarray) -> np.ndarray:
    """(n, 3) RGB in [0, 1] for errors ``values``: green at the smallest, through yellow, to red at
    the largest, on a log scale."""
    logs = np.log(np.maximum(values, 1e-300))
    span = logs.max() - logs.min()
    t = (logs - logs.min()) / span if span > 0 else np.zeros_like(logs)
    return np.array([colorsys.hsv_to_rgb(0.33 * (1.0 - x), 0.85, 0.9) for x in t])


def add_error_cloud(vis, points: np.ndarray, values: np.ndarray, reach: float) -> None:
    import meshcat.geometry as mg

    node = f"{ROOT}/error_cloud"
    cloud = mg.PointCloud(points.T, error_colors(values).T, size=0.6 * _POINT_RADIUS * reach)
    vis[node].set_object(cloud)
    top = points[np.argmax(points[:, 2])]
    low, high = values.min() * 1e3, values.max() * 1e3
    add_label(vis, f"{node}/range", f"error {low:.3g}–{high:.3g} mm", top, reach, size=0.3)


def add_ellipsoid(vis, path: str, centre: np.ndarray, radii: np.ndarray, axes: np.ndarray) -> None:
    import meshcat.geometry as mg

    drawn = np.maximum(radii, MIN_DRAWN_AXIS * radii.max())
    vis[path].set_object(mg.Ellipsoid(drawn), material(ELLIPSOID_COLOR, 0.6))
    T = _translation(centre)
    T[:3, :3] = axes
    vis[path].set_transform(T)


class _Label:
    """A text label that always faces the camera: a three.js Sprite with meshcat's ``_text``
    texture (black text drawn on a 256×256 canvas). meshcat-python has no class for it."""

    def __init__(self, path, text: str, size: float) -> None:
        from uuid import uuid4

        self.path = path
        self.text = text
        self.size = size
        self.uuids = [str(uuid4()) for _ in range(3)]

    def lower(self) -> dict:
        obj, material, texture = self.uuids
        s = self.size
        return {
            "type": "set_object",
            "path": self.path.lower(),
            "object": {
                "metadata": {"version": 4.5, "type": "Object"},
                "geometries": [],
                "textures": [
                    {
                        "uuid": texture,
                        "type": "_text",
                        "text": self.text,
                        "font_size": 96,
                        "font_face": "sans-serif",
                    }
                ],
                "materials": [
                    {
                        "uuid": material,
                        "type": "SpriteMaterial",
                        "map": texture,
                        "transparent": True,
                        "depthTest": False,  # always readable, never hidden or boxed by a mesh
                        "depthWrite": False,
                    }
                ],
                "object": {
                    "uuid": obj,
                    "type": "Sprite",
                    "material": material,
                    "matrix": [s, 0, 0, 0, 0, s, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],
                },
            },
        }


def add_label(vis, path: str, text: str, at: np.ndarray, reach: float, size: float = 0.15) -> None:
    """``text`` above the point ``at`` in a square ``size`` × reach wide (a text too long for it
    is drawn smaller)."""
    side = size * reach
    node = vis[path]
    node.window.send(_Label(node.path, text, side))
    node.set_transform(_translation(np.asarray(at) + np.array([0.0, 0.0, 0.3 * side])))


def add_instrument(vis, where: np.ndarray, points: np.ndarray, colors, reach: float) -> None:
    import meshcat.geometry as mg

    side = 0.05 * reach
    vis[f"{ROOT}/instrument/body"].set_object(mg.Box([side, side, side]), material("#303030"))
    vis[f"{ROOT}/instrument/body"].set_transform(_translation(where))
    for i, color in enumerate(colors):
        ends = []
        for p in points[i]:
            ends += [where, p]
        vertices = np.array(ends, dtype=np.float32).T
        vis[f"{ROOT}/instrument/sight_lines/pose_{i + 1:02d}"].set_object(
            mg.LineSegments(mg.PointsGeometry(vertices), mg.LineBasicMaterial(color=_hex_int(color)))
        )


def _joint_origins(robot: Robot, qs: np.ndarray) -> np.ndarray:
    """(m·njoints, 3) every joint's origin at each configuration, instrument frame [m]."""
    origins = ForwardKinematics(robot).placements(np.asarray(qs, dtype=float)).joint_translations
    return (origins.reshape(-1, 3) @ robot.base.rotation.T + robot.base.translation).reshape(-1, 3)


VIEW_PAD = 0.08
"""Padding around the joint origins and points the view frames, as a fraction of the robot's reach
(the links' thickness)."""

FIELD_OF_VIEW = 75.0
"""meshcat's vertical field of view [deg]."""


def set_view(vis, robot: Robot, qs: np.ndarray, reach: float, extra: np.ndarray | None = None) -> np.ndarray:
    """A light background, and a view that frames every pose of the robot: returns the centre [m].

    meshcat's camera looks at, and turns about, its origin: the scene's root is shifted so that
    the centre of the box holding every joint origin, tip and marker of ``qs`` (and the ``extra``
    points, e.g. the cell's obstacles), padded by :data:`VIEW_PAD` × reach, is there; the camera
    stands far enough for the sphere around that box to fit its field of view (nothing cut at
    the top), and the grid lies at the robot's base plane, or under the lowest point when
    something is below it (nothing hidden under the floor).
    """
    vis["/Background"].set_property("top_color", [0.98, 0.98, 0.98])  # RGB in [0, 1]
    vis["/Background"].set_property("bottom_color", [0.78, 0.8, 0.84])
    pts = _joint_origins(robot, qs) if len(qs) else np.zeros((1, 3))
    pts = np.vstack([pts, robot.points(qs, check=False).reshape(-1, 3) if len(qs) else pts])
    if extra is not None and len(extra):
        pts = np.vstack([pts, np.asarray(extra, dtype=float).reshape(-1, 3)])
    pad = VIEW_PAD * reach
    lo, hi = pts.min(axis=0) - pad, pts.max(axis=0) + pad
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 0.3 * reach)
    vis[ROOT].set_transform(_translation(-centre))
    vis["/Axes"].set_transform(_translation(-centre))
    low = float(pts[:, 2].min())
    floor = low - pad if low < 0 else 0.0
    vis["/Grid"].set_transform(_translation(np.array([-centre[0], -centre[1], floor - centre[2]])))
    extent = hi - lo
    direction = np.array([1.0, -1.4, 0.9])
    if extent[2] < 0.1 * max(extent.max(), 1e-9):  # a planar robot: look from above
        direction = np.array([0.3, -0.6, 1.6])
    distance = 1.05 * radius / np.sin(np.radians(FIELD_OF_VIEW / 2))
    eye = direction / np.linalg.norm(direction) * distance
    # The camera sits under /Cameras/default/rotated, whose axes are (x, z, -y) of the world's.
    vis["/Cameras/default/rotated/<object>"].set_property("position", [eye[0], eye[2], -eye[1]])
    return centre
