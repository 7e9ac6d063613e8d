"""Shared fixtures: robots are loaded once per session (they are immutable)."""

from __future__ import annotations

import os

# Small dense matrices everywhere: BLAS threads only contend (4x slower on a loaded 2-core box).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pincal  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OFF_AXIS = [(0.1, 0.05, 0.2)]


@pytest.fixture(scope="session")
def planar():
    return pincal.load_robot(ROOT / "robots" / "planar_2r.urdf", tip="tip")


@pytest.fixture(scope="session")
def kr270():
    return pincal.load_robot(ROOT / "robots" / "kr270.urdf", tip="tool0")


@pytest.fixture(scope="session")
def kr270_marker():
    return pincal.load_robot("kr270", tip="tool0", markers=OFF_AXIS)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def pytest_collection_modifyitems(config, items):
    """The long fuzz profile runs only when asked for (pytest -m fuzz)."""
    if "fuzz" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="long fuzz profile: run with 'pytest -m fuzz'")
    for item in items:
        if item.get_closest_marker("fuzz"):
            item.add_marker(skip)
