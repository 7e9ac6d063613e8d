"""A newcomer's first hour (issue 21), regions: ``--around`` on prismatic joints takes a length."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal


# ------------------------------------------------------------ --around on prismatic joints
def test_around_takes_a_length_for_prismatic_joints(cli):
    rail = pincal.load_robot("rail_arm")
    q0 = [0.8, 0.3, 0.4, -0.6]
    with pytest.raises(
        pincal.errors.BadArgument, match=r"no half-width for the prismatic joint\(s\) rail.*10deg,2cm"
    ):
        pincal.around(q0, math.radians(10)).resolve(rail)
    region = pincal.around(q0, math.radians(10), length=0.02, samples=200).resolve(rail)
    spread = np.abs(region.poses - q0).max(axis=0)
    assert spread[0] <= 0.02 + 1e-12 and spread[0] > 0.015  # the rail: ±2 cm
    np.testing.assert_array_less(spread[1:], math.radians(10) + 1e-12)
    assert spread[1:].min() > math.radians(8)
    assert region.description.startswith("±10°/±2 cm around the test pose")
    # the CLI: a length is needed, and the plan table gives each column's unit
    names = ",".join(rail.parameters("full,offsets").identifiable().identifiable.names)
    base = ["design", "rail_arm", "-m", "8", "--test-pose=0.8,17,23,-34", "--deg", "--starts", "2",
            "--workers", "1", "--pool-size", "300", "--no-accuracy", "--params", names]  # fmt: skip
    cli.fails(*base, "--around", "10deg", match="prismatic joint(s) rail")
    cli.fails(*base, "--around", "10deg,2kg", match="unknown unit 'kg'")
    code, out, err = cli.run(*base, "--around", "10deg,2cm")
    assert code == 0, err
    lines = out.splitlines()
    table = lines.index("plan:")
    assert lines[table + 1].split() == ["rail", "waist", "shoulder", "elbow"]
    assert lines[table + 2].split() == ["[m]", "[deg]", "[deg]", "[deg]"]
