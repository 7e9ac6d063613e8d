"""pincal design and pincal baseline on the command line."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pincal
from pincal.cli import main

PLANAR = ["planar_2r", "--params", "joint2.tx,tip.tx", "--workers", "1", "--starts", "4"]
KR = [
    "kr270",
    "--marker",
    "0.1,0.05,0.2",
    "--params",
    "lengths",
    "--test-pose=0,-90,90,0,45,0",
    "--deg",
    "--workers",
    "1",
]


def test_design_json_reaches_the_closed_form(cli, tmp_path):
    out_csv = tmp_path / "plan.csv"
    q20 = 1.2
    data = cli.json(
        "design", *PLANAR, "-m", "2", "--test-pose", f"0.3,{q20}", "--sigma", "3e-5", "--baseline", "100",
        "--out", out_csv,
    )  # fmt: skip
    assert data["rho0"] ** 2 == pytest.approx(3e-5**2 / 2 * (1 + math.sin(q20)), rel=1e-6)
    assert data["criterion"] == "test-pose" and data["starts"] == 4
    # The plan printed is the one whose rho0 is reported: the closed form (docs/method.md §9.3) in
    # its own S = Σ cos q2i.
    S = sum(math.cos(q[1]) for q in data["plan"])
    assert data["value"] ** 2 == pytest.approx(3e-5**2 * 2 * (2 - math.cos(q20) * S) / (4 - S * S), rel=1e-9)
    assert np.shape(data["plan"]) == (2, 2) and S == pytest.approx(
        2 * (1 - math.sin(q20)) / math.cos(q20), abs=1e-4
    )
    base = data["baseline"]
    assert set(base["random"]) >= {"min", "mean", "median", "max"}
    assert base["random"]["min"] >= data["rho0"] * (1 - 1e-9)
    assert base["d_optimal"] == pytest.approx(3e-5, rel=1e-6)  # 2σ²/m at S = 0
    plan = pincal.Plan.from_csv(out_csv)
    np.testing.assert_allclose(plan.q, data["plan"], rtol=0, atol=0)  # radians, exactly


def test_design_text_in_degrees_and_out_file(cli, tmp_path):
    out_csv = tmp_path / "plan.csv"
    code, text, _ = cli.run(
        "design", *PLANAR, "-m", "3", "--test-pose=10,70", "--deg", "--criterion", "D", "--out", out_csv
    )
    assert code == 0
    assert "plan:" in text and "[deg]" in text and "D = " in text and f"wrote {out_csv} (degrees)" in text
    robot = pincal.load_robot("planar_2r")
    plan = pincal.Plan.from_csv(out_csv, robot=robot, degrees=True)
    assert abs(np.cos(plan.q[:, 1]).sum()) < 1e-4  # D-optimal: Σ cos q2 = 0


def test_design_exchange_over_a_user_pool(cli, tmp_path, kr270_marker):
    pool = kr270_marker.random_configurations(25, np.random.default_rng(4))
    path = tmp_path / "taught.csv"
    pincal.Plan.for_robot(kr270_marker, pool).to_csv(path, degrees=True)
    data = cli.json("design", *KR, "-m", "4", "--method", "exchange", "--pool", path, "--starts", "3")
    rows = {tuple(np.round(q, 9)) for q in pool}
    assert all(tuple(np.round(q, 9)) in rows for q in data["plan"])
    # The taught poses outside the safe defaults (2° from a limit, below the floor) are dropped.
    safe = pincal.planning.constraints.with_safety(kr270_marker)
    kept = int(pincal.planning.constraints.satisfied(kr270_marker, pool, safe).sum())
    assert data["method"] == "exchange" and data["pool_size"] == kept and data["pool_rejected"] == 25 - kept


def test_design_with_constraints_file(cli, tmp_path, kr270_marker):
    cell = tmp_path / "cell.yaml"
    cell.write_text(
        "workspace_box: {lower: [0.8, -2, 0.4], upper: [3, 2, 2.6]}\nmin_spacing: {distance_deg: 15}\n"
    )
    data = cli.json("design", *KR, "-m", "4", "--starts", "3", "--constraints", cell)
    cons = pincal.planning.constraints.load_constraints(cell)
    assert pincal.planning.constraints.satisfied(kr270_marker, data["plan"], cons).all()


@pytest.mark.parametrize(
    "argv, match",
    [
        (["-m", "1"], "at least 2 configurations are needed"),
        (["-m", "4", "--criterion", "best"], "unknown criterion 'best'"),
        (["-m", "4", "--method", "anneal"], "valid: continuous, exchange"),
        (["-m", "4", "--pool", "nope.csv", "--method", "exchange"], "does not exist"),
    ],
)
def test_design_bad_input_one_line(cli, argv, match):
    cli.fails("design", *KR, *argv, match=match)


def test_design_bad_constraints_one_line(cli, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("workspace_box: {lower: [0, 0\n")
    cli.fails("design", *KR, "-m", "4", "--constraints", bad, match="not valid YAML")
    far = tmp_path / "far.yaml"
    far.write_text("workspace_box: {lower: [8, 8, 8], upper: [9, 9, 9]}\n")
    cli.fails("design", *KR, "-m", "4", "--constraints", far, match="workspace_box rejected")


def test_design_out_is_not_written_on_error(cli, tmp_path):
    out_csv = tmp_path / "plan.csv"
    cli.fails("design", *KR, "-m", "1", "--out", out_csv, match="at least 2")
    assert not out_csv.exists() and not list(tmp_path.iterdir())


def test_design_warns_on_one_line_at_a_singular_limit(cli):
    # A low floor that binds is warned about (the default 1e-2 binding is the floor doing its job).
    code, _, err = cli.run("design", *PLANAR, "-m", "2", "--test-pose=0.3,0", "--min-conditioning", "1e-4")
    assert code == 0
    err = err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pincal: warning:") and "not attained" in err[0]


def test_baseline_json(cli):
    data = cli.json(
        "baseline",
        *PLANAR,
        "-m",
        "2",
        "--test-pose=0.3,1.0",
        "--random",
        "200",
        "--d-optimal",
        "--sigma",
        "1",
    )
    assert data["random"]["n"] == 200 and data["random"]["min"] <= data["random"]["median"]
    assert data["random"]["min"] >= math.sqrt((1 + math.sin(1.0)) / 2) * (1 - 1e-9)
    assert data["d_optimal"] == pytest.approx(1.0, rel=1e-6)
    code, out, _ = cli.run("baseline", *PLANAR, "-m", "2", "--test-pose=0.3,1.0", "--random", "50")
    assert code == 0 and "random feasible plans" in out


@pytest.mark.parametrize("command", ["design", "baseline"])
def test_help_has_examples(capsys, command):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "examples:" in out and f"pincal {command} kr270" in out


def test_help_examples_name_identifiable_parameters(capsys):
    """Every design example in --help that names --params for a shipped arm names a set the design
    accepts (an example once listed compliances gravity never loads, which design refuses)."""
    with pytest.raises(SystemExit):
        main(["design", "--help"])
    text = capsys.readouterr().out.replace("\\\n", " ")
    examples = [line.split() for line in text.splitlines() if line.strip().startswith("pincal design")]
    checked = 0
    for words in examples:
        if "--params" not in words or words[2] not in ("kr270", "ur10"):
            continue
        option = dict(zip(words[3::1], words[4::1]))
        marker = [float(v) for v in option["--marker"].split(",")] if "--marker" in option else None
        robot = pincal.load_robot(words[2], markers=None if marker is None else [marker])
        payloads = [float(v) for v in option["--payloads"].split(",")] if "--payloads" in option else None
        found = robot.parameters(option["--params"]).identifiable(payloads=payloads)
        assert found.dropped == {}, (" ".join(words), found.dropped)
        checked += 1
    assert checked >= 1
