"""The public real-data suite: every set of data/ put through the same calibration comparison.

    python benchmarks/realdata/run.py            # all sets; writes the "realdata" section of RESULTS.md
    python benchmarks/realdata/run.py --no-write # print only

For each set: the models of :data:`suite.MODELS` (the nominal robot located by its base alone; the
geometric errors ``full,offsets``; with the joint gains; with compliance under gravity, where the
URDF has inertias; with a Gaussian-process residual model), fitted on 70 % of the rows and judged
on the other 30 % (seed 0): held-out RMS and largest error, and the RMS pincal predicted for them
(``Validation.expected_rms``: its standard errors, what the model does not explain, the noise).
Then, on the IPA series (one tracker placement each), plans of m = 12, 20, 30 configurations chosen
from the training rows — by pincal's test-pose design over the held-out configurations, by a
D-optimal design, at random (10 draws) — each calibrated on its measured rows and judged on the
same held-out rows. Last, each model calibrated on series C used on the other series (another day,
another tracker placement, the T-Mac remounted), its base and the T-Mac located from 12 of their
poses.

The IPA series are large: each is cut to a seeded random subset of :data:`ROWS` rows (of 11 911,
1 495, 2 773 and 632), which keeps the residual model exact (below 500 training rows) and the whole
suite within about ten minutes on two cores.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

import ipa_ur10  # noqa: E402
import mukca  # noqa: E402
import suite  # noqa: E402
from _common import cpu_seconds, header, write  # noqa: E402

import pincal  # noqa: E402
from pincal.calibration.measurements import MeasurementData  # noqa: E402

ROWS = 600
"""Rows of each IPA series used (a seeded random subset)."""
HOLDOUT = 0.3
SEED = 0
SIZES = (12, 20, 30)
DRAWS = 10
STATIONING = 12
"""Poses of another series that locate a calibrated robot in that series' tracker frame."""
RELOCATE = "base,markers"
"""What is located again on another series: the tracker's placement and the T-Mac's on the flange
(remounted between the series: the nominal robot's error on series A falls from 3.7 to 1.3 mm
when the T-Mac is located too)."""


def _used(series: ipa_ur10.Series, rows: int = ROWS, seed: int = SEED) -> MeasurementData:
    """The rows of a series the suite uses: all, or a seeded random subset of ``rows``."""
    chosen = np.arange(len(series.q))
    if len(chosen) > rows:
        chosen = np.sort(np.random.default_rng(seed).choice(len(chosen), rows, replace=False))
    return series.measurements(chosen)


def ipa_section(
    name: str, path: Path, *, rows: int = ROWS, seed: int = SEED, designs: bool = True
) -> list[str]:
    """The figures of one IPA series: models, then designs from its pool."""
    series = ipa_ur10.read(path)
    used = _used(series, rows, seed)
    split = suite.Split.of([used], HOLDOUT, seed)
    robot = ipa_ur10.robot(series.marker)

    def parameters(spec: str) -> pincal.ParameterSet:
        return robot.parameters((spec + ",base").lstrip(",")).identifiable(prefer="base").identifiable

    lines = [
        f"### IPA UR10, series {name}",
        "",
        f"{len(series.q)} poses in the file, {used.m} used (seed {seed}); {split.train[0].m} to calibrate, "
        f"{split.test[0].m} held out; σ = {ipa_ur10.SIGMA * 1e3:g} mm per coordinate; errors in mm.",
        "",
    ]
    table, _ = suite.models_table(parameters, split, suite.MODELS, sigma=ipa_ur10.SIGMA)
    lines += table
    if designs:
        located = pincal.identify(robot.parameters("base"), split.train[0], sigma=ipa_ur10.SIGMA).robot
        geometric = located.parameters("full,offsets,base").identifiable(prefer="base").identifiable
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pooled = pincal.identify(geometric, split.train[0], sigma=ipa_ur10.SIGMA)
        # what the training poses can identify (a small region, as the ISO cubes, leaves some nominal)
        geometric = located.parameters(",".join(n for n in geometric.names if n not in pooled.dropped))
        lines += [
            "",
            f"Plans chosen from the {split.train[0].m} training poses, geometric model ({len(geometric)} parameters), "
            "held-out RMS [mm]:",
            "",
        ]
        lines += suite.designs_table(geometric, split, SIZES, sigma=ipa_ur10.SIGMA, draws=DRAWS, seed=seed)
    return lines


def _moved(
    result: pincal.IdentificationResult, station: MeasurementData, rest: MeasurementData
) -> np.ndarray:
    """(n,) the errors [m] at ``rest`` of a calibration moved to another tracker placement, its base
    and the T-Mac's placement (:data:`RELOCATE`) located from the poses ``station`` there (the
    residual model's mean taken off them, with the placement of a first location)."""
    model, data = result.residual_model, station
    for _ in range(1 if model is None else 2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            placed = pincal.identify(result.robot.parameters(RELOCATE), data, sigma=ipa_ur10.SIGMA).robot
        if model is not None:
            correction = model.mean(station.q)[:, :3] @ placed.base.rotation.T
            data = MeasurementData(station.q, station.points[:, 0] - correction, station.joint_names)
    points = placed.points(rest.q, check=False)[:, 0]
    if model is not None:
        points = points + model.mean(rest.q)[:, :3] @ placed.base.rotation.T
    return np.linalg.norm(points - rest.points[:, 0], axis=1)


def transfer_section(source: str = "C random poses", *, seed: int = SEED) -> list[str]:
    """A calibration on one series' training rows used on the others (another day, another tracker
    placement): its base and the T-Mac located from :data:`STATIONING` poses of each, errors at the
    rest."""
    series = {name: ipa_ur10.read(ipa_ur10.DATA / path) for name, path in ipa_ur10.SERIES.items()}
    robot = ipa_ur10.robot(series[source].marker)
    (train,) = suite.Split.of([_used(series[source])], HOLDOUT, seed).train
    others = [name for name in series if name != source]
    rng = np.random.default_rng(seed)
    targets = {}
    for name in others:
        data = _used(series[name])
        order = rng.permutation(data.m)
        targets[name] = (data.subset(np.sort(order[:STATIONING])), data.subset(np.sort(order[STATIONING:])))
    lines = [
        f"### IPA UR10: calibrated on series {source}, used on the others",
        "",
        f"Each model fitted on the {train.m} training poses of series {source} (as above); on each other series "
        f"(another day and temperature, another tracker placement, the T-Mac remounted, partly another region "
        f"of the joint space) its base and the T-Mac's placement (`{RELOCATE}`) located from {STATIONING} random "
        "poses (seed 0) of the same subset, the error at the rest [mm], RMS / largest:",
        "",
        "| model | " + " | ".join(f"series {name}" for name in others) + " |",
        "| --- |" + " ---: |" * len(others),
    ]
    for model in suite.MODELS:
        params = robot.parameters((model.spec + ",base").lstrip(",")).identifiable(prefer="base").identifiable
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = pincal.identify(
                params, train, sigma=ipa_ur10.SIGMA, residual_model="gp" if model.gp else None
            )
        cells = []
        for name in others:
            e = _moved(result, *targets[name])
            cells.append(f"{suite.mm(float(np.sqrt(np.mean(e**2))))} / {suite.mm(float(e.max()))}")
        lines.append(f"| {model.name} | " + " | ".join(cells) + " |")
    return lines


def mukca_section(arm: str = "panda_2", *, seed: int = SEED) -> list[str]:
    """The figures of the MUKCa set of one arm: models, and the sockets' fitted distance."""
    panda = mukca.robot()
    sockets = mukca.read(arm)
    split = suite.Split.of(mukca.sessions(sockets, panda), HOLDOUT, seed)
    models = [m for m in suite.MODELS if "compliance" not in m.spec]  # the URDF has no inertias
    table, _ = suite.models_table(lambda spec: mukca.parameters(panda, spec), split, models, sigma=None)
    placements = len({s.placement for s in sockets})
    lines = [
        f"### MUKCa, {arm} (Franka Panda, ball in sockets)",
        "",
        f"{placements} tool placements × 2 sockets = {len(sockets)} sessions, {sum(s.q.shape[0] for s in sockets)} "
        f"configurations; 30 % of each socket's rows held out (seed {seed}); the error is the distance from the "
        "predicted ball centre to the fitted socket centre [mm]; σ estimated from the residuals; no compliance "
        "(the URDF has no inertias); the first joint's placement not estimated (with free sockets it is the fit's gauge).",
        "",
        *table,
        "",
        "The distance between the two sockets of each placement (50 mm by construction; the fit never sees it) [mm]:",
        "",
        "| model | " + " | ".join(sorted({s.placement for s in sockets})) + " | RMS error |",
        "| --- |" + " ---: |" * (placements + 1),
    ]
    for model in models:
        if model.gp:
            continue  # the residual model does not move the sockets
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = pincal.identify(mukca.parameters(panda, model.spec), list(split.train))
        d = mukca.socket_distances(result, sockets)
        error = np.sqrt(np.mean((d - mukca.SOCKET_DISTANCE) ** 2))
        lines.append(
            f"| {model.name} | " + " | ".join(f"{v * 1e3:.2f}" for v in d) + f" | {error * 1e3:.2f} |"
        )
    return lines


def main(argv: list[str] | None = None) -> list[str]:
    parser = argparse.ArgumentParser(description="Run the public real-data suite (benchmarks/realdata).")
    parser.add_argument("--no-write", action="store_true", help="print only; leave benchmarks/RESULTS.md")
    parser.add_argument("--only", choices=("ipa", "mukca"), help="one data set only")
    args = parser.parse_args(argv)
    start, cpu = time.perf_counter(), cpu_seconds()
    lines = header("python benchmarks/realdata/run.py")
    lines += [
        "- Data: data/ipa_ur10 (MIT; each series cut to a seeded random subset of "
        f"{ROWS} rows), data/mukca (MIT; panda_2, every row); the method is in benchmarks/realdata/run.py's "
        "docstring.",
        "- Reading the tables: *predicted RMS* is what pincal said beforehand the held-out error would be "
        "(`Validation.expected_rms`: the parameters' standard errors, what the model does not explain, the "
        "noise); *ρ0 of the design* counts σ alone (the plan's criterion), not what no parameter explains, "
        "which dominates on these robots.",
        "",
    ]
    if args.only in (None, "ipa"):
        for name, path in ipa_ur10.SERIES.items():
            lines += ipa_section(name, ipa_ur10.DATA / path) + [""]
        lines += transfer_section() + [""]
    if args.only in (None, "mukca"):
        lines += mukca_section() + [""]
    lines.append(
        f"- Wall time {time.perf_counter() - start:.0f} s, CPU time {cpu_seconds() - cpu:.0f} s (one process)."
    )
    print("\n".join(lines))
    if not args.no_write and args.only is None:
        write(lines, "realdata")
    return lines


if __name__ == "__main__":
    main()
