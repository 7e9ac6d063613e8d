"""One door for payloads (docs: :mod:`pincal.model.statics`): a payload in any of its forms
(:data:`pincal.typing.PayloadLike`) becomes (m, 4) rows at the top of the public function that takes
it, and below that only rows travel (:data:`pincal.model.statics.PayloadRows`), normalised by
nobody again. The calls of ``payload_rows`` are counted against the list of doors: a new call is a
new public door (add it, with its reason) or rows normalised twice (pass the rows instead)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.model.kinematics import ForwardKinematics
from pincal.model.statics import Payload, carried, payload_rows, repeated

PACKAGE = Path(pincal.__file__).resolve().parent

DOORS: dict[str, tuple[int, str]] = {
    "pincal/model/statics.py::Payload.__post_init__": (1, "a Payload checks its own mass and centre"),
    "pincal/model/robot.py::Robot.joint_values": (1, "public; points and tip_poses go through it"),
    "pincal/model/robot.py::Robot.joint_torques": (1, "public"),
    "pincal/model/parameters.py::ParameterSet.jacobian": (1, "public"),
    "pincal/model/base_parameters.py::_drawn_payloads": (1, "identifiability's payloads= (public)"),
    "pincal/planning/plan.py::Plan.__post_init__": (1, "a Plan's payload (Plan.for_robot passes it on)"),
    "pincal/planning/driver.py::_loads": (2, "design's Loads: the payloads and the task payload"),
    "pincal/evaluation/test_pose.py::TestPoseCriterion.__init__": (1, "public: the task payload"),
    "pincal/evaluation/test_pose.py::position_covariance": (1, "public: the task payload"),
    "pincal/evaluation/test_pose.py::_criterion": (1, "rho0's kept criterion: its key needs the rows"),
    "pincal/evaluation/accuracy.py::accuracy": (1, "public: the task payload, one row"),
    "pincal/evaluation/predicted_error.py::PredictedError.__init__": (1, "public: the task payload, one row"),
    "pincal/compensation/compensate.py::compensate": (1, "public"),
    "pincal/calibration/synthetic.py::_compliance_scales": (1, "random_errors' payload, read only here"),
    "pincal/calibration/synthetic.py::simulate_measurements": (1, "public"),
    "pincal/calibration/monte_carlo.py::monte_carlo": (1, "public: the task payload"),
    "pincal/calibration/result.py::IdentificationResult.point_variances": (1, "public (expected_error)"),
    "pincal/calibration/_result_accuracy.py::calibration_accuracy": (1, "IdentificationResult.accuracy"),
}
"""Where ``payload_rows`` is called, ``module::qualified function``: (calls, why it is a door)."""

BELOW_THE_DOOR = (
    "pincal/model/kinematics.py",
    "pincal/model/jacobian.py",
    "pincal/model/collision.py",
    "pincal/planning/constraints",
    "pincal/instruments/kind.py",
    "pincal/instruments/point.py",
    "pincal/instruments/pose.py",
    "pincal/instruments/distance.py",
    "pincal/instruments/image.py",
    "pincal/instruments/error_model.py",
    "pincal/calibration/problem.py",
    "pincal/calibration/sanity.py",
)
"""Modules that take payloads as rows only: they never name the user's forms, nor hand their rows
to a public door (the robot's points, tip poses or joint values: those check them once more);
:class:`~pincal.model.kinematics.ForwardKinematics` takes the rows as they are."""

THROUGH_A_DOOR = re.compile(r"\.(points|tip_poses|joint_values|joint_torques)\([^()]*payload=")


def _calls() -> dict[str, int]:
    """{``module::qualified function``: calls of payload_rows in it} over the package."""
    found: dict[str, int] = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        where = path.relative_to(PACKAGE.parent).as_posix()

        def visit(node: ast.AST, scope: tuple[str, ...], where: str = where) -> None:
            for child in ast.iter_child_nodes(node):
                inner = scope
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    inner = (*scope, child.name)
                if isinstance(child, ast.Call):
                    f = child.func
                    name = f.id if isinstance(f, ast.Name) else getattr(f, "attr", None)
                    if name == "payload_rows":
                        key = f"{where}::{'.'.join(scope)}"
                        found[key] = found.get(key, 0) + 1
                visit(child, inner)

        visit(ast.parse(path.read_text(encoding="utf-8")), ())
    return found


def test_payloads_become_rows_only_at_the_doors():
    calls = _calls()
    new = sorted(set(calls) - set(DOORS))
    assert not new, (
        f"payload_rows called outside the doors: {new}. Below a public door, pass the rows "
        "(PayloadRows) on; a new public function taking payload= is a new door: list it in DOORS"
    )
    gone = sorted(set(DOORS) - set(calls))
    assert not gone, f"no longer doors (remove them from DOORS): {gone}"
    more = {k: n for k, n in calls.items() if n != DOORS[k][0]}
    assert not more, f"a door normalises more (or fewer) payloads than listed: {more}"


def test_below_the_door_takes_rows_only():
    for name in BELOW_THE_DOOR:
        target = PACKAGE.parent / name
        for path in sorted(target.rglob("*.py")) if target.is_dir() else [target]:
            text = path.read_text(encoding="utf-8")
            assert "PayloadLike" not in text, f"{path.name} takes a payload's user forms; it takes rows"
            assert "payload_rows(" not in text, f"{path.name} normalises a payload again"
            door = THROUGH_A_DOOR.search(text)
            assert door is None, f"{path.name} hands its rows to a door again: {door.group(0)}"


def test_the_helpers_below_the_door_carry_rows_as_they_are():
    rows = payload_rows(Payload(3.0, (0.0, 0.0, 0.1)), 2)
    assert carried(rows, 2) is rows  # no copy, no check
    np.testing.assert_array_equal(carried(None, 3), np.zeros((3, 4)))
    np.testing.assert_array_equal(repeated(rows[:1], 3), payload_rows(Payload(3.0, (0.0, 0.0, 0.1)), 3))
    assert repeated(None, 3) is None


@pytest.mark.parametrize("payload", [5.0, Payload(5.0, (0.0, 0.1, 0.0)), [[5.0, 0.0, 0.1, 0.0]] * 3])
def test_the_door_and_the_rows_below_it_agree(ur10, payload):
    """The robot's points under a payload in any form, through the door, are those of its rows
    below it, bit for bit (a compliant robot, where the payload moves the joints)."""
    robot = ur10.replace(joint_compliances=np.full(ur10.nq, 2e-6))
    qs = robot.random_configurations(3, 1)
    through_door = robot.points(qs, payload=payload)
    below = ForwardKinematics(robot).markers(qs, payload_rows(payload, len(qs)))
    np.testing.assert_array_equal(through_door, below)
    assert np.abs(through_door - robot.points(qs)).max() > 1e-7  # the payload matters here


def test_below_the_door_a_payload_that_is_not_rows_is_named(ur10):
    """ForwardKinematics (public in pincal.model) takes rows: a mass or a Payload there is a
    BadArgument naming the rows and the door, not a NumPy error from inside the deflection."""
    from pincal.errors import BadArgument
    from pincal.model.kinematics import ForwardKinematics

    robot = ur10.replace(joint_compliances=np.full(ur10.nq, 3e-6))
    forward, qs = ForwardKinematics(robot), robot.random_configurations(3, 1)
    rows = np.array([[5.0, 0.0, 0.0, 0.1]] * 3)
    np.testing.assert_array_equal(forward.markers(qs, rows), robot.points(qs, payload=rows))
    for wrong in (5.0, pincal.Payload(5.0), rows[:2], rows[:, :3]):
        with pytest.raises(BadArgument, match=r"\(m, 4\) rows \[kg, x, y, z\].*payload_rows"):
            forward.markers(qs, wrong)
    assert forward.motion_scale(rows[:2]).shape == (ur10.nq, ur10.nq)  # any number of rows: a bound
