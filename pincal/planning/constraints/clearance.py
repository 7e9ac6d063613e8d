"""The clearance kept from the mounting plane and from the obstacles of a workcell.

:class:`Clearance` is the distance a design keeps between what the joints move and the plane the
robot is mounted on (its markers, tip and link origins, :class:`~pincal.planning.constraints.Mount`)
and between the robot and every obstacle (:class:`~pincal.planning.constraints.Workcell`). It
checks nothing itself: :func:`~pincal.planning.constraints.with_safety` gives the Mount and the
Workcell among the constraints at least that distance, and keeps the Clearance among them, so that
adding the safe defaults again (a design inside ``next_poses``, a campaign of a designed plan)
keeps the clearance first chosen, 0 included.
"""

from __future__ import annotations

from dataclasses import dataclass

from pincal.model.robot import Robot
from pincal.planning.constraints.base import Bound, Constraint, NothingChecked, number


@dataclass(frozen=True)
class Clearance(Constraint):
    """Keep ``distance`` [m] from the mounting plane and from every obstacle (see the module doc).

    Attributes:
        distance: the clearance [m] (≥ 0; 0: only what the Mount and the Workcell ask themselves).
    """

    distance: float
    key = "clearance"

    def __post_init__(self) -> None:
        object.__setattr__(self, "distance", number(self.distance, "clearance", 0.0))

    def bind(self, robot: Robot) -> Bound:
        return _Carried()


class _Carried(NothingChecked):
    """A Clearance bound to a robot: it checks nothing (the Mount and the Workcell do)."""
