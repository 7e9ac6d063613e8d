"""An identification's result in words: the report (:meth:`IdentificationResult.report`), its
σ and expected-error lines, and how each unit is shown."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from pincal.calibration.sanity import OUTLIER_SCORE

if TYPE_CHECKING:
    from pincal.calibration.result import IdentificationResult


SHOWN = {
    "m": (1e3, "mm"),
    "rad": (1e3, "mrad"),
    "1": (1e6, "ppm"),
    "rad/(N·m)": (1e6, "µrad/(N·m)"),
    "m/N": (1e6, "µm/N"),
}
"""How the report shows a value of each unit: (factor, unit shown)."""


def _sized(value: float, unit: str) -> str:
    """A residual for people: mm, mrad or px."""
    return {"m": f"{value * 1e3:.4g} mm", "rad": f"{value * 1e3:.4g} mrad"}.get(unit, f"{value:.4g} {unit}")


def sigma_line(result: IdentificationResult) -> str:
    """The σ the standard errors are scaled to, given or estimated, in words."""
    if not np.isfinite(result.sigma):  # estimated from no residual degrees of freedom
        return "sigma: undetermined (no residual degrees of freedom to estimate it from)"
    how = " (estimated from the residuals)" if result.sigma_estimated else " (given)"
    return f"sigma: {result.sigma * 1e3:.4g} mm per coordinate{how}"


def expected_line(result: IdentificationResult) -> str:
    """The expected error of the calibration's predictions, saying what it is made of."""
    e = result._expected_at_data
    if not np.isfinite(e["rms"]):
        return "expected error of a prediction: undetermined (no standard errors)"
    head = f"expected error of a prediction at the measured configurations: {e['rms'] * 1e3:.4g} mm RMS"
    if result.residual_model is None:
        return f"{head} ({unexplained_text(result, e)})"
    return (
        f"{head} (the parameters' standard errors {e['parameters'] * 1e3:.4g} mm and the residual "
        f"model's variance {e['residual_model'] * 1e3:.4g} mm; far from the measured configurations "
        f"the residual model's part grows to {e['residual_model_far'] * 1e3:.4g} mm)"
    )


def unexplained_text(result: IdentificationResult, e: dict[str, float] | None = None) -> str:
    """What a prediction without a residual model is made of, in words (with the figures of
    ``e``, :attr:`_expected_at_data`, when given)."""
    e = result._expected_at_data if e is None else e
    parts = (
        f"the parameters' standard errors {e['parameters'] * 1e3:.4g} mm"
        if e
        else "the parameters' standard errors"
    )
    u = result.unexplained
    if u > 0:
        whose = (
            "the default instrument's (a laser tracker's): give sigma (--sigma) for yours"
            if result.sigma_estimated
            else "the sigma given"
        )
        return (
            f"{parts} and what the model does not explain, {np.sqrt(u) * 1e3:.4g} mm per "
            f"coordinate: the residuals ({result.residual_level * 1e3:.4g} mm) exceed the instrument's "
            f"sigma {result.instrument_sigma * 1e3:.4g} mm ({whose}) beyond their scatter; a residual "
            "model (--residual-model gp) can say where"
        )
    return f"{parts}; the residuals are within the noise: the model explains the data"


def report_text(result: IdentificationResult) -> str:
    """A human-readable report: status, residuals, data identifiability, estimates ± standard
    errors (mm, mrad), outliers."""
    lines = [f"{result.status}: {result.message}"]  # an implausible one names its likely causes
    if result.data.is_points:
        what = f"{result.data.m} configurations, {result.data.n_markers} marker(s)"
        rms = (
            f"{result.residual_rms_before * 1e3:.4g} mm before, "
            f"{result.residual_rms_after * 1e3:.4g} mm after"
        )
    else:
        what = f"{result.data.m} configurations, {result.data.measure.describe()}"
        before, after = result.residual_rms_by_unit(before=True), result.residual_rms_by_unit()
        rms = "; ".join(f"{_sized(before[u], u)} before, {_sized(after[u], u)} after" for u in after)
    lines += [
        f"residual RMS: {rms} ({what}, {len(result.params)} parameters, {result.iterations} "
        f"iterations, {result.method}, loss {result.loss})",
        sigma_line(result),
    ]
    if result.prior is not None:
        lines.append(f"prior: {result.prior} (MAP estimate)")
    if result.check is not None:
        lines.append(result.check.report())
    width = max(len(n) for n in result.names)
    for name, v, s, unit in zip(result.names, result.values, result.std, result.params.units, strict=True):
        scale, shown = SHOWN[unit]
        if name in result.dropped:
            lines.append(f"  {name:{width}s} not identified (nominal)")
        elif np.isfinite(s):
            lines.append(f"  {name:{width}s} {v * scale:+11.5f} ± {s * scale:.5f} {shown}")
        else:  # no degrees of freedom left to estimate σ from (e.g. after --reject)
            lines.append(f"  {name:{width}s} {v * scale:+11.5f} (standard error undetermined) {shown}")
    if result.residual_model is not None:
        lines.append(result.residual_model.describe())
    lines.append(expected_line(result))
    if result.rejected:
        lines.append(f"rejected {len(result.rejected)} row(s) and refitted:")
        lines += [f"  {o}" for o in result.rejected]
    if result.outliers:
        lines.append(f"suspicious rows (over {OUTLIER_SCORE:g} robust sigma):")
        lines += [f"  {o}" for o in result.outliers]
    return "\n".join(lines)
