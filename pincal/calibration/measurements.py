"""Measurements: the points an instrument measured at known joint values.

A :class:`MeasurementData` holds m configurations (m, nq) [rad or m] and the K measured points at
each, (m, K, 3) [m], expressed in the instrument's frame (or the robot base frame when the
instrument is registered to it).

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

from pincal.arguments import MAX_LENGTH, SIGMA_RANGE, check_lengths
from pincal.deprecation import keywords_after
from pincal.errors import BadArgument, BadMeasurementData
from pincal.files import atomic_write_text, column_mismatch, csv_header, read_numeric_csv
from pincal.model.robot import Robot
from pincal.model.statics import MAX_PAYLOAD, PAYLOAD_COLUMNS, payload_columns
from pincal.typing import ArrayLike, PayloadLike

_MEASURED = re.compile(r"^([xyz])(\d*)$")
_SIGMA = re.compile(r"^s([xyz]?)(\d*)$")


@dataclass(frozen=True, eq=False)
class MeasurementData:
    """Measured points at m configurations.

    Attributes:
        q: (m, nq) joint values [rad or m], read-only.
        points: (m, K, 3) measured points [m], read-only.
        joint_names: the joint of each column of ``q``.
        lines: the line of each configuration in its source file (for messages), or None.
        source: the file the data came from, or None.
        sigma: (m, K, 3) standard uncertainty of each measured coordinate [m], read-only, or None
            (the same unknown σ for all).
        payload: (m, 4) payload carried at each configuration, rows [kg, x, y, z] (centre of mass
            in the tip frame [m]), read-only, or None (no payload).
    """

    q: np.ndarray
    points: np.ndarray
    joint_names: tuple[str, ...]
    lines: tuple[int, ...] | None = None
    source: str | None = None
    sigma: np.ndarray | None = None
    payload: np.ndarray | None = None

    def __post_init__(self) -> None:
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

    def __len__(self) -> int:
        return len(self.q)

    @property
    def m(self) -> int:
        """Number of configurations."""
        return len(self.q)

    @property
    def n_markers(self) -> int:
        """Number of measured points K per configuration."""
        return self.points.shape[1]

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
        return MeasurementData(
            self.q[index], self.points[index], self.joint_names, lines, self.source, sigma, payload
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
        _check_markers(self.n_markers, robot, self._where())
        q = self.q[:, [self.joint_names.index(n) for n in names]]
        robot.check_limits(q, self.labels(), degrees=False)
        if names == self.joint_names:
            return self
        return MeasurementData(q, self.points, names, self.lines, self.source, self.sigma, self.payload)

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
    ) -> MeasurementData:
        """Read measurements for ``robot`` from a CSV file (format: see the module doc).

        Args:
            path: the file.
            robot: the robot measured: its joint names, markers and limits.
            degrees: revolute joint values are in degrees (converted to radians).
            millimetres: coordinates are in millimetres (converted to metres).

        Returns:
            the data, in the robot's joint order, values in radians and metres.

        Raises:
            BadMeasurementData: missing, empty or malformed file, columns that do not match the
                joints or markers (listed), a bad row (its line is named).
            BadConfiguration: a joint value outside its limits (its line is named).
        """
        source = str(path)
        header, rows, lines = read_numeric_csv(path, what="measurement", error=BadMeasurementData)
        where = f"measurement file {source!r}"
        measured = [h for h in header if _MEASURED.match(h)]
        uncertain = [h for h in header if _SIGMA.match(h)]
        loads = [h for h in header if h.startswith("payload_")]
        joints = [h for h in header if not (_MEASURED.match(h) or _SIGMA.match(h) or h in loads)]
        _check_joint_names(tuple(joints), robot.joint_names, where)
        columns = _measured_columns(measured, where)
        K = len(columns) // 3
        q = rows[:, [header.index(n) for n in robot.joint_names]]
        if degrees:
            q = robot.to_radians(q)
        points = rows[:, [header.index(c) for c in columns]].reshape(len(rows), K, 3)
        sigma = _sigma_columns(header, rows, uncertain, K, where)
        payload = payload_columns(header, rows, where, BadMeasurementData)
        if millimetres:
            points = points / 1000.0
            sigma = None if sigma is None else sigma / 1000.0
            payload = None if payload is None else payload / [1.0, 1000.0, 1000.0, 1000.0]
        _check_markers(K, robot, where)
        if sigma is not None and not np.all(sigma > 0):
            row = int(np.argwhere(~(sigma > 0))[0][0])
            raise BadMeasurementData(f"{where}, line {lines[row]}: the uncertainty s must be positive")
        data = cls(q, points, robot.joint_names, tuple(lines), source, sigma, payload)
        robot.check_limits(q, data.labels(), degrees)
        return data

    @keywords_after(1)
    def to_csv_text(
        self, *, degrees: bool = False, millimetres: bool = False, robot: Robot | None = None
    ) -> str:
        """CSV text of these data (format: see the module doc).

        Args:
            degrees: write the revolute joints in degrees (prismatic joints stay in metres).
            millimetres: write coordinates in millimetres.
            robot: the robot, to tell revolute from prismatic joints; needed with ``degrees``.

        Raises:
            BadArgument: ``degrees`` without ``robot``.
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
        points = self.points * (1000.0 if millimetres else 1.0)
        K = self.n_markers
        coords = ["x", "y", "z"] if K == 1 else [f"{c}{k}" for k in range(K) for c in "xyz"]
        values = [q, points.reshape(len(points), -1)]
        if self.sigma is not None:
            coords += ["s" + c for c in coords]
            values.append(self.sigma.reshape(len(points), -1) * (1000.0 if millimetres else 1.0))
        if self.payload is not None:
            coords += list(PAYLOAD_COLUMNS)
            values.append(self.payload * ([1.0, 1000.0, 1000.0, 1000.0] if millimetres else 1.0))
        out = io.StringIO()
        out.write(csv_header(list(self.joint_names) + coords))
        for row in np.hstack(values):
            out.write(",".join(repr(float(v)) for v in row) + "\n")
        return out.getvalue()

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
