"""Calibrating: measurement files (:mod:`.measurements`), identification (:mod:`.identification`
in stages over :mod:`.state`, :mod:`.noise`, :mod:`.problem`, :mod:`.solver`, :mod:`.sanity`,
:mod:`.result`), held-out errors (:mod:`.validation`), synthetic data (:mod:`.synthetic`), the
Monte-Carlo check of a plan (:mod:`.monte_carlo`), the joint corrections a controller applies
(:mod:`.corrections`) and other tools' measurement files (:mod:`.formats`: FIGAROH,
robot_calibration, industrial_calibration, MoveIt Calibration). The calibrated URDF, MJCF and SDF are
written by the next stage, :mod:`pincal.export`."""

from pincal.calibration.formats import read_measurements
from pincal.calibration.identification import identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.monte_carlo import MonteCarloResult, monte_carlo
from pincal.calibration.result import IdentificationResult
from pincal.calibration.sanity import Outlier
from pincal.calibration.synthetic import RandomErrors, SmoothField, random_errors, simulate_measurements
from pincal.calibration.validation import Validation, holdout, kfold, validate
from pincal.deprecation import moved_from

__all__ = [
    "IdentificationResult",
    "MeasurementData",
    "MonteCarloResult",
    "Outlier",
    "RandomErrors",
    "SmoothField",
    "Validation",
    "holdout",
    "identify",
    "kfold",
    "monte_carlo",
    "random_errors",
    "read_measurements",
    "simulate_measurements",
    "validate",
]

__getattr__ = moved_from(__name__, {"pincal.export": ("export_mjcf", "export_sdf", "export_urdf")})
"""Names that moved to :mod:`pincal.export` in 0.2."""
