"""Plans: CSV and JSON round trips, degrees, plan algebra, and row-numbered errors."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.errors import BadConfiguration, BadPlanFile


def test_csv_round_trip_radians_and_degrees(tmp_path, kr270):
    plan = pincal.Plan.for_robot(kr270, kr270.random_configurations(5, 0))
    plan.to_csv(tmp_path / "p.csv")
    back = pincal.Plan.from_csv(tmp_path / "p.csv", robot=kr270)
    np.testing.assert_array_equal(back.q, plan.q)
    plan.to_csv(tmp_path / "d.csv", degrees=True)
    back = pincal.Plan.from_csv(tmp_path / "d.csv", robot=kr270, degrees=True)
    np.testing.assert_allclose(back.q, plan.q, rtol=1e-14)
    first = (tmp_path / "d.csv").read_text().splitlines()
    assert first[0] == ",".join(kr270.joint_names)
    assert float(first[1].split(",")[0]) == pytest.approx(np.degrees(plan.q[0, 0]))


def test_columns_in_any_order(tmp_path, planar):
    (tmp_path / "p.csv").write_text("joint2,joint1\n0.5,0.1\n\n# a comment\n-1.0,2.0\n")
    plan = pincal.Plan.from_csv(tmp_path / "p.csv", robot=planar)
    np.testing.assert_array_equal(plan.q, [[0.1, 0.5], [2.0, -1.0]])


@pytest.mark.parametrize(
    "text,match",
    [
        ("", "empty"),
        ("joint1,joint2\n", "no rows"),
        ("0.1,0.2\n0.3,0.4\n", "header"),
        ("joint1,joint2\n0.1\n", "line 2: 1 values, expected 2"),
        ("joint1,joint2\n0.1,0.2\n0.1,abc\n", "line 3: column joint2 is 'abc', not a number"),
        ("joint1,joint2\n0.1,nan\n", "line 2: column joint2 is nan"),
        ("joint1,joint2\n0.1,inf\n", "must be finite"),
        ("joint1,jointX\n0.1,0.2\n", r"missing joint2; unknown column\(s\) jointX"),
        ("joint1,joint1\n0.1,0.2\n", "duplicate"),
    ],
)
def test_bad_plan_files(tmp_path, planar, text, match):
    path = tmp_path / "p.csv"
    path.write_text(text)
    with pytest.raises(BadPlanFile, match=match):
        pincal.Plan.from_csv(path, robot=planar)


def test_out_of_limits_names_line_joint_and_limits(tmp_path, kr270):
    path = tmp_path / "p.csv"
    path.write_text(",".join(kr270.joint_names) + "\n0,-60,30,0,0,0\n0,-60,30,0,130,0\n")
    with pytest.raises(
        BadConfiguration,
        match=r"line 3: joint joint_a5 = 130 is outside its limits \[-122.5, 122.5\] \(degrees\)",
    ):
        pincal.Plan.from_csv(path, robot=kr270, degrees=True)
    with pytest.raises(BadConfiguration, match="look like degrees: add --deg"):
        pincal.Plan.from_csv(path, robot=kr270)


def test_missing_file(tmp_path, planar):
    with pytest.raises(BadPlanFile, match="does not exist"):
        pincal.Plan.from_csv(tmp_path / "none.csv", robot=planar)


def test_algebra_and_json(planar):
    a = pincal.Plan([[0.1, 0.2], [0.3, 0.4]], ("joint1", "joint2"))
    b = pincal.Plan([[0.5, 0.6]], ("joint1", "joint2"))
    assert len(a.repeat(3)) == 6
    np.testing.assert_array_equal(a.repeat(2).q[2:], a.q)
    np.testing.assert_array_equal((a + b).q, [[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]])
    assert np.array(a).shape == (2, 2)
    back = pincal.Plan.from_json(a.to_json())
    np.testing.assert_array_equal(back.q, a.q)
    import json

    back = pincal.Plan.from_json(json.dumps(a.to_json()))
    assert back.joint_names == a.joint_names
    with pytest.raises(BadPlanFile):
        a.concat(pincal.Plan([[0.1]], ("joint1",)))
    with pytest.raises(pincal.errors.BadArgument, match="repeat count must be an integer"):
        a.repeat(0)
    with pytest.raises(BadPlanFile):
        pincal.Plan.from_json({"q": [[1, 2]]})
    with pytest.raises(ValueError):
        a.q[0, 0] = 1.0  # read-only


def test_atomic_write_leaves_no_partial_file(tmp_path, planar, monkeypatch):
    plan = pincal.Plan([[0.1, 0.2]], ("joint1", "joint2"))
    target = tmp_path / "out.csv"
    target.write_text("previous")

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr("os.replace", boom)
    with pytest.raises(OSError):
        plan.to_csv(target)
    assert target.read_text() == "previous"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_written_files_get_ordinary_permissions(tmp_path):
    import os
    import stat

    plan = pincal.Plan([[0.1, 0.2]], ("joint1", "joint2"))
    plan.to_csv(tmp_path / "out.csv")
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE((tmp_path / "out.csv").stat().st_mode) == 0o666 & ~umask
