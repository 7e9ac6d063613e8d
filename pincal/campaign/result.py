"""A campaign: the moves of the tour through a plan's poses, each checked, timed, and written as
CSV or text (:class:`Campaign`, planned by :func:`pincal.campaign.schedule.plan_campaign`)."""

from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass

import numpy as np

from pincal.campaign.line_of_sight import Occlusion
from pincal.campaign.motion import Detour, MoveCheck
from pincal.campaign.timing import Timing
from pincal.errors import CannotWrite
from pincal.files import csv_header
from pincal.model.robot import Robot
from pincal.outputs import atomic_write_text
from pincal.planning.plan import Plan

HOME = -1
"""The index that stands for the home configuration in :attr:`Move.start` and :attr:`Move.end`."""


@dataclass(frozen=True, eq=False)
class Move:
    """One move of the campaign.

    Attributes:
        start: the plan row it leaves (0-based), or :data:`HOME`.
        end: the plan row it goes to, or :data:`HOME`.
        time: its duration [s] (through the detour when there is one).
        check: the check of the straight move (None when moves are not checked).
        detour: the detour taken instead of the straight move, or None.
    """

    start: int
    end: int
    time: float
    check: MoveCheck | None = None
    detour: Detour | None = None

    @property
    def clear(self) -> bool | None:
        """The move as run (straight or by its detour) is certified clear (None: not checked)."""
        if self.check is None:
            return None
        return self.check.clear or self.detour is not None

    def as_dict(self) -> dict:
        return {
            "from": None if self.start == HOME else self.start,
            "to": None if self.end == HOME else self.end,
            "time": self.time,
            "clear": self.clear,
            "check": None if self.check is None else self.check.as_dict(),
            "via": None if self.detour is None else self.detour.via.tolist(),
            "via_checks": None
            if self.detour is None
            else [self.detour.first.as_dict(), self.detour.second.as_dict()],
        }


@dataclass(frozen=True, eq=False)
class Campaign:
    """A plan as a technician runs it (see the module doc).

    Attributes:
        robot: the robot.
        plan: the plan as given.
        home: (nq,) the configuration the campaign starts and ends at [rad or m].
        order: the plan's rows (0-based) in the order they are measured.
        moves: the m + 1 moves: home to the first pose, ..., the last pose to home.
        timing: the time model.
        exact: the order is the optimum (Held–Karp), else a 2-opt/Or-opt local optimum.
        given_time: the campaign's time in the plan's own order, without detours [s].
        checked: the moves and poses were checked against collisions.
        geometry: the robot geometry of the checks (``the URDF's collision geometry`` or the
            capsules), or "".
        pose_clearance: (m,) at each pose, the distance of the pair closest to its clearance [m]
            (inf: nothing to check).
        pose_closest: that pair at each pose.
        pose_required: (m,) the clearance that pair keeps [m].
        home_short: the pair at the home configuration closer than its clearance, or "".
        required: what each kind of pair keeps [m]: ``{"self": ..., "obstacle": ..., "floor": ...}``.
        occlusions: the markers the instrument cannot see (with a visibility constraint).
        skipped_pairs: pairs of the robot's shapes in contact at the reference configuration, not checked.
        home_source: where :attr:`home` comes from, in words (``given``, ``the URDF zero``, or
            ``the plan's first pose`` and why).
    """

    robot: Robot
    plan: Plan
    home: np.ndarray
    order: tuple[int, ...]
    moves: tuple[Move, ...]
    timing: Timing
    exact: bool
    given_time: float
    checked: bool = False
    geometry: str = ""
    pose_clearance: np.ndarray | None = None
    pose_closest: tuple[str, ...] = ()
    pose_required: np.ndarray | None = None
    home_short: str = ""
    required: dict | None = None
    occlusions: tuple[Occlusion, ...] = ()
    skipped_pairs: tuple[str, ...] = ()
    home_source: str = ""

    @property
    def m(self) -> int:
        """Number of measurement poses."""
        return len(self.order)

    @property
    def move_time(self) -> float:
        """Time spent moving [s]."""
        return float(sum(mv.time for mv in self.moves))

    @property
    def stop_time(self) -> float:
        """Time spent at the poses (settle and dwell) [s]."""
        return self.m * self.timing.stop

    @property
    def total(self) -> float:
        """The campaign's time from home and back [s]."""
        return self.move_time + self.stop_time

    @property
    def blocked(self) -> tuple[str, ...]:
        """The moves that could not be made clear, named (``pose 3 → pose 7: link_4 / table ...``)."""
        out = []
        for mv in self.moves:
            if mv.check is not None and not mv.clear:
                out.append(f"{self._name(mv.start)} → {self._name(mv.end)}: {mv.check.blocked}")
        return tuple(out)

    @property
    def unsafe_poses(self) -> tuple[int, ...]:
        """The poses (0-based plan rows) closer than their clearance to something."""
        if self.pose_clearance is None:
            return ()
        assert self.pose_required is not None  # set with pose_clearance (a checked campaign)
        return tuple(int(i) for i in np.flatnonzero(self.pose_clearance < self.pose_required - 1e-12))

    @property
    def closest_pose(self) -> int | None:
        """The pose (0-based plan row) whose closest pair comes nearest to its clearance (None:
        not checked, or nothing to check)."""
        if self.pose_clearance is None or self.pose_required is None or not self.m:
            return None
        excess = self.pose_clearance - self.pose_required
        if not np.isfinite(excess).any():
            return None
        return int(np.argmin(excess))

    def _name(self, index: int) -> str:
        return "home" if index == HOME else f"pose {index + 1}"

    def waypoints(self) -> list[tuple[np.ndarray, int, float]]:
        """Every configuration the robot goes through, in order: (q, plan row + 1 for a
        measurement pose or 0 for home and a detour's via point, time spent there [s])."""
        out = [(self.home, 0, 0.0)]
        for mv in self.moves:
            if mv.detour is not None:
                out.append((mv.detour.via, 0, 0.0))
            if mv.end == HOME:
                out.append((self.home, 0, 0.0))
            else:
                out.append((self.plan.q[mv.end], mv.end + 1, self.timing.stop))
        return out

    def to_csv_text(self, degrees: bool = False) -> str:
        """The robot program as CSV: a header of joint names, ``pose`` and ``wait``, then every
        waypoint (:meth:`waypoints`), joints in radians (revolute ones in degrees if asked) and
        metres, ``pose`` the plan row measured there (1-based; 0 for home and via points), ``wait``
        the time spent there [s]."""
        out = io.StringIO()
        out.write("# pincal campaign: " + self.summary() + "\n")
        out.write(csv_header([*self.robot.joint_names, "pose", "wait"]))  # a name with a comma quoted
        for q, pose, wait in self.waypoints():
            values = self.robot.to_degrees(q) if degrees else q
            if not (np.all(np.isfinite(values)) and math.isfinite(wait)):
                raise CannotWrite(
                    f"the campaign's waypoint {list(map(float, values))} (wait {wait!r} s) is not finite: "
                    "no robot program is written"
                )
            out.write(",".join([*(repr(float(v)) for v in values), str(pose), f"{wait:g}"]) + "\n")
        return out.getvalue()

    def to_csv(self, path: str | os.PathLike, degrees: bool = False) -> None:
        """Write :meth:`to_csv_text` atomically."""
        atomic_write_text(path, self.to_csv_text(degrees))

    def summary(self) -> str:
        """One line: poses, order, time."""
        how = "optimal order" if self.exact else "2-opt/Or-opt order"
        return f"{self.m} poses, {how}, {self.total / 60:.3g} min from home and back"

    def as_dict(self) -> dict:
        return {
            "m": self.m,
            "order": list(self.order),
            "home": self.home.tolist(),
            "home_source": self.home_source,
            "exact": self.exact,
            "total": self.total,
            "move_time": self.move_time,
            "stop_time": self.stop_time,
            "given_time": self.given_time,
            "gain": self.given_time - self.tour_time,
            "moves": [mv.as_dict() for mv in self.moves],
            "dwell": [self.timing.dwell] * self.m,
            "settle": [self.timing.settle] * self.m,
            "timing": self.timing.as_dict(),
            "checked": self.checked,
            "geometry": self.geometry,
            "required": self.required,
            "pose_clearance": None
            if self.pose_clearance is None
            else [float(v) if math.isfinite(v) else None for v in self.pose_clearance],
            "pose_closest": list(self.pose_closest),
            "blocked": list(self.blocked),
            "unsafe_poses": list(self.unsafe_poses),
            "closest_pose": self.closest_pose,
            "home_short": self.home_short,
            "occlusions": [o.as_dict() for o in self.occlusions],
            "skipped_pairs": list(self.skipped_pairs),
        }

    @property
    def tour_time(self) -> float:
        """The campaign's time in the chosen order without detours [s] (to compare with
        :attr:`given_time`)."""
        straight = [self.timing.move_time(*self._ends(mv)) for mv in self.moves]
        return float(sum(straight)) + self.stop_time

    def _ends(self, mv: Move) -> tuple[np.ndarray, np.ndarray]:
        def q(i: int) -> np.ndarray:
            return self.home if i == HOME else self.plan.q[i]

        return q(mv.start), q(mv.end)

    def lines(self) -> list[str]:
        """The report: order, times, checks."""
        t = self.timing
        out = [f"campaign: {self.summary()}"]
        out.append(f"  {t.describe()}")
        if self.home_source:
            out.append(f"  home: {self.home_source}")
        saved = self.given_time - self.tour_time
        out.append(
            f"  in the plan's order: {self.given_time / 60:.3g} min; this order saves {saved:.3g} s "
            f"({100 * saved / max(self.given_time, 1e-12):.3g} %)"
        )
        out.append(
            f"  moving {self.move_time:.4g} s, at the poses {self.stop_time:.4g} s "
            f"({self.m} × ({t.settle:g} s settle + {t.dwell:g} s dwell))"
        )
        out.append("  order (plan rows, 1-based): " + " ".join(str(i + 1) for i in self.order))
        for mv in self.moves:
            line = f"    {self._name(mv.start):>8} → {self._name(mv.end):<8} {mv.time:7.3f} s"
            if mv.check is not None:
                c = mv.check
                if mv.detour is not None:
                    line += f"  detour (straight: {c.blocked})"
                elif c.clear and not math.isfinite(c.certified):
                    line += "  clear: nothing to check"
                elif c.clear:
                    line += (
                        f"  clear (certified ≥ {c.certified * 1e3:.3g} mm; closest {c.sampled * 1e3:.4g} mm, "
                        f"{c.closest}; {c.evaluations} evaluations)"
                    )
                else:
                    line += f"  NOT CLEAR: {c.blocked}"
            out.append(line)
        if self.checked:
            out.append(f"  checked against: {self.geometry}")
            if self.required:
                r = self.required
                out.append(
                    f"  clearance kept: self {r['self'] * 1e3:.3g} mm, "
                    f"obstacles {r['obstacle'] * 1e3:.3g} mm, floor {r['floor'] * 1e3:.3g} mm"
                )
            closest = self.closest_pose
            if closest is not None:
                i = closest
                assert self.pose_clearance is not None and self.pose_required is not None  # checked
                short = "  ** closer than the clearance **" if i in self.unsafe_poses else ""
                out.append(
                    f"  closest pose: pose {i + 1}, {self.pose_closest[i]} "
                    f"{self.pose_clearance[i] * 1e3:.4g} mm "
                    f"(kept: {self.pose_required[i] * 1e3:.3g} mm){short}"
                )
            if self.skipped_pairs:
                out.append(
                    "  not checked (in contact at the reference configuration): "
                    + ", ".join(self.skipped_pairs)
                )
            for name in self.blocked:
                out.append(f"  blocked: {name}")
            if self.home_short:
                out.append(f"  home itself is too close: {self.home_short}")
            for i in self.unsafe_poses:
                assert self.pose_clearance is not None  # unsafe_poses are empty without it
                out.append(
                    f"  pose {i + 1} itself is too close: {self.pose_closest[i]} "
                    f"{self.pose_clearance[i] * 1e3:.3g} mm"
                )
        else:
            out.append("  moves not checked for collisions")
        for o in self.occlusions:
            out.append(f"  line of sight: {o}")
        return out
