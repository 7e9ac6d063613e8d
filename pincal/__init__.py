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

from .criteria import (
    Criteria,
    TestPoseCriterion,
    criteria,
    information_matrix,
    position_covariance,
    rho0,
)
from .errors import (
    BadConfiguration,
    BadPlanFile,
    FrameNotFound,
    PincalError,
    RobotNotFound,
    SingularPlan,
    UnknownName,
    UnknownParameter,
    UnsupportedJoint,
    UrdfError,
)
from .identifiability import Identifiability, identifiability
from .parameters import Parameter, ParameterSet
from .plan import Plan
from .robot import Robot, load_robot, shipped_robots

__version__ = "0.1.0"

__all__ = [
    "BadConfiguration",
    "BadPlanFile",
    "Criteria",
    "FrameNotFound",
    "Identifiability",
    "Parameter",
    "ParameterSet",
    "PincalError",
    "Plan",
    "Robot",
    "RobotNotFound",
    "SingularPlan",
    "TestPoseCriterion",
    "UnknownName",
    "UnknownParameter",
    "UnsupportedJoint",
    "UrdfError",
    "__version__",
    "criteria",
    "identifiability",
    "information_matrix",
    "load_robot",
    "position_covariance",
    "rho0",
    "shipped_robots",
]
