"""Real data: the Hilti construction-robot stationing datasets, read as pincal measurements.

Hilti-Research/construction_robot_stationing_datasets (CC BY-NC-SA 3.0; the files used, their
licence and attribution are in data/hilti_stationing/): a Doosan arm on a two-stage lifting column
on tracks ("Trailblazer", a Hilti JaiBot prototype), a prism on its tool measured by a total station
(σ ≈ 0.75 mm per coordinate) at about 450 waypoints per dataset, with the joint states and a
base accelerometer.

The column's two stages are mimic joints of one recorded ``column_prismatic_joint`` (q): the
middle stage stands at 0.5·q − 0.706 m and the top stage at 0.5·q − 0.736 m (the dataset's own
formulas). pincal loads the published URDF as it is (mimic joints as ordinary joints), so a
measurement row carries both stages' values, the six arm joints and the prism's position. The
base accelerometer measures the specific force, −gravity, in the robot's base frame: its mean over
a dataset is the gravity the compliance term uses (the floor's tilt).

Run as a script to convert a dataset to pincal's CSV format::

    python benchmarks/hilti_stationing.py convert data/hilti_stationing/flat.yaml --out flat.csv

or to measure the held-out accuracy of each model (the figures of benchmarks/RESULTS.md)::

    python benchmarks/hilti_stationing.py report

(1) on flat.yaml, a random 70/30 split (seed 0): calibrate on 70 %, report the error at the other
30 %; (2) calibrate on all of flat.yaml, then on each other dataset (the robot moved, the floor
tilted, the day colder) locate the base from that dataset's stationing points only and report the
error at its evaluation points: the use a calibration is for.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

import pincal
from pincal.calibration.measurements import MeasurementData

DATA = Path(__file__).resolve().parents[1] / "data" / "hilti_stationing"
URDF = DATA / "trailblazer.urdf"
TIP = "prism"
SIGMA = 0.75e-3
"""The total station's standard deviation per coordinate [m] (the dataset's README)."""

COLUMN_STAGES = (("column_middle_joint", 0.5, -0.706), ("column_top_joint", 0.5, -0.736))
"""The mimic stages of the recorded column joint: value = multiplier·q + offset [m]."""


@dataclass(frozen=True)
class Waypoints:
    """One dataset's waypoints.

    Attributes:
        joint_names: the robot's chain joints (the two column stages, then the arm's six).
        q: (m, 8) joint values [m, rad] in that order.
        points: (m, 3) prism positions measured by the total station [m].
        station: (m,) index of each waypoint's station (one column height and arm solution space).
        stationing: (m,) True for the station's stationing points, False for its evaluation points.
        accelerometer: (m, 3) the base accelerometer's reading [m/s²].
    """

    joint_names: tuple[str, ...]
    q: np.ndarray
    points: np.ndarray
    station: np.ndarray
    stationing: np.ndarray
    accelerometer: np.ndarray

    @property
    def gravity(self) -> np.ndarray:
        """Gravity in the robot's base frame [m/s²]: minus the mean accelerometer reading."""
        return -self.accelerometer.mean(axis=0)

    def measurements(self, rows: object = slice(None)) -> MeasurementData:
        """The waypoints ``rows`` as pincal measurements."""
        return MeasurementData(self.q[rows], self.points[rows], self.joint_names)


def read(path: str | Path) -> Waypoints:
    """The waypoints of one dataset file (``flat.yaml``, ``outdoor.yaml``, ...)."""
    raw = yaml.safe_load(Path(path).read_text())
    recorded = raw["joint_names"]
    column = recorded.index("column_prismatic_joint")
    arm = [i for i, name in enumerate(recorded) if name != "column_prismatic_joint"]
    rows, station_of, stationing, accel = [], [], [], []
    station = 0
    for height in raw["column_heights"].values():
        for space in height["solution_spaces"].values():
            for kind in ("stationing_measurements", "evaluation_measurements"):
                for meas in space[kind]:
                    joints = np.asarray(meas["joint_states"], dtype=float)
                    stages = [k * joints[column] + c for _, k, c in COLUMN_STAGES]
                    rows.append(np.r_[stages, joints[arm], meas["prism_position"]])
                    station_of.append(station)
                    stationing.append(kind == "stationing_measurements")
                    accel.append(meas["tilt_sensor_base_accel"])
            station += 1
    table = np.array(rows)
    names = tuple(name for name, _, _ in COLUMN_STAGES) + tuple(recorded[i] for i in arm)
    return Waypoints(
        joint_names=names,
        q=table[:, :8],
        points=table[:, 8:],
        station=np.array(station_of),
        stationing=np.array(stationing),
        accelerometer=np.array(accel, dtype=float),
    )


def robot(gravity: object = None) -> pincal.Robot:
    """The published URDF with the prism as the measured point (and the dataset's gravity)."""
    loaded = pincal.load_robot(URDF, tip=TIP)
    return loaded if gravity is None else loaded.with_gravity(gravity)


MODELS = {
    "nominal (base only)": ("", False),
    "geometric": ("full,offsets", False),
    "geometric + gains": ("full,offsets,gains", False),
    "geometric + compliance": ("full,offsets,compliance", False),
    "geometric + gains + compliance": ("full,offsets,gains,compliance", False),
    "geometric + residual model": ("full,offsets", True),
    "geometric + compliance + residual model": ("full,offsets,compliance", True),
}
"""The models compared: pincal's default geometric set, and with each further term (each with the
base frame, the identifiable subset); the residual model is a Gaussian process of what the fit
leaves, fitted on the calibration's waypoints only."""


def calibrated(waypoints: Waypoints, rows: np.ndarray, spec: str, gp: bool = False):
    """The identification result with parameter set ``spec`` (+ base) on ``rows`` of ``waypoints``."""
    nominal = robot(waypoints.gravity)
    params = nominal.parameters((spec + ",base").lstrip(",")).identifiable(prefer="base").identifiable
    return pincal.identify(
        params, waypoints.measurements(rows), sigma=SIGMA, residual_model="gp" if gp else None
    )


def predicted(located: pincal.Robot, residual, q: np.ndarray) -> np.ndarray:
    """(m, 3) the prism's predicted positions: the robot's, plus the residual model's mean (robot
    base frame, rotated into the instrument's)."""
    points = located.points(q, check=False)[:, 0]
    return points if residual is None else points + residual.mean(q)[:, :3] @ located.base.rotation.T


def located(result, other: Waypoints) -> pincal.Robot:
    """The calibrated robot on another dataset: its base fitted to that dataset's stationing
    points (the residual model's mean removed from them, with the base of a first fit)."""
    moved = result.robot.with_gravity(other.gravity)
    rows = np.flatnonzero(other.stationing)
    data = other.measurements(rows)
    for _ in range(1 if result.residual_model is None else 2):
        base = pincal.identify(moved.parameters("base"), data, sigma=SIGMA).robot
        if result.residual_model is not None:
            correction = result.residual_model.mean(other.q[rows])[:, :3] @ base.base.rotation.T
            data = pincal.MeasurementData(other.q[rows], other.points[rows] - correction, other.joint_names)
    return base


def _stats(e: np.ndarray) -> tuple[float, float, float]:
    return np.sqrt(np.mean(e**2)) * 1e3, np.median(e) * 1e3, np.percentile(e, 95) * 1e3


def report(seed: int = 0) -> list[str]:
    """The held-out figures (see module doc), as Markdown table lines."""
    flat = read(DATA / "flat.yaml")
    m = len(flat.q)
    order = np.random.default_rng(seed).permutation(m)
    train, test = np.sort(order[: int(0.7 * m)]), np.sort(order[int(0.7 * m) :])
    lines = [
        f"flat.yaml, {len(train)} waypoints to calibrate, {len(test)} held out (seed {seed}); error at the "
        "held-out waypoints [mm], and the residual model's own prediction of it:",
        "",
        "| model | RMS | median | 95 % | predicted RMS |",
        "| --- | --- | --- | --- | --- |",
    ]
    for name, (spec, gp) in MODELS.items():
        result = calibrated(flat, train, spec, gp)
        e = np.linalg.norm(
            predicted(result.robot, result.residual_model, flat.q[test]) - flat.points[test], axis=1
        )
        guess = (
            ""
            if not gp
            else f"{np.sqrt(np.mean(3 * (result.residual_model.variance(flat.q[test]) + SIGMA**2))) * 1e3:.2f}"
        )
        lines.append(f"| {name} | {' | '.join(f'{v:.2f}' for v in _stats(e))} | {guess} |")
    others = {name: read(DATA / f"{name}.yaml") for name in ("outdoor", "seesaw")}
    lines += [
        "",
        "Calibrated on all of flat.yaml; on each other dataset the base located from its stationing points, error at its",
        "evaluation points [mm] (RMS / median / 95 %):",
        "",
        "| model | " + " | ".join(others) + " |",
        "| --- |" + " --- |" * len(others),
    ]
    for name, (spec, gp) in MODELS.items():
        result = calibrated(flat, np.arange(m), spec, gp)
        cells = []
        for other in others.values():
            evaluation = np.flatnonzero(~other.stationing)
            placed = located(result, other)
            e = np.linalg.norm(
                predicted(placed, result.residual_model, other.q[evaluation]) - other.points[evaluation],
                axis=1,
            )
            cells.append(" / ".join(f"{v:.2f}" for v in _stats(e)))
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description="The Hilti stationing datasets: convert one, or report held-out figures."
    )
    commands = parser.add_subparsers(dest="command", required=True)
    convert = commands.add_parser("convert", help="convert a dataset to pincal's CSV format")
    convert.add_argument("dataset", type=Path, help="a dataset file, e.g. data/hilti_stationing/flat.yaml")
    convert.add_argument("--out", type=Path, required=True, help="the CSV to write")
    commands.add_parser("report", help="held-out accuracy of each model (benchmarks/RESULTS.md)")
    args = parser.parse_args(argv)
    if args.command == "report":
        print("\n".join(report()))
        return
    waypoints = read(args.dataset)
    waypoints.measurements().to_csv(args.out)
    g = waypoints.gravity
    print(
        f"{len(waypoints.q)} waypoints -> {args.out}; gravity in the base frame {np.round(g, 4).tolist()} m/s²"
    )


if __name__ == "__main__":
    main()
