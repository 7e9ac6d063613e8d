"""Moved to :mod:`pincal.adaptive.rehearsal` in 0.2 (the adaptive loop has its own stage, after
calibration): the names still work from here, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_from

__getattr__ = moved_from(
    __name__,
    {
        "pincal.adaptive.rehearsal": (
            "Faults",
            "Rehearsal",
            "one_shot_plan",
            "rehearse",
            "summary",
        ),
    },
)
