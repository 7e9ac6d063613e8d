"""What users install is what is tested: the wheel holds every subpackage, module and data file of
the source tree (a subpackage missed by a hand-written list broke every regular install once), and
under .ci/run the suite runs against that installed wheel, never against the checkout.

.ci/run builds the wheel, installs it in a fresh virtual environment and runs this suite from a copy
of the repository without ``pincal/``; it sets ``PINCAL_WHEEL`` (the wheel it built),
``PINCAL_SOURCE`` (the checkout it was built from) and ``PINCAL_EXPECT_INSTALLED=1``. Run by hand,
the wheel is built here from the source tree (a few seconds, no network)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

import pincal
from pincal.model.loading import ROBOTS_DIR
from tests.conftest import ROOT


def _source() -> Path:
    """The source tree the wheel is built from (the checkout; ``PINCAL_SOURCE`` under .ci/run)."""
    source = Path(os.environ.get("PINCAL_SOURCE", ROOT))
    assert (source / "pincal" / "__init__.py").is_file(), f"no pincal/ source under {source}"
    return source


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel of the source tree: .ci/run's own, or one built here from a copy of the sources
    (so the build writes nothing into the checkout)."""
    if os.environ.get("PINCAL_WHEEL"):
        return Path(os.environ["PINCAL_WHEEL"])
    source, copy = _source(), tmp_path_factory.mktemp("source")
    for name in ("pyproject.toml", "setup.py", "setup.cfg", "MANIFEST.in", "README.md", "LICENSE"):
        if (source / name).is_file():
            shutil.copy(source / name, copy / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for folder in ("pincal", "robots"):
        shutil.copytree(source / folder, copy / folder, ignore=ignore)
    out = tmp_path_factory.mktemp("wheel")
    build = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out)]
    result = subprocess.run([*build, str(copy)], capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
    (built,) = out.glob("pincal-*.whl")
    return built


def _shipped(source: Path) -> set[str]:
    """What the wheel must hold, as its archive names: every file of every package under pincal/
    (a folder with ``__init__.py``; modules, ``py.typed``, anything the package reads) and every
    URDF of robots/ as ``pincal/robots/``."""
    expected = set()
    for init in (source / "pincal").rglob("__init__.py"):
        package = init.parent
        if any(part == "__pycache__" or part.startswith(".") for part in package.parts):
            continue
        for path in package.iterdir():
            if path.is_file() and not path.name.startswith(".") and path.suffix != ".pyc":
                expected.add(path.relative_to(source).as_posix())
    expected |= {f"pincal/robots/{p.name}" for p in (source / "robots").glob("*.urdf")}
    expected |= {f"pincal/robots/dh/{p.name}" for p in (source / "robots" / "dh").glob("*.yaml")}
    return expected


def test_the_wheel_holds_every_subpackage_module_and_robot(wheel):
    source = _source()
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
    expected = _shipped(source)
    subpackages = {p.parent.relative_to(source).as_posix() for p in (source / "pincal").rglob("__init__.py")}
    assert "pincal/planning/constraints" in subpackages and len(subpackages) >= 8
    assert {"pincal/py.typed", "pincal/model/xacro_expansion.py", "pincal/robots/kr270.urdf"} <= expected
    assert "pincal/robots/dh/ur5_dh.yaml" in expected
    missing = sorted(expected - names)
    assert not missing, f"{wheel.name} lacks {missing}"
    packaged = {n for n in names if not n.startswith("pincal-")}
    assert all(n.startswith("pincal/") for n in packaged), sorted(packaged)  # no tests/, no robots/ at top


def test_the_wheel_carries_the_license(wheel):
    """The BSD-3-Clause text travels with every install (pyproject ``license-files``), and the
    metadata declares it as an SPDX expression."""
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        licenses = [n for n in names if n.endswith(".dist-info/licenses/LICENSE")]
        assert licenses, f"{wheel.name} carries no LICENSE: {sorted(n for n in names if 'dist-info' in n)}"
        text = archive.read(licenses[0]).decode()
        (metadata,) = [n for n in names if n.endswith(".dist-info/METADATA")]
        header = archive.read(metadata).decode().split("\n\n", 1)[0]
    assert "BSD 3-Clause License" in text and "the pincal developers" in text
    assert "License-Expression: BSD-3-Clause" in header
    assert "License-File: LICENSE" in header


def test_the_tested_package_is_the_installed_wheel():
    """Under .ci/run (``PINCAL_EXPECT_INSTALLED=1``) ``import pincal`` is the wheel installed in the
    environment, not the checkout and not an editable install."""
    if os.environ.get("PINCAL_EXPECT_INSTALLED") != "1":
        pytest.skip("checked under .ci/run, which tests the installed wheel (PINCAL_EXPECT_INSTALLED=1)")
    package = Path(pincal.__file__).resolve().parent
    site = Path(sysconfig.get_paths()["purelib"]).resolve()
    assert package == site / "pincal", f"pincal imported from {package}, not from {site}"
    assert not (ROOT / "pincal").exists(), "the tests run from a copy of the repository without pincal/"
    assert (package / "robots" / "kr270.urdf").is_file()
    assert ROBOTS_DIR.resolve() == package / "robots"
    direct_url = list(site.glob("pincal-*.dist-info/direct_url.json"))
    assert not any('"editable": true' in f.read_text() for f in direct_url), "an editable install"
