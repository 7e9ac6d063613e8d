"""What the adaptive tests share: the KR 270's identifiable lengths and offsets, a region around
its test pose, and a first plan of six poses (a fast design)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal

Q0 = np.radians([0, -60, 60, 0, 45, 0])
FAST = dict(starts=2, pool=300, workers=1, polish=False)
SEARCH = pincal.Search(**FAST, seed=0)
"""next_poses's search in the tests: few starts over a small pool."""


@pytest.fixture(scope="module")
def params(kr270_marker):
    return kr270_marker.parameters("lengths,offsets").identifiable().identifiable


@pytest.fixture(scope="module")
def region():
    return pincal.around(Q0, math.radians(10), samples=64)


@pytest.fixture(scope="module")
def first(params, region):
    return pincal.design(params, 6, region, search=pincal.Search(**FAST, seed=0)).plan
