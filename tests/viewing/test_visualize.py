"""meshcat scenes (pincal.visualize), their static HTML export and ``pincal show``."""

from __future__ import annotations

import importlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import types
import urllib.request
import warnings

import meshcat  # noqa: E402  (a required dependency: a broken install fails, it does not skip)
import numpy as np
import pytest
import umsgpack

import pincal
from pincal.cli import main
from pincal.viewing.static_page import StaticWindow  # noqa: E402
from tests.support.meshcat_nodes import matrix, node, unpack

visualize = importlib.import_module("pincal.viewing.scene")  # the module (pincal.viewing.scene: the function)

KR_Q0 = np.radians([0, -60, 60, 0, 45, 0])
SIGMA = 3e-5


@pytest.fixture(scope="module")
def kr_scene(kr270_marker):
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    plan = kr270_marker.random_configurations(12, 7)
    built = visualize.scene(params, plan, KR_Q0, sigma=SIGMA, instrument_at=(2.0, -1.5, 0.5))
    return params, plan, built


def materials(node_):
    """Materials of every mesh under a node."""
    out = []
    if node_.object is not None:
        out += unpack(node_.object)["object"]["materials"]
    for child in node_.values():
        out += materials(child)
    return out


def geometries(node_):
    out = []
    if node_.object is not None:
        out += unpack(node_.object)["object"]["geometries"]
    for child in node_.values():
        out += geometries(child)
    return out


# ------------------------------------------------------------------------------- the scene
def test_one_ghost_per_configuration_in_its_own_colour(kr_scene, kr270_marker):
    params, plan, built = kr_scene
    ghosts = node(built, "ghosts")
    assert sorted(ghosts) == [f"pose_{i:02d}" for i in range(1, 13)]
    assert len(set(built.colors)) == 12 and visualize.TEST_POSE_COLOR not in built.colors
    points = kr270_marker.points(plan)
    for i, color in enumerate(built.colors):
        ghost = ghosts[f"pose_{i + 1:02d}"]
        mats = materials(ghost["robot"])
        assert mats, "the ghost has geometry"
        assert {m["color"] for m in mats} == {int(color[1:], 16)}
        assert all(m["transparent"] and m["opacity"] == visualize.GHOST_OPACITY for m in mats)
        # The measured point of the configuration, as a sphere where the robot puts it.
        assert np.allclose(matrix(ghost["marker_0"])[:3, 3], points[i, 0])
        assert unpack(ghost["marker_0"].object)["object"]["geometries"][0]["type"] == "SphereGeometry"
        label = unpack(ghost["label"].object)["object"]
        assert label["object"]["type"] == "Sprite" and label["textures"][0]["text"] == str(i + 1)


def test_kinematic_only_robot_is_drawn_as_cylinders(kr_scene, kr270_marker):
    _, _, built = kr_scene
    for robot_node in (node(built, "ghosts/pose_01/robot"), node(built, "test_poses/test_1/robot")):
        kinds = [g["type"] for g in geometries(robot_node)]
        # One cylinder per link, one per joint axis, the tip and the marker arm: never invisible.
        assert kinds.count("CylinderGeometry") >= 2 * kr270_marker.nq
    opaque = materials(node(built, "test_poses/test_1/robot"))
    assert {m["color"] for m in opaque} == {int(visualize.TEST_POSE_COLOR[1:], 16)}
    assert all(m["opacity"] == 1.0 and not m["transparent"] for m in opaque)


def test_ellipsoid_is_the_3_sigma_ellipsoid_of_the_predicted_covariance(kr_scene, kr270_marker):
    params, plan, built = kr_scene
    cov = pincal.evaluation.position_covariance(params, plan, KR_Q0, sigma=SIGMA)[0]
    w, v = np.linalg.eigh(cov)
    radii = 3.0 * np.sqrt(w[::-1])
    assert np.allclose(built.ellipsoid_radii[0, 0], radii, rtol=1e-10)
    assert built.rho0[0] == pytest.approx(pincal.rho0(params, plan, KR_Q0, sigma=SIGMA), rel=1e-10)
    # The drawn ellipsoid: semi-axes radii × the stated factor, centred on the test point, and its
    # shape matrix R diag(r)² Rᵀ equals (3 · factor)² · covariance.
    scale = built.ellipsoid_scale
    assert scale > 1 and scale / 10 ** np.floor(np.log10(scale)) in (1.0, 2.0, 5.0)
    reach = visualize.robot_reach(kr270_marker)
    assert 0.5 * visualize.ELLIPSOID_SIZE * reach < radii[0] * scale <= visualize.ELLIPSOID_SIZE * reach
    ellipsoid = node(built, "test_poses/test_1/ellipsoid_0")
    intrinsic = np.array(unpack(ellipsoid.object)["object"]["object"]["matrix"]).reshape(4, 4)
    assert np.allclose(np.diag(intrinsic)[:3], radii * scale, rtol=1e-10)
    T = matrix(ellipsoid)
    assert np.allclose(T[:3, 3], kr270_marker.points(KR_Q0)[0, 0])
    shape = T[:3, :3] @ np.diag((radii * scale) ** 2) @ T[:3, :3].T
    assert np.allclose(shape, (3 * scale) ** 2 * cov, rtol=1e-8, atol=1e-12 * scale**2)
    label = unpack(node(built, "test_poses/test_1/label").object)["object"]["textures"][0]["text"]
    assert f"×{scale:g}" in label


def test_explicit_scale_and_instrument(kr_scene, kr270_marker):
    params, plan, built = kr_scene
    again = visualize.scene(params, plan, KR_Q0, sigma=SIGMA, scale=250.0)
    assert again.ellipsoid_scale == 250.0
    assert np.allclose(again.ellipsoid_radii, built.ellipsoid_radii)
    box = node(built, "instrument/body")
    assert np.allclose(matrix(box)[:3, 3], [2.0, -1.5, 0.5])
    assert len(node(built, "instrument/sight_lines")) == len(plan)
    with pytest.raises(pincal.errors.BadConfiguration, match="instrument_at"):
        visualize.scene(params, plan, KR_Q0, instrument_at=(1.0, 2.0))


def test_the_instrument_position_is_instrument_at_and_the_0_1_form_keeps_working(kr_scene):
    """``instrument=`` is an Instrument across pincal: where it stands is ``instrument_at=``;
    pincal 0.1's position (or Visibility) as ``instrument=``, by keyword or by position, draws the
    same scene with a DeprecationWarning at the caller's line."""
    params, plan, built = kr_scene
    with pytest.warns(
        DeprecationWarning, match=r"scene\(\): instrument= as a position is renamed instrument_at="
    ) as w:
        old = visualize.scene(params, plan, KR_Q0, sigma=SIGMA, instrument=(2.0, -1.5, 0.5))
    assert w[0].filename == __file__ and "pincal 0.3" in str(w[0].message)
    assert np.array_equal(old.ellipsoid_radii, built.ellipsoid_radii)
    assert np.allclose(matrix(node(old, "instrument/body"))[:3, 3], [2.0, -1.5, 0.5])
    visible = pincal.planning.constraints.Visibility(tracker=(1.0, 2.0, 0.5))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        by_position = visualize.scene(params, plan, KR_Q0, SIGMA, visible)
    assert {str(c.message).split(":")[0] for c in caught} == {"scene()"}  # by position, and the rename
    assert np.allclose(matrix(node(by_position, "instrument/body"))[:3, 3], [1.0, 2.0, 0.5])
    with pytest.raises(TypeError, match="give instrument_at= only"):
        visualize.scene(params, plan, KR_Q0, instrument=(1.0, 2.0, 3.0), instrument_at=(1.0, 2.0, 3.0))


def test_an_instrument_sets_the_ellipsoids_and_a_tracker_where_it_is_drawn(kr_scene):
    """``instrument=`` an Instrument: its rows and reference σ make the ellipsoids (points with
    one σ: bit for bit the ``sigma=`` scene), a tracker is drawn where it stands, and ``sigma=``
    beside it is refused."""
    from pincal.instruments import Instrument, PerCoordinate, Point, Pose, Tracker

    params, plan, built = kr_scene
    same = visualize.scene(params, plan, KR_Q0, instrument=Instrument(Point(), PerCoordinate(SIGMA)))
    assert same.covariance.tobytes() == built.covariance.tobytes() and same.sigma == SIGMA
    tracker = Instrument(Pose(), Tracker(at=(3.0, 1.0, 0.5)))
    error_cloud = kr_scene[1][:5]
    seen = visualize.scene(params, plan, KR_Q0, instrument=tracker, error_samples=error_cloud)
    assert seen.instrument is tracker and seen.sigma == tracker.reference
    assert np.allclose(matrix(node(seen, "instrument/body"))[:3, 3], [3.0, 1.0, 0.5])
    expected = pincal.evaluation.TestPoseCriterion(params, KR_Q0, aggregate="each", instrument=tracker)(plan)
    assert seen.rho0 == pytest.approx(expected, rel=1e-9)
    assert not np.allclose(seen.rho0, built.rho0, rtol=0.05)  # not σ per coordinate
    predicted = pincal.evaluation.PredictedError(params, plan, instrument=tracker)(error_cloud)
    assert seen.error_values == pytest.approx(predicted, rel=1e-12)
    moved = visualize.scene(params, plan, KR_Q0, instrument=tracker, instrument_at=(0.0, 2.0, 1.0))
    assert np.allclose(matrix(node(moved, "instrument/body"))[:3, 3], [0.0, 2.0, 1.0])
    with pytest.raises(pincal.errors.BadArgument, match="not both"):
        visualize.scene(params, plan, KR_Q0, sigma=SIGMA, instrument=tracker)
    with pytest.raises(pincal.errors.BadArgument, match=r"instrument= takes"):
        visualize.scene(params, plan, KR_Q0, instrument=Tracker())


def test_singular_plan_still_shows_the_poses(kr270_marker):
    params = kr270_marker.parameters("full,offsets").identifiable().identifiable
    plan = kr270_marker.random_configurations(3, 0)
    with pytest.warns(UserWarning, match="at least"):
        built = visualize.scene(params, plan, KR_Q0)
    assert built.covariance is None and built.ellipsoid_radii is None and "singular" in built.note
    assert len(node(built, "ghosts")) == 3 and "test_1" in node(built, "test_poses")


def test_robot_with_meshes_shows_them():
    ur10 = pincal.load_robot("ur10")
    params = ur10.parameters("lengths,offsets").identifiable().identifiable
    plan = ur10.random_configurations(6, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no mesh is skipped
        built = visualize.scene(params, plan, ur10.random_configurations(1, 4)[0], sigma=SIGMA)
    visual = node(built, "test_poses/test_1/robot/visuals")
    assert len(visual) == 7  # the seven links of the URDF, each a mesh
    for name in visual:
        (geometry,) = geometries(visual[name])
        assert geometry["type"] == "BufferGeometry"  # the triangles of the URDF's mesh file
    # The ghosts: the URDF's collision geometry (seven STL files and a box), far lighter.
    ghost = sorted(g["type"] for g in geometries(node(built, "ghosts/pose_01/robot")))
    assert ghost == ["BoxGeometry"] + ["_meshfile"] * 7


def test_show_takes_a_robot_and_a_viewer(planar):
    vis = visualize.static_viewer()
    plan = [[0.1, 1.0], [0.5, -1.0], [1.0, 2.0], [1.5, -0.3], [-0.5, 2.5]]
    out = visualize.show(planar, plan, test_pose=[0.3, 1.2], viewer=vis)
    assert out is vis
    assert len(vis.window.node("/meshcat/pincal/ghosts")) == 5
    with pytest.raises(pincal.errors.BadConfiguration, match="outside its limits"):
        visualize.show(planar, [[0.1, 9.0]], viewer=vis)


def test_core_never_imports_meshcat_or_matplotlib():
    code = (
        "import sys, pincal, pincal.viewing.scene, pincal.viewing.plots, pincal.cli\n"
        "bad = [m for m in ('meshcat', 'matplotlib') if m in sys.modules]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_missing_meshcat_gives_an_actionable_error(monkeypatch, planar):
    monkeypatch.setitem(sys.modules, "meshcat", None)
    with pytest.raises(pincal.PincalError, match="pip install"):
        visualize.scene(planar, [[0.1, 1.0]])


# ------------------------------------------------------------------------- static export
def test_static_window_renders_what_meshcat_server_renders(planar):
    """The same commands through meshcat's own server code and through StaticWindow give the
    same page."""
    from meshcat.servers.tree import SceneTree
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    frames = []

    class Tee(StaticWindow):
        def send(self, command):
            data = command.lower()
            frames.append([data["type"].encode(), data["path"].encode(), umsgpack.packb(data)])
            self.apply(data["type"], data["path"], frames[-1][2])

    vis = meshcat.Visualizer(window=Tee())
    plan = [[0.1, 1.0], [0.5, -1.0], [1.0, 2.0]]
    visualize.show(planar.parameters("lengths"), plan, test_pose=[0.3, 1.2], viewer=vis)
    vis["pincal/ghosts/pose_02"].delete()  # deletions are replayed too
    replies = []
    server = types.SimpleNamespace(
        tree=SceneTree(),
        zmq_socket=types.SimpleNamespace(send=replies.append),
        forward_to_websockets=lambda frames: None,
    )
    for f in frames + [[b"get_scene"]]:
        ZMQWebSocketBridge.handle_zmq(server, f)
    assert replies[-1].decode() == vis.static_html()
    assert "pose_02" not in server.tree["meshcat"]["pincal"]["ghosts"]


def test_html_is_self_contained(kr_scene, tmp_path):
    _, _, built = kr_scene
    path = built.save_html(tmp_path / "scene.html")
    html = path.read_text()
    assert html.lstrip().startswith("<!DOCTYPE html>")
    assert "new MeshCat.Viewer" in html and len(html) > 500_000  # the viewer's code is inlined
    assert not re.search(r"<script[^>]*\bsrc=", html), "no external script"
    assert not re.search(r"<link[^>]*\bhref=", html), "no external stylesheet"
    commands = re.findall(r'fetch\("([^"]{0,30})', html)
    assert commands and all(c.startswith("data:") for c in commands), "every command is inline data"
    assert not list(tmp_path.glob(".*.tmp")), "written atomically"


def _chromium() -> str | None:
    for name in (os.environ.get("PINCAL_CHROMIUM"), "chromium", "chromium-browser", "google-chrome"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def test_exported_html_renders_in_headless_chromium(tmp_path, planar):
    browser = _chromium()
    if browser is None:
        pytest.skip("chromium not found (apt-get install chromium, or set PINCAL_CHROMIUM)")
    Image = pytest.importorskip("PIL.Image")
    plan = [[0.1, 1.0], [0.5, -1.0], [1.0, 2.0], [-1.5, 0.7]]
    built = visualize.scene(planar.parameters("lengths"), plan, [0.3, 1.2], instrument_at=(1.0, -1.0, 0.5))
    assert built.ellipsoid_radii is not None
    html = built.save_html(tmp_path / "s.html")
    png = tmp_path / "s.png"
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run(
            [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={profile}", f"--screenshot={png}", "--window-size=800,600",
             "--virtual-time-budget=5000", html.as_uri()],
            capture_output=True, timeout=180, check=False,
        )  # fmt: skip
    assert png.is_file(), "chromium wrote no screenshot"
    pixels = np.asarray(Image.open(png).convert("RGB")).astype(int)[40:]  # below meshcat's menu bar
    assert np.allclose(pixels[-1, 0], [199, 204, 214], atol=25), "pincal's light background"
    dark = (pixels.max(axis=2) < 110).sum()  # the opaque dark robot at the test pose
    coloured = (np.ptp(pixels, axis=2) > 60).sum()  # ghosts, points, ellipsoid
    assert dark > 300 and coloured > 1000, (dark, coloured)
    assert len(np.unique(pixels // 16 @ [256, 16, 1])) > 100


# ------------------------------------------------------------------------------- the CLI
@pytest.fixture
def planar_plan(tmp_path):
    path = tmp_path / "planar.csv"
    path.write_text("joint1,joint2\n0.1,1.0\n0.5,-1.0\n1.0,2.0\n")
    return path


def test_cli_show_writes_html_and_plot(capsys, tmp_path, planar_plan):
    html, png = tmp_path / "scene.html", tmp_path / "rho0.png"
    argv = ["show", "planar_2r", "--plan", str(planar_plan), "--test-pose=-0.3,1.2", "--params",
            "joint2.tx,tip.tx", "--sigma", "1e-4", "--html", str(html), "--plot", str(png),
            "--baseline", "50", "--instrument-at", "-1,-1,0.5", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    robot = pincal.load_robot("planar_2r", tip="tip")
    params = robot.parameters("joint2.tx,tip.tx")
    plan = pincal.Plan.from_csv(planar_plan, robot=robot)
    assert out["rho0"][0] == pytest.approx(pincal.rho0(params, plan, [-0.3, 1.2], sigma=1e-4), rel=1e-10)
    assert out["html"] == str(html) and html.read_text().lstrip().startswith("<!DOCTYPE html>")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out["random_rho0"]["n"] == 50 and out["random_rho0"]["min"] > 0
    assert out["url"] is None


def test_cli_show_instrument_is_instrument_at_until_0_3(capsys, tmp_path, planar_plan):
    """``show --instrument X,Y,Z`` (pincal 0.1's name of --instrument-at) draws the same scene, with
    a warning naming the new option."""
    argv = ["show", "planar_2r", "--plan", str(planar_plan), "--test-pose=0.3,1.2", "--params", "lengths",
            "--html", str(tmp_path / "s.html"), "--json"]  # fmt: skip
    assert main(argv + ["--instrument-at", "1,-1,0.5"]) == 0
    new = capsys.readouterr()
    assert main(argv + ["--instrument", "1,-1,0.5"]) == 0
    old = capsys.readouterr()
    assert old.out == new.out and new.err == ""
    assert old.err.startswith("pincal: warning: show --instrument X,Y,Z is deprecated: write --instrument-at")


def test_cli_show_takes_the_tracker_from_the_constraints(capsys, tmp_path, planar_plan, monkeypatch):
    cell = tmp_path / "cell.yaml"
    cell.write_text("visibility:\n  tracker: [1.5, -0.5, 0.3]\n  max_range: 4.0\n")
    seen = {}

    def spy(*args, **kwargs):
        built = original(*args, **kwargs)
        seen["box"] = matrix(built.viewer.window.node("/meshcat/pincal/instrument/body"))[:3, 3]
        return built

    original = visualize.scene
    monkeypatch.setattr(visualize, "scene", spy)
    argv = ["show", "planar_2r", "--plan", str(planar_plan), "--test-pose=0.3,1.2", "--params", "lengths",
            "--constraints", str(cell), "--html", str(tmp_path / "s.html"), "--json"]  # fmt: skip
    assert main(argv) == 0
    assert np.allclose(seen["box"], [1.5, -0.5, 0.3])


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--plot", "x.png"], "--test-pose"),
        (["--html", "x.html", "--instrument-at", "1,2"], "X,Y,Z"),
        (["--html", "x.html", "--instrument", "1,2,3", "--instrument-at", "1,2,3"], "--instrument-at only"),
        (["--html", "x.html", "--test-pose=0,9"], "outside its limits"),
        (["--html", "x.html", "--scale", "-1"], "--scale"),
    ],
)
def test_cli_show_bad_input(capsys, tmp_path, planar_plan, extra, message, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["show", "planar_2r", "--plan", str(planar_plan)] + extra)
    except SystemExit as exc:  # a value refused where argparse reads it
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("pincal: error:") and message in err and err.count("\n") == 1


def test_cli_show_serves_until_ctrl_c(planar_plan):
    """Without --html, a meshcat server on localhost serves the scene until SIGINT."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "pincal", "show", "planar_2r", "--plan", str(planar_plan),
         "--test-pose=0.3,1.2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        url = None
        for line in proc.stdout:
            if line.startswith("meshcat scene at "):
                url = line.split()[3]
                break
        assert url and url.startswith("http://127.0.0.1:"), url
        with urllib.request.urlopen(url, timeout=60) as page:
            assert page.status == 200 and b"MeshCat" in page.read()
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=120)
        assert proc.returncode == 0 and "stopped" in out
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
