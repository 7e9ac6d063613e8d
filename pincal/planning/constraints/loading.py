"""Constraints from YAML (:func:`load_constraints`) or a dict (:func:`constraints_from_dict`)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from pincal.errors import BadConstraint
from pincal.files import read_yaml
from pincal.planning.constraints.base import number
from pincal.planning.constraints.clearance import Clearance
from pincal.planning.constraints.half_space import HalfSpace
from pincal.planning.constraints.joint_limits import JointLimits
from pincal.planning.constraints.line_of_sight import LineOfSight
from pincal.planning.constraints.min_spacing import MinSpacing
from pincal.planning.constraints.mount import MOUNTS, Mount
from pincal.planning.constraints.self_collision import SelfCollision
from pincal.planning.constraints.visibility import Visibility
from pincal.planning.constraints.workcell import workcell_from_dict
from pincal.planning.constraints.workspace_box import WorkspaceBox

if TYPE_CHECKING:  # the union of the constraint classes, defined where they are all gathered
    from pincal.planning.constraints import AnyConstraint


_KEYS = (
    "joint_limits",
    "mount",
    "clearance",
    "workspace_box",
    "half_space",
    "visibility",
    "line_of_sight",
    "self_collision",
    "workcell",
    "min_spacing",
)


def _angle(entry: dict, key: str, what: str, default: float | None) -> float | None:
    """An angle given as ``key`` [rad] or ``key_deg`` [deg]."""
    if key in entry and f"{key}_deg" in entry:
        raise BadConstraint(f"{what}: give {key} (radians) or {key}_deg (degrees), not both")
    if f"{key}_deg" in entry:
        return math.radians(number(entry[f"{key}_deg"], f"{what} {key}_deg"))
    return entry.get(key, default)


def _check_keys(entry: object, what: str, valid: Sequence[str]) -> dict:
    if entry is True:
        return {}
    if not isinstance(entry, dict):
        raise BadConstraint(f"{what} must be a mapping of {', '.join(valid)}, got {entry!r}")
    unknown = [k for k in entry if k not in valid]
    if unknown:
        raise BadConstraint(f"{what}: unknown key {unknown[0]!r}; valid: {', '.join(valid)}")
    return entry


def _entries(value: object) -> list:
    return list(value) if isinstance(value, list) else [value]


def _mount(e: object) -> Mount:
    """The mount of the ``mount`` key: a plane's name, or a mapping with plane, or normal and offset."""
    if isinstance(e, str):
        return Mount.parse(e)
    e = _check_keys(e, "mount", ("plane", "normal", "offset"))
    if "plane" in e and e["plane"] not in MOUNTS:
        raise BadConstraint(f"mount plane must be one of {', '.join(MOUNTS)}, got {e['plane']!r}")
    if "plane" in e and ("normal" in e or "offset" in e):
        raise BadConstraint("mount: give plane (floor, wall, ceiling, none) or normal and offset, not both")
    if "plane" in e:
        return Mount(e["plane"])
    if "normal" in e:
        return Mount("plane", e["normal"], e.get("offset", 0.0))
    raise BadConstraint("mount needs plane: floor|wall|ceiling|none, or normal: [x, y, z] and offset")


def constraints_from_dict(data: object, folder: str | os.PathLike | None = None) -> tuple[AnyConstraint, ...]:
    """Constraints from a mapping with the layout of the YAML file (see :func:`load_constraints`);
    the workcell's relative paths are taken from ``folder`` (default: the working folder)."""
    if data is None:
        return ()
    if not isinstance(data, dict):
        raise BadConstraint(f"constraints must be a mapping with keys {', '.join(_KEYS)}")
    unknown = [k for k in data if k not in _KEYS]
    if unknown:
        raise BadConstraint(f"unknown constraint {unknown[0]!r}; valid: {', '.join(_KEYS)}")
    out: list[AnyConstraint] = []
    if "joint_limits" in data:
        e = _check_keys(data["joint_limits"], "joint_limits", ("margin", "margin_deg", "prismatic"))
        out.append(JointLimits(_angle(e, "margin", "joint_limits", 0.0), e.get("prismatic")))  # type: ignore[arg-type]  # checked there
    if "mount" in data:
        out.append(_mount(data["mount"]))
    if "clearance" in data:
        out.append(Clearance(data["clearance"]))
    if "workspace_box" in data:
        e = _check_keys(data["workspace_box"], "workspace_box", ("lower", "upper"))
        if "lower" not in e or "upper" not in e:
            raise BadConstraint("workspace_box needs lower: [x, y, z] and upper: [x, y, z] (metres)")
        out.append(WorkspaceBox(e["lower"], e["upper"]))
    for e in _entries(data.get("half_space", [])):
        e = _check_keys(e, "half_space", ("normal", "offset"))
        if "normal" not in e:
            raise BadConstraint("half_space needs normal: [x, y, z] (and offset, metres)")
        out.append(HalfSpace(e["normal"], e.get("offset", 0.0)))
    for e in _entries(data.get("visibility", [])):
        keys = ("tracker", "max_range", "min_range", "normal", "max_angle", "max_angle_deg")
        e = _check_keys(e, "visibility", keys)
        if "tracker" not in e:
            raise BadConstraint("visibility needs tracker: [x, y, z] (metres)")
        out.append(
            Visibility(
                e["tracker"],
                e.get("max_range", math.inf),
                e.get("min_range", 0.0),
                e.get("normal"),
                _angle(e, "max_angle", "visibility", None),
            )
        )
    for e in _entries(data.get("line_of_sight", [])):
        e = _check_keys(e, "line_of_sight", ("instrument", "clearance", "skip", "package_dirs"))
        if "instrument" not in e:
            raise BadConstraint("line_of_sight needs instrument: [x, y, z] (metres)")
        dirs = _entries(e.get("package_dirs", []))
        if not all(isinstance(d, str) for d in dirs):
            raise BadConstraint(f"line_of_sight package_dirs must be folder names, got {dirs!r}")
        out.append(LineOfSight(e["instrument"], e.get("clearance", 0.01), e.get("skip", 0.05), tuple(dirs)))
    if data.get("self_collision", None) is False:  # turned off: the design adds no check either
        out.append(SelfCollision(enabled=False))
    elif "self_collision" in data:
        e = _check_keys(data["self_collision"], "self_collision", ("min_distance", "package_dirs"))
        dirs = _entries(e.get("package_dirs", []))
        if not all(isinstance(d, str) for d in dirs):
            raise BadConstraint(f"self_collision package_dirs must be folder names, got {dirs!r}")
        out.append(SelfCollision(e.get("min_distance", 0.0), tuple(dirs)))
    if "workcell" in data:
        out.append(workcell_from_dict(data["workcell"], None if folder is None else Path(folder)))
    if "min_spacing" in data:
        e = _check_keys(data["min_spacing"], "min_spacing", ("distance", "distance_deg"))
        distance = _angle(e, "distance", "min_spacing", None)
        if distance is None:
            raise BadConstraint("min_spacing needs distance (radians) or distance_deg (degrees)")
        out.append(MinSpacing(distance))
    return tuple(out)


def load_constraints(path: str | os.PathLike) -> tuple[AnyConstraint, ...]:
    """Read constraints from a YAML file.

    Layout (every key optional; lengths in metres in the instrument frame; angles in radians, or
    in degrees with the ``_deg`` keys)::

        joint_limits: {margin_deg: 5, prismatic: 0.02}   # default 2 deg, 1 cm on prismatic joints
        mount: floor                     # floor, wall, ceiling, none, or {normal: [0, 0, 1], offset: -0.8}
        clearance: 0.05                  # kept from the mount and the obstacles (default 0.05; 0: none)
        workspace_box: {lower: [0.5, -1.5, 0.2], upper: [2.8, 1.5, 2.2]}
        half_space:                      # one mapping or a list; keeps normal·p >= offset
          - {normal: [0, 0, 1], offset: 0.3}
        visibility:                      # one mapping or a list
          tracker: [4.0, 0.0, 1.2]
          max_range: 6.0
          min_range: 1.0
          normal: [0, 0, 1]              # marker normal in the tip frame
          max_angle_deg: 60
        line_of_sight:                   # one mapping or a list: needs collision geometry
          instrument: [4.0, 0.0, 1.2]
          clearance: 0.01                # the beam's radius with a margin
        self_collision: {min_distance: 0.01}   # or: true; false turns the default check off
        workcell:                        # obstacles, base frame (pincal.planning.constraints.workcell)
          min_distance: 0.02
          obstacles: [{name: table, box: [1.2, 0.8, 0.05], xyz: [1.6, 0, 0.5]}]
        min_spacing: {distance_deg: 10}

    Raises:
        BadConstraint: the file is missing, not YAML, or holds an unknown key or a bad value.
    """
    path = Path(path)
    data = read_yaml(path, "constraints", BadConstraint)
    try:
        return constraints_from_dict(data, path.parent)
    except BadConstraint as exc:
        raise BadConstraint(f"constraints file {str(path)!r}: {exc}") from None
