"""The placements of a robot's chain that carry geometric errors (:attr:`pincal.Robot.origins`),
and the joints' motion axes (:attr:`pincal.Robot.motion_axes`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


def _frame_names(model: pin.Model) -> list[str]:
    return [f.name for f in model.frames]


def motion_axes(model: pin.Model) -> np.ndarray:
    """(njoints, 6) motion subspace S of each one-dof joint, in its joint frame: motion = exp6(S q)
    (row 0 unused). One forward kinematics for all: a joint's motion ``liMi`` depends on its own
    coordinates only."""
    data = model.createData()
    q = pin.neutral(model)
    step = 1e-3
    idx_qs, placements = list(model.idx_qs), list(model.jointPlacements)
    for joint in range(1, model.njoints):
        q[idx_qs[joint]] += step
    pin.forwardKinematics(model, data, q)
    axes = np.zeros((model.njoints, 6))
    for joint in range(1, model.njoints):
        motion = placements[joint].inverse() * data.liMi[joint]
        axes[joint] = pin.log6(motion).vector / step
    return axes


def _origin_parent(model: pin.Model, frame: int, joint: int) -> pin.SE3:
    """Placement P of the parent link of a URDF origin, relative to ``joint``.

    Pinocchio stores the placement of a joint (or of a frame) relative to the previous *joint*;
    the URDF ``<origin>`` is relative to the parent *link*. The two differ by the fixed joints
    between them: placement = P * origin.
    """
    if frame < 0:
        return pin.SE3.Identity()
    parent = model.frames[frame].parentFrame
    if 0 < parent < len(model.frames) and model.frames[parent].parentJoint == joint:
        return pin.SE3(model.frames[parent].placement)
    return pin.SE3.Identity()


@dataclass(frozen=True, eq=False)
class Origin:
    """One placement on the chain that carries geometric errors.

    Attributes:
        name: the joint name (or the tip frame name) used in parameter names.
        urdf_joint: the URDF joint whose ``<origin>`` this is (None if there is none).
        joint: Pinocchio joint id the placement belongs to (the joint itself, or the tip's joint).
        parent: placement P of the parent link relative to the previous joint.
        origin: the URDF origin L (parent link -> this frame); the Pinocchio placement is P * L.
    """

    name: str
    urdf_joint: str | None
    joint: int
    parent: pin.SE3
    origin: pin.SE3


def chain_origins(model: pin.Model, tip_name: str, tip_frame: int, tip_joint: int) -> tuple[Origin, ...]:
    """The placements carrying errors of the chain ``model`` (:attr:`pincal.Robot.origins`): one
    per chain joint, then the tip frame's (named after the tip frame, or ``tip`` when the tip frame
    is named like a chain joint)."""
    frames = _frame_names(model)
    out = []
    for j in range(1, model.njoints):
        name = model.names[j]
        fid = next(
            (i for i, f in enumerate(model.frames) if f.name == name and f.type == pin.JOINT),
            -1,
        )
        parent = _origin_parent(model, fid, model.parents[j])
        placement = model.jointPlacements[j]
        out.append(Origin(name, name, j, parent, parent.inverse() * placement))
    tip = model.frames[tip_frame]
    # The URDF fixed joint whose child is the tip link has a frame of its own, the tip's parent.
    fixed = tip.parentFrame
    urdf_joint = None
    anchor = tip_frame
    if (
        0 < fixed < len(frames)
        and model.frames[fixed].type == pin.FIXED_JOINT
        and model.frames[fixed].placement.isApprox(tip.placement)
    ):
        urdf_joint = model.frames[fixed].name
        anchor = fixed
    parent = _origin_parent(model, anchor, tip_joint)
    # A tip named like a chain joint (tip="joint_a6") would repeat that joint's names.
    name = "tip" if tip_name in tuple(model.names[1:]) else tip_name
    out.append(Origin(name, urdf_joint, tip_joint, parent, parent.inverse() * tip.placement))
    return tuple(out)
