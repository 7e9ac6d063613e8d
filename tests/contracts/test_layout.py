"""The tests mirror the house (tests/README.md): each test file in the folder of the pincal stage it
tests, or in contracts/; shared helpers in support/, data in data/; every folder a package, so
test files of different stages may share a name."""

from __future__ import annotations

from pathlib import Path

import pincal
from tests.conftest import ROOT

TESTS = ROOT / "tests"
NOT_STAGES = {"contracts", "support", "data"}


def stages() -> set[str]:
    """pincal's stages: its subpackages, where pincal is imported from (the wheel under .ci/run)."""
    (package,) = pincal.__spec__.submodule_search_locations or []
    return {p.parent.name for p in Path(package).glob("*/__init__.py")}


def test_every_test_file_is_in_a_stage_folder_or_contracts():
    allowed = stages() | {"contracts"}
    misplaced = [
        path.relative_to(TESTS).as_posix()
        for path in sorted(TESTS.rglob("test_*.py"))
        if path.relative_to(TESTS).parts[0] != "data"
        and (path.parent == TESTS or path.parent.parent != TESTS or path.parent.name not in allowed)
    ]
    assert misplaced == [], f"test files outside tests/<stage>/ and tests/contracts/: {misplaced}"


def test_the_folders_are_stages_contracts_support_and_data():
    folders = {p.name for p in TESTS.iterdir() if p.is_dir() and not p.name.startswith((".", "_"))}
    assert NOT_STAGES <= folders and folders - NOT_STAGES <= stages(), sorted(folders)
    for folder in folders - {"data"}:
        assert (TESTS / folder / "__init__.py").is_file(), f"tests/{folder}/ is not a package"
    assert not list((TESTS / "support").glob("test_*.py")), "support/ holds helpers, not tests"
