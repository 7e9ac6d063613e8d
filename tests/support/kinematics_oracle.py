"""The forward kinematics' oracle: Pinocchio one configuration at a time on a model whose tip body
carries the payload, θ from its defining equation (independent of pincal.model.kinematics)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

import pincal
from pincal.model.statics import Payload


def oracle_thetas(robot: pincal.Robot, qs: np.ndarray, payload: Payload | None = None) -> np.ndarray:
    """θ from the readings by the defining equation, θ = q + Δq + k⊙q + c⊙τ(θ), τ = −g(θ) from
    Pinocchio on a model whose tip body carries the payload, iterated to a fixed point here."""
    model = pin.Model(robot.model)
    if payload is not None:
        tip = model.frames[robot.tip_frame].placement
        joint = robot.tip_joint
        model.inertias[joint] = model.inertias[joint] + pin.Inertia(
            payload.mass, tip.act(np.array(payload.centre)), np.zeros((3, 3))
        )
    data = model.createData()
    start = qs + robot.joint_offsets + robot.joint_gains * qs
    thetas = start.copy()
    for _ in range(200):
        thetas = start - robot.joint_compliances * np.array(
            [pin.computeGeneralizedGravity(model, data, t) for t in thetas]
        )
    return thetas


def oracle_frames(robot: pincal.Robot, thetas: np.ndarray):
    """Pinocchio's framesForwardKinematics per configuration: (oMi translations, oMi rotations,
    tip frame, markers), base frame."""
    model, data = robot.model, robot.model.createData()
    out = []
    for theta in thetas:
        pin.framesForwardKinematics(model, data, theta)
        tip = pin.SE3(data.oMf[robot.tip_frame])
        joints = [pin.SE3(m) for m in data.oMi]
        out.append((joints, tip, np.array([tip.act(p) for p in robot.markers])))
    return out


def heights(robot: pincal.Robot, q: np.ndarray, payload: Payload | None = None) -> np.ndarray:
    """The heights (z, base frame) of the mount's candidate points at the reading ``q`` (nq,):
    the moving joints' origins, the tip, the markers (Pinocchio at the oracle's θ)."""
    ((joints, tip, points),) = oracle_frames(robot, oracle_thetas(robot, q[None], payload))
    return np.array([m.translation[2] for m in joints[1:]] + [tip.translation[2], *points[:, 2]])
