"""pincal: choose the measurement configurations of a robot calibration for where the robot works,
then calibrate.

Data flows one way: robot → parameters → Jacobians → criteria → design → (simulate | identify) →
export / visualise.

    >>> import pincal
    >>> robot = pincal.load_robot("kr270", tip="tool0", markers=[(0.1, 0.05, 0.2)])
    >>> params = robot.parameters("full,offsets").identifiable().identifiable
    >>> len(params)
    27
"""

from ._optional import MissingDependency
from .constraints import (
    BadConstraint,
    HalfSpace,
    Infeasible,
    JointLimits,
    MinSpacing,
    SelfCollision,
    Visibility,
    WorkspaceBox,
    load_constraints,
)
from .criteria import (
    Criteria,
    TestPoseCriterion,
    criteria,
    information_matrix,
    position_covariance,
    rho0,
)
from .design import (
    DegenerateOptimum,
    DegenerateOptimumWarning,
    DesignResult,
    RandomPlans,
    StartRecord,
    design,
    random_plans,
)
from .errors import (
    BadConfiguration,
    BadMeasurementData,
    BadPlanFile,
    FrameNotFound,
    IdentificationFailed,
    OverwriteRefused,
    PincalError,
    RobotNotFound,
    SingularPlan,
    UnknownName,
    UnknownParameter,
    UnsupportedJoint,
    UrdfError,
)
from .export import export_urdf
from .identifiability import Identifiability, identifiability
from .identify import IdentificationResult, identify
from .measurements import MeasurementData
from .parameters import Parameter, ParameterSet
from .plan import Plan
from .robot import Robot, load_robot, shipped_robots
from .simulate import MonteCarloResult, RandomErrors, monte_carlo, random_errors, simulate_measurements
from .visualize import Scene, scene, show

__version__ = "0.1.0"

__all__ = [
    "BadConfiguration",
    "BadConstraint",
    "BadMeasurementData",
    "BadPlanFile",
    "Criteria",
    "DegenerateOptimum",
    "DegenerateOptimumWarning",
    "DesignResult",
    "FrameNotFound",
    "HalfSpace",
    "Identifiability",
    "IdentificationFailed",
    "IdentificationResult",
    "Infeasible",
    "JointLimits",
    "MeasurementData",
    "MinSpacing",
    "MissingDependency",
    "MonteCarloResult",
    "OverwriteRefused",
    "Parameter",
    "ParameterSet",
    "PincalError",
    "Plan",
    "RandomErrors",
    "RandomPlans",
    "Robot",
    "RobotNotFound",
    "Scene",
    "SelfCollision",
    "SingularPlan",
    "StartRecord",
    "TestPoseCriterion",
    "UnknownName",
    "UnknownParameter",
    "UnsupportedJoint",
    "UrdfError",
    "Visibility",
    "WorkspaceBox",
    "__version__",
    "criteria",
    "design",
    "export_urdf",
    "identifiability",
    "identify",
    "information_matrix",
    "load_constraints",
    "load_robot",
    "monte_carlo",
    "position_covariance",
    "random_errors",
    "random_plans",
    "rho0",
    "scene",
    "shipped_robots",
    "show",
    "simulate_measurements",
]
