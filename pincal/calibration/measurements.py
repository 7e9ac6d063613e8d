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

import os
import re
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from pincal.arguments import MAX_LENGTH, SIGMA_RANGE, check_lengths
from pincal.calibration._measurement_csv import check_joint_names, check_markers, csv_text, read_csv
from pincal.deprecation import keywords_after
from pincal.errors import BadMeasurementData
from pincal.instruments.image import Image
from pincal.instruments.kind import Kind
from pincal.instruments.point import Point
from pincal.model.robot import Robot
from pincal.model.statics import MAX_PAYLOAD
from pincal.outputs import atomic_write_text
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
        check_joint_names(self.joint_names, names, self._where())
        if self.is_points:
            check_markers(self.n_markers, robot, self._where())
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
        return read_csv(cls, path, robot, degrees, millimetres, kind)

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
        return csv_text(self, degrees=degrees, millimetres=millimetres, robot=robot)

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
