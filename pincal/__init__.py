"""pincal: choose the measurement configurations of a robot calibration for where the robot works,
then calibrate.

Data flows one way: robot → parameters → Jacobians → criteria → design → campaign →
(simulate | identify) → next poses → export → compensate → show (the stages in
:data:`pincal.stages.STAGES`).

    >>> import pincal
    >>> robot = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
    >>> params = robot.parameters("full,offsets").identifiable().identifiable
    >>> len(params)
    27

The names here are the workflow; each stage is a public subpackage holding the rest, with its own
``__all__``: :mod:`pincal.model` (robots, parameters, identifiability, DH tables, payloads),
:mod:`pincal.evaluation` (criteria, regions, accuracy, the data check), :mod:`pincal.planning`
(design, plans, constraints in :mod:`pincal.planning.constraints`), :mod:`pincal.calibration`
(measurements, identification, validation, simulation), :mod:`pincal.export` (the calibrated URDF,
MJCF, SDF, xacro and ROS files), :mod:`pincal.compensation`,
:mod:`pincal.campaign` (ordered, checked, timed campaigns), :mod:`pincal.adaptive` (the next poses
from the data so far),
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
from pincal.stages import FOUNDATIONS as _FOUNDATIONS
from pincal.stages import PUBLIC_LISTS as _PUBLIC_LISTS
from pincal.stages import STAGES as _STAGE_NAMES
from pincal.version import __version__

if TYPE_CHECKING:
    from pincal.adaptive.loop import next_poses
    from pincal.calibration.identification import identify
    from pincal.calibration.measurements import MeasurementData
    from pincal.calibration.monte_carlo import monte_carlo
    from pincal.calibration.result import IdentificationResult
    from pincal.calibration.synthetic import random_errors, simulate_measurements
    from pincal.calibration.validation import validate
    from pincal.campaign.schedule import plan_campaign
    from pincal.compensation.compensate import compensate
    from pincal.errors import PincalError, PincalWarning
    from pincal.evaluation.accuracy import accuracy
    from pincal.evaluation.classic import criteria
    from pincal.evaluation.prior import Prior
    from pincal.evaluation.region import TestPath, around, cartesian_box
    from pincal.evaluation.test_pose import rho0
    from pincal.export.urdf import export_urdf
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

_STAGE_LISTS = tuple(f"pincal.{module}" for module in _PUBLIC_LISTS)
"""The modules a public or moved name is looked up in (:data:`pincal.stages.PUBLIC_LISTS`): each
public name's home is the one whose ``__all__`` holds it (a test checks that exactly one does)."""

_NO_LIST = {"DEFAULT_SIGMA": "pincal.arguments"}
"""Moved names whose home has no ``__all__`` (pincal.arguments holds the argument checks)."""

_STAGES = (*_STAGE_NAMES, *_FOUNDATIONS)
"""The public subpackages and modules, imported on first use as attributes (``pincal.model``)."""

_WORKFLOW = frozenset(__all__).difference({"__version__"})
"""The workflow's names, each imported on first use from the stage whose ``__all__`` holds it (type
checkers read the imports above; a test checks they are the same objects)."""
_MOVED_NAMES = _TOP_LEVEL_0_1.difference(__all__)


def _home(name: str) -> str:
    """The stage whose ``__all__`` holds a public or moved name (imports the stages up to that one;
    a moved name without a list, from :data:`_NO_LIST`)."""
    if name in _NO_LIST:
        return _NO_LIST[name]
    for stage in _STAGE_LISTS:
        if name in importlib.import_module(stage).__all__:
            return stage
    raise AttributeError(f"pincal.{name} was removed from every stage: no home to point to")


def _moved() -> dict[str, tuple[str, ...]]:
    """Each stage and the moved names it holds (imports every stage; for tests and tools)."""
    homes = {name: _home(name) for name in sorted(_MOVED_NAMES)}
    return {home: tuple(n for n in sorted(homes) if homes[n] == home) for home in sorted(set(homes.values()))}


if not TYPE_CHECKING:  # type checkers see the imports above; an unknown name stays an error there

    def __getattr__(name: str) -> Any:
        """A public name, imported from its stage on first use (then a plain attribute); a name
        moved to a stage in 0.2, with a DeprecationWarning; a stage subpackage."""
        if name in _WORKFLOW:
            value = getattr(importlib.import_module(_home(name)), name)
            globals()[name] = value
            return value
        if name in _MOVED_NAMES:
            home = _home(name)
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
