"""pincal: choose the measurement configurations of a robot calibration for where the robot works,
then calibrate.

Data flows one way: robot → parameters → Jacobians → criteria → design → (simulate | identify) →
campaign → compensate / export / show.

    >>> import pincal
    >>> robot = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
    >>> params = robot.parameters("full,offsets").identifiable().identifiable
    >>> len(params)
    27

The names here are the workflow; each stage is a public subpackage holding the rest, with its own
``__all__``: :mod:`pincal.model` (robots, parameters, identifiability, DH tables, payloads),
:mod:`pincal.evaluation` (criteria, regions, accuracy, the data check), :mod:`pincal.planning`
(design, plans, constraints in :mod:`pincal.planning.constraints`), :mod:`pincal.calibration`
(measurements, identification, validation, simulation, export), :mod:`pincal.compensation`,
:mod:`pincal.campaign` (ordered, checked, timed campaigns; the next poses from the data so far),
:mod:`pincal.viewing`, :mod:`pincal.errors` (every exception and warning) and
:mod:`pincal.typing` (the types of pincal's arguments).

``import pincal`` imports none of them: each name is imported from its stage on first use, so
that ``import pincal`` and ``pincal --help`` take milliseconds, not the second NumPy, Pinocchio
and SciPy take (PEP 562; type checkers and editors read the imports below).
"""

from __future__ import annotations

import importlib
import sys
import warnings
from typing import TYPE_CHECKING, Any

from pincal.deprecation import REMOVAL as _REMOVAL
from pincal.version import __version__

if TYPE_CHECKING:
    from pincal.calibration.identification import identify
    from pincal.calibration.measurements import MeasurementData
    from pincal.calibration.monte_carlo import monte_carlo
    from pincal.calibration.result import IdentificationResult
    from pincal.calibration.synthetic import random_errors, simulate_measurements
    from pincal.calibration.urdf_export import export_urdf
    from pincal.calibration.validation import validate
    from pincal.campaign.adaptive import next_poses
    from pincal.campaign.schedule import plan_campaign
    from pincal.compensation.compensate import compensate
    from pincal.errors import PincalError, PincalWarning
    from pincal.evaluation.accuracy import accuracy
    from pincal.evaluation.classic import criteria
    from pincal.evaluation.prior import Prior
    from pincal.evaluation.region import TestPath, around, cartesian_box
    from pincal.evaluation.test_pose import rho0
    from pincal.model.loading import load_robot, shipped_robots
    from pincal.model.parameters import ParameterSet
    from pincal.model.robot import Robot
    from pincal.model.statics import Payload
    from pincal.planning.baselines import random_plans
    from pincal.planning.driver import design
    from pincal.planning.options import Loads, Safety, Search
    from pincal.planning.plan import Plan
    from pincal.planning.results import DesignResult
    from pincal.viewing.scene import scene, show

__all__ = [
    "DesignResult",
    "IdentificationResult",
    "Loads",
    "MeasurementData",
    "ParameterSet",
    "Payload",
    "PincalError",
    "PincalWarning",
    "Plan",
    "Prior",
    "Robot",
    "Safety",
    "Search",
    "TestPath",
    "__version__",
    "accuracy",
    "around",
    "cartesian_box",
    "compensate",
    "criteria",
    "design",
    "export_urdf",
    "identify",
    "load_robot",
    "monte_carlo",
    "next_poses",
    "plan_campaign",
    "random_errors",
    "random_plans",
    "rho0",
    "scene",
    "shipped_robots",
    "show",
    "simulate_measurements",
    "validate",
]

_HOMES = {
    "pincal.calibration.identification": ("identify",),
    "pincal.calibration.measurements": ("MeasurementData",),
    "pincal.calibration.monte_carlo": ("monte_carlo",),
    "pincal.calibration.result": ("IdentificationResult",),
    "pincal.calibration.synthetic": (
        "random_errors",
        "simulate_measurements",
    ),
    "pincal.calibration.urdf_export": ("export_urdf",),
    "pincal.calibration.validation": ("validate",),
    "pincal.campaign.adaptive": ("next_poses",),
    "pincal.campaign.schedule": ("plan_campaign",),
    "pincal.compensation.compensate": ("compensate",),
    "pincal.errors": (
        "PincalError",
        "PincalWarning",
    ),
    "pincal.evaluation.accuracy": ("accuracy",),
    "pincal.evaluation.classic": ("criteria",),
    "pincal.evaluation.prior": ("Prior",),
    "pincal.evaluation.region": (
        "TestPath",
        "around",
        "cartesian_box",
    ),
    "pincal.evaluation.test_pose": ("rho0",),
    "pincal.model.loading": (
        "load_robot",
        "shipped_robots",
    ),
    "pincal.model.parameters": ("ParameterSet",),
    "pincal.model.robot": ("Robot",),
    "pincal.model.statics": ("Payload",),
    "pincal.planning.baselines": ("random_plans",),
    "pincal.planning.driver": ("design",),
    "pincal.planning.options": (
        "Loads",
        "Safety",
        "Search",
    ),
    "pincal.planning.plan": ("Plan",),
    "pincal.planning.results": ("DesignResult",),
    "pincal.viewing.scene": (
        "scene",
        "show",
    ),
}
"""The module defining each public name, imported on first use (the imports above). Each name is
also public in its stage (``pincal.model``, ...)."""

_TOP_LEVEL_0_1 = frozenset(
    """
    DEFAULT_SIGMA AccuracyReport AmbiguousTip BadArgument BadConfiguration BadConstraint BadDHTable
    BadMeasurementData BadPlanFile CannotWrite CartesianBox Criteria DHTable DataCheck
    DataCheckWarning DegenerateOptimum DegenerateOptimumWarning DesignResult ErrorProfile
    FloorUnreachable FrameNotFound HalfSpace Identifiability IdentificationFailed
    IdentificationResult Infeasible JointLimits MeasurementData MinSpacing MissingDependency
    MonteCarloResult Neighbourhood NoInertias Outlier OverwriteRefused Parameter ParameterSet
    PincalError PincalWarning Plan PredictedError Prior RandomErrors RandomPlans Robot
    RobotNotFound Scene SelfCollision SingularPlan StartRecord TestPath TestPoseCriterion
    TestRegion UnknownName UnknownParameter UnsupportedJoint UrdfError Validation Visibility
    WorkspaceBox WorstFound __version__ accuracy around cartesian_box check_plan criteria design
    error_profile export_urdf holdout identifiability identify information_matrix kfold
    load_constraints load_robot monte_carlo position_covariance random_errors random_plans rho0
    rho0_each scene shipped_robots show simulate_measurements urdf_from_dh validate worst_found
    """.split()
)
"""The top level before names moved to their stage: pincal 0.1.0's ``__all__`` (commit 0b3eb34) and
NoInertias, top-level in 0.2's development until the move. History, never edited: the names here
that are not in ``__all__`` still work, with a DeprecationWarning naming their home, until pincal
0.3; each one's home is the stage whose ``__all__`` holds it (written there once)."""

_STAGE_LISTS = (
    "pincal.errors",
    "pincal.model",
    "pincal.instruments",
    "pincal.evaluation",
    "pincal.planning",
    "pincal.planning.constraints",
    "pincal.calibration",
    "pincal.compensation",
    "pincal.campaign",
    "pincal.viewing",
)
"""The stages a moved name is looked up in, in the data flow's order, so that finding a name
imports little its value does not need (a test checks that exactly one of them holds each name)."""

_NO_LIST = {"DEFAULT_SIGMA": "pincal.arguments"}
"""Moved names whose home has no ``__all__`` (pincal.arguments holds the argument checks)."""

_STAGES = (
    "model",
    "instruments",
    "evaluation",
    "planning",
    "calibration",
    "compensation",
    "campaign",
    "viewing",
    "errors",
    "typing",
    "arguments",
    "cli",
)
"""The public subpackages and modules, imported on first use as attributes (``pincal.model``)."""

_HOME = {name: home for home, names in _HOMES.items() for name in names}
_MOVED_NAMES = _TOP_LEVEL_0_1.difference(__all__)


def _moved_home(name: str) -> str:
    """The stage holding a name moved out of the top level (imports stages up to that one)."""
    if name in _NO_LIST:
        return _NO_LIST[name]
    for stage in _STAGE_LISTS:
        if name in importlib.import_module(stage).__all__:
            return stage
    raise AttributeError(f"pincal.{name} was removed from every stage: no home to point to")


def _moved() -> dict[str, tuple[str, ...]]:
    """Each stage and the moved names it holds (imports every stage; for tests and tools)."""
    homes = {name: _moved_home(name) for name in sorted(_MOVED_NAMES)}
    return {home: tuple(n for n in sorted(homes) if homes[n] == home) for home in sorted(set(homes.values()))}


if not TYPE_CHECKING:  # type checkers see the imports above; an unknown name stays an error there

    def __getattr__(name: str) -> Any:
        """A public name, imported from its stage on first use (then a plain attribute); a name
        moved to a stage in 0.2, with a DeprecationWarning; a stage subpackage."""
        if name in _HOME:
            value = getattr(importlib.import_module(_HOME[name]), name)
            globals()[name] = value
            return value
        if name in _MOVED_NAMES:
            home = _moved_home(name)
            if sys._getframe(1).f_code.co_filename.startswith("<frozen importlib"):
                # 'from pincal import X' looks X up twice: warn once, at the user's line
                return getattr(importlib.import_module(home), name)
            warnings.warn(
                f"pincal.{name} is deprecated: use {home}.{name} (the top level keeps the workflow's "
                f"names; pincal.{name} will be removed in pincal {_REMOVAL})",
                DeprecationWarning,
                stacklevel=2,
            )
            return getattr(importlib.import_module(home), name)
        if name in _STAGES:
            return importlib.import_module(f"pincal.{name}")
        if name in ("_MOVED", "_MOVED_TO"):  # computed on demand: they import every stage
            moved = _moved()
            globals()["_MOVED"] = moved
            globals()["_MOVED_TO"] = {n: home for home, names in moved.items() for n in names}
            return globals()[name]
        raise AttributeError(f"module 'pincal' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*__all__, *_STAGES})
