"""Moved to :mod:`pincal.adaptive.loop` in 0.2 (the adaptive loop has its own stage, after
calibration): the names still work from here, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_from

__getattr__ = moved_from(
    __name__,
    {
        "pincal.adaptive.loop": (
            "MATCH_TOLERANCE",
            "AVOID_DISTANCE",
            "SIGMA_SOURCES",
            "NextPoses",
            "unmeasured",
            "Assessment",
            "assess",
            "next_poses",
        ),
    },
)
