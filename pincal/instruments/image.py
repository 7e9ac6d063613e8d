"""Images: the pixels of a target's known points seen by a calibrated camera (docs/method.md §13.1).

A target (a checkerboard, a grid of circles, fiducials) carries N points at known positions t_j
in its own frame. A camera (:class:`~pincal.instruments.camera.Camera`) reads the pixel (u, v) of
each point it sees: 2N values per configuration, empty (NaN) where a point is not seen.

* eye-in-hand: the camera is fixed to the tool (fixture ``camera``, ``on="tip"``) and the target
  in the cell (fixture ``target``, ``on="world"``);
* eye-to-hand: the camera is fixed in the cell and the target on the tool.

Both placements are identified with the robot (``camera.tx ... rz``, ``target.tx ... rz``: group
``instrument``). With p_c a target point in the camera's frame, the rows are ∂(u, v)/∂p_c (the
camera's projection) times ∂p_c/∂Π: for a frame F fixed to the tool that moves by the twist
(v, ω) in its own axes, a point fixed in the cell moves in F's axes by −v + p × ω, and a point
fixed to F by v + ω × p.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from pincal.errors import BadArgument
from pincal.instruments.camera import MIN_DEPTH, Camera
from pincal.instruments.kind import Kind
from pincal.model.fixtures import Fixture
from pincal.model.jacobian import JacobianEngine, _skew
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows

VISIBILITY_ERROR_STD = (1e-3, 1e-3)
"""The errors before calibration that decide which target points a measurement reads: 1 mm and
1 mrad, :func:`pincal.random_errors`' default. With 1 mrad on every joint and on both placements, a
point 0.3 m from the camera moves by about ten pixels: the nominal model's view is not the one
measured, and a design that counts the points the nominal camera barely sees promises what the
measurement will not deliver (docs/method.md §13.1)."""


LIKELY_READ = 0.9
"""A target point counts for the design when it is read with at least this probability p (then for
p times its information); one that may well be lost counts for nothing: the design does not bet on
it. Without this floor a point close to the camera, whose rows and spread are both large, adds
information p·JᵀJ that grows with its spread although it is seldom read (:meth:`Image.weights`)."""


@dataclass(frozen=True, eq=False)
class Image(Kind):
    """Pixels of a target's points (see module doc).

    Args:
        camera: the camera's intrinsics.
        points: (N, 3) the target's points in its own frame [m].
        eye_in_hand: the camera is on the tool (else the target is).
        error_std: (length [m], angle [rad]): the standard deviations of the geometric errors
            before calibration, which move each target point's pixel: the design and the criteria
            weigh each point by the probability that it is read (:meth:`weights`). None: a point
            counts fully where the nominal model sees it, not at all elsewhere.
    """

    camera: Camera
    points: np.ndarray = field(default_factory=lambda: np.zeros((1, 3)))
    eye_in_hand: bool = True
    error_std: tuple[float, float] | None = VISIBILITY_ERROR_STD
    name: ClassVar[str] = "image"
    partial_view: ClassVar[bool] = True

    def __post_init__(self) -> None:
        try:
            points = np.array(self.points, dtype=float).reshape(-1, 3)
        except (TypeError, ValueError):
            raise BadArgument("target points must be (N, 3) numbers [m]", argument="target") from None
        if not len(points) or not np.all(np.isfinite(points)):
            raise BadArgument("target points must be finite, and at least one", argument="target")
        points.flags.writeable = False
        object.__setattr__(self, "points", points)
        if self.error_std is not None:
            std = tuple(self.error_std) if isinstance(self.error_std, (tuple, list)) else ()
            if len(std) != 2 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < np.inf for v in std
            ):
                raise BadArgument(
                    f"image error_std must be (length [m], angle [rad]), two positive numbers, or None; "
                    f"got {self.error_std!r}",
                    argument="error_std",
                )
            object.__setattr__(self, "error_std", (float(std[0]), float(std[1])))
        if not isinstance(self.camera, Camera):
            raise BadArgument("image measurements need a pincal Camera (intrinsics)", argument="camera")

    # ------------------------------------------------------------------- set-up
    @property
    def on_tool(self) -> str:
        """The fixture fixed to the tool: ``camera`` (eye-in-hand) or ``target``."""
        return "camera" if self.eye_in_hand else "target"

    @property
    def in_cell(self) -> str:
        """The fixture fixed in the cell: ``target`` (eye-in-hand) or ``camera``."""
        return "target" if self.eye_in_hand else "camera"

    def fixtures(self, camera_at: object, target_at: object) -> tuple[Fixture, Fixture]:
        """The camera's and the target's fixtures at their nominal placements (the camera's in the
        tip frame for eye-in-hand, in the instrument's frame otherwise; the target's the other way)."""
        camera_on, target_on = ("tip", "world") if self.eye_in_hand else ("world", "tip")
        return Fixture("camera", camera_at, on=camera_on), Fixture("target", target_at, on=target_on)

    def check(self, robot: Robot) -> None:
        have = {f.name: f for f in robot.fixtures}
        for name, on in ((self.on_tool, "tip"), (self.in_cell, "world")):
            if name not in have or have[name].on != on or have[name].point:
                raise BadArgument(
                    f"image measurements ({'eye-in-hand' if self.eye_in_hand else 'eye-to-hand'}) need a "
                    f"{name} fixture on the {'tool' if on == 'tip' else 'cell'} with its nominal placement "
                    f"(--camera RIG.yaml; robot.with_fixtures(*kind.fixtures(camera_at, target_at)))",
                    argument="camera",
                )

    def describe(self) -> str:
        mount = "eye-in-hand" if self.eye_in_hand else "eye-to-hand"
        return f"image ({mount}, {len(self.points)} target points)"

    def as_dict(self) -> dict:
        return {
            "kind": self.name,
            "eye_in_hand": self.eye_in_hand,
            "camera": self.camera.as_dict(),
            "points": self.points.tolist(),
        }

    def coordinates(self, robot: Robot) -> tuple[str, ...]:
        return tuple(f"{c}{j}" for j in range(len(self.points)) for c in "uv")

    def units(self, robot: Robot) -> tuple[str, ...]:
        return ("px",) * (2 * len(self.points))

    def blocks(self, robot: Robot) -> tuple[tuple[int, ...], ...]:
        return tuple((2 * j, 2 * j + 1) for j in range(len(self.points)))

    # --------------------------------------------------------------- the geometry
    def camera_points(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, N, 3) the target's points in the camera's frame [m]."""
        tool = robot.fixture(self.on_tool).placement
        cell = robot.fixture(self.in_cell).placement
        R_t, p_t = ForwardKinematics(robot).tip(qs, payload)
        R_f = np.matmul(R_t, tool.rotation)  # the tool fixture in the instrument's frame
        p_f = p_t + R_t @ tool.translation
        if self.eye_in_hand:
            world = self.points @ cell.rotation.T + cell.translation  # (N, 3)
            return np.einsum("mji,mnj->mni", R_f, world[None] - p_f[:, None])
        world = np.einsum("mij,nj->mni", R_f, self.points) + p_f[:, None]
        return (world - cell.translation) @ cell.rotation

    def predict(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return self.camera.project(self.camera_points(robot, qs, payload)).reshape(len(qs), -1)

    def seen(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return np.repeat(self.camera.in_view(self.camera_points(robot, qs, payload)), 2, axis=1)

    def weights(
        self, engine: JacobianEngine, qs: np.ndarray, rows: np.ndarray, payload: PayloadRows = None
    ) -> np.ndarray:
        """(m, 2N) each target point's weight at ``qs``: p, the probability that it is read (in
        front of the camera on the nominal model, and inside the image once the errors still
        unknown move its pixel: Gaussian with the spread ``rows``·diag(error_std),
        :meth:`Camera.inside_probability`), where p ≥ :data:`LIKELY_READ`, else 0; with
        ``error_std=None``, :meth:`seen` (1 or 0).

        Why the floor: what calibration delivers is the mean of tr(J₀M⁻¹J₀ᵀ) over which points are
        read, above its value at the mean information (Jensen), and points the design may lose
        are the ones it then leans on. On the example rig (panda, 20 configurations, 1 mm / 1 mrad;
        benchmarks/RESULTS.md, "Camera designs") the nominal view predicts 0.087 mm where 0.128 is
        delivered, p from ½ predicts 0.032 where 0.054 is (one trial in 40 at 2.6 mm), p from 0.9
        predicts 0.100 where 0.084 is: a little pessimistic, and the best delivered of the three."""
        if self.error_std is None:
            return super().weights(engine, qs, rows, payload)
        length, angle = self.error_std
        std = np.array([length if p.is_length else angle for p in engine.params], dtype=float)
        pc = self.camera_points(engine.robot, qs, payload)
        front = pc[..., 2] > MIN_DEPTH
        safe = np.where(front[..., None], pc, np.array([0.0, 0.0, 1.0]))
        with np.errstate(invalid="ignore", over="ignore"):
            spread = np.sqrt(np.einsum("mrp,p->mr", np.where(np.isfinite(rows), rows, 0.0) ** 2, std**2))
        spread = spread.reshape(len(qs), len(self.points), 2)
        inside = self.camera.inside_probability(self.camera.project(safe), spread)
        return np.repeat(np.where(front & (inside >= LIKELY_READ), inside, 0.0), 2, axis=1)

    def reads(self, engine: JacobianEngine, qs: np.ndarray) -> np.ndarray:
        """(m,) True where the target points likely read (:meth:`weights` above 0) reveal the
        camera's pose relative to the target as all its points in front of it would: three at
        least, not in a line (rank 6 of their rows). A design draws its candidates, and so its
        starts, among these: of 2000 random Panda configurations on the example rig, 121 qualify
        and 1782 read no point at all, and a random plan of 20 is then rank-deficient."""
        out = np.zeros(len(qs), dtype=bool)
        looked = np.flatnonzero(self.seen(engine.robot, qs).any(axis=1))  # a point read is seen
        if not len(looked):
            return out
        rows = self.rows(engine, qs[looked])
        read = self.weights(engine, qs[looked], rows) > 0
        front = np.repeat(self.camera_points(engine.robot, qs[looked])[..., 2] > MIN_DEPTH, 2, axis=1)
        front &= np.isfinite(rows).all(axis=2)
        full = np.linalg.matrix_rank(np.where(front[..., None], rows, 0.0))
        out[looked] = (np.linalg.matrix_rank(np.where(read[..., None], rows, 0.0)) == full) & (full > 0)
        return out

    def rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        robot = engine.robot
        tool = robot.fixture(self.on_tool).placement
        cell = robot.fixture(self.in_cell).placement
        J, R_f, _ = engine.frame_rows(qs, tool, payload)  # (m, 6, P): the tool fixture's twist
        assert R_f is not None  # pose=True (the default): the fixture's orientations too
        names = [f.name for f in robot.fixtures]
        tool_cols = self._fixture_columns(engine, names.index(self.on_tool))
        cell_cols = self._fixture_columns(engine, names.index(self.in_cell))
        # The tool fixture's own errors: a twist (R_ᵀδt, δω) of the fixture frame.
        for c, col in tool_cols:
            J[:, :3, col] = tool.rotation[c] if c < 3 else 0.0
            J[:, 3:, col] = 0.0 if c < 3 else np.eye(3)[c - 3]
        pc = self.camera_points(robot, qs, payload)  # (m, N, 3)
        m, N, P = len(qs), len(self.points), J.shape[2]
        dpc = np.empty((m, N, 3, P))
        if self.eye_in_hand:  # the target's points are fixed in the cell, the camera is F
            dpc[...] = -J[:, None, :3] + np.einsum("mnij,mjp->mnip", _skews(pc), J[:, 3:])
            for c, col in cell_cols:  # the target's own errors move its points in the cell
                move = np.eye(3)[c] if c < 3 else cell.rotation @ np.cross(np.eye(3)[c - 3], self.points).T
                world = np.broadcast_to(move if c >= 3 else move[:, None], (3, N))
                dpc[:, :, :, col] = np.einsum("mji,jn->mni", R_f, world)
        else:  # the target's points are fixed to F, the camera is in the cell
            lever = np.stack([np.hstack([np.eye(3), -_skew(t)]) for t in self.points])  # (N, 3, 6)
            world = np.einsum("mij,njk,mkp->mnip", R_f, lever, J)
            dpc[...] = np.einsum("ji,mnjp->mnip", cell.rotation, world)
            for c, col in cell_cols:  # the camera's own errors
                dpc[:, :, :, col] = -cell.rotation[c] if c < 3 else np.cross(pc, np.eye(3)[c - 3])
        rows = np.einsum("mnij,mnjp->mnip", self.camera.jacobian(pc), dpc)
        return rows.reshape(m, 2 * N, P)

    @staticmethod
    def _fixture_columns(engine: JacobianEngine, index: int) -> list[tuple[int, int]]:
        """(component, column) of the parameters of fixture ``index`` in the engine's set."""
        return [
            (p.component, col)
            for col, p in enumerate(engine.params.parameters)
            if p.kind == "fixture" and p.index == index
        ]


def _skews(p: np.ndarray) -> np.ndarray:
    """(..., 3, 3) [p]× of vectors (..., 3)."""
    out = np.zeros(p.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -p[..., 2], p[..., 1]
    out[..., 1, 0], out[..., 1, 2] = p[..., 2], -p[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -p[..., 1], p[..., 0]
    return out


def grid(columns: int, rows: int, spacing: float) -> np.ndarray:
    """(columns·rows, 3) the inner corners of a checkerboard (a grid of points) in its plane z = 0,
    row by row from the origin [m]."""
    if columns < 1 or rows < 1 or not (np.isfinite(spacing) and spacing > 0):
        raise BadArgument(
            f"a grid needs positive columns, rows and spacing, got {columns}, {rows}, {spacing}",
            argument="target",
        )
    jj, ii = np.meshgrid(np.arange(rows), np.arange(columns), indexing="ij")
    return np.column_stack([ii.ravel() * spacing, jj.ravel() * spacing, np.zeros(columns * rows)])
