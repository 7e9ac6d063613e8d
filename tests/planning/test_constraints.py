"""Workcell constraints: margins against hand computations, YAML loading, sampling, the search's
constraints (values and Jacobian), self-collision through Pinocchio + coal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pincal.errors import BadConstraint, Infeasible
from pincal.planning.constraints import (
    HalfSpace,
    JointLimits,
    Kinematics,
    MinSpacing,
    Mount,
    SelfCollision,
    Visibility,
    WorkspaceBox,
    constraints_from_dict,
    load_constraints,
    satisfied,
)
from pincal.planning.feasibility import Feasibility

pytestmark = pytest.mark.ur10(markers=None)  # the ur10 fixture (tests/conftest.py)


def tip_point(q1: float, q2: float) -> np.ndarray:
    """The planar 2R arm's measured point (docs/method.md §9.1: l1 = 1, l2 = 0.8)."""
    return np.array([math.cos(q1) + 0.8 * math.cos(q1 + q2), math.sin(q1) + 0.8 * math.sin(q1 + q2), 0.0])


QS = np.array([[0.0, 0.0], [0.5, 1.0], [2.0, -1.5], [-1.0, 2.5]])


def test_box_and_half_space_follow_the_geometry(planar):
    points = np.array([tip_point(*q) for q in QS])
    box = WorkspaceBox((0.5, -2, -1), (2, 2, 1))
    np.testing.assert_array_equal(box.satisfied(planar, QS), (points[:, 0] >= 0.5))
    kin = Kinematics(planar, QS)
    np.testing.assert_allclose(kin.points[:, 0], points, atol=1e-12)
    half = HalfSpace((0, 2, 0), 0.3)  # y >= 0.3 (normal normalised)
    assert half.normal == (0.0, 1.0, 0.0)
    np.testing.assert_array_equal(half.satisfied(planar, QS), points[:, 1] >= 0.3)
    np.testing.assert_allclose(half.bind(planar).margins(kin)[:, 0], points[:, 1] - 0.3, atol=1e-12)


def test_visibility_range_and_incidence(planar):
    tracker = (3.0, 0.0, 0.0)
    points = np.array([tip_point(*q) for q in QS])
    dist = np.linalg.norm(points - tracker, axis=1)
    vis = Visibility(tracker, max_range=2.5, min_range=1.3)
    np.testing.assert_array_equal(vis.satisfied(planar, QS), (dist <= 2.5) & (dist >= 1.3))
    # Marker normal along the tip's x axis: the angle to the line of sight is known in the plane.
    angled = Visibility(tracker, normal=(1, 0, 0), max_angle=math.radians(60))
    heading = QS.sum(axis=1)
    sight = np.array(tracker) - points
    angle = np.abs(np.angle(np.exp(1j * (np.arctan2(sight[:, 1], sight[:, 0]) - heading))))
    np.testing.assert_array_equal(angled.satisfied(planar, QS), angle <= math.radians(60))
    margins = angled.bind(planar).margins(Kinematics(planar, QS))
    np.testing.assert_allclose(margins[:, -1], math.radians(60) - angle, atol=1e-9)


def test_joint_limits_and_spacing(planar):
    limits = JointLimits(0.5)
    q = np.array([[0.0, 0.0], [math.pi - 0.4, 0.0]])
    np.testing.assert_array_equal(limits.satisfied(planar, q), [True, False])
    spacing = MinSpacing(0.5)
    plan = np.array([[0.0, 0.0], [0.3, 0.3], [1.0, 0.0]])
    np.testing.assert_array_equal(spacing.satisfied(planar, plan), [True, False, True])
    np.testing.assert_allclose(
        spacing.margins(plan), [math.hypot(0.3, 0.3) - 0.5, 0.5, math.hypot(0.7, 0.3) - 0.5]
    )
    assert satisfied(planar, plan, [limits]).all() and not satisfied(planar, plan, [spacing]).all()


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: WorkspaceBox((0, 0, 0), (1, -1, 1)), "below upper"),
        (lambda: HalfSpace((0, 0, 0)), "not be zero"),
        (lambda: Visibility((0, 0, 0), max_range=1, min_range=2), "below max_range"),
        (lambda: Visibility((0, 0, 0), max_angle=0.5), "needs the marker normal"),
        (lambda: JointLimits(-1), "from 0 to 1e"),
        (lambda: MinSpacing("far"), "number"),
        (lambda: WorkspaceBox((0, 0), (1, 1, 1)), "must be 3 numbers"),
    ],
)
def test_constructors_validate(make, match):
    with pytest.raises(BadConstraint, match=match):
        make()


YAML = """\
joint_limits: {margin_deg: 5}
workspace_box: {lower: [0.5, -1.5, 0.2], upper: [2.8, 1.5, 2.2]}
half_space:
  - {normal: [0, 0, 1], offset: 0.3}
  - {normal: [1, 0, 0], offset: 0.4}
visibility:
  tracker: [4.0, 0.0, 1.2]
  max_range: 6.0
  normal: [0, 0, 1]
  max_angle_deg: 60
self_collision: {min_distance: 0.01}
min_spacing: {distance_deg: 10}
"""


def test_yaml_round_trip(tmp_path):
    path = tmp_path / "cell.yaml"
    path.write_text(YAML)
    cons = load_constraints(path)
    kinds = [type(c).__name__ for c in cons]
    assert kinds == [
        "JointLimits",
        "WorkspaceBox",
        "HalfSpace",
        "HalfSpace",
        "Visibility",
        "SelfCollision",
        "MinSpacing",
    ]
    assert cons[0].margin == pytest.approx(math.radians(5))
    assert cons[4].max_angle == pytest.approx(math.radians(60)) and cons[4].normal == ((0.0, 0.0, 1.0),)
    assert cons[6].distance == pytest.approx(math.radians(10))
    assert constraints_from_dict({"self_collision": True})[0] == SelfCollision(0.0)


@pytest.mark.parametrize(
    "text, match",
    [
        ("workspace_box: {lower: [0, 0, 0]}\n", "needs lower"),
        ("boxx: {}\n", "unknown constraint 'boxx'; valid: joint_limits"),
        ("visibility: {tracker: [1, 2, 3], range: 4}\n", "unknown key 'range'"),
        ("joint_limits: {margin: 0.1, margin_deg: 5}\n", "not both"),
        ("half_space: [1, 2\n", "line"),
        ("- 1\n- 2\n", "mapping"),
    ],
)
def test_bad_yaml_is_named(tmp_path, text, match):
    path = tmp_path / "cell.yaml"
    path.write_text(text)
    with pytest.raises(BadConstraint, match=match) as info:
        load_constraints(path)
    assert "cell.yaml" in str(info.value)
    with pytest.raises(BadConstraint, match="does not exist"):
        load_constraints(tmp_path / "missing.yaml")


def test_sampling_is_feasible_and_names_the_culprit(kr270_marker):
    rng = np.random.default_rng(0)
    cons = [WorkspaceBox((0.5, -2, 0.3), (3, 2, 2.5)), HalfSpace((1, 0, 0), 0.8), MinSpacing(0.1)]
    feas = Feasibility(kr270_marker, cons)
    qs = feas.sample(300, rng)
    assert len(qs) == 300 and feas.feasible(qs).all()
    assert all(c.satisfied(kr270_marker, qs).all() for c in cons[:2])
    with pytest.raises(Infeasible, match=r"workspace_box rejected \d+ \(100 %\)"):
        Feasibility(kr270_marker, [WorkspaceBox((9, 9, 9), (10, 10, 10))]).sample(10, rng, max_tries=2000)


def test_a_mount_that_checks_nothing_is_no_constraint(kr270_marker):
    """A mount of kind 'none' (or a plane nothing the joints move can reach) keeps no point: it is
    no constraint of the search, whose feasibility is then the joint limits alone."""
    assert Mount("none").bind(kr270_marker).empty
    assert not Mount("floor").bind(kr270_marker).empty
    assert Feasibility(kr270_marker, [Mount("none")]).trivial
    assert not Feasibility(kr270_marker, [Mount("floor")]).trivial


def test_constraint_jacobian_and_repair(kr270_marker):
    cons = [WorkspaceBox((0.5, -2, 0.3), (3, 2, 2.5)), Visibility((4, 0, 1), max_range=3.5), MinSpacing(0.3)]
    feas = Feasibility(kr270_marker, cons)
    rng = np.random.default_rng(1)
    qs = feas.sample(400, rng, strict=True)
    margins = np.hstack([b.margins(feas.kinematics(qs)) for _, b in feas.bound])
    near = qs[np.argsort(margins.min(axis=1))[:4]]  # close to a boundary
    values = feas.constraint_values(near)
    m, nq = near.shape
    k = margins.shape[1]
    # The bounds' margins over their reach (at most 1), configuration by configuration, then the pairs.
    scaled = np.hstack([b.margins(feas.kinematics(near)) / b.reach for _, b in feas.bound])
    np.testing.assert_array_equal(values[: m * k], np.minimum(scaled, 1.0).ravel())
    assert len(values) == m * k + m * (m - 1) // 2 and np.all(values >= 0) and np.all(values <= 1)
    assert np.any(scaled < 1) and np.any(scaled > 1)  # both kinds of rows are checked below
    jac = feas.constraint_jacobian(near)
    assert jac.shape == (len(values), m * nq)
    h = 1e-6
    fd = np.zeros_like(jac)
    for c in range(m * nq):
        e = np.zeros(m * nq)
        e[c] = h
        plus = feas.constraint_values(near + e.reshape(m, nq))
        minus = feas.constraint_values(near - e.reshape(m, nq))
        fd[:, c] = (plus - minus) / (2 * h)
    np.testing.assert_allclose(jac, fd, rtol=1e-4, atol=1e-5 * np.abs(fd).max())
    # A configuration's margins depend on its own joints only.
    blocks = jac[: m * k].reshape(m, k, m, nq)
    off = ~np.eye(m, dtype=bool)
    assert not np.any(blocks[off.nonzero()[0], :, off.nonzero()[1], :])
    # Repair brings an infeasible plan back to a feasible one.
    outside = kr270_marker.random_configurations(200, rng)
    far = np.array(near)
    far[0] = outside[~feas.feasible(outside)][0]
    assert np.min(feas.constraint_values(far)) < 0
    fixed = feas.repair(near, far)
    assert feas.plan_feasible(fixed)


def test_self_collision_exact_and_hulls(ur10):
    collision = SelfCollision(0.0)
    bound = collision.bind(ur10)
    folded = np.array([[0.0, -1.57, 3.1, -1.57, 0.0, 0.0]])  # forearm folded onto the upper arm
    stretched = np.array([[0.0, -1.57, 0.0, -1.57, 0.0, 0.0]])  # straight up
    assert not collision.satisfied(ur10, folded)[0]
    assert collision.satisfied(ur10, stretched)[0]
    assert bound.colliding_pairs(folded[0])
    # Convex hulls contain the meshes: hulls apart implies links apart (never the reverse).
    qs = ur10.random_configurations(300, np.random.default_rng(2))
    kin = Kinematics(ur10, qs)
    exact = bound.satisfied(kin)
    hulls = np.all(bound.margins(kin) > 0, axis=1)
    assert not np.any(hulls & ~exact)
    assert 0.05 < exact.mean() < 1.0
    # Adjacent links are not checked.
    names = {n for pair in bound.names for n in pair}
    assert ("shoulder_link_0", "upper_arm_link_0") not in bound.names and "wrist_3_link_0" in names


def test_self_collision_needs_collision_geometry(planar):
    with pytest.raises(BadConstraint, match="no collision geometry"):
        SelfCollision().bind(planar)
