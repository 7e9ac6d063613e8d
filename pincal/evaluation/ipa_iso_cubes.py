"""A reader of the IPA UR10 + Leica T-Mac ISO-cube series (christianlandgraf/ipa-robot-accuracy,
``Series_D/measurements_iso_cubes.csv``, MIT licence; Landgraf et al., IEEE CASE 2021).

The file is ';'-separated with decimal commas, one row per pose reached: the commanded pose
``Goal x, Goal y, Goal z`` [m] and ``Goal roll, Goal pitch, Goal yaw`` [rad] (fixed-axis x, y, z:
R = Rz(yaw) Ry(pitch) Rx(roll)), the six joint readings [rad] (``shoulder_pan_joint`` …
``wrist_3_joint``, the UR10's joint names), and the T-Mac's pose measured by the laser tracker in
its own frame: ``measurement_x, _y, _z`` [mm] and ``measurement_rx, _ry, _rz`` [deg] (intrinsic
X-Y-Z angles, as the dataset's ``dataset.py`` reads them). The commanded pose is the T-Mac's tool
frame in the robot's base frame, not the flange's: it equals the nominal flange pose at the joint
readings times the inverse of ``Trafo_TM_F_init.txt`` (within 0.45 mm and 0.05°), so the
commanded and the measured poses are of one point, the T-Mac's origin; the T-Mac's measured axes
are turned 180° about z from the commanded ones, a constant rotation the rigid fit finds
(:mod:`pincal.evaluation.rigid_fit`).

How rows make ISO 9283 cubes and cycles: the rows come in blocks of nine, a cube's centre then its
eight corners at ± h on each axis in the same order in every block (−++, −−+, ++−, +−−, +++,
+−+, −+−, −−−). The first four corners lie on one diagonal plane of the cube (x − x₀ = −(z − z₀)):
they are ISO's P2 … P5 in order around that rectangle, P2 = (−,+,+), P3 = (−,−,+), P4 = (+,−,−),
P5 = (+,+,−), with P1 the centre; P2-P4 is the plane's diagonal (ISO's distance pair). The other
four corners are no ISO pose and are left out. Consecutive blocks of the same cube (centre and h
within 1 mm, orientation within 0.01 rad) are its cycles; each cube is one test, named ``cube N``
(in the file's order) with its centre and edge. In Series D the first cube (edge 400 mm) is
measured 3 times; every other cube once. Rows in no block (Series D's last two) are left out.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pincal.errors import BadMeasurementData
from pincal.evaluation.pose_cycles import PoseCycles, rpy_rotations
from pincal.files import read_text

JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
"""The UR10's joints, as the file and the UR10's URDF name them."""

GOAL = ("Goal x", "Goal y", "Goal z", "Goal roll", "Goal pitch", "Goal yaw")
MEASURED = (
    "measurement_x",
    "measurement_y",
    "measurement_z",
    "measurement_rx",
    "measurement_ry",
    "measurement_rz",
)

CORNERS = ((-1, 1, 1), (-1, -1, 1), (1, 1, -1), (1, -1, -1), (1, 1, 1), (1, -1, 1), (-1, 1, -1), (-1, -1, -1))
"""The signs of the eight corners of a block, in the file's order."""

ISO_POSES = {"P1": None, "P2": 0, "P3": 1, "P4": 3, "P5": 2}
"""Each ISO pose's corner in :data:`CORNERS` (P1: the centre)."""

SAME_CUBE = 1e-3
"""Largest difference [m] of centre or half-edge between two blocks of one cube."""


def _intrinsic_xyz(angles: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations of intrinsic X-Y-Z angles [rad]: Rx(a) Ry(b) Rz(c)."""
    a, b, c = (np.asarray(angles, dtype=float)[:, i] for i in range(3))
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    one, zero = np.ones_like(a), np.zeros_like(a)
    rx = np.stack([one, zero, zero, zero, ca, -sa, zero, sa, ca], axis=1).reshape(-1, 3, 3)
    ry = np.stack([cb, zero, sb, zero, one, zero, -sb, zero, cb], axis=1).reshape(-1, 3, 3)
    rz = np.stack([cc, -sc, zero, sc, cc, zero, zero, zero, one], axis=1).reshape(-1, 3, 3)
    return rx @ ry @ rz


def _table(path: Path) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The file's columns by name, and each row's line."""
    name = str(path)
    text = read_text(path, "IPA ISO-cube series", BadMeasurementData)
    lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1) if line.strip()]
    if not lines:
        raise BadMeasurementData(f"IPA file {name!r} is empty", file=name)
    header = [h.strip() for h in lines[0][1].split(";")]
    missing = [c for c in (*GOAL, *JOINTS, *MEASURED) if c not in header]
    if missing:
        raise BadMeasurementData(
            f"IPA file {name!r}: no column {', '.join(missing)}; expected the ';'-separated columns of "
            "ipa-robot-accuracy's measurements_iso_cubes.csv",
            file=name,
            line=lines[0][0],
        )
    values = []
    for n, line in lines[1:]:
        cells = [c.strip().replace(",", ".") for c in line.split(";")]
        if len(cells) != len(header):
            raise BadMeasurementData(
                f"{name}, line {n}: {len(cells)} cells, expected {len(header)}", file=name, line=n
            )
        try:
            row = [float(c) for c in cells]
        except ValueError:
            raise BadMeasurementData(
                f"{name}, line {n}: a cell that is not a number", file=name, line=n
            ) from None
        if not np.all(np.isfinite(row)):
            raise BadMeasurementData(f"{name}, line {n}: NaN or infinite", file=name, line=n)
        values.append(row)
    if not values:
        raise BadMeasurementData(f"IPA file {name!r}: no rows after the header", file=name)
    data = np.array(values)
    return {h: data[:, i] for i, h in enumerate(header)}, np.array([n for n, _ in lines[1:]])


def _block(goal: np.ndarray, start: int) -> tuple[np.ndarray, float] | None:
    """(centre, half-edge h [m]) of the block of nine rows at ``start``, or None if those rows are
    not a cube's centre and its corners in the file's order."""
    if start + 9 > len(goal):
        return None
    centre = goal[start]
    offsets = goal[start + 1 : start + 9] - centre
    h = float(np.abs(offsets).mean())
    if h < 1e-3 or not np.allclose(offsets, h * np.array(CORNERS), atol=SAME_CUBE):
        return None
    return centre, h


def read_ipa_iso_cubes(path: str | os.PathLike) -> PoseCycles:
    """The ISO 9283 poses P1 … P5 of every cube of an IPA ISO-cube file, by cube (test) and cycle.

    The attained poses are the T-Mac's as measured, in the laser tracker's frame (metres; the
    rotations of its angles): express them in the commanded frame with
    :meth:`PoseCycles.in_commanded_frame`. The joint readings are kept (``JOINTS``).

    Raises:
        BadMeasurementData: a malformed file, or no cube in it.
    """
    path = Path(path)
    table, lines = _table(path)
    goal = np.stack([table[c] for c in GOAL[:3]], axis=1)
    rpy = np.stack([table[c] for c in GOAL[3:]], axis=1)
    rows: list[int] = []
    tests: list[str] = []
    poses: list[str] = []
    cycles: list[int] = []
    cubes: list[tuple[np.ndarray, float, np.ndarray]] = []
    start = 0
    while start < len(goal):
        block = _block(goal, start)
        if block is None:
            start += 1
            continue
        centre, h = block
        last = cubes[-1] if cubes else None
        same = (
            last is not None
            and np.allclose(last[0], centre, atol=SAME_CUBE)
            and abs(last[1] - h) <= SAME_CUBE
            and np.allclose(last[2], rpy[start], atol=1e-2)
        )
        if not same:
            cubes.append((centre, h, rpy[start]))
        cycle = cycles[-1] + 1 if same else 1
        for pose, corner in ISO_POSES.items():
            rows.append(start if corner is None else start + 1 + corner)
            tests.append(f"cube {len(cubes)}")
            poses.append(pose)
            cycles.append(cycle)
        start += 9
    if not rows:
        raise BadMeasurementData(
            f"IPA file {str(path)!r}: no ISO cube (a centre followed by its eight corners) in its rows",
            file=str(path),
        )
    index = np.array(rows)
    measured = np.stack([table[c] for c in MEASURED], axis=1)[index]
    return PoseCycles(
        tuple(tests),
        tuple(poses),
        np.array(cycles),
        goal[index],
        measured[:, :3] * 1e-3,
        rpy_rotations(rpy[index]),
        _intrinsic_xyz(np.radians(measured[:, 3:])),
        joints=np.stack([table[c] for c in JOINTS], axis=1)[index],
        joint_names=JOINTS,
        lines=lines[index],
    )


def describe_cubes(cycles: PoseCycles) -> dict[str, str]:
    """Each cube's description: ``centre (x, y, z) mm, edge E mm, n cycles`` (from P1 and P2)."""
    out = {}
    for test in cycles.tests():
        p1, p2 = cycles.rows(test, "P1"), cycles.rows(test, "P2")
        centre = cycles.commanded_positions[p1].mean(axis=0) * 1e3
        edge = 2 * abs(cycles.commanded_positions[p2[0], 0] - cycles.commanded_positions[p1[0], 0]) * 1e3
        out[test] = (
            f"centre ({centre[0]:.1f}, {centre[1]:.1f}, {centre[2]:.1f}) mm, edge {edge:.0f} mm, "
            f"{len(p1)} cycle(s)"
        )
    return out
