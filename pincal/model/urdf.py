"""Reading a URDF as users have it: xacro sources, continuous joints, joint ranges, meshes.

:func:`read_urdf` turns a file into a Pinocchio model of the whole tree:

* a ``.xacro`` file (or a URDF that still holds ``xacro:`` tags) is expanded when the ``xacro``
  package is installed (``pip install "pincal[xacro]"``, no ROS needed); otherwise the error says
  so;
* ``continuous`` joints become revolute joints whose *design range* (the joint values the design
  may choose) is one turn, [-π, π], or the range given for them; a range given for any other
  joint replaces its URDF limits;
* ``package://NAME/...`` and relative mesh files are looked up from the URDF's folder and its
  parents and in the folders given as ``package_dirs`` (``NAME=PATH``); meshes that cannot be
  found give one warning (calibration does not need them; the 3-D view draws sticks instead).

Malformed files give one :class:`~pincal.errors.UrdfError` line (with the XML line number, or the
URDF parser's own first message), never the parser's multi-line report.
"""

from __future__ import annotations

import contextlib
import math
import os
import shlex
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal import files, outputs
from pincal.arguments import check_lengths, checked_name, joint_range
from pincal.errors import BadArgument, UnknownName, UrdfError, warn
from pincal.model import xacro_expansion
from pincal.model.xacro_expansion import package_roots

MAX_URDF_BYTES = 16 * 2**20
"""Largest URDF read (16 MiB; meshes are separate files, so real URDFs are far smaller)."""
MAX_URDF_ELEMENTS = 100_000
"""Most XML elements in a URDF."""
MAX_URDF_JOINTS = 2_000
"""Most joints (and links) in a URDF."""
ONE_TURN = (-np.pi, np.pi)
"""Design range [rad] of a continuous joint when none is given."""


def parse_joint_ranges(ranges: Mapping[str, object] | None) -> dict[str, tuple[float, float]]:
    """``{joint: (lower, upper)}`` checked (:func:`pincal.arguments.joint_range`: numbers within
    ±1e6 rad or m, lower <= upper)."""
    if ranges is not None and not isinstance(ranges, Mapping):
        raise BadArgument(
            f"joint_ranges must be {{joint: (lower, upper)}}, got {ranges!r}", argument="joint_ranges"
        )
    return {
        checked_name(name, "joint name (in a joint range)"): joint_range(value, f"joint range of {name!r}")
        for name, value in (ranges or {}).items()
    }


def resolve_mesh(
    filename: str, urdf: Path, extra: Mapping[str, str] | None = None, search: Iterable[str] = ()
) -> Path | None:
    """The file a URDF ``<mesh filename=...>`` names, or None when it cannot be found.

    Args:
        filename: the ``filename`` attribute: ``package://NAME/...``, ``file://...``, a path
            absolute or relative to the URDF's folder.
        urdf: the URDF file.
        extra: ``{NAME: folder of package NAME}`` (``--package-dir NAME=PATH``), searched first.
        search: folders holding package folders (Pinocchio's ``package_dirs``: ``DIR/NAME/...``),
            searched after ``extra`` and before the folders above the URDF.
    """
    if filename.startswith("file://"):
        filename = filename[len("file://") :]
    if filename.startswith("package://"):
        package, _, rest = filename[len("package://") :].partition("/")
        roots = package_roots(package, urdf, extra, search)
        return next((root / rest for root in roots if (root / rest).is_file()), None)
    path = Path(filename) if os.path.isabs(filename) else urdf.resolve().parent / filename
    return path if path.is_file() else None


def xacro_command(path: Path) -> str:
    """The shell command that expands a xacro file next to it."""
    if path.name.endswith(".xacro"):
        name = path.name[: -len(".xacro")]
        out = path.with_name(name if name.endswith(".urdf") else name + ".urdf")
    else:  # a xacro source saved as .urdf: never write over it
        out = path.with_name(path.stem + ".expanded.urdf")
    return f"xacro {shlex.quote(str(path))} -o {shlex.quote(str(out))}"


def _expand_xacro(path: Path, package_dirs: Mapping[str, str] | None = None) -> str:
    """The URDF text of the xacro file ``path``, expanded in a bounded child process
    (:mod:`pincal.model.xacro_expansion`), xacro's own warnings as one pincal warning."""
    done = xacro_expansion.expand(path, package_dirs, MAX_URDF_BYTES)
    if done.error == "no xacro":
        raise UrdfError(
            f"{str(path)!r} is a xacro file, not a URDF: pincal expands it (without ROS) once the xacro "
            f'package is installed: pip install "pincal[xacro]" (with ROS sourced, '
            f"'{xacro_command(path)}' expands it too)"
        )
    if done.error is not None or done.text is None:
        raise UrdfError(f"xacro cannot expand {str(path)!r}: {done.error}")
    if done.warnings:
        warn(f"xacro, expanding {path.name}: " + "; ".join(done.warnings))
    return done.text


def read_text(path: Path, package_dirs: Mapping[str, str] | None = None) -> str:
    """The URDF text of ``path`` (a xacro file expanded, ``$(find NAME)`` from ``package_dirs``
    or the folders above it), or a one-line UrdfError (missing, not a regular file, over
    :data:`MAX_URDF_BYTES`, binary)."""
    text = files.read_text(path, "URDF", UrdfError, max_bytes=MAX_URDF_BYTES, strict_utf8=False)
    if path.suffix.lower() == ".xacro":
        return _expand_xacro(path, package_dirs)
    return text


def expanded_text(path: Path, package_dirs: Mapping[str, str] | None = None) -> str:
    """The URDF text of the URDF (or xacro) file ``path`` as :func:`read_urdf` reads it: a xacro
    source expanded (in the same bounded child process, ``$(find NAME)`` from ``package_dirs`` or
    the folders above it), a plain URDF as it is; a one-line UrdfError when it cannot be read."""
    text = read_text(path, package_dirs)
    if "<xacro:" in text and path.suffix.lower() != ".xacro":
        with contextlib.suppress(UrdfError):  # no xacro package: read_urdf accepted the text as is
            text = _expand_xacro(path, package_dirs)
    return text


def read_tree(path: Path, package_dirs: Mapping[str, str] | None = None) -> etree._Element:
    """The XML tree of the URDF (or xacro) file ``path``, as :func:`read_urdf` reads it (see
    :func:`expanded_text`)."""
    return _parse(expanded_text(path, package_dirs), repr(str(path)))


def _parse(text: str, where: str) -> etree._Element:
    try:
        root = etree.fromstring(text.encode("utf-8"), etree.XMLParser(remove_comments=True))
    except etree.XMLSyntaxError as exc:
        message = " ".join(str(exc).split())
        raise UrdfError(f"cannot read URDF {where}: not well-formed XML ({message})") from None
    if root.tag != "robot":
        raise UrdfError(f"URDF {where}: the root element is <{root.tag}>, not <robot>")
    counts = {"elements": 0, "joints": 0, "links": 0}
    for element in root.iter():
        counts["elements"] += 1
        if element.tag in ("joint", "link"):
            counts[element.tag + "s"] += 1
    limits = {"elements": MAX_URDF_ELEMENTS, "joints": MAX_URDF_JOINTS, "links": MAX_URDF_JOINTS}
    for what, limit in limits.items():
        if counts[what] > limit:
            raise UrdfError(f"URDF {where} has {counts[what]} {what}, more than the {limit} allowed")
    return root


def _check_tree(root: etree._Element, where: str) -> None:
    """The joints join the links into one tree, as the URDF format requires (urdfdom refuses the
    rest; Pinocchio would cut the chain silently): no joint whose parent and child are the same
    link, no link that is the child of two joints, one root link.

    Raises:
        UrdfError: naming the joint or the links at fault.
    """
    links = [str(link.get("name")) for link in root if link.tag == "link"]
    defined = set(links)
    parent_of: dict[str, str] = {}
    for joint in (j for j in root if j.tag == "joint"):
        name = joint.get("name")
        parent, child = _link_of(joint, "parent"), _link_of(joint, "child")
        for role, link in (("parent", parent), ("child", child)):
            if link is not None and link not in defined:
                raise UrdfError(
                    f"URDF {where}: joint {name!r} names {role} link {link!r}, which the URDF does not "
                    f"define (its links: {few(links, 6)})"
                )
        if parent is not None and parent == child:
            raise UrdfError(
                f"URDF {where}: joint {name!r} has link {parent!r} as both parent and child: a joint "
                "connects two different links"
            )
        if child is None:
            continue
        if child in parent_of:
            raise UrdfError(
                f"URDF {where}: link {child!r} is the child of two joints ({parent_of[child]!r} and "
                f"{name!r}): every link but the root hangs from one joint"
            )
        parent_of[child] = str(name)
    roots = [link for link in links if link not in parent_of]
    if links and not roots:
        raise UrdfError(f"URDF {where}: the joints form a loop (every link has a parent): no root link")
    if len(roots) > 1:
        raise UrdfError(
            f"URDF {where}: the joints leave {len(roots)} links without a parent ({few(roots)}): they "
            "must join every link into one tree, from one root link"
        )


def _link_of(joint: etree._Element, tag: str) -> str | None:
    """The ``link`` attribute of a joint's <parent> or <child>, or None."""
    element = joint.find(tag)
    return None if element is None else element.get("link")


def _set_range(joint: etree._Element, lo: float, hi: float) -> None:
    limit = joint.find("limit")
    if limit is None:
        limit = etree.SubElement(joint, "limit")
    limit.set("lower", repr(float(lo)))
    limit.set("upper", repr(float(hi)))
    for key in ("effort", "velocity"):  # urdfdom requires both
        if limit.get(key) is None:
            limit.set(key, "0")


def prepare(text: str, ranges: Mapping[str, tuple[float, float]], where: str) -> str:
    """The URDF text with continuous joints made revolute on their design range and the joint
    ranges asked for written as limits."""
    root = _parse(text, where)
    _check_tree(root, where)
    joints = {str(j.get("name")): j for j in root.iter("joint") if j.getparent() is root}
    unknown = [name for name in ranges if name not in joints]
    if unknown:
        movable = [n for n, j in joints.items() if j.get("type") in ("revolute", "continuous", "prismatic")]
        raise UnknownName("joint (in a joint range)", unknown[0], movable)
    changed = False
    for name, joint in joints.items():
        kind = joint.get("type")
        if kind == "continuous":
            joint.set("type", "revolute")
            _set_range(joint, *ranges.get(name, ONE_TURN))
            changed = True
        elif name in ranges:
            if kind not in ("revolute", "prismatic"):
                raise UrdfError(f"joint range of {name!r}: it is a {kind} joint, not revolute or prismatic")
            _set_range(joint, *ranges[name])
            changed = True
    return etree.tostring(root, encoding="unicode") if changed else text


@contextlib.contextmanager
def captured_stderr():
    """Collect what C++ code writes on file descriptor 2 (urdfdom's multi-line reports): a list,
    filled when the block ends (see :func:`first_error`)."""
    sink: list[str] = []
    try:
        fd = os.dup(2)
    except OSError:  # no usable stderr: nothing to capture
        yield sink
        return
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        try:
            os.dup2(tmp.fileno(), 2)
            yield sink
        finally:
            os.dup2(fd, 2)
            os.close(fd)
            tmp.seek(0)
            sink.append(tmp.read().decode("utf-8", "replace"))


def model_from_text(text: str, where: str) -> pin.Model:
    """Pinocchio's model of a URDF text, or one UrdfError line naming the first problem."""
    with captured_stderr() as stderr:
        try:
            model = pin.buildModelFromXML(text)
        except Exception as exc:  # Pinocchio raises ValueError/RuntimeError with long texts
            model, error = None, str(exc).strip()
    if model is not None:
        return model
    raise UrdfError(
        f"cannot read URDF {where}: {first_error(stderr) or (error.splitlines() or ['invalid'])[0]}"
    )


def first_error(stderr: list[str]) -> str | None:
    """The first ``Error:`` urdfdom reported in what :func:`captured_stderr` collected, or None."""
    report = [line.strip() for line in "".join(stderr).splitlines() if line.strip().startswith("Error:")]
    return report[0][len("Error:") :].strip() if report else None


def few(names: Sequence[str], limit: int = 3) -> str:
    """The first ``limit`` names, and how many more (for one-line messages)."""
    more = f" and {len(names) - limit} more" if len(names) > limit else ""
    return ", ".join(names[:limit]) + more


def check_meshes(text: str, urdf: Path, package_dirs: Mapping[str, str] | None = None) -> list[str]:
    """Mesh file names of the URDF that cannot be found (one warning names them); those found are
    inputs of the command (:func:`pincal.outputs.note_input`)."""
    names = sorted(
        {str(m.get("filename")) for m in _parse(text, str(urdf)).iter("mesh") if m.get("filename")}
    )
    found = {n: resolve_mesh(n, urdf, package_dirs) for n in names}
    for path in found.values():  # the robot's own files: no output of the command may replace them
        if path is not None:
            outputs.note_input(path)
    missing = [n for n, path in found.items() if path is None]
    if missing:
        warn(
            f"{urdf.name}: {len(missing)} mesh file(s) not found ({few(missing)}); calibration does not "
            f"need them (the 3-D view draws sticks); give --package-dir NAME=PATH to find them"
        )
    return missing


def read_urdf(
    path: Path,
    ranges: Mapping[str, tuple[float, float]] | None = None,
    package_dirs: Mapping[str, str] | None = None,
    meshes: bool = True,
) -> pin.Model:
    """The Pinocchio model of the URDF (or xacro) file ``path`` (see module doc)."""
    where = repr(str(path))
    text = read_text(path, package_dirs)
    try:
        model = model_from_text(prepare(text, ranges or {}, where), where)
    except UrdfError:
        if "<xacro:" not in text:
            raise
        text = _expand_xacro(path, package_dirs)  # a xacro source saved as .urdf: expanded, or the command
        model = model_from_text(prepare(text, ranges or {}, where), where)
    _check_axes(model, where)
    _check_lengths(model, where)
    _check_joint_names(model, where)
    if meshes:
        check_meshes(text, path, package_dirs)
    return model


def _check_lengths(model: pin.Model, where: str) -> None:
    """Every joint and frame is placed within :data:`~pincal.arguments.MAX_LENGTH` of its parent,
    and every prismatic range too (a URDF in mm read as metres, a corrupted number)."""
    placements = [(f"joint {model.names[j]!r}", model.jointPlacements[j]) for j in range(1, model.njoints)]
    placements += [(f"frame {f.name!r}", f.placement) for f in model.frames]
    for what, placement in placements:
        check_lengths(placement.translation, f"URDF {where}: {what} is placed at", UrdfError)
    for j in range(1, model.njoints):
        if model.nqs[j] == 1 and model.joints[j].shortname().startswith("JointModelP"):
            i = model.idx_qs[j]
            limits = [model.lowerPositionLimit[i], model.upperPositionLimit[i]]
            check_lengths(
                limits, f"URDF {where}: prismatic joint {model.names[j]!r} has a limit at", UrdfError
            )


def _check_joint_names(model: pin.Model, where: str) -> None:
    """A joint named ``nan`` or ``inf`` is refused: every CSV reader (pincal's, numpy's, pandas')
    takes it for a number that is none, and it heads a column of every plan and measurement file."""
    for name in list(model.names)[1:]:
        try:
            number = float(name)
        except ValueError:
            continue
        if not math.isfinite(number):
            raise UrdfError(
                f"URDF {where}: joint {name!r} is named like a number that is none (NaN or infinity): "
                f"CSV files of plans and measurements, headed by the joints' names, would read it as "
                f"one; rename the joint"
            )


def _check_axes(model: pin.Model, where: str) -> None:
    """Every one-dof joint moves: an ``<axis xyz="0 0 0"/>`` (or a non-finite one) is refused."""
    data = model.createData()
    nqs, idx_qs, placements = list(model.nqs), list(model.idx_qs), list(model.jointPlacements)
    one_dof = [j for j in range(1, model.njoints) if nqs[j] == 1]
    q = pin.neutral(model)
    for j in one_dof:  # all at once: a joint's motion liMi depends on its own coordinate only
        q[idx_qs[j]] += 1e-3
    pin.forwardKinematics(model, data, q)
    for j in one_dof:
        motion = pin.log6(placements[j].inverse() * data.liMi[j]).vector / 1e-3
        if not np.all(np.isfinite(motion)) or np.linalg.norm(motion) < 1e-6:
            raise UrdfError(
                f"URDF {where}: joint {model.names[j]!r} does not move (its <axis> is zero or not a "
                f'number); give it a unit axis, e.g. <axis xyz="0 0 1"/>'
            )
