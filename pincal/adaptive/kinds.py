"""What the data so far measure, and how well, for the adaptive loop (docs/method.md §12.4, §13).

:func:`~pincal.adaptive.loop.next_poses` takes the kind of its data (a point, a pose, a partial
pose, distances, an image) and an error model, as :func:`pincal.identify` does: ``instrument=`` (a
:class:`~pincal.instruments.Instrument` of the data's kind) or ``sigma=`` (one σ per length
[m], the other units at pincal's defaults), never both. Points with one σ per coordinate are the
loop as it always was (:func:`of_data` returns None for them); any other instrument measures the
poses so far and the next ones through its whitened rows.

Its σ is the error model's scale: given (``instrument=``, ``sigma=``), from the data's own
uncertainty columns or covariances, or re-estimated by the identification — the reference σ
times the whitened residuals' RMS, i.e. the error model scaled by one factor (:func:`scaled`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pincal.arguments import DEFAULT_SIGMA, positive_sigma
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadArgument
from pincal.instruments.error_model import (
    DEFAULT_SIGMA_PX,
    DEFAULT_SIGMA_ROT,
    ErrorModel,
    PerCoordinate,
    RowCovariance,
    Tracker,
)
from pincal.instruments.given import error_model_of, measured
from pincal.instruments.instrument import Instrument
from pincal.model.jacobian import JacobianEngine
from pincal.model.parameters import ParameterSet
from pincal.model.robot import Robot


def of_data(
    instrument: object, sigma: object, data: MeasurementData, robot: Robot
) -> tuple[Instrument | None, float | None]:
    """(the instrument of ``data``, None for points with one σ per coordinate; the σ given [m], or
    None: to be re-estimated). Without ``instrument``, another kind than points is measured with
    :class:`~pincal.instruments.error_model.PerCoordinate` (``sigma`` or the default per length).

    Raises:
        BadArgument: both given, an ``instrument`` that is not an Instrument, one of another kind
            than the data's, or a bad σ.
    """
    if instrument is None:
        given = None if sigma is None else positive_sigma(sigma)
        if data.is_points:
            return None, given
        return Instrument(data.measure, PerCoordinate(DEFAULT_SIGMA if given is None else given)), given
    if isinstance(instrument, ErrorModel):
        raise BadArgument(
            f"instrument= takes a pincal.instruments.Instrument of the data's kind: write "
            f"instrument=pincal.instruments.Instrument({type(data.measure).__name__}(...), "
            f"{type(instrument).__name__}(...))",
            argument="instrument",
            value=instrument,
        )
    inst, _ = measured(instrument, sigma)
    assert inst is not None  # an instrument was given
    error_model_of(inst, None, data.measure, robot)  # of the data's kind, or refused
    if inst.is_default:  # points with one σ per coordinate: sigma='s shorthand
        assert isinstance(inst.error, PerCoordinate)  # what is_default means
        return None, inst.error.sigma
    return inst, inst.reference


def scaled(instrument: Instrument, sigma: float) -> Instrument:
    """``instrument`` with its error model scaled by one factor so that its reference σ is ``sigma``
    [m] (its whitened rows unchanged: only the scale of the criteria moves)."""
    error, factor = instrument.error, sigma / instrument.reference
    if isinstance(error, PerCoordinate):
        model: ErrorModel = PerCoordinate(sigma, error.sigma_rot * factor, error.sigma_px * factor)
    elif isinstance(error, Tracker):
        model = replace(
            error,
            radial=(error.radial[0] * factor, error.radial[1] * factor),
            transverse=(error.transverse[0] * factor, error.transverse[1] * factor),
            sigma_rot=error.sigma_rot * factor,
        )
    else:
        raise BadArgument(f"an error model pincal cannot scale by the data's sigma: {error!r}")
    return Instrument(instrument.kind, model)


def own_rows(
    params: ParameterSet, data: MeasurementData, used: np.ndarray, instrument: Instrument | None
) -> tuple[np.ndarray, float, Instrument]:
    """The data's own uncertainties (columns or covariances), for a kind other than points: ((m, r, P)
    the rows ``used`` whitened by them, zero where a value was not measured; their σ [m], the median
    of their lengths' σ (pincal's default without lengths); the instrument of the next poses: the one
    given, else one σ per unit at the data's medians)."""
    kind, robot = data.measure, params.robot
    q = data.q[used]
    J = kind.rows(JacobianEngine(params), q)
    if data.covariance is not None:
        covariance = RowCovariance(factor=np.linalg.cholesky(data.covariance[used]))
        std = np.sqrt(np.diagonal(data.covariance[used], axis1=1, axis2=2))
    else:
        assert data.sigma is not None  # own uncertainties: σ or covariances
        std = np.asarray(data.sigma, dtype=float).reshape(data.m, -1)[used]
        covariance = RowCovariance(std=std)
    seen = np.isfinite(data.values[used])
    rows = covariance.whiten(np.where(seen[..., None], J, 0.0), seen)
    units = np.array(kind.units(robot))

    def median(unit: str, default: float) -> float:
        values = std[:, units == unit][seen[:, units == unit]]
        return float(np.median(values)) if values.size else default

    own = PerCoordinate(
        median("m", DEFAULT_SIGMA), median("rad", DEFAULT_SIGMA_ROT), median("px", DEFAULT_SIGMA_PX)
    )
    return rows, own.sigma, instrument if instrument is not None else Instrument(kind, own)
