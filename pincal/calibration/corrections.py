"""A calibration as corrections of the unchanged source description, and their YAML layout.

A calibrated URDF is a copy of the user's description with new numbers in it. The corrections are
the same calibration kept apart from the description (docs/method.md §5.10): for each joint of the
measured chain its calibrated ``<origin>`` (offset folded in, and without it), its offset and its
gain; the tool's fixed joint; the markers and the base. :func:`corrections_of` reads them from a
calibrated robot (the calibrated file reloaded with its sidecar's terms), its sidecar and the source
it was made from; :func:`corrections_yaml` writes them in the layout below, which a xacro
description can read (:mod:`pincal.export.xacro`)::

    format: pincal-corrections-1
    robot: NAME
    source: FILE            # the description calibrated (its file name)
    tip: FRAME
    units: metres and radians
    kinematics:             # what a description reads: each origin with the offset folded in
      JOINT: {x: .., y: .., z: .., roll: .., pitch: .., yaw: ..}
    joints:                 # the chain's joints, the offset kept apart
      JOINT:
        origin: {x: .., y: .., z: .., roll: .., pitch: .., yaw: ..}
        nominal: {x: .., ...}   # the source's origin
        offset: ..          # the joint stands at reading * (1 + gain) + offset
        gain: ..
    tool: {joint: JOINT, origin: {...}, nominal: {...}}   # the tip's fixed joint (or null)
    markers: [[x, y, z], ...]                              # in the tip frame
    base: {x: .., y: .., z: .., roll: .., pitch: .., yaw: ..}   # the robot in the instrument frame

An origin is the URDF's: xyz in the parent link's frame, rpy the fixed-axis roll, pitch, yaw
(R = Rz(yaw)·Ry(pitch)·Rx(roll)). For a Universal Robots arm (the six joints of ur_description,
any prefix) ``kinematics`` is ur_description's own layout (``shoulder``, ``upper_arm``,
``forearm``, ``wrist_1``, ``wrist_2``, ``wrist_3`` and a ``hash``), so the file is a
``kinematics_params`` file for ur_description as it is; it then has no entry for the tool, whose
fixed joints ur_description writes as literals (the tool's correction is in ``tool``).
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument, PincalWarning
from pincal.model.loading import load_robot
from pincal.model.robot import Robot
from pincal.version import __version__

FORMAT = "pincal-corrections-1"
"""The layout's name and version, the file's ``format``."""

UR_KEYS = {
    "shoulder_pan_joint": "shoulder",
    "shoulder_lift_joint": "upper_arm",
    "elbow_joint": "forearm",
    "wrist_1_joint": "wrist_1",
    "wrist_2_joint": "wrist_2",
    "wrist_3_joint": "wrist_3",
}
"""ur_description's kinematics key of each UR joint (its ``ur_common.xacro``: the key's
``x y z roll pitch yaw`` are the joint's ``<origin>``)."""


@dataclass(frozen=True)
class JointCorrection:
    """One chain joint's calibration.

    Attributes:
        name: the URDF joint.
        nominal: its ``<origin>`` in the source.
        origin: the calibrated origin, offset not folded in.
        folded: the calibrated origin with the offset folded in (the calibrated URDF's).
        offset: the joint offset [rad or m]: the joint stands at reading·(1 + gain) + offset.
        gain: the joint gain error (dimensionless).
    """

    name: str
    nominal: pin.SE3
    origin: pin.SE3
    folded: pin.SE3
    offset: float
    gain: float


@dataclass(frozen=True)
class ToolCorrection:
    """The tip's fixed joint: its ``<origin>`` in the source (``nominal``) and calibrated."""

    joint: str
    nominal: pin.SE3
    origin: pin.SE3


@dataclass(frozen=True)
class Corrections:
    """A calibration as corrections of its source (see the module doc).

    Attributes:
        robot: the calibrated robot (the calibration's).
        source: the description it was calibrated from.
        joints: the chain's joints, in chain order.
        tool: the tip's fixed joint, or None when the tip has none.
        markers: (k, 3) markers in the tip frame [m].
        base: the robot's base in the instrument frame.
    """

    robot: Robot
    source: Path
    joints: tuple[JointCorrection, ...]
    tool: ToolCorrection | None
    markers: np.ndarray
    base: pin.SE3

    @property
    def ur_prefix(self) -> str | None:
        """The joints' prefix when the chain is a Universal Robots arm's six joints (ur_description's
        names after a common prefix, in order), else None."""
        names = [j.name for j in self.joints]
        if len(names) != len(UR_KEYS):
            return None
        prefix = names[0].removesuffix("shoulder_pan_joint")
        if prefix == names[0] or [prefix + key for key in UR_KEYS] != names:
            return None
        return prefix


def source_of(sidecar: dict, calibrated: str | os.PathLike, given: str | os.PathLike | None = None) -> Path:
    """The description the calibration ``calibrated`` (with its ``sidecar``) was made from:
    ``given`` (``--source``), else the sidecar's ``source``.

    Raises:
        BadArgument: neither is there, or the file is missing.
    """
    if given is not None:
        path = Path(given)
    elif isinstance(sidecar.get("source"), str):
        path = Path(sidecar["source"])
    else:
        raise BadArgument(
            f"the sidecar of {Path(calibrated).name} does not name the description it was calibrated from "
            "(sidecars before pincal 0.x): give --source ROBOT.urdf or ROBOT.urdf.xacro",
            argument="--source",
        )
    if not path.is_file():
        raise BadArgument(
            f"the calibration's source {str(path)!r} is not a file: give --source, the URDF or xacro "
            "file the calibration was made from",
            argument="--source",
            value=str(path),
        )
    return path


def _joint_offsets(sidecar: dict) -> dict:
    """The sidecar's ``joint_offsets``: {joint name: a finite number [rad or m]} (BadArgument else)."""
    offsets = sidecar.get("joint_offsets") or {}
    numbers = isinstance(offsets, dict) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in offsets.values()
    )
    if not numbers:
        raise BadArgument(
            f"the calibration's sidecar: 'joint_offsets' must map joint names to finite numbers [rad or m], "
            f"got {str(offsets)[:80]}",
            argument="CAL.urdf",
        )
    return offsets


def corrections_of(robot: Robot, sidecar: dict, source: str | os.PathLike) -> Corrections:
    """The corrections of the calibrated ``robot`` (its ``sidecar`` holds the joint offsets folded
    into its origins) relative to ``source`` (see the module doc).

    Raises:
        BadArgument: the source does not hold the calibrated chain.
    """
    source = Path(source)
    ranges = dict(zip(robot.joint_names, zip(robot.lower.tolist(), robot.upper.tolist())))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PincalWarning)  # told when the calibration was loaded
        nominal = load_robot(
            source,
            tip=robot.tip,
            root=robot.root,
            joint_ranges=ranges,
            package_dirs=dict(robot.package_dirs),
        )
    if nominal.joint_names != robot.joint_names:
        raise BadArgument(
            f"{source}: its chain to {robot.tip!r} has joints {', '.join(nominal.joint_names)}; the "
            f"calibration's has {', '.join(robot.joint_names)}: give --source, the file it was made from",
            argument="--source",
        )
    offsets = _joint_offsets(sidecar)
    joints = []
    for o, name in enumerate(robot.joint_names):
        folded = pin.SE3(robot.origins[o].origin)
        offset = float(offsets.get(name, 0.0))
        axis = robot.motion_axes[robot.origins[o].joint]
        joints.append(
            JointCorrection(
                name=name,
                nominal=pin.SE3(nominal.origins[o].origin),
                origin=folded * pin.exp6(pin.Motion(-axis * offset)),
                folded=folded,
                offset=offset,
                gain=float(robot.joint_gains[o]),
            )
        )
    tool = None
    tip, nominal_tip = robot.origins[-1], nominal.origins[-1]
    if len(robot.origins) > robot.nq and tip.urdf_joint is not None:
        tool = ToolCorrection(tip.urdf_joint, pin.SE3(nominal_tip.origin), pin.SE3(tip.origin))
    return Corrections(robot, source, tuple(joints), tool, np.array(robot.markers), pin.SE3(robot.base))


def pose_dict(placement: pin.SE3) -> dict[str, float]:
    """``{x, y, z, roll, pitch, yaw}`` of a placement [m, rad] (URDF's fixed-axis rpy)."""
    x, y, z = (float(v) + 0.0 for v in placement.translation)
    roll, pitch, yaw = (float(v) + 0.0 for v in pin.rpy.matrixToRpy(placement.rotation))
    return {"x": x, "y": y, "z": z, "roll": roll, "pitch": pitch, "yaw": yaw}


def pose_of(values: dict) -> pin.SE3:
    """The placement of a ``{x, y, z, roll, pitch, yaw}`` (:func:`pose_dict`)."""
    rotation = pin.rpy.rpyToMatrix(float(values["roll"]), float(values["pitch"]), float(values["yaw"]))
    return pin.SE3(rotation, np.array([float(values[k]) for k in ("x", "y", "z")]))


def kinematics(corrections: Corrections) -> dict:
    """The ``kinematics`` section: ur_description's for a UR arm, else ``{joint: origin}`` for the
    chain's joints and the tool's, each origin with its offset folded in."""
    prefix = corrections.ur_prefix
    if prefix is not None:
        out: dict[str, object] = {
            UR_KEYS[j.name.removeprefix(prefix)]: pose_dict(j.folded) for j in corrections.joints
        }
        digest = hashlib.sha256(json.dumps(out, sort_keys=True).encode()).hexdigest()[:16]
        out["hash"] = f"calib_pincal_{digest}"  # not the controller's: the UR driver says they differ
        return out
    out = {j.name: pose_dict(j.folded) for j in corrections.joints}
    if corrections.tool is not None:
        out[corrections.tool.joint] = pose_dict(corrections.tool.origin)
    return out


def corrections_dict(corrections: Corrections) -> dict:
    """The corrections in the layout of the module doc."""
    tool = corrections.tool
    return {
        "format": FORMAT,
        "robot": corrections.robot.name,
        "source": corrections.source.name,
        "tip": corrections.robot.tip,
        "units": "metres and radians",
        "kinematics": kinematics(corrections),
        "joints": {
            j.name: {
                "origin": pose_dict(j.origin),
                "nominal": pose_dict(j.nominal),
                "offset": j.offset,
                "gain": j.gain,
            }
            for j in corrections.joints
        },
        "tool": None
        if tool is None
        else {"joint": tool.joint, "origin": pose_dict(tool.origin), "nominal": pose_dict(tool.nominal)},
        "markers": corrections.markers.tolist(),
        "base": pose_dict(corrections.base),
    }


def corrections_yaml(corrections: Corrections) -> str:
    """The corrections as YAML text (the layout of the module doc), numbers written exactly."""
    import yaml

    head = [
        f"# Calibration of {corrections.robot.name} as corrections of {corrections.source.name}, "
        f"written by pincal {__version__}.",
        "# Layout: pincal docs/method.md 5.10. kinematics: each joint origin as the calibrated",
        "# description has it (offsets folded in); joints: the offset kept apart (a joint stands at",
        "# reading * (1 + gain) + offset); markers in the tip frame; base in the instrument frame.",
    ]
    body = yaml.safe_dump(corrections_dict(corrections), sort_keys=False, default_flow_style=None, width=100)
    return "\n".join(head) + "\n" + body
