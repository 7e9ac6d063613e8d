"""A calibrated robot loaded from a URDF, written as a new MuJoCo XML file.

Unlike MuJoCo's own URDF import (which ignores ``<calibration>`` and fuses fixed links into their
parents unless ``<compiler fusestatic="false"/>``), every link becomes a body, fixed links
included (so a tool frame stays a frame), placed by its joint's ``<origin>``; the chain joints get
their calibrated origin and their offset δ as ``ref = −δ`` (``offsets="ref"``) or folded into the
origin (``"fold"``). Angles are written in radians (``<compiler angle="radian">``). Revolute joints
become hinges, prismatic ones slides, with their URDF limits as ``range`` (continuous joints: no
range); a floating joint becomes a ``freejoint``. Inertias are kept (``fullinertia``); visual
shapes are kept as geoms that do not collide (boxes, cylinders, spheres, and the STL/OBJ meshes
found; other mesh formats are left out). The markers are sites on the tip's body and the base is
the root body's placement.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal.errors import UrdfError
from pincal.model.mjcf import quat_text, vector_text
from pincal.model.robot import Robot
from pincal.model.urdf import read_tree, resolve_mesh

MESH_FORMATS = (".stl", ".obj")
"""Mesh files MuJoCo reads (others are left out of the geometry)."""
NO_MASS = 1e-9
"""Mass [kg] of a link the URDF gives none (MuJoCo needs one on a moving body)."""
NO_INERTIA = 1e-15
"""Principal inertia [kg·m²] of a link the URDF gives none."""


def _origin(element: etree._Element | None) -> pin.SE3:
    origin = None if element is None else element.find("origin")
    if origin is None:
        return pin.SE3.Identity()
    xyz = [float(v) for v in (origin.get("xyz") or "0 0 0").split()]
    rpy = [float(v) for v in (origin.get("rpy") or "0 0 0").split()]
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))


def _place(element: etree._Element, value: pin.SE3) -> None:
    if not value.isApprox(pin.SE3.Identity(), 1e-15):
        element.set("pos", vector_text(value.translation))
        element.set("quat", quat_text(value.rotation))


def urdf_to_mjcf(
    robot: Robot, src: Path, out: Path, offsets: str, comment: str
) -> tuple[str, np.ndarray, pin.SE3]:
    """The MJCF text of ``robot`` (loaded from the URDF ``src``), its markers in the tip frame and
    the sidecar's base (see module doc)."""
    urdf = read_tree(src, dict(robot.package_dirs))
    links = {str(link.get("name")): link for link in urdf.findall("link")}
    joints = [j for j in urdf.findall("joint")]
    child_of = {str(j.find("child").get("link")): j for j in joints if j.find("child") is not None}  # type: ignore[union-attr]
    children: dict[str, list[etree._Element]] = {}
    for joint in joints:
        parent = joint.find("parent")
        if parent is not None:
            children.setdefault(str(parent.get("link")), []).append(joint)
    roots = [name for name in links if name not in child_of]
    if len(roots) != 1:
        raise UrdfError(f"URDF {str(src)!r}: {len(roots)} root links, not one")
    origins = {}
    refs = {}
    for o, origin in enumerate(robot.origins):
        if o < robot.nq:
            fold = offsets == "fold"
            origins[origin.urdf_joint] = robot.folded_origin(o) if fold else pin.SE3(origin.origin)
            refs[origin.urdf_joint] = 0.0 if fold else -float(robot.joint_offsets[o])
        elif origin.urdf_joint is not None:
            origins[origin.urdf_joint] = pin.SE3(origin.origin)
    mujoco = etree.Element("mujoco", model=urdf.get("name") or robot.name)
    mujoco.append(etree.Comment(comment))
    etree.SubElement(
        mujoco,
        "compiler",
        angle="radian",
        autolimits="true",
        inertiafromgeom="false",
    )
    asset = etree.SubElement(mujoco, "asset")
    world = etree.SubElement(mujoco, "worldbody")
    rerooted = robot.root is not None or robot.floating
    meshes: dict[str, str] = {}

    def body(link: str, parent: etree._Element, placed: pin.SE3, joint: etree._Element | None) -> None:
        element = etree.SubElement(parent, "body", name=link)
        _place(element, placed)
        _inertial(element, links[link])
        if joint is not None:
            _joint(element, joint, refs.get(str(joint.get("name")), 0.0))
        _visuals(element, links[link], src, robot, asset, meshes)
        if link == robot.tip:
            for k, marker in enumerate(robot.markers):
                etree.SubElement(element, "site", name=f"pincal_marker{k}", pos=vector_text(marker))
        for child_joint in children.get(link, []):
            name = str(child_joint.get("name"))
            child = str(child_joint.find("child").get("link"))  # type: ignore[union-attr]
            placement = origins.get(name, _origin(child_joint))
            body(child, element, placement, None if child_joint.get("type") == "fixed" else child_joint)

    body(roots[0], world, pin.SE3.Identity() if rerooted else robot.base, None)
    if not len(asset):
        mujoco.remove(asset)
    etree.indent(mujoco, space="  ")
    text = '<?xml version="1.0"?>\n' + etree.tostring(mujoco, encoding="unicode") + "\n"
    if robot.tip not in links:
        raise UrdfError(
            f"URDF {str(src)!r}: the tip {robot.tip!r} is not a link; MJCF export needs a link tip"
        )
    return text, np.array(robot.markers), robot.base if rerooted else pin.SE3.Identity()


def _joint(body: etree._Element, joint: etree._Element, ref: float) -> None:
    kind = joint.get("type")
    name = str(joint.get("name"))
    if kind == "floating":
        etree.SubElement(body, "freejoint", name=name)
        return
    if kind not in ("revolute", "continuous", "prismatic"):
        raise UrdfError(
            f"URDF joint {name!r} is {kind}: MJCF export writes revolute, prismatic and fixed joints"
        )
    axis = joint.find("axis")
    element = etree.SubElement(
        body,
        "joint",
        name=name,
        type="slide" if kind == "prismatic" else "hinge",
        axis=(axis.get("xyz") if axis is not None else None) or "1 0 0",
    )
    limit = joint.find("limit")
    if (
        kind != "continuous"
        and limit is not None
        and limit.get("lower") is not None
        and limit.get("upper") is not None
    ):
        element.set("range", f"{float(limit.get('lower', 0))!r} {float(limit.get('upper', 0))!r}")
    if ref != 0.0:
        element.set("ref", repr(ref))


def _inertial(body: etree._Element, link: etree._Element) -> None:
    inertial = link.find("inertial")
    mass_element = None if inertial is None else inertial.find("mass")
    mass = 0.0 if mass_element is None else float(mass_element.get("value", 0))
    if inertial is None or mass <= 0:  # MuJoCo and Pinocchio need one: a negligible mass, as none
        etree.SubElement(
            body,
            "inertial",
            pos="0 0 0",
            mass=repr(NO_MASS),
            diaginertia=f"{NO_INERTIA!r} " * 2 + repr(NO_INERTIA),
        )
        return
    inertia = inertial.find("inertia")
    values = [
        float(inertia.get(k, 0)) if inertia is not None else 0.0
        for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")
    ]
    element = etree.SubElement(body, "inertial", mass=repr(mass), fullinertia=vector_text(np.array(values)))
    frame = _origin(inertial)
    element.set("pos", vector_text(frame.translation))
    if not np.allclose(frame.rotation, np.eye(3)):
        element.set("quat", quat_text(frame.rotation))


def _visuals(
    body: etree._Element,
    link: etree._Element,
    src: Path,
    robot: Robot,
    asset: etree._Element,
    meshes: dict[str, str],
) -> None:
    for visual in link.findall("visual"):
        shape = visual.find("geometry")
        if shape is None or not len(shape):
            continue
        kind = shape[0]
        geom = etree.Element("geom", contype="0", conaffinity="0", group="1")
        if kind.tag == "box":
            geom.set("type", "box")
            geom.set("size", vector_text(np.array([float(v) for v in kind.get("size", "0 0 0").split()]) / 2))
        elif kind.tag == "cylinder":
            geom.set("type", "cylinder")
            geom.set("size", f"{float(kind.get('radius', 0))!r} {float(kind.get('length', 0)) / 2!r}")
        elif kind.tag == "sphere":
            geom.set("type", "sphere")
            geom.set("size", repr(float(kind.get("radius", 0))))
        elif kind.tag == "mesh":
            found = resolve_mesh(kind.get("filename") or "", src, dict(robot.package_dirs))
            if found is None or found.suffix.lower() not in MESH_FORMATS:
                continue
            key = str(found.resolve()) + "|" + (kind.get("scale") or "")
            if key not in meshes:
                meshes[key] = f"mesh{len(meshes)}"
                mesh = etree.SubElement(asset, "mesh", name=meshes[key], file=str(found.resolve()))
                if kind.get("scale"):
                    mesh.set("scale", str(kind.get("scale")))
            geom.set("type", "mesh")
            geom.set("mesh", meshes[key])
        else:
            continue
        _place(geom, _origin(visual))
        body.append(geom)
