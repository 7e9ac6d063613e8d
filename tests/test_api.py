"""The public surface: every name in __all__ imports, and the README's Python example runs."""

from __future__ import annotations

import re

import pytest

import pincal
from tests.conftest import ROOT


def test_all_names_import():
    for name in pincal.__all__:
        assert hasattr(pincal, name), name
    assert pincal.__all__ == sorted(pincal.__all__)
    assert isinstance(pincal.__version__, str)


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

    import pincal.model.robot

    for module in (pincal, pincal.model.robot):
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
        assert result.attempted > 0 and result.failed == 0, module.__name__
