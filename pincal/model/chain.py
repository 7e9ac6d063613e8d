"""The serial chain a calibration measures, picked out of a robot's tree.

A chain runs from a *root* frame (the link held fixed in front of the instrument) to a *tip*
frame (the one the markers are fixed to); the root must lie above the tip in the URDF's tree.
Every other joint is locked: joints above the root and on other branches at their neutral value,
zero-range joints of the chain at their one value (with a warning). A floating base (a free-flyer
joint, or a robot known to float) is never a calibrated joint: the chain starts at the floating
body, or below it.

Without a tip, the chain ends are found: the leaf frames of the tree's last moving joints, with a
``tool0``/``tcp``/``flange``/``end_effector`` frame preferred on each end (even with camera frames
hung below it), and gripper fingers (joints or frames named like ``finger``, ``thumb``,
``hand_index``, ``gripper``, ``jaw``, ...) set aside: a hand that carries fingers is an end, its
fingers are locked. One end is taken; several give an error that lists them (fingers marked as such).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pincal.arguments import MAX_ANGLE
from pincal.errors import AmbiguousTip, FrameNotFound, UnsupportedJoint, warn

DIGIT = re.compile(
    r"finger|thumb|knuckle|phalan|pinky|hand_?((left|right|l|r)_)?(index|middle|ring|little|mrl)",
    re.IGNORECASE,
)
"""Names of the fingers of a hand (``LFinger11Link``, ``left_hand_index_1_link``,
``hand_mrl_joint``): a joint that moves such a link is a finger joint, whatever hangs below it.
``index``, ``middle``, ... count only after ``hand`` (``middle_lumbar_Z`` is a spine joint)."""

FINGER = re.compile(DIGIT.pattern + r"|gripper|jaw|claw|pinch", re.IGNORECASE)
"""Names of gripper fingers (joints, or links at a chain end): never a chain end chosen by
default. A ``gripper_link`` with more joints below it is often the wrist (Interbotix arms), so
these names mark a link as a finger only at an end."""

PREFERRED_TIP = re.compile(r"tool0|tcp|flange|end_effector|ee_link|eef|tool", re.IGNORECASE)
"""Names preferred among the leaf frames of one chain end."""

ZERO_RANGE = 1e-9
"""A joint whose upper - lower limit is at most this [rad or m] cannot move: it is locked."""

_FRAME_PREFERENCE = (pin.BODY, pin.OP_FRAME, pin.FIXED_JOINT, pin.JOINT, pin.SENSOR)


def frame_id(model: pin.Model, name: str, what: str = "frame") -> int:
    """Id of frame ``name``; a link's frame when several frames share the name (a link and the
    fixed joint that carries it)."""
    for kind in _FRAME_PREFERENCE:
        if model.existFrame(name, kind):
            return model.getFrameId(name, kind)
    raise FrameNotFound(name, _names(model), kind=what)


def _names(model: pin.Model) -> list[str]:
    return list(dict.fromkeys(f.name for f in model.frames))


def is_floating(model: pin.Model, joint: int) -> bool:
    """A joint that moves its child freely (free-flyer, planar, spherical...): never calibrated."""
    return model.nvs[joint] > 1


@dataclass(frozen=True)
class Candidate:
    """One chain end a tip may be chosen at.

    Attributes:
        frame: the frame name (give it as ``tip``).
        joints: number of moving joints from the root to it.
        finger: it is (on) a gripper finger.
        hand: names of the finger joints hanging on it (locked when it is the tip).
    """

    frame: str
    joints: int
    finger: bool = False
    hand: tuple[str, ...] = ()

    def describe(self) -> str:
        notes = [f"{self.joints} joint{'s' if self.joints != 1 else ''}"]
        if self.finger:
            notes.append("gripper finger")
        if self.hand:
            notes.append("hand: finger joints " + ", ".join(self.hand) + " locked")
        return f"{self.frame} ({'; '.join(notes)})"


def _descendants(model: pin.Model, joint: int) -> list[int]:
    return [j for j in range(1, model.njoints) if j != joint and joint in model.supports[j]]


def candidates(model: pin.Model, root_joint: int = 0) -> list[Candidate]:
    """The chain ends below ``root_joint`` (see module doc): the longest chains first, gripper
    fingers last, otherwise in the model's order (an arm is listed before a humanoid's ten
    foot-sensor frames, whose list is cut short in messages)."""
    below = [j for j in _descendants(model, root_joint) if not is_floating(model, j)]
    children = {j: [c for c in below if model.parents[c] == j] for j in [root_joint, *below]}
    link = {  # the child link of each joint
        f.parentJoint: f.name
        for f in model.frames
        if f.type == pin.BODY and model.frames[f.parentFrame].type == pin.JOINT
    }
    finger: set[int] = set()
    for j in below:  # parents come before children
        child = link.get(j, "")
        named = (
            FINGER.search(model.names[j]) or DIGIT.search(child) or (not children[j] and FINGER.search(child))
        )
        if model.parents[j] in finger or named:
            finger.add(j)
    arm = [j for j in below if j not in finger]
    depth = {j: sum(1 for s in model.supports[j] if s in below or s == j) for j in below}
    out: list[Candidate] = []
    for end in arm + [j for j in finger if not any(c in finger for c in children[j])]:
        if any(c in arm for c in children[end]):
            continue  # not an end
        leaves = _leaf_frames(model, end)
        is_finger = end in finger
        if not is_finger:
            fingers = [f for f in leaves if FINGER.search(f)]
            others = [f for f in leaves if f not in fingers]
            leaves = others or (len(fingers) > 1 and _hand(model, fingers)) or leaves
            preferred = [f for f in leaves if PREFERRED_TIP.search(f)]
            if not preferred and not fingers:  # sensors hung on the flange (a hand is the end)
                preferred = _inner_preferred(model, end)
            leaves = preferred or leaves
            if any(f.name == "tool0" and f.parentJoint == end for f in model.frames):
                leaves = ["tool0"]  # the ROS-Industrial flange frame, even with frames hung on it
        hand = tuple(model.names[c] for c in children[end] if c in finger)
        out += [Candidate(f, depth[end], is_finger, () if is_finger else hand) for f in leaves]
    return sorted(out, key=lambda c: (c.finger, -c.joints))


def _inner_preferred(model: pin.Model, joint: int) -> list[str]:
    """Tool-named frames fixed to ``joint`` with only other frames hung below them (a camera on
    the Kinova Gen3's ``end_effector_link``): the last ones of them along each branch."""
    frames = model.frames
    on = [i for i, f in enumerate(frames) if f.parentJoint == joint and f.type in (pin.BODY, pin.OP_FRAME)]
    named = {i for i in on if PREFERRED_TIP.search(frames[i].name)}

    def above(i: int) -> set[int]:
        out = set()
        while frames[i].parentJoint == joint and frames[i].parentFrame != i:
            i = frames[i].parentFrame
            out.add(i)
        return out

    inner = set().union(*(above(i) for i in named)) if named else set()
    return list(dict.fromkeys(frames[i].name for i in on if i in named and i not in inner))


def _leaf_frames(model: pin.Model, joint: int) -> list[str]:
    """Frames fixed to ``joint`` that no other frame fixed to it hangs from."""
    frames = model.frames
    on = [i for i, f in enumerate(frames) if f.parentJoint == joint and f.type in (pin.BODY, pin.OP_FRAME)]
    parents = {f.parentFrame for f in frames if f.parentJoint == joint}
    return list(dict.fromkeys(model.frames[i].name for i in on if i not in parents))


def _hand(model: pin.Model, leaves: list[str]) -> list[str]:
    """The link the finger-named leaf frames all hang from (the deepest common one), if any."""

    def ancestors(name: str) -> list[str]:
        out, i = [], frame_id(model, name)
        joint = model.frames[i].parentJoint
        while 0 < i < len(model.frames) and model.frames[i].parentJoint == joint:
            if model.frames[i].type == pin.BODY:
                out.append(model.frames[i].name)
            i = model.frames[i].parentFrame
        return out

    lines = [ancestors(name) for name in leaves]
    common = [name for name in lines[0][1:] if all(name in line for line in lines[1:])]
    return common[:1]


def default_tip(model: pin.Model, root_joint: int, robot: str, floating_note: str = "") -> str:
    """The one chain end below ``root_joint`` that is not a finger; else AmbiguousTip."""
    found = candidates(model, root_joint)
    arms = [c for c in found if not c.finger]
    if len(arms) == 1:
        return arms[0].frame
    tool0 = [c for c in arms if c.frame == "tool0"]
    if len(tool0) == 1:
        return "tool0"
    raise AmbiguousTip(robot, [c.describe() for c in found], floating_note)


def _locked_value(model: pin.Model, joint: int) -> float:
    """The value a zero-range joint is locked at (its limit, or 0 when unlimited)."""
    lo = model.lowerPositionLimit[model.idx_qs[joint]]
    return float(lo) if np.isfinite(lo) else 0.0


def chain_model(model: pin.Model, root: str | None, tip: str, robot: str) -> tuple[pin.Model, str]:
    """The model of the chain from ``root`` to ``tip`` expressed in the root frame, and the root
    frame's name (see module doc). ``root`` None is the model's root, or the floating body."""
    tip_id = frame_id(model, tip)
    tip_joint = model.frames[tip_id].parentJoint
    root_id = frame_id(model, root, "root frame") if root is not None else default_root(model)
    root_joint = model.frames[root_id].parentJoint
    support = list(model.supports[tip_joint])
    if root_joint not in support:
        above = [f.name for f in model.frames if f.parentJoint in support]
        raise FrameNotFound(
            model.frames[root_id].name,
            list(dict.fromkeys(above)),
            kind=f"root frame (it is not above the tip {tip!r} in the tree)",
        )
    chain = support[support.index(root_joint) + 1 :]
    if not chain:
        raise FrameNotFound(
            tip,
            [c.frame for c in candidates(model, root_joint)],
            kind="tip frame (it is fixed to the base: no joint of the chain moves it)",
        )
    for j in chain:
        if model.nqs[j] == 2 and model.nvs[j] == 1:
            raise UnsupportedJoint(
                f"joint {model.names[j]!r} is continuous in the Pinocchio model given; load the robot "
                f"from its URDF instead (pincal makes continuous joints revolute on a one-turn range)"
            )
        if is_floating(model, j) or model.nqs[j] != 1:
            raise UnsupportedJoint(
                f"joint {model.names[j]!r} ({model.joints[j].shortname()}) on the chain to {tip!r} is "
                f"not a one-dof revolute or prismatic joint; choose a --root below it"
            )
    q = pin.neutral(model)
    zero = []
    for j in chain:
        i = model.idx_qs[j]
        limits = (model.lowerPositionLimit[i], model.upperPositionLimit[i])
        if not all(abs(v) <= MAX_ANGLE for v in limits):  # NaN too
            raise UnsupportedJoint(
                f"{robot}: joint {model.names[j]!r} has the limits ({limits[0]:g}, {limits[1]:g}), over the "
                f"{MAX_ANGLE:g} (rad or m) pincal accepts; give its range with --joint-range NAME=LO,HI "
                "(joint_ranges=)"
            )
        if model.upperPositionLimit[i] - model.lowerPositionLimit[i] <= ZERO_RANGE:
            zero.append(j)
            q[i] = _locked_value(model, j)
    if len(zero) == len(chain):
        names = ", ".join(model.names[j] for j in zero)
        raise UnsupportedJoint(
            f"{robot}: every joint on the chain to {tip!r} has a zero range ({names}): give their "
            f"ranges with --joint-range NAME=LO,HI (joint_ranges=) or the limits in the URDF"
        )
    if zero:
        warn(
            f"{robot}: joint(s) {', '.join(model.names[j] for j in zero)} have a zero range in the URDF "
            f"and are locked, not calibrated; give --joint-range NAME=LO,HI (joint_ranges=) to move them"
        )
    keep = set(chain) - set(zero)
    locked = [j for j in range(1, model.njoints) if j not in keep]
    reduced = _reduced(model, locked, q) if locked else pin.Model(model)
    root_name = model.frames[root_id].name
    return _rerooted(reduced, root_name), root_name


def _reduced(model: pin.Model, locked: list[int], q: np.ndarray) -> pin.Model:
    """pin.buildReducedModel, which needs distinct frame names (a URDF may give a link and a
    joint the same name): duplicates are renamed for the reduction, then given back."""
    counts: dict[str, int] = {}
    for frame in model.frames:
        counts[frame.name] = counts.get(frame.name, 0) + 1
    renamed = pin.Model(model)
    for i, frame in enumerate(renamed.frames):
        if counts[frame.name] > 1 and frame.type != pin.JOINT:
            frame.name = f"{frame.name}\x00{i}"
            renamed.frames[i] = frame
    reduced = pin.buildReducedModel(renamed, locked, q)
    for i, frame in enumerate(reduced.frames):
        if "\x00" in frame.name:
            frame.name = frame.name.split("\x00")[0]
            reduced.frames[i] = frame
    return reduced


def default_root(model: pin.Model) -> int:
    """Frame id of the chain's default root: the floating body if the model has a floating
    joint at its root, else the universe."""
    for j in range(1, model.njoints):
        if model.parents[j] == 0 and is_floating(model, j):
            return next(i for i, f in enumerate(model.frames) if f.parentJoint == j and f.type == pin.BODY)
    return 0


def _rerooted(model: pin.Model, root: str) -> pin.Model:
    """The model with its world frame moved to frame ``root`` (fixed in the world)."""
    root_id = frame_id(model, root)
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    placement = data.oMf[root_id]
    if placement.isIdentity():
        return model
    inverse = placement.inverse()
    parents = list(model.parents)
    for j in range(1, model.njoints):
        if parents[j] == 0:
            model.jointPlacements[j] = inverse * model.jointPlacements[j]
    for i, frame in enumerate(model.frames):
        if frame.parentJoint == 0:
            frame.placement = inverse * frame.placement
            model.frames[i] = frame
    return model
