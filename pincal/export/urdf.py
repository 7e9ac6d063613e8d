"""Calibrated URDF export: the user's URDF with the identified geometry written into it.

What :func:`export_urdf` writes, precisely:

* For each joint of the measured chain, its ``<origin xyz rpy>`` becomes the calibrated origin
  L' = (R·exp3(δω), t + δt) (docs/method.md §2.1, §5.8) with the joint offset Δq folded in,
  L'' = L'·exp(S·Δq), S the joint's motion axis in its own frame: a rotation by Δq about the
  joint's axis (revolute), a translation by Δq along it (prismatic). A joint value q on the
  calibrated URDF then places the child link where q + Δq placed it on the identified model, so a
  controller using the calibrated URDF needs no offset table: its joint zeros are the real ones.
* The ``<origin>`` of the tip's fixed joint (the joint whose child is the tip frame's link)
  becomes the calibrated tip placement.
* Nothing else changes: links, visuals, collisions, meshes, inertias, limits, the other joints,
  tags pincal does not know (``<gazebo>``, ``<transmission>``, ...) and comments are kept as they
  are. (yourdfpy reads and checks the source and the result; the edit itself is made on the XML
  tree, because yourdfpy's writer drops the tags and comments it does not model.) Relative mesh
  file names are rewritten relative to the new file's directory so that they still resolve;
  ``package://`` and absolute names are kept.
* Marker errors and the base placement are not robot geometry: they are written in an XML comment
  at the top of ``<robot>`` (with the identified parameters and standard errors when a result is
  exported), and are available as ``result.robot.markers`` and ``result.robot.base``.
* Next to the URDF, a small JSON *sidecar* (:func:`sidecar_path`: ``cal.urdf`` →
  ``cal.calibration.json``) holds what a program needs to predict instrument coordinates from the
  URDF without parsing the comment: the tip frame, the markers in it [m], the base in the
  instrument frame (xyz [m], rpy [rad] and the 4×4 matrix), σ, the data's conditioning and the
  residuals, and what is not geometry: gravity in the robot's base frame [m/s²], the joint gains
  and compliances (``{joint: value}``, when the calibration has any) and the residual model (its
  hyperparameters and training data): everything ``pincal compensate`` needs
  (:mod:`pincal.compensation.calibration_file`); and, for ``pincal export`` (the corrections as
  an overlay of the unchanged source, :mod:`pincal.calibration.corrections`), the source file
  (``source``, its absolute path) and the joint offsets folded into the origins
  (``joint_offsets``, ``{joint: value}`` [rad or m])::

      p = base · oMf[tip] · marker,   oMf from pin.framesForwardKinematics on the URDF's model

Before writing, the new URDF is loaded back with Pinocchio and must reproduce the calibrated
model's points at random configurations to 1e-9 m; the URDF and its sidecar are then written all or
nothing (:func:`pincal.outputs.all_or_nothing`: temporary files renamed together at the end). The
source URDF is never overwritten. A xacro source is expanded as loading expands it, and the
calibrated robot is written as that URDF.
"""

from __future__ import annotations

import io
import json
import os
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
from lxml import etree

from pincal.calibration.identification import IdentificationResult
from pincal.deprecation import keywords_after
from pincal.errors import (
    BadArgument,
    IdentificationFailed,
    OverwriteRefused,
    PincalWarning,
    UrdfError,
)
from pincal.model.loading import load_robot
from pincal.model.robot import Robot
from pincal.model.urdf import expanded_text, model_from_text, prepare
from pincal.outputs import all_or_nothing, atomic_write_text, same_file
from pincal.version import __version__

ROUND_TRIP_TOLERANCE = 1e-9
"""Largest point distance [m] allowed between the exported URDF and the calibrated model."""


def sidecar_path(path: str | os.PathLike) -> Path:
    """The sidecar of a calibrated URDF: ``cal.urdf`` → ``cal.calibration.json``."""
    return Path(path).with_suffix(".calibration.json")


def sidecar(
    calibrated: IdentificationResult | Robot,
    urdf: str | os.PathLike,
    source: str | os.PathLike | None = None,
) -> dict:
    """The sidecar's content for ``calibrated`` exported to ``urdf`` from ``source`` (the robot's
    own file by default; see the module doc)."""
    result = calibrated if isinstance(calibrated, IdentificationResult) else None
    robot = calibrated.robot if isinstance(calibrated, IdentificationResult) else calibrated
    base = robot.base
    out = {
        "urdf": Path(urdf).name,
        "tip": robot.tip,
        "joints": list(robot.joint_names),
        "markers": robot.markers.tolist(),
        "base": {
            "xyz": base.translation.tolist(),
            "rpy": pin.rpy.matrixToRpy(base.rotation).tolist(),
            "matrix": base.homogeneous.tolist(),
        },
        "units": "metres and radians; points p = base * oMf[tip] * marker",
        "gravity": robot.gravity.tolist(),
        "joint_offsets": dict(zip(robot.joint_names, robot.joint_offsets.tolist())),
    }
    origin = source if source is not None else robot.urdf_path
    if origin is not None:
        out["source"] = str(Path(origin).resolve())
    if robot.is_elastic:
        out["joint_gains"] = dict(zip(robot.joint_names, robot.joint_gains.tolist()))
        out["joint_compliances"] = dict(zip(robot.joint_names, robot.joint_compliances.tolist()))
        out["units"] += "; joint gains dimensionless, compliances rad/(N·m) or m/N (prismatic)"
    if robot.fixtures:  # the instrument's parts identified with the robot (camera, target, anchors)
        out["fixtures"] = {
            f.name: {
                "on": f.on,
                "xyz": f.placement.translation.tolist(),
                "rpy": pin.rpy.matrixToRpy(f.placement.rotation).tolist(),
            }
            for f in robot.fixtures
        }
    if result is not None:
        summary = result.as_dict()
        out.update(
            {
                "status": result.status,
                "sigma": summary["sigma"],
                "sigma_estimated": result.sigma_estimated,
                "conditioning": summary["conditioning"],
                "condition_number": summary["condition_number"],
                "residual_rms_before": summary["residual_rms_before"],
                "residual_rms_after": summary["residual_rms_after"],
                "m": result.data.m,
                "dropped": summary["dropped"],
                "bases": summary["bases"],
            }
        )
        if result.residual_model is not None:
            out["residual_model"] = result.residual_model.as_dict()
    return out


def exported_robot(
    calibrated: IdentificationResult | Robot, force: bool, writer: str
) -> tuple[Robot, IdentificationResult | None]:
    """(the robot to write, its identification result or None) of what ``writer`` (export_urdf,
    export_mjcf, export_sdf) was given: a result must have succeeded (or, with ``force``, be only
    implausible), else IdentificationFailed; anything but a result or a Robot is a BadArgument."""
    result = calibrated if isinstance(calibrated, IdentificationResult) else None
    robot = calibrated.robot if isinstance(calibrated, IdentificationResult) else calibrated
    if result is not None and not (result.success or (force and result.status == "implausible")):
        raise IdentificationFailed(result)
    if not isinstance(robot, Robot):
        raise BadArgument(
            f"{writer} needs an IdentificationResult or a Robot, got {type(calibrated).__name__}",
            argument="calibrated",
        )
    return robot, result


@keywords_after(2)
def export_urdf(
    calibrated: IdentificationResult | Robot,
    path: str | os.PathLike,
    *,
    source_urdf: str | os.PathLike | None = None,
    force: bool = False,
    write_sidecar: bool = True,
) -> Path:
    """Write the calibrated robot as a URDF (what is written: see the module doc).

    Args:
        calibrated: a successful
            :class:`~pincal.calibration.identification.IdentificationResult`, or a Robot (e.g.
            a perturbed one, ``params.apply(values)`` or ``random_errors(...).robot``).
        path: the URDF file to write; must not be the source.
        source_urdf: the URDF to start from; default the robot's own (``robot.urdf_path``: the file
            it was loaded from, a xacro source expanded as loading expands it, or the URDF file
            a ``RobotWrapper`` carries, as example-robot-data's do in ``wrapper.urdf``).
        force: export an ``implausible`` result too (never one that did not converge).
        write_sidecar: also write the JSON sidecar (:func:`sidecar_path`).

    Returns:
        the path written.

    Raises:
        IdentificationFailed: ``calibrated`` is a result that did not converge.
        OverwriteRefused: ``path`` is the source URDF.
        UrdfError: no source URDF, or one that does not hold the robot's chain, or that cannot
            reproduce the calibrated model.
    """
    robot, result = exported_robot(calibrated, force, "export_urdf")
    source = source_urdf if source_urdf is not None else robot.urdf_path
    if source is None:
        raise UrdfError(
            f"robot {robot.name!r} was not loaded from a URDF file (a pinocchio Model, or a RobotWrapper "
            "without a URDF file in its 'urdf' attribute): give source_urdf, the URDF to write the "
            "calibrated origins into"
        )
    source, out = Path(source), Path(path)
    if same_file(source, out):
        raise OverwriteRefused(
            f"refusing to overwrite the source URDF {str(source)!r}: choose another output path"
        )
    # The URDF as loading read it: a xacro source expanded the same way ($(find NAME) too); a plain
    # URDF's own bytes (its declaration and encoding kept).
    expanded = expanded_text(source, dict(robot.package_dirs))
    text = source.read_bytes()
    if source.suffix.lower() == ".xacro" or b"<xacro:" in text:
        text = expanded.encode("utf-8")
    tree = _parse(text, source)
    _check_with_yourdfpy(tree, source)
    root = tree.getroot()
    joints = {str(j.get("name")): j for j in root.findall("joint")}
    origins = _calibrated_origins(robot)
    missing = [name for name in origins if name not in joints]
    if missing:
        raise UrdfError(
            f"URDF {str(source)!r} does not hold the robot's chain: no joint(s) "
            f"{', '.join(missing)} (its joints: {', '.join(joints) or 'none'})"
        )
    changed = [name for name, placement in origins.items() if _set_origin(joints[name], placement)]
    _rebase_mesh_paths(root, source.resolve().parent, out.resolve().parent)
    _add_comment(root, robot, result, source, changed)
    new = _serialise(root, text)
    _verify(new, robot, origins, source)
    with all_or_nothing():  # the URDF and its sidecar, or neither
        written = atomic_write_text(out, new)
        if write_sidecar:
            atomic_write_text(
                sidecar_path(out),
                json.dumps(sidecar(calibrated, out, source), indent=2, allow_nan=False) + "\n",
            )
    return written


def _serialise(root: etree._Element, original: bytes) -> str:
    """The document as text: the source's XML declaration, top-level comments one per line."""
    head = original.lstrip()
    declaration = '<?xml version="1.0"?>'
    if head.startswith(b"<?xml"):
        declaration = head[: head.index(b"?>") + 2].decode("utf-8", "replace")
    parts = [declaration]
    parts += [_text(node) for node in reversed(list(root.itersiblings(preceding=True)))]
    parts.append(_text(root))
    parts += [_text(node) for node in root.itersiblings()]
    return "\n".join(parts) + "\n"


def _text(node: etree._Element) -> str:
    return etree.tostring(node, encoding="unicode", with_tail=False)


def _parse(text: bytes, source: Path) -> etree._ElementTree:
    """The XML tree of a URDF, comments kept; tolerates what Pinocchio tolerates (e.g. '--' in a
    comment) by lxml's recovering parser."""
    try:
        tree = etree.parse(io.BytesIO(text), etree.XMLParser(remove_comments=False))
    except etree.XMLSyntaxError as exc:
        tree = etree.parse(io.BytesIO(text), etree.XMLParser(remove_comments=False, recover=True))
        if tree.getroot() is None:
            raise UrdfError(f"cannot read URDF {str(source)!r}: {exc}") from None
    if tree.getroot().tag != "robot":
        raise UrdfError(f"URDF {str(source)!r}: the root element is <{tree.getroot().tag}>, not <robot>")
    return tree


def _check_with_yourdfpy(tree: etree._ElementTree, source: Path):
    """Read the URDF with yourdfpy (comments stripped: yourdfpy does not use them)."""
    import yourdfpy  # imported here: it pulls in trimesh, a quarter of a second at start-up

    root = etree.fromstring(etree.tostring(tree), etree.XMLParser(remove_comments=True, recover=True))
    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(etree.tostring(root)),
            build_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # yourdfpy raises many types on bad files
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UrdfError(f"cannot read URDF {str(source)!r}: {first}") from None
    if urdf.robot is None or not urdf.robot.joints:
        raise UrdfError(f"URDF {str(source)!r} has no joints")
    return urdf


def _calibrated_origins(robot: Robot) -> dict[str, pin.SE3]:
    """``{URDF joint name: calibrated origin}`` for the chain joints (offsets folded) and the tip."""
    out: dict[str, pin.SE3] = {}
    for o, origin in enumerate(robot.origins):
        if o < robot.nq:
            assert origin.urdf_joint is not None  # a chain joint is a URDF joint
            out[origin.urdf_joint] = robot.folded_origin(o)
        elif origin.urdf_joint is not None:
            out[origin.urdf_joint] = pin.SE3(origin.origin)
    return out


def _read_origin(joint: etree._Element) -> pin.SE3:
    element = joint.find("origin")
    if element is None:
        return pin.SE3.Identity()
    xyz = [float(v) for v in (element.get("xyz") or "0 0 0").split()]
    rpy = [float(v) for v in (element.get("rpy") or "0 0 0").split()]
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))


def _set_origin(joint: etree._Element, placement: pin.SE3) -> bool:
    """Write ``placement`` into the joint's <origin> (created if absent); False if unchanged."""
    current = _read_origin(joint)
    if np.allclose(current.homogeneous, placement.homogeneous, rtol=0.0, atol=1e-15):
        return False
    element = joint.find("origin")
    if element is None:
        element = etree.Element("origin")
        joint.insert(0, element)
        element.tail = joint.text
    element.set("xyz", " ".join(repr(float(v)) for v in placement.translation))
    element.set("rpy", " ".join(repr(float(v)) for v in pin.rpy.matrixToRpy(placement.rotation)))
    return True


def _rebase_mesh_paths(root: etree._Element, source_dir: Path, out_dir: Path) -> None:
    if source_dir == out_dir:
        return
    for mesh in root.iter("mesh"):
        name = mesh.get("filename")
        if not name or "://" in name or os.path.isabs(name):
            continue
        mesh.set("filename", os.path.relpath(source_dir / name, out_dir))


def _comment_text(robot: Robot, result: IdentificationResult | None, source: Path, changed: list[str]) -> str:

    base = robot.base
    lines = [
        f"Calibrated by pincal {__version__} from {source.name}.",
        "Corrected <origin> of: " + (", ".join(changed) or "nothing (no geometric error)") + ".",
        "Joint offsets dq are folded into the origins: origin <- origin * exp(S dq), S the joint's",
        "motion axis; a joint value q on this URDF means what q + dq meant on the source.",
        "Not robot geometry, not written as URDF elements:",
        f"  markers in frame {robot.tip} [m]: "
        + "; ".join("(" + ", ".join(f"{v:.9g}" for v in m) + ")" for m in robot.markers),
        f"  robot base in the instrument frame: {placement_text(base)}",
    ]
    if result is not None:
        lines.append(
            f"Identified from {result.data.m} configurations: residual RMS "
            f"{result.residual_rms_before:.4g} m "
            f"before, {result.residual_rms_after:.4g} m after; errors relative to the source "
            f"(value +/- std, m or rad):"
        )
        lines += [
            f"  {n} = {v:.6g} +/- {s:.3g}"
            for n, v, s in zip(result.names, result.values, result.std, strict=True)
        ]
    text = "\n    ".join(lines)
    while "--" in text:
        text = text.replace("--", "- -")
    return f"\n    {text}\n  "


def _add_comment(
    root: etree._Element, robot: Robot, result: IdentificationResult | None, source: Path, changed: list[str]
) -> None:
    comment = etree.Comment(_comment_text(robot, result, source, changed))
    comment.tail = root.text if root.text and not root.text.strip() else "\n  "
    root.insert(0, comment)
    if root.text is None or root.text.strip():
        root.text = "\n  "


def _verify(text: str, robot: Robot, origins: dict[str, pin.SE3], source: Path) -> None:
    """The new URDF must reproduce the calibrated model: checked with yourdfpy and Pinocchio."""
    urdf = _check_with_yourdfpy(_parse(text.encode("utf-8"), source), source)
    for name, placement in origins.items():
        written = urdf.joint_map[name].origin
        if written is None or not np.allclose(written, placement.homogeneous, atol=1e-12):
            raise UrdfError(f"exported origin of joint {name!r} does not read back (internal error)")
    ranges = dict(zip(robot.joint_names, zip(robot.lower, robot.upper)))
    model = model_from_text(prepare(text, ranges, "exported"), "exported")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PincalWarning)  # told when the source was loaded
        exported = load_robot(model, tip=robot.tip, markers=robot.markers, root=robot.root)
    # The sidecar's terms on top of the URDF's geometry: the exported pair must be the calibrated robot.
    check_reproduces(
        exported,
        robot,
        f"URDF {str(source)!r}",
        f"the URDF written from {str(source)!r}",
        f", or the tip frame {robot.tip!r} has no fixed joint of its own to carry its corrected placement",
    )


def check_reproduces(
    exported: Robot, robot: Robot, source: str, written: str, hint: str = "", base: pin.SE3 | None = None
) -> Robot:
    """``exported`` (a written file read back) with the sidecar's terms of ``robot`` (its base, or
    ``base``; gains, compliances, gravity); it must be the calibrated robot: the same chain, and the
    same points to :data:`ROUND_TRIP_TOLERANCE` at 20 configurations.

    Raises:
        UrdfError: naming ``source`` (what does not match) or ``written`` (what would not reproduce
            the calibrated model), with ``hint`` (more likely causes) after the first.
    """
    exported = exported.replace(
        base=robot.base if base is None else base,
        joint_gains=robot.joint_gains,
        joint_compliances=robot.joint_compliances,
    ).with_gravity(robot.gravity)
    if exported.joint_names != robot.joint_names:
        raise UrdfError(
            f"{source} does not match the robot: its chain to {robot.tip!r} has joints "
            f"{', '.join(exported.joint_names)}, the robot {', '.join(robot.joint_names)}"
        )
    qs = robot.random_configurations(20, np.random.default_rng(0))
    error = float(np.max(np.linalg.norm(exported.points(qs) - robot.points(qs), axis=-1)))
    if error > ROUND_TRIP_TOLERANCE:
        raise UrdfError(
            f"{written} would not reproduce the calibrated model (points differ by up to {error:.3g} m): "
            f"the source does not describe this robot{hint}"
        )
    return exported


def placement_text(placement: pin.SE3) -> str:
    """``xyz="..." rpy="..."`` of a placement [m, rad], as the written files' comments give the base."""
    xyz = " ".join(f"{v + 0.0:.9g}" for v in placement.translation)
    rpy = " ".join(f"{v + 0.0:.9g}" for v in pin.rpy.matrixToRpy(placement.rotation))
    return f'xyz="{xyz}" rpy="{rpy}"'
