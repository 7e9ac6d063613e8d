"""Loading a robot: from a URDF (or xacro) file, a shipped robot, an example-robot-data robot or a
``pinocchio.Model``, choosing the chain (root and tip) and the markers measured on it."""

from __future__ import annotations

import os
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.arguments import check_lengths, checked_name
from pincal.errors import (
    AmbiguousTip,
    BadArgument,
    BadConfiguration,
    PincalWarning,
    RobotNotFound,
    UnknownName,
    warn,
)
from pincal.model.chain import Candidate, candidates, chain_model, default_root, default_tip, frame_id
from pincal.model.mjcf import is_mjcf, read_mjcf
from pincal.model.robot import Robot
from pincal.model.urdf import parse_joint_ranges, read_urdf
from pincal.typing import PointsLike, RobotSource

_PACKAGE = Path(__file__).resolve().parent.parent
ROBOTS_DIR = _PACKAGE / "robots" if (_PACKAGE / "robots").is_dir() else _PACKAGE.parent / "robots"
"""Where the URDFs pincal ships live (``robots/`` in a checkout, ``pincal/robots`` installed)."""


def shipped_robots() -> dict[str, Path]:
    """The robots pincal ships, by name: ``{name: path to URDF}``."""
    return {p.stem: p for p in sorted(ROBOTS_DIR.glob("*.urdf"))}


def example_robot_data_names() -> list[str]:
    """Names of the example-robot-data robots (empty if the loaders are not installed)."""
    try:
        from example_robot_data.robots_loader import ROBOTS
    except ImportError:  # pragma: no cover - a declared dependency
        return []
    return sorted(ROBOTS)


def _example_robot_data_urdf(name: str) -> Path | None:
    try:
        from example_robot_data.robots_loader import ROBOTS, getModelPath
    except ImportError:  # pragma: no cover - a declared dependency
        return None
    loader = ROBOTS.get(name)
    if loader is None or not loader.urdf_filename:
        return None
    relative = os.path.join(loader.path, loader.urdf_subpath, loader.urdf_filename)
    return Path(getModelPath(relative)) / relative


def _floating_by_name(name: str) -> bool:
    """example-robot-data knows which of its robots float (legged, humanoid, flying ones)."""
    try:
        from example_robot_data.robots_loader import ROBOTS
    except ImportError:  # pragma: no cover - a declared dependency
        return False
    return bool(getattr(ROBOTS.get(name), "free_flyer", False))


def _resolve_source(
    source: RobotSource,
    ranges: dict[str, tuple[float, float]],
    package_dirs: dict[str, str] | None,
) -> tuple[pin.Model, Path | None, str, bool]:
    """(model, urdf path or None, display name, known to float) for what load_robot accepts."""
    if isinstance(source, pin.Model):
        return _with_ranges(pin.Model(source), ranges), None, source.name or "model", False
    if hasattr(source, "model") and isinstance(source.model, pin.Model):  # a RobotWrapper
        model = _with_ranges(pin.Model(source.model), ranges)
        return model, _wrapper_urdf(source), source.model.name or "model", False
    if not isinstance(source, (str, os.PathLike)):
        raise RobotNotFound(repr(source), list(shipped_robots()) + example_robot_data_names())
    text = os.fspath(source)
    path = Path(text)
    if path.suffix.lower() in (".urdf", ".xacro") or _exists(path) or os.sep in text:
        if is_mjcf(path):
            return read_mjcf(path, ranges), path.resolve(), _stem(path), False
        return read_urdf(path, ranges, package_dirs), path.resolve(), _stem(path), False
    checked_name(text, "robot name")
    shipped = shipped_robots()
    if text in shipped:
        return read_urdf(shipped[text], ranges, package_dirs), shipped[text], text, False
    urdf = _example_robot_data_urdf(text)
    if urdf is not None:
        return read_urdf(urdf, ranges, package_dirs), urdf, text, _floating_by_name(text)
    if text in example_robot_data_names():
        raise RobotNotFound(text, [], reason="example-robot-data describes it without a URDF file")
    raise RobotNotFound(text, list(shipped) + example_robot_data_names())


def _wrapper_urdf(wrapper: object) -> Path | None:
    """The URDF file a RobotWrapper carries (example-robot-data's set ``wrapper.urdf``), or None."""
    urdf = getattr(wrapper, "urdf", None)
    if isinstance(urdf, (str, os.PathLike)) and _exists(Path(urdf)) and Path(urdf).is_file():
        return Path(urdf).resolve()
    return None


def _exists(path: Path) -> bool:
    """``path.exists()``, False for a name the system refuses as a path (too long, a NUL byte)."""
    try:
        return path.exists()
    except (OSError, ValueError):
        return False


def _stem(path: Path) -> str:
    name = path.name
    for suffix in (".xacro", ".urdf", ".xml", ".mjcf"):
        name = name[: -len(suffix)] if name.lower().endswith(suffix) else name
    return name


def _with_ranges(model: pin.Model, ranges: dict[str, tuple[float, float]]) -> pin.Model:
    """A model given as such: the joint ranges asked for written into its limits."""
    for name, (lo, hi) in ranges.items():
        if not model.existJointName(name) or model.nqs[model.getJointId(name)] != 1:
            valid = [model.names[j] for j in range(1, model.njoints) if model.nqs[j] == 1]
            raise UnknownName("one-dof joint (in a joint range)", name, valid)
        i = model.idx_qs[model.getJointId(name)]
        model.lowerPositionLimit[i], model.upperPositionLimit[i] = lo, hi
    return model


def _parse_markers(markers: PointsLike | None) -> np.ndarray:
    if markers is None:
        return np.zeros((1, 3))
    try:
        arr = np.array(markers, dtype=float)
    except (TypeError, ValueError):
        raise BadConfiguration(f"markers must be (x, y, z) triples in metres, got {markers!r}") from None
    if arr.ndim == 1 and arr.size == 3:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 3 or len(arr) == 0:
        raise BadConfiguration(f"markers must be (x, y, z) triples in metres, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise BadConfiguration("markers must be finite numbers")
    check_lengths(arr, "marker coordinate", BadConfiguration)
    return arr


@dataclass(frozen=True)
class ChainEnds:
    """The chains a robot offers: where they start and the tips they may end at.

    Attributes:
        name: the robot's display name.
        floating: the robot has a floating base (held fixed at ``root`` while measuring).
        root: the chain's root frame.
        candidates: the chain ends below ``root`` (gripper fingers marked).
        default: the tip :func:`load_robot` takes when none is given (None: give one).
    """

    name: str
    floating: bool
    root: str
    candidates: tuple[Candidate, ...]
    default: str | None

    def describe(self) -> str:
        """One line: the default chain, or the candidates to choose from."""
        head = f"floating base held at {self.root}; " if self.floating else ""
        if self.default is not None:
            tip = next(c for c in self.candidates if c.frame == self.default)
            return head + f"tip {tip.describe()}"
        if not self.candidates:
            return head + "no joint moves any frame: nothing to calibrate"
        shown = ", ".join(c.describe() for c in self.candidates[:6])
        more = f", ... ({len(self.candidates)} in all)" if len(self.candidates) > 6 else ""
        return head + f"give --tip: {shown}{more}"


def chain_ends(
    source: RobotSource,
    root: str | None = None,
    joint_ranges: dict[str, tuple[float, float]] | None = None,
) -> ChainEnds:
    """The chains ``source`` offers (see :func:`load_robot` for the arguments)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PincalWarning)
        model, _, name, floats = _resolve_source(source, parse_joint_ranges(joint_ranges), None)
    root_id = frame_id(model, root, "root frame") if root is not None else default_root(model)
    root_joint = model.frames[root_id].parentJoint
    found = tuple(candidates(model, root_joint))
    try:
        tip = default_tip(model, root_joint, name)
    except AmbiguousTip:
        tip = None
    floating = floats or (root is None and root_id != 0)
    return ChainEnds(name, floating, model.frames[max(root_id, 1)].name, found, tip)


def load_robot(
    source: RobotSource,
    tip: str | None = None,
    markers: PointsLike | None = None,
    *,
    root: str | None = None,
    joint_ranges: dict[str, tuple[float, float]] | None = None,
    package_dirs: dict[str, str] | None = None,
) -> Robot:
    """Load a robot and choose the chain and what is measured on it.

    Args:
        source: a URDF (or xacro) path, the name of a shipped robot (``kr270``, ``planar_2r``),
            the name of an example-robot-data robot (``ur10``, ``panda``, ...), a
            ``pinocchio.Model`` or a ``RobotWrapper`` (copied, never modified).
        tip: frame the markers are fixed to. Default: the one chain end of the tree (a hand
            rather than its gripper fingers; ``tool0`` or a ``tcp``/``flange`` frame on it);
            when there are several, AmbiguousTip lists them.
        markers: one (x, y, z) or a list of them [m], expressed in the tip frame; default the tip
            frame origin.
        root: frame the chain starts from, held fixed in front of the instrument (the points are
            expressed in it); default the URDF's root link, or the floating body of a robot with
            a floating base. It must lie above ``tip`` in the tree.
        joint_ranges: ``{joint: (lower, upper)}`` [rad or m]: the range a joint moves in during
            the experiment, replacing its URDF limits; continuous joints default to one turn,
            (-π, π).
        package_dirs: ``{package name: folder of that package}`` resolving ``package://NAME/``
            mesh paths, for the missing-mesh check, the 3-D view and the self-collision
            constraint (kept as ``Robot.package_dirs``); each folder must exist. The folders
            above the URDF are searched after them.

    Returns:
        the Robot: the chain from ``root`` to ``tip`` (every other joint locked).

    Raises:
        RobotNotFound, UrdfError, FrameNotFound, AmbiguousTip, UnsupportedJoint, BadConfiguration.

    Example:
        >>> robot = load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
        >>> robot.joint_names
        ('joint_a1', 'joint_a2', 'joint_a3', 'joint_a4', 'joint_a5', 'joint_a6')
    """
    ranges = parse_joint_ranges(joint_ranges)
    dirs = _package_dirs(package_dirs)
    model, urdf, name, floats = _resolve_source(source, ranges, dirs)
    root_id = frame_id(model, root, "root frame") if root is not None else default_root(model)
    note = ""
    floating = bool(floats or root_id != 0 and root is None)
    if floating:
        note = (
            f"it has a floating base, held fixed at its link {model.frames[max(root_id, 1)].name!r} "
            f"(the chain's root; --root LINK (root=) for another); "
        )
    if tip is None:
        tip = default_tip(model, model.frames[root_id].parentJoint, name, note)
    if note:
        warn(f"{name}: {note.rstrip('; ')}")
    chain, _ = chain_model(model, model.frames[root_id].name if root is None else root, tip, name)
    return Robot(
        chain,
        tip,
        _parse_markers(markers),
        name=name,
        urdf_path=urdf,
        root=root if root else None,
        package_dirs=tuple(dirs.items()),
        floating=floating,
    )


def _package_dirs(package_dirs: object) -> dict[str, str]:
    """``{package name: folder}`` checked: names and existing folders (the folder of package NAME,
    holding what ``package://NAME/...`` names)."""
    if package_dirs is None:
        return {}
    if not isinstance(package_dirs, Mapping):
        raise BadArgument(
            f"package_dirs: expected {{package name: folder}}, got {type(package_dirs).__name__}",
            argument="package_dirs",
            value=package_dirs,
        )
    out = {}
    for name, folder in package_dirs.items():
        if not isinstance(name, str) or not name or "/" in name or not isinstance(folder, (str, os.PathLike)):
            raise BadArgument(
                f"package_dirs: expected a package name and a folder, got {name!r}: {folder!r}",
                argument="package_dirs",
                value=package_dirs,
            )
        if not Path(folder).is_dir():
            raise BadArgument(
                f"package folder {os.fspath(folder)!r} (--package-dir {name}=PATH) is not a folder",
                argument="package_dirs",
                value=os.fspath(folder),
            )
        out[name] = str(Path(folder).resolve())
    return out
