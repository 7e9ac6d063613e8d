"""Measurement files read and written (:meth:`MeasurementData.from_csv`, :meth:`MeasurementData.to_csv`;
the format in :mod:`pincal.calibration.measurements`' doc): the columns told apart, checked and
converted to radians and metres."""

from __future__ import annotations

import io
import os
import re
from typing import TYPE_CHECKING

import numpy as np

from pincal.calibration import columns as _columns
from pincal.errors import BadArgument, BadMeasurementData, warn
from pincal.files import column_mismatch, csv_header, read_numeric_csv
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.instruments.pose import Partial
from pincal.model.robot import Robot
from pincal.model.statics import PAYLOAD_COLUMNS, payload_columns

if TYPE_CHECKING:
    from pincal.calibration.measurements import MeasurementData

_MEASURED = re.compile(r"^([xyz])(\d*)$")
_SIGMA = re.compile(r"^s([xyz]?)(\d*)$")


def read_csv(
    cls: type[MeasurementData],
    path: str | os.PathLike,
    robot: Robot,
    degrees: bool = False,
    millimetres: bool = False,
    kind: Kind | None = None,
) -> MeasurementData:
    """:meth:`MeasurementData.from_csv` (its arguments, returns and errors are documented there)."""
    source = str(path)
    header, rows, lines = read_numeric_csv(
        path, what="measurement", error=BadMeasurementData, may_be_empty=_columns.may_be_empty
    )
    where = f"measurement file {source!r}"
    # the robot's joints first: a joint may be named like another kind's column (u0, d0, sx)
    named = set(robot.joint_names)
    others = [h for h in header if h not in named]
    loads = [h for h in others if h.startswith("payload_")]
    measured = [h for h in others if _MEASURED.match(h) or _columns.is_measured(h)]
    uncertain = [h for h in others if _SIGMA.match(h) or _columns.is_uncertainty(h)]
    joints = [h for h in header if h in named or not (h in measured or h in uncertain or h in loads)]
    check_joint_names(tuple(joints), robot.joint_names, where)
    kind = _kind_of(measured, robot, kind, where)
    q = rows[:, [header.index(n) for n in robot.joint_names]]
    if degrees:
        q = robot.to_radians(q)
    columns = [i for i, h in enumerate(header) if h not in named]
    payload = payload_columns(others, rows[:, columns], where, BadMeasurementData)
    if millimetres:
        payload = None if payload is None else payload / [1.0, 1000.0, 1000.0, 1000.0]
    if kind is None:
        data = _points_from_rows(
            cls, robot, q, (header, rows, lines), measured, uncertain, payload, millimetres, source
        )
    else:
        kind.check(robot)
        _columns.check_magnitudes(kind, robot, header, rows, where, lines, millimetres)
        values = _columns.values_of(kind, robot, header, rows, where, lines)
        std, covariance = _columns.uncertainties(kind, robot, header, rows, where, lines)
        scale = _columns.unit_scale(kind.units(robot), millimetres)
        std = None if std is None else std * scale
        covariance = None if covariance is None else covariance * np.outer(scale, scale)
        _check_positive(std, covariance, lines, where)
        data = cls(q, values * scale, robot.joint_names, tuple(lines), source, std, payload, kind, covariance)
    robot.check_limits(q, data.labels(), degrees)
    return data


def _points_from_rows(
    cls: type[MeasurementData],
    robot: Robot,
    q: np.ndarray,
    table: tuple[list[str], np.ndarray, np.ndarray],
    measured: list[str],
    uncertain: list[str],
    payload: np.ndarray | None,
    millimetres: bool,
    source: str,
) -> MeasurementData:
    """:meth:`from_csv` of points: x,y,z columns (x0,y0,z0,... for several markers), from the
    file's (header, rows, line numbers)."""
    header, rows, lines = table
    where = f"measurement file {source!r}"
    others = [c for c in uncertain if not _SIGMA.match(c)]
    if others:
        raise BadMeasurementData(
            f"{where}: column(s) {','.join(others)} are not uncertainties of points "
            f"(s, sx,sy,sz, s0, sx0, ...)"
        )
    columns = _measured_columns(measured, where)
    K = len(columns) // 3
    points = rows[:, [header.index(c) for c in columns]].reshape(len(rows), K, 3)
    sigma = _sigma_columns(header, rows, uncertain, K, where)
    if millimetres:
        points = points / 1000.0
        sigma = None if sigma is None else sigma / 1000.0
    check_markers(K, robot, where)
    if sigma is not None and not np.all(sigma > 0):
        row = int(np.argwhere(~(sigma > 0))[0][0])
        raise BadMeasurementData(f"{where}, line {lines[row]}: the uncertainty s must be positive")
    return cls(q, points, robot.joint_names, tuple(lines), source, sigma, payload)


def csv_text(
    data: MeasurementData, *, degrees: bool = False, millimetres: bool = False, robot: Robot | None = None
) -> str:
    """:meth:`MeasurementData.to_csv_text` of ``data`` (documented there)."""
    q = np.array(data.q)
    if degrees:
        if robot is None:
            raise BadArgument(
                "writing measurements in degrees needs the robot (robot=), to leave its prismatic "
                "joints in metres",
                argument="degrees",
            )
        q = robot.to_degrees(q)
    if data.is_points:
        coords, values = _point_columns(data, millimetres)
    else:
        assert data.kind is not None  # not points: another kind
        if robot is None:
            raise BadArgument(
                f"writing {data.kind.describe()} data needs the robot (robot=)", argument="robot"
            )
        coords, values = _kind_columns(data, robot, millimetres)
    values.insert(0, q)
    if data.payload is not None:
        coords += list(PAYLOAD_COLUMNS)
        values.append(data.payload * ([1.0, 1000.0, 1000.0, 1000.0] if millimetres else 1.0))
    clash = sorted(set(data.joint_names) & set(coords))
    if clash:
        raise BadMeasurementData(
            f"joint {clash[0]!r} has the name of a measured column ({','.join(coords)}): a "
            f"measurement file could not tell them apart; rename the joint (<joint name=> in the URDF)"
        )
    out = io.StringIO()
    out.write(csv_header(list(data.joint_names) + coords))
    for row in np.hstack(values):
        out.write(",".join("" if np.isnan(v) else repr(float(v)) for v in row) + "\n")
    return out.getvalue()


def _point_columns(data: MeasurementData, millimetres: bool) -> tuple[list[str], list[np.ndarray]]:
    """(names, (m, ·) blocks) of the measured points' columns (and their σ)."""
    points = data.points * (1000.0 if millimetres else 1.0)
    K = data.n_markers
    coords = ["x", "y", "z"] if K == 1 else [f"{c}{k}" for k in range(K) for c in "xyz"]
    values = [points.reshape(len(points), -1)]
    if data.sigma is not None:
        coords += ["s" + c for c in coords]
        values.append(data.sigma.reshape(len(points), -1) * (1000.0 if millimetres else 1.0))
    return coords, values


def _kind_columns(
    data: MeasurementData, robot: Robot, millimetres: bool
) -> tuple[list[str], list[np.ndarray]]:
    """(names, (m, ·) blocks) of another kind's columns: its values, their σ and covariances."""
    assert data.kind is not None  # not points: another kind
    names = list(data.kind.coordinates(robot))
    scale = 1.0 / _columns.unit_scale(data.kind.units(robot), millimetres)
    coords, values = list(names), [data.values * scale]
    spread = (
        data.sigma if data.covariance is None else np.sqrt(np.diagonal(data.covariance, axis1=1, axis2=2))
    )
    if spread is not None:
        coords += ["s" + n for n in names]
        values.append(spread * scale)
    if data.covariance is not None:
        pairs = [
            (a, b)
            for a in range(len(names))
            for b in range(a + 1, len(names))
            if data.covariance[:, a, b].any()
        ]
        coords += [f"cov_{names[a]}_{names[b]}" for a, b in pairs]
        values.append(
            np.column_stack([data.covariance[:, a, b] * scale[a] * scale[b] for a, b in pairs]).reshape(
                data.m, -1
            )
        )
    return coords, values


def check_joint_names(found: tuple[str, ...], expected: tuple[str, ...], where: str) -> None:
    mismatch = column_mismatch(expected, found)
    if mismatch:
        raise BadMeasurementData(
            f"{where}: the joint columns must be the robot's joints {','.join(expected)}{mismatch}"
            " (measured columns are x,y,z or x0,y0,z0,x1,...)"
        )


def check_markers(K: int, robot: Robot, where: str) -> None:
    if K != robot.n_markers:
        raise BadMeasurementData(
            f"{where}: {K} measured point(s) per configuration but the robot has "
            f"{robot.n_markers} marker(s); give one --marker (markers=[...]) per measured point, "
            f"in the order of the columns"
        )


def _measured_columns(measured: list[str], where: str) -> list[str]:
    """The measured column names in marker order (x0 y0 z0 x1 ...), checked complete."""
    if not measured:
        raise BadMeasurementData(
            f"{where}: no measured columns; expected x,y,z (one marker) or x0,y0,z0,x1,... (several)"
        )
    odd = [c for c in measured if not _MEASURED.match(c)]
    if odd:  # a distance, pose or image file read as points (identify --validate of another kind)
        raise BadMeasurementData(
            f"{where}: measured column(s) {','.join(odd)} are not points' (x,y,z, or x0,y0,z0,... for "
            "several markers): a file of another kind of measurement"
        )
    plain = [c for c in measured if c in ("x", "y", "z")]
    if plain:
        if sorted(measured) != ["x", "y", "z"]:
            raise BadMeasurementData(
                f"{where}: measured columns {','.join(measured)}: use x,y,z for one marker or "
                f"x0,y0,z0,x1,... for several, not a mix"
            )
        return ["x", "y", "z"]
    indices = sorted({int(_MEASURED.match(c).group(2)) for c in measured})  # type: ignore[union-attr]
    expected = [f"{c}{k}" for k in range(len(indices)) for c in "xyz"]
    if sorted(measured) != sorted(expected):
        missing = [c for c in expected if c not in measured]
        extra = [c for c in measured if c not in expected]
        raise BadMeasurementData(
            f"{where}: measured columns must be x0,y0,z0,...,x{len(indices) - 1},y{len(indices) - 1},"
            f"z{len(indices) - 1}"
            + (f"; missing {', '.join(missing)}" if missing else "")
            + (f"; unexpected {', '.join(extra)}" if extra else "")
        )
    return expected


def _sigma_columns(
    header: list[str], rows: np.ndarray, columns: list[str], K: int, where: str
) -> np.ndarray | None:
    """(m, K, 3) uncertainties from s / sx,sy,sz / s0.. / sx0,sy0,sz0.. columns, or None."""
    if not columns:
        return None
    valid = "s, or sx,sy,sz, for every marker; or s0,s1,... or sx0,sy0,sz0,... per marker"
    out = np.empty((len(rows), K, 3))
    for k in range(K):
        for c, axis in enumerate("xyz"):
            for name in (f"s{axis}{k}", f"s{k}", f"s{axis}", "s"):
                if name in columns:
                    out[:, k, c] = rows[:, header.index(name)]
                    break
            else:
                raise BadMeasurementData(
                    f"{where}: uncertainty columns {','.join(columns)} leave {axis}{k if K > 1 else ''} "
                    f"without one; valid: {valid}"
                )
    return out


def _kind_of(measured: list[str], robot: Robot, given: Kind | None, where: str) -> Kind | None:
    """The kind of a file's measured columns; None for points (read as they always were). Columns
    of x, y, z alone that do not make points for the robot's markers are a partial measurement when
    they make one (``z``; ``x,y``), else the points' own error."""
    if given is not None:
        return None if isinstance(given, Point) else _columns.kind_of(measured, robot, given, where)
    if not measured or all(_MEASURED.match(c) for c in measured):
        try:
            _measured_columns(measured, where)
            return None
        except BadMeasurementData as error:
            try:
                kind = _columns.kind_of(measured, robot, None, where)
            except BadMeasurementData:
                raise error from None
    else:
        kind = _columns.kind_of(measured, robot, None, where)
    if isinstance(kind, Partial) and all(mask == ("x", "y") for mask in kind.masks):
        # every marker's x,y and no z: a point file that lost its z column, or planar data
        warn(
            f"{where} has columns {','.join(measured)} but no z: read as partial measurements of x,y "
            f"only, z left out of the calibration; if z was measured, add its column; if not, say "
            f"so: --measure x,y (kind=Partial(('x', 'y')) in Python)"
        )
    return None if isinstance(kind, Point) else kind


def _check_positive(
    std: np.ndarray | None, covariance: np.ndarray | None, lines: np.ndarray, where: str
) -> None:
    """Refuse a non-positive uncertainty or a covariance that is not one, naming the line."""
    if std is not None and not np.all(std > 0):
        row = int(np.argwhere(~(std > 0))[0][0])
        raise BadMeasurementData(f"{where}, line {lines[row]}: an uncertainty must be positive")
    if covariance is not None:
        for i, c in enumerate(covariance):
            if np.any(np.diag(c) <= 0) or np.any(np.linalg.eigvalsh(c) <= 0):
                raise BadMeasurementData(
                    f"{where}, line {lines[i]}: the uncertainties and covariances make no covariance "
                    f"(not positive definite)"
                )
