"""Figures of a calibration design (matplotlib, optional: ``pip install "pincal[plot]"``).

Each function takes numbers computed elsewhere (ρ0 of plans, Monte-Carlo errors, search traces),
draws one figure and returns it: nothing is shown (no ``plt.show()``) and nothing is written;
save with :func:`save_figure` (atomic, never over an input) or ``fig.savefig(path)``. Lengths
come in metres and are drawn in ``unit`` (``"mm"`` by default). matplotlib is imported when a
function is called, never when pincal is imported.

* :func:`rho0_histogram`: ρ0 of the designed plan(s) against the distribution of random plans.
* :func:`error_comparison`: Monte-Carlo position errors at the test pose, plans side by side.
* :func:`search_progress`: the criterion against search time, start by start.
* :func:`error_vs_distance`: predicted error after calibration against the distance from the test
  pose (median and 95th percentile), plans side by side.
* :func:`validation_errors`: held-out position errors before/after calibration, per point and
  as histograms.
* :func:`accuracy_vs_time`: predicted error after calibration against the campaign's minutes,
  one point per plan size.
* :func:`placement_map`: the predicted error at the test region against the instrument's position
  over the box searched (:func:`pincal.planning.placement.place_instrument`).
* :func:`iso9283_characteristics`: ISO 9283 AP and RP pose by pose, before and after calibration.
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pincal.errors import BadArgument, CannotWrite
from pincal.optional import require
from pincal.outputs import atomic_write_bytes

if TYPE_CHECKING:  # matplotlib is optional: imported when a figure is drawn
    from matplotlib.figure import Figure

UNITS = {"m": 1.0, "mm": 1e3, "um": 1e6, "µm": 1e6}
"""Length units a figure can be drawn in, with their factor from metres."""

_COLORS = ("#7f7f7f", "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf")


PLOT_EXTRA = "pincal[plot]"
"""The pip requirement that brings matplotlib."""


def _pyplot(feature: str = "pincal.viewing.plots"):
    return require("matplotlib.pyplot", feature, PLOT_EXTRA)


def _factor(unit: str) -> float:
    if unit not in UNITS:
        raise BadArgument(f"unknown unit {unit!r}; valid: {', '.join(UNITS)}")
    return UNITS[unit]


def _figure(figsize: tuple[float, float]) -> Figure:
    """A new Figure that pyplot does not keep (it is freed with its last reference)."""
    _pyplot()  # a clear error if matplotlib is missing, before any matplotlib import
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def figure_format(path: str | os.PathLike, feature: str = "pincal.viewing.plots") -> str:
    """The image format of a figure file, from its suffix ('png', 'pdf', 'svg', ...), or an error
    listing the valid ones.

    Raises:
        MissingDependency: matplotlib is not installed (``feature`` names what needs it).
        CannotWrite: a suffix matplotlib cannot write.
    """
    _pyplot(feature)
    from matplotlib.backend_bases import FigureCanvasBase

    valid = FigureCanvasBase.get_supported_filetypes()
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in valid:
        got = f"suffix .{suffix}" if suffix else "no suffix"
        raise CannotWrite(f"figure {os.fspath(path)!r} has {got}; valid: {', '.join(sorted(valid))}")
    return suffix


def save_figure(fig: Figure, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Save ``fig`` to ``path`` in the format of its suffix, atomically (never half-written, never
    over an input: see :func:`pincal.outputs.atomic_write_bytes`)."""
    fmt = figure_format(path)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=dpi)
    return atomic_write_bytes(path, buffer.getvalue(), "figure")


def _finite_positive(values: object, what: str) -> np.ndarray:
    arr = np.asarray(values, dtype=float).reshape(-1)
    arr = arr[np.isfinite(arr)]
    if arr.size == 0 or np.any(arr <= 0):
        raise BadArgument(f"{what}: expected positive finite lengths in metres, got {arr.size} usable values")
    return arr


def rho0_histogram(
    random_rho0: object,
    plans: Mapping[str, float] | float,
    unit: str = "mm",
    bins: int = 40,
    title: str | None = None,
) -> Figure:
    """ρ0 of designed plan(s) against the distribution of ρ0 over random plans (log scale).

    Args:
        random_rho0: (n,) ρ0 of n random plans of the same size [m] (non-finite values, from
            singular plans, are left out).
        plans: ``{label: ρ0 [m]}`` of the plans to compare (the designed plan, a D-optimal plan),
            or one ρ0 (labelled "designed plan").
        unit: length unit of the axis (``"mm"``, ``"um"``, ``"m"``).
        bins: number of logarithmically spaced bins.
        title: figure title (default: a summary of the comparison).

    Returns:
        the matplotlib Figure (x: ρ0 on a log scale; y: number of random plans).
    """
    f = _factor(unit)
    random = _finite_positive(random_rho0, "random_rho0") * f
    marks = {"designed plan": plans} if np.isscalar(plans) else dict(plans)  # type: ignore[arg-type]
    if not marks:
        raise BadArgument("plans: give at least one plan's rho0")
    values = {k: float(_finite_positive(v, f"plans[{k!r}]")[0]) * f for k, v in marks.items()}
    lo = min(random.min(), *values.values())
    hi = max(random.max(), *values.values())
    edges = np.geomspace(lo / 1.05, hi * 1.05, bins + 1)
    fig = _figure((7.0, 5.0))
    ax = fig.add_subplot()
    ax.hist(random, bins=edges.tolist(), color="#c7c7c7", edgecolor="#7f7f7f", linewidth=0.5,
            label=f"{len(random)} random plans")  # fmt: skip
    ax.set_xscale("log")
    median = float(np.median(random))
    for i, (label, v) in enumerate(values.items()):
        share = 100.0 * np.mean(random < v)
        versus = f"{median / v:.2g}× better" if v <= median else f"{v / median:.2g}× worse"
        ax.axvline(v, color=_COLORS[1 + i % (len(_COLORS) - 1)], linewidth=2,
                   label=f"{label}: {v:.3g} {unit}, {versus} than the median random plan; "
                         f"{share:.1f}% of random plans do better")  # fmt: skip
    ax.axvline(median, color="#7f7f7f", linestyle="--", linewidth=1, label=f"median {median:.3g} {unit}")
    ax.set_xlabel(f"ρ0, expected position error at the test pose after calibration [{unit}]")
    ax.set_ylabel("random plans")
    ax.legend(fontsize="small", loc="upper center", bbox_to_anchor=(0.5, -0.15))
    ax.set_title(
        title
        or f"random plans: min {random.min():.3g}, mean {random.mean():.3g}, max {random.max():.3g} {unit}",
        fontsize="medium",
    )
    return fig


def error_comparison(
    errors: Mapping[str, Any],
    predicted: Mapping[str, float] | None = None,
    unit: str = "mm",
    title: str | None = None,
) -> Figure:
    """Monte-Carlo position errors at the test pose after calibration, plans side by side.

    The classic figure of the method: for each plan (say random, D-optimal, designed for the test
    pose) the distribution of the error ‖g(q0, Π̂) − g(q0, Π)‖ over simulated calibrations, its
    root mean square (the empirical ρ0) and the predicted ρ0, with the gain over the first plan.

    Args:
        errors: ``{label: errors}``, each (n,) errors [m] or a result with ``errors`` and
            ``rho0_predicted`` attributes
            (:class:`pincal.calibration.monte_carlo.MonteCarloResult`). The first plan is the
            reference for the gains.
        predicted: ``{label: predicted ρ0 [m]}`` (taken from the results when they carry it).
        unit: length unit of the axis.
        title: figure title.

    Returns:
        the matplotlib Figure (one column per plan: the errors as points and a box, ρ0 as bars).
    """
    f = _factor(unit)
    if not errors:
        raise BadArgument("errors: give at least one plan's Monte-Carlo errors")
    samples, expected = {}, dict(predicted or {})
    for label, value in errors.items():
        samples[label] = _finite_positive(getattr(value, "errors", value), f"errors[{label!r}]") * f
        if label not in expected and hasattr(value, "rho0_predicted"):
            expected[label] = value.rho0_predicted
    labels = list(samples)
    rms = {k: float(np.sqrt(np.mean(v**2))) for k, v in samples.items()}
    fig = _figure((1.2 + 2.0 * len(labels), 4.2))
    ax = fig.add_subplot()
    rng = np.random.default_rng(0)  # jitter of the points only
    for i, label in enumerate(labels):
        color = _COLORS[i % len(_COLORS)]
        y = samples[label]
        ax.scatter(i + 0.25 * (rng.random(y.size) - 0.5), y, s=6, alpha=0.35, color=color, linewidths=0)
        ax.boxplot([y], positions=[i], widths=0.5, showfliers=False,
                   medianprops={"color": "black"}, boxprops={"color": color},
                   whiskerprops={"color": color}, capprops={"color": color})  # fmt: skip
        ax.hlines(rms[label], i - 0.35, i + 0.35, color="black", linewidth=2,
                  label="RMS error (empirical ρ0)" if i == 0 else None)  # type: ignore[arg-type]  # fmt: skip
        if label in expected:
            ax.hlines(float(expected[label]) * f, i - 0.35, i + 0.35, color="#ff7f0e", linewidth=2,
                      linestyle=":", label="predicted ρ0" if i == 0 else None)  # type: ignore[arg-type]  # fmt: skip
        change = 100.0 * (1.0 - rms[label] / rms[labels[0]])
        gain = "" if i == 0 else f"\n{abs(change):.0f}% {'below' if change >= 0 else 'above'} {labels[0]}"
        ax.annotate(f"ρ0 = {rms[label]:.3g} {unit}{gain}", (i, 1.0), xycoords=("data", "axes fraction"),
                    ha="center", va="top", fontsize="small")  # fmt: skip
    top = max(np.quantile(v, 0.995) for v in samples.values())
    ax.set_ylim(0, 1.3 * top)
    ax.set_xticks(range(len(labels)), labels)
    ax.set_xlim(-0.6, len(labels) - 0.4)
    ax.set_ylabel(f"position error at the test pose after calibration [{unit}]")
    ax.legend(fontsize="small", loc="center right")
    n = ", ".join(str(v.size) for v in samples.values())
    ax.set_title(title or f"Monte-Carlo calibrations ({n} trials)", fontsize="medium")
    return fig


def search_progress(
    history: Any,
    ylabel: str = "criterion",
    scale: float = 1.0,
    best: float | None = None,
    title: str | None = None,
) -> Figure:
    """The criterion against search time, start by start, of a multi-start search.

    Args:
        history: a :class:`pincal.planning.results.DesignResult` (its ``history``), or a sequence with one
            entry per start: a record with ``time_s`` and ``value`` (a
            :class:`pincal.planning.results.StartRecord`: a point per start; ``continued=False`` marks a
            start dropped after screening), or a ``(times [s], values)`` pair of arrays, or an
            object with ``times`` and ``values``, for a start's whole trace (a line: the best
            value so far).
        ylabel: name and unit of the criterion for the axis.
        scale: factor applied to the values before drawing (1e3 for ρ0 in metres drawn as mm).
        best: a reference value (the best found, a known optimum), drawn as a dashed line;
            default the best value of the history.
        title: figure title.

    Returns:
        the matplotlib Figure (x: wall time of the start [s]; y: the criterion, on a log scale
        when the values are positive and span more than a factor 10).
    """
    entries = list(getattr(history, "history", history))
    if not entries:
        raise BadArgument("history: give at least one start")
    fig = _figure((7.0, 4.0))
    ax = fig.add_subplot()
    points: list[tuple[float, float, bool]] = []
    finals = []
    for i, entry in enumerate(entries):
        if hasattr(entry, "time_s"):
            value = float(entry.value) * scale
            if np.isfinite(value):
                points.append((float(entry.time_s), value, bool(getattr(entry, "continued", True))))
                finals.append(value)
            continue
        times, values = (entry.times, entry.values) if hasattr(entry, "times") else entry
        t = np.asarray(times, dtype=float).reshape(-1)
        v = np.asarray(values, dtype=float).reshape(-1) * scale
        if t.size != v.size or t.size == 0:
            raise BadArgument(f"history[{i}]: times and values must be non-empty and of equal length")
        keep = np.isfinite(v)
        if keep.any():
            t, v = t[keep], np.minimum.accumulate(v[keep])
            ax.step(t, v, where="post", linewidth=1, alpha=0.7, color=_COLORS[1 + i % (len(_COLORS) - 1)])
            finals.append(v[-1])
    if not finals:
        raise BadArgument("history: no start has a finite criterion value")
    if points:
        t, v, continued = (np.array(c) for c in zip(*points, strict=True))
        ax.scatter(t[continued], v[continued], s=18, color=_COLORS[1], label="run to convergence")
        if (~continued).any():
            ax.scatter(t[~continued], v[~continued], s=18, facecolors="none", edgecolors=_COLORS[0],
                       label="dropped after screening")  # fmt: skip
    reference = min(finals) if best is None else best * scale
    ax.axhline(reference, color="black", linestyle="--", linewidth=1,
               label=f"{'best' if best is None else 'reference'} {reference:.4g}")  # fmt: skip
    ax.legend(fontsize="small")
    drawn = [float(y) for line in ax.get_lines() for y in np.asarray(line.get_ydata())] + [
        y for _, y, _ in points
    ]
    if min(drawn) > 0 and max(drawn) > 10 * min(drawn):  # a log scale only for a wide spread
        ax.set_yscale("log")
    ax.set_xlabel("wall time of the start [s]")
    ax.set_ylabel(ylabel)
    finals_arr = np.array(finals)
    ax.set_title(
        title or f"{len(finals)} starts: final values {finals_arr.min():.4g} … {finals_arr.max():.4g}",
        fontsize="medium",
    )
    return fig


def error_vs_distance(profiles, unit: str = "mm", title: str | None = None) -> Figure:
    """Predicted error after calibration against the joint-space distance from the test pose.

    Args:
        profiles: :class:`pincal.evaluation.ErrorProfile` values (from
            :func:`pincal.evaluation.error_profile`), one per plan: each drawn as its median (solid)
            and 95th percentile (dashed).
        unit: length unit of the axis.
        title: the figure's title (default: a description).

    Returns:
        the figure (log scale: a local plan's error grows by orders of magnitude away from q0).
    """
    factor = _factor(unit)
    profiles = list(profiles)
    if not profiles:
        raise BadArgument("error_vs_distance: no profile to draw")
    fig = _figure((6.4, 4.2))
    ax = fig.add_subplot()
    for i, p in enumerate(profiles):
        color = _COLORS[(i + 1) % len(_COLORS)]
        d = np.degrees(p.distance)
        ax.plot(d, _finite_positive(p.median, p.name) * factor, color=color, label=f"{p.name}: median")
        ax.plot(d, _finite_positive(p.p95, p.name) * factor, color=color, ls="--", label=f"{p.name}: 95 %")
    ax.set_yscale("log")
    ax.set_xlabel("distance from the test pose, max |q − q0| [deg]")
    ax.set_ylabel(f"predicted error after calibration [{unit}]")
    ax.set_title(title or "Accuracy away from the test pose")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def validation_errors(validation: Any, unit: str = "mm", bins: int = 30, title: str | None = None) -> Figure:
    """Held-out position errors before and after calibration: per point (left) and histograms
    (right), with RMS, 95th percentile and max in the legend.

    Args:
        validation: a :class:`pincal.calibration.Validation` (or anything with ``before`` and ``after``, (n,)
            errors [m]).
        unit: length unit of the axes.
        bins: number of histogram bins.
        title: figure title (default: how the points were held out).
    """
    f = _factor(unit)
    before = np.asarray(getattr(validation, "before", None), dtype=float).reshape(-1) * f
    after = np.asarray(getattr(validation, "after", None), dtype=float).reshape(-1) * f
    if (
        before.size == 0
        or before.shape != after.shape
        or not np.all(np.isfinite(before) & np.isfinite(after))
    ):
        raise BadArgument("validation: expected equal numbers of finite errors before and after calibration")
    fig = _figure((10.0, 4.0))
    left, right = fig.subplots(1, 2)
    index = np.arange(before.size)
    edges = np.linspace(0.0, max(before.max(), after.max()) * 1.02 or 1.0, bins + 1)
    for errors, label, color in ((before, "before", _COLORS[0]), (after, "after", _COLORS[1])):
        rms = float(np.sqrt(np.mean(errors**2)))
        text = f"{label}: RMS {rms:.3g}, 95% {np.percentile(errors, 95):.3g}, max {errors.max():.3g} {unit}"
        left.plot(index, errors, "o", markersize=3, color=color, label=text)
        right.hist(errors, bins=edges, color=color, alpha=0.6, label=label)
    left.set_xlabel("held-out point")
    left.set_ylabel(f"position error [{unit}]")
    left.legend(fontsize="small")
    right.set_xlabel(f"position error [{unit}]")
    right.set_ylabel("points")
    right.legend(fontsize="small")
    fig.suptitle(title or f"validation: {getattr(validation, 'how', 'held-out points')}", fontsize="medium")
    return fig


def accuracy_vs_time(
    sizes: object, minutes: object, errors: object, unit: str = "mm", title: str | None = None
) -> Figure:
    """The predicted error over the test region [m] against the campaign's time [min], one point
    per plan size, labelled ``m=…`` (:func:`pincal.campaign.tradeoff.accuracy_vs_time`)."""
    factor = _factor(unit)
    m = np.asarray(sizes, dtype=int)
    t = np.asarray(minutes, dtype=float)
    e = _finite_positive(errors, "errors") * factor
    if not (len(m) == len(t) == len(e)):
        raise BadArgument("accuracy_vs_time: one size, one time and one error per point")
    fig = _figure((6.0, 4.0))
    ax = fig.add_subplot()
    ax.plot(t, e, "o-", color=_COLORS[1])
    for mi, x, y in zip(m, t, e, strict=True):
        ax.annotate(f"m={mi}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xlabel("campaign time [min]")
    ax.set_ylabel(f"predicted error over the test region [{unit}]")
    ax.set_title(title or "accuracy against campaign time")
    ax.grid(True, alpha=0.3)
    return fig


def placement_map(placement: Any, unit: str = "mm", title: str | None = None) -> Figure:
    """The predicted error at the test region against the instrument's position: the box seen from
    above (x, y) and from the side (x, z), each position tried coloured by the criterion of the plan
    designed with the instrument there (the best over the hidden coordinate where positions
    overlap); the chosen position a star, the default one a square, positions without a feasible
    plan a cross.

    Args:
        placement: a :class:`pincal.planning.placement.Placement` (``positions`` (n, 3) [m],
            ``values`` (n,) [m], inf where infeasible; ``at``, ``default_at``).
        unit: length unit of the colour scale.
        title: the figure's title (default: the factor over the default placement).
    """
    factor = _factor(unit)
    positions = np.asarray(placement.positions, dtype=float)
    values = np.asarray(placement.values, dtype=float)
    feasible = np.isfinite(values)
    if not feasible.any():
        raise BadArgument("placement_map: no position of the box has a feasible plan")
    from matplotlib.colors import LogNorm

    low, high = values[feasible].min() * factor, values[feasible].max() * factor
    norm = LogNorm(vmin=low, vmax=high if high > low else low * 1.001)
    fig = _figure((9.0, 4.0))
    axes = fig.subplots(1, 2)
    mappable = None
    for ax, (i, j, name) in zip(axes, ((0, 1, "from above"), (0, 2, "from the side")), strict=True):
        best: dict[tuple[float, float], float] = {}
        for p, v in zip(positions[feasible], values[feasible], strict=True):
            key = (round(p[i], 9), round(p[j], 9))
            best[key] = min(best.get(key, np.inf), v)
        xy = np.array(list(best))
        mappable = ax.scatter(
            xy[:, 0], xy[:, 1], c=np.array(list(best.values())) * factor, norm=norm, cmap="viridis_r", s=90
        )
        if (~feasible).any():
            ax.scatter(positions[~feasible, i], positions[~feasible, j], marker="x", color="#d62728",
                       label="no feasible plan")  # fmt: skip
        ax.scatter(*placement.default_at[[i, j]], marker="s", s=160, facecolors="none", edgecolors="k",
                   label="default")  # fmt: skip
        ax.scatter(*np.asarray(placement.at)[[i, j]], marker="*", s=260, color="#d62728", edgecolors="k",
                   label="chosen")  # fmt: skip
        ax.set_xlabel("x [m]")
        ax.set_ylabel("yz"[j - 1] + " [m]")
        ax.set_title(name)
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    assert mappable is not None  # two panels, each with a feasible position
    fig.colorbar(mappable, ax=axes, label=f"predicted error at the test region [{unit}]")
    ratio = placement.factor
    fig.suptitle(
        title
        or (
            "Instrument placement: the chosen position is "
            + (
                f"{ratio:.3g} times better than the default"
                if np.isfinite(ratio)
                else "the only feasible one"
            )
        )
    )
    return fig


def iso9283_characteristics(reports: Mapping[str, Any], unit: str = "mm", title: str | None = None) -> Figure:
    """ISO 9283 position accuracy AP (top) and repeatability RP (bottom) pose by pose, one series
    per report (``{"before": ..., "after": ...}``, :class:`pincal.evaluation.iso9283.Iso9283Report`
    values over the same poses). A pose without repeatability (one cycle) has no RP point."""
    factor = _factor(unit)
    reports = dict(reports)
    if not reports:
        raise BadArgument("iso9283_characteristics: no report to draw")
    first = next(iter(reports.values()))
    labels = [f"{p.test} {p.pose}".strip() for p in first.poses]
    index = np.arange(len(labels))
    fig = _figure((max(6.4, min(16.0, 0.35 * len(labels) + 2.0)), 5.6))
    top, bottom = fig.subplots(2, 1, sharex=True)
    width = 0.8 / len(reports)
    for k, (name, report) in enumerate(reports.items()):
        color = _COLORS[k % len(_COLORS)]
        shift = (k - (len(reports) - 1) / 2) * width
        ap = np.array([p.ap for p in report.poses]) * factor
        top.bar(index + shift, ap, width=width, color=color, label=f"{name}: AP max {ap.max():.3g} {unit}")
        rp = np.array([np.nan if p.rp is None else p.rp for p in report.poses]) * factor
        if np.isfinite(rp).any():
            bottom.bar(index + shift, np.nan_to_num(rp), width=width, color=color, label=name)
    top.set_ylabel(f"AP [{unit}]")
    top.legend(fontsize="small")
    top.grid(True, axis="y", alpha=0.3)
    bottom.set_ylabel(f"RP [{unit}]")
    bottom.grid(True, axis="y", alpha=0.3)
    if len(labels) <= 40:
        bottom.set_xticks(index, labels, rotation=90, fontsize=7)
    else:
        bottom.set_xlabel(f"pose ({len(labels)} poses, in the data's order)")
    fig.suptitle(title or "ISO 9283 pose accuracy and repeatability", fontsize="medium")
    return fig
