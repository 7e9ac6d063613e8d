"""Measurement plans: the configurations at which the robot is measured.

A :class:`Plan` is an immutable (m, nq) array of joint values [rad or m] with the joint names of
its columns, and, when the design chose them, the payload to mount at each configuration. Permuting
a plan changes no criterion; repeating it k times divides ρ0² by k.
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass

import numpy as np

from pincal.arguments import MAX_COUNT, positive_int
from pincal.errors import BadArgument, BadPlanFile, warn
from pincal.files import column_mismatch, csv_header, read_numeric_csv
from pincal.model.statics import PAYLOAD_COLUMNS, payload_columns, payload_rows
from pincal.outputs import atomic_write_text
from pincal.typing import ConfigurationsLike, PayloadLike


@dataclass(frozen=True, eq=False)
class Plan:
    """m configurations of the chain joints.

    Attributes:
        q: (m, nq) joint values [rad or m], read-only.
        joint_names: the joint of each column.
        revolute: for each column, True if its joint is revolute (its values are angles), False
            if prismatic (lengths); None when unknown (a plan not made for a robot). Writing or
            reading degrees converts the revolute columns only, so it needs to know them.
        payload: (m, 4) the payload to mount at each configuration, rows [kg, x, y, z] (centre of
            mass in the tip frame [m]), read-only; None: no payload (the plan's CSV then has no
            payload columns).
    """

    q: np.ndarray
    joint_names: tuple[str, ...]
    revolute: tuple[bool, ...] | None = None
    payload: np.ndarray | None = None

    def __post_init__(self) -> None:
        q = np.array(self.q, dtype=float, copy=True)
        if q.ndim == 1:
            q = q[None, :]
        names = tuple(self.joint_names)
        if q.ndim != 2 or q.shape[1] != len(names):
            raise BadPlanFile(
                f"a plan needs one column per joint ({len(names)}: {', '.join(names)}), "
                f"got shape {np.shape(self.q)}"
            )
        revolute = None if self.revolute is None else tuple(bool(r) for r in self.revolute)
        if revolute is not None and len(revolute) != len(names):
            raise BadPlanFile(
                f"a plan's revolute flags need one per joint ({len(names)}), got {len(revolute)}"
            )
        q.flags.writeable = False
        if self.payload is not None:
            payload = payload_rows(self.payload, len(q))
            payload.flags.writeable = False
            object.__setattr__(self, "payload", payload)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "revolute", revolute)

    @classmethod
    def for_robot(cls, robot, q: ConfigurationsLike, payload: PayloadLike = None) -> Plan:
        """A plan for ``robot`` from (m, nq) joint values, checked against its limits (and the
        payload of each configuration, see :func:`~pincal.model.statics.payload_rows`)."""
        qs = robot.configurations(q)
        # the payload becomes rows at the plan's own door (__post_init__)
        return cls(qs, robot.joint_names, tuple(robot.revolute), payload)  # type: ignore[arg-type]

    def __len__(self) -> int:
        return len(self.q)

    @property
    def m(self) -> int:
        """Number of configurations."""
        return len(self.q)

    def __array__(self, dtype=None, copy=None):
        return np.array(self.q, dtype=dtype)

    def repeat(self, k: int) -> Plan:
        """The whole plan measured ``k`` times (ρ0² is divided by k exactly)."""
        k = positive_int(k, "repeat count", high=MAX_COUNT // max(len(self.q), 1))
        payload = None if self.payload is None else np.tile(self.payload, (k, 1))
        return Plan(np.tile(self.q, (k, 1)), self.joint_names, self.revolute, payload)

    def concat(self, *others: Plan) -> Plan:
        """This plan followed by ``others`` (same joints)."""
        for other in others:
            if tuple(other.joint_names) != self.joint_names:
                raise BadPlanFile(
                    f"cannot concatenate plans of different joints: {list(self.joint_names)} "
                    f"and {list(other.joint_names)}"
                )
        known = [p.revolute for p in (self, *others) if p.revolute is not None]
        plans = (self, *others)
        payload = None
        if any(p.payload is not None for p in plans):
            payload = np.vstack([p.payload if p.payload is not None else np.zeros((p.m, 4)) for p in plans])
        return Plan(
            np.vstack([self.q, *(o.q for o in others)]),
            self.joint_names,
            known[0] if known else None,
            payload,
        )

    __add__ = concat

    # -------------------------------------------------------------------------- I/O
    def to_csv_text(self, degrees: bool = False, robot=None) -> str:
        """CSV text: a header of joint names, one configuration per row.

        Args:
            degrees: write the revolute joints in degrees (prismatic joints stay in metres).
            robot: tells revolute from prismatic joints when the plan does not know (see
                :attr:`revolute`).

        Raises:
            BadArgument: degrees asked of a plan that does not know its revolute joints, without
                a robot.
        """
        values = np.where(self._revolute(robot, "write"), np.degrees(self.q), self.q) if degrees else self.q
        header = list(self.joint_names)
        if self.payload is not None:
            values = np.hstack([values, self.payload])
            header += list(PAYLOAD_COLUMNS)
        out = io.StringIO()
        out.write(csv_header(header))
        for row in values:
            out.write(",".join(repr(float(v)) for v in row) + "\n")
        return out.getvalue()

    def to_csv(self, path: str | os.PathLike, degrees: bool = False, robot=None) -> None:
        """Write the plan as CSV (radians and metres, or the revolute joints in degrees if asked),
        atomically (see :meth:`to_csv_text`)."""
        atomic_write_text(path, self.to_csv_text(degrees, robot))

    def _revolute(self, robot, verb: str) -> np.ndarray:
        if robot is not None:
            return np.asarray(robot.revolute)
        if self.revolute is None:
            raise BadArgument(
                f"cannot {verb} a plan in degrees without knowing which joints are revolute: build it "
                f"with Plan.for_robot(robot, q) or pass robot=",
                argument="degrees",
            )
        return np.asarray(self.revolute)

    @classmethod
    def from_csv(cls, path: str | os.PathLike, robot=None, degrees: bool = False, what: str = "plan") -> Plan:
        """Read a plan CSV: header of joint names, one configuration per row.

        Args:
            path: the file.
            robot: if given, columns are matched to its joints by name (any order) and the values
                checked against its limits.
            degrees: the file holds degrees (converted to radians; prismatic joints untouched).
        """
        header, rows, lines = read_numeric_csv(path, what=what)
        named = set() if robot is None else set(robot.joint_names)  # a joint may be named payload_kg
        loads = [i for i, h in enumerate(header) if h.startswith("payload_") and h not in named]
        payload = payload_columns(
            [header[i] for i in loads], rows[:, loads], f"{what} file {str(path)!r}", BadPlanFile
        )
        keep = [i for i in range(len(header)) if i not in loads]
        header, rows = [header[i] for i in keep], rows[:, keep]
        if robot is None:
            if degrees:
                raise BadArgument(
                    f"{what} file {str(path)!r}: reading degrees needs the robot (robot=), to leave its "
                    f"prismatic joints in metres",
                    argument="degrees",
                    file=str(path),
                )
            return cls(rows, tuple(header), payload=payload)
        names = robot.joint_names
        mismatch = column_mismatch(names, header)
        if mismatch:
            raise BadPlanFile(
                f"{what} file {str(path)!r}: columns must be the joints {','.join(names)}{mismatch}"
            )
        q = rows[:, [header.index(n) for n in names]]
        if degrees:
            _check_not_radians(q[:, np.asarray(robot.revolute, dtype=bool)], f"{what} file {str(path)!r}")
            q = robot.to_radians(q)
        robot.check_limits(q, [f"{what} file {str(path)!r}, line {n}" for n in lines], degrees)
        try:
            return cls.for_robot(robot, q, payload)
        except BadArgument as exc:  # a payload row out of range: name the file
            raise BadPlanFile(f"{what} file {str(path)!r}: {exc}") from None

    def to_json(self) -> dict:
        """A JSON-ready dict: ``{"joint_names": [...], "q": [[...], ...]}`` (radians)."""
        out = {"joint_names": list(self.joint_names), "q": self.q.tolist()}
        if self.payload is not None:
            out["payload"] = self.payload.tolist()
        return out

    @classmethod
    def from_json(cls, data: dict | str) -> Plan:
        """Inverse of :meth:`to_json` (a dict or its JSON text)."""
        content = json.loads(data) if isinstance(data, str) else data
        try:
            return cls(
                np.asarray(content["q"], dtype=float),
                tuple(content["joint_names"]),
                payload=content.get("payload"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise BadPlanFile(f"not a plan: expected keys joint_names and q ({exc})") from None


RADIAN_LIKE = 3.2
"""Degrees read from a plan whose revolute values all lie within ±this (π and a little) while
several rows turn some joint look like radians read with ``degrees=True`` (``--deg``)."""


def _check_not_radians(angles: np.ndarray, where: str) -> None:
    """Warn when ``angles`` (m, n) — a file's revolute values read as degrees — look like radians:
    all within ±:data:`RADIAN_LIKE` and at least two rows with a non-zero one (a real plan in
    degrees turns its joints by more than 3°)."""
    if angles.size == 0 or np.abs(angles).max() > RADIAN_LIKE:
        return
    if np.count_nonzero(np.any(angles != 0, axis=1)) < 2:
        return
    warn(
        f"{where}: read in degrees (--deg), but every revolute value lies within ±{RADIAN_LIKE:g}, "
        f"which looks like radians (each pose within ±{RADIAN_LIKE:g}° of zero); if the file is in "
        f"radians, drop --deg (degrees=False)"
    )
