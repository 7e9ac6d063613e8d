"""Moved to :mod:`pincal.export.sdf` in 0.2 (export and deployment have their own stage, after
calibration): the names still work from here, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_from

__getattr__ = moved_from(
    __name__,
    {
        "pincal.export.sdf": (
            "SDF_VERSION",
            "MARKER_FRAME",
            "ROUND_TRIP_TOLERANCE",
            "JOINT_TYPES",
            "export_sdf",
            "sdf_text",
            "sdf_points",
        ),
    },
)
