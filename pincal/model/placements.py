"""The placements of every joint of a chain at many configurations at once.

Pinocchio's forward kinematics takes one configuration per call; a constraint that reads the
joint origins of tens of thousands of configurations (the random plans of a baseline) would pay
a Python call per configuration and per joint. Here the same recursion Pinocchio runs,
oMi[j] = oMi[parent] · jointPlacement[j] · M_j(q_j), is applied to all configurations at
once, one joint after the other, with each joint's motion M_j written as Pinocchio writes it
(``RX``/``RY``/``RZ``: the rotation by cos/sin about the axis; ``RevoluteUnaligned``: Rodrigues'
formula; ``PX``/``PY``/``PZ``/``PrismaticUnaligned``: a translation along the axis). The products
are grouped differently (oMi[parent] · jointPlacement first, one matrix product for all
configurations), so the results agree with ``pin.forwardKinematics`` to rounding (a few 1e-16 m
on a 3 m arm), not bit for bit.
A chain with any other joint type (none in pincal's chains: they are made of one-dof revolute
and prismatic joints) is computed with Pinocchio, one configuration at a time.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}


def _motion(joint: pin.JointModel) -> tuple[str, np.ndarray, bool] | None:
    """(``revolute`` or ``prismatic``, unit axis, aligned with a frame axis) of a joint type
    written here, else None."""
    kind = joint.shortname().removeprefix("JointModel")
    if kind in ("RX", "RY", "RZ", "PX", "PY", "PZ"):
        return ("revolute" if kind[0] == "R" else "prismatic"), np.array(_AXES[kind[1]]), True
    if kind in ("RevoluteUnaligned", "PrismaticUnaligned"):
        axis = np.array(joint.extract().axis, dtype=float)
        return ("revolute" if kind[0] == "R" else "prismatic"), axis, False
    return None


def _turned(frames: np.ndarray, axis: np.ndarray, aligned: bool, angles: np.ndarray) -> np.ndarray:
    """(m, 3, 3) ``frames @ R(angle)``, R the rotation by each angle [rad] about the unit ``axis``
    (``aligned``: an RX/RY/RZ joint, whose rotation mixes two columns; else Rodrigues' formula
    R = c·I + s·[a]ₓ + (1 − c)·a·aᵀ), elementwise over the configurations."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    if aligned:
        k = int(np.argmax(axis))
        i, j = (k + 1) % 3, (k + 2) % 3
        out = np.empty_like(frames)
        out[:, :, k] = frames[:, :, k]
        out[:, :, i] = frames[:, :, i] * c + frames[:, :, j] * s
        out[:, :, j] = frames[:, :, j] * c - frames[:, :, i] * s
        return out
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    along = _times(frames, axis[:, None])[:, :, 0]
    return (
        c[:, :, None] * frames
        + s[:, :, None] * _times(frames, cross)
        + ((1.0 - c) * along)[:, :, None] * axis
    )


def _times(frames: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """(m, 3, k) ``frames @ matrix`` for one (3, k) matrix: a single matrix product."""
    return (frames.reshape(-1, 3) @ matrix).reshape(len(frames), 3, matrix.shape[1])


class JointPlacements:
    """Every joint's placement in the model's world (base) frame, many configurations at once.

    Args:
        model: the chain's Pinocchio model (read once here, not modified).

    Example: ``rotations, translations = JointPlacements(robot.model)(qs + robot.joint_offsets)``
    gives ``data.oMi[j]`` of configuration i as ``rotations[j, i]`` and ``translations[j, i]``.
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        self.njoints = model.njoints
        motions = [_motion(model.joints[j]) for j in range(1, model.njoints)]
        self.batched = all(m is not None for m in motions) and all(
            model.nqs[j] == 1 for j in range(1, model.njoints)
        )
        self.joints = [
            (
                j,
                model.parents[j],
                model.idx_qs[j],
                motion,
                np.array(model.jointPlacements[j].rotation),
                np.array(model.jointPlacements[j].translation),
            )
            for j, motion in enumerate(motions, start=1)
        ]

    def __call__(self, thetas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Placements of every joint at each configuration.

        Args:
            thetas: (m, nq) joint values [rad or m] as Pinocchio reads them (offsets added).

        Returns:
            (njoints, m, 3, 3) rotations and (njoints, m, 3) translations [m]: ``data.oMi`` after
            ``pin.forwardKinematics`` (joint 0, the universe, is the identity).
        """
        thetas = np.asarray(thetas, dtype=float)
        m = len(thetas)
        rotations = np.empty((self.njoints, m, 3, 3))
        translations = np.empty((self.njoints, m, 3))
        rotations[0], translations[0] = np.eye(3), 0.0
        if not self.batched:
            data = self.model.createData()
            for i, q in enumerate(thetas):
                pin.forwardKinematics(self.model, data, q)
                for j in range(1, self.njoints):
                    rotations[j, i] = data.oMi[j].rotation
                    translations[j, i] = data.oMi[j].translation
            return rotations, translations
        for j, parent, iq, (kind, axis, aligned), rotation, translation in self.joints:  # type: ignore[misc]
            # oMi[j] = oMi[parent] · jointPlacement[j] · M(q_j); the universe's placement is I
            if parent == 0:
                frames = np.broadcast_to(rotation, (m, 3, 3))
                translations[j] = translation
            else:
                frames = _times(rotations[parent], rotation)
                translations[j] = (
                    translations[parent] + _times(rotations[parent], translation[:, None])[:, :, 0]
                )
            q = thetas[:, iq]
            if kind == "revolute":
                rotations[j] = _turned(frames, axis, aligned, q)
            else:
                rotations[j] = frames
                translations[j] += q[:, None] * _times(frames, axis[:, None])[:, :, 0]
        return rotations, translations
