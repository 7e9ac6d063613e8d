"""The inputs of the every-command fuzzer (tests/support/fuzz_every.py): valid seed files written by pincal
itself on a small 3-D robot (rail_arm: a plan, measurements of every kind, a calibration and its
sidecar, a camera rig, a workcell and its mesh, a program, ISO 9283 cycles, a DH table, the robot
as MJCF and with a collision mesh), and the ways each is broken: a number replaced by an edge value,
a column dropped or renamed, a JSON field made null, the wrong type, nested or a boolean, a mesh
made flat, zero-scale, missing or huge, the file missing, empty, a folder, of another kind or huge.

Everything here draws from a ``random.Random``: a seed gives the same cases on every machine.
"""

from __future__ import annotations

import contextlib
import io
import json
import random
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pincal.cli import main

ROOT = Path(__file__).resolve().parents[2]
ROBOT = "rail_arm"
TEST_POSE = "--test-pose=0.5,0.3,0.2,-0.4"
JOINTS = ("rail", "waist", "shoulder", "elbow")

# Numbers at the edges: zero, negative, subnormal, the largest doubles, non-finite, malformed.
EDGE_NUMBERS = (
    "0", "-0", "-1", "1", "0.5", "-0.5", "2", "1e-320", "-1e-320", "5e-324", "1e308", "-1e308",
    "1.7976931348623157e308", "1e309", "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e7", "3.15",
    "180", "-720", "1e-12", "", " ", "abc", "1e", "0x10", "1_0", "١", "9" * 400, "true",
)  # fmt: skip
STRINGS = ("", "a,b", "é", "∞", "x" * 300, "-1", "nan", " ", "a b", "joint1", "tool0", "rail", ",,", "\u2028")
UNITS = ("", "mm", "m", "cm", "um", "µm", "deg", "rad", "mrad", "kg", "s", "x")


def number(rng: random.Random) -> str:
    if rng.random() < 0.6:
        return rng.choice(EDGE_NUMBERS)
    return f"{rng.uniform(-3, 3):.4g}"


# ----------------------------------------------------------------------------------- the seeds
@dataclass(frozen=True)
class Seeds:
    """The valid files, by kind: {kind: (file name, bytes)} (a kind may bring files it names)."""

    files: dict[str, dict[str, bytes]]


def _pincal(folder: Path, *argv: str) -> None:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(folder), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    if code != 0:
        raise RuntimeError(f"seed 'pincal {' '.join(argv)}' failed: {err.getvalue()}")


def cube_stl(size: float = 0.1, facets: int = 1) -> str:
    """A closed cube of side ``size`` (``facets`` copies of its 12 triangles: a huge mesh)."""
    v = [(x, y, z) for x in (0, size) for y in (0, size) for z in (0, size)]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip
    one = "".join(
        "facet normal 0 0 0\n outer loop\n"
        + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in (v[i] for i in f))
        + " endloop\nendfacet\n"
        for f in faces
    )
    return f"solid cube\n{one * facets}endsolid cube\n"


FLAT_STL = cube_stl().replace(" 0.1\n", " 0\n")  # every z = 0: a mesh spanning no volume


def _mesh_robot(urdf: str) -> str:
    collision = (
        '<link name="forearm"><collision><origin xyz="0.2 0 0"/><geometry><mesh filename="part.stl" '
        'scale="1 1 1"/></geometry></collision></link>'
    )
    return urdf.replace('<link name="forearm"/>', collision)


def build_seeds(folder: Path) -> Seeds:
    """Write the seeds with pincal in ``folder`` (a few seconds) and return them."""
    urdf = (ROOT / "robots" / "rail_arm.urdf").read_text()
    (folder / "robot.urdf").write_text(urdf)
    run = lambda *a: _pincal(folder, *a)  # noqa: E731
    run("design", "robot.urdf", "-m", "16", TEST_POSE, "--starts", "2", "--workers", "1", "--no-progress",
        "--out", "plan.csv")  # fmt: skip
    sim = ("measure-sim", "robot.urdf", "--plan", "plan.csv", "--error-std", "1e-3,1e-3")
    run(*sim, "--out", "point.csv")
    run(*sim, "--measure", "pose", "--out", "pose.csv")
    run(*sim, "--measure", "x,y,rz", "--out", "partial.csv")
    run(*sim, "--measure", "distance", "--anchor", "1,1,0", "--out", "distance.csv")
    run("example", "rig", "--out", "rig.yaml")
    run(*sim, "--camera", "rig.yaml", "--out", "image.csv")
    run(*sim, "--instrument", "tracker", "--instrument-at", "2,0,1", "--out", "tracker.csv")
    run("identify", "robot.urdf", "--data", "point.csv", "--out", "cal.urdf")
    run("export", "cal.urdf", "--format", "mjcf", "--out", "robot_mjcf.xml")
    for name in ("cell", "fixture", "cycles", "table"):
        run("example", name, "--out", {"cell": "cell.yaml", "fixture": "fixture.stl"}.get(name, f"{name}.x"))
    plan = (folder / "plan.csv").read_text().splitlines()
    read = lambda name: (folder / name).read_bytes()  # noqa: E731
    files: dict[str, dict[str, bytes]] = {
        "plan": {"plan.csv": read("plan.csv")},
        "pool": {"pool.csv": read("plan.csv")},
        "path": {"path.csv": ("\n".join(plan[:5]) + "\n").encode()},
        "program": {"program.csv": ("\n".join(plan[:4]) + "\n").encode()},
        "rig": {"rig.yaml": read("rig.yaml")},
        "constraints": {"cell.yaml": read("cell.yaml"), "fixture.stl": read("fixture.stl")},
        "cycles": {"cycles.csv": read("cycles.x")},
        "dh": {"table.yaml": read("table.x")},
        "calibration": {"cal.urdf": read("cal.urdf"), "cal.calibration.json": read("cal.calibration.json")},
        "urdf": {"robot.urdf": urdf.encode()},
        "mjcf": {"robot_mjcf.xml": read("robot_mjcf.xml")},
        "mesh": {"robot_mesh.urdf": _mesh_robot(urdf).encode(), "part.stl": cube_stl().encode()},
        "joint_states": {"states.yaml": b"joint_names: [rail, waist, shoulder, elbow]\n"},
    }
    for kind in MEASUREMENT_KINDS:
        files[f"meas_{kind}"] = {f"{kind}.csv": read(f"{kind}.csv")}
    return Seeds(files)


# The kinds of measurement, and the options a command reading or writing them takes.
MEASUREMENT_KINDS = {
    "point": [],
    "pose": ["--measure", "pose"],
    "partial": ["--measure", "x,y,rz"],
    "distance": ["--measure", "distance", "--anchor", "1,1,0"],
    "image": ["--camera", "{rig}"],
    "tracker": ["--instrument", "tracker", "--instrument-at", "2,0,1"],
}


# -------------------------------------------------------------------------------- mutations
NUMBER = re.compile(rb"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


def replace_number(rng: random.Random, data: bytes) -> bytes:
    spans = [m.span() for m in NUMBER.finditer(data)]
    if not spans:
        return data
    a, b = rng.choice(spans)
    return (
        data[:a]
        + rng.choice(("1e308", "-1e308", "nan", "inf", "0", "-1", "1e-320", "1e7")).encode()
        + data[b:]
    )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def csv_mutation(rng: random.Random, data: bytes) -> bytes:
    """A cell made an edge number or empty, a column dropped, renamed or duplicated, rows repeated."""
    lines = data.decode().rstrip("\n").split("\n")
    comments = [line for line in lines if line.startswith("#")]
    rows = [line.split(",") for line in lines if line and not line.startswith("#")]
    op = rng.choice(["cell", "cell", "drop", "rename", "duplicate", "rows", "truncate"])
    j = rng.randrange(len(rows[0]))
    if op == "cell" and len(rows) > 1:
        r = rng.randrange(1, len(rows))
        if j < len(rows[r]) and _is_number(rows[r][j]):
            rows[r][j] = rng.choice(("1e308", "-1e308", "nan", "inf", "", "1e-320", "abc", "0", "1e7"))
        elif j < len(rows[r]):  # a name (a pose label): 'nan' there is a name, not a number
            rows[r][j] = rng.choice(("", "1e308", "é", "x" * 300, "P1"))
    elif op == "drop":
        for row in rows:
            del row[j : j + 1]
    elif op == "rename":
        rows[0][j] = rng.choice(STRINGS + ("x", "z", "qw", "d", "u0", "sx", "cov_x_y", "payload_kg"))
    elif op == "duplicate":
        for row in rows:
            row.append(row[j] if j < len(row) else "")
    elif op == "rows":
        rows = rows[:1] + rows[1:] * rng.choice((2, 50))
    else:
        rows = rows[: rng.randrange(1, len(rows) + 1)]
    return ("\n".join(comments + [",".join(row) for row in rows]) + "\n").encode()


WRONG_JSON = (
    None,
    "x",
    "",
    [],
    {},
    True,
    False,
    1e308,
    -1.0,
    0,
    [[[[[]]]]],
    {"a": {"b": None}},
    [1, "a", None],
)


def json_mutation(rng: random.Random, data: bytes) -> bytes:
    """A field of the JSON tree made null, of the wrong type, a boolean, deeply nested, or removed."""
    tree = json.loads(data)
    paths: list[list] = []

    def walk(node: object, path: list) -> None:
        paths.append(path)
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, [*path, k])
        elif isinstance(node, list):
            for i, v in enumerate(node[:6]):
                walk(v, [*path, i])

    walk(tree, [])
    path = rng.choice(paths[1:] or paths)
    parent = tree
    for key in path[:-1]:
        parent = parent[key]
    how = rng.choice(["value", "value", "value", "remove", "deep", "nan"])
    if how == "remove" and isinstance(parent, dict):
        del parent[path[-1]]
    elif how == "deep" and path:
        parent[path[-1]] = "DEEP"
    elif path:
        parent[path[-1]] = rng.choice(WRONG_JSON) if how == "value" else float("nan")
    text = json.dumps(tree)
    if how == "deep":
        n = rng.choice((50, 1000, 100_000))
        text = text.replace('"DEEP"', "[" * n + "]" * n)
    return text.encode()


def yaml_mutation(rng: random.Random, data: bytes) -> bytes:
    """A number replaced, a value made a boolean, null, a list or a mapping, nesting, a tag."""
    op = rng.choice(["number", "number", "bool", "null", "deep", "tag", "key"])
    if op == "number":
        return replace_number(rng, data)
    if op == "deep":
        n = rng.choice((50, 5000))
        return b"deep: " + b"[" * n + b"]" * n + b"\n" + data
    if op == "tag":
        return b"!!python/object/apply:os.system ['true']\n"
    spans = [m.span() for m in NUMBER.finditer(data)]
    if not spans:
        return data
    a, b = rng.choice(spans)
    new = {"bool": rng.choice((b"true", b"false", b"yes")), "null": b"null", "key": b"{a: 1}"}[op]
    return data[:a] + new + data[b:]


def xml_mutation(rng: random.Random, data: bytes) -> bytes:
    """A number replaced, an element or attribute dropped, the document cut."""
    op = rng.choice(["number", "number", "drop", "cut", "attribute"])
    if op == "number":
        return replace_number(rng, data)
    if op == "cut":
        return data[: rng.randrange(len(data))]
    tags = [
        m.span()
        for m in re.finditer(rb"<(joint|origin|axis|limit|body|geom|inertial|parent|child)\b[^>]*/>", data)
    ]
    if op == "drop" and tags:
        a, b = rng.choice(tags)
        return data[:a] + data[b:]
    attrs = [m.span() for m in re.finditer(rb'\s\w+="[^"]*"', data)]
    if not attrs:
        return data
    a, b = rng.choice(attrs)
    return data[:a] + data[b:]


def mesh_variant(rng: random.Random) -> tuple[str, bytes | None, str]:
    """(how, the mesh file's bytes or None for missing, the scale the robot or cell gives it)."""
    how = rng.choice(["cube", "flat", "zero_scale", "missing", "huge", "junk", "empty", "negative_scale"])
    data = {
        "cube": cube_stl(),
        "flat": FLAT_STL,
        "zero_scale": cube_stl(),
        "negative_scale": cube_stl(),
        "huge": cube_stl(facets=4000),
        "junk": "solid x\nfacet normal nan\n",
        "empty": "",
    }.get(how)
    scale = {"zero_scale": "0", "negative_scale": "-1"}.get(how, rng.choice(("1", "1", "0.001", "1e308")))
    return how, None if data is None else data.encode(), scale


MUTATE: dict[str, Callable[[random.Random, bytes], bytes]] = {
    ".csv": csv_mutation,
    ".json": json_mutation,
    ".yaml": yaml_mutation,
    ".urdf": xml_mutation,
    ".xml": xml_mutation,
    ".stl": replace_number,
}
