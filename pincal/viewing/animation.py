"""See a campaign: the robot running it as an animation, in the same meshcat scene as a plan.

The scene holds, under ``/meshcat/pincal``:

* ``campaign/robot``: the robot, opaque, animated along the campaign — home, every move (joint-space
  straight lines, detours through their via points), a short stop at each pose — played by
  meshcat's animation controls (open "Animations" in the viewer's menu: play, pause, the time slider);
* ``campaign/poses/pose_<k>``: the measured point(s) at the k-th pose *in execution order*, each
  with its number, coloured from the first to the last;
* ``campaign/path``: the path the first marker follows over the whole campaign;
* ``cell``: the workcell's obstacles (grey) and, for a mount given as a plane, that plane.

The view frames the robot at every configuration it passes and the cell (see
:func:`~pincal.viewing.drawing.set_view`). The animation runs at ``speedup`` times real time, the
stops shown for ``stop_shown`` seconds each. meshcat is imported when a scene is built.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from pincal.campaign.result import HOME, Campaign
from pincal.errors import BadArgument
from pincal.model.collision import reach as robot_reach
from pincal.model.kinematics import ForwardKinematics
from pincal.optional import require
from pincal.outputs import atomic_write_text
from pincal.planning.constraints import AnyConstraint, Mount, Workcell
from pincal.viewing.drawing import (
    ROOT,
    add_label,
    add_points,
    add_robot,
    geometry_models,
    material,
    rgb,
    set_view,
)
from pincal.viewing.scene import pose_colors, static_viewer

ROBOT_COLOR = "#2b3a4e"
"""Colour of the animated robot."""

CELL_COLOR = "#8c8c8c"
"""Colour of the cell's obstacles."""

PATH_COLOR = "#d62728"
"""Colour of the marker's path."""


@dataclass(frozen=True, eq=False)
class CampaignScene:
    """A campaign's animated scene (see the module doc).

    Attributes:
        viewer: the ``meshcat.Visualizer`` holding it.
        campaign: the campaign shown.
        times: (m,) when the animation reaches each pose, in execution order [s].
        duration: the animation's length [s].
        frames: its number of frames.
        fps: frames per second.
    """

    viewer: Any
    campaign: Campaign
    times: np.ndarray
    duration: float
    frames: int
    fps: float

    def html(self) -> str:
        """One self-contained HTML page (meshcat's static export, the animation included)."""
        return self.viewer.static_html()

    def save_html(self, path: str | os.PathLike) -> Path:
        """Write :meth:`html` atomically; return the path."""
        return atomic_write_text(path, self.html())


def _frames(
    campaign: Campaign, fps: float, speedup: float, stop_shown: float
) -> tuple[np.ndarray, np.ndarray]:
    """(configurations of every frame (n, nq), the frame at which each pose is reached (m,))."""
    timing = campaign.timing
    qs: list[np.ndarray] = [campaign.home]
    arrivals = []

    def move(a: np.ndarray, b: np.ndarray) -> None:
        steps = max(1, int(np.ceil(timing.move_time(a, b) / speedup * fps)))
        for s in np.arange(1, steps + 1) / steps:
            qs.append(a + s * (b - a))

    q = campaign.home
    for mv in campaign.moves:
        end = campaign.home if mv.end == HOME else campaign.plan.q[mv.end]
        if mv.detour is not None:
            move(q, mv.detour.via)
            q = mv.detour.via
        move(q, end)
        q = end
        if mv.end != HOME:
            arrivals.append(len(qs) - 1)
            qs.extend([end] * max(1, int(round(stop_shown * fps))))
    return np.array(qs), np.array(arrivals, dtype=int)


def campaign_scene(
    campaign: Campaign,
    constraints: Iterable[AnyConstraint] = (),
    *,
    viewer: object = "static",
    fps: float = 10.0,
    speedup: float = 1.0,
    stop_shown: float = 0.5,
) -> CampaignScene:
    """The campaign as an animated meshcat scene (see the module doc).

    Args:
        campaign: a :func:`~pincal.campaign.schedule.plan_campaign` result.
        constraints: the cell (a Workcell's obstacles are drawn; a Mount given as a plane too).
        viewer: a ``meshcat.Visualizer``, or ``"static"`` (no server: save with
            :meth:`CampaignScene.save_html`).
        fps: frames per second of the animation.
        speedup: how many times faster than real time the moves are shown.
        stop_shown: how long each stop at a pose is shown [s].

    Raises:
        MissingDependency: meshcat is not installed.
        BadArgument: a non-positive fps, speedup or a negative stop_shown.
    """
    for value, name in ((fps, "fps"), (speedup, "speedup")):
        if not (np.isfinite(value) and value > 0):
            raise BadArgument(f"{name} must be a positive number, got {value!r}", argument=name)
    if not (np.isfinite(stop_shown) and stop_shown >= 0):
        raise BadArgument(f"stop_shown must be seconds ≥ 0, got {stop_shown!r}", argument="stop_shown")
    meshcat = require("meshcat", "pincal campaign --html", "meshcat")
    from meshcat.animation import Animation

    robot = campaign.robot
    vis = static_viewer() if isinstance(viewer, str) and viewer == "static" else viewer
    if not isinstance(vis, meshcat.Visualizer):
        raise BadArgument(
            f"viewer must be a meshcat.Visualizer or 'static', got {viewer!r}", argument="viewer"
        )
    vis[ROOT].delete()
    reach = robot_reach(robot)
    visual, _ = geometry_models(robot, reach)
    frames, arrivals = _frames(campaign, fps, speedup, stop_shown)

    # The poses in execution order: their points, numbered, coloured from first to last.
    order = list(campaign.order)
    colors = pose_colors(len(order))
    points = robot.points(campaign.plan.q[order], check=False) if order else np.empty((0, robot.n_markers, 3))
    for k, color in enumerate(colors):
        node = f"{ROOT}/campaign/poses/pose_{k + 1:02d}"
        add_points(vis, node, points[k], reach, color)
        add_label(vis, f"{node}/label", str(k + 1), points[k].mean(axis=0), reach)
    _draw_path(vis, robot.points(frames, check=False)[:, 0])
    corners = _draw_cell(vis, robot, constraints, reach)

    # The robot, then one keyframe per frame for each of its shapes.
    path = f"{ROOT}/campaign/robot"
    viz = add_robot(vis, robot, visual, campaign.home, path, rgb(ROBOT_COLOR) + (1.0,))
    forward, gdata = ForwardKinematics(robot), visual.createData()
    animation = Animation(default_framerate=fps)
    names = [viz.getViewerNodeName(o, pin.GeometryType.VISUAL) for o in visual.geometryObjects]
    for i, q in enumerate(frames):
        forward.place_geometry(visual, gdata, q)
        with animation.at_frame(vis, i) as frame:
            for g, obj in enumerate(visual.geometryObjects):
                T = gdata.oMg[g].homogeneous.copy()
                T[:3, :3] = T[:3, :3] * np.asarray(obj.meshScale)[None, :]
                frame[names[g]].set_transform(T)
    vis.set_animation(animation, play=False, repetitions=1)
    set_view(vis, robot, frames[:: max(1, len(frames) // 200)], reach, corners)
    return CampaignScene(vis, campaign, arrivals / fps, len(frames) / fps, len(frames), float(fps))


def _draw_path(vis, points: np.ndarray) -> None:
    import meshcat.geometry as mg

    if len(points) < 2:
        return
    ends = np.repeat(points, 2, axis=0)[1:-1].T.astype(np.float32)  # segments between frames
    vis[f"{ROOT}/campaign/path"].set_object(
        mg.LineSegments(mg.PointsGeometry(ends), mg.LineBasicMaterial(color=int(PATH_COLOR[1:], 16)))
    )


def _draw_cell(vis, robot, constraints: Iterable[AnyConstraint], reach: float) -> np.ndarray:
    """Draw the workcell's obstacles (and a mount given as a plane); return points of their extent
    (the corners of their bounding boxes) in the instrument frame."""
    from pinocchio.visualize import MeshcatVisualizer

    corners = []
    objects = [obj for c in constraints if isinstance(c, Workcell) for obj in c.geometry_objects()]
    if objects:
        cell = pin.GeometryModel()
        for obj in objects:
            cell.addGeometryObject(obj)
            obj.geometry.computeLocalAABB()
            lo, hi = np.array(obj.geometry.aabb_local.min_), np.array(obj.geometry.aabb_local.max_)
            box = np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
            placed = robot.base * obj.placement
            corners.append(box @ placed.rotation.T + placed.translation)
        empty = pin.Model()
        viz = MeshcatVisualizer(empty, None, cell)
        viz.initViewer(viewer=vis)
        viz.loadViewerModel(rootNodeName=f"{ROOT}/cell", visual_color=list(rgb(CELL_COLOR) + (0.6,)))
        vis[f"{ROOT}/cell"].set_transform(robot.base.homogeneous)
        viz.display(np.zeros(0))
    for c in constraints:
        if isinstance(c, Mount) and c.kind == "plane":
            import meshcat.geometry as mg

            side = 1.5 * reach
            n = np.array(c.normal)
            rotation = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), n).toRotationMatrix()
            placement = robot.base * pin.SE3(rotation, n * c.offset)
            vis[f"{ROOT}/cell/mount_plane"].set_object(
                mg.Box([side, side, 0.002 * reach]), material(CELL_COLOR, 0.25)
            )
            vis[f"{ROOT}/cell/mount_plane"].set_transform(placement.homogeneous)
    return np.vstack(corners) if corners else np.empty((0, 3))
