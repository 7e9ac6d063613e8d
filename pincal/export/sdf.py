"""Calibrated SDFormat export: a calibrated robot loaded from a URDF, written as an SDF ``<model>``.

What :func:`export_sdf` writes (docs/method.md §5.10, SDFormat 1.9, read by Gazebo):

* One ``<model>``; every URDF link a ``<link>`` (fixed links kept, so a tool frame stays a frame),
  every URDF joint a ``<joint>`` of the same type (revolute, continuous, prismatic, fixed) with
  its parent and child.
* Poses in SDF's convention: each joint's ``<pose relative_to="PARENT_LINK">`` is the URDF
  ``<origin>`` (x y z roll pitch yaw, R = Rz(yaw)·Ry(pitch)·Rx(roll), as URDF), each link's
  ``<pose relative_to="JOINT">`` the identity (a URDF child link's frame is its joint's frame at
  the zero); the root link's is relative to ``__model__``. The axis ``<xyz>`` is in the joint's
  frame (SDF's default), normalised.
* The calibration: each chain joint's pose is the calibrated origin with the joint offset folded
  in, L'' = L'·exp(S·Δq) (SDF has no ``<calibration>``), so a joint value q places the child link
  where q + Δq placed it on the identified model; the tip's fixed joint gets the calibrated tip
  placement. The joint limits are kept (``<limit>``: lower, upper, effort, velocity).
* The markers are ``<frame name="pincal_marker<k>" attached_to="TIP">`` with
  ``<pose relative_to="TIP">``; the base (the robot in the instrument's frame) is the model's
  ``<pose>``: the world frame of a world holding the model is the instrument's.
* Inertials, visuals and collisions (box, cylinder, sphere, mesh) are kept; a link without an
  inertial gets a negligible one (SDF's default would be 1 kg).
* Joint gains and compliances have no SDF element: they are written in the comment, with a
  :class:`~pincal.errors.PincalWarning`, and the file holds the geometry without them.

Before writing, the SDF text is read back (its ``relative_to`` chains resolved as SDFormat
resolves them, the joints moved about their axes) and the marker frames must be the calibrated
model's points at random configurations to 1e-9 m. The file is written atomically, never over
an input.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal.calibration.identification import IdentificationResult
from pincal.errors import PincalWarning, UrdfError
from pincal.export._urdf_to_mjcf import NO_INERTIA, NO_MASS
from pincal.export.urdf import exported_robot, placement_text
from pincal.model.robot import Robot
from pincal.model.urdf import read_tree, resolve_mesh
from pincal.outputs import atomic_write_text
from pincal.version import __version__

SDF_VERSION = "1.9"
"""The SDFormat version written (libsdformat 12 and later; Gazebo Fortress and later)."""
MARKER_FRAME = "pincal_marker{}"
"""Name of the frame of marker k."""
ROUND_TRIP_TOLERANCE = 1e-9
"""Largest point distance [m] allowed between the SDF written and the calibrated model."""
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")
"""The URDF joint types SDF writes as its own (a floating or planar joint is refused)."""


def export_sdf(
    calibrated: IdentificationResult | Robot,
    path: str | os.PathLike,
    *,
    source: str | os.PathLike | None = None,
    force: bool = False,
) -> Path:
    """Write the calibrated robot as an SDFormat model (what is written: see the module doc).

    Args:
        calibrated: a successful
            :class:`~pincal.calibration.identification.IdentificationResult`, or a Robot (a
            calibration's ``DeployedCalibration.robot``, ``random_errors(...).robot``).
        path: the ``.sdf`` file to write.
        source: the URDF (or xacro) file holding the robot's links and joints; default the
            robot's own (``robot.urdf_path``).
        force: export an ``implausible`` result too (never one that did not converge).

    Returns:
        the path written.

    Raises:
        IdentificationFailed, OverwriteRefused (``path`` is an input), UrdfError (no URDF source,
        one that is not this robot, or a joint or name SDF cannot hold), BadArgument.
    """
    robot, result = exported_robot(calibrated, force, "export_sdf")
    given = source if source is not None else robot.urdf_path
    if given is None:
        raise UrdfError(
            f"robot {robot.name!r} was not loaded from a file (a pinocchio Model): give source, the "
            "URDF holding its links and joints"
        )
    if robot.root is not None or robot.floating:
        raise UrdfError(
            f"robot {robot.name!r} is measured from frame {robot.root or 'of a floating base'}: SDF "
            "export writes a robot whose chain starts at its URDF's root link"
        )
    if robot.is_elastic:
        warnings.warn(
            "SDF has no joint gain or compliance: the SDF written holds the geometry without them "
            "(their values are in its comment; the calibration file keeps them)",
            PincalWarning,
            stacklevel=2,
        )
    text = sdf_text(robot, Path(given))
    _verify(text, robot)
    return atomic_write_text(path, text)


def sdf_text(robot: Robot, src: Path) -> str:
    """The SDF text of ``robot``, its links and joints read from the URDF ``src`` (see module doc)."""
    urdf = read_tree(src, dict(robot.package_dirs))
    links = {str(link.get("name")): link for link in urdf.findall("link")}
    joints = urdf.findall("joint")
    _check_names(src, list(links), [str(j.get("name")) for j in joints], robot)
    children = {str(j.find("child").get("link")) for j in joints if j.find("child") is not None}  # type: ignore[union-attr]
    roots = [name for name in links if name not in children]
    if len(roots) != 1:
        raise UrdfError(f"URDF {str(src)!r}: {len(roots)} root links, not one")
    origins = {}
    for o, origin in enumerate(robot.origins):
        if o < robot.nq:
            origins[origin.urdf_joint] = robot.folded_origin(o)
        elif origin.urdf_joint is not None:
            origins[origin.urdf_joint] = pin.SE3(origin.origin)
    missing = [str(name) for name in origins if name not in {j.get("name") for j in joints}]
    if missing or robot.tip not in links:
        raise UrdfError(
            f"URDF {str(src)!r} does not hold the robot: no joint(s) {', '.join(missing)}"
            if missing
            else f"URDF {str(src)!r}: the tip {robot.tip!r} is not a link; SDF export needs a link tip"
        )
    sdf = etree.Element("sdf", version=SDF_VERSION)
    sdf.append(etree.Comment(_comment(robot, src)))
    model = etree.SubElement(sdf, "model", name=urdf.get("name") or robot.name)
    _pose(model, robot.base, None)
    for name, link in links.items():
        parent = next((j for j in joints if j.find("child").get("link") == name), None)  # type: ignore[union-attr]
        element = etree.SubElement(model, "link", name=name)
        _pose(element, pin.SE3.Identity(), "__model__" if parent is None else str(parent.get("name")))
        _inertial(element, link)
        for kind in ("visual", "collision"):
            for i, shape in enumerate(link.findall(kind)):
                _shape(element, kind, shape, i, src, robot)
    for joint in joints:
        _joint(model, joint, origins.get(str(joint.get("name"))), src)
    for k, marker in enumerate(robot.markers):
        frame = etree.SubElement(model, "frame", name=MARKER_FRAME.format(k), attached_to=robot.tip)
        _pose(frame, pin.SE3(np.eye(3), np.asarray(marker, dtype=float)), robot.tip)
    etree.indent(sdf, space="  ")
    return '<?xml version="1.0"?>\n' + etree.tostring(sdf, encoding="unicode") + "\n"


def _check_names(src: Path, links: list[str], joints: list[str], robot: Robot) -> None:
    """SDF's naming rules: links, joints and frames of a model share one set of unique names; none
    is ``world``, holds ``::`` or is of the reserved ``__name__`` form."""
    names = links + joints + [MARKER_FRAME.format(k) for k in range(len(robot.markers))]
    shared = sorted({n for n in names if names.count(n) > 1})
    reserved = [n for n in names if n == "world" or "::" in n or (n.startswith("__") and n.endswith("__"))]
    if shared or reserved:
        why = (
            f"{', '.join(shared)} name(s) more than one link, joint or marker frame"
            if shared
            else f"{', '.join(reserved)} reserved (world, '::', __name__)"
        )
        raise UrdfError(
            f"URDF {str(src)!r} cannot be written as SDF: {why}; SDF needs unique names among a "
            "model's links, joints and frames: rename them in the URDF"
        )


def _origin(element: etree._Element) -> pin.SE3:
    origin = element.find("origin")
    if origin is None:
        return pin.SE3.Identity()
    xyz = [float(v) for v in (origin.get("xyz") or "0 0 0").split()]
    rpy = [float(v) for v in (origin.get("rpy") or "0 0 0").split()]
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))


def _numbers(values) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def _pose(element: etree._Element, value: pin.SE3, relative_to: str | None) -> None:
    pose = etree.SubElement(element, "pose")
    if relative_to is not None:
        pose.set("relative_to", relative_to)
    pose.text = _numbers([*value.translation, *pin.rpy.matrixToRpy(value.rotation)])


def _joint(model: etree._Element, joint: etree._Element, origin: pin.SE3 | None, src: Path) -> None:
    kind, name = joint.get("type"), str(joint.get("name"))
    if kind not in JOINT_TYPES:
        raise UrdfError(
            f"URDF {str(src)!r}: joint {name!r} is {kind}; SDF export writes {', '.join(JOINT_TYPES)} joints"
        )
    parent = str(joint.find("parent").get("link"))  # type: ignore[union-attr]
    element = etree.SubElement(model, "joint", name=name, type=str(kind))
    _pose(element, origin if origin is not None else _origin(joint), parent)
    etree.SubElement(element, "parent").text = parent
    etree.SubElement(element, "child").text = str(joint.find("child").get("link"))  # type: ignore[union-attr]
    if kind == "fixed":
        return
    found = joint.find("axis")
    direction = np.array(
        [float(v) for v in ((found.get("xyz") if found is not None else None) or "1 0 0").split()]
    )
    if not np.linalg.norm(direction) > 0:
        raise UrdfError(f"URDF {str(src)!r}: joint {name!r} has a zero axis")
    axis = etree.SubElement(element, "axis")
    etree.SubElement(axis, "xyz").text = _numbers(direction / np.linalg.norm(direction))
    limit = joint.find("limit")
    if limit is not None:
        bounds = etree.SubElement(axis, "limit")
        keys = ("effort", "velocity") if kind == "continuous" else ("lower", "upper", "effort", "velocity")
        for key in keys:
            if limit.get(key) is not None:
                etree.SubElement(bounds, key).text = repr(float(limit.get(key)))  # type: ignore[arg-type]
    dynamics = joint.find("dynamics")
    if dynamics is not None and (dynamics.get("damping") or dynamics.get("friction")):
        element_dynamics = etree.SubElement(axis, "dynamics")
        for key in ("damping", "friction"):
            if dynamics.get(key):
                etree.SubElement(element_dynamics, key).text = repr(float(dynamics.get(key)))  # type: ignore[arg-type]


def _inertial(link_element: etree._Element, link: etree._Element) -> None:
    inertial = link.find("inertial")
    mass_element = None if inertial is None else inertial.find("mass")
    mass = 0.0 if mass_element is None else float(mass_element.get("value", 0))
    element = etree.SubElement(link_element, "inertial")
    inertia = None if inertial is None else inertial.find("inertia")
    if inertial is None or mass <= 0:
        mass, values, frame = NO_MASS, [NO_INERTIA, 0, 0, NO_INERTIA, 0, NO_INERTIA], pin.SE3.Identity()
    else:
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        values = [float(inertia.get(k, 0)) if inertia is not None else 0.0 for k in keys]
        frame = _origin(inertial)
    _pose(element, frame, None)
    etree.SubElement(element, "mass").text = repr(mass)
    tensor = etree.SubElement(element, "inertia")
    for key, value in zip(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), values):
        etree.SubElement(tensor, key).text = repr(float(value))


def _shape(link: etree._Element, kind: str, shape: etree._Element, i: int, src: Path, robot: Robot) -> None:
    """A URDF <visual> or <collision> as SDF's (its geometry: box, cylinder, sphere or mesh)."""
    geometry = shape.find("geometry")
    if geometry is None or not len(geometry):
        return
    form = geometry[0]
    out = etree.Element("geometry")
    if form.tag == "box":
        etree.SubElement(etree.SubElement(out, "box"), "size").text = _numbers(
            form.get("size", "0 0 0").split()
        )
    elif form.tag in ("cylinder", "sphere"):
        element = etree.SubElement(out, str(form.tag))
        for key in ("radius", "length") if form.tag == "cylinder" else ("radius",):
            etree.SubElement(element, key).text = repr(float(form.get(key, 0)))
    elif form.tag == "mesh":
        name = form.get("filename") or ""
        found = resolve_mesh(name, src, dict(robot.package_dirs))
        element = etree.SubElement(out, "mesh")
        etree.SubElement(element, "uri").text = found.resolve().as_uri() if found is not None else name
        if form.get("scale"):
            etree.SubElement(element, "scale").text = _numbers(str(form.get("scale")).split())
    else:
        return
    named = etree.SubElement(link, kind, name=shape.get("name") or f"{kind}{i}")
    _pose(named, _origin(shape), None)
    named.append(out)


def _comment(robot: Robot, src: Path) -> str:
    base = robot.base
    lines = [
        f"Calibrated by pincal {__version__} from {src.name}.",
        "Joint offsets dq are folded into the joint poses: pose <- origin * exp(S dq), S the joint's",
        "motion axis; a joint value q on this model means what q + dq meant on the source.",
        f"Markers: frames pincal_marker<k> attached to {robot.tip}; the model's pose is the robot base",
        f"in the instrument frame: {placement_text(base)}",
    ]
    if robot.is_elastic:
        lines.append(
            "Not written (no SDF element): joint gains "
            + ", ".join(f"{n} {v:.6g}" for n, v in zip(robot.joint_names, robot.joint_gains))
            + "; compliances "
            + ", ".join(f"{n} {v:.6g}" for n, v in zip(robot.joint_names, robot.joint_compliances))
        )
    text = "\n    ".join(lines)
    while "--" in text:
        text = text.replace("--", "- -")
    return f"\n    {text}\n  "


def _read_pose(element: etree._Element) -> tuple[pin.SE3, str | None]:
    pose = element.find("pose")
    if pose is None:
        return pin.SE3.Identity(), None
    v = [float(x) for x in (pose.text or "0 0 0 0 0 0").split()]
    return pin.SE3(pin.rpy.rpyToMatrix(*v[3:]), np.array(v[:3])), pose.get("relative_to")


def _zero_poses(model: etree._Element) -> dict[str, pin.SE3]:
    """Every link's, joint's and frame's pose in the model frame at the zero configuration, each
    ``relative_to`` chain resolved (default: a joint's child link, a link's and a frame's the model)."""
    raw = {str(e.get("name")): e for e in model if e.tag in ("link", "joint", "frame")}
    zero: dict[str, pin.SE3] = {"__model__": pin.SE3.Identity()}

    def resolved(name: str, seen: tuple[str, ...] = ()) -> pin.SE3:
        if name not in zero:
            if name in seen or name not in raw:
                raise UrdfError(f"SDF pose of {name!r}: a relative_to cycle or an unknown frame")
            element = raw[name]
            pose, relative_to = _read_pose(element)
            default = element.findtext("child") if element.tag == "joint" else "__model__"
            zero[name] = resolved(relative_to or str(default), (*seen, name)) * pose
        return zero[name]

    for name in raw:
        resolved(name)
    return zero


def _motion(joint: etree._Element, value: float) -> pin.SE3:
    """The joint's motion at ``value`` [rad or m] in its own frame: exp(S·value)."""
    if joint.get("type") == "fixed":
        return pin.SE3.Identity()
    axis = np.array([float(v) for v in str(joint.findtext("axis/xyz")).split()]) * value
    twist = np.r_[axis, 0, 0, 0] if joint.get("type") == "prismatic" else np.r_[0, 0, 0, axis]
    return pin.exp6(pin.Motion(twist))


def sdf_points(text: str, configurations: np.ndarray, joint_names: tuple[str, ...]) -> np.ndarray:
    """The marker frames' positions in the world of the SDF ``text`` (as :func:`sdf_text` writes
    it) at ``configurations`` ((n, len(joint_names)) [rad or m], the other joints at 0):
    (n, frames, 3) [m].

    SDFormat's semantics: the poses are the zero configuration's, and a joint J moves its child C
    by exp(S·q) in J's frame: X_C(q) = X_P(q)·Z_P⁻¹·Z_J·exp(S·q)·Z_J⁻¹·Z_C, Z the zero poses."""
    model = etree.fromstring(text.encode()).find("model")
    if model is None:
        raise UrdfError("the SDF has no <model>")
    zero = _zero_poses(model)
    joints = {str(j.findtext("child")): j for j in model.findall("joint")}
    order = [str(link.get("name")) for link in model.findall("link")]
    depth = {name: 0 for name in order}
    for name in order:  # parents before children: sort by the number of joints above each link
        at = name
        while at in joints:
            at = str(joints[at].findtext("parent"))
            depth[name] += 1
            if depth[name] > len(order):
                raise UrdfError("the SDF's joints form a loop")
    order.sort(key=depth.__getitem__)
    frames = model.findall("frame")
    base = _read_pose(model)[0]
    out = np.empty((len(np.atleast_2d(configurations)), len(frames), 3))
    for n, q in enumerate(np.atleast_2d(configurations)):
        values = dict(zip(joint_names, q.tolist()))
        placed: dict[str, pin.SE3] = {}
        for name in order:
            joint = joints.get(name)
            if joint is None:
                placed[name] = base * zero[name]
                continue
            parent, j = str(joint.findtext("parent")), str(joint.get("name"))
            move = _motion(joint, values.get(j, 0.0))
            placed[name] = (
                placed[parent] * zero[parent].inverse() * zero[j] * move * zero[j].inverse() * zero[name]
            )
        for k, frame in enumerate(frames):
            held = str(frame.get("attached_to"))
            out[n, k] = (placed[held] * zero[held].inverse() * zero[str(frame.get("name"))]).translation
    return out


def _verify(text: str, robot: Robot) -> None:
    """The SDF written, read back, must give the calibrated model's points (gains aside)."""
    rigid = robot.replace(joint_gains=np.zeros(robot.nq), joint_compliances=np.zeros(robot.nq))
    qs = robot.random_configurations(20, np.random.default_rng(0))
    error = float(np.max(np.linalg.norm(sdf_points(text, qs, robot.joint_names) - rigid.points(qs), axis=-1)))
    if error > ROUND_TRIP_TOLERANCE:
        raise UrdfError(
            f"the SDF written for {robot.name!r} would not reproduce the calibrated model (points differ "
            f"by up to {error:.3g} m): the URDF does not describe this robot"
        )
