"""What an accuracy report holds (:func:`pincal.evaluation.accuracy`): the summary of the predicted
errors over one set of configurations (:class:`ErrorSummary`), one plan's summaries
(:class:`PlanAccuracy`) and the report of a plan and the plans it is compared with
(:class:`AccuracyReport`, with its text table)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.evaluation.predicted_error import WorstFound
from pincal.evaluation.prior import Prior


def _order_statistics(R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(median, 95th percentile, maximum) of each row of R (k, n), n ≥ 1, from one sort: NumPy's
    numbers (``numpy.median``: the middle value, or the mean of the middle two;
    ``numpy.percentile``'s linear interpolation at (n − 1)·0.95, in its arithmetic), for a
    fraction of the time of its quantile machinery."""
    S = np.sort(R, axis=1)
    n = S.shape[1]
    half = n // 2
    median = S[:, half] if n % 2 else (S[:, half - 1] + S[:, half]) / 2
    at = (n - 1) * 0.95
    below = math.floor(at)
    t = at - below
    a, b = S[:, below], S[:, min(below + 1, n - 1)]
    step = b - a
    p95 = b - step * (1 - t) if t >= 0.5 else a + step * t
    return median, p95, S[:, -1]


@dataclass(frozen=True)
class ErrorSummary:
    """Predicted errors over a set of configurations [m].

    Attributes:
        where: what the set is (``"test pose"``, ``"±10°"``, ``"region ±10°"`` (within 10° of the
            region's samples: up to 10° beyond its edge), ``"workspace"``, ...).
        n: configurations.
        rms: root mean square (the square root of the mean criterion).
        median, p95, max: of ρ over the set.
    """

    where: str
    n: int
    rms: float
    median: float
    p95: float
    max: float

    @classmethod
    def of(cls, where: str, rho: np.ndarray) -> ErrorSummary:
        return cls(
            where,
            len(rho),
            float(np.sqrt(np.mean(rho**2))),
            float(np.median(rho)),
            float(np.percentile(rho, 95)),
            float(rho.max()),
        )

    @classmethod
    def of_rows(cls, rows: list[tuple[str, np.ndarray]]) -> list[ErrorSummary]:
        """:meth:`of` each ``(where, ρ)`` of ``rows``, the same numbers, the rows of one length
        summarised together from one sort (:func:`_order_statistics`)."""
        out: list[ErrorSummary | None] = [None] * len(rows)
        by_length: dict[int, list[int]] = {}
        for i, (_, rho) in enumerate(rows):
            by_length.setdefault(len(rho), []).append(i)
        for n, which in by_length.items():
            if n == 1:  # one value r (one test pose): rms sqrt(r²/1), and r its median, p95 and max
                for i in which:
                    r = float(rows[i][1][0])
                    out[i] = cls(rows[i][0], 1, math.sqrt(r * r / 1), r, r, r)
                continue
            R = np.stack([rows[i][1] for i in which])
            # NumPy's mean: the pairwise sum along each row, then one division
            columns = (np.sqrt(np.add.reduce(R * R, axis=1) / n), *_order_statistics(R))
            for i, values in zip(which, zip(*(c.tolist() for c in columns)), strict=True):
                out[i] = cls(rows[i][0], n, *values)
        return out  # type: ignore[return-value]  # every row summarised

    def as_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass(frozen=True)
class PlanAccuracy:
    """Where one plan leaves the robot accurate.

    Attributes:
        name: ``"plan"``, ``"D-optimal"``, ...
        rows: the summaries at the test pose(s), over each neighbourhood and over the workspace.
        worst: the worst found over the test region (None for plain test poses).
        from_measurements, from_prior: rms ρ0 at the test pose(s) due to the measurement noise and
            due to the prior errors the plan leaves uncorrected [m] (their squares add up to the
            test-pose row's rms²); ``from_prior`` is 0 without a prior.
        from_residual_model: for a calibration's report
            (:meth:`~pincal.IdentificationResult.accuracy`), the rms at the test pose(s) of its
            residual model's posterior variance [m] (0 without a residual model;
            ``from_measurements`` is then its parameters' standard errors' part); None for a plan.
            Without a residual model, what the fitted model does not explain (the residual level
            beyond the instrument's noise, docs/method.md §11.6).
        unexplained: what ``from_residual_model`` is, in words.
    """

    name: str
    rows: tuple[ErrorSummary, ...]
    worst: WorstFound | None
    from_measurements: float
    from_prior: float
    from_residual_model: float | None = None
    unexplained: str = "the residual model's variance (what it cannot explain there)"

    def row(self, where: str) -> ErrorSummary:
        return next(r for r in self.rows if r.where == where)

    def as_dict(self) -> dict:
        return {
            "name": self.name,
            "rows": [r.as_dict() for r in self.rows],
            "worst_found": None if self.worst is None else self.worst.as_dict(),
            "from_measurements": self.from_measurements,
            "from_prior": self.from_prior,
            "from_residual_model": self.from_residual_model,
        }


@dataclass(frozen=True)
class AccuracyReport:
    """Predicted accuracy after calibration, at and away from the test pose(s), for a plan and
    the plans it is compared with (see :func:`accuracy`).

    Attributes:
        plans: one :class:`PlanAccuracy` per plan (the plan first).
        sigma: measurement noise per coordinate [m].
        prior: the prior, or None.
        before: rms error at the test pose(s) before calibration, predicted by the prior
            (sqrt of the mean tr(J₀ΣpJ₀ᵀ)) [m]; None without a (finite) prior.
        region: description of the test region (or ``"test pose"``).
        revolute: which joints are revolute (poses in degrees convert those only), or None: all.
    """

    plans: tuple[PlanAccuracy, ...]
    sigma: float
    prior: Prior | None
    before: float | None
    region: str
    revolute: tuple[bool, ...] | None = None
    residual_model: bool = False

    def as_dict(self) -> dict:
        return {
            "plans": [p.as_dict() for p in self.plans],
            "sigma": self.sigma,
            "prior": None if self.prior is None else self.prior.as_dict(),
            "before_calibration": self.before,
            "region": self.region,
            "residual_model": self.residual_model,
        }

    def _pose_text(self, pose: np.ndarray, degrees: bool) -> str:
        """'10, -50, 70 deg', or each value with its unit when some joints are prismatic."""
        angle_unit = "deg" if degrees else "rad"
        values = np.degrees(pose) if degrees else pose
        if self.revolute is None or all(self.revolute):
            return ", ".join(f"{v:.4g}" for v in values) + f" {angle_unit}"
        return ", ".join(
            f"{v:.4g} {angle_unit}" if r else f"{q:.4g} m" for v, q, r in zip(values, pose, self.revolute)
        )

    def lines(self, unit: str = "mm", degrees: bool = False) -> list[str]:
        """The report as text lines (a table: one column pair per plan); worst poses in radians,
        or degrees."""
        scale = {"mm": 1e3, "m": 1.0, "um": 1e6}[unit]
        names = [p.name for p in self.plans]
        head = f"  {'predicted error after calibration [' + unit + ']':<44}" + "".join(
            f"{n:>22}" for n in names
        )
        out = [head, f"  {'':<44}" + "".join(f"{'rms':>11}{'p95':>11}" for _ in names)]
        for i, row in enumerate(self.plans[0].rows):
            label = row.where + (" (median, p95)" if row.where == "workspace" else "")
            cells = []
            for p in self.plans:
                r = p.rows[i]
                first = r.median if row.where == "workspace" else r.rms
                cells.append(f"{first * scale:11.4g}{r.p95 * scale:11.4g}")
            out.append(f"  {label:<44}" + "".join(cells))
        for p in self.plans:
            if p.worst is not None:
                out.append(
                    f"  {p.name}: worst {'found' if p.worst.searched else 'of the test poses'} "
                    f"{p.worst.rho * scale:.4g} {unit} at q = {self._pose_text(p.worst.pose, degrees)}"
                )
        if self.residual_model:
            out.append(
                "  with the residual model of an earlier calibration: the expected error when the parameters "
                "and the residual are estimated together from each plan (its variance included)"
            )
        for p in self.plans:
            if p.from_residual_model is None:
                continue
            if p.from_residual_model > 0:
                out.append(
                    f"  {p.name}: at the test pose(s), {p.from_measurements * scale:.4g} {unit} rms from "
                    f"the parameters' standard errors and {p.from_residual_model * scale:.4g} {unit} "
                    f"from {p.unexplained}"
                )
            else:
                out.append(
                    f"  {p.name}: from the parameters' standard errors alone (no residual model, and the "
                    "residuals are within the noise: the fitted model explains the data)"
                )
        if self.prior is not None:
            p = self.plans[0]
            out.append(
                f"  prior {self.prior}: at the test pose(s), {p.from_measurements * scale:.4g} {unit} rms "
                f"from the measurements and {p.from_prior * scale:.4g} {unit} from the prior"
                + ("" if self.before is None else f" (before calibration: {self.before * scale:.4g} {unit})")
            )
        return out
