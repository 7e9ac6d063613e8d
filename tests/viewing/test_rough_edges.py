"""A newcomer's first hour (issue 21), figures: without matplotlib every figure option is one line
naming the extra."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]


# --------------------------------------------------------------- figures without matplotlib
HIDE_MATPLOTLIB = """
import sys

class Hidden:
    def find_spec(self, name, path=None, target=None):
        if name == "matplotlib" or name.startswith("matplotlib."):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None

for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
    del sys.modules[name]
sys.meta_path.insert(0, Hidden())
from pincal.cli import main
code = main(sys.argv[1:])
assert "matplotlib" not in sys.modules
sys.exit(code)
"""


NEEDS_MATPLOTLIB = 'needs matplotlib, which is not installed: pip install "pincal[plot]"'


@pytest.mark.parametrize("command", ["design", "evaluate", "identify", "simulate"])
def test_every_figure_without_matplotlib_is_one_line_naming_the_extra(cell, command):
    """The top-level package hidden by a meta-path finder in a fresh interpreter (as after the
    README's install without the extra): exit 2, one line, and no output written."""
    planar = [cell / "robot.urdf", *PLANAR]
    argv = {
        "design": ["design", *planar, "-m", "3", "--test-pose=0.3,1.2", "--workers", "1", "--out",
                   cell / "out.csv", "--plot", cell / "fig.png"],
        "evaluate": ["evaluate", *planar, "--plan", cell / "plan.csv", "--test-pose=0.3,1.2",
                     "--accuracy-plot", cell / "fig.png"],
        "identify": ["identify", *planar, "--data", cell / "meas.csv", "--holdout", "0.3", "--out",
                     cell / "out.urdf", "--plot", cell / "fig.png"],
        "simulate": ["simulate", *planar, "--plan", cell / "plan.csv", "--test-pose=0.3,1.2",
                     "--trials", "3", "--plot", cell / "fig.png"],
    }[command]  # fmt: skip
    (cell / "meas.csv").write_text("joint1,joint2,x,y,z\n0,0,1.8,0,0\n0,1,1.43,0.67,0\n1,1,0.21,1.57,0\n")
    before = sorted(os.listdir(cell))
    done = subprocess.run(
        [sys.executable, "-c", HIDE_MATPLOTLIB, *map(str, argv)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 2, done.stderr
    flag = "--accuracy-plot" if command == "evaluate" else "--plot"
    assert done.stderr == f"pincal: error: {flag} (a figure) {NEEDS_MATPLOTLIB}\n"
    assert sorted(os.listdir(cell)) == before


def test_the_plots_module_without_matplotlib_names_the_extra():
    code = HIDE_MATPLOTLIB.split("from pincal.cli")[0] + (
        "import pincal.viewing.plots\n"
        "try:\n"
        "    pincal.viewing.plots.rho0_histogram([1e-4, 2e-4], 1e-4)\n"
        "except pincal.errors.MissingDependency as exc:\n"
        "    print(exc)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout == f"pincal.viewing.plots {NEEDS_MATPLOTLIB}\n"
