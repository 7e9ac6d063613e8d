"""The kinematic model: the robot (:mod:`.robot`, loaded by :mod:`.loading`), its parameters
(:mod:`.parameters`, named in :mod:`.catalogue`), which of them measurements can identify
(:mod:`.base_parameters`), the parameter Jacobians (:mod:`.jacobian`), gravity and payloads
(:mod:`.statics`), the residual model (:mod:`.residual`), robots given by DH tables (:mod:`.dh`),
the instrument's parts identified with the robot (:mod:`.fixtures`), and the one forward kinematics
every check and view uses (:mod:`.kinematics`) with the collision world of robot and cell
(:mod:`.collision`). The first stage of robot → parameters → Jacobians → criteria → design →
(simulate | identify) → export / view."""

from pincal.model.base_parameters import Identifiability, identifiability
from pincal.model.catalogue import Parameter
from pincal.model.dh import DHTable, shipped_dh_tables, urdf_from_dh
from pincal.model.fixtures import Fixture
from pincal.model.kinematics import ForwardKinematics
from pincal.model.loading import load_robot, shipped_robots
from pincal.model.parameters import ParameterSet
from pincal.model.residual import ResidualModel
from pincal.model.robot import Robot
from pincal.model.statics import Payload

__all__ = [
    "DHTable",
    "Fixture",
    "ForwardKinematics",
    "Identifiability",
    "Parameter",
    "ParameterSet",
    "Payload",
    "ResidualModel",
    "Robot",
    "identifiability",
    "load_robot",
    "shipped_dh_tables",
    "shipped_robots",
    "urdf_from_dh",
]
