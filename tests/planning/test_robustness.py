"""Robustness of the planning inputs and the design (issue 12; split from tests/cli/test_robustness.py):
bounded plan and constraints readers, and the determinism / concurrency checks of a design."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import pincal
from pincal.cli import main
from pincal.files import MAX_CELL_CHARS, MAX_LINE_CHARS, MAX_YAML_DEPTH

PLANAR = ["--tip", "tip", "--params", "joint2.tx,tip.tx"]
PLAN = "joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n"


# ------------------------------------------------------------------------------ bounded readers
@pytest.mark.parametrize(
    "content, fragment",
    [
        (b"joint1,joint2\n0.1,\x000.2\n", "line 2: a NUL byte"),
        (b"joint1,joint2\n0.1," + b"1" * (MAX_CELL_CHARS + 1) + b"\n", "more than the 1000 a cell"),
        (b"joint1,joint2\n" + b"0.1," * (MAX_LINE_CHARS // 4 + 1) + b"\n", "a line may have"),
        (b"joint1,joint2\n\xff\xfe,1\n", "line 2: not UTF-8"),
        (b"joint1,joint2\n1e999,0\n", "must be finite"),
        (b"joint1,joint2\n" + b"9" * 400 + b",0\n", "must be finite"),
    ],
)
def test_plan_csv_limits(cell, cli, content, fragment):
    (cell / "plan.csv").write_bytes(content)
    cli.fails(
        "evaluate",
        cell / "robot.urdf",
        "--plan",
        cell / "plan.csv",
        "--test-pose=0,1",
        *PLANAR,
        match=fragment,
    )


def test_csv_byte_order_mark_and_crlf_are_read(cell, capsys):
    (cell / "plan.csv").write_bytes(b"\xef\xbb\xbf" + PLAN.replace("\n", "\r\n").encode())
    argv = ["evaluate", cell / "robot.urdf", "--plan", cell / "plan.csv", "--test-pose=0.3,1.2", *PLANAR]
    assert main([str(a) for a in argv]) == 0


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("joint_limits: " + "[" * 5000 + "]" * 5000, f"nested more than {MAX_YAML_DEPTH} levels"),
        ("joint_limits: {margin_deg: 1.0e+999}", "joint_limits.margin_deg is inf, not a finite number"),
        ("joint_limits: {margin_deg: " + "1" * 5000 + "}", "digits"),
        ("joint_limits: {margin_deg: " + "9" * 400 + "}", "an integer of 400 digits, over 1e300"),
        ("joint_limits: {margin_deg: .nan}", "not a finite number"),
        ("a: &x [1]\nb: *x", "anchors and aliases"),
        ("workspace_box: 3", "workspace_box must be a mapping"),
        ("workspace_box: {lower: {a: 1}, upper: [1, 1, 1]}", "must be 3 numbers"),
        ("self_collision: {package_dirs: 5}", "package_dirs must be folder names"),
        ("!!python/object/apply:os.system ['true']", "not valid YAML"),
        ("joint_limits: {margin_deg: 1", ", line 1: not valid YAML"),
    ],
)
def test_constraints_yaml_limits(cell, cli, text, fragment):
    (cell / "cell.yaml").write_text(text)
    argv = ["design", cell / "robot.urdf", "-m", "3", "--test-pose=0.3,1.2", *PLANAR, "--workers", "1"]
    cli.fails(*argv, "--constraints", cell / "cell.yaml", match=fragment)


# ------------------------------------------------ determinism, concurrency, interrupted writes
def _design(seed: int) -> np.ndarray:
    params = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")
    return pincal.design(
        params, 3, [0.3, 1.2], search=pincal.Search(starts=3, seed=seed, workers=1, pool=200)
    ).plan.q


def test_same_seed_same_plan_and_concurrent_designs_agree():
    serial = {seed: _design(seed) for seed in (0, 1)}
    assert not np.array_equal(serial[0], serial[1])  # the seed matters
    results: dict = {}

    def run(k: int) -> None:
        results[k] = _design(k % 2)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(8):
        np.testing.assert_array_equal(results[k], serial[k % 2])


def test_cli_same_seed_same_plan_file(cell):
    outs = []
    for k in range(2):
        out = cell / f"plan{k}.csv"
        argv = ["design", cell / "robot.urdf", "-m", "3", "--test-pose=0.3,1.2", *PLANAR]
        argv += ["--starts", "2", "--workers", "1", "--no-progress", "--pool-size", "100", "--seed", "7"]
        assert main([str(a) for a in [*argv, "--out", out]]) == 0
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
