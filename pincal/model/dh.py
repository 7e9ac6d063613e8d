"""Robots given by a Denavit–Hartenberg table: read the table, write the URDF pincal loads.

Two conventions, one row per joint from the base to the tip, each row ``a, alpha, d, theta``:

* ``standard`` (distal, Denavit–Hartenberg 1955 as in Spong, Corke's ``DH``): joint i moves about
  the z axis of frame i−1 and ``ᵢ₋₁Tᵢ = Rz(θᵢ) Tz(dᵢ) Tx(aᵢ) Rx(αᵢ)``;
* ``modified`` (proximal, Craig's): joint i moves about the z axis of frame i and
  ``ᵢ₋₁Tᵢ = Rx(αᵢ₋₁) Tx(aᵢ₋₁) Rz(θᵢ) Tz(dᵢ)``; row i holds aᵢ₋₁ and αᵢ₋₁ under ``a`` and ``alpha``.

The joint variable q is added to the table's value: θ = theta + q (revolute), d = d + q
(prismatic), so the table's theta (or d) is the joint's zero offset. The URDF holds one link per
joint (``link<i>``, the frame joint i moves, on its z axis), a fixed ``flange`` (the last DH
frame), the tool frame (default ``tool0``) and one fixed frame per marker (``marker<k>``, in the
tool frame). The DH product of a table is :meth:`DHTable.forward_kinematics`; every URDF is
checked against it in Pinocchio before it is returned.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pincal.arguments import check_lengths, generator, number
from pincal.errors import BadDHTable, OverwriteRefused
from pincal.files import read_yaml
from pincal.model._dh_urdf import fixed_frame, origin_text, quoteattr, rx, rz, tx, tz
from pincal.model.loading import ROBOTS_DIR
from pincal.outputs import atomic_write_text
from pincal.typing import ConfigurationsLike

CONVENTIONS = ("standard", "modified")
JOINT_TYPES = ("revolute", "prismatic")
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3}
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180}
TOP_KEYS = ("name", "convention", "units", "joints", "base", "tool", "markers")
ROW_KEYS = ("name", "type", "a", "alpha", "d", "theta", "limits", "velocity", "effort")
SELF_CHECK_TOLERANCE = 1e-9
"""Largest difference [m, rad] allowed between the URDF in Pinocchio and the DH product."""


@dataclass(frozen=True)
class DHJoint:
    """One row of a DH table, in metres and radians.

    Attributes:
        name: the URDF joint's name.
        type: ``revolute`` or ``prismatic``.
        a, alpha, d, theta: the row's parameters [m, rad, m, rad]; theta (revolute) or d
            (prismatic) is the value of the joint variable at q = 0.
        lower, upper: joint limits [rad or m].
        velocity, effort: the URDF's velocity and effort limits (0 when not given; pincal reads neither).
    """

    name: str
    type: str
    a: float
    alpha: float
    d: float
    theta: float
    lower: float
    upper: float
    velocity: float = 0.0
    effort: float = 0.0


@dataclass(frozen=True, eq=False)
class DHTable:
    """A robot as a DH table, in metres and radians (see the module doc for the conventions).

    Attributes:
        name: the robot's name.
        convention: ``standard`` or ``modified``.
        joints: the rows, base to tip.
        base: (4, 4) placement of DH frame 0 in the URDF's ``base_link``.
        tool_name: name of the tool frame.
        tool: (4, 4) placement of the tool frame in the flange (the last DH frame).
        markers: (k, 3) measured points in the tool frame [m] (may be empty).
    """

    name: str
    convention: str
    joints: tuple[DHJoint, ...]
    base: np.ndarray
    tool_name: str
    tool: np.ndarray
    markers: np.ndarray

    def __post_init__(self) -> None:
        if self.convention not in CONVENTIONS:
            raise BadDHTable(f"convention {self.convention!r} is not one of {', '.join(CONVENTIONS)}")
        bad = [j.name for j in self.joints if j.type not in JOINT_TYPES or not j.lower < j.upper]
        if not self.joints or bad:
            raise BadDHTable(f"DH table rows must be revolute or prismatic with lower < upper limits: {bad}")
        for name, shape in (("base", (4, 4)), ("tool", (4, 4))):
            value = np.array(getattr(self, name), dtype=float)  # a read-only copy
            if value.shape != shape:
                raise BadDHTable(f"DH table {name}: expected a (4, 4) placement, got shape {value.shape}")
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        markers = np.array(self.markers, dtype=float).reshape(-1, 3)
        markers.flags.writeable = False
        object.__setattr__(self, "markers", markers)

    @classmethod
    def from_yaml(cls, path: str | os.PathLike) -> DHTable:
        """Read a table from a YAML file (the layout is in the README and ``pincal urdf-from-dh --help``),
        or the table pincal ships by that name (``"ur5_dh"``, see :func:`shipped_dh_tables`).

        Raises:
            BadDHTable: the file is missing, not YAML, or a key or row is wrong (the message names it).
        """
        path = dh_table_path(path)
        content = read_yaml(path, "DH table", BadDHTable)
        return cls.from_dict(content, f"DH table {str(path)!r}", default_name=Path(path).stem)

    @classmethod
    def from_dict(cls, content: object, where: str = "DH table", default_name: str = "robot") -> DHTable:
        """A table from the mapping a YAML file holds (lengths and angles in its ``units``).

        Raises:
            BadDHTable: naming the key or the row (1-based) that is wrong.
        """
        if not isinstance(content, Mapping):
            raise BadDHTable(f"{where}: expected a mapping with keys {', '.join(TOP_KEYS)}")
        _known_keys(content, TOP_KEYS, where)
        length, angle = _units(content.get("units"), where)
        convention = content.get("convention", "standard")
        if convention not in CONVENTIONS:
            raise BadDHTable(f"{where}: convention {convention!r} is not one of {', '.join(CONVENTIONS)}")
        rows = content.get("joints")
        if not isinstance(rows, list) or not rows:
            raise BadDHTable(f"{where}: 'joints' must be a list of rows, one per joint (base to tip)")
        joints = tuple(_joint(row, i, length, angle, where) for i, row in enumerate(rows, start=1))
        tool = content.get("tool") or {}
        if not isinstance(tool, Mapping):
            raise BadDHTable(f"{where}, tool: expected a mapping with keys name, xyz, rpy")
        _known_keys(tool, ("name", "xyz", "rpy"), f"{where}, tool")
        base = content.get("base") or {}
        if not isinstance(base, Mapping):
            raise BadDHTable(f"{where}, base: expected a mapping with keys xyz, rpy")
        _known_keys(base, ("xyz", "rpy"), f"{where}, base")
        tool_name = _name(tool.get("name", "tool0"), f"{where}, tool: name")
        markers = content.get("markers") or []
        if not isinstance(markers, list):
            raise BadDHTable(f"{where}, markers: expected a list of [x, y, z] points in the tool frame")
        points = np.array(
            [_vector(p, 3, f"{where}, markers[{k}]") for k, p in enumerate(markers)], dtype=float
        ).reshape(-1, 3)
        check_lengths(points * length, f"{where}, markers: a coordinate of", BadDHTable)
        table = cls(
            name=_name(content.get("name", default_name), f"{where}: name"),
            convention=convention,
            joints=joints,
            base=_placement(base, length, angle, f"{where}, base"),
            tool_name=tool_name,
            tool=_placement(tool, length, angle, f"{where}, tool"),
            markers=points * length,
        )
        _check_names(table, where)
        return table

    @property
    def nq(self) -> int:
        return len(self.joints)

    def link_transforms(self, q: np.ndarray) -> list[np.ndarray]:
        """The (4, 4) transform of each row at joint values ``q`` [rad or m]: ᵢ₋₁Tᵢ."""
        out = []
        for joint, value in zip(self.joints, q, strict=True):
            theta = joint.theta + (value if joint.type == "revolute" else 0.0)
            d = joint.d + (value if joint.type == "prismatic" else 0.0)
            if self.convention == "standard":
                out.append(rz(theta) @ tz(d) @ tx(joint.a) @ rx(joint.alpha))
            else:
                out.append(rx(joint.alpha) @ tx(joint.a) @ rz(theta) @ tz(d))
        return out

    def forward_kinematics(self, q: ConfigurationsLike) -> np.ndarray:
        """(4, 4) placement of the tool frame in ``base_link`` at joint values ``q``: the DH product
        base · ⁰T₁ ⋯ ⁿ⁻¹Tₙ · tool."""
        q = np.asarray(q, dtype=float).reshape(self.nq)
        T = self.base.copy()
        for link in self.link_transforms(q):
            T = T @ link
        return T @ self.tool

    def to_urdf(self) -> str:
        """The URDF text of the robot (kinematics only: no meshes, no inertias)."""
        lines = [
            '<?xml version="1.0"?>',
            f"<!-- Written by pincal urdf-from-dh from a {self.convention} DH table. Joint variable q "
            "adds to the table's theta (revolute) or d (prismatic). -->",
            f"<robot name={quoteattr(self.name)}>",
            '  <link name="base_link"/>',
        ]
        parent = "base_link"
        before = self.base  # fixed transform not yet written, ahead of the next joint's motion
        for i, joint in enumerate(self.joints, start=1):
            # θ (revolute) or d (prismatic) is the variable; the rest of the row is fixed.
            theta = joint.theta
            d = joint.d
            if self.convention == "standard":
                origin = before @ rz(theta) @ tz(d)
                before = tx(joint.a) @ rx(joint.alpha)
            else:
                origin = before @ rx(joint.alpha) @ tx(joint.a) @ rz(theta) @ tz(d)
                before = np.eye(4)
            child = f"link{i}"
            limit = (
                f'<limit lower="{joint.lower!r}" upper="{joint.upper!r}" '
                f'effort="{joint.effort!r}" velocity="{joint.velocity!r}"/>'
            )
            lines += [
                f'  <link name="{child}"/>',
                f'  <joint name={quoteattr(joint.name)} type="{joint.type}">',
                f'    <parent link="{parent}"/>',
                f'    <child link="{child}"/>',
                f"    {origin_text(origin)}",
                '    <axis xyz="0 0 1"/>',
                f"    {limit}",
                "  </joint>",
            ]
            parent = child
        lines += fixed_frame(parent, "flange", before)
        lines += fixed_frame("flange", self.tool_name, self.tool)
        for k, point in enumerate(self.markers):
            placement = np.eye(4)
            placement[:3, 3] = point
            lines += fixed_frame(self.tool_name, f"marker{k}", placement)
        lines.append("</robot>")
        return "\n".join(lines) + "\n"


DH_DIR = ROBOTS_DIR / "dh"
"""Where the DH tables pincal ships live (``robots/dh`` in a checkout, ``pincal/robots/dh`` installed)."""


def shipped_dh_tables() -> dict[str, Path]:
    """The DH tables pincal ships, by name: ``{name: path to YAML}`` (``ur5_dh``: Universal Robots'
    published table of the UR5). ``pincal urdf-from-dh NAME`` and :func:`urdf_from_dh` take a name."""
    return {p.stem: p for p in sorted(DH_DIR.glob("*.yaml"))}


def dh_table_path(table: str | os.PathLike) -> Path:
    """The file of a DH table: ``table`` itself when it exists, else the shipped table of that name
    (``ur5_dh`` or ``ur5_dh.yaml``), else ``table`` (reading it then says it is missing, and which
    tables pincal ships)."""
    path = Path(table)
    if path.exists() or path.parent != Path("."):
        return path
    shipped = shipped_dh_tables()
    name = path.stem if path.suffix in (".yaml", ".yml") else path.name
    if name in shipped:
        return shipped[name]
    if not shipped:  # pragma: no cover - a broken install
        return path
    raise BadDHTable(
        f"DH table file {str(table)!r} does not exist, nor is it a table pincal ships "
        f"({', '.join(shipped)}: give the name alone)"
    )


def urdf_from_dh(table: DHTable | Mapping | str | os.PathLike, out: str | os.PathLike | None = None) -> str:
    """The URDF of a robot given by a DH table; written to ``out`` (atomically) when given.

    Args:
        table: a :class:`DHTable`, the mapping a YAML table holds, the path of a YAML file, or
            the name of a table pincal ships (``"ur5_dh"``, see :func:`shipped_dh_tables`).
        out: where to write the URDF (never over the table's file).

    Returns:
        the URDF text, checked first: Pinocchio's forward kinematics of it equals the DH product
        at random configurations (to 1e-9 m and rad).

    Raises:
        BadDHTable: the table is malformed (the message names the key or the row).
        OverwriteRefused: ``out`` is the table's file.

    Example:
        >>> import pincal
        >>> rows = [{"a": 0.5, "alpha": 0, "d": 0, "theta": 0, "limits": [-3, 3]}] * 2
        >>> urdf = pincal.model.urdf_from_dh({"name": "arm", "joints": rows})
        >>> urdf.count('type="revolute"')
        2
    """
    source = None
    if isinstance(table, (str, os.PathLike)):
        source = dh_table_path(table)
        table = DHTable.from_yaml(source)
    elif isinstance(table, Mapping):
        table = DHTable.from_dict(table)
    elif not isinstance(table, DHTable):
        raise BadDHTable(f"expected a DHTable, a mapping or a YAML path, got {type(table).__name__}")
    if out is not None and source is not None and Path(out).resolve() == source.resolve():
        raise OverwriteRefused(f"the URDF would overwrite its DH table {str(source)!r}: choose another path")
    text = table.to_urdf()
    worst = self_check(table, text)
    if worst > SELF_CHECK_TOLERANCE:  # pragma: no cover - a bug, not bad input
        raise BadDHTable(f"the URDF written for {table.name!r} differs from its DH product by {worst:.3g}")
    if out is not None:
        atomic_write_text(out, text)
    return text


def self_check(table: DHTable, urdf: str, n: int = 50, seed: int = 0) -> float:
    """Largest difference [m, rad] between the tool placement of ``urdf`` in Pinocchio and the DH
    product, over ``n`` random configurations within the limits."""
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    frame = model.getFrameId(table.tool_name)
    rng = generator(seed)
    lower = np.array([j.lower for j in table.joints])
    upper = np.array([j.upper for j in table.joints])
    worst = 0.0
    for q in lower + (upper - lower) * rng.random((n, table.nq)):
        pin.framesForwardKinematics(model, data, q)
        expected = table.forward_kinematics(q)
        got = data.oMf[frame]
        worst = max(
            worst,
            float(np.abs(got.translation - expected[:3, 3]).max()),
            float(np.linalg.norm(pin.log3(got.rotation.T @ expected[:3, :3]))),
        )
    return worst


# ------------------------------------------------------------------------ reading rows
def _known_keys(content: Mapping, valid: tuple[str, ...], where: str) -> None:
    for key in content:
        if key not in valid:
            raise BadDHTable(f"{where}: unknown key {key!r}; valid keys: {', '.join(valid)}")


def _units(units: object, where: str) -> tuple[float, float]:
    if units is None:
        return 1.0, 1.0
    if not isinstance(units, Mapping):
        raise BadDHTable(f"{where}, units: expected {{length: m|mm, angle: rad|deg}}")
    _known_keys(units, ("length", "angle"), f"{where}, units")
    length = units.get("length", "m")
    angle = units.get("angle", "rad")
    if length not in LENGTH_UNITS:
        raise BadDHTable(f"{where}, units: length {length!r} is not one of {', '.join(LENGTH_UNITS)}")
    if angle not in ANGLE_UNITS:
        raise BadDHTable(f"{where}, units: angle {angle!r} is not one of {', '.join(ANGLE_UNITS)}")
    return LENGTH_UNITS[length], ANGLE_UNITS[angle]


def _number(value: object, where: str) -> float:
    """A number of the table (a YAML bool or text refused: :func:`pincal.arguments.number`)."""
    return number(value, where, error=BadDHTable)


def _vector(value: object, n: int, where: str) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise BadDHTable(f"{where}: expected a list of {n} numbers, got {value!r}")
    return [_number(v, f"{where}[{k}]") for k, v in enumerate(value)]


def _name(value: object, where: str) -> str:
    if not isinstance(value, str) or not _NAME.fullmatch(value):
        raise BadDHTable(f"{where} {value!r}: expected a name of letters, digits, '_', '.' or '-'")
    return value


_NAME = re.compile(r"[A-Za-z0-9_.\-]+")


def _joint(row: object, i: int, length: float, angle: float, where: str) -> DHJoint:
    label = f"{where}, row {i}"
    if not isinstance(row, Mapping):
        raise BadDHTable(f"{label}: expected a mapping with keys a, alpha, d, theta (and name, type, limits)")
    name = _name(row.get("name", f"joint{i}"), f"{label}: name")
    label = f"{where}, row {i} ({name})"
    _known_keys(row, ROW_KEYS, label)
    kind = row.get("type", "revolute")
    if kind not in JOINT_TYPES:
        raise BadDHTable(f"{label}: type {kind!r} is not one of {', '.join(JOINT_TYPES)}")
    missing = [k for k in ("a", "alpha", "d", "theta") if k not in row]
    if missing:
        raise BadDHTable(f"{label}: missing {', '.join(missing)} (each row needs a, alpha, d, theta)")
    values = {k: _number(row[k], f"{label}: {k}") for k in ("a", "alpha", "d", "theta")}
    for k in ("a", "d"):
        check_lengths(values[k] * length, f"{label}: {k} is", BadDHTable)
    unit = angle if kind == "revolute" else length
    if "limits" in row:
        lower, upper = (v * unit for v in _vector(row["limits"], 2, f"{label}: limits"))
        if not lower < upper:
            raise BadDHTable(f"{label}: limits {row['limits']} must be [lower, upper] with lower < upper")
        if kind == "prismatic":
            check_lengths([lower, upper], f"{label}: a limit at", BadDHTable)
    elif kind == "revolute":
        lower, upper = -math.pi, math.pi
    else:
        raise BadDHTable(f"{label}: a prismatic joint needs limits: [lower, upper] (in the length unit)")
    extra = {k: _number(row.get(k, 0.0), f"{label}: {k}") for k in ("velocity", "effort")}
    if extra["velocity"] < 0 or extra["effort"] < 0:
        raise BadDHTable(f"{label}: velocity and effort must be ≥ 0")
    return DHJoint(
        name=name,
        type=kind,
        a=values["a"] * length,
        alpha=values["alpha"] * angle,
        d=values["d"] * length,
        theta=values["theta"] * angle,
        lower=lower,
        upper=upper,
        velocity=extra["velocity"] * unit,
        effort=extra["effort"],
    )


def _placement(content: Mapping, length: float, angle: float, where: str) -> np.ndarray:
    """(4, 4) placement from {xyz, rpy} (URDF order: fixed-axis roll, pitch, yaw)."""
    T = np.eye(4)
    T[:3, 3] = np.array(_vector(content.get("xyz", [0, 0, 0]), 3, f"{where}: xyz")) * length
    check_lengths(T[:3, 3], f"{where}: xyz has", BadDHTable)
    rpy = np.array(_vector(content.get("rpy", [0, 0, 0]), 3, f"{where}: rpy")) * angle
    T[:3, :3] = pin.rpy.rpyToMatrix(*rpy)
    return T


def _check_names(table: DHTable, where: str) -> None:
    joints = [j.name for j in table.joints]
    dup = sorted({n for n in joints if joints.count(n) > 1})
    if dup:
        raise BadDHTable(f"{where}: joint name(s) {', '.join(dup)} used more than once")
    links = {"base_link", "flange", *(f"link{i}" for i in range(1, table.nq + 1))}
    links |= {f"marker{k}" for k in range(len(table.markers))}
    if table.tool_name in links:
        raise BadDHTable(f"{where}, tool: name {table.tool_name!r} is taken by a generated frame")
    fixed = {f"{n}_joint" for n in links | {table.tool_name}}
    taken = sorted(set(joints) & fixed)
    if taken:
        raise BadDHTable(f"{where}: joint name(s) {', '.join(taken)} are taken by the generated fixed joints")


# ------------------------------------------------------------------------ writing URDF
