"""A laser tracker at a known position sees every marker (range and incidence angle)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pincal.errors import BadConstraint
from pincal.model.robot import Robot
from pincal.planning.constraints.base import Bound, Constraint, Kinematics, number, vector


@dataclass(frozen=True)
class Visibility(Constraint):
    """A laser tracker at ``tracker`` sees every marker.

    Attributes:
        tracker: (x, y, z) position of the instrument [m] (instrument frame).
        max_range: largest tracker-to-marker distance [m].
        min_range: smallest tracker-to-marker distance [m] (default 0).
        normal: the marker's normal in the tip frame (one (x, y, z) for all markers, or one per
            marker); needed for ``max_angle``.
        max_angle: largest angle between the marker normal and the line of sight from the marker
            to the tracker [rad] (None: no incidence limit).
    """

    tracker: tuple[float, float, float]
    max_range: float = math.inf
    min_range: float = 0.0
    normal: tuple | None = None
    max_angle: float | None = None
    key = "visibility"

    def __post_init__(self) -> None:
        object.__setattr__(self, "tracker", vector(self.tracker, "visibility tracker"))
        max_range = math.inf if self.max_range is None else self.max_range
        if max_range != math.inf:
            max_range = number(max_range, "visibility max_range", 0.0, strict=True)
        object.__setattr__(self, "max_range", float(max_range))
        object.__setattr__(self, "min_range", number(self.min_range, "visibility min_range", 0.0))
        if self.min_range >= self.max_range:
            raise BadConstraint(
                f"visibility: min_range {self.min_range:g} must be below max_range {self.max_range:g}"
            )
        if self.normal is not None:
            try:
                n = np.array(self.normal, dtype=float).reshape(-1, 3)
            except (TypeError, ValueError):
                raise BadConstraint(
                    f"visibility normal must be (x, y, z) triples, got {self.normal!r}"
                ) from None
            norms = np.linalg.norm(n, axis=1)
            if not np.all(np.isfinite(n)) or np.any(norms < 1e-12):
                raise BadConstraint(f"visibility normal must be finite and non-zero, got {self.normal!r}")
            object.__setattr__(self, "normal", tuple(map(tuple, (n / norms[:, None]).tolist())))
        if self.max_angle is not None:
            angle = number(self.max_angle, "visibility max_angle [rad]", 0.0, strict=True)
            if angle > math.pi:
                raise BadConstraint(f"visibility max_angle must be at most pi radians, got {angle:g}")
            if self.normal is None:
                raise BadConstraint("visibility max_angle needs the marker normal (in the tip frame)")
            object.__setattr__(self, "max_angle", angle)

    def bind(self, robot: Robot) -> Bound:
        normals = None
        if self.normal is not None:
            normals = np.array(self.normal)
            if len(normals) not in (1, robot.n_markers):
                raise BadConstraint(
                    f"visibility: {len(normals)} marker normals for {robot.n_markers} markers "
                    f"(give one for all, or one per marker)"
                )
            normals = np.broadcast_to(normals, (robot.n_markers, 3))
        return VisibilityBound(self, normals)


class VisibilityBound(Bound):
    def __init__(self, spec: Visibility, normals: np.ndarray | None) -> None:
        self.tracker = np.array(spec.tracker)
        self.spec = spec
        self.normals = normals

    def margins(self, kin: Kinematics) -> np.ndarray:
        s = self.spec
        sight = self.tracker - kin.points  # (m, K, 3) marker -> tracker
        dist = np.linalg.norm(sight, axis=2)
        out = [dist - s.min_range]
        if np.isfinite(s.max_range):
            out.append(s.max_range - dist)
        if s.max_angle is not None:
            assert self.normals is not None  # bound with the tip's normals when there is a max_angle
            n_world = np.einsum("mij,kj->mki", kin.rotations, self.normals)
            cos = np.einsum("mki,mki->mk", n_world, sight) / np.maximum(dist, 1e-12)
            out.append(s.max_angle - np.arccos(np.clip(cos, -1.0, 1.0)))
        return np.concatenate(out, axis=1)
