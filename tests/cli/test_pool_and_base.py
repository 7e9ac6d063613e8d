"""--pool and --base everywhere they matter: random baselines drawn from a user's pool, and the
base parameter set of ``identify --base`` in design, evaluate, params and baseline."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import pincal
from pincal.cli import main

POOL_Q2 = (0.5, 1.5, 2.5)
Q0 = (0.3, 1.0)
PLANAR = ["planar_2r", "--params", "joint2.tx,tip.tx", "--sigma", "1"]  # rho0 in units of sigma
QUIET = ["planar_2r", "--params", "joint2.tx,tip.tx"]  # no --sigma 1: it warns (looks like millimetres)
KR = ["kr270", "--marker", "0.1,0.05,0.2", "--test-pose=0,-90,90,0,45,0", "--deg", "--sigma", "3e-5"]


def rho0_pair(a: float, b: float, q20: float = Q0[1]) -> float:
    """ρ0 [σ = 1] of the planar arm's lengths for the plan {q2 = a, q2 = b}, in closed form.

    With J = [u(q1), u(q1 + q2)], M = [[2, s], [s, 2]] (s = cos a + cos b) and
    ρ0² = trace(M⁻¹ J0ᵀJ0) = (4 − 2 s cos q20) / (4 − s²).
    """
    s = math.cos(a) + math.cos(b)
    return math.sqrt((4 - 2 * s * math.cos(q20)) / (4 - s * s))


PAIRS = sorted(rho0_pair(a, b) for a, b in itertools.combinations(POOL_Q2, 2))


@pytest.fixture
def pool_csv(tmp_path):
    path = tmp_path / "taught.csv"
    path.write_text("joint1,joint2\n" + "".join(f"0.0,{q2}\n" for q2 in POOL_Q2))
    return path


# ------------------------------------------------------------------------ --pool
def test_random_plans_from_a_pool_are_its_plans(planar):
    params = planar.parameters("joint2.tx,tip.tx")
    pool = [[0.0, q2] for q2 in POOL_Q2]
    randoms = pincal.random_plans(params, 2, 300, Q0, sigma=1.0, pool=pool, seed=3)
    assert randoms.n == 300 and randoms.n_singular == 0
    # Three pool configurations make exactly three plans of two: every draw is one of them, all appear.
    found = np.unique(np.round(randoms.values, 12))
    np.testing.assert_allclose(found, PAIRS, rtol=1e-12)
    again = pincal.random_plans(
        params, 2, 300, Q0, sigma=1.0, pool=pincal.Plan.for_robot(planar, pool), seed=3
    )
    np.testing.assert_array_equal(randoms.values, again.values)  # a Plan or an array, same draws


def test_random_plans_pool_too_small_is_named(planar):
    params = planar.parameters("joint2.tx,tip.tx")
    with pytest.raises(pincal.errors.Infeasible, match="only 1 of the 1 pool configurations"):
        pincal.random_plans(params, 2, 10, Q0, pool=[[0.0, 1.0]])


def test_design_baseline_is_drawn_from_the_pool(cli, pool_csv):
    data = cli.json(
        "design", *PLANAR, "-m", "2", "--test-pose=0.3,1.0", "--pool", pool_csv, "--baseline", "200"
    )
    random = data["baseline"]["random"]
    assert data["rho0"] == pytest.approx(PAIRS[0], rel=1e-9)  # the best of the three
    assert random["min"] == pytest.approx(PAIRS[0], rel=1e-9)
    assert random["max"] == pytest.approx(PAIRS[-1], rel=1e-9)  # not a plan from the joint limits
    code, out, _ = cli.run(
        "design", *PLANAR, "-m", "2", "--test-pose=0.3,1.0", "--pool", pool_csv, "--baseline", "20"
    )
    assert code == 0
    assert f"random feasible plans of the configurations of {pool_csv}" in out


def test_baseline_command_draws_from_the_pool(cli, pool_csv):
    argv = ["baseline", *PLANAR, "-m", "2", "--test-pose=0.3,1.0", "--random", "200", "--pool", pool_csv]
    data = cli.json(*argv, "--d-optimal", "--workers", "1", "--starts", "3")
    assert data["pool"] == str(pool_csv)
    assert data["random"]["min"] == pytest.approx(PAIRS[0], rel=1e-9)
    assert data["random"]["max"] == pytest.approx(PAIRS[-1], rel=1e-9)
    assert sorted(q[1] for q in data["d_optimal_plan"]) in ([0.5, 1.5], [0.5, 2.5], [1.5, 2.5])
    # Without the pool, the plans come from the joint limits: their spread is far wider.
    free = cli.json(*argv[:-2])
    assert free["random"]["max"] > 2 * PAIRS[-1]


def test_show_pool_needs_plot(cli, tmp_path, pool_csv):
    cli.fails("show", *QUIET, "--plan", pool_csv, "--test-pose=0.3,1.0", "--pool", pool_csv, match="--plot")


# ------------------------------------------------------------------------ --base
@pytest.fixture(scope="module")
def kr_plan(tmp_path_factory, kr270_marker):
    robot = kr270_marker
    path = tmp_path_factory.mktemp("plan") / "plan.csv"
    pincal.Plan.for_robot(robot, robot.random_configurations(12, np.random.default_rng(7))).to_csv(
        path, degrees=True
    )
    return path


def test_evaluate_params_design_share_the_identify_base_set(cli, kr_plan):
    with_base = cli.json("evaluate", *KR, "--plan", kr_plan, "--base")
    without = cli.json("evaluate", *KR, "--plan", kr_plan)
    names = with_base["params"]
    assert {f"base.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")} <= set(names)
    assert not any(n.startswith("joint_a1.") for n in names)  # the base takes joint 1's place
    # full,offsets already moves the whole robot (joint 1's origin): the base only re-parametrises
    # the same column space, so the predicted error at the test pose cannot change.
    assert len(names) == len(without["params"])
    assert with_base["rho0"] == pytest.approx(without["rho0"], rel=1e-7)
    # The same spec in --params means the same set; params --base reports it; design uses it.
    spelled = cli.json("evaluate", *KR, "--plan", kr_plan, "--params", "full,offsets,base")
    assert spelled["params"] == names
    alone = cli.json("evaluate", *KR, "--plan", kr_plan, "--params", "base")  # the base placement only
    assert alone["params"] == [f"base.{c}" for c in ("tx", "ty", "tz", "rx", "ry", "rz")]
    listed = cli.json("params", "kr270", "--marker", "0.1,0.05,0.2", "--base")
    assert listed["identifiable"] == names
    assert "joint_a1.offset" in listed["dropped"]
    designed = cli.json("design", *KR, "--base", "-m", "10", "--starts", "2", "--workers", "1")
    assert designed["params"] == names


def test_base_adds_columns_to_a_chain_set(cli, kr_plan):
    lengths = ["--params", "lengths,offsets"]
    with_base = cli.json("evaluate", *KR, "--plan", kr_plan, *lengths, "--base")
    without = cli.json("evaluate", *KR, "--plan", kr_plan, *lengths)
    assert "base.tx" in with_base["params"] and len(with_base["params"]) > len(without["params"])
    # More unknowns on the same data: the error at the test pose can only grow.
    assert with_base["rho0"] >= without["rho0"] * (1 - 1e-9)
    code, out, _ = cli.run("evaluate", *KR, "--plan", kr_plan, *lengths, "--base")
    assert code == 0 and "with the base frame" in out


@pytest.mark.parametrize("command", ["design", "evaluate", "params", "baseline"])
def test_help_mentions_base_and_pool(capsys, command):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    out = capsys.readouterr().out
    assert "--base" in out and "instrument's frame" in out
    if command in ("design", "baseline"):
        assert "--pool" in out
