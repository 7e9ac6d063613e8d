"""Shared fixtures: the robots (loaded once per session: they are immutable), the command line run
in-process, a seeded generator; and the marker logic."""

from __future__ import annotations

import os

# Small dense matrices everywhere: BLAS threads only contend (4x slower on a loaded 2-core box).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import json  # noqa: E402
import shutil  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import NamedTuple  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pincal  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OFF_AXIS = [(0.1, 0.05, 0.2)]  # the README's marker on the KR 270's flange
UR10_MARKER = [(0.03, -0.02, 0.1)]  # the UR10's, unless a module asks for another


@pytest.fixture(scope="session")
def planar():
    return pincal.load_robot(ROOT / "robots" / "planar_2r.urdf", tip="tip")


@pytest.fixture
def cell(tmp_path):
    """A folder with the planar robot's URDF (robot.urdf) and a plan of 3 configurations (plan.csv),
    as a user's cell would have them."""
    shutil.copy(ROOT / "robots" / "planar_2r.urdf", tmp_path / "robot.urdf")
    (tmp_path / "plan.csv").write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n")
    return tmp_path


@pytest.fixture(scope="session")
def kr270():
    """The KR 270 from robots/kr270.urdf, tip tool0, no marker: the flange's origin is measured."""
    return pincal.load_robot(ROOT / "robots" / "kr270.urdf", tip="tool0")


@pytest.fixture(scope="session")
def kr270_marker():
    """The shipped KR 270 with the README's off-axis marker (OFF_AXIS)."""
    return pincal.load_robot("kr270", tip="tool0", markers=OFF_AXIS)


_UR10S: dict[tuple, pincal.Robot] = {}


@pytest.fixture(scope="module")
def ur10(request):
    """The shipped UR10 with one marker (UR10_MARKER), loaded once per session for each variant.

    A module that needs another UR10 says so once, ``pytestmark = pytest.mark.ur10(markers=[...])``
    (``markers=None``: load_robot's default, the flange's origin), optionally with ``base=`` (an
    SE3: where the robot stands in the instrument's frame).
    """
    mark = request.node.get_closest_marker("ur10")
    options = {"markers": UR10_MARKER, "base": None} | (mark.kwargs if mark else {})
    base = options["base"]
    key = (repr(options["markers"]), None if base is None else base.homogeneous.tobytes())
    if key not in _UR10S:
        robot = pincal.load_robot("ur10", markers=options["markers"])
        _UR10S[key] = robot if base is None else robot.replace(base=base)
    return _UR10S[key]


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


class CliRun(NamedTuple):
    """What one command printed: ``code, out, err = cli.run(...)``."""

    code: int
    out: str
    err: str


class Cli:
    """The ``pincal`` command line, run in this process (``pincal.cli.main``), output captured."""

    def __init__(self, capsys: pytest.CaptureFixture[str]) -> None:
        self._capsys = capsys

    def run(self, *argv: object) -> CliRun:
        """Run ``pincal ARGV...`` (each argument through ``str``, so paths and numbers do).

        Usage errors, ``--help`` and ``--version`` leave argparse through ``SystemExit``: its code is
        the exit code.
        """
        from pincal.cli import main

        try:
            code = main([str(a) for a in argv])
        except SystemExit as exc:
            code = exc.code
        out, err = self._capsys.readouterr()
        return CliRun(code, out, err)

    def json(self, *argv: object) -> dict:
        """Run ``pincal ARGV... --json``; it must succeed; its JSON output, parsed."""
        code, out, err = self.run(*argv, "--json")
        assert code == 0, (code, err)
        return json.loads(out)

    def fails(self, *argv: object, match: str = "") -> str:
        """Run a command that must be refused: exit code 2 and exactly one line on stderr,
        ``pincal: error: ...`` containing ``match``, no traceback. Returns that line."""
        code, out, err = self.run(*argv)
        assert code == 2, (code, out, err)
        assert err.startswith("pincal: error: ") and err.count("\n") == 1 and err.endswith("\n"), err
        assert "Traceback" not in err, err
        assert match in err, err
        return err[:-1]


@pytest.fixture
def cli(capsys):
    """The command line, with ``.run(*argv) -> (code, out, err)``, ``.json(*argv)`` and
    ``.fails(*argv, match=...)``."""
    return Cli(capsys)


def pytest_configure(config):
    config.addinivalue_line("markers", "ur10(markers=..., base=...): which UR10 the ur10 fixture loads")


def pytest_collection_modifyitems(config, items):
    """The long fuzz profile runs only when asked for (pytest -m fuzz)."""
    if "fuzz" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="long fuzz profile: run with 'pytest -m fuzz'")
    for item in items:
        if item.get_closest_marker("fuzz"):
            item.add_marker(skip)


def pytest_addoption(parser):
    """The long fuzz profile's size and draw: pytest -m fuzz --fuzz-cases 2000 --fuzz-seed 7."""
    parser.addoption(
        "--fuzz-cases", type=int, default=2000, help="cases of the every-command fuzzer (-m fuzz)"
    )
    parser.addoption("--fuzz-seed", type=int, default=0, help="seed of the every-command fuzzer's cases")
