"""A camera rig from YAML: the camera's intrinsics, where it and its target are, and the target's
points (docs/method.md §13.1).

Layout (lengths in metres, angles in radians, or degrees under a key ending in ``_deg``)::

    camera:
      fx: 600.0            # focal lengths and principal point [px] (ROS camera_info K)
      fy: 600.0
      cx: 320.0
      cy: 240.0
      distortion: [0.05, -0.02, 0.0, 0.0, 0.0]   # k1, k2, p1, p2, k3 (camera_info D); optional
      width: 640           # image size [px]; optional (points outside are not seen)
      height: 480
      mount: tool          # tool (eye-in-hand) or cell (eye-to-hand)
      xyz: [0.05, 0.0, 0.05]   # nominal placement: in the tip frame (tool), the instrument's (cell)
      rpy: [0.0, 0.0, 0.0]
    target:
      grid: {columns: 6, rows: 5, spacing: 0.03}   # or points: [[x, y, z], ...] in its frame
      xyz: [0.5, 0.0, 0.0]     # nominal placement, on the other side (cell, or tool)
      rpy_deg: [180, 0, 0]
    pixel_sigma: 0.5       # [px]; optional

The camera's frame has z along the optical axis, x to the image's right and y down (OpenCV, ROS
``camera_info``). The nominal placements need only be good to a few centimetres and degrees: they
are identified with the robot.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument
from pincal.files import read_yaml
from pincal.instruments.camera import Camera
from pincal.instruments.error_model import DEFAULT_SIGMA_PX
from pincal.instruments.image import Image, grid
from pincal.model.fixtures import Fixture

_CAMERA = ("fx", "fy", "cx", "cy", "distortion", "width", "height", "mount", "xyz", "rpy", "rpy_deg")
_TARGET = ("grid", "points", "xyz", "rpy", "rpy_deg")


@dataclass(frozen=True, eq=False)
class Rig:
    """A camera rig: the image kind, the camera's and the target's fixtures, the pixel σ.

    Attributes:
        kind: the image measurement kind (intrinsics, target points, mount).
        fixtures: the camera's and the target's fixtures at their nominal placements.
        pixel_sigma: the pixel noise [px].
    """

    kind: Image
    fixtures: tuple[Fixture, Fixture]
    pixel_sigma: float = DEFAULT_SIGMA_PX


def load_rig(path: str | os.PathLike) -> Rig:
    """The camera rig of a YAML file (see module doc).

    Raises:
        BadArgument: a missing, unreadable or malformed file, naming the key.
    """
    data = read_yaml(path, what="camera rig", error=BadArgument)
    return rig_from_dict(data, f"camera rig {str(path)!r}")


def rig_from_dict(data: object, where: str = "camera rig") -> Rig:
    """The camera rig of a mapping with the YAML file's layout."""
    data = _mapping(data, where, ("camera", "target", "pixel_sigma"))
    camera = _mapping(data.get("camera"), f"{where}: camera", _CAMERA)
    target = _mapping(data.get("target"), f"{where}: target", _TARGET)
    mount = camera.get("mount", "tool")
    if mount not in ("tool", "cell"):
        raise BadArgument(f"{where}: camera mount {mount!r}; valid: tool (eye-in-hand), cell (eye-to-hand)")
    intrinsics = Camera(
        fx=_number(camera, "fx", f"{where}: camera"),
        fy=_number(camera, "fy", f"{where}: camera"),
        cx=_number(camera, "cx", f"{where}: camera"),
        cy=_number(camera, "cy", f"{where}: camera"),
        distortion=tuple(_numbers(camera.get("distortion", []), f"{where}: camera distortion")),
        width=_pixels(camera, "width", where),
        height=_pixels(camera, "height", where),
    )
    kind = Image(intrinsics, _points(target, where), eye_in_hand=mount == "tool")
    fixtures = kind.fixtures(_placement(camera, f"{where}: camera"), _placement(target, f"{where}: target"))
    sigma = data.get("pixel_sigma", DEFAULT_SIGMA_PX)
    if isinstance(sigma, bool) or not (
        isinstance(sigma, (int, float)) and math.isfinite(sigma) and sigma > 0
    ):
        raise BadArgument(f"{where}: pixel_sigma must be a positive number of pixels, got {sigma!r}")
    return Rig(kind, fixtures, float(sigma))


def _mapping(value: object, where: str, valid: tuple[str, ...]) -> dict:
    if not isinstance(value, dict):
        raise BadArgument(f"{where} must be a mapping of {', '.join(valid)}, got {value!r}")
    unknown = [k for k in value if k not in valid]
    if unknown:
        raise BadArgument(f"{where}: unknown key {unknown[0]!r}; valid: {', '.join(valid)}")
    return value


def _is_number(value: object) -> bool:
    """A finite int or float as YAML reads it: never a boolean (``true`` is no 1), never a string."""
    return not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value)


def _number(entry: dict, key: str, where: str) -> float:
    value = entry.get(key)
    if not _is_number(value):
        raise BadArgument(f"{where} {key} must be a number, got {value!r}")
    return float(value)  # type: ignore[arg-type]  # an int or a float: _is_number


def _pixels(entry: dict, key: str, where: str) -> int | None:
    """The image's width or height [px]: a positive integer, or absent."""
    value = entry.get(key)
    if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
        raise BadArgument(f"{where}: camera {key} must be a positive number of pixels, got {value!r}")
    return value


def _numbers(value: object, where: str, size: int | None = None) -> list[float]:
    if not isinstance(value, (list, tuple)) or not all(_is_number(v) for v in value):
        raise BadArgument(f"{where} must be a list of finite numbers, got {value!r}")
    if size is not None and len(value) != size:
        raise BadArgument(f"{where} must be {size} finite numbers, got {value!r}")
    return [float(v) for v in value]


def _placement(entry: dict, where: str) -> pin.SE3:
    if "rpy" in entry and "rpy_deg" in entry:
        raise BadArgument(f"{where}: give rpy (radians) or rpy_deg (degrees), not both")
    xyz = _numbers(entry.get("xyz", [0.0, 0.0, 0.0]), f"{where} xyz", 3)
    if "rpy_deg" in entry:
        rpy = np.radians(_numbers(entry["rpy_deg"], f"{where} rpy_deg", 3))
    else:
        rpy = np.array(_numbers(entry.get("rpy", [0.0, 0.0, 0.0]), f"{where} rpy", 3))
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))


def _points(target: dict, where: str) -> np.ndarray:
    if ("grid" in target) == ("points" in target):
        raise BadArgument(
            f"{where}: the target needs grid: {{columns, rows, spacing}} or points: [[x, y, z], ...]"
        )
    if "points" in target:
        given = target["points"]
        if not isinstance(given, list) or not given:
            raise BadArgument(f"{where}: target points must be a list [[x, y, z], ...], got {given!r}")
        points = [_numbers(p, f"{where}: target point", 3) for p in given]
        return np.array(points)
    g = _mapping(target["grid"], f"{where}: target grid", ("columns", "rows", "spacing"))
    columns, rows = g.get("columns"), g.get("rows")
    if (
        not isinstance(columns, int)
        or not isinstance(rows, int)
        or isinstance(columns, bool)
        or isinstance(rows, bool)
    ):
        raise BadArgument(f"{where}: target grid columns and rows must be integers")
    return grid(columns, rows, _number(g, "spacing", f"{where}: target grid"))
