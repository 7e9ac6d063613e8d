"""Sanity of a calibration before it is called converged: outliers and implausible results.

* :func:`find_outliers` scores each measured configuration by its residual in robust standard
  deviations (σ̂ = 1.4826·median|e| of the whitened residual coordinates e; σ itself when σ̂ is
  below :data:`ZERO_SCALE`, an exact fit) and names the rows above a threshold, by file and line.
* :func:`implausible` lists what no real robot does — a link origin moving by more than
  :data:`LINK_LIMIT`, the tool frame or a marker by more than :data:`TOOL_LIMIT`, an angle
  changing by more than :data:`ANGLE_LIMIT`, residuals :data:`RESIDUAL_FACTOR` times the
  instrument's σ (before calibration: at least :data:`BEFORE_LIMIT`) — and
  :func:`likely_causes` names the usual reasons: millimetres read as metres,
  a forgotten marker, data in the instrument's frame without ``--base``, swapped columns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pincal.calibration.noise import Noise
from pincal.calibration.problem import Problem, fit_rms, measured_points
from pincal.model.kinematics import ForwardKinematics
from pincal.model.parameters import ParameterSet

OUTLIER_SCORE = 5.0
"""Rows whose residual exceeds this many robust σ are reported as suspicious (a 3-D Gaussian
residual exceeds 5σ once in 70 000 points)."""
LINK_LIMIT = 0.05
"""A chain origin moving by more than this [m] is not a calibration result."""
TOOL_LIMIT = 0.05
"""A tool frame or marker moving by more than this [m] is not a calibration result."""
ANGLE_LIMIT = 0.1
"""An origin turning or a joint zero moving by more than this [rad] (5.7°) is not one either."""
RESIDUAL_FACTOR = 1000.0
"""Residuals above this many times the instrument's σ are not robot errors (after calibration;
before it, above this or :data:`BEFORE_LIMIT`, whichever is larger: a badly mastered joint zero
moves a large robot's tool by centimetres)."""
BEFORE_LIMIT = 0.1
"""Residual RMS before calibration [m] that no real robot's geometric errors reach."""
ZERO_SCALE = 1e-4
"""A robust spread of the whitened residuals below this (a ten-thousandth of σ: 3 nm for a
tracker's 30 µm) is no measure of the noise: residuals are then scored against σ itself. (Scored
against the median of an exact fit, identical rows each scored 139 366 σ: every row an outlier.)"""


@dataclass(frozen=True)
class Outlier:
    """A suspicious measured configuration.

    Attributes:
        row: index in the data (sessions stacked).
        label: the file and line (or the row index).
        distance: largest distance between measured and model point in the row [m].
        score: its whitened residual in robust standard deviations (see :func:`robust_scale`).
        unit: the unit of ``distance``: ``m`` (``rad`` or ``px`` for orientations and pixels
            alone).
    """

    row: int
    label: str
    distance: float
    score: float
    unit: str = "m"

    def __str__(self) -> str:
        sizes = {"m": f"{self.distance * 1e3:.3g} mm", "rad": f"{self.distance * 1e3:.3g} mrad"}
        size = sizes.get(self.unit, f"{self.distance:.3g} {self.unit}")
        return f"{self.label}: {size} ({self.score:.3g} sigma)"

    def as_dict(self) -> dict:
        out = {"row": self.row, "label": self.label, "distance": self.distance, "score": self.score}
        return out if self.unit == "m" else out | {"unit": self.unit}


def robust_sigma(e: np.ndarray) -> float:
    """1.4826·median|e|: the standard deviation of Gaussian e, unmoved by a few gross errors."""
    return float(1.4826 * np.median(np.abs(e)))


def robust_scale(e: np.ndarray) -> float:
    """The spread of whitened residuals e to score them against: their :func:`robust_sigma`, or 1
    (σ itself) when that is below :data:`ZERO_SCALE`: more than half the coordinates are fitted
    exactly (identical or duplicated rows, as many unknowns as coordinates, exact simulated data),
    and the median measures the fit's arithmetic, not the instrument's noise."""
    scale = robust_sigma(e)
    return scale if scale >= ZERO_SCALE else 1.0


def row_scores(
    residual: np.ndarray, noise: Noise, blocks: Sequence[Sequence[int]] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(distances [m], scores [robust σ, see :func:`robust_scale`]) of each of the m rows of a
    stacked (N,) residual: the largest over the row's markers (three coordinates each) or, for
    another kind, over its ``blocks`` of values (a distance is then the size of a block's values
    of its first value's unit)."""
    m = len(noise.std)
    if blocks is None:
        r3 = residual.reshape(m, -1, 3)  # (m, K, 3) points
        e3 = noise.whiten(residual).reshape(m, -1, 3)
        distances = np.linalg.norm(r3, axis=-1).max(axis=1)
        return distances, np.linalg.norm(e3, axis=-1).max(axis=1) / robust_scale(e3)
    r, e = residual.reshape(m, -1), noise.whiten(residual).reshape(m, -1)
    measured = e if noise.seen is None else e[noise.seen]
    scale = robust_scale(measured)
    head = [list(b[: 3 if len(b) == 6 else len(b)]) for b in blocks]  # a pose's size is its position's
    distance = np.stack([np.linalg.norm(r[:, h], axis=1) for h in head], axis=1).max(axis=1)
    score = np.stack([np.linalg.norm(e[:, list(b)], axis=1) for b in blocks], axis=1).max(axis=1) / scale
    return distance, score


def find_outliers(
    residual: np.ndarray,
    noise: Noise,
    labels: Sequence[str],
    threshold: float = OUTLIER_SCORE,
    blocks: Sequence[Sequence[int]] | None = None,
    unit: str = "m",
) -> tuple[Outlier, ...]:
    """The rows whose residual exceeds ``threshold`` robust σ, worst first (``blocks`` as
    :func:`row_scores`; ``unit`` that of the distances)."""
    distance, score = row_scores(residual, noise, blocks)
    rows = sorted(np.flatnonzero(score > threshold), key=lambda i: -score[i])
    return tuple(Outlier(int(i), labels[int(i)], float(distance[i]), float(score[i]), unit) for i in rows)


def implausible(params: ParameterSet, x: np.ndarray, before: float, after: float, sigma: float) -> list[str]:
    """What no real robot does, in words (empty when the result is plausible).

    Args:
        params: the set identified; x its values (errors relative to the nominal robot).
        before, after: residual RMS before and after calibration [m].
        sigma: the instrument's σ per coordinate [m].
    """
    robot = params.robot
    problems = []
    moves: dict[tuple[str, int], np.ndarray] = {}
    for p, v in zip(params, x, strict=True):
        if p.kind in ("placement", "marker") and (p.kind == "marker" or p.component < 3):
            moves.setdefault((p.kind, p.index), np.zeros(3))[p.component] = v
        elif p.kind in ("placement", "offset") and abs(v) > ANGLE_LIMIT and p.unit == "rad":
            problems.append(f"{p.name} changes by {np.degrees(v):.3g} degrees")
    for (kind, index), d in moves.items():
        size = float(np.linalg.norm(d))
        if kind == "marker" and size > TOOL_LIMIT:
            problems.append(f"marker {index} moves by {size * 1e3:.4g} mm in the tool frame")
        elif kind == "placement" and index >= robot.nq and size > TOOL_LIMIT:
            problems.append(f"the tool frame {robot.tip} moves by {size * 1e3:.4g} mm")
        elif kind == "placement" and index < robot.nq and size > LINK_LIMIT:
            problems.append(f"the origin of {robot.origins[index].name} moves by {size:.4g} m")
    for what, value, limit in (
        ("before", before, max(RESIDUAL_FACTOR * sigma, BEFORE_LIMIT)),
        ("after", after, RESIDUAL_FACTOR * sigma),
    ):
        if value > limit:
            problems.append(
                f"the residual {what} calibration is {value * 1e3:.4g} mm RMS, {value / sigma:.3g} times "
                f"the instrument's sigma ({sigma * 1e3:.3g} mm)"
            )
    return problems


def implausible_noise(before: float, after: float) -> list[str]:
    """What no real robot does, in words, for measurements other than points, from the RMS of
    their whitened residuals (in the instrument's standard deviations) before and after calibration."""
    problems = []
    for what, value in (("before", before), ("after", after)):
        if value > RESIDUAL_FACTOR:
            problems.append(
                f"the residual {what} calibration is {value:.3g} times the instrument's sigma (RMS)"
            )
    return problems


def _spread(points: np.ndarray) -> float:
    p = points.reshape(-1, 3)
    return float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))


ILL_CONDITIONED = 1e-3
"""Data conditioned below this (the conditioning every report gives; a design keeps its plans above
1e-2) can turn a little noise into values no robot has: a likely cause of an implausible fit whose
residuals are small."""

SMALL_ANGLES = 0.06
"""Revolute joint values all within this [rad] (3.4°) over several rows: radians read as degrees."""


def likely_causes(
    problem: Problem,
    z: np.ndarray,
    problems: list[str],
    conditioning: float = float("nan"),
    outliers: Sequence[Outlier] = (),
) -> list[str]:
    """The usual reasons for an implausible result, most likely first (at least one): units, the
    frame, joint units, outliers (by row), too few or ill-conditioned configurations (with the
    conditioning), a marker, column order.

    Args:
        problem, z: the problem and the fit's unknowns.
        problems: what no real robot has (:func:`implausible`).
        conditioning: the data's conditioning (NaN: unknown).
        outliers: the suspicious rows of the fit, worst first.
    """
    params, data = problem.params, problem.sessions[0]
    causes = _joint_units(problem)
    points = measured_points(data)
    if points is None:  # no positions measured: nothing to compare the robot's points with
        return (
            causes
            + _data_causes(problem, problems, conditioning, outliers)
            + [
                "joint columns or units: check that the joint columns hold the joints named in the header "
                "and their unit (--deg), the measured columns' units (--mm), and the instrument's nominal "
                "set-up (--anchor, --camera)"
            ]
        )
    nominal = params.robot.points(data.q, check=False).reshape(-1, 3)
    measured = points.reshape(-1, 3)
    spread_measured, spread_nominal = _spread(measured), _spread(nominal)
    # one point (or all at one place) has no spread: units cannot be told from it
    ratio = spread_measured / spread_nominal if spread_measured > 0 and spread_nominal > 0 else 1.0
    if ratio > 30:
        causes.append(
            f"units: the measured points spread {ratio:.3g} times wider than the robot's: millimetres "
            f"read as metres? try --mm (millimetres=True)"
        )
    elif ratio < 1 / 30:
        causes.append(
            f"units: the measured points spread {1 / ratio:.3g} times narrower than the robot's: metres "
            f"read as millimetres? drop --mm"
        )
    proper, mirror = fit_rms(nominal, measured), fit_rms(nominal, measured, mirror=True)
    if mirror < 0.1 * proper:
        causes.append(
            "column order: the points are a mirror image of the robot's (two coordinate columns "
            "swapped?): check the x,y,z columns"
        )
    raw = float(np.sqrt(np.mean(np.sum((measured - nominal) ** 2, axis=1))))
    if not problem.base and proper < 0.1 * raw:
        causes.append(
            "frame: a rigid motion explains most of the difference: the points are in the instrument's "
            "frame; pass --base (identify base.*)"
        )
    causes += _data_causes(problem, problems, conditioning, outliers) if not causes else []
    marker = None if causes or not problem.points else _marker_offset(problem, z)
    if not causes and (any("tool frame" in p or "marker" in p for p in problems) or marker is not None):
        where = f" (the data put it {marker * 1e3:.4g} mm from where the model has it)" if marker else ""
        causes.append(
            f"marker: the measured point is not where the model puts it on {params.robot.tip}{where}: "
            f"did you pass --marker X,Y,Z (markers=[...])?"
        )
    if not causes:
        causes.append(
            "column order or joint units: check that the joint columns hold the joints named in the "
            "header and their unit (--deg), and the x,y,z columns"
        )
    return causes


def _joint_units(problem: Problem) -> list[str]:
    """Radians read as degrees: every revolute joint value of several rows within a few degrees."""
    robot, data = problem.params.robot, problem.sessions[0]
    revolute = np.asarray(robot.revolute, dtype=bool)
    if data.m < 3 or not revolute.any():
        return []
    largest = float(np.abs(data.q[:, revolute]).max())
    if 0 < largest <= SMALL_ANGLES:
        return [
            f"joint units: every joint value is within {np.degrees(largest):.3g} degrees: radians read as "
            "degrees? drop --deg (degrees=False)"
        ]
    return []


def _data_causes(
    problem: Problem, problems: list[str], conditioning: float, outliers: Sequence[Outlier]
) -> list[str]:
    """Outliers (a few rows far beyond the rest) and too few or ill-conditioned configurations (the
    values wild, the residuals not)."""
    causes = []
    gross = [o for o in outliers if o.score > 2 * OUTLIER_SCORE]
    if gross and len(gross) <= max(1, problem.m // 5):
        rows = ", ".join(str(o) for o in gross[:3]) + (
            f" and {len(gross) - 3} more" if len(gross) > 3 else ""
        )
        causes.append(f"outliers: {rows}: drop them (--reject {OUTLIER_SCORE:g}, reject={OUTLIER_SCORE:g})")
    plausible_residuals = not any("the residual" in p for p in problems)
    if np.isfinite(conditioning) and conditioning < ILL_CONDITIONED and plausible_residuals:
        causes.append(
            f"too few or ill-conditioned configurations: these {problem.m} condition the parameters at "
            f"{conditioning:.2g} (a designed plan keeps above 1e-2), so the fit turns noise into values no "
            "robot has: measure more, or better chosen, configurations (pincal design, pincal next), or "
            "identify fewer parameters"
        )
    return causes


def _marker_offset(problem: Problem, z: np.ndarray) -> float | None:
    """The size of a marker offset that would explain most of the residual [m], or None."""
    if any(p.kind == "marker" for p in problem.params):
        return None
    data = problem.sessions[0]
    robot = problem.robot(z, 0)
    r = (data.points - ForwardKinematics(robot).markers(data.q, data.payload)).reshape(-1)
    J = np.hstack(
        [
            problem.jacobian(z)[: r.size, : len(problem.params)],
            robot.parameters("markers").jacobian(data.q, frame="world").reshape(r.size, -1),
        ]
    )
    step, *_ = np.linalg.lstsq(J, r, rcond=None)
    left = r - J @ step
    offsets = step[len(problem.params) :].reshape(-1, 3)
    size = float(np.linalg.norm(offsets, axis=1).max())
    if np.linalg.norm(left) < 0.1 * np.linalg.norm(r) and size > 0.01:
        return size
    return None
