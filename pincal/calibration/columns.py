"""The columns of a measurement file for every measurement kind but points (which
:mod:`pincal.calibration.measurements` reads as it always has): which kind a header holds, its
values, their uncertainties and covariances (docs/method.md §13).

Measured columns (K markers: no suffix for one marker, the marker's index for several, ``x0``):

* pose: ``x,y,z`` and the orientation as ``qx,qy,qz,qw`` (a unit quaternion, scalar last, as
  scipy's ``Rotation.as_quat`` and ROS messages) or ``rx,ry,rz`` (a rotation vector [rad]), of
  each marker's frame in the instrument's frame;
* partial: any other subset of ``x,y,z,rx,ry,rz`` per marker (``z``; ``x,y``; ``z0,x1,y1``);
* distance: ``d`` (one), or ``d0,d1,...`` from marker 0 to the anchors ``anchor0``, ``anchor1``, ...;
* image: ``u0,v0,u1,v1,...``, the pixels of the target's points in their order; a point not seen
  in a row is left empty. The camera's intrinsics and the target's points are not in the file:
  image data are read with their kind (``kind=Image(...)``, ``--camera RIG.yaml``).

Uncertainties (optional, in the unit of their column): ``s<column>`` for one value (``sx``, ``srz``,
``sd0``, ``su3``), or ``s`` for every length, ``srot`` for every angle, ``spx`` for every pixel;
covariances between two values of a row: ``cov_<a>_<b>`` (``cov_x_y``; absent pairs are 0). With
quaternion columns the orientation's uncertainties are those of its rotation vector.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

from pincal.arguments import MAX_ANGLE, MAX_LENGTH, SIGMA_RANGE
from pincal.errors import BadMeasurementData
from pincal.instruments.distance import Distance
from pincal.instruments.kind import POSE_COMPONENTS, Kind
from pincal.instruments.point import Point
from pincal.instruments.pose import Partial, Pose
from pincal.model.robot import Robot

_POSE = re.compile(r"^(x|y|z|rx|ry|rz|qx|qy|qz|qw)(\d*)$")
_DISTANCE = re.compile(r"^d(\d*)$")
_PIXEL = re.compile(r"^[uv]\d+$")
QUATERNION = ("qx", "qy", "qz", "qw")


def is_measured(name: str) -> bool:
    """A column that holds a measured value of some kind."""
    return bool(_POSE.match(name) or _DISTANCE.match(name) or _PIXEL.match(name))


def is_uncertainty(name: str) -> bool:
    """A column that holds an uncertainty or a covariance (``s``, ``srot``, ``spx``, ``s<column>``,
    ``cov_<a>_<b>``)."""
    return (
        name in ("s", "srot", "spx") or name.startswith("cov_") or (name[:1] == "s" and is_measured(name[1:]))
    )


def may_be_empty(name: str) -> bool:
    """Cells a file may leave empty: an image's pixels (a point not seen)."""
    return bool(_PIXEL.match(name))


def kind_of(measured: list[str], robot: Robot, given: Kind | None, where: str) -> Kind:
    """The kind the measured columns hold (``given``, when given, is checked against them).

    Raises:
        BadMeasurementData: columns no kind has, or not the given kind's.
    """
    if given is not None:
        expected = set(given.coordinates(robot))
        alternative = set(_with_quaternions(given, robot)) if isinstance(given, Pose) else expected
        if set(measured) not in (expected, alternative):
            raise BadMeasurementData(
                f"{where}: {given.describe()} measurements need the columns "
                f"{','.join(given.coordinates(robot))}, got {','.join(measured) or 'none'}"
            )
        return given
    if any(_PIXEL.match(c) for c in measured):
        raise BadMeasurementData(
            f"{where}: image columns (u0,v0,...) need the camera and its target: give --camera RIG.yaml "
            f"(kind=pincal.instruments.Image(...))"
        )
    distances = [c for c in measured if _DISTANCE.match(c)]
    if distances:
        return _distance_kind(distances, measured, where)
    return _pose_kind(measured, robot.n_markers, where)


def _groups(pattern: re.Pattern[str], column: str) -> tuple[str, ...]:
    """The groups of a measured ``column`` that kind_of sorted into ``pattern``'s kind."""
    match = pattern.match(column)
    assert match is not None  # kind_of only passes columns of this pattern
    return match.groups()


def _distance_kind(distances: list[str], measured: list[str], where: str) -> Kind:
    if len(distances) != len(measured) or (len(distances) > 1 and "d" in distances):
        raise BadMeasurementData(
            f"{where}: distance columns are d (one) or d0,d1,... alone, got {','.join(measured)}"
        )
    if distances == ["d"]:
        return Distance()
    indices = sorted(int(_groups(_DISTANCE, c)[0]) for c in distances)
    if indices != list(range(len(indices))):
        raise BadMeasurementData(f"{where}: distance columns must be d0,d1,...,d{len(indices) - 1}")
    return Distance.to_anchors(len(indices))


def _pose_kind(measured: list[str], K: int, where: str) -> Kind:
    per_marker: dict[int, set[str]] = {}
    for c in measured:
        name, index = _groups(_POSE, c)
        if (index == "") != (K == 1):
            raise BadMeasurementData(
                f"{where}: column {c}: with {K} marker(s) the measured columns are "
                + ("x,y,z,... without an index" if K == 1 else "x0,y0,z0,... with the marker's index")
            )
        per_marker.setdefault(int(index or 0), set()).add(name)
    if sorted(per_marker) != list(range(K)):
        raise BadMeasurementData(f"{where}: every one of the {K} marker(s) needs measured columns")
    masks = []
    for k in range(K):
        names = per_marker[k]
        quaternion = names & set(QUATERNION)
        if quaternion and (
            quaternion != set(QUATERNION) or names & {"rx", "ry", "rz"} or not {"x", "y", "z"} <= names
        ):
            raise BadMeasurementData(
                f"{where}: a quaternion is qx,qy,qz,qw beside x,y,z (no rx,ry,rz); marker {k} has "
                f"{','.join(sorted(names))}"
            )
        masks.append(tuple(c for c in POSE_COMPONENTS if c in names or (quaternion and c.startswith("r"))))
    if all(m == ("x", "y", "z") for m in masks):
        return Point()
    if all(m == POSE_COMPONENTS for m in masks):
        return Pose()
    return Partial(tuple(masks))


def _with_quaternions(kind: Kind, robot: Robot) -> tuple[str, ...]:
    K = robot.n_markers
    suffix = [str(k) if K > 1 else "" for k in range(K)]
    return tuple(c + s for s in suffix for c in ("x", "y", "z") + QUATERNION)


MAX_PIXELS = 1e6
"""The largest pixel coordinate (and pixel uncertainty) a measurement file may hold [px]: no image
is a million pixels across."""


def check_magnitudes(
    kind: Kind,
    robot: Robot,
    header: list[str],
    rows: np.ndarray,
    where: str,
    lines: np.ndarray,
    millimetres: bool,
) -> None:
    """Refuse a value no instrument gives, naming its column and line, before any arithmetic on it
    (1e308 overflowed in the whitening): a length beyond :data:`~pincal.arguments.MAX_LENGTH`, an
    angle beyond :data:`~pincal.arguments.MAX_ANGLE`, a pixel beyond :data:`MAX_PIXELS`, a
    quaternion component beyond 1e6; an uncertainty outside :data:`~pincal.arguments.SIGMA_RANGE`
    (in its column's unit: m, rad, px; zero and negative ones are refused later, as they always
    were), a covariance beyond the product of the largest uncertainties."""
    names, units = kind.coordinates(robot), kind.units(robot)
    unit_of = dict(zip(names, units))
    written = {"m": 1e3 if millimetres else 1.0, "rad": 1.0, "px": 1.0, "": 1.0}  # unit as written
    limits = {"m": MAX_LENGTH, "rad": MAX_ANGLE, "px": MAX_PIXELS, "": 1e6}
    shown = {"m": "mm" if millimetres else "m", "rad": "rad", "px": "px", "": ""}
    shared = {"s": "m", "srot": "rad", "spx": "px"}
    low, high = SIGMA_RANGE
    for i, column in enumerate(header):
        values = rows[:, i]
        if column in unit_of or column.rstrip("0123456789") in QUATERNION:
            unit = unit_of.get(column, "")
            _refuse_outside(values, 0.0, limits[unit] * written[unit], shown[unit], where, column, lines)
        elif column in shared or (column[:1] == "s" and column[1:] in unit_of):
            unit = shared.get(column) or unit_of[column[1:]]
            _refuse_outside(
                values, low * written[unit], high * written[unit], shown[unit], where, column, lines
            )
        elif column.startswith("cov_") and all(p in unit_of for p in column[4:].split("_")[:2]):
            first, second = (unit_of[p] for p in column[4:].split("_")[:2])
            limit = high * written[first] * high * written[second]
            _refuse_outside(values, 0.0, limit, f"{shown[first]}·{shown[second]}", where, column, lines)


def _refuse_outside(
    values: np.ndarray, low: float, high: float, unit: str, where: str, column: str, lines: np.ndarray
) -> None:
    """Refuse the first of ``values`` whose size is beyond ``high`` or, non-zero, below ``low``
    [``unit``]; NaN (an empty cell) passes."""
    size = np.abs(values)
    outside = np.flatnonzero(~np.isnan(values) & ((size > high) | ((size > 0) & (size < low))))
    if outside.size:
        row = int(outside[0])
        bounds = f"from {low:g} to {high:g} {unit}" if low else f"up to {high:g} {unit}"
        raise BadMeasurementData(
            f"{where}, line {lines[row]}: column {column} = {values[row]:.3g} {unit}".rstrip()
            + f": pincal accepts {bounds.rstrip()} (a unit or number error?)"
        )


def values_of(
    kind: Kind, robot: Robot, header: list[str], rows: np.ndarray, where: str, lines: np.ndarray
) -> np.ndarray:
    """(m, r) the measured values, orientations from quaternions turned into rotation vectors."""
    names = kind.coordinates(robot)
    if all(n in header for n in names):
        return rows[:, [header.index(n) for n in names]]
    out = np.empty((len(rows), len(names)))
    K = robot.n_markers
    for k in range(K):
        s = str(k) if K > 1 else ""
        out[:, 6 * k : 6 * k + 3] = rows[:, [header.index(c + s) for c in ("x", "y", "z")]]
        quaternions = rows[:, [header.index(c + s) for c in QUATERNION]]
        norms = np.linalg.norm(quaternions, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1) > 1e-3)
        if bad.size:
            raise BadMeasurementData(
                f"{where}, line {lines[bad[0]]}: the quaternion qx,qy,qz,qw has norm {norms[bad[0]]:.6g}, "
                f"not 1 (scalar last: qw is the cosine of half the angle)"
            )
        for i, q in enumerate(quaternions / norms[:, None]):
            out[i, 6 * k + 3 : 6 * k + 6] = pin.log3(
                pin.Quaternion(q[3], q[0], q[1], q[2]).toRotationMatrix()
            )
    return out


def unit_scale(units: tuple[str, ...], millimetres: bool) -> np.ndarray:
    """(r,) the factor that turns values of these units as written into metres, radians, pixels."""
    return np.array([1e-3 if millimetres and u == "m" else 1.0 for u in units])


def uncertainties(
    kind: Kind,
    robot: Robot,
    header: list[str],
    rows: np.ndarray,
    where: str,
    lines: np.ndarray | None = None,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """((m, r) standard deviations or None, (m, r, r) covariances or None), as written; ``lines``
    the rows' line numbers, for messages."""
    names, units = kind.coordinates(robot), kind.units(robot)
    columns = [h for h in header if is_uncertainty(h)]
    if not columns:
        return None, None
    std = np.full((len(rows), len(names)), np.nan)
    shared = {"m": "s", "rad": "srot", "px": "spx"}
    for i, (name, unit) in enumerate(zip(names, units)):
        for column in (f"s{name}", shared[unit]):
            if column in header:
                std[:, i] = rows[:, header.index(column)]
                break
    covariances = [c for c in columns if c.startswith("cov_")]
    known = {f"s{n}" for n in names} | set(shared.values()) | set(covariances)
    unknown = [c for c in columns if c not in known]
    if unknown:
        raise BadMeasurementData(
            f"{where}: uncertainty column(s) {','.join(unknown)} name no measured value; valid: s<column> "
            f"({', '.join('s' + n for n in names[:3])}, ...), s, srot, spx, cov_<a>_<b>"
        )
    if np.isnan(std).any():
        missing = names[int(np.argwhere(np.isnan(std[0]))[0][0])] if np.isnan(std[0]).any() else names[0]
        raise BadMeasurementData(
            f"{where}: uncertainty columns leave {missing} without one (give s{missing})"
        )
    if not covariances:
        return std, None
    lines = np.arange(2, len(rows) + 2) if lines is None else np.asarray(lines)
    return None, _covariance(std, covariances, names, header, rows, where, lines)


def _covariance(
    std: np.ndarray,
    columns: list[str],
    names: tuple[str, ...],
    header: list[str],
    rows: np.ndarray,
    where: str,
    lines: np.ndarray,
) -> np.ndarray:
    cov = np.einsum("mi,ij->mij", std**2, np.eye(len(names)))
    given: dict[tuple[int, int], str] = {}
    for column in columns:
        pair = column[4:].split("_")
        if len(pair) != 2 or not all(p in names for p in pair) or pair[0] == pair[1]:
            raise BadMeasurementData(
                f"{where}: covariance column {column}: expected cov_<a>_<b> for two measured columns a, b "
                f"({', '.join(names)})"
            )
        a, b = names.index(pair[0]), names.index(pair[1])
        values = rows[:, header.index(column)]
        first = given.setdefault((min(a, b), max(a, b)), column)
        if first != column:  # cov_x_y and cov_y_x: one covariance, given twice
            differ = ~np.isclose(values, cov[:, a, b], rtol=1e-9, atol=0.0)
            if differ.any():
                row = int(np.flatnonzero(differ)[0])
                raise BadMeasurementData(
                    f"{where}, line {lines[row]}: {first} = {cov[row, a, b]:.6g} and {column} = "
                    f"{values[row]:.6g} differ: a covariance is symmetric (give one of the two columns)"
                )
        cov[:, a, b] = cov[:, b, a] = values
    return cov
