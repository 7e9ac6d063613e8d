"""Designing from a measured pool (issue 29): the CLI takes --pool with --residual-model, ``next``
takes --pool, and pool configurations dropped by the safe defaults are said in one line naming the
fix (only the JSON said it before: 241 of 1 000 measured poses of an arm working below its base)."""

from __future__ import annotations

import numpy as np
import pytest

import pincal

MARKER = "0.03,-0.02,0.1"
Q0 = "--test-pose=0.3,-1.2,1.4,-1,-1.4,0.2"


@pytest.fixture(scope="module")
def measured(ur10, tmp_path_factory):
    """(measurement CSV, the same configurations as a pool CSV, calibration URDF with a residual
    model) of a UR10 with 0.3 mm of unmodelled error."""
    folder = tmp_path_factory.mktemp("pool")
    params = ur10.parameters("full,offsets").identifiable().identifiable
    field = pincal.calibration.synthetic.SmoothField.random(ur10, 3e-4, seed=2)
    qs = ur10.random_configurations(80, 3)
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=1), qs, 1e-5, seed=4, unmodelled=field
    )
    meas, pool = folder / "meas.csv", folder / "pool.csv"
    data.to_csv(meas)
    pincal.Plan.for_robot(ur10, qs).to_csv(pool)
    return meas, pool, qs


def _rows_of(plan: np.ndarray, pool: np.ndarray) -> bool:
    return all(np.abs(pool - q).max(axis=1).min() < 1e-9 for q in plan)


def test_a_measured_pool_with_a_residual_model(cli, tmp_path, measured):
    meas, pool, qs = measured
    cal = tmp_path / "cal.urdf"
    code, _, err = cli.run(
        "identify",
        "ur10",
        "--marker",
        MARKER,
        "--data",
        meas,
        "--residual-model",
        "gp",
        "--out",
        cal,
        "--no-progress",
    )
    assert code == 0, err
    code, out, err = cli.run(
        "design", "ur10", "--marker", MARKER, "-m", 12, Q0, "--residual-model", cal, "--pool", pool,
        "--starts", 2, "--workers", 1, "--json",
    )  # fmt: skip
    assert code == 0, err
    import json

    design = json.loads(out)
    assert design["criterion"] == "test-pose-gp" and design["value"] > 0
    assert _rows_of(np.array(design["plan"]), qs)


def test_pool_configurations_dropped_by_the_floor_are_said(cli, measured, ur10):
    _, pool, qs = measured
    below = int((ur10.points(qs)[:, 0, 2] < 0).sum())
    assert below > 0  # a UR10 reaches below its base plane
    code, out, err = cli.run(
        "design", "ur10", "--marker", MARKER, "-m", 12, Q0, "--pool", pool, "--starts", 2, "--workers", 1,
        "--no-progress", "--baseline", 20,
    )  # fmt: skip
    assert code == 0, err
    lines = [line for line in err.splitlines() if "pool configurations dropped" in line]
    assert len(lines) == 1  # once, though the baseline draws from the same pool
    assert "mount" in lines[0] and "--mount" in lines[0] and f"of the {len(qs)} pool" in lines[0]
    # With the robot's real mount the floor drops none (self-collision, a default, may drop some).
    code, out, err = cli.run(
        "design", "ur10", "--marker", MARKER, "-m", 12, Q0, "--pool", pool, "--starts", 2, "--workers", 1,
        "--no-progress", "--mount", "none", "--joint-margin", 0,
    )  # fmt: skip
    assert code == 0 and "mount" not in "".join(line for line in err.splitlines() if "dropped" in line)


def test_next_takes_a_pool(cli, measured, tmp_path):
    meas, pool, qs = measured
    out_csv = tmp_path / "next.csv"
    code, out, err = cli.run(
        "next", "ur10", "--marker", MARKER, "--data", meas, Q0, "-k", 3, "--pool", pool, "--starts", 2,
        "--workers", 1, "--sigma", 1e-5, "--out", out_csv, "--no-progress", "--mount", "none",
    )  # fmt: skip
    assert code == 0, err
    chosen = pincal.Plan.from_csv(out_csv).q
    assert len(chosen) == 3 and _rows_of(chosen, qs)
