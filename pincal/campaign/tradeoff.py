"""Accuracy against campaign time: what each more pose costs, and what it buys
(docs/method.md §12.6).

For m = 6 … 30 poses, :func:`accuracy_vs_time` designs the plan of m poses (as
:func:`pincal.design`, same options), orders it into a campaign (:func:`plan_campaign`, order and
time: the moves are not checked) and reports the predicted error over the test region next to the
campaign's minutes — so a user picks m knowing the price in robot downtime. Sizes too small to
identify the parameters (without a prior) are left out and named.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from pincal.arguments import positive_int
from pincal.campaign.schedule import plan_campaign
from pincal.campaign.timing import Timing
from pincal.deprecation import moved_keywords
from pincal.errors import BadArgument, PincalError
from pincal.evaluation.prior import Prior
from pincal.instruments.given import keywords, measured
from pincal.instruments.instrument import Instrument
from pincal.model.parameters import ParameterSet
from pincal.planning.constraints import with_safety
from pincal.planning.driver import design
from pincal.planning.options import FLAT, Safety, Search, check_value, regroup
from pincal.planning.plan import Plan
from pincal.typing import JointValues, TestPoseLike

DEFAULT_SIZES = (6, 8, 10, 12, 15, 18, 21, 24, 27, 30)

MAX_SIZES = 50
"""The most plan sizes a trade-off designs: each size is a full design."""
"""The plan sizes of the trade-off by default (m = 6 … 30)."""


@dataclass(frozen=True, eq=False)
class TradeoffRow:
    """One plan size.

    Attributes:
        m: poses.
        predicted: the predicted error over the test region after calibration [m] (root mean square).
        minutes: the campaign's time from home and back [min].
        plan: the designed plan.
    """

    m: int
    predicted: float
    minutes: float
    plan: Plan


@dataclass(frozen=True, eq=False)
class Tradeoff:
    """Accuracy against campaign time (see the module doc).

    Attributes:
        rows: one per plan size, by m.
        skipped: the sizes left out, with why.
        timing: the time model of the campaigns.
        sigma: the noise of the predictions [m].
    """

    rows: tuple[TradeoffRow, ...]
    skipped: tuple[tuple[int, str], ...]
    timing: Timing
    sigma: float

    def as_dict(self) -> dict:
        return {
            "rows": [{"m": r.m, "predicted": r.predicted, "minutes": r.minutes} for r in self.rows],
            "skipped": [{"m": m, "why": why} for m, why in self.skipped],
            "timing": self.timing.as_dict(),
            "sigma": self.sigma,
        }

    def lines(self) -> list[str]:
        out = [
            "accuracy against campaign time (predicted error over the test region after calibration; "
            "campaign from home and back):",
            f"  {self.timing.describe()}",
            f"  {'m':>4} {'error':>11} {'minutes':>8}",
        ]
        for r in self.rows:
            out.append(f"  {r.m:>4} {r.predicted * 1e3:>8.4g} mm {r.minutes:>8.3g}")
        for m, why in self.skipped:
            out.append(f"  {m:>4} left out: {why}")
        return out


def parse_sizes(text: str) -> tuple[int, ...]:
    """``6:30:3`` (start:stop:step, stop included), ``6,8,12`` or ``12``: plan sizes, at most
    :data:`MAX_SIZES` of them."""
    text = str(text).strip()
    try:
        if ":" in text:
            parts = [int(p) for p in text.split(":")]
            if len(parts) not in (2, 3) or (len(parts) == 3 and parts[2] < 1):
                raise ValueError
            start, stop, step = parts[0], parts[1], parts[2] if len(parts) == 3 else 1
            # at most one size beyond the bound: never a range too long to count
            sizes = tuple(range(start, min(stop, start + MAX_SIZES * step) + 1, step))
        else:
            sizes = tuple(int(p) for p in text.split(","))
    except ValueError:
        sizes = ()
    if len(set(sizes)) > MAX_SIZES:
        raise BadArgument(
            f"plan sizes {text!r}: more than {MAX_SIZES} sizes (each is a design); give 1 to {MAX_SIZES} "
            "sizes, e.g. 6:30:3",
            argument="sizes",
            value=text,
            valid=(1, MAX_SIZES),
        )
    if not sizes or min(sizes) < 1:
        raise BadArgument(
            f"plan sizes {text!r}: expected START:STOP[:STEP] (e.g. 6:30:3), or M1,M2,... (integers > 0)",
            argument="sizes",
            value=text,
        )
    return tuple(sorted(set(sizes)))


@moved_keywords(FLAT, functools.partial(regroup, function="accuracy_vs_time"))
def accuracy_vs_time(
    params: ParameterSet,
    test_pose: TestPoseLike,
    sizes: Iterable[int] = DEFAULT_SIZES,
    *,
    timing: Timing | None = None,
    home: JointValues | None = None,
    sigma: float | None = None,
    instrument: Instrument | None = None,
    prior: Prior | None = None,
    search: Search | None = None,
    safety: Safety | None = None,
    **options: Any,  # passed on to design(), which checks each
) -> Tradeoff:
    """The predicted error over the test region and the campaign time for each plan size.

    Args:
        params: the parameters identified.
        test_pose: where the robot works (test pose(s), a region, a path).
        sizes: the plan sizes (default :data:`DEFAULT_SIZES`, 6 … 30).
        timing: the campaign's time model (default: the URDF's speeds, a laser tracker's dwell).
        home: where each campaign starts and ends (see :func:`plan_campaign`).
        sigma, instrument, prior: as :func:`pincal.design`'s (what each plan measures and how
            well: its instrument's rows set the fewest poses that identify the parameters).
        search: how each plan is searched (:class:`pincal.Search`), as :func:`pincal.design`'s.
        safety: how each plan is kept safe (:class:`pincal.Safety`), as :func:`pincal.design`'s;
            its constraints, with the safe defaults, are also those each campaign is ordered with.
        options: more :func:`pincal.design` keywords (``criterion``, ``loads``, ``instrument``, ...).
            The flat keywords of pincal 0.1 (``starts=``, ``constraints=``, ...) keep working until
            pincal 0.3, with a DeprecationWarning.

    Raises:
        BadArgument: a size that is not a positive integer, more than :data:`MAX_SIZES` sizes, or a
            bad design option.
    """
    robot = params.robot
    sizes = tuple(sorted({positive_int(m, "plan size") for m in sizes}))
    if len(sizes) > MAX_SIZES:
        raise BadArgument(
            f"{len(sizes)} plan sizes: at most {MAX_SIZES} (each is a design)",
            argument="sizes",
            value=len(sizes),
            valid=(1, MAX_SIZES),
        )
    timing = Timing.for_robot(robot) if timing is None else timing
    safety = Safety() if safety is None else safety
    check_value(safety, Safety, "safety")
    constraints = with_safety(
        robot, safety.constraints, safety.joint_margin, safety.mount, clearance=safety.clearance
    )
    kept = Safety(constraints=constraints, min_conditioning=safety.min_conditioning)
    rows, skipped = [], []
    instrument, sigma = measured(instrument, sigma)
    rows_each = 3 * robot.n_markers if instrument is None else instrument.kind.size(robot)
    minimum = -(-len(params) // rows_each)
    how = keywords(instrument, sigma)
    for m in sizes:
        if prior is None and m < minimum:
            skipped.append((m, f"fewer than the {minimum} poses that identify the {len(params)} parameters"))
            continue
        try:
            result = design(
                params,
                m,
                test_pose,
                prior=prior,
                search=search,
                safety=kept,
                **how,
                **options,
            )
        except PincalError as exc:
            skipped.append((m, str(exc).split(";")[0]))
            continue
        campaign = plan_campaign(
            robot, result.plan, home=home, timing=timing, constraints=constraints, check=False
        )
        predicted = result.rho0 if result.rho0 is not None else math.nan
        rows.append(TradeoffRow(m, float(predicted), campaign.total / 60.0, result.plan))
    return Tradeoff(tuple(rows), tuple(skipped), timing, float(sigma))
