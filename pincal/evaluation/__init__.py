"""How good a plan is: the information matrix and its numerical kernel (:mod:`.information`), the
criterion interface (:mod:`.criterion`) and one module per criterion — the test-pose criterion ρ0
(:mod:`.test_pose`, :mod:`.test_pose_worst`), D, A, E, cond (:mod:`.d_optimal`, :mod:`.a_optimal`,
:mod:`.e_optimal`, :mod:`.condition`) — by name in :mod:`.registry`, the classic criteria of a
plan together (:mod:`.classic`), where the robot works (:mod:`.region`), prior knowledge
(:mod:`.prior`), the predicted accuracy of a plan (:mod:`.accuracy`, :mod:`.predicted_error`,
:mod:`.accuracy_report`, :mod:`.accuracy_samples`, :mod:`.error_profile`), what a plan's data can
identify (:mod:`.data_check`), and the ISO 9283 pose characteristics of poses measured in cycles
(:mod:`.iso9283`, the poses in :mod:`.pose_cycles`, the IPA ISO-cube reader in :mod:`.ipa_iso_cubes`,
the instrument's frame by :mod:`.rigid_fit`)."""

from pincal.evaluation.accuracy import accuracy
from pincal.evaluation.accuracy_report import AccuracyReport
from pincal.evaluation.classic import Criteria, criteria
from pincal.evaluation.criterion import Criterion
from pincal.evaluation.data_check import DataCheck, check_plan
from pincal.evaluation.error_profile import ErrorProfile, error_profile
from pincal.evaluation.information import information_matrix
from pincal.evaluation.iso9283 import Iso9283Report, iso9283
from pincal.evaluation.pose_cycles import PoseCycles, read_pose_cycles
from pincal.evaluation.predicted_error import PredictedError, WorstFound, worst_found
from pincal.evaluation.prior import Prior
from pincal.evaluation.region import CartesianBox, Neighbourhood, TestPath, TestRegion, around, cartesian_box
from pincal.evaluation.registry import CRITERIA, make_criterion
from pincal.evaluation.residual_criterion import ResidualCriterion, expected_error
from pincal.evaluation.test_pose import TestPoseCriterion, position_covariance, rho0, rho0_each, rho0_split

__all__ = [
    "CRITERIA",
    "AccuracyReport",
    "CartesianBox",
    "Criteria",
    "Criterion",
    "DataCheck",
    "ErrorProfile",
    "Iso9283Report",
    "Neighbourhood",
    "PoseCycles",
    "PredictedError",
    "Prior",
    "ResidualCriterion",
    "TestPath",
    "TestPoseCriterion",
    "TestRegion",
    "WorstFound",
    "accuracy",
    "around",
    "cartesian_box",
    "check_plan",
    "criteria",
    "error_profile",
    "expected_error",
    "information_matrix",
    "iso9283",
    "make_criterion",
    "position_covariance",
    "read_pose_cycles",
    "rho0",
    "rho0_each",
    "rho0_split",
    "worst_found",
]
