"""Figures (pincal.plots): what they draw, that they save as non-blank PNGs, and never show."""

from __future__ import annotations

import types

import matplotlib  # the [test] extra: a broken install fails, it does not skip
import numpy as np
import pytest

import pincal

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from PIL import Image  # noqa: E402

from pincal.viewing import plots  # noqa: E402


@pytest.fixture(autouse=True)
def no_pyplot_figures():
    plt.close("all")
    yield
    assert plt.get_fignums() == [], "pincal.plots must not leave pyplot figures open"


def saved_png(fig, tmp_path):
    path = tmp_path / "fig.png"
    fig.savefig(path, dpi=60)
    pixels = np.asarray(Image.open(path).convert("RGB")).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 20, "a drawing, not a blank image"
    assert (pixels.min(axis=1) < 100).sum() > 500, "dark ink: text, axes and data"
    return path


def test_rho0_histogram(tmp_path):
    rng = np.random.default_rng(0)
    random = np.exp(rng.normal(np.log(1e-4), 0.5, 500))
    random[:7] = np.nan  # singular plans are left out
    fig = plots.rho0_histogram(random, {"designed": 2e-5, "D-optimal": 6e-5}, bins=30)
    (ax,) = fig.axes
    assert ax.get_xscale() == "log"
    heights = [p.get_height() for p in ax.patches]
    assert len(heights) == 30 and sum(heights) == 493
    lines = {line.get_label().split(":")[0]: line.get_xdata()[0] for line in ax.get_lines()}
    assert lines["designed"] == pytest.approx(2e-2) and lines["D-optimal"] == pytest.approx(6e-2)  # mm
    median = np.median(random[7:]) * 1e3
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(f"{median / 2e-2:.2g}× better" in t for t in legend)
    saved_png(fig, tmp_path)


def test_error_comparison_reports_rms_and_gains(tmp_path):
    rng = np.random.default_rng(1)
    random = np.abs(rng.normal(0, 1e-4, 300))
    designed = np.abs(rng.normal(0, 4e-5, 300))
    result = types.SimpleNamespace(errors=designed, rho0_predicted=4e-5)  # like a MonteCarloResult
    fig = plots.error_comparison({"random": random, "test-pose": result}, predicted={"random": 1e-4})
    (ax,) = fig.axes
    texts = [t.get_text() for t in ax.texts]
    rms = [np.sqrt(np.mean(random**2)) * 1e3, np.sqrt(np.mean(designed**2)) * 1e3]
    assert texts[0] == f"ρ0 = {rms[0]:.3g} mm"
    assert texts[1] == f"ρ0 = {rms[1]:.3g} mm\n{100 * (1 - rms[1] / rms[0]):.0f}% below random"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["random", "test-pose"]
    predicted = [c for c in ax.collections if c.get_label() == "predicted ρ0"]
    assert predicted, "the predicted ρ0 is drawn"
    saved_png(fig, tmp_path)


def test_search_progress_of_traces(tmp_path):
    traces = [
        (np.array([0.0, 1.0, 2.0, 3.0]), np.array([4.0, 2.0, 3.0, 1.0])),
        types.SimpleNamespace(times=[0.0, 0.5, 1.5], values=[5.0, 0.5, 0.7]),
    ]
    fig = plots.search_progress(traces, ylabel="ρ0 [mm]", best=0.25)
    (ax,) = fig.axes
    assert ax.get_yscale() == "log"
    steps = [line for line in ax.get_lines() if line.get_label().startswith("_")]
    assert len(steps) == 2
    assert list(steps[0].get_ydata()) == [4.0, 2.0, 2.0, 1.0]  # best so far never goes up
    assert "0.5 … 1" in ax.get_title()
    assert any(line.get_ydata()[0] == 0.25 for line in ax.get_lines())
    saved_png(fig, tmp_path)


def test_search_progress_of_a_design(tmp_path, planar):
    from pincal.planning.driver import design

    params = planar.parameters("joint2.tx,tip.tx")
    result = design(
        params,
        m=2,
        test_pose=[0.0, 1.0],
        search=pincal.Search(starts=8, workers=1, keep=0.5, method="continuous"),
    )
    fig = plots.search_progress(result, ylabel="ρ0/σ", scale=1.0)
    (ax,) = fig.axes
    offsets = np.vstack([c.get_offsets() for c in ax.collections])
    assert len(offsets) == 8
    assert np.allclose(sorted(offsets[:, 1]), sorted(h.value for h in result.history))
    assert {c.get_label() for c in ax.collections} == {"run to convergence", "dropped after screening"}
    saved_png(fig, tmp_path)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: plots.rho0_histogram([1e-4], {"x": 1e-5}, unit="furlong"), "unknown unit"),
        (lambda: plots.rho0_histogram([np.nan], 1e-5), "random_rho0"),
        (lambda: plots.rho0_histogram([1e-4], {}), "at least one"),
        (lambda: plots.error_comparison({}), "at least one"),
        (lambda: plots.search_progress([([0.0, 1.0], [1.0])]), "equal length"),
        (lambda: plots.search_progress([]), "at least one"),
    ],
)
def test_bad_input_is_a_pincal_error(call, message):
    with pytest.raises(pincal.PincalError, match=message):
        call()


@pytest.mark.parametrize("extra", [["--baseline", "50"], []], ids=["histogram", "search"])
def test_cli_design_plot(tmp_path, capsys, extra):
    from pincal.cli import main

    png = tmp_path / "design.png"
    argv = ["design", "planar_2r", "-m", "2", "--test-pose=0.3,1.2", "--params", "joint2.tx,tip.tx",
            "--starts", "4", "--workers", "1", "--plot", str(png), "--json"] + extra  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    pixels = np.asarray(Image.open(png).convert("RGB")).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 20


def test_cli_simulate_plot_compares_plans(tmp_path, capsys, monkeypatch):
    from pincal.cli import main

    drawn = {}

    def spy(results, **kwargs):
        drawn.update(results)
        return original(results, **kwargs)

    original = plots.error_comparison
    monkeypatch.setattr(plots, "error_comparison", spy)

    (tmp_path / "designed.csv").write_text("joint1,joint2\n0,-60\n90,60\n")
    (tmp_path / "poor.csv").write_text("joint1,joint2\n0,120\n60,160\n")
    png = tmp_path / "mc.png"
    argv = ["simulate", "planar_2r", "--plan", str(tmp_path / "designed.csv"), "--deg", "--test-pose=0,15",
            "--params", "joint2.tx,tip.tx", "--sigma", "1e-4", "--trials", "20",
            "--compare", str(tmp_path / "poor.csv"), "--plot", str(png), "--json"]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    pixels = np.asarray(Image.open(png).convert("RGB")).reshape(-1, 3)
    assert len(np.unique(pixels, axis=0)) > 20
    assert list(drawn) == ["designed", "poor"]
    assert all(len(r.errors) >= 18 for r in drawn.values())
    assert drawn["poor"].rho0_predicted > drawn["designed"].rho0_predicted
