"""What the workcell imposes on measurement configurations (SPEC §5).

Each constraint is a small frozen value object; a design keeps every configuration it returns
inside all of them. Lengths are in metres, in the instrument's frame (the robot's base frame unless
the robot has a base placement); angles in radians. :func:`load_constraints` reads them from YAML
(degrees allowed there, with ``_deg`` keys).

* :class:`JointLimits` — the URDF limits shrunk by a margin (always applied, margin 0 by default).
* :class:`WorkspaceBox` — every marker inside an axis-aligned box.
* :class:`HalfSpace` — every marker on one side of a plane (``normal · p ≥ offset``).
* :class:`Visibility` — a laser tracker at a known position sees every marker: distance within
  [min_range, max_range] and, if the marker's normal is given, the angle between that normal and
  the line of sight at most ``max_angle``.
* :class:`SelfCollision` — no two links of the chain closer than ``min_distance`` (the URDF's
  collision geometry through Pinocchio and coal; pairs of adjacent links are not checked).
* :class:`MinSpacing` — any two configurations of a plan at least ``distance`` apart in joint space
  (Euclidean norm of the joint differences [rad]).

Inside the continuous search the constraints act as a barrier: a truncated logarithmic barrier
that is zero farther than :attr:`reach` from the boundary (5 cm, 0.05 rad, 2 cm for collisions)
and infinite on it, so that every iterate stays feasible; every plan returned is checked exactly.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.errors import BadConstraint, Infeasible
from pincal.files import read_yaml
from pincal.model.robot import LIMIT_TOLERANCE, Robot

TOLERANCE = 1e-9
"""Slack [m or rad] allowed when checking a constraint exactly (rounding)."""


def _vector(value: object, what: str, size: int = 3) -> tuple[float, ...]:
    try:
        arr = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise BadConstraint(f"{what} must be {size} numbers, got {value!r}") from None
    if arr.size != size or not np.all(np.isfinite(arr)):
        raise BadConstraint(f"{what} must be {size} finite numbers, got {value!r}")
    return tuple(float(v) for v in arr)


def _number(value: object, what: str, low: float = -math.inf, strict: bool = False) -> float:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise BadConstraint(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < low or (strict and v == low):
        bound = f"{'>' if strict else '≥'} {low:g}"
        raise BadConstraint(f"{what} must be a finite number {bound}, got {value!r}")
    return v


class Kinematics:
    """Tip poses and marker positions of a batch of configurations, in the instrument frame.

    Attributes:
        qs: (m, nq) configurations.
        rotations: (m, 3, 3) tip orientations.
        positions: (m, 3) tip positions [m].
        points: (m, K, 3) marker positions [m].
    """

    def __init__(self, robot: Robot, qs: np.ndarray, data: pin.Data | None = None) -> None:
        self.qs = qs
        self.rotations, self.positions = robot.tip_poses(qs, check=False, data=data)
        self.points = self.positions[:, None, :] + np.einsum("mij,kj->mki", self.rotations, robot.markers)


class _Bound:
    """A per-configuration constraint bound to a robot (may hold Pinocchio/coal data)."""

    reach: float = 0.05
    """Distance from the boundary [m or rad] within which the search's barrier acts."""

    def margins(self, kin: Kinematics) -> np.ndarray:
        """(m, c) signed margins [m or rad]: ≥ 0 where satisfied (smooth where possible)."""
        raise NotImplementedError

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        """(m,) True where the configuration satisfies the constraint exactly."""
        return np.all(self.margins(kin) >= -TOLERANCE, axis=1)


class Constraint:
    """Base of the per-configuration constraints."""

    key: str = ""

    def bind(self, robot: Robot) -> _Bound:  # pragma: no cover - abstract
        raise NotImplementedError

    def satisfied(self, robot: Robot, q: object) -> np.ndarray:
        """(m,) True where configuration i of ``q`` (validated) satisfies this constraint."""
        qs = robot.configurations(q)
        return self.bind(robot).satisfied(Kinematics(robot, qs))


@dataclass(frozen=True)
class JointLimits(Constraint):
    """Keep ``margin`` away from every joint limit.

    Attributes:
        margin: distance kept from each limit [rad, or m for a prismatic joint].
    """

    margin: float = 0.0
    key = "joint_limits"

    def __post_init__(self) -> None:
        object.__setattr__(self, "margin", _number(self.margin, "joint_limits margin", 0.0))

    def bind(self, robot: Robot) -> _Bound:
        return _LimitsBound(robot, self.margin)


class _LimitsBound(_Bound):
    def __init__(self, robot: Robot, margin: float) -> None:
        self.lower = robot.model.lowerPositionLimit + margin
        self.upper = robot.model.upperPositionLimit - margin
        if np.any(self.upper < self.lower):
            j = int(np.argmax(self.lower - self.upper))
            raise Infeasible(
                f"joint limit margin {margin:g} leaves no room between the limits of joint "
                f"{robot.joint_names[j]}"
            )

    def margins(self, kin: Kinematics) -> np.ndarray:
        return np.minimum(kin.qs - self.lower, self.upper - kin.qs)

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        return np.all(self.margins(kin) >= -LIMIT_TOLERANCE, axis=1)


@dataclass(frozen=True)
class WorkspaceBox(Constraint):
    """Every marker inside the box ``lower ≤ p ≤ upper`` (instrument frame).

    Attributes:
        lower: (x, y, z) lower corner [m].
        upper: (x, y, z) upper corner [m].
    """

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]
    key = "workspace_box"

    def __post_init__(self) -> None:
        lower = _vector(self.lower, "workspace_box lower")
        upper = _vector(self.upper, "workspace_box upper")
        if any(lo >= hi for lo, hi in zip(lower, upper, strict=True)):
            raise BadConstraint(f"workspace_box: lower {lower} must be below upper {upper} on every axis")
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)

    def bind(self, robot: Robot) -> _Bound:
        return _BoxBound(np.array(self.lower), np.array(self.upper))


class _BoxBound(_Bound):
    def __init__(self, lower: np.ndarray, upper: np.ndarray) -> None:
        self.lower, self.upper = lower, upper

    def margins(self, kin: Kinematics) -> np.ndarray:
        p = kin.points
        return np.concatenate([p - self.lower, self.upper - p], axis=1).reshape(len(p), -1)


@dataclass(frozen=True)
class HalfSpace(Constraint):
    """Every marker on the side of a plane where ``normal · p ≥ offset`` (instrument frame).

    Example: ``HalfSpace((0, 0, 1), 0.3)`` keeps the markers at least 0.3 m above z = 0.

    Attributes:
        normal: (3,) plane normal, pointing to the allowed side (normalised on construction).
        offset: signed distance of the plane from the origin along ``normal`` [m].
    """

    normal: tuple[float, float, float]
    offset: float = 0.0
    key = "half_space"

    def __post_init__(self) -> None:
        n = np.array(_vector(self.normal, "half_space normal"))
        if np.linalg.norm(n) < 1e-12:
            raise BadConstraint("half_space normal must not be zero")
        object.__setattr__(self, "normal", tuple(float(v) for v in n / np.linalg.norm(n)))
        object.__setattr__(self, "offset", _number(self.offset, "half_space offset"))

    def bind(self, robot: Robot) -> _Bound:
        return _HalfSpaceBound(np.array(self.normal), self.offset)


class _HalfSpaceBound(_Bound):
    def __init__(self, normal: np.ndarray, offset: float) -> None:
        self.normal, self.offset = normal, offset

    def margins(self, kin: Kinematics) -> np.ndarray:
        return kin.points @ self.normal - self.offset


@dataclass(frozen=True)
class Visibility(Constraint):
    """A laser tracker at ``tracker`` sees every marker.

    Attributes:
        tracker: (x, y, z) position of the instrument [m] (instrument frame).
        max_range: largest tracker-to-marker distance [m].
        min_range: smallest tracker-to-marker distance [m] (default 0).
        normal: the marker's normal in the tip frame (one (x, y, z) for all markers, or one per
            marker); needed for ``max_angle``.
        max_angle: largest angle between the marker normal and the line of sight from the marker
            to the tracker [rad] (None: no incidence limit).
    """

    tracker: tuple[float, float, float]
    max_range: float = math.inf
    min_range: float = 0.0
    normal: tuple | None = None
    max_angle: float | None = None
    key = "visibility"

    def __post_init__(self) -> None:
        object.__setattr__(self, "tracker", _vector(self.tracker, "visibility tracker"))
        max_range = math.inf if self.max_range is None else self.max_range
        if max_range != math.inf:
            max_range = _number(max_range, "visibility max_range", 0.0, strict=True)
        object.__setattr__(self, "max_range", float(max_range))
        object.__setattr__(self, "min_range", _number(self.min_range, "visibility min_range", 0.0))
        if self.min_range >= self.max_range:
            raise BadConstraint(
                f"visibility: min_range {self.min_range:g} must be below max_range {self.max_range:g}"
            )
        if self.normal is not None:
            try:
                n = np.array(self.normal, dtype=float).reshape(-1, 3)
            except (TypeError, ValueError):
                raise BadConstraint(
                    f"visibility normal must be (x, y, z) triples, got {self.normal!r}"
                ) from None
            norms = np.linalg.norm(n, axis=1)
            if not np.all(np.isfinite(n)) or np.any(norms < 1e-12):
                raise BadConstraint(f"visibility normal must be finite and non-zero, got {self.normal!r}")
            object.__setattr__(self, "normal", tuple(map(tuple, (n / norms[:, None]).tolist())))
        if self.max_angle is not None:
            angle = _number(self.max_angle, "visibility max_angle [rad]", 0.0, strict=True)
            if angle > math.pi:
                raise BadConstraint(f"visibility max_angle must be at most pi radians, got {angle:g}")
            if self.normal is None:
                raise BadConstraint("visibility max_angle needs the marker normal (in the tip frame)")
            object.__setattr__(self, "max_angle", angle)

    def bind(self, robot: Robot) -> _Bound:
        normals = None
        if self.normal is not None:
            normals = np.array(self.normal)
            if len(normals) not in (1, robot.n_markers):
                raise BadConstraint(
                    f"visibility: {len(normals)} marker normals for {robot.n_markers} markers "
                    f"(give one for all, or one per marker)"
                )
            normals = np.broadcast_to(normals, (robot.n_markers, 3))
        return _VisibilityBound(self, normals)


class _VisibilityBound(_Bound):
    def __init__(self, spec: Visibility, normals: np.ndarray | None) -> None:
        self.tracker = np.array(spec.tracker)
        self.spec = spec
        self.normals = normals

    def margins(self, kin: Kinematics) -> np.ndarray:
        s = self.spec
        sight = self.tracker - kin.points  # (m, K, 3) marker -> tracker
        dist = np.linalg.norm(sight, axis=2)
        out = [dist - s.min_range]
        if np.isfinite(s.max_range):
            out.append(s.max_range - dist)
        if s.max_angle is not None:
            n_world = np.einsum("mij,kj->mki", kin.rotations, self.normals)
            cos = np.einsum("mki,mki->mk", n_world, sight) / np.maximum(dist, 1e-12)
            out.append(s.max_angle - np.arccos(np.clip(cos, -1.0, 1.0)))
        return np.concatenate(out, axis=1)


@dataclass(frozen=True)
class SelfCollision(Constraint):
    """No two non-adjacent links of the chain closer than ``min_distance``.

    Uses the URDF's ``<collision>`` geometry (Pinocchio + coal). Pairs of geometries on the same
    link or on two links joined by one joint are not checked. The exact test (coal collision with
    a security margin) decides feasibility; the continuous search steers by the distances between
    the geometries' convex hulls, which never exceed the true distances.

    Attributes:
        min_distance: clearance kept between links [m] (0: only no contact).
        package_dirs: directories searched for ``package://`` mesh paths (the URDF's ancestors
            are searched too).
    """

    min_distance: float = 0.0
    package_dirs: tuple[str, ...] = ()
    key = "self_collision"

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "min_distance", _number(self.min_distance, "self_collision min_distance", 0.0)
        )
        object.__setattr__(self, "package_dirs", tuple(str(p) for p in self.package_dirs))

    def bind(self, robot: Robot) -> _Bound:
        return _CollisionBound(robot, self)


def _package_dirs(urdf: Path, extra: Iterable[str]) -> list[str]:
    """Directories that resolve the ``package://NAME/...`` paths of ``urdf``."""
    dirs = [str(p) for p in extra]
    names = set(re.findall(r"package://([^/\"']+)/", urdf.read_text(errors="replace")))
    for name in names:
        for parent in urdf.resolve().parents:
            if (parent / name).is_dir():
                dirs.append(str(parent))
                break
    return dirs + [str(urdf.parent)]


class _CollisionBound(_Bound):
    reach = 0.02

    def __init__(self, robot: Robot, spec: SelfCollision) -> None:
        import coal

        if robot.urdf_path is None:
            raise BadConstraint(
                "self_collision needs the robot's URDF (load the robot from a URDF file or name)"
            )
        urdf = Path(robot.urdf_path)
        model = robot.model
        try:
            geom = pin.buildGeomFromUrdf(
                model, str(urdf), pin.COLLISION, package_dirs=_package_dirs(urdf, spec.package_dirs)
            )
        except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with long texts
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise BadConstraint(
                f"self_collision: cannot read the collision geometry of {str(urdf)!r}: {first}"
            ) from None
        objects = geom.geometryObjects
        pairs = []
        for a in range(len(objects)):
            for b in range(a + 1, len(objects)):
                ja, jb = objects[a].parentJoint, objects[b].parentJoint
                if ja == jb or model.parents[ja] == jb or model.parents[jb] == ja:
                    continue
                pairs.append((a, b))
        if not pairs:
            raise BadConstraint(
                f"self_collision: the URDF {urdf.name} has no collision geometry on non-adjacent links"
            )
        for a, b in pairs:
            geom.addCollisionPair(pin.CollisionPair(a, b))
        self.names = [(objects[a].name, objects[b].name) for a, b in pairs]
        self.model, self.data = model, model.createData()
        self.offsets = robot.joint_offsets
        self.exact, self.exact_data = geom, geom.createData()
        for request in self.exact_data.collisionRequests:
            request.security_margin = spec.min_distance
        # Convex hulls: fast, smooth distances that never exceed the true ones.
        hulls = pin.GeometryModel()
        for obj in objects:
            obj = obj.copy()
            if isinstance(obj.geometry, coal.BVHModelBase):
                obj.geometry.buildConvexHull(True, "Qt")  # qhull: the true hull of the mesh
                obj.geometry = obj.geometry.convex
            hulls.addGeometryObject(obj)
        for a, b in pairs:
            hulls.addCollisionPair(pin.CollisionPair(a, b))
        self.hulls, self.hull_data = hulls, hulls.createData()
        self.min_distance = spec.min_distance

    def margins(self, kin: Kinematics) -> np.ndarray:
        out = np.empty((len(kin.qs), len(self.names)))
        for i, q in enumerate(kin.qs + self.offsets):
            pin.updateGeometryPlacements(self.model, self.data, self.hulls, self.hull_data, q)
            pin.computeDistances(self.hulls, self.hull_data)
            out[i] = [r.min_distance for r in self.hull_data.distanceResults]
        return out - self.min_distance

    def satisfied(self, kin: Kinematics) -> np.ndarray:
        model, data, geom, gdata = self.model, self.data, self.exact, self.exact_data
        return np.array(
            [not pin.computeCollisions(model, data, geom, gdata, q, True) for q in kin.qs + self.offsets],
            dtype=bool,
        )

    def colliding_pairs(self, q: np.ndarray) -> list[tuple[str, str]]:
        """Names of the geometry pairs in collision at one configuration."""
        pin.computeCollisions(self.model, self.data, self.exact, self.exact_data, q + self.offsets, False)
        results = self.exact_data.collisionResults
        return [n for n, r in zip(self.names, results, strict=True) if r.isCollision()]


@dataclass(frozen=True)
class MinSpacing:
    """Any two configurations of a plan at least ``distance`` apart (Euclidean norm [rad or m]).

    Attributes:
        distance: smallest allowed ‖qᵢ − qⱼ‖ between configurations [rad, or m for prismatic joints].
    """

    distance: float
    key = "min_spacing"
    reach = 0.05

    def __post_init__(self) -> None:
        object.__setattr__(self, "distance", _number(self.distance, "min_spacing distance", 0.0))

    def margins(self, qs: np.ndarray) -> np.ndarray:
        """(m(m−1)/2,) ‖qᵢ − qⱼ‖ − distance over pairs i < j [rad]."""
        i, j = np.triu_indices(len(qs), 1)
        return np.linalg.norm(qs[i] - qs[j], axis=1) - self.distance

    def satisfied(self, robot: Robot, q: object) -> np.ndarray:
        """(m,) False for configuration j when it is too close to an earlier one."""
        qs = robot.configurations(q)
        i, j = np.triu_indices(len(qs), 1)
        bad = np.linalg.norm(qs[i] - qs[j], axis=1) < self.distance - TOLERANCE
        out = np.ones(len(qs), dtype=bool)
        out[j[bad]] = False
        return out


AnyConstraint = Constraint | MinSpacing


# ----------------------------------------------------------------------------------- YAML
_KEYS = ("joint_limits", "workspace_box", "half_space", "visibility", "self_collision", "min_spacing")


def _angle(entry: dict, key: str, what: str, default: float | None) -> float | None:
    """An angle given as ``key`` [rad] or ``key_deg`` [deg]."""
    if key in entry and f"{key}_deg" in entry:
        raise BadConstraint(f"{what}: give {key} (radians) or {key}_deg (degrees), not both")
    if f"{key}_deg" in entry:
        return math.radians(_number(entry[f"{key}_deg"], f"{what} {key}_deg"))
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


def constraints_from_dict(data: dict) -> tuple[AnyConstraint, ...]:
    """Constraints from a mapping with the layout of the YAML file (see :func:`load_constraints`)."""
    if data is None:
        return ()
    if not isinstance(data, dict):
        raise BadConstraint(f"constraints must be a mapping with keys {', '.join(_KEYS)}")
    unknown = [k for k in data if k not in _KEYS]
    if unknown:
        raise BadConstraint(f"unknown constraint {unknown[0]!r}; valid: {', '.join(_KEYS)}")
    out: list[AnyConstraint] = []
    if "joint_limits" in data:
        e = _check_keys(data["joint_limits"], "joint_limits", ("margin", "margin_deg"))
        out.append(JointLimits(_angle(e, "margin", "joint_limits", 0.0)))
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
    if "self_collision" in data and data["self_collision"] is not False:
        e = _check_keys(data["self_collision"], "self_collision", ("min_distance", "package_dirs"))
        out.append(SelfCollision(e.get("min_distance", 0.0), tuple(e.get("package_dirs", ()))))
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

        joint_limits: {margin_deg: 5}
        workspace_box: {lower: [0.5, -1.5, 0.2], upper: [2.8, 1.5, 2.2]}
        half_space:                      # one mapping or a list; keeps normal·p >= offset
          - {normal: [0, 0, 1], offset: 0.3}
        visibility:                      # one mapping or a list
          tracker: [4.0, 0.0, 1.2]
          max_range: 6.0
          min_range: 1.0
          normal: [0, 0, 1]              # marker normal in the tip frame
          max_angle_deg: 60
        self_collision: {min_distance: 0.01}   # or: self_collision: true
        min_spacing: {distance_deg: 10}

    Raises:
        BadConstraint: the file is missing, not YAML, or holds an unknown key or a bad value.
    """
    path = Path(path)
    data = read_yaml(path, "constraints", BadConstraint)
    try:
        return constraints_from_dict(data)
    except BadConstraint as exc:
        raise BadConstraint(f"constraints file {str(path)!r}: {exc}") from None


def satisfied(robot: Robot, plan: object, constraints: Iterable[AnyConstraint] = ()) -> np.ndarray:
    """(m,) True where a configuration of ``plan`` satisfies every constraint (and the joint
    limits); a configuration too close to an earlier one (MinSpacing) is marked False."""
    qs = robot.configurations(plan)
    ok = np.ones(len(qs), dtype=bool)
    for c in constraints:
        ok &= c.satisfied(robot, qs)
    return ok


def spacing_of(constraints: Iterable[AnyConstraint]) -> float:
    """The largest MinSpacing distance among ``constraints`` (0 if none)."""
    return max((c.distance for c in constraints if isinstance(c, MinSpacing)), default=0.0)


def limit_margin_of(constraints: Iterable[AnyConstraint]) -> float:
    """The largest JointLimits margin among ``constraints`` (0 if none)."""
    return max((c.margin for c in constraints if isinstance(c, JointLimits)), default=0.0)
