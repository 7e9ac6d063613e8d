"""Moved to :mod:`pincal.export.urdf` in 0.2 (export and deployment have their own stage, after
calibration): the names still work from here, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_from

__getattr__ = moved_from(
    __name__,
    {
        "pincal.export.urdf": (
            "ROUND_TRIP_TOLERANCE",
            "sidecar_path",
            "sidecar",
            "export_urdf",
            "check_reproduces",
            "placement_text",
        ),
    },
)
