"""Every option that needs a package pincal does not require (matplotlib, scikit-learn, meshcat,
xacro) is refused when the arguments are read, before any work (issue 32): one line naming the
option and the pip command, exit 2, nothing written — never an internal error after a long search.

The package is made missing in this process (``sys.modules[name] = None``: importing it raises
ImportError) and loading the robot, the first work of every command, fails the test if reached.
tests/viewing/test_rough_edges.py hides matplotlib from a fresh interpreter for the figure options."""

from __future__ import annotations

import os
import sys

import pytest

MATPLOTLIB = ("matplotlib", "matplotlib.pyplot", "matplotlib.backend_bases")
SKLEARN = ("sklearn", "sklearn.gaussian_process", "sklearn.gaussian_process.kernels")
NEEDS = {
    MATPLOTLIB: 'needs matplotlib, which is not installed: pip install "pincal[plot]"',
    SKLEARN: 'needs sklearn, which is not installed: pip install "pincal[gp]"',
    ("meshcat",): 'needs meshcat, which is not installed: pip install "meshcat"',
}
DESIGN = "design -m 3 --test-pose=0.3,1.2"
ON_PLAN = "--plan {plan} --test-pose=0.3,1.2"

CASES = {
    # the command (its robot added), the modules made missing, what the error line names
    f"{DESIGN} --plot {{out}}.png": (MATPLOTLIB, "--plot (a figure)"),
    f"{DESIGN} --accuracy-plot {{out}}.png": (MATPLOTLIB, "--accuracy-plot (a figure)"),
    f"{DESIGN} --place-instrument 1,1,0,2,2,1 --placement-plot {{out}}.png": (
        MATPLOTLIB, "--placement-plot (a figure)"),
    f"{DESIGN} --campaign --campaign-plot {{out}}.png": (MATPLOTLIB, "--campaign-plot (a figure)"),
    f"evaluate {ON_PLAN} --accuracy-plot {{out}}.png": (MATPLOTLIB, "--accuracy-plot (a figure)"),
    f"simulate {ON_PLAN} --plot {{out}}.png": (MATPLOTLIB, "--plot (a figure)"),
    f"show {ON_PLAN} --plot {{out}}.png": (MATPLOTLIB, "--plot (a figure)"),
    "identify --data {plan} --holdout 0.3 --plot {out}.png": (MATPLOTLIB, "--plot (a figure)"),
    "identify --data {plan} --residual-model gp": (SKLEARN, "--residual-model gp"),
    "show --plan {plan} --html {out}.html": (("meshcat",), "pincal show"),
    "campaign --plan {plan} --html {out}.html": (("meshcat",), "--html (a meshcat scene)"),
}  # fmt: skip


@pytest.fixture
def no_work(monkeypatch):
    """Loading the robot (every command's first work) fails the test: the refusal comes first."""
    import pincal.cli._common as common

    def load_robot(*args, **kwargs):
        raise AssertionError("the command started its work before checking its optional packages")

    monkeypatch.setattr(common, "load_robot", load_robot)


@pytest.mark.parametrize("case", list(CASES))
def test_an_option_needing_a_missing_package_is_refused_before_any_work(
    case, tmp_path, monkeypatch, cli, no_work
):
    modules, option = CASES[case]
    for name in modules:
        monkeypatch.setitem(sys.modules, name, None)  # import raises ImportError
    plan = tmp_path / "plan.csv"
    plan.write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n")
    command, *argv = case.format(plan=plan, out=tmp_path / "out").split()
    before = sorted(os.listdir(tmp_path))
    line = cli.fails(command, "planar_2r", *argv)
    assert line == f"pincal: error: {option} {NEEDS[modules]}"
    assert sorted(os.listdir(tmp_path)) == before


def test_a_xacro_robot_without_xacro_is_refused_before_any_work(tmp_path, monkeypatch, cli, no_work):
    monkeypatch.setitem(sys.modules, "xacro", None)
    src = tmp_path / "arm.urdf.xacro"
    src.write_text('<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro"/>\n')
    line = cli.fails("params", src)
    assert line == (
        f"pincal: error: ROBOT {src} is a xacro file: pincal expands it (without ROS) once the xacro "
        'package is installed: pip install "pincal[xacro]"'
    )


def test_the_packages_present_pass(tmp_path, cli, no_work):
    """With the packages installed the check lets the command start (and reach its work)."""
    pytest.importorskip("matplotlib")
    command, *argv = DESIGN.split()
    code, _, err = cli.run(command, "planar_2r", *argv, "--plot", tmp_path / "fig.png")
    assert code == 1 and "started its work" in err, err
