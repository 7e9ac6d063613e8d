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
    fast = dict(starts=2, workers=1, pool=50)
    # design: one int is drawn from the Generator; it is the result's seed and repeats the design.
    drawn = pincal.design(params, 2, [0.0, 1.0], search=pincal.Search(**fast, seed=np.random.default_rng(5)))
    assert drawn.seed == int(np.random.default_rng(5).integers(2**63))
    again = pincal.design(params, 2, [0.0, 1.0], search=pincal.Search(**fast, seed=drawn.seed))
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
        pincal.design(params, 2, [0.0, 1.0], search=pincal.Search(**fast, seed=-3))


def test_bad_arguments_are_value_errors_carrying_what_they_name(tmp_path, kr270):
    # Ordinary Python code catches them as ValueError.
    with pytest.raises(ValueError):
        pincal.load_robot("planar_2r").parameters("no_such_parameter")
    with pytest.raises(pincal.errors.BadConfiguration) as caught:
        kr270.configurations([0, 0, 0, 0, 0, 0])  # A2's limits are [-140°, -5°]
    error = caught.value
    assert isinstance(error, ValueError)
    assert error.joint == "joint_a2" and error.value == 0.0
    assert error.valid == pytest.approx((-np.radians(140), -np.radians(5)))
    plan = tmp_path / "plan.csv"
    plan.write_text("joint1,joint2\n0.1,0.2\n0.3,x\n")
    with pytest.raises(pincal.errors.BadPlanFile) as caught:
        pincal.Plan.from_csv(plan)
    assert (caught.value.file, caught.value.line) == (str(plan), 3)
    with pytest.raises(pincal.errors.BadArgument) as caught:
        pincal.design(pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx"), 0, test_pose=[0, 1])
    assert caught.value.argument == "m (number of configurations)" and caught.value.value == 0
    with pytest.raises(pincal.errors.UnknownParameter) as caught:
        kr270.parameters("joint_a9.tx")
    assert caught.value.name == "joint_a9.tx" and "joint_a2.tx" in caught.value.valid


def test_every_exception_is_a_pincal_error_and_input_errors_are_value_errors():
    import pincal.errors as errors

    for name in dir(errors):
        cls = getattr(errors, name)
        if isinstance(cls, type) and issubclass(cls, Exception):
            assert issubclass(cls, pincal.PincalError), name
    for cls in (errors.UnknownName, errors.BadConfiguration, errors.BadConstraint, errors.BadMeasurementData,
                errors.BadPlanFile, errors.RobotNotFound, errors.UnsupportedJoint):  # fmt: skip
        assert issubclass(cls, errors.BadArgument) and issubclass(cls, ValueError), cls


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
    assert pincal.arguments.DEFAULT_SIGMA == 3e-5


# ------------------------------------------------- one answer for the same value, everywhere
SIGMA_REFUSED = "sigma must be a positive number of metres from 1e-12 to 1000"


def _sigma_calls(planar):
    """Every public function that takes σ, called with it (a plan and test pose of the planar arm)."""
    params = planar.parameters("joint2.tx,tip.tx")
    plan, q0 = [[0.1, 1.0], [0.5, -1.0], [1.0, 2.0]], [0.3, 1.2]
    return {
        "rho0": lambda s: pincal.rho0(params, plan, q0, sigma=s),
        "rho0_each": lambda s: pincal.evaluation.rho0_each(params, plan, q0, sigma=s),
        "position_covariance": lambda s: pincal.evaluation.position_covariance(params, plan, q0, sigma=s),
        "TestPoseCriterion": lambda s: pincal.evaluation.TestPoseCriterion(params, q0, sigma=s),
        "PredictedError": lambda s: pincal.evaluation.PredictedError(params, plan, s),
        "accuracy": lambda s: pincal.accuracy(params, plan, q0, sigma=s, samples=8, workspace=8),
        "error_profile": lambda s: pincal.evaluation.error_profile(
            params, {"p": plan}, q0, sigma=s, samples=8
        ),
        "check_plan": lambda s: pincal.evaluation.check_plan(params, plan, sigma=s),
        "design": lambda s: pincal.design(
            params, 3, q0, sigma=s, search=pincal.Search(starts=1, workers=1, pool=50)
        ),
        "random_plans": lambda s: pincal.random_plans(params, 3, 5, q0, sigma=s),
        "monte_carlo": lambda s: pincal.monte_carlo(params, plan, q0, sigma=s, trials=2),
        "simulate_measurements": lambda s: pincal.simulate_measurements(planar, plan, sigma=s),
        "identify": lambda s: pincal.identify(
            params, pincal.simulate_measurements(planar, plan, 0.0), sigma=s
        ),
        "scene": lambda s: pincal.scene(params, plan, q0, sigma=s),
        "Prior.information": lambda s: pincal.Prior(1e-3, 1e-3).information(params, s),
    }


SIGMA_OR_INSTRUMENT = (
    "rho0", "rho0_each", "accuracy", "error_profile", "design", "random_plans", "monte_carlo",
    "simulate_measurements", "scene", "check_plan", "position_covariance", "TestPoseCriterion",
    "PredictedError",
)  # fmt: skip
"""The functions whose ``sigma=`` is the shorthand of ``instrument=`` (pincal.instruments.given)."""


@pytest.mark.parametrize("sigma", [1e-20, -1.0, 0.0, float("inf"), float("nan"), 1e308, True, "3e-5", None])
def test_sigma_has_one_answer_everywhere(planar, sigma):
    """rho0(sigma=1e-20) was accepted where design refused it, position_covariance(sigma=-1)
    returned a covariance: every function now refuses the same values with the same words (0 is
    exact points for simulate_measurements only)."""
    for name, call in _sigma_calls(planar).items():
        if name == "simulate_measurements" and sigma == 0.0:
            assert call(sigma).points.shape == (3, 1, 3)
            continue
        if name == "identify" and sigma is None:  # identify's None: estimated from the residuals
            continue
        if name in SIGMA_OR_INSTRUMENT and sigma is None:  # None: not given (the default σ, or instrument=)
            call(sigma)
            continue
        with pytest.raises(pincal.errors.BadArgument, match=SIGMA_REFUSED) as caught:
            call(sigma)
        assert caught.value.argument == "sigma", name


@pytest.mark.parametrize(
    "option, value, fragment",
    [
        ("--sigma", "1e-20", "must be a positive number of metres from 1e-12 to 1000, got 1e-20"),
        ("--sigma", "nan", "must be a positive number of metres from 1e-12 to 1000, got nan"),
        ("--seed", "-1", "must be an integer ≥ 0, got -1"),
        ("--starts", "0", "must be an integer from 1 to 10,000,000, got 0"),
        ("--starts", str(10**30), "must be an integer from 1 to 10,000,000"),
        ("--min-conditioning", "0.5", "must be a number in [0, 0.1), got 0.5"),
        ("--around", "-10deg", "--around '-10deg': the angle must be a positive number of radians"),
    ],
)
def test_the_cli_refuses_with_the_api_s_bounds_naming_the_option(cli, option, value, fragment):
    argv = ["design", "planar_2r", "-m", "3", "--test-pose=0.3,1.2", "--params", "joint2.tx,tip.tx"]
    err = cli.fails(*argv, f"{option}={value}", match=fragment)
    if option != "--around":  # read by argparse: the option is named once, in argparse's words
        assert err.startswith(f"pincal: error: argument {option}: must be")


def test_counts_angles_lengths_fractions_have_one_rule(planar):
    params = planar.parameters("joint2.tx,tip.tx")
    q0 = [0.3, 1.2]
    counts = {
        "around samples": lambda n: pincal.around(q0, 0.1, samples=n),
        "cartesian_box samples": lambda n: pincal.cartesian_box(
            [0, 0, 0], [1, 1, 1], reference=q0, samples=n
        ),
        "random_plans n": lambda n: pincal.random_plans(params, 3, n, q0),
        "design starts": lambda n: pincal.design(params, 3, q0, search=pincal.Search(starts=n, workers=1)),
        "monte_carlo trials": lambda n: pincal.monte_carlo(params, [[0, 1], [1, 1], [1, 2]], q0, trials=n),
        "random_configurations": lambda n: planar.random_configurations(n),
        "Plan.repeat": lambda n: pincal.Plan.for_robot(planar, [[0, 1]]).repeat(n),
        "identifiability": lambda n: pincal.model.identifiability(params, n_configurations=n),
    }
    for name, call in counts.items():
        for bad in (True, 1.5, -1, 10**8):
            with pytest.raises(pincal.errors.BadArgument, match="must be an integer") as caught:
                call(bad)
            assert caught.value.value is bad, name
    for call in (
        lambda a: pincal.around(q0, a),
        lambda a: pincal.accuracy(params, [[0, 1], [1, 1], [1, 2]], q0, sigma=3e-5, neighbourhoods=(a,)),
        lambda a: planar.random_configurations(3, margin=a),
    ):
        for bad in (-0.1, float("inf"), 1e7, True):
            with pytest.raises(pincal.errors.BadArgument, match="number of radians"):
                call(bad)
    for bad in ([0, 0, 1e7], [0, 0, True], [0, 0, float("nan")]):
        with pytest.raises(pincal.errors.BadArgument, match="must be a number of metres in"):
            pincal.cartesian_box([0, 0, 0], bad, reference=q0)
    for bad in (0, 1, 1.5, True):
        with pytest.raises(pincal.errors.BadArgument, match=r"must be a fraction in \(0, 1\)"):
            pincal.calibration.holdout(
                params, pincal.simulate_measurements(planar, [[0, 1], [1, 1], [1, 2]], 0.0), bad
            )
    with pytest.raises(pincal.errors.BadArgument, match=r"keep must be a fraction in \(0, 1\]"):
        pincal.design(params, 3, q0, search=pincal.Search(keep=0, workers=1))
