"""A calibration as a xacro overlay: a wrapper that includes the user's unchanged description and
hands it the corrections YAML (:mod:`pincal.calibration.corrections`).

URDF has no way to override a joint declared elsewhere, and xacro cannot edit what an include
produced: a wrapper cannot change a description whose joint origins are literal numbers. What
works, and what descriptions written for calibration already do, is the other way round: the
description reads its joint origins from a YAML file named by a xacro argument. Universal Robots'
ur_description is the model (``ur.urdf.xacro``: ``<xacro:arg name="kinematics_params" .../>``,
loaded with ``xacro.load_yaml`` into the joints' ``<origin>``; its ``ur_calibration`` writes such a
file from the controller's factory calibration). :func:`export_xacro` writes:

* ``OUT`` (e.g. ``cal.urdf.xacro``): declares the arguments ``kinematics_params``,
  ``kinematics_parameters_file`` and ``kinematics_params_file`` with the corrections file as their
  default (a xacro argument keeps its first declaration's default, so the description's own default
  yields; a command-line ``name:=value`` still wins), then includes the description unchanged;
* ``BASE.corrections.yaml`` beside it: the corrections, ``kinematics`` in ur_description's layout
  for a UR arm (so ``kinematics_params:=BASE.corrections.yaml`` works with ur_description's own
  launch files too), ``{joint: origin}`` otherwise;
* the sidecar (``cal.urdf.calibration.json``): markers, base, gains for ``pincal compensate``.

Before writing, the wrapper is expanded with xacro and loaded: it must reproduce the calibrated
points to 1e-9 m at 100 configurations. A description that does not read its origins from the file
fails this check and nothing is written: the error says how to add the hook (docs/method.md §5.10)
or to write a calibrated copy (``--format urdf``). When the description reads the chain's joints
but not the tool's (ur_description writes its tool joints as literals), the tool's correction is
folded into the sidecar's markers: the points are the calibration's, the tool frame is nominal.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.calibration.corrections import Corrections, corrections_yaml
from pincal.errors import PincalWarning, UrdfError
from pincal.export.urdf import sidecar_path
from pincal.model import xacro_expansion
from pincal.model.loading import load_robot
from pincal.model.urdf import MAX_URDF_BYTES
from pincal.outputs import all_or_nothing, atomic_write_text
from pincal.version import __version__

ARGUMENTS = ("kinematics_params", "kinematics_parameters_file", "kinematics_params_file")
"""The xacro arguments that name a kinematics YAML: ur_description's ``ur.urdf.xacro``
(``kinematics_params``), its macro's parameter name and its driver's launch argument."""
ROUND_TRIP_TOLERANCE = 1e-9
"""Largest point distance [m] allowed between the expanded wrapper and the calibration."""
CONFIGURATIONS = 100
"""Configurations at which the expanded wrapper is compared with the calibration."""


def corrections_path(out: str | os.PathLike) -> Path:
    """The corrections file of a wrapper: ``cal.urdf.xacro`` → ``cal.corrections.yaml``."""
    out = Path(out)
    base = out.name
    for suffix in (".xacro", ".urdf"):
        base = base.removesuffix(suffix)
    return out.with_name(base + ".corrections.yaml")


def wrapper_text(corrections: Corrections, yaml_name: str, include: str) -> str:
    """The wrapper: the arguments defaulting to ``yaml_name`` (relative to the wrapper's folder, or
    absolute), then the include of ``include``."""
    robot = corrections.robot
    comment = (
        f"Calibration of {robot.name} by pincal {__version__}: {corrections.source.name} unchanged, "
        f"its joint origins read from {Path(yaml_name).name} through the argument "
        f"{ARGUMENTS[0]} (docs/method.md 5.10). Markers, base and gains: the sidecar."
    )
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- {comment} -->",
        f'<robot xmlns:xacro="http://wiki.ros.org/xacro" name="{robot.name}">',
    ]
    lines += [
        f'  <xacro:arg name="{name}" default="${{xacro.abs_filename(\'{yaml_name}\')}}"/>'
        for name in ARGUMENTS
    ]
    lines += [f'  <xacro:include filename="{include}"/>', "</robot>", ""]
    return "\n".join(lines)


def export_xacro(corrections: Corrections, path: str | os.PathLike, sidecar_content: dict) -> Path:
    """Write the overlay of ``corrections`` (what is written: see the module doc).

    Args:
        corrections: the calibration as corrections of its source.
        path: the wrapper to write (``cal.urdf.xacro``).
        sidecar_content: the calibration's sidecar, copied with the file name and markers updated.

    Returns:
        the wrapper's path.

    Raises:
        UrdfError: the expanded wrapper does not reproduce the calibration (the description does
            not read its joint origins from a kinematics YAML), or xacro cannot expand it.
    """
    out = Path(path)
    yaml_file = corrections_path(out)
    text = corrections_yaml(corrections)
    markers = _checked_markers(corrections, text, out)
    include = os.path.relpath(corrections.source.resolve(), out.resolve().parent)
    content = dict(sidecar_content)
    content.update(
        urdf=out.name,
        markers=markers.tolist(),
        source=str(corrections.source.resolve()),
        corrections=yaml_file.name,
    )
    with all_or_nothing():
        atomic_write_text(yaml_file, text)
        written = atomic_write_text(out, wrapper_text(corrections, yaml_file.name, include))
        atomic_write_text(sidecar_path(out), json.dumps(content, indent=2, allow_nan=False) + "\n")
    return written


def _checked_markers(corrections: Corrections, yaml_text: str, out: Path) -> np.ndarray:
    """Expand the wrapper (with absolute paths, in a temporary folder beside ``out``: ``$(find
    NAME)`` searches the folders above it as it will above ``out``) and compare it with the
    calibration; the markers that make it reproduce the calibration's points (the tool's correction
    folded in when the description keeps the tool's origin)."""
    robot = corrections.robot
    ranges = dict(zip(robot.joint_names, zip(robot.lower.tolist(), robot.upper.tolist())))
    with tempfile.TemporaryDirectory(prefix=".pincal-xacro-", dir=out.resolve().parent) as folder:
        yaml_file = Path(folder) / "corrections.yaml"
        yaml_file.write_text(yaml_text, encoding="utf-8")
        wrapper = Path(folder) / "wrapper.urdf.xacro"
        wrapper.write_text(
            wrapper_text(corrections, str(yaml_file), str(corrections.source.resolve())), encoding="utf-8"
        )
        done = xacro_expansion.expand(wrapper, dict(robot.package_dirs), MAX_URDF_BYTES)
        if done.error is not None or done.text is None:
            raise UrdfError(f"xacro cannot expand the overlay of {corrections.source.name}: {done.error}")
        expanded = Path(folder) / "expanded.urdf"
        expanded.write_text(done.text, encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PincalWarning)  # told when the source was loaded
            overlay = load_robot(expanded, tip=robot.tip, root=robot.root, joint_ranges=ranges)
    markers = np.array(corrections.markers)
    tool = corrections.tool
    if tool is not None and not overlay.origins[-1].origin.isApprox(tool.origin, 1e-12):
        change = pin.SE3(overlay.origins[-1].origin).inverse() * tool.origin
        markers = markers @ change.rotation.T + change.translation
    overlay = overlay.replace(
        markers=markers,
        base=robot.base,
        joint_gains=robot.joint_gains,
        joint_compliances=robot.joint_compliances,
    ).with_gravity(robot.gravity)
    if overlay.joint_names != robot.joint_names:
        raise UrdfError(
            f"the overlay of {corrections.source.name} expands to a chain of joints "
            f"{', '.join(overlay.joint_names)}, the calibration's is {', '.join(robot.joint_names)}"
        )
    qs = robot.random_configurations(CONFIGURATIONS, np.random.default_rng(0))
    error = float(np.max(np.linalg.norm(overlay.points(qs) - robot.points(qs), axis=-1)))
    if error > ROUND_TRIP_TOLERANCE:
        raise UrdfError(
            f"{corrections.source.name} does not read its joint origins from a kinematics YAML (the "
            f"overlay's points differ from the calibration's by up to {error:.3g} m): a wrapper cannot "
            f"change the origins a description writes as numbers. Either give the description the hook "
            f"(a xacro argument {ARGUMENTS[0]} naming a YAML loaded with xacro.load_yaml into the joints' "
            f"<origin>, as ur_description does: docs/method.md 5.10), or write a calibrated copy with "
            f"--format urdf"
        )
    return markers
