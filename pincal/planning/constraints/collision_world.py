"""Moved: the collision world is :mod:`pincal.model.collision`, beside the robot's geometry and
kinematics. Its names read from here still work, with a DeprecationWarning, until pincal 0.3."""

from pincal.deprecation import moved_module

__getattr__ = moved_module(
    __name__,
    "pincal.model.collision",
    (
        "LINK_RADIUS",
        "MARKER_RADIUS",
        "REFINE_BELOW",
        "TOUCHING",
        "CollisionWorld",
        "Pair",
        "RobotGeometry",
        "capsule_geometry",
        "motion_weights",
        "reach",
        "robot_geometry",
        "segment_placement",
        "touching_at_reference",
        "with_exact",
    ),
)
