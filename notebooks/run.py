"""Re-execute the notebooks and store them with their outputs.

    python notebooks/run.py                    # every notebook
    python notebooks/run.py 02_kr270           # the ones named

Run it after any change that moves the numbers the notebooks show (a design kernel, a default, the
notebook itself), and commit the notebooks it rewrites: ``tests/contracts/test_notebooks.py`` re-executes each
notebook and fails when a stored number is not what the code produces, to the tolerance its output
declares. Each notebook runs in a fresh kernel in a temporary working directory (nothing is written
into the repository) and is written back only when every cell ran without an error.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import nbclient
import nbformat

HERE = Path(__file__).resolve().parent
TIMEOUT_S = 600
"""Longest a cell may run [s]."""


def notebooks(names: list[str] | None = None) -> list[Path]:
    """The notebooks of this folder, or those named (file names, with or without ``.ipynb``)."""
    every = sorted(HERE.glob("*.ipynb"))
    if not names:
        return every
    wanted = {Path(name).stem for name in names}
    unknown = wanted - {path.stem for path in every}
    if unknown:
        raise SystemExit(
            f"run.py: no notebook {', '.join(sorted(unknown))}; there are {', '.join(p.stem for p in every)}"
        )
    return [path for path in every if path.stem in wanted]


def execute(path: Path) -> nbformat.NotebookNode:
    """The notebook at ``path`` run afresh from top to bottom (stored outputs dropped first).

    Raises:
        nbclient.exceptions.CellExecutionError: a cell failed (the message shows the cell and the traceback).
    """
    notebook = nbformat.read(path, as_version=4)
    for cell in notebook.cells:
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    with tempfile.TemporaryDirectory(prefix="pincal-notebook-") as workdir:
        client = nbclient.NotebookClient(
            notebook,
            timeout=TIMEOUT_S,
            kernel_name="python3",
            record_timing=False,  # no execution times in the stored file: a re-run changes what changed
            resources={"metadata": {"path": workdir}},
        )
        client.execute()
    notebook.metadata.get("language_info", {}).pop("version", None)  # the Python of whoever ran it last
    return notebook


def store(path: Path, notebook: nbformat.NotebookNode) -> None:
    """Write ``notebook`` over ``path`` through a temporary file (never half written)."""
    temporary = path.with_name(path.name + ".tmp")
    nbformat.write(notebook, temporary)
    temporary.replace(path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], epilog="Example: python notebooks/run.py 01_planar_2link"
    )
    parser.add_argument("names", nargs="*", help="notebooks to run (default: every notebook of this folder)")
    args = parser.parse_args(argv)
    for path in notebooks(args.names):
        start = time.perf_counter()
        store(path, execute(path))
        print(f"{path.name}: run and stored in {time.perf_counter() - start:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
