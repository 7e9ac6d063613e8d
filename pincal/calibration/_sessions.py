"""The sessions of an identification as one :class:`~pincal.calibration.measurements.MeasurementData`
(their rows stacked)."""

from __future__ import annotations

import numpy as np

from pincal.calibration.measurements import MeasurementData


def stacked(sessions: list[MeasurementData]) -> MeasurementData:
    if len(sessions) == 1:
        return sessions[0]
    if not sessions[0].is_points:
        return _stacked_values(sessions)
    sigma = None
    if any(d.sigma is not None for d in sessions):
        sigma = np.concatenate(
            [d.sigma if d.sigma is not None else np.full(d.points.shape, np.nan) for d in sessions]
        )
    return MeasurementData(
        np.concatenate([d.q for d in sessions]),
        np.concatenate([d.points for d in sessions]),
        sessions[0].joint_names,
        sigma=None if sigma is None or np.isnan(sigma).any() else sigma,
        source=" + ".join(str(d.source) for d in sessions),
        payload=_stacked_payload(sessions),
    )


def _stacked_payload(sessions: list[MeasurementData]) -> np.ndarray | None:
    """The sessions' payload rows stacked (no payload columns: none), or None if no session has any."""
    if all(d.payload is None for d in sessions):
        return None
    return np.concatenate([d.payload if d.payload is not None else np.zeros((d.m, 4)) for d in sessions])


def _stacked_values(sessions: list[MeasurementData]) -> MeasurementData:
    """The sessions of a kind other than points as one MeasurementData (their σ or covariances when
    every one has them)."""

    def joined(name: str) -> np.ndarray | None:
        parts = [getattr(d, name) for d in sessions]
        return None if any(p is None for p in parts) else np.concatenate(parts)

    return MeasurementData(
        np.concatenate([d.q for d in sessions]),
        np.concatenate([d.values for d in sessions]),
        sessions[0].joint_names,
        source=" + ".join(str(d.source) for d in sessions),
        sigma=joined("sigma"),
        payload=_stacked_payload(sessions),
        kind=sessions[0].kind,
        covariance=joined("covariance"),
    )
