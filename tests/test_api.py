"""The public surface: every name in __all__ imports, and the README's Python example runs."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import pincal
from tests.conftest import ROOT

PACKAGE = Path(pincal.__file__).resolve().parent
"""The package under test (the checkout's pincal/, or the installed wheel's under .ci/run)."""


def test_all_names_import():
    for name in pincal.__all__:
        assert hasattr(pincal, name), name
    assert pincal.__all__ == sorted(pincal.__all__)
    assert isinstance(pincal.__version__, str)
    declared = re.search(r'^version = "([^"]+)"', (ROOT / "pyproject.toml").read_text(), re.M)
    assert declared and declared.group(1) == pincal.__version__


def test_no_import_inside_a_function_but_optional_ones():
    """Import cycles are not broken by imports inside functions: only the optional viewer
    (meshcat, through pincal.viewing.scene and its static page) is imported late."""
    allowed = {
        ("pincal/cli/show.py", "pincal.viewing.scene"),
        ("pincal/viewing/scene.py", "pincal.viewing.static_page"),
    }
    for path in sorted(PACKAGE.rglob("*.py")):
        name = path.relative_to(PACKAGE.parent).as_posix()
        for function in ast.walk(ast.parse(path.read_text())):
            if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(function):
                modules = [node.module or ""] if isinstance(node, ast.ImportFrom) else []
                modules += [a.name for a in node.names] if isinstance(node, ast.Import) else []
                for module in modules:
                    if module.split(".")[0] == "pincal":
                        assert (name, module) in allowed, f"{name}: {function.name} imports {module}"


STAGES = ("model", "evaluation", "planning", "calibration", "compensation", "viewing", "cli")


def test_data_flows_one_way():
    """Each stage imports only the stages before it (robot → parameters → Jacobians → criteria →
    design → identify → view → CLI); the foundation modules (errors, files, arguments, ...) none."""
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).parts
        stage = parts[0] if len(parts) > 1 else None
        if stage is None and parts[0] in ("__init__.py", "__main__.py"):
            continue  # the public surface gathers every stage
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("pincal."):
                target = node.module.split(".")[1]
                if target not in STAGES:
                    continue
                where = path.relative_to(PACKAGE.parent).as_posix()
                assert stage is not None, f"foundation module {where} imports the stage {target}"
                assert STAGES.index(target) <= STAGES.index(stage), f"{where} imports the later {target}"


def test_errors_share_one_root():
    for name in pincal.__all__:
        obj = getattr(pincal, name)
        if isinstance(obj, type) and issubclass(obj, Exception):
            assert issubclass(obj, pincal.PincalError), name


@pytest.mark.filterwarnings("ignore::pincal.DegenerateOptimumWarning")  # the README explains it
def test_readme_python_blocks_run(tmp_path, monkeypatch):
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, flags=re.S)
    assert blocks, "the README has Python examples"
    monkeypatch.chdir(ROOT)
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {"__name__": "readme"})


def test_docstring_examples_run():
    import doctest

    import pincal.model.loading

    for module in (pincal, pincal.model.loading):
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
        assert result.attempted > 0 and result.failed == 0, module.__name__
