"""Calibrating: measurement files (:mod:`.measurements`), identification (:mod:`.identification`),
synthetic data (:mod:`.synthetic`), the Monte-Carlo check of a plan (:mod:`.monte_carlo`) and the
calibrated URDF (:mod:`.urdf_export`)."""
