"""One convention per argument: seeds (int, Generator or None) and σ, checked alike everywhere."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.arguments import generator, positive_sigma, seed_entropy


def test_a_generator_is_used_as_is_and_an_int_seeds_numpy_s_default():
    rng = np.random.default_rng(3)
    assert generator(rng) is rng
    np.testing.assert_array_equal(generator(7).random(5), np.random.default_rng(7).random(5))
    assert seed_entropy(42) == 42
    assert seed_entropy(np.random.SeedSequence(9)) == 9


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3", [1]])
def test_bad_seeds_are_refused_by_name(seed):
    with pytest.raises(pincal.PincalError, match="seed must be an integer ≥ 0, a numpy Generator or None"):
        generator(seed)


@pytest.mark.parametrize("sigma", [0, -1e-5, float("nan"), float("inf"), "x", None])
def test_bad_sigma_is_refused(sigma):
    with pytest.raises(pincal.PincalError, match="sigma must be a positive number of metres"):
        positive_sigma(sigma)


def test_every_seed_argument_takes_a_generator(planar):
    params = planar.parameters("joint2.tx,tip.tx")
    fast = dict(test_pose=[0.0, 1.0], starts=2, workers=1, pool=50)
    # design: one int is drawn from the Generator; it is the result's seed and repeats the design.
    drawn = pincal.design(params, 2, seed=np.random.default_rng(5), **fast)
    assert drawn.seed == int(np.random.default_rng(5).integers(2**63))
    again = pincal.design(params, 2, seed=drawn.seed, **fast)
    np.testing.assert_array_equal(drawn.plan.q, again.plan.q)
    # The others draw from the Generator itself: the same stream as its seed.
    a = pincal.random_plans(params, 2, 20, [0.0, 1.0], seed=np.random.default_rng(8))
    b = pincal.random_plans(params, 2, 20, [0.0, 1.0], seed=8)
    np.testing.assert_array_equal(a.values, b.values)
    e1 = pincal.random_errors(params, seed=np.random.default_rng(4)).values
    np.testing.assert_array_equal(e1, pincal.random_errors(params, seed=4).values)
    np.testing.assert_array_equal(
        planar.random_configurations(3, 6), planar.random_configurations(3, np.random.default_rng(6))
    )
    with pytest.raises(pincal.PincalError, match="seed must be"):
        pincal.design(params, 2, seed=-3, **fast)


def test_bad_arguments_are_value_errors_carrying_what_they_name(tmp_path, kr270):
    # Ordinary Python code catches them as ValueError.
    with pytest.raises(ValueError):
        pincal.load_robot("planar_2r").parameters("no_such_parameter")
    with pytest.raises(pincal.BadConfiguration) as caught:
        kr270.configurations([0, 0, 0, 0, 0, 0])  # A2's limits are [-140°, -5°]
    error = caught.value
    assert isinstance(error, ValueError)
    assert error.joint == "joint_a2" and error.value == 0.0
    assert error.valid == pytest.approx((-np.radians(140), -np.radians(5)))
    plan = tmp_path / "plan.csv"
    plan.write_text("joint1,joint2\n0.1,0.2\n0.3,x\n")
    with pytest.raises(pincal.BadPlanFile) as caught:
        pincal.Plan.from_csv(plan)
    assert (caught.value.file, caught.value.line) == (str(plan), 3)
    with pytest.raises(pincal.BadArgument) as caught:
        pincal.design(pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx"), 0, test_pose=[0, 1])
    assert caught.value.argument == "m (number of configurations)" and caught.value.value == 0
    with pytest.raises(pincal.UnknownParameter) as caught:
        kr270.parameters("joint_a9.tx")
    assert caught.value.name == "joint_a9.tx" and "joint_a2.tx" in caught.value.valid


def test_every_exception_is_a_pincal_error_and_input_errors_are_value_errors():
    import pincal.errors as errors

    for name in dir(errors):
        cls = getattr(errors, name)
        if isinstance(cls, type) and issubclass(cls, Exception):
            assert issubclass(cls, pincal.PincalError), name
    for cls in (pincal.UnknownName, pincal.BadConfiguration, pincal.BadConstraint, pincal.BadMeasurementData,
                pincal.BadPlanFile, pincal.RobotNotFound, pincal.UnsupportedJoint):  # fmt: skip
        assert issubclass(cls, pincal.BadArgument) and issubclass(cls, ValueError), cls


@pytest.mark.parametrize("command", ["design", "evaluate", "baseline", "simulate", "show"])
def test_every_report_in_metres_names_its_sigma(command, tmp_path, capsys):
    from pincal.cli import main

    plan = tmp_path / "plan.csv"
    plan.write_text("joint1,joint2\n0,-1.0\n0.5,1.0\n1.0,2.0\n")
    common = ["planar_2r", "--params", "joint2.tx,tip.tx", "--test-pose=0.3,1.2"]
    extra = {
        "design": ["-m", "2", "--starts", "2", "--workers", "1", "--pool-size", "100"],
        "evaluate": ["--plan", str(plan)],
        "baseline": ["-m", "2", "--random", "20"],
        "simulate": ["--plan", str(plan), "--trials", "4"],
        "show": ["--plan", str(plan), "--html", str(tmp_path / "s.html")],
    }[command]
    assert main([command, *common, *extra]) == 0
    assert "σ = 0.030 mm (default: laser tracker)" in capsys.readouterr().out
    assert main([command, *common, *extra, "--sigma", "1e-4"]) == 0
    out = capsys.readouterr().out
    assert "σ = 0.100 mm" in out and "default" not in out.split("σ = 0.100 mm")[1].splitlines()[0]
    assert pincal.DEFAULT_SIGMA == 3e-5
