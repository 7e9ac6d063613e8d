"""ISO 9283 pose characteristics (pincal.evaluation.iso9283): the formulas of docs/method.md §8.5 checked on
an example computed by hand, properties (a pure offset, noise alone, a moved instrument), the rigid
fit, the poses after calibration, and the two readers (the CSV layout and the IPA ISO-cube series)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pincal.errors import BadArgument, BadMeasurementData
from pincal.evaluation.ipa_iso_cubes import describe_cubes, read_ipa_iso_cubes
from pincal.evaluation.iso9283 import distance_characteristics, iso9283, pose_characteristics
from pincal.evaluation.pose_cycles import PoseCycles, read_pose_cycles
from pincal.evaluation.rigid_fit import rigid_fit
from tests.conftest import ROOT

IPA_SLICE = ROOT / "tests" / "data" / "iso9283" / "measurements_iso_cubes_slice.csv"
MM = 1e-3


def _rx(angle: float) -> np.ndarray:
    return pin.utils.rotate("x", angle)


def hand_example() -> PoseCycles:
    """Two poses x three cycles (millimetres in the comments, metres in the data).

    P1 commanded at (0, 0, 0) mm, attained (1, 0, 0), (3, 0, 0), (2, 3, 0) mm, and turned about the
    commanded x axis by 0.001, 0.003, 0.002 rad. P2 commanded at (100, 0, 0) mm turned 90 deg about
    z, attained (101, 0, 0) mm every cycle, turned by a further 0.002 rad about its own y axis.
    """
    rz = pin.utils.rotate("z", np.pi / 2)
    commanded = np.array([[0, 0, 0]] * 3 + [[100, 0, 0]] * 3) * MM
    attained = np.array([[1, 0, 0], [3, 0, 0], [2, 3, 0]] + [[101, 0, 0]] * 3) * MM
    commanded_r = np.array([np.eye(3)] * 3 + [rz] * 3)
    attained_r = np.array([_rx(0.001), _rx(0.003), _rx(0.002)] + [rz @ pin.utils.rotate("y", 0.002)] * 3)
    return PoseCycles(
        ("",) * 6,
        ("P1",) * 3 + ("P2",) * 3,
        np.array([1, 2, 3] * 2),
        commanded,
        attained,
        commanded_r,
        attained_r,
    )


def test_the_formulas_on_an_example_computed_by_hand():
    report = iso9283(hand_example())
    p1, p2 = report.poses
    # P1: mean attained (2, 1, 0) mm; AP = sqrt(2² + 1²) = sqrt(5) = 2.2360680 mm.
    assert p1.n == 3
    np.testing.assert_allclose(p1.deviation, np.array([2, 1, 0]) * MM, atol=1e-15)
    assert p1.ap == pytest.approx(np.sqrt(5) * MM, rel=1e-12)
    # l_j = |p_j - mean| = |(-1,-1,0)|, |(1,-1,0)|, |(0,2,0)| = sqrt2, sqrt2, 2 mm;
    # l̄ = (2 + 2 sqrt2)/3 = 1.6094757 mm; l_j - l̄ = (sqrt2 - 2)/3 twice and -2(sqrt2 - 2)/3, so
    # S_l = sqrt(6 (2 - sqrt2)²/9 / (n - 1 = 2)) = (2 - sqrt2)/sqrt3 = 0.3382040 mm;
    # RP = l̄ + 3 S_l = 1.6094757 + 1.0146119 = 2.6240876 mm.
    assert p1.rp == pytest.approx(((2 + 2 * np.sqrt(2)) / 3 + np.sqrt(3) * (2 - np.sqrt(2))) * MM, rel=1e-12)
    assert p1.rp == pytest.approx(2.6240876 * MM, abs=1e-10)
    # Orientation: a_j = 0.001, 0.003, 0.002 rad, b = c = 0: AP_a = ā = 0.002 rad;
    # S_a = sqrt(((-0.001)² + 0.001² + 0²)/2) = 0.001 rad, RP_a = 3 S_a = 0.003 rad.
    np.testing.assert_allclose(p1.ap_abc, [0.002, 0, 0], atol=1e-12)
    np.testing.assert_allclose(p1.rp_abc, [0.003, 0, 0], atol=1e-12)
    # P2: the same offset (1, 0, 0) mm each cycle: AP = 1 mm, RP = 0; its rotation is about the
    # commanded frame's y (the base's -x after the 90 deg turn): AP_b = 0.002 rad, RP = 0.
    assert p2.ap == pytest.approx(1 * MM, rel=1e-12)
    assert p2.rp == pytest.approx(0, abs=1e-15)
    np.testing.assert_allclose(p2.ap_abc, [0, 0.002, 0], atol=1e-12)
    np.testing.assert_allclose(p2.rp_abc, 0, atol=1e-12)
    # Distance P1-P2 (the pair by default: no P2/P4): D_c = 100 mm, D_j = |P2_j - P1_j| = 100, 98,
    # sqrt(99² + 3²) = sqrt(9810) = 99.0454441 mm; D̄ = 99.0151480 mm, AD = D̄ - D_c = -0.9848520 mm;
    # D_j - D̄ = 0.9848520, -1.0151480, 0.0302961; S_D = sqrt(2.0013766/2) = 1.0003441, RD = 3.0010324 mm.
    (d,) = report.distances
    assert d.poses == ("P1", "P2") and d.n == 3
    assert d.commanded == pytest.approx(100 * MM, rel=1e-12)
    assert d.ad == pytest.approx((100 + 98 + np.sqrt(9810)) / 3 * MM - 100 * MM, rel=1e-12)
    assert d.ad == pytest.approx(-0.9848520 * MM, abs=1e-10)
    assert d.rd == pytest.approx(3.0010324 * MM, abs=1e-10)


def test_the_report_in_text_and_json():
    report = iso9283(hand_example())
    text = "\n".join(report.lines())
    assert "2.2361" in text and "2.6241" in text  # AP and RP of P1 [mm]
    assert "+0.1146" in text  # AP_a of P1: 0.002 rad = 0.1146 deg
    assert "AD -0.9849 mm, RD ±3.0010 mm" in text
    assert "(ISO 9283: 30)" in text
    data = report.as_dict()
    assert data["poses"][0]["AP"] == pytest.approx(np.sqrt(5) * MM)
    assert data["summary"]["AP_max"] == pytest.approx(np.sqrt(5) * MM)


def test_a_pure_offset_gives_its_size_and_no_scatter(rng):
    commanded = rng.uniform(-1, 1, (5, 3))
    offset = np.array([0.3, -0.4, 1.2]) * MM  # 1.3 mm
    rows = np.repeat(commanded, 30, axis=0)
    cycles = PoseCycles(
        ("",) * 150,
        tuple(f"P{i + 1}" for i in range(5) for _ in range(30)),
        np.tile(np.arange(1, 31), 5),
        rows,
        rows + offset,
    )
    report = iso9283(cycles)
    for p in report.poses:
        assert p.n == 30
        assert p.ap == pytest.approx(1.3 * MM, rel=1e-9)
        assert p.rp == pytest.approx(0, abs=1e-12)
    (d,) = report.distances  # ISO's P2-P4: a translation keeps every distance
    assert d.poses == ("P2", "P4")
    assert d.ad == pytest.approx(0, abs=1e-12) and d.rd == pytest.approx(0, abs=1e-12)


def test_noise_alone_gives_no_accuracy_error_and_the_repeatability_of_its_spread(rng):
    """Isotropic noise σ per coordinate: AP → 0 and RP → E l + 3 sd l with l Maxwell-distributed:
    2σ sqrt(2/π) + 3σ sqrt(3 - 8/π) = 3.616 σ."""
    sigma, n = 0.02 * MM, 4000
    commanded = np.tile([0.5, 0.2, 0.9], (n, 1))
    cycles = PoseCycles(
        ("",) * n, ("P1",) * n, np.arange(n), commanded, commanded + rng.normal(0, sigma, (n, 3))
    )
    (p,) = iso9283(cycles).poses
    assert p.ap < 4 * sigma * np.sqrt(3 / n)
    expected = 2 * sigma * np.sqrt(2 / np.pi) + 3 * sigma * np.sqrt(3 - 8 / np.pi)
    assert p.rp == pytest.approx(expected, rel=0.03)


def test_one_cycle_has_accuracy_and_no_repeatability():
    p = pose_characteristics(np.zeros((1, 3)), np.array([[0.0, 0.0, 2e-3]]), pose="P1")
    assert p.ap == pytest.approx(2e-3) and p.rp is None
    d = distance_characteristics(np.zeros((1, 3)), np.zeros((1, 3)), np.ones((1, 3)), np.ones((1, 3)))
    assert d.ad == pytest.approx(0) and d.rd is None


def _moved(cycles: PoseCycles, rotation: np.ndarray, translation: np.ndarray, tool: np.ndarray) -> PoseCycles:
    """``cycles`` with the attained poses as an instrument at (rotation, translation) in the commanded
    frame measures them, its measured frame turned by ``tool`` on the tool."""
    positions = (cycles.attained_positions - translation) @ rotation
    rotations = np.einsum("ji,njk,kl->nil", rotation, cycles.attained_rotations, tool)
    return PoseCycles(
        cycles.test,
        cycles.pose,
        cycles.cycle,
        cycles.commanded_positions,
        positions,
        cycles.commanded_rotations,
        rotations,
    )


def test_the_rigid_fit_recovers_an_instrument_frame_exactly(rng):
    commanded = rng.uniform(-1, 1, (12, 3))
    rotations = np.array([pin.exp3(rng.normal(0, 1, 3)) for _ in range(12)])
    exact = PoseCycles(
        ("",) * 12, tuple(f"P{i}" for i in range(12)), np.ones(12), commanded, commanded, rotations, rotations
    )
    frame, tool = pin.exp3(np.array([0.3, -1.0, 2.0])), pin.utils.rotate("z", np.pi)
    moved = _moved(exact, frame, np.array([2.0, -1.0, 0.5]), tool)
    back, fit = moved.in_commanded_frame()
    np.testing.assert_allclose(fit.rotation, frame, atol=1e-12)
    np.testing.assert_allclose(fit.tool_rotation, tool, atol=1e-12)
    assert fit.rms < 1e-12
    np.testing.assert_allclose(back.attained_positions, commanded, atol=1e-12)
    np.testing.assert_allclose(back.attained_rotations, rotations, atol=1e-12)
    with pytest.raises(BadMeasurementData, match="not spread in a plane"):
        rigid_fit(np.zeros((2, 3)), np.zeros((2, 3)))


def test_distances_do_not_depend_on_the_frame(rng):
    example = hand_example()
    moved = _moved(example, pin.exp3(np.array([0.1, 0.2, -0.3])), np.array([1.0, 2.0, 3.0]), np.eye(3))
    (d,) = iso9283(example).distances
    (e,) = iso9283(moved).distances
    assert e.ad == pytest.approx(d.ad, abs=1e-12) and e.rd == pytest.approx(d.rd, abs=1e-12)


def test_after_calibration_a_model_that_explains_everything_leaves_the_commanded_poses(kr270_marker, rng):
    """Measured poses that are exactly the calibrated model's at the joint readings, seen from an
    instrument elsewhere: after compensation every pose is its commanded one (AP = RP = 0)."""
    robot = kr270_marker
    q = np.repeat(robot.random_configurations(5, rng, margin=0.2), 3, axis=0)
    rotations, positions = robot.tip_poses(q)
    measured = positions + rotations @ robot.markers[0]
    commanded = measured + np.array([1e-3, 0, 0])  # the robot misses its commands by 1 mm
    poses = tuple(f"P{i + 1}" for i in range(5) for _ in range(3))
    cycles = PoseCycles(
        ("",) * 15,
        poses,
        np.tile([1, 2, 3], 5),
        commanded,
        measured,
        rotations,
        rotations,
        q,
        robot.joint_names,
    )
    frame, tool = pin.exp3(np.array([0.0, 0.2, 1.0])), pin.utils.rotate("x", 0.5)
    seen = _moved(cycles, frame, np.array([3.0, 1.0, 0.0]), tool)
    seen = PoseCycles(*(getattr(seen, f) for f in ("test", "pose", "cycle")), seen.commanded_positions,
                      seen.attained_positions, seen.commanded_rotations, seen.attained_rotations, q,
                      robot.joint_names)  # fmt: skip
    before = iso9283(seen.in_commanded_frame()[0])
    after, fit = seen.after_calibration(robot)
    assert fit.rms < 1e-9
    report = iso9283(after)
    for p in report.poses:
        assert p.ap < 1e-9 and p.rp < 1e-9 and np.abs(p.ap_abc).max() < 1e-9
    assert max(p.ap for p in before.poses) < 1.01e-3  # the rigid fit leaves at most the 1 mm offset
    with pytest.raises(BadMeasurementData, match="joint readings"):
        hand_example().after_calibration(robot)


def _csv(tmp_path, text: str):
    path = tmp_path / "cycles.csv"
    path.write_text(text)
    return path


def test_the_csv_layout(tmp_path):
    path = _csv(
        tmp_path,
        "# P1 and P2 of one cube, millimetres and degrees\n"
        "pose,cycle,x_c,y_c,z_c,a_c,b_c,c_c,x,y,z,a,b,c\n"
        "P1,1,0,0,0,0,0,0,1,0,0,0.1,0,0\n"
        "P1,2,0,0,0,0,0,0,3,0,0,0.2,0,0\n"
        "P2,1,100,0,0,0,0,90,101,0,0,0,0,90\n"
        "P2,2,100,0,0,0,0,90,101,0,0,0,0,90\n",
    )
    cycles = read_pose_cycles(path, millimetres=True, degrees=True)
    assert cycles.pose == ("P1", "P1", "P2", "P2") and cycles.oriented
    np.testing.assert_allclose(cycles.attained_positions[1], [3e-3, 0, 0])
    np.testing.assert_allclose(cycles.commanded_rotations[2], pin.utils.rotate("z", np.pi / 2), atol=1e-12)
    p1 = iso9283(cycles).poses[0]
    assert p1.ap == pytest.approx(2e-3) and np.degrees(p1.ap_abc[0]) == pytest.approx(0.15)
    assert list(cycles.lines) == [3, 4, 5, 6]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("pose,cycle,x_c,y_c,z_c,x,y\n", "missing: z"),
        ("pose,cycle,x_c,y_c,z_c,x,y,z,a\nP1,1,0,0,0,0,0,0,0\n", "all six or none"),
        ("pose,cycle,x_c,y_c,z_c,x,y,z\nP1,1,0,0,0,0,0,zero\n", "line 2: a cell that is not a number"),
        ("pose,cycle,x_c,y_c,z_c,x,y,z\nP1,1,0,0,0,0,0,0\nP1,1,0,0,0,0,0,0\n", "cycle 1 is given twice"),
        ("pose,cycle,x_c,y_c,z_c,x,y,z\nP1,1,0,0,0,0,0,0\nP1,2,0.5,0,0,0,0,0\n", "differ by 500 mm"),
        ("pose,cycle,x_c,y_c,z_c,x,y,z\nP1,1.5,0,0,0,0,0,0\n", "whole number"),
        ("pose,cycle,x_c,y_c,z_c,x,y,z\n", "no rows"),
    ],
)
def test_a_bad_csv_is_refused_naming_what_is_wrong(tmp_path, text, match):
    with pytest.raises(BadMeasurementData, match=match):
        read_pose_cycles(_csv(tmp_path, text))


def test_an_unknown_pair_is_refused():
    with pytest.raises(BadArgument, match="no pose 'P9'; the poses are P1, P2"):
        iso9283(hand_example(), [("P1", "P9")])


def test_the_ipa_reader_groups_cubes_and_cycles():
    cycles = read_ipa_iso_cubes(IPA_SLICE)
    assert cycles.tests() == ["cube 1", "cube 2"]
    assert [len(cycles.rows("cube 1", p)) for p in ("P1", "P2", "P3", "P4", "P5")] == [3] * 5
    assert len(cycles.rows("cube 2", "P1")) == 1
    assert cycles.joint_names[0] == "shoulder_pan_joint" and cycles.joints.shape == (20, 6)
    # P2 ... P5 go round the diagonal plane: (-,+,+), (-,-,+), (+,-,-), (+,+,-) from P1, h = 200 mm.
    p1 = cycles.commanded_positions[cycles.rows("cube 1", "P1")[0]]
    signs = [
        np.sign(cycles.commanded_positions[cycles.rows("cube 1", p)[0]] - p1)
        for p in ("P2", "P3", "P4", "P5")
    ]
    np.testing.assert_array_equal(signs, [[-1, 1, 1], [-1, -1, 1], [1, -1, -1], [1, 1, -1]])
    assert describe_cubes(cycles)["cube 1"] == "centre (115.7, 633.7, 762.9) mm, edge 400 mm, 3 cycle(s)"
    report = iso9283(cycles.in_commanded_frame()[0])
    d = report.distances[0]
    assert d.poses == ("P2", "P4") and d.commanded == pytest.approx(0.4 * np.sqrt(3), abs=1e-3)
    for p in report.poses:  # a UR10: accuracy of a millimetre or two, repeatability a tenth
        assert 0 < p.ap < 3e-3
        assert p.rp is None or p.rp < 0.3e-3
        assert np.degrees(np.abs(p.ap_abc)).max() < 0.2


def test_the_ipa_reader_refuses_another_file(tmp_path):
    with pytest.raises(BadMeasurementData, match="no column Goal x"):
        read_ipa_iso_cubes(_csv(tmp_path, "pose,cycle\nP1,1\n"))
