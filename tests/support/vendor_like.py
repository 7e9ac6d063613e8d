"""Vendor-like URDFs made from the shipped robots (no vendor file is copied).

Many published URDFs (Kinova Gen3, Franka, xArm, SO-101, ...) turn every joint frame so that the
joint's axis is its z axis, and write the turns as ``rpy`` rounded to 4 or 5 digits (1.5708,
3.1416). :func:`z_axis_urdf` writes that description of any pincal chain: exactly the same robot
with ``digits=None``, and a robot whose axes are off by up to ~5e-5 rad with ``digits=4``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pincal import Robot

_Z = np.array([0.0, 0.0, 1.0])


def _turn_to(axis: np.ndarray) -> np.ndarray:
    """A rotation A with A·z = axis, a quarter or half turn when the axis is a coordinate axis."""
    axis = axis / np.linalg.norm(axis)
    if np.allclose(axis, _Z):
        return np.eye(3)
    if np.allclose(axis, -_Z):
        return pin.rpy.rpyToMatrix(np.pi, 0.0, 0.0)
    return pin.Quaternion.FromTwoVectors(_Z, axis).toRotationMatrix()


def _origin(placement: pin.SE3, digits: int | None) -> str:
    rpy = pin.rpy.matrixToRpy(placement.rotation)
    xyz = placement.translation
    if digits is not None:
        rpy = np.round(rpy, digits)
    xyz = np.round(xyz, 9)
    return f'<origin xyz="{_numbers(xyz)}" rpy="{_numbers(rpy)}"/>'


def _numbers(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in values)


def z_axis_urdf(robot: Robot, digits: int | None = None, continuous: tuple[str, ...] = ()) -> str:
    """The robot's chain as a URDF whose joint axes are all z (see module doc).

    Args:
        robot: the chain to describe (its joint limits are kept).
        digits: round every rpy angle to this many decimals (None: exact).
        continuous: joints written as ``continuous`` (no limits).
    """
    model = robot.model
    axes = robot.motion_axes
    turns = [np.eye(3)]
    links = ['<link name="base"/>']
    joints = []
    for j in range(1, model.njoints):
        name = model.names[j]
        prismatic = np.linalg.norm(axes[j, 3:]) < 0.5
        axis = axes[j, :3] if prismatic else axes[j, 3:]
        turn = _turn_to(axis)
        parent = pin.SE3(turns[model.parents[j]], np.zeros(3)).inverse()
        placement = parent * model.jointPlacements[j] * pin.SE3(turn, np.zeros(3))
        turns.append(turn)
        kind = "continuous" if name in continuous else ("prismatic" if prismatic else "revolute")
        i = model.idx_qs[j]
        limit = (
            ""
            if kind == "continuous"
            else f'<limit lower="{float(model.lowerPositionLimit[i])!r}" '
            f'upper="{float(model.upperPositionLimit[i])!r}" effort="1" velocity="1"/>'
        )
        parent_link = "base" if model.parents[j] == 0 else f"link_{model.names[model.parents[j]]}"
        links.append(f'<link name="link_{name}"/>')
        joints.append(
            f'<joint name="{name}" type="{kind}"><parent link="{parent_link}"/><child link="link_{name}"/>'
            f'{_origin(placement, digits)}<axis xyz="0 0 1"/>{limit}</joint>'
        )
    tip = model.frames[robot.tip_frame]
    placement = pin.SE3(turns[tip.parentJoint], np.zeros(3)).inverse() * tip.placement
    links.append('<link name="tool"/>')
    joints.append(
        f'<joint name="tool_joint" type="fixed"><parent link="link_{model.names[tip.parentJoint]}"/>'
        f'<child link="tool"/>{_origin(placement, digits)}</joint>'
    )
    body = "\n".join(links + joints)
    return f'<?xml version="1.0"?>\n<robot name="{robot.name}_z">\n{body}\n</robot>\n'
