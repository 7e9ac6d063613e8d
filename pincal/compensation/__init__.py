"""Deploying a calibration: corrected joint commands for a user's program (:mod:`.compensate`)."""
