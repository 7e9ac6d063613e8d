"""From a plan to a campaign: the order a technician runs the poses in, each move checked, how
long it takes, accuracy against time (docs/method.md §12).

A campaign uses a plan and sits above planning, before anything is measured: timing.py (move times,
settle, dwell), ordering.py (Held–Karp, 2-opt/Or-opt), motion.py (moves certified collision-free,
detours), line_of_sight.py, schedule.py (:func:`plan_campaign`), result.py (the campaign),
tradeoff.py (:func:`accuracy_vs_time`). The next poses from the data so far are the adaptive loop's,
after calibration: :mod:`pincal.adaptive`.
"""

from pincal.campaign.result import Campaign, Move
from pincal.campaign.schedule import plan_campaign
from pincal.campaign.timing import DWELLS, Timing
from pincal.campaign.tradeoff import Tradeoff, accuracy_vs_time
from pincal.deprecation import moved_from

__all__ = [
    "DWELLS",
    "Campaign",
    "Move",
    "Timing",
    "Tradeoff",
    "accuracy_vs_time",
    "plan_campaign",
]

__getattr__ = moved_from(__name__, {"pincal.adaptive": ("MeasuredPrior", "NextPoses", "next_poses")})
"""Names that moved to :mod:`pincal.adaptive` (the adaptive loop's own stage) in 0.2."""
