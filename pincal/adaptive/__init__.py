"""The adaptive loop, after calibration: the next poses to measure from the data so far
(:mod:`.loop`: :func:`next_poses`, the measured poses as a prior in :mod:`.measured`) and simulated
campaigns of it against a one-shot plan (:mod:`.rehearsal`). It uses an identification's result, so
it sits above calibration (docs/method.md §12)."""

from pincal.adaptive.loop import NextPoses, next_poses
from pincal.adaptive.measured import MeasuredPrior

__all__ = ["MeasuredPrior", "NextPoses", "next_poses"]
