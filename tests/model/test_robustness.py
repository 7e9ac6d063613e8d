"""Robustness of robot files (issue 12; split from tests/cli/test_robustness.py): bounded URDF and DH
readers with one-line messages, and runaway xacro sources stopped in one line."""

from __future__ import annotations

import pytest

from pincal.cli import main
from pincal.model import shipped_dh_tables, xacro_expansion


@pytest.mark.parametrize(
    "edit, fragment",
    [
        (lambda t: t.replace("</robot>", '<link name="x"/>' * 2001 + "</robot>"), "2005 links, more than"),
        (lambda t: t.replace("</robot>", ""), "not well-formed XML"),
        (lambda t: t.replace('<parent link="base_link"/>', ""), "missing a parent"),
        (lambda t: "\x00" + t, "a NUL byte"),
        (lambda t: t.replace("<!--", "<!--\n<!--", 1), "not well-formed XML"),  # lxml's message had a newline
        # the long fuzz run: a zero axis gave NaN directions and a NumPy warning in 'show'
        (lambda t: t.replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>', 1), "'joint1' does not move"),
        # the fuzzer: a link 1e300 m long overflowed in the Jacobians (a NumPy warning, now an error)
        (
            lambda t: t.replace('xyz="1.0 0 0"', 'xyz="1e300 0 0"'),
            "joint 'joint2' is placed at 1e+300 m, over",
        ),
    ],
)
def test_urdf_limits_and_native_messages(cell, capfd, edit, fragment):
    urdf = cell / "robot.urdf"
    urdf.write_text(edit(urdf.read_text()))
    argv = ["params", urdf, "--tip", "tip"]
    code = main([str(a) for a in argv])
    out, err = capfd.readouterr()  # file descriptor 2: urdfdom's own "Error:" lines must not show
    assert code == 2 and err.startswith("pincal: error: ") and err.count("\n") == 1, err
    assert fragment in err


def test_dh_table_with_a_400_digit_integer_is_refused(cell, cli):
    # The long fuzz run: the YAML reader's finite check formatted the integer as a float (OverflowError)
    table = (shipped_dh_tables()["ur5_dh"]).read_text().replace("a: -0.425,", "a: " + "9" * 400 + ",")
    (cell / "table.yaml").write_text(table)
    cli.fails("urdf-from-dh", cell / "table.yaml", match="joints[1].a is an integer of 400 digits")


def test_dh_table_with_an_absurd_length_is_refused_by_name(cell, cli):
    # It was refused, but as 'the URDF written differs from its DH product by 2.2e+284'
    table = (shipped_dh_tables()["ur5_dh"]).read_text().replace("a: -0.425,", "a: 1.0e+300,")
    (cell / "table.yaml").write_text(table)
    cli.fails("urdf-from-dh", cell / "table.yaml", match="row 2 (shoulder_lift_joint): a is 1e+300 m, over")


XACRO_ROBOT = (
    '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="a"><link name="base"/>'
    '<link name="{name}"/><joint name="j" type="revolute"><parent link="base"/><child link="tip"/>'
    '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
)


@pytest.mark.parametrize(
    "expression, fragment",
    [
        ("${10**10**10}", "took over 2 s and was stopped"),  # hours of big-integer arithmetic
        ("${'x' * 10**10}", "out of memory: the limit is 2 GiB"),  # 10 GB
        ("${'x' * 20000000}", "expands to over 16 MiB of URDF"),
    ],
)
def test_a_runaway_xacro_is_stopped_in_one_line(tmp_path, cli, monkeypatch, expression, fragment):
    """xacro sources are programs: they run in a child process, bounded in time, memory and
    output (pincal.model.xacro_expansion); each runaway ends in one line, and pincal goes on."""
    path = tmp_path / "runaway.urdf.xacro"
    path.write_text(XACRO_ROBOT.format(name=expression))
    with monkeypatch.context() as patched:
        if "took over" in fragment:  # only the time limit is shortened: on a loaded machine the
            patched.setattr(xacro_expansion, "XACRO_SECONDS", 2.0)  # child's start alone can take 2 s
        cli.fails("params", path, match=fragment)
    path.write_text(XACRO_ROBOT.format(name="tip"))  # the same file, sane: it loads
    assert main(["params", str(path)]) == 0
