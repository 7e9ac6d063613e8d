"""Reading a MuJoCo XML (MJCF) robot: a ``.xml`` file whose root element is ``<mujoco>``.

:func:`read_mjcf` gives the Pinocchio model of the whole tree through Pinocchio's MJCF parser
(``pinocchio.buildModelFromMJCF``), after writing the file in the forms that parser reads as MuJoCo
does (checked against MuJoCo's own forward kinematics, tests/model/test_mjcf.py):

* ``<include file>`` elements are replaced by the included file's content;
* every orientation (``euler`` in the ``<compiler eulerseq>`` order, ``axisangle``, ``xyaxes``,
  ``zaxis``, an unnormalised ``quat``) becomes a unit ``quat`` (w, x, y, z) and every angle is
  written in radians: Pinocchio 4.1 misreads an extrinsic ``eulerseq`` ("XYZ") and an
  unnormalised ``axisangle`` axis, and converts a slide joint's ``range`` as if it were degrees;
* each joint's attributes, default classes and ``childclass`` resolved, are written on the joint;
* the bodies under ``<worldbody>`` are placed in a fixed body named ``world`` (MuJoCo's name of the
  world body): Pinocchio drops the placement of a top-level body without a joint;
* bodies and joints without a name are named ``body<i>`` and ``joint<i>`` (MuJoCo's ids).

A hinge joint moves by qpos − ``ref`` (docs/method.md §5.9): Pinocchio folds ``ref``
into the joint placement, so a configuration is MuJoCo's qpos. Joint limits are MuJoCo's: a
``range`` when the joint is limited (``limited="true"``, or ``"auto"`` with a range and
``<compiler autolimits="true">``, MuJoCo's default); a hinge without one is given one turn
(-π, π) and a slide none (give ``--joint-range``), with one warning naming them. Bodies are frames
(a body without a joint as a fixed frame), sites too: either may be the tip. ``<frame>`` elements
are not read (Pinocchio 4.1 drops the bodies inside them): the error says so.
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal import outputs
from pincal.arguments import MAX_LENGTH
from pincal.errors import UnknownName, UrdfError, warn
from pincal.model.mjcf_document import read_document
from pincal.model.urdf import ONE_TURN, few

ORIENTATIONS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")
"""The attributes that orient an element, in the order MuJoCo reads them."""
POSED = ("body", "site", "geom", "camera", "inertial", "frame")
"""Elements with a position and an orientation in their body's frame."""
WORLD = "world"
"""Name of the fixed body that holds the top-level bodies (MuJoCo's name of the world body)."""


def is_mjcf(path: str | os.PathLike) -> bool:
    """``path`` is a MuJoCo XML file: it ends in ``.xml`` (or ``.mjcf``) and its root element is
    ``<mujoco>`` (only the first element is read)."""
    path = Path(path)
    if path.suffix.lower() not in (".xml", ".mjcf") or not path.is_file():
        return False
    try:
        with path.open("rb") as handle:
            for _, element in etree.iterparse(handle, events=("start",), resolve_entities=False):
                return element.tag == "mujoco"
    except (OSError, etree.XMLSyntaxError):
        return False
    return False


@dataclass(frozen=True)
class Compiler:
    """What ``<compiler>`` says about numbers: the angle unit and the Euler sequence.

    Attributes:
        radians_per_unit: 1 (``angle="radian"``) or π/180 (``angle="degree"``, MJCF's default).
        eulerseq: the axes of ``euler`` (lower case: the rotating axes; upper case: the fixed ones).
        autolimits: a joint with a ``range`` is limited unless it says ``limited="false"``.
    """

    radians_per_unit: float = math.pi / 180
    eulerseq: str = "xyz"
    autolimits: bool = True

    @classmethod
    def of(cls, root: etree._Element) -> Compiler:
        """The settings of the (last) ``<compiler>`` elements of a document."""
        angle, seq, auto = "degree", "xyz", "true"
        for element in root.iter("compiler"):
            angle = element.get("angle", angle)
            seq = element.get("eulerseq", seq)
            auto = element.get("autolimits", auto)
        return cls(1.0 if angle == "radian" else math.pi / 180, seq, auto == "true")

    @property
    def degrees(self) -> bool:
        return self.radians_per_unit != 1.0


MAX_MJCF_NUMBER = 1e9
"""Largest magnitude of a number in a position, orientation or range (a robot is metres across):
beyond, a norm or a rotation overflows."""


def _floats(text: str | None, n: int, what: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in (text or "").split()], dtype=float)
    except ValueError:
        raise UrdfError(f"MJCF: {what} must be {n} numbers, got {text!r}") from None
    if len(values) != n or not np.all(np.abs(values) <= MAX_MJCF_NUMBER):
        raise UrdfError(f"MJCF: {what} must be {n} finite numbers within ±{MAX_MJCF_NUMBER:g}, got {text!r}")
    return values


def _axis_quat(axis: np.ndarray, angle: float) -> pin.Quaternion:
    norm = float(np.linalg.norm(axis))
    if norm < 1e-12:
        return pin.Quaternion(1.0, 0.0, 0.0, 0.0)
    return pin.Quaternion(pin.AngleAxis(angle, axis / norm))


def rotation(element: etree._Element, compiler: Compiler) -> np.ndarray:
    """The rotation (3, 3) an element's orientation attribute gives (identity when it has none),
    as MuJoCo computes it."""
    name = element.get("name") or element.tag
    if element.get("quat") is not None:
        q = _floats(element.get("quat"), 4, f"quat of {name}")
        if np.linalg.norm(q) < 1e-12:
            raise UrdfError(f"MJCF: quat of {name} is zero")
        return pin.Quaternion(*(q / np.linalg.norm(q))).toRotationMatrix()
    if element.get("axisangle") is not None:
        a = _floats(element.get("axisangle"), 4, f"axisangle of {name}")
        return _axis_quat(a[:3], a[3] * compiler.radians_per_unit).toRotationMatrix()
    if element.get("euler") is not None:
        angles = _floats(element.get("euler"), 3, f"euler of {name}") * compiler.radians_per_unit
        seq = compiler.eulerseq
        if len(seq) != 3 or any(c not in "xyzXYZ" for c in seq):
            raise UrdfError(f"MJCF: <compiler eulerseq={seq!r}> is not three of x, y, z, X, Y, Z")
        R = np.eye(3)
        for c, a in zip(seq, angles, strict=True):
            step = _axis_quat(np.eye(3)["xyz".index(c.lower())], float(a)).toRotationMatrix()
            R = R @ step if c.islower() else step @ R  # rotating axes: on the right
        return R
    if element.get("xyaxes") is not None:
        v = _floats(element.get("xyaxes"), 6, f"xyaxes of {name}")
        x = v[:3] / np.linalg.norm(v[:3])
        y = v[3:] - x * float(x @ v[3:])
        y = y / np.linalg.norm(y)
        return np.column_stack([x, y, np.cross(x, y)])
    if element.get("zaxis") is not None:
        z = _floats(element.get("zaxis"), 3, f"zaxis of {name}")
        return _z_rotation(z)
    return np.eye(3)


def _z_rotation(z: np.ndarray) -> np.ndarray:
    """The smallest rotation taking (0, 0, 1) to ``z`` (MuJoCo's ``zaxis``)."""
    z = z / np.linalg.norm(z)
    axis = np.cross([0.0, 0.0, 1.0], z)
    if np.linalg.norm(axis) < 1e-12:
        axis = np.array([1.0, 0.0, 0.0])
    return _axis_quat(axis, math.acos(max(-1.0, min(1.0, float(z[2]))))).toRotationMatrix()


def placement(element: etree._Element, compiler: Compiler) -> pin.SE3:
    """An element's ``pos`` and orientation: its frame in its parent body's frame."""
    pos = element.get("pos")
    t = _floats(pos, 3, f"pos of {element.get('name') or element.tag}") if pos is not None else np.zeros(3)
    return pin.SE3(rotation(element, compiler), t)


def quat_text(R: np.ndarray) -> str:
    """``quat`` attribute (w, x, y, z) of a rotation, to the last digit."""
    q = pin.Quaternion(R)
    q.normalize()
    w, x, y, z = q.w, q.x, q.y, q.z
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    return " ".join(repr(float(v) + 0.0) for v in (w, x, y, z))


def vector_text(values: np.ndarray) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def set_placement(element: etree._Element, value: pin.SE3) -> None:
    """Write ``value`` as the element's ``pos`` and ``quat`` (other orientation attributes removed)."""
    for key in ORIENTATIONS:
        element.attrib.pop(key, "")
    element.set("pos", vector_text(value.translation))
    element.set("quat", quat_text(value.rotation))


# ------------------------------------------------------------------ the document


def _attributes(element: etree._Element) -> dict[str, str]:
    return {str(k): str(v) for k, v in element.attrib.items()}


def default_classes(root: etree._Element) -> dict[str, dict[str, dict[str, str]]]:
    """``{class: {tag: attributes}}`` of the ``<default>`` tree, each class holding what it inherits
    (the top ``<default>`` is class ``main``)."""
    out: dict[str, dict[str, dict[str, str]]] = {}

    def visit(element: etree._Element, name: str, inherited: dict[str, dict[str, str]]) -> None:
        mine = {tag: dict(attrs) for tag, attrs in inherited.items()}
        for child in element:
            if isinstance(child.tag, str) and child.tag != "default":
                mine.setdefault(child.tag, {}).update(_attributes(child))
        out[name] = mine
        for child in element:
            if child.tag == "default":
                visit(child, child.get("class", "main"), mine)

    for top in root.findall("default"):
        visit(top, top.get("class", "main"), out.get("main", {}))
    return out


def element_class(element: etree._Element) -> str:
    """The default class an element takes: its ``class``, else its bodies' nearest ``childclass``."""
    if element.get("class"):
        return str(element.get("class"))
    parent = element.getparent()
    while parent is not None and parent.tag != "worldbody":
        if parent.get("childclass"):
            return str(parent.get("childclass"))
        parent = parent.getparent()
    return "main"


def resolved(element: etree._Element, classes: dict[str, dict[str, dict[str, str]]]) -> dict[str, str]:
    """The element's attributes with those of its default class under them."""
    name = element_class(element)
    if name not in classes and name != "main":
        raise UnknownName("MJCF default class", name, sorted(classes))
    return {**classes.get(name, {}).get(str(element.tag), {}), **_attributes(element)}


def name_elements(root: etree._Element) -> None:
    """Name the unnamed bodies and joints ``body<i>``, ``joint<i>`` (MuJoCo's ids) in place."""
    world = root.find("worldbody")
    if world is None:
        return
    for i, body in enumerate(world.iter("body"), start=1):
        if not body.get("name"):
            body.set("name", f"body{i}")
    for i, joint in enumerate(e for e in world.iter("joint", "freejoint")):
        if not joint.get("name"):
            joint.set("name", f"joint{i}")


@dataclass(frozen=True)
class JointLimits:
    """A joint's limits as MuJoCo reads them.

    Attributes:
        slide: it is a slide (prismatic) joint, else a hinge.
        limits: (lower, upper) [rad or m], or None when the joint is not limited.
        ref: its ``ref`` (qpos0) [rad or m].
    """

    slide: bool
    limits: tuple[float, float] | None
    ref: float


def joint_limits(
    joint: etree._Element, classes: dict[str, dict[str, dict[str, str]]], compiler: Compiler
) -> JointLimits:
    """The limits and ``ref`` of a hinge or slide joint, default classes applied, in SI units."""
    attrs = resolved(joint, classes)
    slide = attrs.get("type", "hinge") == "slide"
    unit = 1.0 if slide else compiler.radians_per_unit
    name = joint.get("name")
    ref = float(_floats(attrs["ref"], 1, f"ref of joint {name!r}")[0]) * unit if "ref" in attrs else 0.0
    limited = attrs.get("limited", "auto")
    if limited == "auto":
        on = compiler.autolimits and "range" in attrs
    else:
        on = limited == "true"
    if not on or "range" not in attrs:
        return JointLimits(slide, None, ref)
    lo, hi = _floats(attrs["range"], 2, f"range of joint {name!r}") * unit
    return JointLimits(slide, (float(lo), float(hi)), ref)


def hinge_or_slide(joint: etree._Element, classes: dict[str, dict[str, dict[str, str]]]) -> bool:
    return joint.tag == "joint" and resolved(joint, classes).get("type", "hinge") in ("hinge", "slide")


# --------------------------------------------------------------------- Pinocchio


def prepared(tree: etree._ElementTree, folder: Path) -> tuple[str, dict[str, JointLimits]]:
    """The MJCF text Pinocchio reads as MuJoCo does (see module doc), and each hinge and slide
    joint's limits."""
    root = tree.getroot()
    if root.find(".//worldbody//frame") is not None or root.find("worldbody/frame") is not None:
        frame = next(root.iter("frame"))
        raise UrdfError(
            f"MJCF: a <frame> element (line {frame.sourceline}): pincal reads bodies, joints and sites "
            "placed by their own pos and quat; move the frame's placement into its children"
        )
    compiler = Compiler.of(root)
    classes = default_classes(root)
    name_elements(root)
    world = root.find("worldbody")
    if world is None:
        raise UrdfError("MJCF: no <worldbody>")
    limits: dict[str, JointLimits] = {}
    for joint in world.iter("joint"):
        if not hinge_or_slide(joint, classes):
            continue
        attrs = resolved(joint, classes)
        found = joint_limits(joint, classes, compiler)
        limits[str(joint.get("name"))] = found
        unit = 1.0 if found.slide else compiler.radians_per_unit
        for key in ("axis", "pos", "type"):
            if key in attrs:
                joint.set(key, attrs[key])
        joint.set("ref", repr(found.ref))
        if "range" in attrs:
            joint.set("range", vector_text(_floats(attrs["range"], 2, "range") * unit))
        joint.attrib.pop("springref", "")
    for element in world.iter(*POSED):
        if element.tag == "geom" and element.get("fromto") is not None:
            continue
        if any(element.get(k) is not None for k in ORIENTATIONS):
            R = rotation(element, compiler)
            for key in ORIENTATIONS:
                element.attrib.pop(key, "")
            element.set("quat", quat_text(R))
    for element in root.iter("compiler"):
        element.set("angle", "radian")
        element.attrib.pop("eulerseq", "")
        for key in ("meshdir", "texturedir", "assetdir"):
            if element.get(key) is not None and not os.path.isabs(str(element.get(key))):
                element.set(key, str(folder / str(element.get(key))))
    if root.find("compiler") is None:
        root.insert(0, etree.Element("compiler", angle="radian"))
    compiler_element = root.find("compiler")
    assert compiler_element is not None
    if compiler_element.get("meshdir") is None and compiler_element.get("assetdir") is None:
        compiler_element.set("meshdir", str(folder))
    wrapper = etree.Element("body", name=WORLD)
    etree.SubElement(wrapper, "inertial", pos="0 0 0", mass="0", diaginertia="0 0 0")
    for child in list(world):
        if child.tag == "body":
            wrapper.append(child)
    world.append(wrapper)
    return etree.tostring(root, encoding="unicode"), limits


@contextlib.contextmanager
def _text_file(text: str):
    """A temporary file holding ``text`` (Pinocchio reads MJCF from a file name)."""
    with tempfile.TemporaryDirectory(prefix="pincal-mjcf-") as folder:
        path = Path(folder) / "model.xml"
        path.write_text(text, encoding="utf-8")
        yield str(path)


def _check_lengths(model: pin.Model, where: str) -> None:
    """Refuse a body or site placed beyond :data:`pincal.arguments.MAX_LENGTH` from its parent (a
    ``pos`` of 1e308 that Pinocchio read as it is, later an overflow), as URDF origins are."""
    placements = [(model.names[j], model.jointPlacements[j]) for j in range(1, model.njoints)]
    placements += [(f.name, f.placement) for f in model.frames]
    for name, placed in placements:
        far = float(np.max(np.abs(placed.translation)))
        if not far <= MAX_LENGTH:
            raise UrdfError(
                f"MJCF {where}: {name!r} is placed {far:.3g} m from its parent, beyond {MAX_LENGTH:g} m"
            )


def build(text: str, where: str) -> pin.Model:
    """Pinocchio's model of a prepared MJCF text, or one UrdfError line."""
    with _text_file(text) as name:
        try:
            return pin.buildModelFromMJCF(name)
        except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with long texts
            text = str(exc).strip()
            said = text.split("message:", 1)[1] if "message:" in text else text
            first = " ".join(said.split()) or type(exc).__name__
            raise UrdfError(f"cannot read MJCF {where}: {first}") from None


def build_geometry(model: pin.Model, text: str, kind: pin.GeometryType) -> pin.GeometryModel:
    """Pinocchio's geometry of ``kind`` for a prepared MJCF text."""
    with _text_file(text) as name:
        return pin.buildGeomFromMJCF(model, name, kind)


def geometry_text(path: Path) -> tuple[str, tuple[str, ...]]:
    """The prepared MJCF text of ``path`` for its geometry, the geoms whose mesh file cannot be
    found left out, and the ``file`` of each such mesh (sorted); the files found are inputs of the
    command (:func:`pincal.outputs.note_input`)."""
    tree = read_document(path)
    folder = path.resolve().parent
    root = tree.getroot()
    meshdir = folder
    for element in root.iter("compiler"):
        for key in ("assetdir", "meshdir"):
            if element.get(key) is not None:
                meshdir = folder / str(element.get(key))
    missing: set[str] = set()
    gone: set[str] = set()
    for asset in root.iter("asset"):
        for mesh in [m for m in asset if m.tag == "mesh" and m.get("file")]:
            file = str(mesh.get("file"))
            found = meshdir / file
            if found.is_file():
                outputs.note_input(found)
                continue
            missing.add(file)
            gone.add(mesh.get("name") or Path(file).stem)
            asset.remove(mesh)
    for geom in [g for g in root.iter("geom") if g.get("mesh") in gone]:
        parent = geom.getparent()
        assert parent is not None
        parent.remove(geom)
    text, _ = prepared(tree, folder)
    return text, tuple(sorted(missing))


def read_mjcf(path: Path, ranges: Mapping[str, tuple[float, float]] | None = None) -> pin.Model:
    """The Pinocchio model of the MJCF file ``path`` (see module doc); ``ranges`` replace the
    limits of the joints they name."""
    where = repr(str(path))
    tree = read_document(path)
    text, limits = prepared(tree, path.resolve().parent)
    model = build(text, where)
    _check_lengths(model, where)
    ranges = dict(ranges or {})
    unknown = [name for name in ranges if name not in limits]
    if unknown:
        raise UnknownName("joint (in a joint range)", unknown[0], list(limits))
    open_hinges: list[str] = []
    open_slides: list[str] = []
    for name, found in limits.items():
        if not model.existJointName(name):
            continue
        j = model.getJointId(name)
        if model.nqs[j] != 1:
            continue  # several joints on one body: a composite joint, refused on a chain
        i = model.idx_qs[j]
        lo_hi = ranges.get(name, found.limits)
        if lo_hi is None:
            (open_slides if found.slide else open_hinges).append(name)
            lo_hi = (-math.inf, math.inf) if found.slide else ONE_TURN
        model.lowerPositionLimit[i], model.upperPositionLimit[i] = lo_hi
    if open_hinges or open_slides:
        said = []
        if open_hinges:
            said.append(f"hinge(s) {few(open_hinges, 4)} move on one turn (-180°, 180°)")
        if open_slides:
            said.append(f"slide(s) {few(open_slides, 4)} need a range")
        warn(
            f'{path.name}: joint(s) without limits (no range, or limited="false"): '
            + "; ".join(said)
            + "; give --joint-range NAME=LO,HI (joint_ranges=) for their real range"
        )
    return model
