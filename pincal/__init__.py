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

from pincal.arguments import DEFAULT_SIGMA
from pincal.calibration.identification import IdentificationResult, identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.monte_carlo import MonteCarloResult, monte_carlo
from pincal.calibration.sanity import Outlier
from pincal.calibration.synthetic import RandomErrors, random_errors, simulate_measurements
from pincal.calibration.urdf_export import export_urdf
from pincal.calibration.validation import Validation, holdout, kfold, validate
from pincal.compensation.compensate import Compensation, compensate
from pincal.errors import (
    AmbiguousTip,
    BadArgument,
    BadConfiguration,
    BadConstraint,
    BadDHTable,
    BadMeasurementData,
    BadPlanFile,
    CannotWrite,
    DataCheckWarning,
    DegenerateOptimum,
    DegenerateOptimumWarning,
    FloorUnreachable,
    FrameNotFound,
    IdentificationFailed,
    Infeasible,
    MissingDependency,
    NoInertias,
    OverwriteRefused,
    PincalError,
    PincalWarning,
    RobotNotFound,
    SingularPlan,
    UnknownName,
    UnknownParameter,
    UnsupportedJoint,
    UrdfError,
)
from pincal.evaluation.accuracy import (
    AccuracyReport,
    ErrorProfile,
    PredictedError,
    WorstFound,
    accuracy,
    error_profile,
    worst_found,
)
from pincal.evaluation.classic import Criteria, criteria
from pincal.evaluation.data_check import DataCheck, check_plan
from pincal.evaluation.information import information_matrix
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import CartesianBox, Neighbourhood, TestPath, TestRegion, around, cartesian_box
from pincal.evaluation.test_pose import TestPoseCriterion, position_covariance, rho0, rho0_each
from pincal.model.base_parameters import Identifiability, identifiability
from pincal.model.catalogue import Parameter
from pincal.model.dh import DHTable, urdf_from_dh
from pincal.model.loading import load_robot, shipped_robots
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot
from pincal.model.statics import Payload
from pincal.planning.baselines import random_plans
from pincal.planning.constraints import (
    HalfSpace,
    JointLimits,
    MinSpacing,
    SelfCollision,
    Visibility,
    WorkspaceBox,
    load_constraints,
)
from pincal.planning.driver import design
from pincal.planning.plan import Plan
from pincal.planning.results import DesignResult, RandomPlans, StartRecord
from pincal.version import __version__
from pincal.viewing.scene import Scene, scene, show

__all__ = [
    "AccuracyReport",
    "AmbiguousTip",
    "BadArgument",
    "BadConfiguration",
    "BadConstraint",
    "BadDHTable",
    "BadMeasurementData",
    "BadPlanFile",
    "CannotWrite",
    "CartesianBox",
    "Compensation",
    "Criteria",
    "DEFAULT_SIGMA",
    "DHTable",
    "DataCheck",
    "DataCheckWarning",
    "DegenerateOptimum",
    "DegenerateOptimumWarning",
    "DesignResult",
    "ErrorProfile",
    "FloorUnreachable",
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
    "Neighbourhood",
    "NoInertias",
    "Outlier",
    "OverwriteRefused",
    "Parameter",
    "ParameterSet",
    "Payload",
    "PincalError",
    "PincalWarning",
    "Plan",
    "PredictedError",
    "Prior",
    "RandomErrors",
    "RandomPlans",
    "Robot",
    "RobotNotFound",
    "Scene",
    "SelfCollision",
    "SingularPlan",
    "StartRecord",
    "TestPath",
    "TestPoseCriterion",
    "TestRegion",
    "UnknownName",
    "UnknownParameter",
    "UnsupportedJoint",
    "UrdfError",
    "Validation",
    "Visibility",
    "WorkspaceBox",
    "WorstFound",
    "__version__",
    "accuracy",
    "around",
    "cartesian_box",
    "check_plan",
    "compensate",
    "criteria",
    "design",
    "error_profile",
    "export_urdf",
    "holdout",
    "identifiability",
    "identify",
    "information_matrix",
    "kfold",
    "load_constraints",
    "load_robot",
    "monte_carlo",
    "position_covariance",
    "random_errors",
    "random_plans",
    "rho0",
    "rho0_each",
    "scene",
    "shipped_robots",
    "show",
    "simulate_measurements",
    "urdf_from_dh",
    "validate",
    "worst_found",
]
