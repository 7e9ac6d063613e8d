"""The names of a robot's parameters: the catalogue in canonical order, the groups, and how a spec
(``"lengths,offsets,joint2.tx"``) splits (conventions: :mod:`pincal.model.parameters`).

Beside the geometric parameters, each joint has a gain and a compliance (how its reading scales and
how it yields to gravity: :mod:`pincal.model.statics`); they come after them in the canonical
order, and the fixtures of the measurement set-up (:mod:`pincal.model.fixtures`: group
``instrument``, or one fixture by its name) come last."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pincal.model.robot import Robot

COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")
GROUPS = ("offsets", "lengths", "full", "base", "markers", "gains", "compliance", "instrument")
LENGTH_TOLERANCE = 1e-9
"""An origin component counts as a length when |xyz component| exceeds this [m]."""


@dataclass(frozen=True)
class Parameter:
    """One geometric parameter.

    Attributes:
        name: stable readable name, e.g. ``joint_a2.tx``.
        kind: ``"placement"``, ``"offset"``, ``"marker"``, ``"base"``, ``"gain"``,
            ``"compliance"`` or ``"fixture"`` (a part of the measurement set-up:
            :mod:`pincal.model.fixtures`).
        index: origin index (placement: joints in chain order, then the tip), joint index
            (offset, gain, compliance: 0-based in configuration order), marker index, fixture
            index (in ``robot.fixtures``), or 0 (base).
        component: 0..5 for tx ty tz rx ry rz (a fixture's too); 0..2 for a marker's or a point
            fixture's x y z; 0 otherwise.
        unit: ``"m"``, ``"rad"``, ``"1"`` (a gain), ``"rad/(N·m)"`` or ``"m/N"`` (the compliance
            of a revolute or a prismatic joint).
    """

    name: str
    kind: str
    index: int
    component: int
    unit: str

    @property
    def is_length(self) -> bool:
        """True when the parameter is in metres."""
        return self.unit == "m"


def catalogue(robot: Robot) -> list[Parameter]:
    """Every parameter of ``robot``, in canonical order."""
    out: list[Parameter] = []
    n_joints = robot.nq
    for o, origin in enumerate(robot.origins):
        for c, comp in enumerate(COMPONENTS):
            out.append(Parameter(f"{origin.name}.{comp}", "placement", o, c, "m" if c < 3 else "rad"))
        if o < n_joints:
            out.append(
                Parameter(f"{origin.name}.offset", "offset", o, 0, "rad" if robot.revolute[o] else "m")
            )
    for k in range(robot.n_markers):
        for c, comp in enumerate("xyz"):
            out.append(Parameter(f"marker{k}.{comp}", "marker", k, c, "m"))
    for c, comp in enumerate(COMPONENTS):
        out.append(Parameter(f"base.{comp}", "base", 0, c, "m" if c < 3 else "rad"))
    names = robot.joint_names
    out += [Parameter(f"{names[j]}.gain", "gain", j, 0, "1") for j in range(n_joints)]
    out += [
        Parameter(f"{names[j]}.compliance", "compliance", j, 0, "rad/(N·m)" if robot.revolute[j] else "m/N")
        for j in range(n_joints)
    ]
    for f, fixture in enumerate(robot.fixtures):
        for c, comp in enumerate(fixture.components):
            unit = "rad" if comp.startswith("r") else "m"
            out.append(Parameter(f"{fixture.name}.{comp}", "fixture", f, c, unit))
    return out


def group(robot: Robot, every: list[Parameter], name: str) -> list[Parameter]:
    """The parameters of group ``name`` (one of :data:`GROUPS`) among ``every`` (the catalogue)."""
    if name == "offsets":
        return [p for p in every if p.kind == "offset"]
    if name == "full":
        return [p for p in every if p.kind == "placement"]
    if name == "lengths":
        xyz = [o.origin.translation for o in robot.origins]
        return [
            p
            for p in every
            if p.kind == "placement" and p.component < 3 and abs(xyz[p.index][p.component]) > LENGTH_TOLERANCE
        ]
    if name == "base":
        return [p for p in every if p.kind == "base"]
    if name == "markers":
        return [p for p in every if p.kind == "marker"]
    if name == "gains":
        return [p for p in every if p.kind == "gain"]
    if name == "compliance":
        return [p for p in every if p.kind == "compliance"]
    if name == "instrument":
        return [p for p in every if p.kind == "fixture"]
    fixtures = [f.name for f in robot.fixtures]
    if name in fixtures:
        return [p for p in every if p.kind == "fixture" and p.index == fixtures.index(name)]
    raise AssertionError(name)


def split_spec(spec: str | Iterable[str]) -> list[str]:
    """The names and groups of a parameter spec: ``"a, b"`` or ``["a", "b,c"]`` → ``["a", "b", "c"]``."""
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    return [s.strip() for item in items for s in str(item).split(",") if s.strip()]
