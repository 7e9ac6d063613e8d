"""Real data: the IPA UR10 accuracy set, a Leica T-Mac on a UR10's flange seen by a laser tracker.

christianlandgraf/ipa-robot-accuracy (MIT; the files, their licence and attribution are in
data/ipa_ur10/): four series of commanded poses with the joint readings reached and the T-Mac's
pose measured by the tracker: A a grid (11 911 poses), B joint configurations (1 495), C random
poses (2 773), D the ISO 9283 cubes (632). Files are ';'-separated with decimal commas; the
measured pose is in the tracker's frame [mm, deg, Euler 'XYZ'] (the dataset's ``dataset.py``).

pincal reads the T-Mac's origin as a point measured in the tracker's frame: the marker is the
T-Mac's origin in the flange frame (``tool0``), 109 mm out along the flange's z, from the series'
``Trafo_TM_F_init.txt`` (the flange's pose in the T-Mac's frame [mm]); the robot's placement in the
tracker's frame is identified (``base``). The robot is example-robot-data's UR10, whose joint names
are the files' columns.

    python benchmarks/realdata/ipa_ur10.py convert data/ipa_ur10/Series_C/measurements_random_poses.csv --out c.csv
    pincal identify ur10 --data c.csv --base --marker 0,0,0.109 --sigma 3e-5 --holdout 0.3

The suite's figures: ``python benchmarks/realdata/run.py``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import pincal
from pincal.calibration.measurements import MeasurementData

DATA = Path(__file__).resolve().parents[2] / "data" / "ipa_ur10"
SERIES = {
    "A grid": "Series_A/measurements_grid.csv",
    "B joint configurations": "Series_B/measurements_joint_configurations.csv",
    "C random poses": "Series_C/measurements_random_poses.csv",
    "D ISO cubes": "Series_D/measurements_iso_cubes.csv",
}
"""Each series' measurement file, relative to a data folder."""
JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
SIGMA = 3e-5
"""The tracker's standard deviation per coordinate [m] (pincal's default tracker; a Leica AT960
with a T-Mac at 2-4 m has a maximum permissible error of 15 µm + 6 µm/m)."""


@dataclass(frozen=True)
class Series:
    """One series' rows.

    Attributes:
        q: (m, 6) the joint readings [rad], in :data:`JOINTS` order.
        points: (m, 3) the T-Mac's origin measured in the tracker's frame [m].
        std: (m, 3) the tracker's standard deviation of each measured coordinate [m] (the
            repeatability of its averaging), or None when the series has none (A).
        temperature: (m,) the air temperature [°C].
        marker: (3,) the T-Mac's origin in the flange frame [m], from ``Trafo_TM_F_init.txt``.
        source: the file read.
    """

    q: np.ndarray
    points: np.ndarray
    std: np.ndarray | None
    temperature: np.ndarray
    marker: np.ndarray
    source: str

    def measurements(self, rows: object = slice(None)) -> MeasurementData:
        """The rows ``rows`` as pincal point measurements (the file's line numbers kept)."""
        lines = tuple(int(i) + 2 for i in np.arange(len(self.q))[rows])
        return MeasurementData(self.q[rows], self.points[rows], JOINTS, lines=lines, source=self.source)


def _number(cell: str) -> float:
    return float(cell.strip().replace(",", "."))


def tmac_in_flange(folder: Path) -> np.ndarray:
    """The T-Mac's origin in the flange frame [m] from the series' ``Trafo_TM_F_init.txt`` (the
    flange's pose in the T-Mac's frame, a 4x4 matrix [mm])."""
    T = np.loadtxt(folder / "Trafo_TM_F_init.txt")
    return -T[:3, :3].T @ T[:3, 3] / 1e3


def read(path: str | Path) -> Series:
    """One series' measurement file (``data/ipa_ur10/Series_C/measurements_random_poses.csv``)."""
    path = Path(path)
    lines = [line for line in path.read_text().splitlines() if line.strip()]
    header = [c.strip() for c in lines[0].split(";")]
    table = np.array([[_number(c) for c in line.split(";")] for line in lines[1:]])

    def columns(*names: str) -> np.ndarray:
        return table[:, [header.index(n) for n in names]]

    std = None
    if "measurement_std_x" in header:
        std = columns("measurement_std_x", "measurement_std_y", "measurement_std_z") / 1e3
    return Series(
        q=columns(*JOINTS),
        points=columns("measurement_x", "measurement_y", "measurement_z") / 1e3,
        std=std,
        temperature=columns("measurement_temperature")[:, 0],
        marker=tmac_in_flange(path.parent),
        source=path.name,
    )


def robot(marker: object = (0.0, 0.0, 0.109)) -> pincal.Robot:
    """example-robot-data's UR10, the T-Mac's origin as the marker on ``tool0`` (the flange)."""
    return pincal.load_robot("ur10", tip="tool0", markers=[tuple(np.asarray(marker, dtype=float))])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Convert an IPA UR10 series to pincal's measurement CSV.")
    commands = parser.add_subparsers(dest="command", required=True)
    convert = commands.add_parser("convert", help="convert a series to pincal's CSV format (metres, radians)")
    convert.add_argument(
        "series", type=Path, help="e.g. data/ipa_ur10/Series_C/measurements_random_poses.csv"
    )
    convert.add_argument("--out", type=Path, required=True, help="the CSV to write")
    args = parser.parse_args(argv)
    series = read(args.series)
    series.measurements().to_csv(args.out)
    marker = ",".join(f"{v:.4f}" for v in np.round(series.marker, 4) + 0.0)
    print(
        f"{len(series.q)} rows -> {args.out}; identify with: pincal identify ur10 --data {args.out} --base "
        f"--marker {marker} --sigma {SIGMA}"
    )


if __name__ == "__main__":
    main()
