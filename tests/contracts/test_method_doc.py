"""docs/method.md is the method the code cites: every citation in the repository resolves to one
of its sections, and nothing cites the old SPEC (a file that is not in the repository)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import pincal
from tests.conftest import ROOT

METHOD = ROOT / "docs" / "method.md"
PACKAGE = Path(pincal.__file__).resolve().parent
"""The package imported (the checkout's, or the installed wheel's under .ci/run): its docstrings."""
CITING = ("tests", "notebooks", "robots", "benchmarks", "docs")
"""Folders of the repository whose files may cite the method (with README.md and CHANGELOG.md)."""
SUFFIXES = {".py", ".md", ".ipynb", ".urdf", ".yaml", ".txt"}

BY_NUMBER = re.compile(
    r"(?:docs/method\.md|\bmethod(?:'s)?)\]?\s*(?:\([^)]*\)\s*)?((?:§\s?[\d.]*\d(?:\s*(?:,|and)\s*)?)+)"
    r"|docs/method\.md section (\d+)",
    re.IGNORECASE,
)
SECTION = re.compile(r"§\s?([\d.]*\d)")
BY_ANCHOR = re.compile(r"method\.md#([\w-]+)")


def _method() -> str:
    if not METHOD.exists():
        pytest.skip("docs/method.md is not installed with the package: run the suite from a checkout")
    return METHOD.read_text(encoding="utf-8")


def _sections(text: str) -> set[str]:
    """'6', '6.2', ... of the numbered headings."""
    return set(re.findall(r"^#{2,4} (\d+(?:\.\d+)*)\.? ", text, flags=re.MULTILINE))


def _anchors(text: str) -> set[str]:
    return set(re.findall(r'<a id="([\w-]+)"></a>', text))


def _citing_files():
    for path in sorted(ROOT.iterdir()):
        if path.name in ("README.md", "CHANGELOG.md"):
            yield path
    for folder in [PACKAGE] + [ROOT / name for name in CITING]:
        for path in sorted(folder.rglob("*")):
            if path.suffix in SUFFIXES and path.is_file() and "__pycache__" not in path.parts:
                yield path


def _shown(path: Path) -> str:
    """The file as a reader finds it: relative to the repository or to the package."""
    for root, prefix in ((ROOT, ""), (PACKAGE, "pincal/")):
        if path.is_relative_to(root):
            return prefix + str(path.relative_to(root))
    return str(path)


def _citations():
    """(file, section numbers, anchors) cited in each file."""
    for path in _citing_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        numbers = set()
        for match in BY_NUMBER.finditer(text):
            numbers.update(SECTION.findall(match.group(1) or ""))
            if match.group(2):
                numbers.add(match.group(2))
        yield path, numbers, set(BY_ANCHOR.findall(text))


def test_every_citation_of_the_method_resolves():
    text = _method()
    sections, anchors = _sections(text), _anchors(text)
    assert {"2.1", "6.2", "7.5", "9.3", "11", "12", "13"} <= sections
    cited_numbers = cited_anchors = 0
    for path, numbers, names in _citations():
        where = _shown(path)
        assert numbers <= sections, f"{where} cites docs/method.md §{sorted(numbers - sections)}: none such"
        assert names <= anchors, f"{where} cites docs/method.md#{sorted(names - anchors)}: no such anchor"
        cited_numbers += len(numbers)
        cited_anchors += len(names)
    assert cited_numbers > 20 and cited_anchors > 5  # the code and README do cite it


def test_the_method_cites_its_own_sections_and_anchors():
    text = _method()
    sections, anchors = _sections(text), _anchors(text)
    own = set(SECTION.findall(text))
    assert own <= sections, sorted(own - sections)
    links = set(re.findall(r"\]\(#([\w-]+)\)", text))
    assert links and links <= anchors, sorted(links - anchors)
    assert len(anchors) == text.count('<a id="'), "an anchor is defined twice"


def test_nothing_cites_the_spec():
    for path in _citing_files():
        if path.name == Path(__file__).name:
            continue  # this file names what it looks for
        text = path.read_text(encoding="utf-8", errors="replace")
        found = re.search(r"SPEC\s*(?:§|section)|the SPEC\b|project's SPEC", text)
        assert not found, f"{_shown(path)} cites the SPEC ({found.group()!r}): cite docs/method.md"
