"""ISO 9283 pose characteristics: position and orientation accuracy and repeatability at each pose
of the test cube, and distance accuracy and repeatability between two poses (docs/method.md §8.5).

For a pose commanded n times (cycles j = 1 … n), with d_j = p_j − p_c,j the attained position less
the commanded one (ISO 9283 commands one pose, p_c,j = p_c; recorded commands that differ by a few
tenths of a millimetre are compared cycle by cycle, which is ISO's formula when they are equal):

* AP = ‖d̄‖ = √((x̄ − x_c)² + (ȳ − y_c)² + (z̄ − z_c)²);
* RP = l̄ + 3 S_l with l_j = ‖d_j − d̄‖ = √((x_j − x̄)² + (ȳ_j − ȳ)² + (z_j − z̄)²) and
  S_l = √(Σ (l_j − l̄)² / (n − 1));
* orientation: (a_j, b_j, c_j) = log(R_c,jᵀ R_j), the attained orientation's small rotation from the
  commanded one about the commanded frame's x, y, z axes [rad] (well defined at any orientation,
  where differences of Euler angles are not: at pitch ±90° they are singular);
  AP_a = ā − a_c = ā (a_c = 0 in this convention), RP_a = ±3 S_a, S_a = √(Σ (a_j − ā)² / (n − 1)),
  and b, c alike;
* distance between poses A and B: D_j = ‖p_A,j − p_B,j‖ and D_c,j the commanded one,
  AD = D̄ − D̄_c, RD = ±3 S_D with S_D the sample standard deviation of D_j − D_c,j (cycles matched by
  number). A distance does not depend on the frame the poses are expressed in.

Repeatabilities need n ≥ 2 (S divides by n − 1): with one cycle they are None. ISO 9283 prescribes
30 cycles. Lengths in metres, angles in radians.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
import pinocchio as pin

from pincal.errors import BadArgument, BadMeasurementData
from pincal.evaluation.pose_cycles import PoseCycles

ISO_CYCLES = 30
"""The number of cycles ISO 9283 prescribes."""

ISO_PAIR = ("P2", "P4")
"""The poses ISO 9283 measures distance accuracy between: opposite corners of the cube's plane."""


@dataclass(frozen=True)
class PoseCharacteristics:
    """ISO 9283 accuracy and repeatability at one pose.

    Attributes:
        test: the test (cube) the pose belongs to (``""`` for one test).
        pose: the pose's name.
        n: the number of cycles.
        commanded: (3,) the mean commanded position [m].
        deviation: (3,) the mean attained position less the commanded one, d̄ [m].
        ap: position accuracy AP = ‖d̄‖ [m].
        rp: position repeatability RP = l̄ + 3 S_l [m], or None (one cycle).
        ap_abc: (3,) orientation accuracy AP_a, AP_b, AP_c [rad], or None (no orientations).
        rp_abc: (3,) orientation repeatability RP_a, RP_b, RP_c (the ± of ±3 S) [rad], or None.
    """

    test: str
    pose: str
    n: int
    commanded: np.ndarray
    deviation: np.ndarray
    ap: float
    rp: float | None
    ap_abc: np.ndarray | None
    rp_abc: np.ndarray | None

    def as_dict(self) -> dict[str, object]:
        """JSON-ready values, in metres and radians."""
        return {
            "test": self.test,
            "pose": self.pose,
            "n": self.n,
            "commanded": self.commanded.tolist(),
            "deviation": self.deviation.tolist(),
            "AP": self.ap,
            "RP": self.rp,
            "AP_abc": None if self.ap_abc is None else self.ap_abc.tolist(),
            "RP_abc": None if self.rp_abc is None else self.rp_abc.tolist(),
        }


@dataclass(frozen=True)
class DistanceCharacteristics:
    """ISO 9283 distance accuracy and repeatability between two poses.

    Attributes:
        test: the test (cube).
        poses: the two poses' names.
        n: the number of cycles with both poses.
        commanded: the mean commanded distance D̄_c [m].
        mean: the mean attained distance D̄ [m].
        ad: distance accuracy AD = D̄ − D̄_c [m].
        rd: distance repeatability RD (the ± of ±3 S_D) [m], or None (one cycle).
    """

    test: str
    poses: tuple[str, str]
    n: int
    commanded: float
    mean: float
    ad: float
    rd: float | None

    def as_dict(self) -> dict[str, object]:
        """JSON-ready values, in metres."""
        return {
            "test": self.test,
            "poses": list(self.poses),
            "n": self.n,
            "D_c": self.commanded,
            "D": self.mean,
            "AD": self.ad,
            "RD": self.rd,
        }


def _sample_std(values: np.ndarray) -> np.ndarray:
    """Standard deviation over axis 0 with n − 1 (values has n ≥ 2 rows)."""
    return np.sqrt(np.sum((values - values.mean(axis=0)) ** 2, axis=0) / (len(values) - 1))


def orientation_deviations(commanded: np.ndarray, attained: np.ndarray) -> np.ndarray:
    """(n, 3) small rotations (a, b, c) [rad] from each commanded orientation to the attained one,
    about the commanded frame's x, y, z axes: log(R_cᵀ R)."""
    return np.array([pin.log3(c.T @ r) for c, r in zip(commanded, attained, strict=True)]).reshape(-1, 3)


def pose_characteristics(
    commanded: np.ndarray,
    attained: np.ndarray,
    commanded_rotations: np.ndarray | None = None,
    attained_rotations: np.ndarray | None = None,
    *,
    test: str = "",
    pose: str = "",
) -> PoseCharacteristics:
    """AP, RP (and with orientations AP_a/b/c, RP_a/b/c) of one pose over its n cycles.

    Args:
        commanded: (n, 3) commanded positions, cycle by cycle (one row repeated for ISO's one
            command) [m].
        attained: (n, 3) attained positions, in the commanded frame [m].
        commanded_rotations: (n, 3, 3) commanded orientations, or None.
        attained_rotations: (n, 3, 3) attained orientations, or None.
        test: the test's name, carried into the result.
        pose: the pose's name, carried into the result.
    """
    c = np.asarray(commanded, dtype=float).reshape(-1, 3)
    d = np.asarray(attained, dtype=float).reshape(-1, 3) - c
    n = len(d)
    if n == 0:
        raise BadMeasurementData(f"pose {pose!r}: no cycle")
    mean = d.mean(axis=0)
    rp = None
    if n >= 2:
        lengths = np.linalg.norm(d - mean, axis=1)
        rp = float(lengths.mean() + 3.0 * _sample_std(lengths))
    ap_abc = rp_abc = None
    if commanded_rotations is not None and attained_rotations is not None:
        abc = orientation_deviations(commanded_rotations, attained_rotations)
        ap_abc = abc.mean(axis=0)
        rp_abc = 3.0 * _sample_std(abc) if n >= 2 else None
    return PoseCharacteristics(
        test, pose, n, c.mean(axis=0), mean, float(np.linalg.norm(mean)), rp, ap_abc, rp_abc
    )


def distance_characteristics(
    commanded_a: np.ndarray,
    attained_a: np.ndarray,
    commanded_b: np.ndarray,
    attained_b: np.ndarray,
    *,
    test: str = "",
    poses: tuple[str, str] = ("", ""),
) -> DistanceCharacteristics:
    """AD and RD between poses A and B over n cycles (row j of each array: cycle j) [m]."""
    d = np.linalg.norm(np.asarray(attained_a, float) - np.asarray(attained_b, float), axis=1)
    dc = np.linalg.norm(np.asarray(commanded_a, float) - np.asarray(commanded_b, float), axis=1)
    n = len(d)
    if n == 0 or len(dc) != n:
        raise BadMeasurementData(f"distance {poses[0]}-{poses[1]}: no cycle with both poses")
    rd = float(3.0 * _sample_std(d - dc)) if n >= 2 else None
    return DistanceCharacteristics(
        test, poses, n, float(dc.mean()), float(d.mean()), float(d.mean() - dc.mean()), rd
    )


@dataclass(frozen=True)
class Iso9283Report:
    """ISO 9283 pose characteristics of every pose of every test, and distance characteristics.

    Attributes:
        poses: one :class:`PoseCharacteristics` per (test, pose), in the data's order.
        distances: one :class:`DistanceCharacteristics` per (test, pair of poses).
        frame: how the attained poses were expressed (``PoseCycles.frame``).
    """

    poses: tuple[PoseCharacteristics, ...]
    distances: tuple[DistanceCharacteristics, ...]
    frame: str

    @property
    def oriented(self) -> bool:
        """True when orientations were compared."""
        return any(p.ap_abc is not None for p in self.poses)

    def summary(self) -> dict[str, float | None]:
        """Over every pose: the largest and the mean AP, the largest RP (None without repeatability)
        [m], and the largest |AP_a|, |AP_b|, |AP_c| and RP_a/b/c [rad]."""
        ap = np.array([p.ap for p in self.poses])
        rp = [p.rp for p in self.poses if p.rp is not None]
        out: dict[str, float | None] = {
            "poses": float(len(self.poses)),
            "AP_max": float(ap.max()),
            "AP_mean": float(ap.mean()),
            "RP_max": max(rp) if rp else None,
        }
        if self.oriented:
            out["AP_abc_max"] = float(max(np.abs(p.ap_abc).max() for p in self.poses if p.ap_abc is not None))
            rps = [p.rp_abc.max() for p in self.poses if p.rp_abc is not None]
            out["RP_abc_max"] = float(max(rps)) if rps else None
        return out

    def lines(self, descriptions: dict[str, str] | None = None) -> list[str]:
        """The report as text, test by test: lengths in mm, angles in degrees (``descriptions``:
        a line about each test, such as its cube's centre and edge)."""
        out = [f"attained poses {self.frame}"]
        if self.oriented:
            out.append("a, b, c: rotation of the attained orientation about the commanded frame's x, y, z")
        head = f"  {'pose':6s} {'n':>3s} {'AP mm':>8s} {'RP mm':>8s}"
        if self.oriented:
            head += f" {'AP_a':>8s} {'AP_b':>8s} {'AP_c':>8s} {'RP_a':>7s} {'RP_b':>7s} {'RP_c':>7s} (deg)"
        for test in dict.fromkeys(p.test for p in self.poses):
            poses = [p for p in self.poses if p.test == test]
            n = max(p.n for p in poses)
            cycles = f"{n} cycle{'s' if n != 1 else ''}" + (
                "" if n >= ISO_CYCLES else f" (ISO 9283: {ISO_CYCLES})"
            )
            title = f"{test}: " if test else ""
            about = (descriptions or {}).get(test)
            out.append(f"{title}{about}" if about else f"{title}{cycles}")
            out.append(head)
            for p in poses:
                rp_text = "-" if p.rp is None else f"{p.rp * 1e3:.4f}"
                row = f"  {p.pose:6s} {p.n:3d} {p.ap * 1e3:8.4f} {rp_text:>8s}"
                if p.ap_abc is not None:
                    row += "".join(f" {v:+8.4f}" for v in np.degrees(p.ap_abc))
                    abc = ["-"] * 3 if p.rp_abc is None else [f"{v:.4f}" for v in np.degrees(p.rp_abc)]
                    row += "".join(f" {v:>7s}" for v in abc)
                out.append(row)
            for d in (d for d in self.distances if d.test == test):
                rd = "-" if d.rd is None else f"±{d.rd * 1e3:.4f} mm"
                out.append(
                    f"  distance {d.poses[0]}-{d.poses[1]} ({d.n} cycle{'s' if d.n != 1 else ''}): "
                    f"D_c {d.commanded * 1e3:.3f} mm, "
                    f"AD {d.ad * 1e3:+.4f} mm, RD {rd}"
                )
        ap = np.array([p.ap for p in self.poses]) * 1e3
        rps = [p.rp * 1e3 for p in self.poses if p.rp is not None]
        tail = f"over {len(self.poses)} poses: AP max {ap.max():.4f} mm, mean {ap.mean():.4f} mm"
        if rps:
            tail += f"; RP max {max(rps):.4f} mm"
        abc = [np.degrees(np.abs(p.ap_abc)).max() for p in self.poses if p.ap_abc is not None]
        if abc:
            tail += f"; |AP_a,b,c| max {max(abc):.4f} deg"
        out.append(tail)
        return out

    def as_dict(self) -> dict[str, object]:
        """JSON-ready values, in metres and radians."""
        return {
            "frame": self.frame,
            "poses": [p.as_dict() for p in self.poses],
            "distances": [d.as_dict() for d in self.distances],
            "summary": self.summary(),
        }


def iso9283(cycles: PoseCycles, pairs: list[tuple[str, str]] | None = None) -> Iso9283Report:
    """The ISO 9283 pose characteristics of poses measured in cycles.

    Args:
        cycles: the commanded and attained poses, the attained ones in the commanded frame
            (:meth:`PoseCycles.in_commanded_frame` when they are in an instrument's).
        pairs: the pairs of poses whose distance characteristics are computed, in every test that
            has both (default: ISO's P2-P4 when the poses have those names, else every pair).

    Raises:
        BadArgument: a pair names a pose no test has.
    """
    poses = []
    for test, pose in cycles.groups():
        rows = cycles.rows(test, pose)
        rotations = (None, None)
        if cycles.commanded_rotations is not None and cycles.attained_rotations is not None:
            rotations = (cycles.commanded_rotations[rows], cycles.attained_rotations[rows])
        poses.append(
            pose_characteristics(
                cycles.commanded_positions[rows],
                cycles.attained_positions[rows],
                *rotations,
                test=test,
                pose=pose,
            )
        )
    names = list(dict.fromkeys(cycles.pose))
    if pairs is None:
        pairs = [ISO_PAIR] if all(p in names for p in ISO_PAIR) else list(combinations(names, 2))
    for a, b in pairs:
        for name in (a, b):
            if name not in names:
                raise BadArgument(
                    f"pair {a},{b}: no pose {name!r}; the poses are {', '.join(names)}", argument="pair"
                )
    distances = []
    for test in cycles.tests():
        for a, b in pairs:
            rows_a, rows_b = cycles.rows(test, a), cycles.rows(test, b)
            common = sorted(set(cycles.cycle[rows_a]) & set(cycles.cycle[rows_b]))
            if not common:
                continue
            ia = np.array([i for i in rows_a if cycles.cycle[i] in common])
            ib = np.array([i for i in rows_b if cycles.cycle[i] in common])
            distances.append(
                distance_characteristics(
                    cycles.commanded_positions[ia],
                    cycles.attained_positions[ia],
                    cycles.commanded_positions[ib],
                    cycles.attained_positions[ib],
                    test=test,
                    poses=(a, b),
                )
            )
    return Iso9283Report(tuple(poses), tuple(distances), cycles.frame)
