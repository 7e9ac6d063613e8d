"""The types of pincal's arguments, by name: what a function taking joint values, a plan, a test
pose, a payload or a seed accepts. Use them to annotate code that calls pincal::

    from pincal.typing import ConfigurationsLike, TestPoseLike

    def my_rho0(params: pincal.ParameterSet, plan: ConfigurationsLike, q0: TestPoseLike) -> float:
        return pincal.rho0(params, plan, q0)

Every alias is checked where it comes in (:meth:`pincal.Robot.configurations` for joint values,
:mod:`pincal.arguments` for seeds and numbers): a value of the right type can still be refused
(joint values outside their limits, a negative seed), with a :class:`~pincal.errors.BadArgument`
naming it.

Units: joint values in radians (revolute) or metres (prismatic); points and lengths in metres.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING, TypeAlias

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:  # annotations only: pincal.typing imports no stage at run time
    import meshcat
    import pinocchio as pin

    from pincal.evaluation.region import TestRegion
    from pincal.instruments.error_model import Tracker
    from pincal.model.statics import Payload
    from pincal.planning.constraints import Visibility
    from pincal.planning.plan import Plan

__all__ = [
    "ArrayLike",
    "ConfigurationsLike",
    "InstrumentAt",
    "JointValues",
    "PathLike",
    "PayloadLike",
    "PlansLike",
    "PointsLike",
    "PoolLike",
    "RobotSource",
    "SeedLike",
    "TestPoseLike",
    "ViewerLike",
]

ArrayLike: TypeAlias = npt.ArrayLike
"""Anything NumPy reads as an array of numbers (a list, a tuple, an ndarray)."""

JointValues: TypeAlias = npt.ArrayLike
"""The (nq,) joint values of one configuration [rad or m], in the chain's joint order
(:attr:`pincal.Robot.joint_names`)."""

ConfigurationsLike: TypeAlias = "npt.ArrayLike | Plan"
"""Configurations: (nq,) joint values, (m, nq) of them [rad or m], or a :class:`pincal.Plan`."""

PlansLike: TypeAlias = "npt.ArrayLike | Plan | Sequence[Plan]"
"""One plan ((m, nq) joint values [rad or m] or a :class:`pincal.Plan`) or a batch of k plans of
the same m: (k, m, nq) joint values or a sequence of Plans (the batch evaluations return one value
per plan)."""

TestPoseLike: TypeAlias = "npt.ArrayLike | TestRegion"
"""Where the robot works: a test pose (nq,), k test poses (k, nq) [rad or m], or a region or path
(:func:`pincal.around`, :class:`pincal.TestPath`, :func:`pincal.cartesian_box`)."""

PointsLike: TypeAlias = npt.ArrayLike
"""A point (3,) or k points (k, 3) [m]: markers in the tip frame, Cartesian targets, positions."""

PayloadLike: TypeAlias = "float | Payload | Sequence[Payload] | npt.ArrayLike | None"
"""What the tip carries: None (nothing), a mass [kg] or a :class:`pincal.Payload` for every
configuration, one Payload per configuration, (m,) masses [kg] at the tip origin, or (m, 4) rows
[kg, x, y, z] (the centre of mass in the tip frame [m])."""

PoolLike: TypeAlias = "int | npt.ArrayLike | None"
"""The candidate configurations of a design: their number (drawn inside the constraints), the
(n, nq) candidates themselves [rad or m], or None (the default number)."""

SeedLike: TypeAlias = int | np.integer | np.random.Generator | np.random.SeedSequence | None
"""What every ``seed`` argument accepts: an int ≥ 0 or a ``numpy.random.SeedSequence`` (the same
draws each time), a ``numpy.random.Generator`` (its stream continues; the caller's generator
advances), or None (fresh entropy)."""

PathLike: TypeAlias = str | os.PathLike[str]
"""A file's path: text or a :class:`pathlib.Path`."""

RobotSource: TypeAlias = "str | os.PathLike[str] | pin.Model"
"""A robot to load: a URDF (or xacro) path, the name of a shipped or example-robot-data robot
(``pincal robots`` lists them), or a ``pinocchio.Model``."""

InstrumentAt: TypeAlias = "npt.ArrayLike | Visibility | Tracker | None"
"""Where the instrument stands, for a scene (``instrument_at=``): its position (x, y, z) in the
base/instrument frame [m], a :class:`~pincal.planning.constraints.Visibility` constraint (its
tracker), a :class:`~pincal.instruments.Tracker` (its ``at``), or None."""

InstrumentLike: TypeAlias = InstrumentAt
"""pincal 0.2's first name of :data:`InstrumentAt` (a position, where ``instrument=`` is an
:class:`~pincal.instruments.Instrument` across pincal); kept, out of ``__all__``, until pincal 0.3."""

ViewerLike: TypeAlias = "str | meshcat.Visualizer | None"
"""Where a scene is drawn: a ``meshcat.Visualizer``, ``"static"`` (a serverless one, for an HTML
page), or None (start a meshcat server)."""
