"""Warnings name the user's line: whatever depth inside pincal raises a warning, its file and line
are those of the first frame outside the pincal package (pincal.errors.warn), so Python and
Jupyter show the caller's code, never a pincal source line or an install path."""

from __future__ import annotations

import importlib
import sys
import warnings
from pathlib import Path

import pincal
from pincal.errors import PincalWarning, warn
from tests.support.urdfs import tree_urdf

visualize = importlib.import_module("pincal.viewing.scene")  # the module (pincal.viewing.scene: the function)

HERE = str(Path(__file__))


def _next_line() -> int:
    """The line number after the caller's."""
    return sys._getframe(1).f_lineno + 1


def _caught(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        call()
    return caught


def test_load_robot_warnings_name_the_callers_line(tmp_path):
    path = tmp_path / "tree.urdf"
    path.write_text(tree_urdf(mesh="package://nowhere/meshes/l1.stl"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        line = _next_line()
        pincal.load_robot(path)  # load_robot -> read_urdf -> check_meshes
        floating = _next_line()
        pincal.load_robot("solo12", tip="FL_FOOT")
    (mesh,) = [w for w in caught if "mesh file(s) not found" in str(w.message)]
    (base,) = [w for w in caught if "floating base" in str(w.message)]
    assert (mesh.filename, mesh.lineno) == (HERE, line)
    assert (base.filename, base.lineno) == (HERE, floating)
    assert mesh.category is PincalWarning and base.category is PincalWarning


def _load_through_user_code(path):
    return pincal.load_robot(path)  # the frame nearest to pincal is named


def test_the_nearest_user_frame_is_named(tmp_path):
    path = tmp_path / "tree.urdf"
    path.write_text(tree_urdf(mesh="package://nowhere/meshes/l1.stl"))
    (w,) = _caught(lambda: _load_through_user_code(path))
    assert w.filename == HERE and w.lineno == _load_through_user_code.__code__.co_firstlineno + 1


def test_warn_skips_every_pincal_frame():
    """Three nested functions compiled as if they were pincal modules: the warning names this
    test's line, not theirs."""
    fake = str(Path(pincal.__file__).parent / "model" / "_fake_module.py")
    code = "def inner():\n    warn('deep')\ndef middle():\n    inner()\ndef outer():\n    middle()\n"
    namespace = {"warn": warn}
    exec(compile(code, fake, "exec"), namespace)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        line = _next_line()
        namespace["outer"]()
    (w,) = caught
    assert (w.filename, w.lineno, str(w.message)) == (HERE, line, "deep")


def test_design_and_scene_warnings_name_the_callers_line(tmp_path):
    path = tmp_path / "tree.urdf"
    path.write_text(tree_urdf())
    robot = pincal.load_robot(path, markers=[(0.05, 0.02, 0.03)])
    params = robot.parameters("full,offsets").identifiable().identifiable
    # The planar arm's test pose at q2 = 0 is a singular limit (closed form): whatever plan the
    # search ends on, the floor binds and design warns.
    lengths = pincal.load_robot("planar_2r").parameters("joint2.tx,tip.tx")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        line = _next_line()
        pincal.design(
            lengths,
            2,
            test_pose=[0.2, 0.0],
            search=pincal.Search(starts=2, seed=1),
            safety=pincal.Safety(min_conditioning=1e-4),
        )
    degenerate = [w for w in caught if issubclass(w.category, pincal.errors.DegenerateOptimumWarning)]
    assert degenerate and all((w.filename, w.lineno) == (HERE, line) for w in degenerate)
    few = robot.random_configurations(2, 0)  # too few configurations: no ellipsoid
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        line = _next_line()
        visualize.scene(params, few, few[0], sigma=3e-5)
    (w,) = [w for w in caught if "no error ellipsoid" in str(w.message)]
    assert (w.filename, w.lineno) == (HERE, line)
