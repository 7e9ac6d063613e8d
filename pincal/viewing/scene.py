"""See a measurement plan: a meshcat scene of the measurement poses against the test pose.

The scene holds, under ``/meshcat/pincal``:

* ``test_poses/test_<k>``: the robot at each test pose, opaque and highlighted (dark, among the
  pastel ghosts); the measured point(s) there; and the **ellipsoid of the predicted
  post-calibration error** (amber) — the 3σ ellipsoid of ``pincal.evaluation.position_covariance``
  (σ² J₀ M⁻¹ J₀ᵀ), drawn ``ellipsoid_scale`` times larger than life so that it can be seen (the
  factor is written next to it: "q0 3σ ×2000").
* ``ghosts/pose_<i>``: one translucent "ghost" of the robot per measurement configuration, each
  in its own colour, with its measured point(s) as spheres and its number as a label.
* ``instrument``: the instrument (a dark box) and its lines of sight, when its position is given
  (``instrument_at=``, or the position of an ``instrument=`` whose error model is a tracker).
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
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pincal.arguments import ratio
from pincal.deprecation import keywords_after, renamed_keyword
from pincal.errors import BadConfiguration, SingularPlan, warn
from pincal.evaluation.predicted_error import PredictedError
from pincal.evaluation.prior import Prior
from pincal.evaluation.test_pose import position_covariance
from pincal.instruments.error_model import ErrorModel, Tracker
from pincal.instruments.given import instrument_of, keywords
from pincal.instruments.instrument import Instrument
from pincal.model.collision import reach as robot_reach
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.optional import require
from pincal.outputs import atomic_write_text
from pincal.planning.plan import Plan
from pincal.typing import ConfigurationsLike, InstrumentAt, PayloadLike, ViewerLike
from pincal.viewing.drawing import (
    ROOT,
    add_ellipsoid,
    add_error_cloud,
    add_instrument,
    add_label,
    add_points,
    add_robot,
    geometry_models,
    rgb,
    set_view,
)

if TYPE_CHECKING:  # meshcat is imported when a scene is built
    from meshcat import Visualizer

ELLIPSOID_SIGMAS = 3.0
"""The error ellipsoid is the ELLIPSOID_SIGMAS-σ ellipsoid of the predicted covariance."""

ELLIPSOID_SIZE = 0.1
"""With ``scale=None`` the drawn ellipsoid's largest semi-axis is about this fraction of the
robot's reach (the factor is rounded down to 1, 2 or 5 times a power of ten)."""

GHOST_OPACITY = 0.35
"""Opacity of the measurement-pose ghosts (the test pose is opaque)."""

TEST_POSE_COLOR = "#2b3a4e"
"""Colour of the robot at the test pose (opaque dark slate, among translucent pastel ghosts)."""

ORDER_0_1 = ("sigma", "instrument", "scale", "viewer", "error_samples", "prior", "task_payload")
"""show()'s and scene()'s keywords in pincal 0.1's order (what arguments by position after the
third meant; ``instrument`` was the position, now ``instrument_at``)."""

AT_WHAT = " as a position"
AT_WHY = "instrument= is a pincal.instruments.Instrument across pincal; where it stands is instrument_at="


def _a_position(value: object) -> bool:
    """``instrument=`` in pincal 0.1's meaning: where the instrument stands (not an Instrument, nor
    an error model, refused as ``instrument=`` would be)."""
    return value is not None and not isinstance(value, (Instrument, ErrorModel))


# tab20 without its oranges: distinct colours for up to 18 poses, then evenly spaced hues.
_PALETTE = (
    "#1f77b4", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
    "#7f7f7f", "#aec7e8", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#9edae5",
    "#dbdb8d", "#393b79",
)  # fmt: skip


def pose_colors(m: int) -> tuple[str, ...]:
    """``m`` distinct ``#rrggbb`` colours, one per measurement configuration."""
    if m <= len(_PALETTE):
        return _PALETTE[:m]
    hues = (0.55 + np.arange(m) / m) % 1.0
    return tuple(
        "#{:02x}{:02x}{:02x}".format(*(int(255 * c) for c in colorsys.hsv_to_rgb(h, 0.75, 0.85)))
        for h in hues
    )


@dataclass(frozen=True, eq=False)
class Scene:
    """A scene built by :func:`scene`, and what it shows.

    Attributes:
        viewer: the ``meshcat.Visualizer`` holding the scene.
        plan: (m, nq) measurement configurations [rad or m].
        test_poses: (k, nq) test poses (k = 0 when none was given).
        colors: ``#rrggbb`` colour of each measurement configuration.
        sigma: measurement noise per coordinate [m] used for the ellipsoids (with an
            ``instrument``: its reference σ).
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
        instrument: what the plan is measured with (its rows weigh the prediction), or None:
            points with ``sigma``.
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
    instrument: Instrument | None = None

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


@keywords_after(3, ORDER_0_1)
@renamed_keyword("instrument", "instrument_at", AT_WHY, old_form=_a_position, what=AT_WHAT)
def show(
    params_or_robot: ParameterSet | Robot,
    plan: ConfigurationsLike,
    test_pose: ConfigurationsLike | None = None,
    *,
    sigma: float | None = None,
    instrument: Instrument | None = None,
    instrument_at: InstrumentAt = None,
    scale: float | None = None,
    viewer: ViewerLike = None,
    error_samples: int | ConfigurationsLike | None = None,
    prior: Prior | None = None,
    task_payload: PayloadLike = None,
) -> Visualizer:
    """Show a plan in meshcat: ghosts of the measurement poses, the test pose and its error.

    Args:
        params_or_robot: the parameters identified (they set the error ellipsoid), or a Robot
            (then the identifiable base set of ``full,offsets``).
        plan: (m, nq) measurement configurations [rad or m], or a :class:`~pincal.Plan`.
        test_pose: (nq,) or (k, nq) test pose(s), or None.
        sigma: the shorthand for points measured with this noise per coordinate [m] (default
            :data:`~pincal.arguments.DEFAULT_SIGMA`): the ellipsoid is the 3σ ellipsoid of
            σ² J₀ M⁻¹ J₀ᵀ. Not with ``instrument``.
        instrument: what the plan is measured with and how well
            (:class:`pincal.instruments.Instrument`): M is the information of its whitened rows
            and σ its reference σ; a :class:`~pincal.instruments.Tracker`'s position is where the
            instrument is drawn (unless ``instrument_at``). Default: points, ``sigma``.
        instrument_at: where the instrument is drawn: its position (x, y, z) in the
            base/instrument frame [m], a :class:`pincal.planning.constraints.Visibility`
            constraint (its tracker) or a Tracker (its ``at``), or None. pincal 0.1 took it as
            ``instrument=``, which keeps working until pincal 0.3 with a DeprecationWarning.
        scale: how many times larger than life the ellipsoid is drawn; None chooses a factor
            (1, 2 or 5 × 10^n) that makes its largest semi-axis about a tenth of the robot's reach
            (see :attr:`Scene.ellipsoid_scale`, written next to it in the scene).
        viewer: a ``meshcat.Visualizer`` to draw into, ``"static"`` for a serverless one (see
            :func:`static_viewer`), or None to start a meshcat server (its URL is printed).
        error_samples: configurations, or a number of random ones, at which the measured point is
            drawn coloured by the predicted error after calibration (green low, red high).
        prior: the errors' prior for that prediction, or None.
        task_payload: the payload at the test pose(s) and the error cloud's configurations (a
            mass [kg] or a :class:`~pincal.Payload`), or None; a :class:`~pincal.Plan`'s own
            payloads enter the prediction too (as :func:`pincal.rho0` takes them).

    Returns:
        the ``meshcat.Visualizer``; :func:`scene` returns the full :class:`Scene`.

    Raises:
        MissingDependency: meshcat is not installed.
        BadConfiguration: a configuration of the wrong size or outside the joint limits.
    """
    return scene(
        params_or_robot,
        plan,
        test_pose,
        sigma=sigma,
        instrument=instrument,
        instrument_at=instrument_at,
        scale=scale,
        viewer=viewer,
        error_samples=error_samples,
        prior=prior,
        task_payload=task_payload,
    ).viewer


@keywords_after(3, ORDER_0_1)
@renamed_keyword("instrument", "instrument_at", AT_WHY, old_form=_a_position, what=AT_WHAT)
def scene(
    params_or_robot: ParameterSet | Robot,
    plan: ConfigurationsLike,
    test_pose: ConfigurationsLike | None = None,
    *,
    sigma: float | None = None,
    instrument: Instrument | None = None,
    instrument_at: InstrumentAt = None,
    scale: float | None = None,
    viewer: ViewerLike = "static",
    error_samples: int | ConfigurationsLike | None = None,
    prior: Prior | None = None,
    task_payload: PayloadLike = None,
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
    params = _checked_params(params_or_robot, scale)
    measured, shorthand = instrument_of(instrument, sigma)  # σ checked; not both
    given = None if shorthand else measured  # points with one σ take their own path, as always
    sigma = measured.reference
    robot = params.robot
    qs = robot.configurations(plan)
    q0 = np.empty((0, robot.nq)) if test_pose is None else robot.configurations(test_pose, what="test pose")
    where = _instrument_position(instrument_at, given)

    vis = _viewer(meshcat, viewer)
    vis[ROOT].delete()  # a viewer reused for another plan starts afresh
    reach = robot_reach(robot)
    colors = pose_colors(len(qs))
    visual, ghost = geometry_models(robot, reach)
    points = _draw_ghosts(vis, robot, ghost, qs, colors, reach)
    plan_measured = plan if isinstance(plan, Plan) else qs  # a Plan is measured under its payloads
    cov, note, radii, axes, rho, drawn_scale = _error_ellipsoids(
        params, plan_measured, q0, sigma, scale, reach, task_payload, given
    )
    _draw_test_poses(vis, robot, visual, q0, radii, axes, drawn_scale, reach)
    samples = values = None
    if error_samples is not None:
        samples, values, cloud_note = _draw_error_cloud(
            vis, params, plan_measured, sigma, prior, error_samples, reach, task_payload, given
        )
        if cloud_note:
            note = (note + "; " if note else "") + cloud_note
    if where is not None:
        add_instrument(vis, where, points, colors, reach)
    set_view(vis, robot, np.vstack([qs, q0]), reach)
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
        instrument=given,
    )


def _checked_params(params_or_robot: ParameterSet | Robot, scale: float | None) -> ParameterSet:
    """The parameters of the prediction (a robot's full identifiable set), after checking the
    ellipsoid scale."""
    if isinstance(params_or_robot, ParameterSet):
        params = params_or_robot
    elif isinstance(params_or_robot, Robot):
        params = params_or_robot.parameters("full,offsets").identifiable().identifiable
    else:
        raise BadConfiguration(
            f"expected a pincal ParameterSet or Robot, got {type(params_or_robot).__name__}"
        )
    if scale is not None:
        ratio(scale, "scale")
    return params


def _error_ellipsoids(
    params: ParameterSet,
    qs: np.ndarray | Plan,
    q0: np.ndarray,
    sigma: float,
    scale: float | None,
    reach: float,
    task_payload: PayloadLike = None,
    instrument: Instrument | None = None,
) -> tuple[np.ndarray | None, str, np.ndarray | None, np.ndarray | None, np.ndarray | None, float]:
    """(covariance, note, radii, axes, ρ0, drawn scale) of the predicted error at the test poses;
    a singular plan gives no ellipsoid (None) and a note, also warned."""
    cov, note = None, ""
    if len(q0):
        try:
            cov = position_covariance(
                params,
                qs,
                q0,
                task_payload=task_payload,
                **keywords(instrument, sigma),
            )
        except SingularPlan as exc:
            note = f"no error ellipsoid: {exc}"
            warn(note, UserWarning)
    radii = axes = rho = None
    drawn_scale = 1.0 if scale is None else float(scale)
    if cov is not None:
        radii, axes = _ellipsoids(cov, params.robot.n_markers)
        rho = np.sqrt(np.trace(cov, axis1=1, axis2=2))
        if scale is None:
            drawn_scale = _nice_scale(ELLIPSOID_SIZE * reach / max(radii.max(), 1e-300))
    return cov, note, radii, axes, rho, drawn_scale


def _draw_error_cloud(
    vis,
    params: ParameterSet,
    qs: np.ndarray | Plan,
    sigma: float,
    prior: Prior | None,
    error_samples: int | ConfigurationsLike,
    reach: float,
    task_payload: PayloadLike = None,
    instrument: Instrument | None = None,
) -> tuple[np.ndarray | None, np.ndarray | None, str]:
    """(sample configurations, predicted errors there, note) of the error cloud, drawn: a number of
    samples draws them within the joint limits (seed 0); a singular plan draws none and says why."""
    robot = params.robot
    values = None
    if isinstance(error_samples, (int, np.integer)) and not isinstance(error_samples, bool):
        samples = robot.random_configurations(int(error_samples), 0)
    else:
        samples = robot.configurations(error_samples, what="error sample")
    try:
        values = PredictedError(
            params, qs, prior=prior, task_payload=task_payload, **keywords(instrument, sigma)
        )(samples)
        add_error_cloud(vis, robot.points(samples)[:, 0], values, reach)
    except SingularPlan as exc:
        return None, values, f"no error cloud: {exc}"
    return samples, values, ""


def _viewer(meshcat, viewer: ViewerLike):
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
        add_robot(vis, robot, geom, q, f"{node}/robot", rgb(color) + (GHOST_OPACITY,))
        add_points(vis, node, points[i], reach, color)
        add_label(vis, f"{node}/label", str(i + 1), points[i].mean(axis=0), reach)
    return points


def _draw_test_poses(
    vis, robot: Robot, geom, q0: np.ndarray, radii, axes, scale: float, reach: float
) -> None:
    """The opaque robot at each test pose, its points, and their error ellipsoids ``scale`` × life."""
    p0 = robot.points(q0) if len(q0) else np.empty((0, robot.n_markers, 3))
    for k, q in enumerate(q0):
        node = f"{ROOT}/test_poses/test_{k + 1}"
        add_robot(vis, robot, geom, q, f"{node}/robot", rgb(TEST_POSE_COLOR) + (1.0,))
        add_points(vis, node, p0[k], reach, "#000000", 0.6)
        text = "q0" if len(q0) == 1 else f"q0,{k + 1}"
        if radii is not None:
            for j in range(robot.n_markers):
                add_ellipsoid(vis, f"{node}/ellipsoid_{j}", p0[k, j], radii[k, j] * scale, axes[k, j])
            text += f" 3σ ×{scale:g}"
        add_label(vis, f"{node}/label", text, p0[k].mean(axis=0), reach, size=0.4)


# ---------------------------------------------------------------------------- numbers
def _instrument_position(at: InstrumentAt, instrument: Instrument | None) -> np.ndarray | None:
    """Where the instrument is drawn: ``at`` (a position, a Visibility's tracker, a Tracker's
    ``at``), else the position of ``instrument``'s tracker, else None."""
    if at is None and instrument is not None and isinstance(instrument.error, Tracker):
        at = instrument.error
    if at is None:
        return None
    value = getattr(at, "tracker", getattr(at, "position", getattr(at, "at", at)))
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = np.empty(0)
    if arr.size != 3 or not np.all(np.isfinite(arr)):
        raise BadConfiguration(f"instrument_at: expected a position (x, y, z) in metres, got {value!r}")
    return arr


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
