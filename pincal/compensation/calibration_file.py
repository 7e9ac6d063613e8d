"""A calibration as deployed: the calibrated URDF (plain geometry, joint offsets folded in) and its
JSON sidecar, which holds everything else compensation needs: the tip and markers, the joint gains
and compliances, gravity in the robot's base frame, the base in the instrument's frame and the
residual model (see :mod:`pincal.export.urdf`)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument, UrdfError
from pincal.export.urdf import sidecar_path
from pincal.files import read_text
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


MAX_GAIN = 0.5
"""Largest joint gain error in size a sidecar may hold (a joint reading q moves it by q·(1 + gain):
−1 would hold it still; real gain errors are a fraction of a percent)."""


def _numbers(value: object, field: str, side: Path, shape: tuple[int, ...] | None = None) -> np.ndarray:
    """The sidecar's ``field`` as an array of finite numbers (of ``shape``), never a boolean read
    as 1 or 0 (a JSON ``true`` is not a number), or one BadArgument naming the field."""

    def numbers(v: object) -> bool:
        if isinstance(v, list):
            return all(numbers(x) for x in v)
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    expected = "numbers" if shape is None else f"{' x '.join(map(str, shape))} numbers"
    if not numbers(value):
        raise BadArgument(
            f"{side}: {field!r} must be {expected}, got {_shown(value)}", argument="--calibration"
        )
    try:
        out = np.array(value, dtype=float)
    except (TypeError, ValueError):  # ragged lists
        raise BadArgument(
            f"{side}: {field!r} must be {expected}, got {_shown(value)}", argument="--calibration"
        ) from None
    if shape is not None and out.shape != shape:
        raise BadArgument(
            f"{side}: {field!r} must be {expected}, got shape {out.shape}", argument="--calibration"
        )
    if not np.all(np.isfinite(out)):
        raise BadArgument(f"{side}: {field!r} must be finite numbers", argument="--calibration")
    return out


def _shown(value: object) -> str:
    """``value`` for a message: its JSON, cut to 80 characters."""
    text = json.dumps(value) if not isinstance(value, float) or np.isfinite(value) else repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _by_joint(values: object, names: tuple[str, ...], what: str, where: Path) -> np.ndarray | None:
    """A {joint: value} of the sidecar as an array in ``names`` order (0 for a joint it does not list)."""
    if values is None:
        return None
    if not isinstance(values, dict) or not set(values) <= set(names):
        raise BadArgument(
            f"{where}: {what} must map the chain's joints ({', '.join(names)}) to numbers, "
            f"got {_shown(values)}",
            argument="--calibration",
        )
    return _numbers([values.get(name, 0.0) for name in names], what, where, (len(names),))


def _base(value: object, side: Path) -> pin.SE3:
    """The sidecar's base: ``{"matrix": 4 x 4}``, a rigid transform (identity when absent)."""
    if not isinstance(value, dict) or "matrix" not in value:
        raise BadArgument(
            f"{side}: 'base' must be the robot base in the instrument's frame, {{\"matrix\": 4 x 4, ...}}, "
            f"got {_shown(value)}",
            argument="--calibration",
        )
    matrix = _numbers(value["matrix"], "base.matrix", side, (4, 4))
    rotation = matrix[:3, :3]
    rigid = np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) and np.linalg.det(rotation) > 0
    if not (rigid and np.allclose(matrix[3], [0, 0, 0, 1])):
        raise BadArgument(
            f"{side}: 'base.matrix' must be a rigid transform (a rotation, a translation, last row 0 0 0 1)",
            argument="--calibration",
        )
    return pin.SE3(matrix)


def _residual_model(value: object, side: Path) -> ResidualModel:
    """The sidecar's residual model (:meth:`ResidualModel.as_dict`), checked: numbers that are
    numbers (its ``revolute`` flags aside)."""
    if not isinstance(value, dict):
        raise BadArgument(
            f"{side}: 'residual_model' must be the residual model's description (an object), "
            f"got {_shown(value)}",
            argument="--calibration",
        )
    for key, item in value.items():
        if key not in ("kind", "revolute") and isinstance(item, (list, bool, int, float)):
            _numbers(item, f"residual_model.{key}", side)
    try:
        return ResidualModel.from_dict(value)
    except (BadArgument, AttributeError, IndexError, KeyError, TypeError, ValueError) as exc:
        raise BadArgument(f"{side}: 'residual_model': {exc}", argument="--calibration") from None


def _read_sidecar(side: Path) -> dict:
    """The sidecar's JSON object, read as an input (never overwritten by the command's outputs)."""
    text = read_text(side, "calibration sidecar", BadArgument)

    def refuse(constant: str) -> float:
        raise ValueError(f"{constant} is not a number a calibration holds")

    try:
        content = json.loads(text, parse_constant=refuse)
    except RecursionError:
        raise BadArgument(
            f"{side}: not a calibration sidecar (nested too deeply)", argument="--calibration"
        ) from None
    except ValueError as exc:  # json.JSONDecodeError too
        raise BadArgument(f"{side}: not a readable JSON sidecar ({exc})", argument="--calibration") from None
    if not isinstance(content, dict) or "tip" not in content:
        raise BadArgument(f"{side}: not a calibration sidecar (no 'tip')", argument="--calibration")
    tip = content["tip"]
    if not isinstance(tip, str) or not tip.strip():
        raise BadArgument(
            f"{side}: 'tip' must be the name of the tip frame (a string), got {_shown(tip)}",
            argument="--calibration",
        )
    return content


def sidecar_tip(side: Path) -> str:
    """The tip frame a calibration's sidecar names (BadArgument, naming what is wrong, for a sidecar
    that is no JSON object with a 'tip' string: nested too deeply, NaN, a null tip)."""
    return str(_read_sidecar(side)["tip"])


def load_calibration(urdf: str | os.PathLike, nominal: Robot) -> DeployedCalibration:
    """Read a calibrated URDF and its sidecar (``cal.urdf`` → ``cal.calibration.json``) for the chain
    of ``nominal`` (its root and joint ranges).

    Raises:
        UrdfError: the URDF cannot be read, or its chain is not the nominal robot's.
        BadArgument: the sidecar is missing or malformed (what is wrong is named).
    """
    urdf = Path(urdf)
    if not urdf.name or urdf.is_dir():
        raise BadArgument(
            f"the calibration {str(urdf)!r} is no file: give the calibrated URDF 'pincal identify --out' "
            "wrote (its sidecar beside it)",
            argument="--calibration",
        )
    side = sidecar_path(urdf)
    if not side.is_file():
        raise BadArgument(
            f"the calibration's sidecar {str(side)!r} is missing: it holds what compensation needs beside "
            f"the URDF's geometry (tip, markers, gains, compliances, gravity, residual model); export the "
            f"calibration with 'pincal identify --out' to write both",
            argument="--calibration",
        )
    content = _read_sidecar(side)
    markers = content.get("markers")
    if markers is not None:
        markers = _numbers(markers, "markers", side)
        if markers.ndim != 2 or markers.shape[1] != 3 or not len(markers):
            raise BadArgument(f"{side}: 'markers' must be [[x, y, z], ...] [m]", argument="--calibration")
    ranges = {n: (lo, hi) for n, lo, hi in zip(nominal.joint_names, nominal.lower, nominal.upper)}
    robot = load_robot(
        urdf,
        tip=content["tip"],
        markers=markers,
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
    if gains is not None and not np.all(np.abs(gains) < MAX_GAIN):
        j = int(np.argmax(np.abs(gains)))
        raise BadArgument(
            f"{side}: 'joint_gains' of {names[j]} is {gains[j]:g}: a gain error must lie within "
            f"±{MAX_GAIN:g} (the joint moves by q·(1 + gain))",
            argument="--calibration",
        )
    compliances = _by_joint(content.get("joint_compliances"), names, "joint_compliances", side)
    robot = robot.replace(
        joint_gains=gains,
        joint_compliances=compliances,
        base=_base(content["base"], side) if "base" in content else pin.SE3.Identity(),
    )
    if content.get("gravity") is not None:
        robot = robot.with_gravity(_numbers(content["gravity"], "gravity", side, (3,)))
    residual = content.get("residual_model")
    model = _residual_model(residual, side) if residual is not None else None
    if model is not None and (len(model.revolute) != robot.nq or model.rows != 3 * robot.n_markers):
        raise BadArgument(f"{side}: its residual model does not fit the chain ({robot.nq} joints)")
    return DeployedCalibration(robot, model, urdf, content)
