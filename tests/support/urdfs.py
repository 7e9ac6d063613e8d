"""URDF and xacro sources as users bring them, written here (issue 11): a tree with two arms, a hand and
a camera, bare chains from joints, a xacro arm. Shared by tests of several stages."""

from __future__ import annotations


def joint_xml(name, kind, parent, child, xyz="0 0 0", rpy="0 0 0", axis="0 0 1", limits=(-2.0, 2.0)):
    """One URDF joint (limits for every kind but fixed and continuous)."""
    limit = (
        ""
        if kind in ("fixed", "continuous")
        else f'<limit lower="{limits[0]}" upper="{limits[1]}" effort="1" velocity="1"/>'
    )
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}</joint>'
    )


def urdf(name: str, links: list[str], joints: list[str]) -> str:
    """A URDF of bare links and the joints given (made with :func:`joint_xml`)."""
    body = "".join(f'<link name="{link}"/>' for link in links)
    return f'<?xml version="1.0"?><robot name="{name}">{body}{"".join(joints)}</robot>'


def tree_urdf(arm2: bool = False, continuous: bool = True, zero: bool = False, mesh: str = "") -> str:
    """A trunk with a 4-joint arm (joint a2 continuous), a hand with two fingers and a tcp, a
    camera on the trunk, and optionally a second arm."""
    links = ["trunk", "l1", "l2", "l3", "l4", "hand", "tcp", "left_finger", "right_finger", "camera"]
    joints = [
        joint_xml("a1", "revolute", "trunk", "l1", "0 0 0.4"),
        joint_xml(
            "a2",
            "continuous" if continuous else "revolute",
            "l1",
            "l2",
            "0 0.1 0.3",
            "1.5707963267948966 0 0",
        ),
        joint_xml(
            "a3", "revolute", "l2", "l3", "0.5 0 0", axis="0 0 1", limits=(0, 0) if zero else (-2.0, 2.0)
        ),
        joint_xml("a4", "revolute", "l3", "l4", "0.4 0 0.05", "0 1.5707963267948966 0"),
        joint_xml("hand_mount", "fixed", "l4", "hand", "0 0 0.1"),
        joint_xml("tcp_joint", "fixed", "hand", "tcp", "0 0 0.12"),
        joint_xml(
            "finger_left", "prismatic", "hand", "left_finger", "0 0.02 0.05", axis="0 1 0", limits=(0, 0.04)
        ),
        joint_xml(
            "finger_right",
            "prismatic",
            "hand",
            "right_finger",
            "0 -0.02 0.05",
            axis="0 -1 0",
            limits=(0, 0.04),
        ),
        joint_xml("camera_joint", "fixed", "trunk", "camera", "0.1 0 0.6"),
    ]
    if arm2:
        links += ["b1", "b2", "b_tool"]
        joints += [
            joint_xml("b1", "revolute", "trunk", "b1", "0 0.3 0.4"),
            joint_xml("b2", "revolute", "b1", "b2", "0.4 0 0", axis="0 1 0"),
            joint_xml("b_tool_joint", "fixed", "b2", "b_tool", "0.3 0 0"),
        ]
    visual = f'<visual><geometry><mesh filename="{mesh}"/></geometry></visual>' if mesh else ""
    body = "".join(f'<link name="{name}">{visual if name == "l1" else ""}</link>' for name in links)
    return f'<?xml version="1.0"?><robot name="tree">{body}{"".join(joints)}</robot>'


XACRO_ARM = """<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="xarm">
  <xacro:property name="l" value="0.4"/>
  <xacro:macro name="revolute" params="name parent child xyz axis">
    <joint name="${name}" type="revolute"><parent link="${parent}"/><child link="${child}"/>
      <origin xyz="${xyz}"/><axis xyz="${axis}"/>
      <limit lower="${-pi/2}" upper="${pi/2}" effort="1" velocity="1"/></joint>
  </xacro:macro>
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tool0"/>
  <xacro:revolute name="j1" parent="base" child="l1" xyz="0 0 ${l}" axis="0 0 1"/>
  <xacro:revolute name="j2" parent="l1" child="l2" xyz="${l} 0 0" axis="0 1 0"/>
  <joint name="t" type="fixed"><parent link="l2"/><child link="tool0"/><origin xyz="${l/2} 0 0"/></joint>
</robot>
"""
