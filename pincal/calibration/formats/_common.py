"""What the readers of other tools' files share: where a value came from (for messages), the
joint values by name in the robot's order, typed getters of parsed YAML, and the turn that gives
a measured frame the tip's axes (pincal's marker frame)."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from pincal.errors import BadMeasurementData
from pincal.model.robot import Robot


def where(path: str | os.PathLike, what: str) -> str:
    """How messages name a file: ``FIGAROH measurement file 'a.csv'``."""
    return f"{what} file {str(path)!r}"


def bad(place: str, message: str, path: str | os.PathLike, line: int | None = None) -> BadMeasurementData:
    """The one error of a bad file: its place (file, line or key) and what was expected."""
    return BadMeasurementData(f"{place}: {message}", file=str(path), line=line)


def mapping(value: object, place: str, path: str | os.PathLike, expected: str) -> dict:
    """``value`` if it is a mapping, else the error naming ``place`` and what was ``expected``."""
    if not isinstance(value, dict):
        raise bad(place, f"expected {expected}, got {_kind(value)}", path)
    return value


def sequence(value: object, place: str, path: str | os.PathLike, expected: str) -> list:
    """``value`` if it is a list, else the error naming ``place`` and what was ``expected``."""
    if not isinstance(value, list):
        raise bad(place, f"expected {expected}, got {_kind(value)}", path)
    return value


def key(value: dict, name: str, place: str, path: str | os.PathLike) -> object:
    """``value[name]``, or the error naming the missing key and the keys there are."""
    if name not in value:
        there = ", ".join(str(k) for k in value) or "none"
        raise bad(place, f"missing key {name!r} (keys: {there})", path)
    return value[name]


def numbers(value: object, place: str, path: str | os.PathLike, count: int | None = None) -> np.ndarray:
    """A list of real numbers (``count`` of them when given) as a float array; booleans and text
    are not numbers."""
    ok = isinstance(value, list) and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value
    )
    if not ok or (count is not None and len(value) != count):  # type: ignore[arg-type]
        size = f"{count} " if count is not None else ""
        raise bad(place, f"expected a list of {size}numbers, got {_kind(value)}", path)
    return np.array(value, dtype=float)


def number(value: object, place: str, path: str | os.PathLike) -> float:
    """A real number (not a boolean, not text)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise bad(place, f"expected a number, got {_kind(value)}", path)
    return float(value)


def text(value: object, place: str, path: str | os.PathLike) -> str:
    """A string."""
    if not isinstance(value, str):
        raise bad(place, f"expected a name, got {_kind(value)}", path)
    return value


def _kind(value: object) -> str:
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if value is None:
        return "nothing"
    return f"{type(value).__name__} {value!r}"[:80]


def by_name(
    names: Sequence[str], rows: np.ndarray, robot: Robot, place: str, path: str | os.PathLike
) -> np.ndarray:
    """(m, nq) the robot's joint values, in its order, from ``rows`` (m, len(names)) whose columns
    are named ``names``; other joints (a gripper's, a head's) are left out."""
    missing = [n for n in robot.joint_names if n not in names]
    if missing:
        raise bad(
            place,
            f"no value for the robot's joint(s) {', '.join(missing)} (the file names "
            f"{', '.join(names) or 'no joint'}; the robot's joints are {', '.join(robot.joint_names)})",
            path,
        )
    return rows[:, [list(names).index(n) for n in robot.joint_names]]


def quaternion(value: dict, place: str, path: str | os.PathLike, keys: Sequence[str]) -> np.ndarray:
    """The rotation matrix of a quaternion given by its ``keys`` (w, x, y, z order), normalised;
    a quaternion far from unit length is refused."""
    w, x, y, z = (number(key(value, k, place, path), f"{place}.{k}", path) for k in keys)
    norm = np.sqrt(w * w + x * x + y * y + z * z)
    if not 0.9 < norm < 1.1:
        raise bad(place, f"the quaternion ({', '.join(keys)}) has length {norm:.3g}, expected 1", path)
    return pin.Quaternion(w / norm, x / norm, y / norm, z / norm).toRotationMatrix()


def homogeneous(value: object, place: str, path: str | os.PathLike) -> pin.SE3:
    """A 4x4 homogeneous transform given as 16 numbers row by row [m]."""
    T = numbers(value, place, path, 16).reshape(4, 4)
    R = T[:3, :3]
    if not (np.allclose(T[3], [0, 0, 0, 1], atol=1e-6) and np.allclose(R @ R.T, np.eye(3), atol=1e-4)):
        raise bad(place, "expected a rigid transform (4x4, row by row: a rotation, then 0 0 0 1)", path)
    U, _, Vt = np.linalg.svd(R)  # the nearest rotation: a transform printed to a few digits
    return pin.SE3(U @ Vt, T[:3, 3].copy())


MIN_TURN = 1e-3
"""The least spread of the tool's turns [rad] about a second axis for its measured frame's
orientation on the tool to be found."""


def turn_on_tool(robot: Robot, q: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, float]:
    """(X, misfit): the constant rotation X (3, 3) of a frame fixed on the tool relative to the
    robot's tip, from its orientations ``measured`` (m, 3, 3) in a fixed frame at joint values
    ``q`` (m, nq), and the RMS misfit [rad] of the relative turns.

    The measured orientations are Mᵢ = C·Aᵢ·X with Aᵢ the tip's nominal orientation and C the
    fixed frame's: the relative turns Aᵢᵀ·Aⱼ and Mᵢᵀ·Mⱼ are conjugate by X (AX = XB), so the
    rotation vectors α = log(AᵢᵀAⱼ) and β = log(MᵢᵀMⱼ) satisfy α = X·β, solved as an orthogonal
    Procrustes problem (Park and Martin, 1994). Needs turns about two axes at least.
    """
    A, _ = robot.tip_poses(q, check=False)
    m = len(A)
    pairs = {(i, j) for i in range(m) for j in (i + 1, i + m // 2) if j < m}
    alpha = np.array([pin.log3(A[i].T @ A[j]) for i, j in sorted(pairs)]).reshape(-1, 3)
    beta = np.array([pin.log3(measured[i].T @ measured[j]) for i, j in sorted(pairs)]).reshape(-1, 3)
    if len(alpha) < 2 or np.linalg.svd(alpha, compute_uv=False)[1] < MIN_TURN * np.sqrt(len(alpha)):
        raise BadMeasurementData(
            "the tool turns about one axis at most in these data: the measured frame's orientation on "
            "the tool cannot be found (add configurations that turn the tool about another axis)"
        )
    U, _, Vt = np.linalg.svd(alpha.T @ beta)
    X = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    misfit = float(np.sqrt(np.mean(np.sum((alpha - beta @ X.T) ** 2, axis=1))))
    return X, misfit


def pose_values(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """(m, 6) pose values [x, y, z [m], rotation vector [rad]] of (m, 3) positions and (m, 3, 3)
    orientations."""
    return np.array([np.concatenate([p, pin.log3(R)]) for p, R in zip(positions, rotations)])
