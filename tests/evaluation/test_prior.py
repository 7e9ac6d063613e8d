"""The prior in physical units (docs/method.md §8.4): parsing, per-kind standard deviations, overrides."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.errors import PincalError


@pytest.mark.parametrize(
    "text, length, angle",
    [
        ("1mm,1mrad", 1e-3, 1e-3),
        ("1mrad, 1mm", 1e-3, 1e-3),
        ("0.5 mm,0.1deg", 5e-4, math.radians(0.1)),
        ("2e-3,3e-3", 2e-3, 3e-3),
        ("20um,inf", 2e-5, math.inf),
    ],
)
def test_parse(text, length, angle):
    prior = pincal.Prior.parse(text)
    assert prior.length == pytest.approx(length, rel=1e-15)
    assert prior.angle == pytest.approx(angle, rel=1e-15)


@pytest.mark.parametrize("text", ["1mm", "1mm,2mm", "1mm,1kg", "abc,1mrad", "-1mm,1mrad", "0,1mrad", "1,2,3"])
def test_parse_rejects_with_what_is_valid(text):
    with pytest.raises(PincalError, match="length and an angle|positive"):
        pincal.Prior.parse(text)


def test_std_by_kind_and_overrides(kr270_marker):
    params = kr270_marker.parameters("full,offsets,base")
    prior = pincal.Prior(1e-3, 2e-3, {"base": math.inf, "joint_a1.offset": 0.01})
    std = prior.std(params)
    for name, s in zip(params.names, std, strict=True):
        p = params.parameters[params.index(name)]
        if name.startswith("base."):
            assert s == math.inf
        elif name == "joint_a1.offset":
            assert s == 0.01
        else:
            assert s == (1e-3 if p.unit == "m" else 2e-3)
    precision = prior.precision(params)
    assert np.allclose(np.diag(precision), np.where(np.isinf(std), 0.0, 1 / std**2))
    assert np.allclose(prior.information(params, 3e-5), 9e-10 * precision)
    assert str(pincal.Prior(1e-3, 1e-3)) == "1 mm, 1 mrad"
