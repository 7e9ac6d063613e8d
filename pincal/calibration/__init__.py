"""Calibrating: measurement files (:mod:`.measurements`), identification (:mod:`.identification`
in stages over :mod:`.state`, :mod:`.noise`, :mod:`.problem`, :mod:`.solver`, :mod:`.sanity`,
:mod:`.result`), held-out errors (:mod:`.validation`), synthetic data (:mod:`.synthetic`), the
Monte-Carlo check of a plan (:mod:`.monte_carlo`), the calibrated URDF (:mod:`.urdf_export`), MJCF
(:mod:`.mjcf_export`) and SDF (:mod:`.sdf_export`) and other tools' measurement files
(:mod:`.formats`: FIGAROH, robot_calibration, industrial_calibration, MoveIt Calibration)."""

from pincal.calibration.formats import read_measurements
from pincal.calibration.identification import identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.mjcf_export import export_mjcf
from pincal.calibration.monte_carlo import MonteCarloResult, monte_carlo
from pincal.calibration.result import IdentificationResult
from pincal.calibration.sanity import Outlier
from pincal.calibration.sdf_export import export_sdf
from pincal.calibration.synthetic import RandomErrors, SmoothField, random_errors, simulate_measurements
from pincal.calibration.urdf_export import export_urdf
from pincal.calibration.validation import Validation, holdout, kfold, validate

__all__ = [
    "IdentificationResult",
    "MeasurementData",
    "MonteCarloResult",
    "Outlier",
    "RandomErrors",
    "SmoothField",
    "Validation",
    "export_mjcf",
    "export_sdf",
    "export_urdf",
    "holdout",
    "identify",
    "kfold",
    "monte_carlo",
    "random_errors",
    "read_measurements",
    "simulate_measurements",
    "validate",
]
