"""Calibrated MJCF export: the user's MuJoCo XML with only what calibration changes written into it.

What :func:`export_mjcf` writes for a robot loaded from an MJCF file (docs/method.md §5.9, MJCF
conventions):

* For each joint of the measured chain, the ``pos`` and ``quat`` of the body holding it become the
  calibrated placement: X' = L'·L⁻¹·X, X the body's placement in its parent body, L and L' the
  joint's origin before and after calibration (docs/method.md §2.1); the joint offset δ goes into
  the joint's ``ref``: ref' = ref − δ, in the file's angle unit (``<compiler angle>``, degrees by
  default) — MuJoCo moves a hinge by qpos − ref, so qpos = the joint reading q places the body
  where q + δ placed it on the identified model. With ``offsets="fold"`` the offset is folded into
  the body's placement instead (X' = L'·exp(S·δ)·L⁻¹·X) and ``ref`` is kept.
* The tip: a site's ``pos``/``quat`` (or a body's without a joint) get the calibrated tip placement
  the same way; a body with a joint cannot carry it without moving its joint, so the correction is
  folded into the markers (the sidecar's markers then differ from ``result.robot.markers``).
* The markers are ``site`` elements ``pincal_marker<k>`` on the tip's body (replaced when present).
* The base (the robot's placement in the instrument's frame) is composed into the placement of the
  top-level body holding the chain: MuJoCo's world frame is then the instrument's.
* Nothing else changes: actuators, contacts, meshes, defaults, keyframes, the other bodies and
  comments are kept. ``<include>`` files are inlined (the written file stands alone); unnamed
  bodies and joints are named ``body<i>``/``joint<i>``; relative asset folders are rewritten for
  the new file's folder.
* Next to it, the JSON sidecar of :mod:`pincal.export.urdf` (``cal.xml`` →
  ``cal.calibration.json``): ``pincal compensate`` reads the pair as it reads a URDF's.

A robot loaded from a URDF is written as a new MJCF file (:mod:`._urdf_to_mjcf`): each link a body
(fixed links kept as bodies), offsets as ``ref``. Before writing, the new file is read back with
Pinocchio and must reproduce the calibrated model's points at random configurations to 1e-9 m;
the file and its sidecar are written all or nothing. The source is never overwritten.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from pathlib import Path
from typing import Literal

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal.calibration.identification import IdentificationResult
from pincal.errors import BadArgument, OverwriteRefused, PincalWarning, UrdfError
from pincal.export._urdf_to_mjcf import urdf_to_mjcf
from pincal.export.urdf import check_reproduces, exported_robot, placement_text, sidecar, sidecar_path
from pincal.model.chain import default_root, frame_id
from pincal.model.loading import load_robot
from pincal.model.mjcf import (
    Compiler,
    default_classes,
    is_mjcf,
    joint_limits,
    name_elements,
    placement,
    read_document,
    read_mjcf,
    set_placement,
    vector_text,
)
from pincal.model.robot import Robot
from pincal.outputs import all_or_nothing, atomic_write_text, same_file
from pincal.version import __version__

MARKER_SITE = "pincal_marker{}"
"""Name of the site of marker k."""


def export_mjcf(
    calibrated: IdentificationResult | Robot,
    path: str | os.PathLike,
    *,
    source: str | os.PathLike | None = None,
    offsets: Literal["ref", "fold"] = "ref",
    force: bool = False,
    write_sidecar: bool = True,
    sidecar_content: dict | None = None,
) -> Path:
    """Write the calibrated robot as a MuJoCo XML file (what is written: see the module doc).

    Args:
        calibrated: a successful
            :class:`~pincal.calibration.identification.IdentificationResult`, or a Robot.
        path: the ``.xml`` file to write; must not be the source.
        source: the MJCF (or URDF) file to start from; default the robot's own
            (``robot.urdf_path``, the file it was loaded from).
        offsets: ``"ref"`` (the joint offsets as each joint's ``ref``) or ``"fold"`` (folded into
            the bodies' placements).
        force: export an ``implausible`` result too (never one that did not converge).
        write_sidecar: also write the JSON sidecar (``cal.xml`` → ``cal.calibration.json``).
        sidecar_content: the sidecar to start from (a calibration's own, when converting one),
            instead of one made from ``calibrated``; the file name, markers and base are updated.

    Returns:
        the path written.

    Raises:
        IdentificationFailed, OverwriteRefused, UrdfError (no source, one that does not hold the
        chain, or that cannot reproduce the calibrated model), BadArgument.
    """
    robot, result = exported_robot(calibrated, force, "export_mjcf")
    if offsets not in ("ref", "fold"):
        raise BadArgument(f"offsets must be 'ref' or 'fold', got {offsets!r}", argument="offsets")
    given = source if source is not None else robot.urdf_path
    if given is None:
        raise UrdfError(
            f"robot {robot.name!r} was not loaded from a file (a pinocchio Model): give source, the MJCF "
            "or URDF file to write the calibrated geometry into"
        )
    src, out = Path(given), Path(path)
    if same_file(src, out):
        raise OverwriteRefused(f"refusing to overwrite the source {str(src)!r}: choose another output path")
    if is_mjcf(src):
        text, markers, base = _edited(robot, src, out, offsets, result)
    else:
        text, markers, base = urdf_to_mjcf(robot, src, out, offsets, _comment(robot, src, result))
    _verify(text, out, robot, markers, base)
    with all_or_nothing():  # the model and its sidecar, or neither
        written = atomic_write_text(out, text)
        if write_sidecar:
            content = dict(sidecar_content) if sidecar_content is not None else sidecar(calibrated, out)
            content["urdf"] = out.name
            content["markers"] = markers.tolist()
            content["base"] = {
                "xyz": base.translation.tolist(),
                "rpy": pin.rpy.matrixToRpy(base.rotation).tolist(),
                "matrix": base.homogeneous.tolist(),
            }
            atomic_write_text(sidecar_path(out), json.dumps(content, indent=2, allow_nan=False) + "\n")
    return written


def writes_mjcf(robot: Robot, out: str | os.PathLike) -> bool:
    """A calibration of ``robot`` written to ``out`` is MJCF: ``out`` ends in ``.xml`` (or ``.mjcf``),
    or the robot was loaded from an MJCF file (then ``out`` must not end in ``.urdf``).

    Raises:
        BadArgument: an MJCF robot with a ``.urdf`` output.
    """
    suffix = Path(out).suffix.lower()
    if suffix in (".xml", ".mjcf"):
        return True
    if robot.urdf_path is not None and is_mjcf(robot.urdf_path):
        if suffix == ".urdf":
            raise BadArgument(
                f"{Path(robot.urdf_path).name} is a MuJoCo (MJCF) robot: its calibration is written as MJCF; "
                f"give an output ending in .xml (for a URDF, load the robot from one)",
                argument="--out",
                value=str(out),
            )
        return True
    return False


def _rerooted(robot: Robot) -> bool:
    """The chain's root is not MuJoCo's world: loading re-expresses points in the root frame."""
    return robot.root is not None or robot.floating


def _edited(
    robot: Robot, src: Path, out: Path, offsets: str, result: IdentificationResult | None
) -> tuple[str, np.ndarray, pin.SE3]:
    """The calibrated MJCF text, the markers in the written tip frame and the sidecar's base."""
    tree = read_document(src, remove_comments=False)
    root = tree.getroot()
    name_elements(root)
    compiler = Compiler.of(root)
    classes = default_classes(root)
    world = root.find("worldbody")
    if world is None:
        raise UrdfError(f"MJCF {str(src)!r}: no <worldbody>")
    bodies = {str(b.get("name")): b for b in world.iter("body")}
    joints = {str(j.get("name")): j for j in world.iter("joint")}
    sites = {str(s.get("name")): s for s in world.iter("site") if s.get("name")}
    ranges = dict(zip(robot.joint_names, zip(robot.lower.tolist(), robot.upper.tolist())))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PincalWarning)  # told when the source was loaded
        nominal = load_robot(src, tip=robot.tip, root=robot.root, joint_ranges=ranges)
    if nominal.joint_names != robot.joint_names:
        raise UrdfError(
            f"MJCF {str(src)!r} does not match the robot: its chain to {robot.tip!r} has joints "
            f"{', '.join(nominal.joint_names)}, the robot {', '.join(robot.joint_names)}"
        )
    changed: list[str] = []
    for o, name in enumerate(robot.joint_names):
        joint = joints[name]
        body = joint.getparent()
        assert body is not None and body.tag == "body"  # a joint of a chain is in a body
        before, after = nominal.origins[o].origin, robot.origins[o].origin
        delta = float(robot.joint_offsets[o])
        if offsets == "fold":
            after = after * pin.exp6(pin.Motion(robot.motion_axes[robot.origins[o].joint] * delta))
        elif delta != 0.0:
            found = joint_limits(joint, classes, compiler)
            unit = 1.0 if found.slide else compiler.radians_per_unit
            joint.set("ref", repr((found.ref - delta) / unit))
            changed.append(f"{name}.ref")
        if not after.isApprox(before, 1e-15):
            set_placement(body, after * before.inverse() * placement(body, compiler))
            changed.append(str(body.get("name")))
    markers = np.array(robot.markers)
    tip_before, tip_after = nominal.origins[-1].origin, robot.origins[-1].origin
    tip_element = sites.get(robot.tip) if robot.tip not in bodies else bodies[robot.tip]
    if tip_element is None:  # a frame Pinocchio made of something else: keep it, fold into the markers
        raise UrdfError(f"MJCF {str(src)!r}: the tip {robot.tip!r} is neither a body nor a site")
    jointed = tip_element.tag == "body" and tip_element.find("joint") is not None
    if not tip_after.isApprox(tip_before, 1e-15):
        if jointed:
            change = tip_before.inverse() * tip_after
            markers = markers @ change.rotation.T + change.translation
        else:
            set_placement(tip_element, tip_after * tip_before.inverse() * placement(tip_element, compiler))
            changed.append(robot.tip)
    _write_markers(root, tip_element, markers, compiler)
    base = robot.base
    if not _rerooted(robot):
        moved = _move_base(world, joints[robot.joint_names[0]], base, compiler)
        if moved:
            changed.append(f"{moved} (the base)")
        base = pin.SE3.Identity()
    else:
        model = read_mjcf(src)
        data = model.createData()
        pin.framesForwardKinematics(model, data, pin.neutral(model))
        held = data.oMf[frame_id(model, robot.root) if robot.root else default_root(model)]
        _move_base(world, joints[robot.joint_names[0]], robot.base * held.inverse(), compiler)
    _rebase_assets(root, src.resolve().parent, out.resolve().parent)
    comment = etree.Comment(_comment(robot, src, result, changed))
    comment.tail = root.text if root.text and not root.text.strip() else "\n  "
    root.insert(0, comment)
    return _serialised(root, src.read_bytes()), markers, base


def _serialised(root: etree._Element, original: bytes) -> str:
    """The document as text: the source's XML declaration, top-level comments one per line."""
    head = original.lstrip()
    parts = [head[: head.index(b"?>") + 2].decode("utf-8", "replace")] if head.startswith(b"<?xml") else []
    nodes = [*reversed(list(root.itersiblings(preceding=True))), root, *root.itersiblings()]
    parts += [etree.tostring(node, encoding="unicode", with_tail=False) for node in nodes]
    return "\n".join(parts) + "\n"


def _write_markers(
    root: etree._Element, tip: etree._Element, markers: np.ndarray, compiler: Compiler
) -> None:
    """The markers as sites on the tip's body (a site tip: placed through the site)."""
    for site in [s for s in root.iter("site") if str(s.get("name", "")).startswith("pincal_marker")]:
        parent = site.getparent()
        assert parent is not None
        parent.remove(site)
    body, frame = tip, pin.SE3.Identity()
    if tip.tag == "site":
        body, frame = tip.getparent(), placement(tip, compiler)  # type: ignore[assignment]
    indent = body.text if body.text and not body.text.strip() else "\n"
    for k, marker in enumerate(markers):
        last = body[-1] if len(body) else None
        site = etree.SubElement(body, "site", name=MARKER_SITE.format(k), pos=vector_text(frame.act(marker)))
        if last is not None:
            site.tail, last.tail = last.tail, indent


def _move_base(world: etree._Element, first: etree._Element, base: pin.SE3, compiler: Compiler) -> str | None:
    """Compose ``base`` into the placement of the top-level body holding ``first``; its name, or
    None when ``base`` is the identity."""
    if base.isApprox(pin.SE3.Identity(), 1e-15):
        return None
    top = first
    while top.getparent() is not world:
        top = top.getparent()  # type: ignore[assignment]
    set_placement(top, base * placement(top, compiler))
    return str(top.get("name"))


def _rebase_assets(root: etree._Element, source_dir: Path, out_dir: Path) -> None:
    """Asset folders (``meshdir``, ``texturedir``, ``assetdir``) relative to the new file's folder."""
    if source_dir == out_dir or not any(e.get("file") for a in root.iter("asset") for e in a):
        return
    compilers = root.findall("compiler")
    if not compilers:
        compilers = [etree.Element("compiler")]
        root.insert(0, compilers[0])
    for element in compilers:
        for key in ("meshdir", "texturedir", "assetdir"):
            value = element.get(key)
            if value is not None and not os.path.isabs(value):
                element.set(key, os.path.relpath(source_dir / value, out_dir))
    last = compilers[-1]
    if all(c.get("meshdir") is None and c.get("assetdir") is None for c in compilers):
        last.set("meshdir", os.path.relpath(source_dir, out_dir))
    if all(c.get("texturedir") is None and c.get("assetdir") is None for c in compilers):
        last.set("texturedir", os.path.relpath(source_dir, out_dir))


def _comment(
    robot: Robot, src: Path, result: IdentificationResult | None, changed: list[str] | None = None
) -> str:
    base = robot.base
    lines = [f"Calibrated by pincal {__version__} from {src.name}."]
    if changed is not None:
        lines.append("Changed: " + (", ".join(changed) or "nothing (no geometric error)") + ".")
    lines += [
        "Joint offsets dq are in each joint's ref (ref <- ref - dq): qpos = the joint reading.",
        f"Markers: sites pincal_marker<k> on {robot.tip}; the robot base in the instrument frame: "
        f"{placement_text(base)}",
    ]
    if result is not None:
        lines.append(
            f"Identified from {result.data.m} configurations: residual RMS "
            f"{result.residual_rms_before:.4g} m before, {result.residual_rms_after:.4g} m after."
        )
    text = "\n    ".join(lines)
    while "--" in text:
        text = text.replace("--", "- -")
    return f"\n    {text}\n  "


def _verify(text: str, out: Path, robot: Robot, markers: np.ndarray, base: pin.SE3) -> None:
    """The new MJCF, read back with Pinocchio, must reproduce the calibrated model."""
    with tempfile.TemporaryDirectory(prefix="pincal-mjcf-") as folder:
        written = Path(folder) / (out.stem + ".xml")
        written.write_text(text, encoding="utf-8")
        ranges = dict(zip(robot.joint_names, zip(robot.lower.tolist(), robot.upper.tolist())))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PincalWarning)
            exported = load_robot(
                written, tip=robot.tip, markers=markers, root=robot.root, joint_ranges=ranges
            )
    check_reproduces(exported, robot, "the MJCF written", f"the MJCF written for {robot.name!r}", base=base)
