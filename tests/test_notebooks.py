"""The notebooks in notebooks/ run from top to bottom (so they never go stale) and leave nothing
behind in the repository. They are stored with their outputs, so a reader on GitHub sees the tables
and figures without running them; refresh the outputs after editing a notebook with
``jupyter execute --inplace notebooks/NAME.ipynb`` (from the repository root)."""

from __future__ import annotations

import os
import re

# Test dependencies (pyproject's [test] extra): a broken install fails here, it does not skip.
import ipykernel  # noqa: F401  (the kernel the notebooks run on)
import nbclient
import nbformat
import pytest

from tests.conftest import ROOT

NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
MACHINE_PATH = re.compile(r"/work/|/home/|/Users/|/tmp/|site-packages|ipykernel_|pincal/[\w/]+\.py:\d+")
"""What a stored output must not show: a path of the machine that ran it, or a pincal source line
(warnings name the notebook's own code, see tests/test_warnings.py)."""
TIMEOUT_S = 300
"""Longest a cell may run [s] (each notebook takes seconds to well under a minute)."""


def _tree(root) -> set[str]:
    """Every file under ``root`` except the git database and caches."""
    skip = {".git", "__pycache__", ".pytest_cache", ".ipynb_checkpoints"}
    out = set()
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = [d for d in dirnames if d not in skip]
        out.update(os.path.relpath(os.path.join(dirpath, f), root) for f in filenames)
    return out


def test_the_four_notebooks_are_there():
    assert [p.name for p in NOTEBOOKS] == [
        "01_planar_2link.ipynb",
        "02_kr270.ipynb",
        "03_your_robot.ipynb",
        "04_beyond_geometry.ipynb",
    ]


def _text(output) -> str:
    """The text an output shows (streams and plain-text results)."""
    return "".join(output.get("text", "")) + "".join(output.get("data", {}).get("text/plain", ""))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_stored_outputs_show_no_machine_paths(path):
    notebook = nbformat.read(path, as_version=4)
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            text = _text(output)
            found = MACHINE_PATH.search(text)
            assert not found, f"{path.name} shows {found.group()!r} in: {text[:200]!r}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs(path, tmp_path):
    notebook = nbformat.read(path, as_version=4)
    code = [cell for cell in notebook.cells if cell.cell_type == "code"]
    assert all(cell.execution_count for cell in code), (
        f"store {path.name} with its outputs: jupyter execute --inplace notebooks/{path.name}"
    )
    assert not any(output.output_type == "error" for cell in code for output in cell.outputs), (
        f"{path.name} is stored with an error in its outputs"
    )
    for cell in code:  # run it afresh, not on the stored outputs
        cell.outputs, cell.execution_count = [], None
    before, original = _tree(ROOT), path.read_bytes()
    client = nbclient.NotebookClient(
        notebook,
        timeout=TIMEOUT_S,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},  # the kernel's working directory
    )
    client.execute()  # raises CellExecutionError, with the cell and the traceback, on any error
    errors = [
        output
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.outputs
        if output.output_type == "error"
    ]
    assert not errors
    shown = [MACHINE_PATH.search(_text(o)) for c in notebook.cells for o in c.get("outputs", [])]
    assert not any(shown), f"{path.name} shows {next(m.group() for m in shown if m)!r}"
    assert _tree(ROOT) == before, "the notebook wrote files into the repository"
    assert path.read_bytes() == original, "the notebook file itself is left as it was"
