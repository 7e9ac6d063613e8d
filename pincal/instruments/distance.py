"""Distances to fixed points: draw-wire sensors and ballbars (docs/method.md §13.1).

Each measured value is the distance d = ‖p_k − a_j‖ [m] between marker k on the tool and an
*anchor* a_j fixed in the cell (a draw-wire's exit, a ballbar's fixed pivot). The anchors are
point fixtures of the robot (:mod:`pincal.model.fixtures`, ``on="world"``), named ``anchor`` (one)
or ``anchor0``, ``anchor1``, ... (several): their positions are known only roughly and are
identified with the robot (``anchor0.x|y|z``, group ``instrument``). Several draw-wires from
different anchors to one point on the tool make a trilateration: every parameter a point
measurement sees becomes visible again, with four or more.

With u = (p − a)/d, the rows are ∂d/∂Π = uᵀ ∂p/∂Π for the robot's parameters and −uᵀ for the
anchor's. A distance does not change when everything in the cell moves rigidly, so the base and
the anchors cannot both be identified: keep the robot's base frame (no ``base.*``) and identify
the anchors in it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pincal.errors import BadArgument
from pincal.instruments.kind import Kind
from pincal.model.fixtures import Fixture
from pincal.model.jacobian import JacobianEngine
from pincal.model.kinematics import ForwardKinematics
from pincal.model.robot import Robot
from pincal.model.statics import PayloadRows


def anchor_names(count: int) -> tuple[str, ...]:
    """The fixture names of ``count`` anchors: ``anchor`` for one, ``anchor0..`` for several."""
    return ("anchor",) if count == 1 else tuple(f"anchor{j}" for j in range(count))


def anchors(*points: object) -> tuple[Fixture, ...]:
    """Point fixtures at the anchors' nominal positions (x, y, z) [m] in the instrument's frame,
    named as :func:`anchor_names` (give them to :meth:`pincal.Robot.with_fixtures`)."""
    return tuple(Fixture(n, p, on="world", point=True) for n, p in zip(anchor_names(len(points)), points))


@dataclass(frozen=True)
class Distance(Kind):
    """Distances between markers and anchors (see module doc).

    Args:
        pairs: (marker k, anchor j) of each measured distance; default one anchor and one marker
            (marker k to anchor k); :meth:`to_anchors` for several anchors measured from one
            marker. The anchors are the robot's fixtures :func:`anchor_names`.
    """

    pairs: tuple[tuple[int, int], ...] = ((0, 0),)
    name: ClassVar[str] = "distance"

    def __post_init__(self) -> None:
        try:
            pairs = tuple((int(k), int(j)) for k, j in self.pairs)
        except (TypeError, ValueError):
            raise BadArgument(
                f"distance pairs must be (marker, anchor) indices, got {self.pairs!r}"
            ) from None
        if not pairs or any(k < 0 or j < 0 for k, j in pairs) or len(set(pairs)) != len(pairs):
            raise BadArgument(f"distance pairs must be distinct (marker, anchor) indices, got {self.pairs!r}")
        object.__setattr__(self, "pairs", pairs)

    @classmethod
    def to_anchors(cls, count: int, marker: int = 0) -> Distance:
        """``count`` anchors, each measured from marker ``marker`` (draw-wires to one tool point)."""
        return cls(tuple((marker, j) for j in range(count)))

    @property
    def n_anchors(self) -> int:
        return 1 + max(j for _, j in self.pairs)

    def anchor_indices(self, robot: Robot) -> list[int]:
        """The index in ``robot.fixtures`` of each anchor."""
        names = [f.name for f in robot.fixtures]
        return [names.index(n) for n in anchor_names(self.n_anchors)]

    def check(self, robot: Robot) -> None:
        wanted = anchor_names(self.n_anchors)
        have = {f.name: f for f in robot.fixtures}
        missing = [n for n in wanted if n not in have or not have[n].point or have[n].on != "world"]
        if missing:
            raise BadArgument(
                f"distance measurements need the anchor point(s) {', '.join(wanted)} fixed in the cell: give "
                "their nominal positions (--anchor X,Y,Z; "
                "robot.with_fixtures(*pincal.instruments.anchors(...)))",
                argument="anchor",
            )
        if max(k for k, _ in self.pairs) >= robot.n_markers:
            raise BadArgument(
                f"distance measurements name marker {max(k for k, _ in self.pairs)} but the robot has "
                f"{robot.n_markers} marker(s)",
                argument="marker",
            )

    def describe(self) -> str:
        return f"distance ({len(self.pairs)} per configuration, {self.n_anchors} anchor(s))"

    def as_dict(self) -> dict:
        return {"kind": self.name, "pairs": [list(p) for p in self.pairs]}

    def coordinates(self, robot: Robot) -> tuple[str, ...]:
        return ("d",) if len(self.pairs) == 1 else tuple(f"d{i}" for i in range(len(self.pairs)))

    def units(self, robot: Robot) -> tuple[str, ...]:
        return ("m",) * len(self.pairs)

    def _vectors(self, robot: Robot, points: np.ndarray) -> np.ndarray:
        """(m, n, 3) p_k − a_j of each pair."""
        fixtures = [robot.fixtures[i].placement.translation for i in self.anchor_indices(robot)]
        return np.stack([points[:, k] - fixtures[j] for k, j in self.pairs], axis=1)

    def predict(self, robot: Robot, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        return np.linalg.norm(self._vectors(robot, ForwardKinematics(robot).markers(qs, payload)), axis=2)

    def rows(self, engine: JacobianEngine, qs: np.ndarray, payload: PayloadRows = None) -> np.ndarray:
        robot, m = engine.robot, len(qs)
        J = engine.jacobian(qs, frame="world", payload=payload).reshape(m, robot.n_markers, 3, -1)
        vectors = self._vectors(robot, ForwardKinematics(robot).markers(qs, payload))
        u = vectors / np.linalg.norm(vectors, axis=2, keepdims=True)
        out = np.stack(
            [np.einsum("mi,mip->mp", u[:, i], J[:, k]) for i, (k, _) in enumerate(self.pairs)], axis=1
        )
        fixture_of = self.anchor_indices(robot)
        for col, p in enumerate(engine.params.parameters):
            if p.kind == "fixture" and p.index in fixture_of:
                j = fixture_of.index(p.index)
                for i, (_, jj) in enumerate(self.pairs):
                    if jj == j:
                        out[:, i, col] = -u[:, i, p.component]
        return out
