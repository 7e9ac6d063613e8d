"""Deploying a calibration: corrected joint commands for a user's program (:mod:`.compensate`),
from a calibrated URDF and its sidecar (:mod:`.calibration_file`)."""

from pincal.compensation.calibration_file import DeployedCalibration, load_calibration
from pincal.compensation.compensate import Compensation, compensate

__all__ = ["Compensation", "DeployedCalibration", "compensate", "load_calibration"]
