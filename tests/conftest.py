"""Shared fixtures: robots are loaded once per session (they are immutable)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pincal

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
