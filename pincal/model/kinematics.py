r"""The robot's forward kinematics, one service for every check and every view: where the joints,
the tip and the markers are at many configurations, with the robot's joint gains and compliances.

A configuration is the joints' *reading* q. The joints stand at θ (:meth:`Robot.joint_values
<pincal.model.robot.Robot.joint_values>`): θ = q + Δq for a rigid robot, and the static solution of
θ = q + Δq + k ⊙ q + c ⊙ τ(θ, w) under the payload w when the robot carries joint gains k or
compliances c (:mod:`pincal.model.statics`). Everything here goes through θ, so a calibrated robot
is checked with its calibrated kinematics: the mount, the collision world, the constraints, the
regions' inverse kinematics and the campaign's moves (the arithmetic for a rigid robot is the one
each of them had, bit for bit).

:class:`ForwardKinematics` holds one ``pinocchio.Data`` (one per thread) and gives, for (m, nq)
readings:

* :meth:`~ForwardKinematics.tip` and :meth:`~ForwardKinematics.markers` — the tip frame and the
  measured points in the instrument frame (Pinocchio's ``forwardKinematics`` per configuration);
* :meth:`~ForwardKinematics.placements` — every joint's placement, the tip and the markers in the
  robot's base frame (:class:`Placements`);
* :meth:`~ForwardKinematics.chain_points` — the joint origins, the tip and the markers in the base
  frame, the mount's points: Pinocchio per configuration below :data:`BATCH` configurations, above
  it all at once (:meth:`~ForwardKinematics.batch_placements`);
* :meth:`~ForwardKinematics.batch_placements` — every joint's placement at many joint values at once
  (:class:`~pincal.model.placements.JointPlacements`, Pinocchio's recursion in NumPy, which agrees
  with Pinocchio to rounding): the one batch of the package, read by the mount's points and the
  self-collision check's bounding spheres;
* :meth:`~ForwardKinematics.place_geometry` — a geometry model's placements (Pinocchio);
* :meth:`~ForwardKinematics.frame_jacobian` — the tip frame's Jacobian with respect to the reading,
  J(θ)·∂θ/∂q, ∂θ/∂q = (I − C ∂τ/∂θ)⁻¹ (I + K);
* :meth:`~ForwardKinematics.motion_scale` — a bound of how far the joints move on a straight move
  of the readings: |Δθ| ≤ S |Δq| elementwise (the motion checks' weights are in θ).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument
from pincal.model.placements import JointPlacements
from pincal.model.statics import Gravity, PayloadRows, carried

if TYPE_CHECKING:  # robot.py imports this module
    from pincal.model.robot import Robot

BATCH = 16
"""Fewest configurations whose chain points are computed in one batch (below, one at a time)."""


def tip_poses(
    robot: Robot, thetas: np.ndarray, data: pin.Data, base: pin.SE3 | None
) -> tuple[np.ndarray, np.ndarray]:
    """Tip orientations (m, 3, 3) and positions (m, 3) at the joint values ``thetas`` (m, nq), in
    the frame ``base`` places the robot's base in (None: the base frame itself): Pinocchio's
    ``forwardKinematics`` one configuration at a time, ``base · oMi[tip joint] · tip``."""
    model = robot.model
    placement = model.frames[robot.tip_frame].placement
    rotations = np.empty((len(thetas), 3, 3))
    positions = np.empty((len(thetas), 3))
    joint = robot.tip_joint
    for i, theta in enumerate(thetas):
        pin.forwardKinematics(model, data, theta)
        tip = data.oMi[joint] * placement if base is None else base * data.oMi[joint] * placement
        rotations[i] = tip.rotation
        positions[i] = tip.translation
    return rotations, positions


def marker_positions(robot: Robot, rotations: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """(m, K, 3) the markers at the tip poses ``rotations`` (m, 3, 3), ``positions`` (m, 3)."""
    return positions[:, None, :] + np.einsum("mij,kj->mki", rotations, robot.markers)


@dataclass(frozen=True, eq=False)
class Placements:
    """Where the chain is at m configurations, in the robot's base frame (the model's world; the
    instrument frame is ``robot.base`` times it).

    Attributes:
        thetas: (m, nq) the joints' values θ [rad or m] (not the readings).
        joint_rotations: (m, njoints, 3, 3) ``data.oMi`` (joint 0, the universe: the identity).
        joint_translations: (m, njoints, 3) [m].
        tip_rotations: (m, 3, 3) the tip frame's orientation.
        tip_positions: (m, 3) [m].
        markers: (m, K, 3) [m].
    """

    thetas: np.ndarray
    joint_rotations: np.ndarray
    joint_translations: np.ndarray
    tip_rotations: np.ndarray
    tip_positions: np.ndarray
    markers: np.ndarray


class ForwardKinematics:
    """The forward kinematics of one robot, gains and compliances included (see the module doc).

    Holds a ``pinocchio.Data`` and the robot's gravity model: one per thread or process. It works
    below the payload door (:mod:`pincal.model.statics`): a ``payload`` here is (m, 4) rows
    [kg, x, y, z], one per configuration (:func:`~pincal.model.statics.payload_rows`), or None;
    :meth:`pincal.Robot.points` and :meth:`pincal.Robot.joint_values` take any payload form.

    Args:
        robot: the robot (not modified).
        data: a ``pinocchio.Data`` of ``robot.model`` to use (default: a new one).
    """

    def __init__(self, robot: Robot, data: pin.Data | None = None) -> None:
        self.robot = robot
        self.model = robot.model
        self._data = data
        self._batch: JointPlacements | None = None
        self._gravity: Gravity | None = None
        self.rigid = not robot.is_elastic
        """True when θ = q + Δq (no joint gains nor compliances)."""

    @property
    def data(self) -> pin.Data:
        """The ``pinocchio.Data`` used (made on first use)."""
        if self._data is None:
            self._data = self.model.createData()
        return self._data

    @property
    def gravity(self) -> Gravity | None:
        """The robot's gravity model when it has compliances (kept: it caches payload models)."""
        if self._gravity is None and self.robot.joint_compliances.any():
            self._gravity = self.robot.gravity_model()
        return self._gravity

    def joint_values(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, nq) the joints' values θ at the readings ``qs`` (m, nq) under the payload rows
        ``payload`` (m, 4) [kg, x, y, z], or None (none)."""
        robot = self.robot
        if self.rigid:
            return qs + robot.joint_offsets
        return robot.joint_values_under(qs, payload, self.gravity)

    # ------------------------------------------------------------------ tip and markers
    def tip(
        self, qs: np.ndarray, payload: PayloadRows = None, *, instrument: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """Tip orientations (m, 3, 3) and positions (m, 3) [m] at readings ``qs``, in the instrument
        frame (``instrument=False``: the robot's base frame)."""
        base = self.robot.base if instrument else None
        return tip_poses(self.robot, self.joint_values(qs, payload), self.data, base)

    def markers(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, K, 3) the markers at readings ``qs`` in the instrument frame [m]."""
        return marker_positions(self.robot, *self.tip(qs, payload))

    def placements(self, qs: np.ndarray, payload: PayloadRows = None) -> Placements:
        """Every joint's placement, the tip and the markers at readings ``qs``, base frame
        (Pinocchio's ``forwardKinematics`` per configuration)."""
        robot, model, data = self.robot, self.model, self.data
        thetas = self.joint_values(qs, payload)
        m, n = len(thetas), model.njoints
        rotations, translations = np.empty((m, n, 3, 3)), np.empty((m, n, 3))
        for i, theta in enumerate(thetas):
            pin.forwardKinematics(model, data, theta)
            for j, placed in enumerate(data.oMi):
                rotations[i, j], translations[i, j] = placed.rotation, placed.translation
        tip = model.frames[robot.tip_frame].placement
        up = rotations[:, robot.tip_joint]
        tip_rotations = up @ tip.rotation
        tip_positions = translations[:, robot.tip_joint] + up @ tip.translation
        markers = marker_positions(robot, tip_rotations, tip_positions)
        return Placements(thetas, rotations, translations, tip_rotations, tip_positions, markers)

    # ------------------------------------------------------------------ the mount's points
    def chain_points(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """(m, nq + 1 + K, 3) the moving joints' origins, the tip and the markers at readings
        ``qs``, in the base frame [m]: Pinocchio per configuration for fewer than :data:`BATCH`
        configurations, else all at once (:meth:`batch_chain_points`; the two agree to rounding)."""
        if len(qs) >= BATCH:
            return self.batch_chain_points(qs, payload)
        robot, model, data = self.robot, self.model, self.data
        tip = model.frames[robot.tip_frame].placement
        joints = range(1, model.njoints)
        out = np.empty((len(qs), len(joints) + 1 + robot.n_markers, 3))
        for i, theta in enumerate(self.joint_values(qs, payload)):
            pin.forwardKinematics(model, data, theta)
            for c, j in enumerate(joints):
                out[i, c] = data.oMi[j].translation
            frame = data.oMi[robot.tip_joint] * tip
            out[i, len(joints)] = frame.translation
            out[i, len(joints) + 1 :] = robot.markers @ frame.rotation.T + frame.translation
        return out

    def batch_chain_points(self, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        """:meth:`chain_points` of all configurations in one batch
        (:class:`~pincal.model.placements.JointPlacements`)."""
        robot = self.robot
        rotations, translations = self.batch_placements(self.joint_values(qs, payload))
        tip = self.model.frames[robot.tip_frame].placement
        up = rotations[robot.tip_joint].reshape(-1, 3)
        tip_rotation = (up @ tip.rotation).reshape(-1, 3, 3)
        tip_position = translations[robot.tip_joint] + (up @ tip.translation).reshape(-1, 3)
        markers = tip_position[:, None, :] + np.einsum("mij,kj->mki", tip_rotation, robot.markers)
        origins = translations[1:].transpose(1, 0, 2)
        return np.concatenate([origins, tip_position[:, None, :], markers], axis=1)

    def batch_placements(self, thetas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every joint's placement in the base frame at the joint values ``thetas`` (m, nq) (θ, not
        the readings: :meth:`joint_values`), all configurations in one batch: (njoints, m, 3, 3)
        rotations and (njoints, m, 3) translations [m], ``data.oMi`` of each configuration to
        rounding (:class:`~pincal.model.placements.JointPlacements`)."""
        if self._batch is None:
            self._batch = JointPlacements(self.model)
        return self._batch(thetas)

    # ------------------------------------------------------------------ geometry
    def place_geometry(
        self, geom: pin.GeometryModel, gdata: pin.GeometryData, q: np.ndarray, payload: PayloadRows = None
    ) -> None:
        """Place the shapes of ``geom`` (on this robot's joints) at the reading ``q`` (nq,):
        ``gdata.oMg`` (Pinocchio's ``updateGeometryPlacements`` at θ)."""
        theta = self.joint_values(np.asarray(q, dtype=float)[None], payload)[0]
        pin.updateGeometryPlacements(self.model, self.data, geom, gdata, theta)

    # ------------------------------------------------------------------ derivatives
    def reading_jacobian(self, theta: np.ndarray, load: np.ndarray | None = None) -> np.ndarray:
        """(nq, nq) ∂θ/∂q at the joint values ``theta`` (nq,) under the payload row ``load``
        [kg, x, y, z]: (I − C ∂τ/∂θ)⁻¹ (I + K) (the identity for a rigid robot)."""
        robot = self.robot
        dtheta = np.diag(1.0 + robot.joint_gains)
        gravity = self.gravity
        if gravity is not None:
            row = np.zeros(4) if load is None else np.asarray(load, dtype=float)
            C = np.diag(robot.joint_compliances)
            dtheta = np.linalg.solve(np.eye(robot.nq) - C @ gravity.torque_derivatives(theta, row), dtheta)
        return dtheta

    def frame_jacobian(
        self, q: np.ndarray, payload: PayloadRows = None, reference: pin.ReferenceFrame = pin.LOCAL
    ) -> tuple[pin.SE3, np.ndarray]:
        """(the tip frame's placement in the base frame, its (6, nq) Jacobian in ``reference``
        with respect to the reading) at the reading ``q`` (nq,) under the payload row ``payload``
        (1, 4) (or None): Pinocchio's frame Jacobian at θ times :meth:`reading_jacobian`."""
        robot, model, data = self.robot, self.model, self.data
        load = carried(payload, 1)
        theta = self.joint_values(np.asarray(q, dtype=float)[None], load)[0]
        pin.framesForwardKinematics(model, data, theta)
        placement = pin.SE3(data.oMf[robot.tip_frame])
        J = pin.computeFrameJacobian(model, data, theta, robot.tip_frame, reference)
        if not self.rigid:
            J = J @ self.reading_jacobian(theta, load[0])
        return placement, J

    def motion_scale(self, payload: PayloadRows = None) -> np.ndarray | None:
        """(nq, nq) S ≥ 0 with |Δθ| ≤ S |Δq| (elementwise) between any two readings of a straight
        move, under the payload ``payload`` (None, or (r, 4) rows [kg, x, y, z]: the bound holds
        under any of them); None for a rigid robot (S = I).

        With gains only, S = |I + K|. With compliances, ∂θ/∂q = (I − C T)⁻¹ (I + K), T = ∂τ/∂θ
        bounded elementwise by T̄ (:func:`torque_derivative_bound`): S = (I − |C| T̄)⁻¹ |I + K|,
        whose series has no negative term.

        Raises:
            BadArgument: compliances too large for the bound (ρ(|C| T̄) ≥ 1/2).
        """
        robot = self.robot
        if self.rigid:
            return None
        scale = np.diag(np.abs(1.0 + robot.joint_gains))
        if not robot.joint_compliances.any():
            return scale
        rows = carried(payload, None)
        loop = np.abs(robot.joint_compliances)[:, None] * torque_derivative_bound(robot, rows)
        if np.max(np.abs(np.linalg.eigvals(loop))) >= 0.5:
            raise BadArgument(
                f"the joint compliances {robot.joint_compliances.tolist()} are too large to bound the "
                f"robot's motion between two poses (industrial joints have 1e-7 to 1e-5 rad/(N·m))",
                argument="compliance",
            )
        return np.linalg.solve(np.eye(robot.nq) - loop, scale)


def torque_derivative_bound(robot: Robot, loads: np.ndarray) -> np.ndarray:
    """(nq, nq) T̄ ≥ |∂τ/∂θ| everywhere, under any payload of ``loads`` (rows [kg, x, y, z]).

    τ_i = −∂V/∂θ_i, V the potential energy: ∂τ_i/∂θ_j = Σ_k m_k g·∂²p_k/∂θ_i∂θ_j over the bodies k
    both joints move (k ≥ J = max(i, j) on a chain), and the second derivative of a point's
    position is at most twice its distance from joint J's origin for two revolute joints, at most 1
    when one slides: T̄_ij = 2|g| Σ_{k ≥ J} m_k max(r_Jk, 1 m), r_Jk the link offsets from J to k
    (with a prismatic joint's travel) plus the centre of mass's offset; the payload is a mass on the
    tip's body."""
    model = robot.model
    n = model.njoints
    travel = np.maximum(np.abs(model.lowerPositionLimit), np.abs(model.upperPositionLimit))
    travel = travel * np.abs(1.0 + robot.joint_gains) + np.abs(robot.joint_offsets)
    lengths = np.zeros(n + 1)
    for j in range(1, n):
        lengths[j] = np.linalg.norm(model.jointPlacements[j].translation)
        lengths[j] += 0.0 if robot.revolute[j - 1] else travel[j - 1]
    masses = np.array([model.inertias[k].mass for k in range(n)])
    levers = np.array([np.linalg.norm(model.inertias[k].lever) for k in range(n)])
    tip = model.frames[robot.tip_frame].placement
    payload = float(loads[:, 0].max())
    payload_lever = max(float(np.linalg.norm(tip.act(row[1:]))) for row in loads)
    moment = np.zeros(n)
    for J in range(1, n):
        reach = np.cumsum(lengths[J + 1 : n])  # from J's origin to each later joint's
        r = np.r_[0.0, reach] + levers[J:n]
        moment[J] = float(np.sum(masses[J:n] * np.maximum(r, 1.0)))
        if payload > 0 and robot.tip_joint >= J:
            moment[J] += payload * max(float(lengths[J + 1 : robot.tip_joint + 1].sum()) + payload_lever, 1.0)
    outer = np.maximum.outer(np.arange(1, n), np.arange(1, n))  # J = max(i, j), Pinocchio's ids
    return 2.0 * float(np.linalg.norm(robot.gravity)) * moment[outer]
