"""From a plan to a campaign: the order a technician runs the poses in, each move checked, how
long it takes, accuracy against time, and the next poses to measure from the data so far
(docs/method.md §12).

A campaign uses a plan and sits above planning (and calibration, for the adaptive loop):
timing.py (move times, settle, dwell), ordering.py (Held–Karp, 2-opt/Or-opt), motion.py (moves
certified collision-free, detours), line_of_sight.py, schedule.py (:func:`plan_campaign`),
tradeoff.py (:func:`accuracy_vs_time`), measured.py (:class:`MeasuredPrior`), adaptive.py
(:func:`next_poses`), rehearsal.py (simulated campaigns, adaptive against one-shot).
"""

from pincal.campaign.adaptive import NextPoses, next_poses
from pincal.campaign.measured import MeasuredPrior
from pincal.campaign.result import Campaign, Move
from pincal.campaign.schedule import plan_campaign
from pincal.campaign.timing import DWELLS, Timing
from pincal.campaign.tradeoff import Tradeoff, accuracy_vs_time

__all__ = [
    "DWELLS",
    "Campaign",
    "MeasuredPrior",
    "Move",
    "NextPoses",
    "Timing",
    "Tradeoff",
    "accuracy_vs_time",
    "next_poses",
    "plan_campaign",
]
