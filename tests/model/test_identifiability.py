"""Identifiability: ranks, base sets and the reasons for what is dropped (docs/method.md §4)."""

from __future__ import annotations

import numpy as np


def test_point_on_a6_axis_hides_a6_offset(kr270):
    ident = kr270.parameters("offsets").identifiable()
    assert "joint_a6.offset" in ident.dropped
    assert ident.dropped["joint_a6.offset"].startswith("invisible")
    assert len(ident.identifiable) == 5


def test_off_axis_marker_reveals_a6_offset(kr270_marker):
    ident = kr270_marker.parameters("offsets").identifiable()
    assert "joint_a6.offset" in ident.identifiable.names
    assert not ident.dropped


def test_kr270_full_set_counts(kr270, kr270_marker):
    # 4 per revolute joint + 6 - 3 for position data = 27 with an off-axis marker; 25 on the axis.
    assert len(kr270.parameters("full").identifiable().identifiable) == 25
    assert len(kr270_marker.parameters("full").identifiable().identifiable) == 27
    ident = kr270_marker.parameters("full,offsets").identifiable()
    assert ident.rank == len(ident.identifiable) == 27


def test_dropped_redundant_parameters_are_exact_combinations(kr270_marker):
    params = kr270_marker.parameters("full,offsets")
    ident = params.identifiable()
    q = kr270_marker.random_configurations(40, 99)  # other configurations than the report used
    J = params.jacobian(q).reshape(-1, len(params))
    for name, combo in ident.combinations.items():
        rebuilt = sum(c * J[:, params.index(n)] for n, c in combo.items())
        np.testing.assert_allclose(rebuilt, J[:, params.index(name)], atol=1e-7)
    assert len(ident.dropped) == len(params) - 27


def test_offsets_preferred_over_equivalent_rotations(kr270_marker):
    ident = kr270_marker.parameters("full,offsets").identifiable()
    assert ident.dropped["joint_a1.rz"] == "redundant: equals -1·joint_a1.offset"
    assert all(f"{j}.offset" in ident.identifiable.names for j in kr270_marker.joint_names)


def test_planar_report(planar):
    ident = planar.parameters("lengths,offsets").identifiable()
    assert ident.identifiable.names == ("joint1.offset", "joint2.tx", "joint2.offset", "tip.tx")
    assert "4 identifiable" in ident.report()


def test_same_seed_same_report(kr270_marker):
    a = kr270_marker.parameters("full,offsets,base").identifiable(seed=3)
    b = kr270_marker.parameters("full,offsets,base").identifiable(seed=3)
    assert a.identifiable.names == b.identifiable.names and a.dropped == b.dropped
    c = kr270_marker.parameters("full,offsets,base").identifiable(seed=4)
    assert c.identifiable.names == a.identifiable.names
