"""Moved to :mod:`pincal.export.ros` in 0.2 (export and deployment have their own stage, after
calibration): the names still work from here, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_from

__getattr__ = moved_from(
    __name__,
    {
        "pincal.export.ros": (
            "ros2_control_text",
            "frame_offset",
            "robot_calibration_text",
        ),
    },
)
