"""See a measurement plan: a meshcat scene of the measurement poses against the test pose.

The scene holds, under ``/meshcat/pincal``:

* ``test_poses/test_<k>``: the robot at each test pose, opaque and highlighted (dark, among the
  pastel ghosts); the measured point(s) there; and the **ellipsoid of the predicted
  post-calibration error** (amber) — the 3σ ellipsoid of ``pincal.position_covariance``
  (σ² J₀ M⁻¹ J₀ᵀ), drawn ``ellipsoid_scale`` times larger than life so that it can be seen (the
  factor is written next to it: "q0 3σ ×2000").
* ``ghosts/pose_<i>``: one translucent "ghost" of the robot per measurement configuration, each
  in its own colour, with its measured point(s) as spheres and its number as a label.
* ``instrument``: the instrument (a dark box) and its lines of sight, when its position is given.
* ``error_cloud``: with ``error_samples``, the measured point at each sampled configuration,
  coloured by the predicted error after calibration there (green: the smallest, red: the largest,
  on a log scale; the range is written next to it): where the plan leaves the robot accurate.

Robots whose URDF has meshes (example-robot-data) show them, through Pinocchio's
``MeshcatVisualizer`` and the URDF's geometry models: the test pose with its visual meshes, the
ghosts with the collision meshes when the URDF has some (a scene stays a few MB instead of a few
tens). Kinematic-only robots (``kr270``, ``planar_2r``, a bare ``pinocchio.Model``) are drawn as
cylinders between the joint frames, with a thicker cylinder along each joint axis.

A scene goes to a meshcat server (:func:`show` starts one) or to a *static* viewer that needs no
server (``viewer="static"``), whose :meth:`Scene.save_html` writes one self-contained HTML file
that opens offline in any browser. meshcat is imported only when a scene is built.
"""

from __future__ import annotations

import colorsys
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from pincal.arguments import DEFAULT_SIGMA
from pincal.errors import BadConfiguration, SingularPlan
from pincal.evaluation.accuracy import PredictedError
from pincal.evaluation.prior import Prior
from pincal.evaluation.test_pose import position_covariance
from pincal.files import atomic_write_text
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.optional import require

if TYPE_CHECKING:  # meshcat is imported when a scene is built
    from meshcat import Visualizer

ROOT = "pincal"
"""Name of the scene's root node (under meshcat's ``/meshcat``)."""

ELLIPSOID_SIGMAS = 3.0
"""The error ellipsoid is the ELLIPSOID_SIGMAS-σ ellipsoid of the predicted covariance."""

ELLIPSOID_SIZE = 0.1
"""With ``scale=None`` the drawn ellipsoid's largest semi-axis is about this fraction of the
robot's reach (the factor is rounded down to 1, 2 or 5 times a power of ten)."""

MIN_DRAWN_AXIS = 0.02
"""A semi-axis is drawn at least this fraction of the largest one (a planar robot's ellipsoid is
flat: its third axis is zero). :attr:`Scene.ellipsoid_radii` keeps the true values."""

GHOST_OPACITY = 0.35
"""Opacity of the measurement-pose ghosts (the test pose is opaque)."""

TEST_POSE_COLOR = "#2b3a4e"
"""Colour of the robot at the test pose (opaque dark slate, among translucent pastel ghosts)."""

ELLIPSOID_COLOR = "#f59b00"
"""Colour of the error ellipsoid (amber; the ghosts' palette leaves it out)."""

# tab20 without its oranges: distinct colours for up to 18 poses, then evenly spaced hues.
_PALETTE = (
    "#1f77b4", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
    "#7f7f7f", "#aec7e8", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#9edae5",
    "#dbdb8d", "#393b79",
)  # fmt: skip

_STICK_LINK = 0.018
_STICK_JOINT = 0.032
_STICK_JOINT_LENGTH = 0.085
_POINT_RADIUS = 0.012
"""Sizes of the stick robot and of the point spheres, as fractions of the robot's reach."""


def pose_colors(m: int) -> tuple[str, ...]:
    """``m`` distinct ``#rrggbb`` colours, one per measurement configuration."""
    if m <= len(_PALETTE):
        return _PALETTE[:m]
    hues = (0.55 + np.arange(m) / m) % 1.0
    return tuple(
        "#{:02x}{:02x}{:02x}".format(*(int(255 * c) for c in colorsys.hsv_to_rgb(h, 0.75, 0.85)))
        for h in hues
    )


def _rgb(color: str) -> tuple[float, float, float]:
    return tuple(int(color[i : i + 2], 16) / 255.0 for i in (1, 3, 5))  # type: ignore[return-value]


def _hex_int(color: str) -> int:
    return int(color[1:], 16)


@dataclass(frozen=True, eq=False)
class Scene:
    """A scene built by :func:`scene`, and what it shows.

    Attributes:
        viewer: the ``meshcat.Visualizer`` holding the scene.
        plan: (m, nq) measurement configurations [rad or m].
        test_poses: (k, nq) test poses (k = 0 when none was given).
        colors: ``#rrggbb`` colour of each measurement configuration.
        sigma: measurement noise per coordinate [m] used for the ellipsoids.
        covariance: (k, 3K, 3K) predicted covariance of the measured points at each test pose
            after calibration [m²], or None (no test pose, or a plan that cannot identify the
            parameters: see ``note``).
        ellipsoid_radii: (k, K, 3) true semi-axes of the 3σ ellipsoids [m], largest first.
        ellipsoid_axes: (k, K, 3, 3) their directions (columns, instrument frame).
        ellipsoid_scale: factor by which the ellipsoids are drawn larger than life.
        rho0: (k,) expected position error at each test pose [m] (sqrt of the covariance's trace).
        note: why something is missing from the scene, or "".
        error_samples: (n, nq) configurations of the error cloud, or None.
        error_values: (n,) predicted error after calibration at each [m], or None.
    """

    viewer: Any
    plan: np.ndarray
    test_poses: np.ndarray
    colors: tuple[str, ...]
    sigma: float
    covariance: np.ndarray | None
    ellipsoid_radii: np.ndarray | None
    ellipsoid_axes: np.ndarray | None
    ellipsoid_scale: float
    rho0: np.ndarray | None
    note: str = ""
    error_samples: np.ndarray | None = None
    error_values: np.ndarray | None = None

    def html(self) -> str:
        """The scene as one self-contained HTML page (meshcat's static export)."""
        return self.viewer.static_html()

    def save_html(self, path: str | os.PathLike) -> Path:
        """Write :meth:`html` to ``path`` atomically; return the path."""
        return atomic_write_text(path, self.html())


def static_viewer() -> Visualizer:
    """A ``meshcat.Visualizer`` that needs no server: it records the scene for static export.

    Its ``static_html()`` is the self-contained page meshcat's server would give; it opens offline.
    """
    meshcat = require("meshcat", "pincal.visualize", "meshcat")
    from pincal.viewing.static_page import StaticWindow

    return meshcat.Visualizer(window=StaticWindow())


def show(
    params_or_robot: ParameterSet | Robot,
    plan: object,
    test_pose: object = None,
    sigma: float = DEFAULT_SIGMA,
    instrument: object = None,
    scale: float | None = None,
    viewer: object = None,
    error_samples: object = None,
    prior: Prior | None = None,
) -> Visualizer:
    """Show a plan in meshcat: ghosts of the measurement poses, the test pose and its error.

    Args:
        params_or_robot: the parameters identified (they set the error ellipsoid), or a Robot
            (then the identifiable base set of ``full,offsets``).
        plan: (m, nq) measurement configurations [rad or m], or a :class:`~pincal.Plan`.
        test_pose: (nq,) or (k, nq) test pose(s), or None.
        sigma: measurement noise per coordinate [m]: the ellipsoid is the 3σ ellipsoid of
            σ² J₀ M⁻¹ J₀ᵀ.
        instrument: position (x, y, z) of the instrument in the base/instrument frame [m], or a
            :class:`pincal.planning.constraints.Visibility` constraint (its tracker), or None.
        scale: how many times larger than life the ellipsoid is drawn; None chooses a factor
            (1, 2 or 5 × 10^n) that makes its largest semi-axis about a tenth of the robot's reach
            (see :attr:`Scene.ellipsoid_scale`, written next to it in the scene).
        viewer: a ``meshcat.Visualizer`` to draw into, ``"static"`` for a serverless one (see
            :func:`static_viewer`), or None to start a meshcat server (its URL is printed).
        error_samples: configurations, or a number of random ones, at which the measured point is
            drawn coloured by the predicted error after calibration (green low, red high).
        prior: the errors' prior for that prediction, or None.

    Returns:
        the ``meshcat.Visualizer``; :func:`scene` returns the full :class:`Scene`.

    Raises:
        MissingDependency: meshcat is not installed.
        BadConfiguration: a configuration of the wrong size or outside the joint limits.
    """
    return scene(
        params_or_robot, plan, test_pose, sigma, instrument, scale, viewer, error_samples, prior
    ).viewer


def scene(
    params_or_robot: ParameterSet | Robot,
    plan: object,
    test_pose: object = None,
    sigma: float = DEFAULT_SIGMA,
    instrument: object = None,
    scale: float | None = None,
    viewer: object = "static",
    error_samples: object = None,
    prior: Prior | None = None,
) -> Scene:
    """Build the scene of :func:`show` (same arguments) and return it with what it shows.

    The default ``viewer="static"`` needs no server: save the result with :meth:`Scene.save_html`.

    Args (beyond :func:`show`'s):
        error_samples: configurations (n, nq) — or a number n of configurations drawn within the
            joint limits (seed 0) — at which to draw the measured point coloured by the predicted
            error after calibration with ``plan`` (see the module doc).
        prior: the errors' prior for that prediction (and the ellipsoids are still σ²J₀M⁻¹J₀ᵀ).
    """
    meshcat = require("meshcat", "pincal.visualize", "meshcat")
    if isinstance(params_or_robot, ParameterSet):
        params = params_or_robot
    elif isinstance(params_or_robot, Robot):
        params = params_or_robot.parameters("full,offsets").identifiable().identifiable
    else:
        raise BadConfiguration(
            f"expected a pincal ParameterSet or Robot, got {type(params_or_robot).__name__}"
        )
    if not (np.isfinite(sigma) and sigma > 0):
        raise BadConfiguration(f"sigma must be a positive number of metres, got {sigma!r}")
    if scale is not None and not (np.isfinite(scale) and scale > 0):
        raise BadConfiguration(f"scale must be a positive number, got {scale!r}")
    robot = params.robot
    qs = robot.configurations(plan)
    q0 = np.empty((0, robot.nq)) if test_pose is None else robot.configurations(test_pose, what="test pose")
    where = _instrument_position(instrument)

    vis = _viewer(meshcat, viewer)
    vis[ROOT].delete()  # a viewer reused for another plan starts afresh
    reach = _reach(robot)
    colors = pose_colors(len(qs))
    visual, ghost = _geometry_models(robot, reach)
    points = _draw_ghosts(vis, robot, ghost, qs, colors, reach)
    cov, note = None, ""
    if len(q0):
        try:
            cov = position_covariance(params, qs, q0, sigma)
        except SingularPlan as exc:
            note = f"no error ellipsoid: {exc}"
            warnings.warn(note, stacklevel=2)
    radii = axes = rho = None
    drawn_scale = 1.0 if scale is None else float(scale)
    if cov is not None:
        radii, axes = _ellipsoids(cov, robot.n_markers)
        rho = np.sqrt(np.trace(cov, axis1=1, axis2=2))
        if scale is None:
            drawn_scale = _nice_scale(ELLIPSOID_SIZE * reach / max(radii.max(), 1e-300))
    _draw_test_poses(vis, robot, visual, q0, radii, axes, drawn_scale, reach)
    samples = values = None
    if error_samples is not None:
        if isinstance(error_samples, (int, np.integer)) and not isinstance(error_samples, bool):
            samples = robot.random_configurations(int(error_samples), 0)
        else:
            samples = robot.configurations(error_samples, what="error sample")
        try:
            values = PredictedError(params, qs, sigma, prior)(samples)
            _add_error_cloud(vis, robot.points(samples)[:, 0], values, reach)
        except SingularPlan as exc:
            note = (note + "; " if note else "") + f"no error cloud: {exc}"
            samples = None
    if where is not None:
        _add_instrument(vis, where, points, colors, reach)
    _set_view(vis, robot, np.vstack([qs, q0]), reach)
    return Scene(
        viewer=vis,
        plan=qs,
        test_poses=q0,
        colors=colors,
        sigma=float(sigma),
        covariance=cov,
        ellipsoid_radii=radii,
        ellipsoid_axes=axes,
        ellipsoid_scale=drawn_scale,
        rho0=rho,
        note=note,
        error_samples=samples,
        error_values=values,
    )


def _viewer(meshcat, viewer: object):
    if viewer is None:
        return meshcat.Visualizer()
    if isinstance(viewer, str) and viewer == "static":
        return static_viewer()
    if isinstance(viewer, meshcat.Visualizer):
        return viewer
    raise BadConfiguration(f"viewer must be a meshcat.Visualizer, 'static' or None, got {viewer!r}")


def _draw_ghosts(vis, robot: Robot, geom, qs: np.ndarray, colors, reach: float) -> np.ndarray:
    """One translucent robot per configuration, its measured points and its number; returns the
    (m, K, 3) points [m]."""
    points = robot.points(qs) if len(qs) else np.empty((0, robot.n_markers, 3))
    for i, (q, color) in enumerate(zip(qs, colors, strict=True)):
        node = f"{ROOT}/ghosts/pose_{i + 1:02d}"
        _add_robot(vis, robot, geom, q, f"{node}/robot", _rgb(color) + (GHOST_OPACITY,))
        _add_points(vis, node, points[i], reach, color)
        _add_label(vis, f"{node}/label", str(i + 1), points[i].mean(axis=0), reach)
    return points


def _draw_test_poses(
    vis, robot: Robot, geom, q0: np.ndarray, radii, axes, scale: float, reach: float
) -> None:
    """The opaque robot at each test pose, its points, and their error ellipsoids ``scale`` × life."""
    p0 = robot.points(q0) if len(q0) else np.empty((0, robot.n_markers, 3))
    for k, q in enumerate(q0):
        node = f"{ROOT}/test_poses/test_{k + 1}"
        _add_robot(vis, robot, geom, q, f"{node}/robot", _rgb(TEST_POSE_COLOR) + (1.0,))
        _add_points(vis, node, p0[k], reach, "#000000", 0.6)
        text = "q0" if len(q0) == 1 else f"q0,{k + 1}"
        if radii is not None:
            for j in range(robot.n_markers):
                _add_ellipsoid(vis, f"{node}/ellipsoid_{j}", p0[k, j], radii[k, j] * scale, axes[k, j])
            text += f" 3σ ×{scale:g}"
        _add_label(vis, f"{node}/label", text, p0[k].mean(axis=0), reach, size=0.4)


# ---------------------------------------------------------------------------- numbers
def _instrument_position(instrument: object) -> np.ndarray | None:
    if instrument is None:
        return None
    value = getattr(instrument, "tracker", getattr(instrument, "position", instrument))
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise BadConfiguration(f"instrument: expected a position (x, y, z) in metres, got {value!r}")
    return arr


def _reach(robot: Robot) -> float:
    """A length scale of the robot [m]: the sum of its link offsets and the farthest marker."""
    model = robot.model
    links = sum(np.linalg.norm(model.jointPlacements[j].translation) for j in range(1, model.njoints))
    tip = model.frames[robot.tip_frame].placement
    markers = np.linalg.norm(robot.markers @ tip.rotation.T + tip.translation, axis=1).max()
    return float(max(links + markers, 1e-3))


def _ellipsoids(cov: np.ndarray, n_markers: int) -> tuple[np.ndarray, np.ndarray]:
    """3σ semi-axes (k, K, 3), largest first, and axes (k, K, 3, 3) of each marker's 3×3 block."""
    k = len(cov)
    radii = np.empty((k, n_markers, 3))
    axes = np.empty((k, n_markers, 3, 3))
    for i in range(k):
        for j in range(n_markers):
            block = cov[i, 3 * j : 3 * j + 3, 3 * j : 3 * j + 3]
            w, v = np.linalg.eigh(0.5 * (block + block.T))
            w, v = w[::-1], v[:, ::-1]
            if np.linalg.det(v) < 0:
                v[:, 2] = -v[:, 2]
            radii[i, j] = ELLIPSOID_SIGMAS * np.sqrt(np.clip(w, 0.0, None))
            axes[i, j] = v
    return radii, axes


def _nice_scale(x: float) -> float:
    """The largest of 1, 2, 5 × 10^n not above ``x`` (below 1 when ``sigma`` is large, e.g.
    σ = 1 m, which gives ρ0/σ)."""
    exponent = np.floor(np.log10(x))
    mantissa = x / 10**exponent
    return float(max(m for m in (1.0, 2.0, 5.0) if m <= mantissa * (1 + 1e-12)) * 10**exponent)


# ---------------------------------------------------------------------------- geometry
def _geometry_models(robot: Robot, reach: float) -> tuple[pin.GeometryModel, pin.GeometryModel]:
    """(test-pose model, ghost model): the URDF's visual and collision meshes, or sticks."""
    visual = _urdf_geometry(robot, pin.GeometryType.VISUAL)
    if visual is None:
        sticks = _stick_geometry(robot, reach)
        return sticks, sticks
    collision = _urdf_geometry(robot, pin.GeometryType.COLLISION)
    return visual, collision if collision is not None else visual


def _urdf_geometry(robot: Robot, kind: pin.GeometryType) -> pin.GeometryModel | None:
    """The URDF's geometry model of ``kind`` on the robot's chain, or None if it has none.

    ``package://`` URIs are looked up in every folder above the URDF (the example-robot-data
    layout, and a ROS workspace's).
    """
    if robot.urdf_path is None:
        return None
    path = Path(robot.urdf_path)
    dirs = [str(p) for p in path.resolve().parents]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            geom = pin.buildGeomFromUrdf(robot.model, str(path), kind, package_dirs=dirs)
    except Exception as exc:  # missing mesh files, unreadable meshes
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        warnings.warn(f"{path.name}: cannot load its {kind.name.lower()} meshes ({first})", stacklevel=3)
        return None
    if geom.ngeoms == 0:
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
    z = np.array([0.0, 0.0, 1.0])

    def cylinder(name: str, joint: int, start: np.ndarray, end: np.ndarray, radius: float) -> None:
        d = np.asarray(end, float) - np.asarray(start, float)
        length = float(np.linalg.norm(d))
        if length < 1e-9:
            return
        rotation = pin.Quaternion.FromTwoVectors(z, d / length).toRotationMatrix()
        placement = pin.SE3(rotation, 0.5 * (np.asarray(start) + np.asarray(end)))
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
def _add_robot(vis, robot: Robot, geom: pin.GeometryModel, q: np.ndarray, path: str, rgba) -> None:
    from pinocchio.visualize import MeshcatVisualizer

    viz = MeshcatVisualizer(robot.model, None, geom)
    viz.initViewer(viewer=vis)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # meshcat's own deprecation chatter
        viz.loadViewerModel(rootNodeName=path, visual_color=list(rgba))
    vis[path].set_transform(robot.base.homogeneous)
    viz.display(q + robot.joint_offsets)


def _material(color: str, opacity: float = 1.0):
    import meshcat.geometry as mg

    return mg.MeshPhongMaterial(color=_hex_int(color), opacity=opacity, transparent=opacity < 1.0)


def _translation(p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = p
    return T


def _add_points(vis, node: str, points: np.ndarray, reach: float, color: str, size: float = 1.0) -> None:
    import meshcat.geometry as mg

    for j, p in enumerate(points):
        path = f"{node}/marker_{j}"
        vis[path].set_object(mg.Sphere(size * _POINT_RADIUS * reach), _material(color))
        vis[path].set_transform(_translation(p))


def error_colors(values: np.ndarray) -> np.ndarray:
    """(n, 3) RGB in [0, 1] for errors ``values``: green at the smallest, through yellow, to red at
    the largest, on a log scale."""
    logs = np.log(np.maximum(values, 1e-300))
    span = logs.max() - logs.min()
    t = (logs - logs.min()) / span if span > 0 else np.zeros_like(logs)
    return np.array([colorsys.hsv_to_rgb(0.33 * (1.0 - x), 0.85, 0.9) for x in t])


def _add_error_cloud(vis, points: np.ndarray, values: np.ndarray, reach: float) -> None:
    import meshcat.geometry as mg

    node = f"{ROOT}/error_cloud"
    cloud = mg.PointCloud(points.T, error_colors(values).T, size=0.6 * _POINT_RADIUS * reach)
    vis[node].set_object(cloud)
    top = points[np.argmax(points[:, 2])]
    low, high = values.min() * 1e3, values.max() * 1e3
    _add_label(vis, f"{node}/range", f"error {low:.3g}–{high:.3g} mm", top, reach, size=0.3)


def _add_ellipsoid(vis, path: str, centre: np.ndarray, radii: np.ndarray, axes: np.ndarray) -> None:
    import meshcat.geometry as mg

    drawn = np.maximum(radii, MIN_DRAWN_AXIS * radii.max())
    vis[path].set_object(mg.Ellipsoid(drawn), _material(ELLIPSOID_COLOR, 0.6))
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


def _add_label(vis, path: str, text: str, at: np.ndarray, reach: float, size: float = 0.15) -> None:
    """``text`` above the point ``at`` in a square ``size`` × reach wide (a text too long for it
    is drawn smaller)."""
    side = size * reach
    node = vis[path]
    node.window.send(_Label(node.path, text, side))
    node.set_transform(_translation(np.asarray(at) + np.array([0.0, 0.0, 0.3 * side])))


def _add_instrument(vis, where: np.ndarray, points: np.ndarray, colors, reach: float) -> None:
    import meshcat.geometry as mg

    side = 0.05 * reach
    vis[f"{ROOT}/instrument/body"].set_object(mg.Box([side, side, side]), _material("#303030"))
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
    model, data = robot.model, robot.model.createData()
    out = []
    for q in qs + robot.joint_offsets:
        pin.forwardKinematics(model, data, q)
        out.extend((robot.base * data.oMi[j]).translation for j in range(model.njoints))
    return np.array(out).reshape(-1, 3)


def _set_view(vis, robot: Robot, qs: np.ndarray, reach: float) -> None:
    """A light background and a camera that sees every pose of the robot (meshcat's camera looks
    at the origin; a far instrument may be out of the first view: zoom out to see it)."""
    vis["/Background"].set_property("top_color", [0.98, 0.98, 0.98])  # RGB in [0, 1]
    vis["/Background"].set_property("bottom_color", [0.78, 0.8, 0.84])
    pts = _joint_origins(robot, qs) if len(qs) else np.zeros((1, 3))
    pts = np.vstack([pts, robot.points(qs).reshape(-1, 3) if len(qs) else pts])
    extent = np.ptp(pts, axis=0)
    direction = np.array([1.0, -1.4, 0.9])
    if extent[2] < 0.05 * max(extent.max(), 1e-9):  # a planar robot: look from above
        direction = np.array([0.3, -0.6, 1.6])
    # meshcat's camera (75° field of view) looks at the origin: keep every point in sight.
    radius = max(np.linalg.norm(pts, axis=1).max(), 0.3 * reach)
    eye = direction / np.linalg.norm(direction) * 1.7 * radius
    # The camera sits under /Cameras/default/rotated, whose axes are (x, z, -y) of the world's.
    vis["/Cameras/default/rotated/<object>"].set_property("position", [eye[0], eye[2], -eye[1]])
