"""Moved to :mod:`pincal.export.xacro` in 0.2 (export and deployment have their own stage, after
calibration): the names still work from here, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_from

__getattr__ = moved_from(
    __name__,
    {
        "pincal.export.xacro": (
            "ARGUMENTS",
            "ROUND_TRIP_TOLERANCE",
            "CONFIGURATIONS",
            "corrections_path",
            "wrapper_text",
            "export_xacro",
        ),
    },
)
