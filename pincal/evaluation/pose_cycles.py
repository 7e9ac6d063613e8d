"""Poses measured in cycles (ISO 9283): what was commanded and what was attained, pose by pose and
cycle by cycle, and the two ways to express the attained poses for a comparison: in the commanded
frame by the best rigid fit, and as they would be after compensation by a calibrated model.

CSV format (read by :func:`read_pose_cycles`; ``pincal iso9283 --data``):

* one header row, then one row per measured pose; blank lines and lines starting with ``#`` are
  skipped; columns in any order;
* ``pose``: the pose's name (``P1`` … ``P5`` for the ISO cube); ``cycle``: the cycle's number;
  optionally ``test``: the test the row belongs to (one cube of several), default one test;
* the commanded position ``x_c,y_c,z_c`` and the attained one ``x,y,z``, in metres (millimetres
  with ``millimetres=True``, ``--mm``);
* optionally the orientations, all six columns or none: commanded ``a_c,b_c,c_c`` and attained
  ``a,b,c``, fixed-axis angles about x, y, z (roll, pitch, yaw: R = Rz(c) Ry(b) Rx(a)), radians
  (degrees with ``degrees=True``, ``--deg``);
* optionally the joint readings at each attained pose, one column per joint named as the robot's
  joints (radians; degrees with ``--deg``): a calibrated model predicts the pose there
  (:meth:`PoseCycles.after_calibration`);
* a cell that is missing, not a number, NaN or infinite, or a (test, pose, cycle) given twice, is
  an error naming the file and its line.

Example (two poses, the first cycles; metres)::

    pose,cycle,x_c,y_c,z_c,x,y,z
    P1,1,0.8,0.0,1.2,0.80012,0.00003,1.19991
    P2,1,0.9,0.1,1.3,0.90008,0.10011,1.29985
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.arguments import check_lengths
from pincal.errors import BadMeasurementData
from pincal.evaluation.rigid_fit import RigidFit, rigid_fit
from pincal.files import read_text
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot

POSITION_COLUMNS = ("x_c", "y_c", "z_c", "x", "y", "z")
"""The commanded and attained position columns of the CSV format."""

ORIENTATION_COLUMNS = ("a_c", "b_c", "c_c", "a", "b", "c")
"""The commanded and attained orientation columns (optional, all or none)."""

SAME_POSE = 1e-3
"""Largest spread [m] of one pose's commanded positions over its cycles: beyond, the rows named
alike are not one pose (ISO 9283 commands the same pose every cycle; recorded commands may differ
by a few tenths of a millimetre, and each cycle is compared with its own)."""


@dataclass(frozen=True, eq=False)
class PoseCycles:
    """Poses commanded and attained in cycles, one row per attained pose.

    Attributes:
        test: (N,) the test (a cube) each row belongs to; ``""`` for one test.
        pose: (N,) the pose's name (``P1`` … ``P5``).
        cycle: (N,) the cycle's number.
        commanded_positions: (N, 3) commanded positions [m].
        attained_positions: (N, 3) attained positions [m], in the frame ``frame`` says.
        commanded_rotations: (N, 3, 3) commanded orientations, or None (positions only).
        attained_rotations: (N, 3, 3) attained orientations, or None.
        joints: (N, nq) joint readings at the attained poses [rad, m], or None.
        joint_names: the names of the columns of ``joints``.
        frame: how the attained poses are expressed (``"as measured"``, ...).
        lines: (N,) the line of each row in its file (0 when not read from a file).
    """

    test: tuple[str, ...]
    pose: tuple[str, ...]
    cycle: np.ndarray
    commanded_positions: np.ndarray
    attained_positions: np.ndarray
    commanded_rotations: np.ndarray | None = None
    attained_rotations: np.ndarray | None = None
    joints: np.ndarray | None = None
    joint_names: tuple[str, ...] = ()
    frame: str = "as measured"
    lines: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.pose)
        for name in ("commanded_positions", "attained_positions"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (n, 3) or not np.all(np.isfinite(value)):
                raise BadMeasurementData(f"{name}: expected ({n}, 3) finite positions [m], got {value.shape}")
            check_lengths(value, name.replace("_", " "), BadMeasurementData)
            object.__setattr__(self, name, value)
        oriented = [self.commanded_rotations is not None, self.attained_rotations is not None]
        if any(oriented) and not all(oriented):
            raise BadMeasurementData(
                "orientations: give both the commanded and the attained ones, or neither"
            )
        for name in ("commanded_rotations", "attained_rotations"):
            if getattr(self, name) is not None:
                value = np.asarray(getattr(self, name), dtype=float)
                if value.shape != (n, 3, 3) or not np.all(np.isfinite(value)):
                    raise BadMeasurementData(
                        f"{name}: expected ({n}, 3, 3) rotation matrices, got {value.shape}"
                    )
                object.__setattr__(self, name, value)
        if len(self.test) != n or len(self.cycle) != n:
            raise BadMeasurementData(f"test, pose and cycle: expected {n} of each")
        object.__setattr__(self, "cycle", np.asarray(self.cycle, dtype=int))
        lines = np.zeros(n, dtype=int) if self.lines is None else np.asarray(self.lines, dtype=int)
        object.__setattr__(self, "lines", lines)
        if self.joints is not None:
            joints = np.asarray(self.joints, dtype=float)
            if joints.shape != (n, len(self.joint_names)) or not np.all(np.isfinite(joints)):
                raise BadMeasurementData(
                    f"joints: expected ({n}, {len(self.joint_names)}) finite joint readings, "
                    f"got {joints.shape}"
                )
            object.__setattr__(self, "joints", joints)
        self._check_rows()

    def _check_rows(self) -> None:
        first: dict[tuple[str, str, int], int] = {}
        for i, key in enumerate(zip(self.test, self.pose, self.cycle.tolist(), strict=True)):
            if key in first:
                raise BadMeasurementData(
                    f"{self._where(i)}test {key[0]!r} pose {key[1]!r} cycle {key[2]} is given twice "
                    f"(also {self._where(first[key]).rstrip(': ') or f'row {first[key] + 1}'}): one row per "
                    "pose and cycle",
                    line=self._line(i) or None,
                )
            first[key] = i
        for test, pose in self.groups():
            rows = self.rows(test, pose)
            spread = np.ptp(self.commanded_positions[rows], axis=0).max()
            if spread > SAME_POSE:
                raise BadMeasurementData(
                    f"{self._where(rows[0])}pose {pose!r}{f' of test {test!r}' if test else ''}: "
                    f"its commanded positions differ by {spread * 1e3:.3g} mm over its cycles (more than "
                    f"{SAME_POSE * 1e3:g} mm): one name, one commanded pose"
                )

    def _line(self, i: int) -> int:
        """The file line of row ``i`` (0: not read from a file)."""
        return 0 if self.lines is None else int(self.lines[i])

    def _where(self, i: int) -> str:
        return f"line {self._line(i)}: " if self._line(i) else ""

    @property
    def oriented(self) -> bool:
        """True when the orientations are given."""
        return self.commanded_rotations is not None

    def groups(self) -> list[tuple[str, str]]:
        """The (test, pose) pairs, in the order they first appear."""
        return list(dict.fromkeys(zip(self.test, self.pose, strict=True)))

    def tests(self) -> list[str]:
        """The tests, in the order they first appear."""
        return list(dict.fromkeys(self.test))

    def rows(self, test: str, pose: str) -> np.ndarray:
        """The rows of ``pose`` in ``test``, by cycle."""
        rows = [i for i, key in enumerate(zip(self.test, self.pose, strict=True)) if key == (test, pose)]
        return np.array(sorted(rows, key=lambda i: self.cycle[i]), dtype=int)

    def select(self, tests: list[str]) -> PoseCycles:
        """The rows of ``tests`` only.

        Raises:
            BadMeasurementData: a test the data do not have (the valid ones are listed).
        """
        unknown = [t for t in tests if t not in self.test]
        if unknown:
            valid = self.tests()
            shown = ", ".join(map(repr, valid[:10])) + (
                f", ... ({len(valid)} in all)" if len(valid) > 10 else ""
            )
            raise BadMeasurementData(
                f"no test {', '.join(map(repr, unknown))} in the data; the tests are {shown}",
                argument="--test",
            )
        keep = np.array([i for i, t in enumerate(self.test) if t in tests], dtype=int)

        def rows(value: np.ndarray | None) -> np.ndarray | None:
            return None if value is None else value[keep]

        return replace(
            self,
            test=tuple(self.test[i] for i in keep),
            pose=tuple(self.pose[i] for i in keep),
            cycle=self.cycle[keep],
            commanded_positions=self.commanded_positions[keep],
            attained_positions=self.attained_positions[keep],
            commanded_rotations=rows(self.commanded_rotations),
            attained_rotations=rows(self.attained_rotations),
            joints=rows(self.joints),
            lines=rows(self.lines),
        )

    def in_commanded_frame(self) -> tuple[PoseCycles, RigidFit]:
        """The attained poses expressed in the commanded frame by the best rigid fit of the attained
        positions onto the commanded ones over every row (and, with orientations, the measured
        frame's constant rotation on the tool: :func:`pincal.evaluation.rigid_fit.rigid_fit`)."""
        fit = rigid_fit(
            self.commanded_positions,
            self.attained_positions,
            self.commanded_rotations,
            self.attained_rotations,
        )
        rotations = None if self.attained_rotations is None else fit.rotations(self.attained_rotations)
        moved = replace(
            self,
            attained_positions=fit.positions(self.attained_positions),
            attained_rotations=rotations,
            frame="in the commanded frame by the best rigid fit"
            + (" (and the measured frame's rotation on the tool)" if rotations is not None else ""),
        )
        return moved, fit

    def after_calibration(
        self, robot: Robot, residual_model: ResidualModel | None = None
    ) -> tuple[PoseCycles, RigidFit]:
        """The attained poses predicted after compensation by a calibrated robot: the commanded pose
        plus what the calibrated model does not explain at the same joint readings,
        p = p_c + (p_measured − p_model(q)) and R = R_c R_model(q)ᵀ R_measured (recorded data cannot
        re-run the robot; a compensated command leaves this residual, docs/method.md §8.5).

        The measured poses are first expressed in the model's frame by the best rigid fit (the
        instrument may have moved since the calibration). The model's pose is its first marker's,
        with the tip's orientation, its residual model's mean added when there is one.

        Args:
            robot: the calibrated robot (:func:`pincal.compensation.load_calibration`).
            residual_model: its residual model, or None.

        Raises:
            BadMeasurementData: no joint readings, or not those of ``robot``'s joints.
        """
        if self.joints is None:
            raise BadMeasurementData(
                f"the poses after calibration need the joint readings at each pose: columns "
                f"{', '.join(robot.joint_names)}"
            )
        missing = [n for n in robot.joint_names if n not in self.joint_names]
        if missing:
            raise BadMeasurementData(
                f"the joint readings have columns {', '.join(self.joint_names)}; the calibrated robot's "
                f"joints are {', '.join(robot.joint_names)} (missing: {', '.join(missing)})"
            )
        q = self.joints[:, [self.joint_names.index(n) for n in robot.joint_names]]
        tip_rotations, tip_positions = robot.tip_poses(q)
        predicted = tip_positions + tip_rotations @ robot.markers[0]
        if residual_model is not None:
            predicted = predicted + residual_model.mean(q)[:, :3]
        fit = rigid_fit(predicted, self.attained_positions, tip_rotations, self.attained_rotations)
        positions = self.commanded_positions + fit.positions(self.attained_positions) - predicted
        rotations = None
        if self.attained_rotations is not None and self.commanded_rotations is not None:
            left = np.einsum("nji,njk->nik", tip_rotations, fit.rotations(self.attained_rotations))
            rotations = self.commanded_rotations @ left
        after = replace(
            self,
            attained_positions=positions,
            attained_rotations=rotations,
            frame="after calibration: commanded + (measured − calibrated model at the joint readings), "
            "measured expressed in the model's frame by the best rigid fit",
        )
        return after, fit


def rpy_rotations(angles: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations of (N, 3) fixed-axis angles a, b, c about x, y, z [rad]: Rz(c) Ry(b) Rx(a)."""
    return np.array([pin.rpy.rpyToMatrix(*row) for row in np.asarray(angles, dtype=float)]).reshape(-1, 3, 3)


def read_pose_cycles(
    path: str | os.PathLike, *, millimetres: bool = False, degrees: bool = False
) -> PoseCycles:
    """Read poses measured in cycles from a CSV file (the format in this module's docstring).

    Args:
        path: the CSV file.
        millimetres: positions in millimetres (default metres).
        degrees: orientations and joint readings in degrees (default radians).

    Raises:
        BadMeasurementData: a malformed file, naming its line.
    """
    path = Path(path)
    text = read_text(path, "pose cycles", BadMeasurementData)
    rows = [
        (n, row)
        for n, row in enumerate(csv.reader(io.StringIO(text, newline="")), start=1)
        if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")
    ]
    name = str(path)
    header, given, joint_names = _pose_cycles_header(rows, name)
    numeric = [*POSITION_COLUMNS, *given, *joint_names]
    values, tests, poses, cycles, lines = _pose_cycles_rows(rows, header, numeric, name)
    if not values:
        raise BadMeasurementData(f"pose cycles file {name!r}: no rows after the header", file=name)
    data = np.array(values)
    scale = 1e-3 if millimetres else 1.0
    angle = np.pi / 180 if degrees else 1.0
    positions = data[:, :6] * scale
    rotations: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
    if given:
        angles = data[:, 6:12] * angle
        rotations = (rpy_rotations(angles[:, :3]), rpy_rotations(angles[:, 3:]))
    joints = data[:, 6 + len(given) :] * angle if joint_names else None
    try:
        return PoseCycles(
            tuple(tests),
            tuple(poses),
            np.array(cycles),
            positions[:, :3],
            positions[:, 3:],
            *rotations,
            joints=joints,
            joint_names=joint_names,
            lines=np.array(lines),
        )
    except BadMeasurementData as exc:
        raise BadMeasurementData(f"{name}: {exc}", file=name, line=exc.line) from None


def _pose_cycles_header(
    rows: list[tuple[int, list[str]]], name: str
) -> tuple[list[str], list[str], tuple[str, ...]]:
    """(header, orientation columns given, joint names) of a pose cycles file's rows, checked."""
    if not rows:
        raise BadMeasurementData(f"pose cycles file {name!r} is empty: expected a header row", file=name)
    header = [h.strip() for h in rows[0][1]]
    required = ("pose", "cycle", *POSITION_COLUMNS)
    missing = [c for c in required if c not in header]
    if missing or len(set(header)) != len(header):
        raise BadMeasurementData(
            f"pose cycles file {name!r}: header {','.join(header)}; expected the columns "
            f"{','.join(required)}[,{','.join(ORIENTATION_COLUMNS)}][,test][,joint names] once each"
            + (f" (missing: {', '.join(missing)})" if missing else ""),
            file=name,
            line=rows[0][0],
        )
    given = [c for c in ORIENTATION_COLUMNS if c in header]
    if given and len(given) != len(ORIENTATION_COLUMNS):
        absent = ", ".join(c for c in ORIENTATION_COLUMNS if c not in header)
        raise BadMeasurementData(
            f"pose cycles file {name!r}: orientation columns {', '.join(given)} without {absent}: "
            "all six or none",
            file=name,
            line=rows[0][0],
        )
    known = {"pose", "cycle", "test", *POSITION_COLUMNS, *ORIENTATION_COLUMNS}
    joint_names = tuple(h for h in header if h not in known)
    return header, given, joint_names


def _pose_cycles_rows(
    rows: list[tuple[int, list[str]]], header: list[str], numeric: list[str], name: str
) -> tuple[list[list[float]], list[str], list[str], list[int], list[int]]:
    """(numbers of the ``numeric`` columns, tests, poses, cycles, line numbers) of the data rows
    (``rows`` after the header row), checked."""
    index = {h: i for i, h in enumerate(header)}
    values, tests, poses, cycles, lines = [], [], [], [], []
    for n, row in rows[1:]:
        if len(row) != len(header):
            raise BadMeasurementData(
                f"{name}, line {n}: {len(row)} cells, expected {len(header)}", file=name, line=n
            )
        try:
            numbers = [float(row[index[c]]) for c in numeric]
            cycle = float(row[index["cycle"]])
        except ValueError:
            raise BadMeasurementData(
                f"{name}, line {n}: a cell that is not a number", file=name, line=n
            ) from None
        if not np.all(np.isfinite([*numbers, cycle])) or cycle != int(cycle):
            raise BadMeasurementData(
                f"{name}, line {n}: NaN, infinite, or a cycle that is not a whole number", file=name, line=n
            )
        pose = row[index["pose"]].strip()
        if not pose:
            raise BadMeasurementData(f"{name}, line {n}: the pose has no name", file=name, line=n)
        values.append(numbers)
        poses.append(pose)
        cycles.append(int(cycle))
        tests.append(row[index["test"]].strip() if "test" in index else "")
        lines.append(n)
    return values, tests, poses, cycles, lines
