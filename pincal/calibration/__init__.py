"""Calibrating: measurement files (:mod:`.measurements`), identification (:mod:`.identification`
in stages over :mod:`.state`, :mod:`.noise`, :mod:`.problem`, :mod:`.solver`, :mod:`.sanity`,
:mod:`.result`), held-out errors (:mod:`.validation`), synthetic data (:mod:`.synthetic`), the
Monte-Carlo check of a plan (:mod:`.monte_carlo`) and the calibrated URDF (:mod:`.urdf_export`)."""

from pincal.calibration.identification import identify
from pincal.calibration.measurements import MeasurementData
from pincal.calibration.monte_carlo import MonteCarloResult, monte_carlo
from pincal.calibration.result import IdentificationResult
from pincal.calibration.sanity import Outlier
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
    "export_urdf",
    "holdout",
    "identify",
    "kfold",
    "monte_carlo",
    "random_errors",
    "simulate_measurements",
    "validate",
]
