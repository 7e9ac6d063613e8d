"""Measurements: what an instrument measured at known joint values.

A :class:`MeasurementData` holds m configurations (m, nq) [rad or m] and what was measured at
each: the K measured points, (m, K, 3) [m], expressed in the instrument's frame (or the robot base
frame when the instrument is registered to it), or the r values of another measurement kind (a
pose, part of one, distances, pixels: :mod:`pincal.instruments`), (m, r), whose columns
:mod:`pincal.calibration.columns` describes. The kind is read from the file's columns (an image's
needs its camera: ``kind=``).

CSV format (read by :meth:`MeasurementData.from_csv`, written by :meth:`MeasurementData.to_csv`):

* one header row, then one row per configuration; blank lines and lines starting with ``#`` are
  skipped; columns in any order;
* one column per chain joint, named as the URDF's joints: radians (metres for prismatic joints),
  or degrees with ``degrees=True`` (``--deg``);
* the measured coordinates: ``x,y,z`` for one marker, ``x0,y0,z0,x1,y1,z1,...`` for several
  (``x0,y0,z0`` is accepted for one), in metres, or millimetres with ``millimetres=True``
  (``--mm``); marker k is the k-th ``--marker`` of the robot;
* optionally, the instrument's standard uncertainty of each point, per coordinate: ``s`` (one
  value for x, y and z) or ``sx,sy,sz``, for every marker, or ``s0,s1,...``/``sx0,sy0,sz0,...``
  per marker; in the unit of the coordinates (metres, millimetres with ``--mm``). Identification
  weights each coordinate by 1/s²;
* optionally, the payload the robot carried at each configuration: ``payload_kg`` [kg], and its
  centre of mass in the tip frame ``payload_x,payload_y,payload_z`` (all three, in the unit of the
  coordinates; default the tip origin). It loads the joints, which matters when joint compliances
  are identified (:mod:`pincal.model.statics`); without the columns, no payload;
* a row with a missing, empty, non-numeric, NaN or infinite cell, the wrong number of cells, or a
  joint value outside the joint limits is an error naming the file and its line; nothing is
  silently dropped.

Example (kr270, one marker, radians and metres)::

    joint_a1,joint_a2,joint_a3,joint_a4,joint_a5,joint_a6,x,y,z
    0.1,-1.2,0.9,0.3,0.8,-0.4,1.7362,-0.1591,1.9021
"""

from __future__ import annotations

import io
import os
import re
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from pincal.arguments import MAX_LENGTH, SIGMA_RANGE, check_lengths
from pincal.calibration import columns as _columns
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, BadMeasurementData, warn
from pincal.files import atomic_write_text, column_mismatch, csv_header, read_numeric_csv
from pincal.instruments.image import Image
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.instruments.pose import Partial
from pincal.model.robot import Robot
from pincal.model.statics import MAX_PAYLOAD, PAYLOAD_COLUMNS, payload_columns
from pincal.typing import ArrayLike, PayloadLike

_MEASURED = re.compile(r"^([xyz])(\d*)$")
_SIGMA = re.compile(r"^s([xyz]?)(\d*)$")


@dataclass(frozen=True, eq=False)
class MeasurementData:
    """What an instrument measured at m configurations.

    Attributes:
        q: (m, nq) joint values [rad or m], read-only.
        points: (m, K, 3) measured points [m], read-only; for another ``kind``, the (m, r) values
            it measured [m, rad or px] (NaN: not measured, a target point out of view).
        joint_names: the joint of each column of ``q``.
        lines: the line of each configuration in its source file (for messages), or None.
        source: the file the data came from, or None.
        sigma: (m, K, 3) standard uncertainty of each measured coordinate [m], read-only, or None
            (the same unknown σ for all).
        payload: (m, 4) payload carried at each configuration, rows [kg, x, y, z] (centre of mass
            in the tip frame [m]), read-only, or None (no payload).
        kind: the measurement kind (:mod:`pincal.instruments`), or None: points. For another kind
            ``sigma`` is (m, r), one per value, in its unit.
        covariance: (m, r, r) the covariance of each row's values, read-only, or None (``sigma``,
            or the instrument's error model).
    """

    q: np.ndarray
    points: np.ndarray
    joint_names: tuple[str, ...]
    lines: tuple[int, ...] | None = None
    source: str | None = None
    sigma: np.ndarray | None = None
    payload: np.ndarray | None = None
    kind: Kind | None = None
    covariance: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.kind is not None and not isinstance(self.kind, Point):
            self._check_values()
            return
        if self.covariance is not None:
            raise BadMeasurementData(
                "measurements: a covariance per row is for kinds other than points (kind=)"
            )
        try:
            q = np.array(self.q, dtype=float, copy=True)
            points = np.array(self.points, dtype=float, copy=True)
        except (TypeError, ValueError):
            raise BadMeasurementData("measurements: joint values and points must be numbers") from None
        if q.ndim == 1:
            q = q[None, :]
        if points.ndim == 2 and points.shape[-1] == 3 and len(points) == len(q):
            points = points[:, None, :]
        names = tuple(self.joint_names)
        if q.ndim != 2 or q.shape[1] != len(names) or len(q) == 0:
            raise BadMeasurementData(
                f"measurements: joint values must be (m, {len(names)}) for joints {', '.join(names)}, "
                f"got shape {np.shape(self.q)}"
            )
        if points.ndim != 3 or points.shape[0] != len(q) or points.shape[2] != 3 or points.shape[1] == 0:
            raise BadMeasurementData(
                f"measurements: points must be (m, K, 3) with m = {len(q)} configurations, "
                f"got shape {np.shape(self.points)}"
            )
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(points))):
            raise BadMeasurementData("measurements: joint values and points must be finite")
        lines = None if self.lines is None else tuple(int(n) for n in self.lines)
        far = np.abs(points) > MAX_LENGTH
        if far.any():
            i = int(np.argwhere(far)[0][0])
            check_lengths(points[i], f"{self.labels_of(lines)[i]}: measured coordinate", BadMeasurementData)
        if lines is not None and len(lines) != len(q):
            raise BadMeasurementData(f"measurements: {len(lines)} line numbers for {len(q)} rows")
        sigma = None
        if self.sigma is not None:
            try:
                sigma = np.broadcast_to(np.array(self.sigma, dtype=float), points.shape).copy()
            except (TypeError, ValueError):
                raise BadMeasurementData(
                    f"measurements: sigma must be one value or one per point coordinate {points.shape}, "
                    f"got shape {np.shape(self.sigma)}"
                ) from None
            low, high = SIGMA_RANGE
            if not np.all((sigma >= low) & (sigma <= high)):
                i = int(np.argwhere(~((sigma >= low) & (sigma <= high)))[0][0])
                raise BadMeasurementData(
                    f"{self.labels_of(lines)[i]}: sigma must be from {low:g} to {high:g} m"
                )
            sigma.flags.writeable = False
        object.__setattr__(self, "sigma", sigma)
        object.__setattr__(self, "payload", _checked_payload(self.payload, len(q), self.labels_of(lines)))
        q.flags.writeable = False
        points.flags.writeable = False
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "lines", lines)

    def _check_values(self) -> None:
        """__post_init__ for a kind other than points: (m, r) values, finite or NaN where an image
        point was not seen; per-value σ or per-row covariances."""
        names = tuple(self.joint_names)
        try:
            q = np.array(self.q, dtype=float, copy=True)
            values = np.array(self.points, dtype=float, copy=True)
        except (TypeError, ValueError):
            raise BadMeasurementData(
                "measurements: joint values and measured values must be numbers"
            ) from None
        q = q[None, :] if q.ndim == 1 else q
        if (
            q.ndim != 2
            or q.shape[1] != len(names)
            or not len(q)
            or values.shape[:1] != q.shape[:1]
            or values.ndim != 2
        ):
            raise BadMeasurementData(
                f"measurements: joint values (m, {len(names)}) and measured values (m, r), got shapes "
                f"{np.shape(self.q)} and {np.shape(self.points)}"
            )
        empty = np.isnan(values)
        if (
            not np.all(np.isfinite(q))
            or np.isinf(values).any()
            or (empty.any() and not isinstance(self.kind, Image))
        ):
            raise BadMeasurementData("measurements: joint values and measured values must be finite")
        lines = None if self.lines is None else tuple(int(n) for n in self.lines)
        sigma = _checked_spread(self.sigma, values.shape, self.labels_of(lines), "sigma")
        covariance = _checked_spread(
            self.covariance, values.shape + values.shape[1:], self.labels_of(lines), "covariance"
        )
        payload = _checked_payload(self.payload, len(q), self.labels_of(lines))
        for name, value in (("q", q), ("points", values), ("sigma", sigma), ("covariance", covariance)):
            if value is not None:
                value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "lines", lines)
        object.__setattr__(self, "payload", payload)

    @property
    def measure(self) -> Kind:
        """The measurement kind (points when ``kind`` is None)."""
        return Point() if self.kind is None else self.kind

    @property
    def is_points(self) -> bool:
        """The data are points (the ``points`` array is (m, K, 3))."""
        return self.kind is None or isinstance(self.kind, Point)

    @property
    def values(self) -> np.ndarray:
        """(m, r) the measured values of each row (a view)."""
        return self.points.reshape(len(self.q), -1)

    @property
    def row_size(self) -> int:
        """r, the values measured per configuration."""
        return self.values.shape[1]

    def __len__(self) -> int:
        return len(self.q)

    @property
    def m(self) -> int:
        """Number of configurations."""
        return len(self.q)

    @property
    def n_markers(self) -> int:
        """Number of measured points K per configuration (points; 0 for another kind)."""
        return self.points.shape[1] if self.is_points else 0

    def labels(self) -> list[str]:
        """How messages name each row: the file and line, or the row index."""
        return self.labels_of(self.lines)

    def labels_of(self, lines: tuple[int, ...] | None) -> list[str]:
        if lines is not None and self.source is not None:
            return [f"measurement file {self.source!r}, line {n}" for n in lines]
        if lines is not None:  # rows of a subset: their index in the data they came from
            return [f"measurement {n}" for n in lines]
        return [f"measurement {i}" for i in range(len(self.q))]

    def subset(self, rows: ArrayLike) -> MeasurementData:
        """The data of some rows (indices or a boolean mask); their labels, lines and σ kept."""
        index = np.arange(self.m)[np.asarray(rows)]
        lines = tuple(int(i) for i in index) if self.lines is None else tuple(self.lines[i] for i in index)
        sigma = None if self.sigma is None else self.sigma[index]
        payload = None if self.payload is None else self.payload[index]
        covariance = None if self.covariance is None else self.covariance[index]
        return MeasurementData(
            self.q[index],
            self.points[index],
            self.joint_names,
            lines,
            self.source,
            sigma,
            payload,
            self.kind,
            covariance,
        )

    def for_robot(self, robot: Robot) -> MeasurementData:
        """These data with columns in ``robot``'s joint order, checked against the robot.

        Raises:
            BadMeasurementData: the joint names or the number of markers do not match (both
                listed).
            BadConfiguration: a joint value outside its limits (naming the row).
        """
        names = robot.joint_names
        _check_joint_names(self.joint_names, names, self._where())
        if self.is_points:
            _check_markers(self.n_markers, robot, self._where())
        else:
            assert self.kind is not None  # not points: another kind
            self.kind.check(robot)
            if self.row_size != self.kind.size(robot):
                raise BadMeasurementData(
                    f"{self._where()}: {self.row_size} values per configuration, but "
                    f"{self.kind.describe()} on {robot.name} measures {self.kind.size(robot)} "
                    f"({', '.join(self.kind.coordinates(robot))})"
                )
        q = self.q[:, [self.joint_names.index(n) for n in names]]
        robot.check_limits(q, self.labels(), degrees=False)
        if names == self.joint_names:
            return self
        return MeasurementData(
            q,
            self.points,
            names,
            self.lines,
            self.source,
            self.sigma,
            self.payload,
            self.kind,
            self.covariance,
        )

    def _where(self) -> str:
        return f"measurement file {self.source!r}" if self.source else "the measurements"

    # -------------------------------------------------------------------------- I/O
    @classmethod
    def from_csv(
        cls,
        path: str | os.PathLike,
        robot: Robot,
        degrees: bool = False,
        millimetres: bool = False,
        kind: Kind | None = None,
    ) -> MeasurementData:
        """Read measurements for ``robot`` from a CSV file (format: see the module doc).

        Args:
            path: the file.
            robot: the robot measured: its joint names, markers and limits (and fixtures).
            degrees: revolute joint values are in degrees (converted to radians).
            millimetres: lengths are in millimetres (converted to metres).
            kind: the measurement kind; default: read from the columns (points, poses, partial
                poses, distances); image data need theirs (:class:`pincal.instruments.Image`).

        Returns:
            the data, in the robot's joint order, values in radians and metres.

        Raises:
            BadMeasurementData: missing, empty or malformed file, columns that do not match the
                joints, markers or kind (listed), a bad row (its line is named).
            BadConfiguration: a joint value outside its limits (its line is named).
        """
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
        _check_joint_names(tuple(joints), robot.joint_names, where)
        kind = _kind_of(measured, robot, kind, where)
        q = rows[:, [header.index(n) for n in robot.joint_names]]
        if degrees:
            q = robot.to_radians(q)
        columns = [i for i, h in enumerate(header) if h not in named]
        payload = payload_columns(others, rows[:, columns], where, BadMeasurementData)
        if millimetres:
            payload = None if payload is None else payload / [1.0, 1000.0, 1000.0, 1000.0]
        if kind is None:
            data = cls._points_from_rows(
                robot, q, (header, rows, lines), measured, uncertain, payload, millimetres, source
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
            data = cls(
                q, values * scale, robot.joint_names, tuple(lines), source, std, payload, kind, covariance
            )
        robot.check_limits(q, data.labels(), degrees)
        return data

    @classmethod
    def _points_from_rows(
        cls,
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
        _check_markers(K, robot, where)
        if sigma is not None and not np.all(sigma > 0):
            row = int(np.argwhere(~(sigma > 0))[0][0])
            raise BadMeasurementData(f"{where}, line {lines[row]}: the uncertainty s must be positive")
        return cls(q, points, robot.joint_names, tuple(lines), source, sigma, payload)

    @keywords_after(1)
    def to_csv_text(
        self, *, degrees: bool = False, millimetres: bool = False, robot: Robot | None = None
    ) -> str:
        """CSV text of these data (format: see the module doc).

        Args:
            degrees: write the revolute joints in degrees (prismatic joints stay in metres).
            millimetres: write coordinates in millimetres.
            robot: the robot, to tell revolute from prismatic joints; needed with ``degrees``,
                and for a kind other than points (its columns' names).

        Raises:
            BadArgument: ``degrees`` (or another kind than points) without ``robot``.
        """
        q = np.array(self.q)
        if degrees:
            if robot is None:
                raise BadArgument(
                    "writing measurements in degrees needs the robot (robot=), to leave its prismatic "
                    "joints in metres",
                    argument="degrees",
                )
            q = robot.to_degrees(q)
        if self.is_points:
            coords, values = self._point_columns(millimetres)
        else:
            assert self.kind is not None  # not points: another kind
            if robot is None:
                raise BadArgument(
                    f"writing {self.kind.describe()} data needs the robot (robot=)", argument="robot"
                )
            coords, values = self._kind_columns(robot, millimetres)
        values.insert(0, q)
        if self.payload is not None:
            coords += list(PAYLOAD_COLUMNS)
            values.append(self.payload * ([1.0, 1000.0, 1000.0, 1000.0] if millimetres else 1.0))
        clash = sorted(set(self.joint_names) & set(coords))
        if clash:
            raise BadMeasurementData(
                f"joint {clash[0]!r} has the name of a measured column ({','.join(coords)}): a "
                f"measurement file could not tell them apart; rename the joint (<joint name=> in the URDF)"
            )
        out = io.StringIO()
        out.write(csv_header(list(self.joint_names) + coords))
        for row in np.hstack(values):
            out.write(",".join("" if np.isnan(v) else repr(float(v)) for v in row) + "\n")
        return out.getvalue()

    def _point_columns(self, millimetres: bool) -> tuple[list[str], list[np.ndarray]]:
        """(names, (m, ·) blocks) of the measured points' columns (and their σ)."""
        points = self.points * (1000.0 if millimetres else 1.0)
        K = self.n_markers
        coords = ["x", "y", "z"] if K == 1 else [f"{c}{k}" for k in range(K) for c in "xyz"]
        values = [points.reshape(len(points), -1)]
        if self.sigma is not None:
            coords += ["s" + c for c in coords]
            values.append(self.sigma.reshape(len(points), -1) * (1000.0 if millimetres else 1.0))
        return coords, values

    def _kind_columns(self, robot: Robot, millimetres: bool) -> tuple[list[str], list[np.ndarray]]:
        """(names, (m, ·) blocks) of another kind's columns: its values, their σ and covariances."""
        assert self.kind is not None  # not points: another kind
        names = list(self.kind.coordinates(robot))
        scale = 1.0 / _columns.unit_scale(self.kind.units(robot), millimetres)
        coords, values = list(names), [self.values * scale]
        spread = (
            self.sigma if self.covariance is None else np.sqrt(np.diagonal(self.covariance, axis1=1, axis2=2))
        )
        if spread is not None:
            coords += ["s" + n for n in names]
            values.append(spread * scale)
        if self.covariance is not None:
            pairs = [
                (a, b)
                for a in range(len(names))
                for b in range(a + 1, len(names))
                if self.covariance[:, a, b].any()
            ]
            coords += [f"cov_{names[a]}_{names[b]}" for a, b in pairs]
            values.append(
                np.column_stack([self.covariance[:, a, b] * scale[a] * scale[b] for a, b in pairs]).reshape(
                    self.m, -1
                )
            )
        return coords, values

    @keywords_after(2)
    def to_csv(
        self,
        path: str | os.PathLike,
        *,
        degrees: bool = False,
        millimetres: bool = False,
        robot: Robot | None = None,
    ) -> None:
        """Write the data as CSV, atomically (see :meth:`to_csv_text`)."""
        atomic_write_text(path, self.to_csv_text(degrees=degrees, millimetres=millimetres, robot=robot))


def _check_joint_names(found: tuple[str, ...], expected: tuple[str, ...], where: str) -> None:
    mismatch = column_mismatch(expected, found)
    if mismatch:
        raise BadMeasurementData(
            f"{where}: the joint columns must be the robot's joints {','.join(expected)}{mismatch}"
            " (measured columns are x,y,z or x0,y0,z0,x1,...)"
        )


def _check_markers(K: int, robot: Robot, where: str) -> None:
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


def _checked_payload(payload: PayloadLike, m: int, labels: list[str]) -> np.ndarray | None:
    """The (m, 4) payload rows, read-only, checked (masses from 0 to MAX_PAYLOAD kg, centres within
    MAX_LENGTH m), or None."""
    if payload is None:
        return None
    try:
        rows = np.array(payload, dtype=float).reshape(m, 4)
    except (TypeError, ValueError):
        raise BadMeasurementData(
            f"measurements: payload must be {m} rows [kg, x, y, z], got shape {np.shape(payload)}"  # type: ignore[arg-type]
        ) from None
    mass = rows[:, 0]
    bad = ~((mass >= 0) & (mass <= MAX_PAYLOAD))
    if bad.any():
        i = int(np.argmax(bad))
        raise BadMeasurementData(
            f"{labels[i]}: payload_kg {float(mass[i])!r} must be from 0 to {MAX_PAYLOAD:g} kg"
        )
    far = ~np.all(np.abs(rows[:, 1:]) <= MAX_LENGTH, axis=1)
    if far.any():
        i = int(np.argmax(far))
        raise BadMeasurementData(
            f"{labels[i]}: the payload's centre {rows[i, 1:].tolist()} must be finite and within "
            f"{MAX_LENGTH:.0e} m of the tip"
        )
    rows.flags.writeable = False
    return rows


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


def _checked_spread(
    value: npt.ArrayLike | None, shape: tuple[int, ...], labels: list[str], what: str
) -> np.ndarray | None:
    """σ (m, r) or covariances (m, r, r) of another kind's values, checked: positive σ, symmetric
    positive definite covariances; a new array, or None."""
    if value is None:
        return None
    try:
        arr = np.broadcast_to(np.array(value, dtype=float), shape).copy()
    except (TypeError, ValueError):
        raise BadMeasurementData(
            f"measurements: {what} must have shape {shape}, got {np.shape(value)}"
        ) from None
    if what == "sigma":
        bad = ~(np.isfinite(arr) & (arr > 0))
        if bad.any():
            raise BadMeasurementData(
                f"{labels[int(np.argwhere(bad)[0][0])]}: sigma must be positive and finite"
            )
        return arr
    for i, c in enumerate(arr):
        if not (np.all(np.isfinite(c)) and np.allclose(c, c.T) and np.all(np.linalg.eigvalsh(c) > 0)):
            raise BadMeasurementData(f"{labels[i]}: the covariance must be symmetric positive definite")
    return arr


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
