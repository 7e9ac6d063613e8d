"""A calibration as deployed: the calibrated URDF (plain geometry, joint offsets folded in) and its
JSON sidecar, which holds everything else compensation needs: the tip and markers, the joint gains
and compliances, gravity in the robot's base frame, the base in the instrument's frame and the
residual model (see :mod:`pincal.calibration.urdf_export`)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.calibration.urdf_export import sidecar_path
from pincal.errors import BadArgument, UrdfError
from pincal.model.loading import load_robot
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot


@dataclass(frozen=True, eq=False)
class DeployedCalibration:
    """A calibration read back from its files.

    Attributes:
        robot: the calibrated robot: the URDF's geometry, with the sidecar's gains, compliances,
            gravity, markers and base.
        residual_model: the residual model, or None.
        urdf: the calibrated URDF.
        sidecar: the sidecar's content.
    """

    robot: Robot
    residual_model: ResidualModel | None
    urdf: Path
    sidecar: dict


def _by_joint(values: object, names: tuple[str, ...], what: str, where: Path) -> np.ndarray | None:
    """A {joint: value} of the sidecar as an array in ``names`` order (0 for a joint it does not list)."""
    if values is None:
        return None
    if not isinstance(values, dict) or not set(values) <= set(names):
        raise BadArgument(
            f"{where}: {what} must map the chain's joints ({', '.join(names)}) to numbers, got {values!r}"
        )
    try:
        out = np.array([float(values.get(name, 0.0)) for name in names])
    except (TypeError, ValueError):
        raise BadArgument(f"{where}: {what} must be numbers, got {values!r}") from None
    if not np.all(np.isfinite(out)):
        raise BadArgument(f"{where}: {what} must be finite")
    return out


def load_calibration(urdf: str | os.PathLike, nominal: Robot) -> DeployedCalibration:
    """Read a calibrated URDF and its sidecar (``cal.urdf`` → ``cal.calibration.json``) for the chain
    of ``nominal`` (its root and joint ranges).

    Raises:
        UrdfError: the URDF cannot be read, or its chain is not the nominal robot's.
        BadArgument: the sidecar is missing or malformed (what is wrong is named).
    """
    urdf = Path(urdf)
    side = sidecar_path(urdf)
    if not side.is_file():
        raise BadArgument(
            f"the calibration's sidecar {str(side)!r} is missing: it holds what compensation needs beside "
            f"the URDF's geometry (tip, markers, gains, compliances, gravity, residual model); export the "
            f"calibration with 'pincal identify --out' to write both",
            argument="--calibration",
        )
    try:
        content = json.loads(side.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadArgument(f"{side}: not a readable JSON sidecar ({exc})", argument="--calibration") from None
    if not isinstance(content, dict) or "tip" not in content:
        raise BadArgument(f"{side}: not a calibration sidecar (no 'tip')", argument="--calibration")
    ranges = {n: (lo, hi) for n, lo, hi in zip(nominal.joint_names, nominal.lower, nominal.upper)}
    robot = load_robot(
        urdf,
        tip=content["tip"],
        markers=content.get("markers"),
        root=nominal.root,
        joint_ranges=ranges,
        package_dirs=dict(nominal.package_dirs),
    )
    if robot.joint_names != nominal.joint_names:
        raise UrdfError(
            f"{urdf}: its chain has joints {', '.join(robot.joint_names)}; the robot compensated has "
            f"{', '.join(nominal.joint_names)}"
        )
    names = robot.joint_names
    gains = _by_joint(content.get("joint_gains"), names, "joint_gains", side)
    compliances = _by_joint(content.get("joint_compliances"), names, "joint_compliances", side)
    base = content.get("base", {}).get("matrix")
    robot = robot.replace(
        joint_gains=gains,
        joint_compliances=compliances,
        base=pin.SE3(np.array(base, dtype=float)) if base is not None else pin.SE3.Identity(),
    )
    if content.get("gravity") is not None:
        robot = robot.with_gravity(content["gravity"])
    residual = content.get("residual_model")
    model = ResidualModel.from_dict(residual) if residual is not None else None
    if model is not None and (len(model.revolute) != robot.nq or model.rows != 3 * robot.n_markers):
        raise BadArgument(f"{side}: its residual model does not fit the chain ({robot.nq} joints)")
    return DeployedCalibration(robot, model, urdf, content)
