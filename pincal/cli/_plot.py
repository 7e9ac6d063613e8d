"""``--plot FILE.png`` of the design command: a figure of the design, saved, never shown."""

from __future__ import annotations

import argparse

from pincal.cli._common import FIGURE_NOTE
from pincal.viewing import plots

PLOT_HELP = (
    "save a figure: with --baseline, rho0 of the designed and D-optimal plans against the random "
    "plans (histogram, log scale); without, the criterion against search time per start" + FIGURE_NOTE
)


def add_plot_argument(parser: argparse.ArgumentParser) -> None:
    """``--plot FILE.png``."""
    parser.add_argument("--plot", metavar="FILE.png", help=PLOT_HELP)


def save_design_plot(path: str, result, baseline=None) -> None:
    """Save the figure of a design (see :data:`PLOT_HELP`) to ``path`` (format from its suffix).

    Args:
        path: the image file to write.
        result: the :class:`pincal.planning.results.DesignResult`.
        baseline: ``(RandomPlans, D-optimal DesignResult or None)`` or None.
    """

    if baseline is not None and result.rho0 is not None:
        randoms, d_optimal = baseline
        plans = {"designed": result.rho0}
        if d_optimal is not None and d_optimal.rho0 is not None:
            plans["D-optimal"] = d_optimal.rho0
        fig = plots.rho0_histogram(randoms.values, plans)
    else:
        is_rho0 = result.criterion in ("test-pose", "test-pose-worst")
        fig = plots.search_progress(
            result,
            ylabel="ρ0 [mm]" if is_rho0 else result.criterion,
            scale=1e3 if is_rho0 else 1.0,
        )
    plots.save_figure(fig, path)


def add_simulation_plot_arguments(parser: argparse.ArgumentParser) -> None:
    """``--plot FILE.png`` and ``--compare PLAN.csv`` (repeatable) of the simulate command."""
    parser.add_argument(
        "--plot",
        metavar="FILE.png",
        help="save a figure of the position errors at the test pose after calibration, this plan and "
        "the --compare plans side by side, with their predicted rho0" + FIGURE_NOTE,
    )
    parser.add_argument(
        "--compare",
        action="append",
        metavar="PLAN.csv",
        help="another plan (a random one, a D-optimal one) simulated alongside with the same trials, "
        "errors and seed: in the report (text and JSON) and in --plot; repeat",
    )


def save_simulation_plot(path: str, results: dict) -> None:
    """Save the side-by-side figure of the Monte-Carlo results of each plan (``{label:
    MonteCarloResult}``, the simulated plan first) to ``path``."""
    plots.save_figure(plots.error_comparison(results), path)
