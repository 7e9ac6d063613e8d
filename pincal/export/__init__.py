"""Export and deployment: what a calibration leaves for the robot's own stack — the calibrated URDF
and its sidecar (:mod:`.urdf`), MJCF for MuJoCo (:mod:`.mjcf`, through :mod:`._urdf_to_mjcf`), SDF
for Gazebo (:mod:`.sdf`), a xacro wrapper of the original description (:mod:`.xacro`) and the
ROS 2 files (:mod:`.ros`: ros2_control joint offsets, robot_calibration's YAML). Comes after
calibration (it reads an :class:`~pincal.calibration.result.IdentificationResult`); compensation
reads its files back."""

from pincal.export.mjcf import export_mjcf
from pincal.export.sdf import export_sdf
from pincal.export.urdf import export_urdf
from pincal.export.xacro import export_xacro

__all__ = ["export_mjcf", "export_sdf", "export_urdf", "export_xacro"]
