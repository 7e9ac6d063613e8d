"""pincal iso9283: the report from a CSV and from the IPA ISO-cube series, before and after a
calibration, in text, JSON and a figure; bad input refused in one line."""

from __future__ import annotations

import sys

import numpy as np
import pinocchio as pin
import pytest

import pincal
from tests.conftest import ROOT

IPA_SLICE = ROOT / "tests" / "data" / "iso9283" / "measurements_iso_cubes_slice.csv"


@pytest.fixture(scope="module")
def kr270_cell(tmp_path_factory, kr270_marker):
    """A true KR 270 (errors of about 0.5 mm), its calibration exported, and five poses commanded
    (the nominal model's) and attained (the true robot's, 5 µm noise) in 4 cycles, with the joint
    readings, as a CSV in millimetres and degrees."""
    folder = tmp_path_factory.mktemp("iso9283")
    robot = kr270_marker
    params = robot.parameters("lengths,offsets").identifiable().identifiable
    rng = np.random.default_rng(3)
    true = params.apply(rng.normal(0, 5e-4, len(params)))
    data = pincal.simulate_measurements(
        true, robot.random_configurations(40, 4, margin=0.1), sigma=1e-6, seed=5
    )
    result = pincal.identify(params, data, sigma=1e-6)
    assert result.success
    urdf = folder / "kr270_cal.urdf"
    pincal.export_urdf(result, urdf)
    q = np.repeat(robot.random_configurations(5, 8, margin=0.2), 4, axis=0)
    r_c, p_c = robot.tip_poses(q)
    r_t, p_t = true.tip_poses(q)
    p_c, p_t = p_c + r_c @ robot.markers[0], p_t + r_t @ robot.markers[0] + rng.normal(0, 5e-6, (20, 3))
    lines = ["pose,cycle,x_c,y_c,z_c,a_c,b_c,c_c,x,y,z,a,b,c," + ",".join(robot.joint_names)]
    for i in range(20):
        abc_c = np.degrees(pin.rpy.matrixToRpy(r_c[i]))
        abc_t = np.degrees(pin.rpy.matrixToRpy(r_t[i]))
        cells = [
            f"P{i // 4 + 1}",
            str(i % 4 + 1),
            *(p_c[i] * 1e3),
            *abc_c,
            *(p_t[i] * 1e3),
            *abc_t,
            *np.degrees(q[i]),
        ]
        lines.append(",".join(c if isinstance(c, str) else repr(float(c)) for c in cells))
    path = folder / "cycles.csv"
    path.write_text("\n".join(lines) + "\n")
    return path, urdf


def test_before_and_after_calibration(kr270_cell, cli):
    path, urdf = kr270_cell
    data = cli.json(
        "iso9283",
        "--data",
        path,
        "--mm",
        "--deg",
        "--robot",
        "kr270",
        "--calibration",
        urdf,
        "--pair",
        "P1,P3",
    )
    before, after = data["before"], data["after"]
    assert data["frame_fit"] is None and data["after_fit"]["rms"] < 1e-3
    assert [p["pose"] for p in before["poses"]] == ["P1", "P2", "P3", "P4", "P5"]
    assert all(p["n"] == 4 for p in before["poses"])
    assert before["summary"]["AP_max"] > 0.5e-3  # the true robot misses by about a millimetre
    assert after["summary"]["AP_max"] < 0.05e-3  # the calibrated model explains it (5 µm noise)
    assert after["summary"]["RP_max"] < 0.05e-3
    assert before["distances"][0]["poses"] == ["P1", "P3"]
    assert abs(after["distances"][0]["AD"]) < abs(before["distances"][0]["AD"]) + 1e-5
    code, out, err = cli.run(
        "iso9283", "--data", path, "--mm", "--deg", "--robot", "kr270", "--calibration", urdf
    )
    assert code == 0, err
    assert "before calibration:" in out and "after calibration by" in out
    assert "4 cycles (ISO 9283: 30)" in out


def test_the_ipa_series(cli, tmp_path):
    code, out, err = cli.run("iso9283", "--data", IPA_SLICE, "--format", "ipa")
    assert code == 0, err
    assert "best rigid fit of the attained positions onto the commanded ones: RMS" in out
    assert "cube 1: centre (115.7, 633.7, 762.9) mm, edge 400 mm, 3 cycle(s)" in out
    assert "distance P2-P4 (3 cycles): D_c 692.820 mm" in out
    data = cli.json("iso9283", "--data", IPA_SLICE, "--format", "ipa", "--test", "cube 1")
    assert [p["test"] for p in data["before"]["poses"]] == ["cube 1"] * 5
    assert data["frame_fit"]["rms"] < 3e-3 and data["tests"] == {
        "cube 1": "centre (115.7, 633.7, 762.9) mm, edge 400 mm, 3 cycle(s)"
    }


def test_the_figure(cli, tmp_path):
    pytest.importorskip("matplotlib")
    figure = tmp_path / "iso.png"
    code, _, err = cli.run("iso9283", "--data", IPA_SLICE, "--format", "ipa", "--plot", figure)
    assert code == 0, err
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_figure_without_matplotlib_is_refused_before_any_work(cli, tmp_path, monkeypatch):
    for name in ("matplotlib", "matplotlib.pyplot", "matplotlib.backend_bases"):
        monkeypatch.setitem(sys.modules, name, None)
    line = cli.fails("iso9283", "--data", IPA_SLICE, "--format", "ipa", "--plot", tmp_path / "iso.png")
    needs = 'needs matplotlib, which is not installed: pip install "pincal[plot]"'
    assert line == f"pincal: error: --plot (a figure) {needs}"
    assert not (tmp_path / "iso.png").exists()


def test_bad_input_is_one_line(cli, tmp_path, kr270_cell):
    path, urdf = kr270_cell
    cli.fails("iso9283", "--data", tmp_path / "missing.csv", match="missing.csv")
    cli.fails("iso9283", "--data", IPA_SLICE, match="expected the columns pose,cycle")
    cli.fails("iso9283", "--data", IPA_SLICE, "--format", "ipa", "--mm", match="no --mm or --deg")
    cli.fails(
        "iso9283", "--data", IPA_SLICE, "--format", "ipa", "--no-fit-frame", match="--no-fit-frame refused"
    )
    cli.fails(
        "iso9283", "--data", IPA_SLICE, "--format", "ipa", "--test", "cube 9", match="'cube 1', 'cube 2'"
    )
    cli.fails(
        "iso9283", "--data", IPA_SLICE, "--format", "ipa", "--pair", "P2", match="two different pose names"
    )
    cli.fails("iso9283", "--data", path, "--calibration", urdf, match="--robot")
    cli.fails("iso9283", "--data", path, "--robot", "kr270", match="give --calibration")
    bare = tmp_path / "bare.csv"
    bare.write_text("pose,cycle,x_c,y_c,z_c,x,y,z\nP1,1,0,0,0,0,0,0\n")
    cli.fails("iso9283", "--data", bare, "--robot", "kr270", "--calibration", urdf, match="joint readings")
    code, out, _ = cli.run("iso9283", "--help")
    assert code == 0 and "examples:" in out and "--format ipa" in out
