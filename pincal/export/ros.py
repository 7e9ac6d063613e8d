"""A calibration in the files ROS tools read: ros2_control's joint offsets and ROS
robot_calibration's offsets YAML (docs/method.md §5.10).

**ros2_control** (:func:`ros2_control_text`). A joint offset is read from the ``<offset>`` of a
``<joint>`` in a ``<transmission>`` of the ``<ros2_control>`` block (hardware_interface's URDF
parser fills ``JointInfo::offset`` and ``mechanical_reduction`` from it);
``transmission_interface/SimpleTransmission`` then gives the joint position as
x_j = x_a / n + offset. pincal's joint stands at q·(1 + gain) + Δq when it reads q, so the offset is
Δq and a gain scales the reduction: n' = n / (1 + gain) (the file gives the factor
1 / (1 + gain) to multiply your reduction by). The same offsets are written as URDF
``<calibration rising="Δq"/>`` of each joint, the place ROS robot_calibration writes them and some
drivers read them (added to the joint reading). These offsets go with the calibrated origins
*without* the offsets folded in (``joints.*.origin`` of ``--format yaml``): with the calibrated URDF,
whose origins hold them already, apply none.

**robot_calibration** (:func:`robot_calibration_text`; mikeferguson/robot_calibration, its
``OptimizationOffsets``): one ``name: value`` line per parameter. A joint's offset is its name
(added to the joint reading); a frame ``F`` is ``F_x, F_y, F_z`` [m] and ``F_a, F_b, F_c``, an
angle-axis vector [rad], composed on the right of the joint's origin: origin' = origin·offset. Each
chain joint and the tool's fixed joint is written as a frame (the calibrated origin relative to the
source's) and each chain joint with its offset. Markers, base and gains have no place there: they
are in comments. Its ``calibrate`` node loads such a file as its starting point
(``OptimizationOffsets::loadOffsetYAML``) and its ``updateURDF`` turns it into a calibrated URDF.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pincal.calibration.corrections import Corrections
from pincal.version import __version__


def _number(value: float) -> str:
    return repr(float(value) + 0.0)


def ros2_control_text(corrections: Corrections) -> str:
    """The joint offsets as a ros2_control ``<transmission>`` per joint and as URDF
    ``<calibration rising>`` elements, in one XML file (root ``<pincal_ros2_control>``: snippets
    to copy into the description, see the module doc)."""
    robot = corrections.robot
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- Joint offsets of {robot.name} (calibrated by pincal {__version__} from "
        f"{corrections.source.name}), for ros2_control: copy each <transmission> into your "
        "<ros2_control> block (SimpleTransmission: joint = actuator / reduction + offset; multiply "
        "your own reduction by the factor given), or each <calibration rising> into its URDF <joint>. "
        "Use them with the calibrated origins WITHOUT the offsets folded in (pincal export "
        "format yaml, joints.*.origin): the calibrated URDF already holds them. -->",
        f'<pincal_ros2_control robot="{robot.name}" source="{corrections.source.name}">',
        f'  <ros2_control name="{robot.name}_calibration" type="system">',
    ]
    for k, joint in enumerate(corrections.joints, start=1):
        factor = 1.0 / (1.0 + joint.gain)
        lines += [
            f'    <transmission name="{joint.name}_transmission">',
            "      <plugin>transmission_interface/SimpleTransmission</plugin>",
            f'      <actuator name="{joint.name}_actuator" role="actuator{k}"/>',
            f'      <joint name="{joint.name}" role="joint{k}">',
            f"        <offset>{_number(joint.offset)}</offset>",
            f"        <mechanical_reduction>{_number(factor)}</mechanical_reduction>",
            "      </joint>",
            "    </transmission>",
        ]
    lines.append("  </ros2_control>")
    lines += [
        f'  <joint name="{joint.name}"><calibration rising="{_number(joint.offset)}"/></joint>'
        for joint in corrections.joints
    ]
    lines += ["</pincal_ros2_control>", ""]
    return "\n".join(lines)


def frame_offset(nominal: pin.SE3, calibrated: pin.SE3) -> dict[str, float]:
    """robot_calibration's frame offset of an origin: ``{x, y, z, a, b, c}``, the placement
    nominal⁻¹·calibrated as a translation [m] and an angle-axis vector [rad]."""
    change = nominal.inverse() * calibrated
    x, y, z = change.translation.tolist()
    a, b, c = pin.log3(change.rotation).tolist()
    return {"x": x, "y": y, "z": z, "a": a, "b": b, "c": c}


def robot_calibration_text(corrections: Corrections) -> str:
    """The calibration as robot_calibration's offsets file (see the module doc)."""
    robot = corrections.robot
    lines = [
        f"# robot_calibration offsets of {robot.name}, calibrated by pincal {__version__} from "
        f"{corrections.source.name}",
        "# joint: offset added to the reading [rad or m]; JOINT_x/_y/_z [m], JOINT_a/_b/_c (angle-axis,",
        "# rad): the origin's correction, origin' = origin * offset. Not representable here: see below.",
    ]
    frames = [(j.name, j.nominal, j.origin) for j in corrections.joints]
    if corrections.tool is not None:
        frames.append((corrections.tool.joint, corrections.tool.nominal, corrections.tool.origin))
    lines += [f"{j.name}: {_number(j.offset)}" for j in corrections.joints]
    for name, nominal, origin in frames:
        lines += [f"{name}_{key}: {_number(value)}" for key, value in frame_offset(nominal, origin).items()]
    markers = "; ".join(" ".join(f"{v:.9g}" for v in m) for m in corrections.markers)
    base = corrections.base
    lines += [
        f"# markers (in {robot.tip}, m): {markers}",
        "# base (robot in the instrument frame): xyz "
        + " ".join(f"{v + 0.0:.9g}" for v in base.translation)
        + " rpy "
        + " ".join(f"{v + 0.0:.9g}" for v in pin.rpy.matrixToRpy(base.rotation)),
    ]
    gains = np.array([j.gain for j in corrections.joints])
    if gains.any():
        lines.append(
            "# joint gains (reading * (1 + gain)): "
            + ", ".join(f"{j.name} {j.gain:.9g}" for j in corrections.joints)
        )
    return "\n".join(lines) + "\n"
