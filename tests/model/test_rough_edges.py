"""A newcomer's first hour (issue 21), robots: a missing xacro package names the extra, ``to_model``
is the chain, long names and malformed chains refused in one line."""

from __future__ import annotations

import pytest

import pincal
from tests.support.urdfs import XACRO_ARM

# ------------------------------------------------------------------- xacro robots export
XACRO = XACRO_ARM  # planar 2-joint arm: properties, a macro, ${pi} limits


def test_a_missing_xacro_package_names_the_extra_not_ros(tmp_path, monkeypatch):
    from pincal.model import xacro_expansion

    path = tmp_path / "arm.urdf.xacro"
    path.write_text(XACRO)
    monkeypatch.setattr(
        xacro_expansion, "expand", lambda *a, **k: xacro_expansion.Expansion(None, "no xacro")
    )
    with pytest.raises(pincal.errors.UrdfError, match=r'without ROS.*pip install "pincal\[xacro\]"'):
        pincal.load_robot(path)


def test_to_model_is_the_chain_and_says_so():
    panda = pincal.load_robot("panda")
    model = panda.to_model()
    assert model.nq == 7 and "panda_finger_joint1" not in list(model.names)
    assert "locked" in pincal.Robot.to_model.__doc__ and "export_urdf" in pincal.Robot.to_model.__doc__


def test_a_long_robot_name_is_refused_as_a_name(cli):
    cli.fails("robots", "a" * 300, match="is 300 characters long, more than the 200 a name may have")
    cli.fails("params", "b" * 300 + ".urdf", match="File name too long")


# ------------------------------------------------------ malformed input said in one line
def _chain_urdf(n: int, loop_at: int | None = None) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = ""
    for i in range(n):
        parent, child = f"l{i}", f"l{i + 1}"
        if i == loop_at:
            child = parent
        joints += (
            f'<joint name="j{i + 1}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>'
            f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        )
    return f'<robot name="chain">{links}{joints}</robot>'


def test_a_joint_from_a_link_to_itself_is_refused(tmp_path, cli):
    (tmp_path / "ok.urdf").write_text(_chain_urdf(7))
    assert pincal.load_robot(tmp_path / "ok.urdf").nq == 7
    (tmp_path / "loop.urdf").write_text(_chain_urdf(7, loop_at=4))  # was a 4-joint robot, tip l4
    cli.fails("params", tmp_path / "loop.urdf", match="joint 'j5' has link 'l4' as both parent and child")
    broken = _chain_urdf(3).replace('<link name="l2"/>', "")
    (tmp_path / "undefined.urdf").write_text(broken)
    cli.fails("params", tmp_path / "undefined.urdf", match="names child link 'l2', which the URDF does not")
    (tmp_path / "forest.urdf").write_text(_chain_urdf(3).replace("</robot>", '<link name="stray"/></robot>'))
    cli.fails("params", tmp_path / "forest.urdf", match="2 links without a parent (l0, stray)")
