"""The CLI fuzz harness: hypothesis strategies for every file pincal reads and every argument value,
and the property every run of ``pincal.cli.main(argv)`` must have.

A case is a command's valid argument list (planar_2r, small and fast), its input files drawn valid
or mutated, and 0-3 argument mutations (a value replaced, an option removed or added, an output
pointed at an input, a folder, a FIFO, a missing folder, ...). The property (:func:`check_run`):

* exit code 0 or 2; on 2, stderr is exactly one ``pincal: error: ...`` line (warnings aside); no
  traceback, no leaked NumPy floating-point warning ("... encountered in ...");
* no NaN or infinity in stdout or in any written CSV/URDF/JSON;
* every input file byte-identical afterwards, the FIFO still a FIFO;
* no partial output: on exit code 2 no new file at all; never a temporary file left.

To fuzz a new file kind: add its valid-content strategy to ``FILE_KINDS`` and map its metavar in
``METAVAR_KINDS``. A new option needs nothing: options are found by introspecting the parser (its
type, choices and metavar choose the value strategy); add a line to ``GOOD_VALUES`` to steer it
towards values that pass, and to ``BASE_ARGV`` to fuzz a new command.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import re
import stat
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from hypothesis import strategies as st

from pincal.cli import build_parser, main
from pincal.model import shipped_dh_tables
from tests.conftest import ROOT

PLANAR_URDF = (ROOT / "robots" / "planar_2r.urdf").read_text()
DH_TABLE = shipped_dh_tables()["ur5_dh"].read_text()
JOINTS = ("joint1", "joint2")
LINKS = (1.0, 0.8)

# ------------------------------------------------------------------------------------ numbers
EDGE_NUMBERS = (
    "0", "-0", "1", "-1", "0.5", "2", "1e-300", "-1e-300", "5e-324", "1e300", "1.7976931348623157e308",
    "1e309", "-1e999", "1.0e+999", "nan", "NaN", "-nan", "inf", "-inf", "Infinity", "1e5", "3.15",
    "-3.15", "180", "-720", "1_0", "0x10", "", " ", "abc", "1e", "--1", "+1", "1,2", "١", "9" * 400,
    "1" * 5000, "0." + "0" * 400 + "1", "True", "null", "~",
)  # fmt: skip
HUGE_NUMBERS = ("1e308", "-1e308", "1.7976931348623157e308", "1e307", "1e100", "1e7", "-1e7", "1e6", "9e15")
number_text = st.one_of(
    st.sampled_from(EDGE_NUMBERS),
    st.sampled_from(HUGE_NUMBERS),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-4, 4).map(lambda v: f"{v:.6g}"),
    st.integers(-(10**30), 10**30).map(str),
)
joint_value = st.floats(-3.1, 3.1).map(lambda v: f"{v:.6g}")
int_text = st.one_of(
    st.integers(-3, 6).map(str),
    st.sampled_from(["0", "-1", str(2**63), str(10**30), "1e3", "abc", "", "2.5", "-" + "9" * 30]),
    # beyond the 10**7 a count may be (10**7 itself is valid: a run that long is no test)
    st.sampled_from([str(10**7 + 1), str(2**31), str(2**64), "9" * 400, "1e308"]),
)
# Names as users' files may hold them: long, with commas, quotes, '#', spaces, non-ASCII, empty.
ODD_NAMES = ("a,b", "#j", 'j"1', " j1", "j1 ", "é", "j" * 300, "x", "s", "1", "", "joint1,joint2", "a;b")


def comma_list(n: int) -> st.SearchStrategy[str]:
    """'v1,...,vk' with mostly n valid-ish numbers."""
    good = st.lists(st.floats(-2, 2).map(lambda v: f"{v:.4g}"), min_size=n, max_size=n)
    bad = st.lists(number_text, min_size=0, max_size=n + 2)
    return st.one_of(good, bad).map(",".join)


# -------------------------------------------------------------------------- valid file contents
def _csv(header: list[str], rows: list[list[str]]) -> str:
    return "\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n"


@st.composite
def plan_csv(draw, rows=(1, 8)) -> str:
    order = draw(st.permutations(JOINTS))
    m = draw(st.integers(*rows))
    return _csv(list(order), [[draw(joint_value) for _ in order] for _ in range(m)])


@st.composite
def test_path_csv(draw) -> str:
    """A test path as users give one (design/evaluate --test-path): a straight joint-space segment
    sampled at 1-60 points, in either column order."""
    order = draw(st.permutations(JOINTS))
    n = draw(st.integers(1, 60))
    start = [draw(st.floats(-3.1, 3.1)) for _ in order]
    end = [draw(st.floats(-3.1, 3.1)) for _ in order]
    rows = [[f"{a + (b - a) * k / max(1, n - 1):.6g}" for a, b in zip(start, end)] for k in range(n)]
    return _csv(list(order), rows)


@st.composite
def measurement_csv(draw) -> str:
    """Joint values and the planar tip point (exact, or with a little noise)."""
    m = draw(st.integers(1, 10))
    noise = draw(st.sampled_from([0.0, 1e-5, 1e-3]))
    rows = []
    for _ in range(m):
        q1, q2 = draw(st.floats(-3.1, 3.1)), draw(st.floats(-3.1, 3.1))
        x = LINKS[0] * math.cos(q1) + LINKS[1] * math.cos(q1 + q2)
        y = LINKS[0] * math.sin(q1) + LINKS[1] * math.sin(q1 + q2)
        e = [draw(st.floats(-noise, noise)) for _ in range(3)]
        rows.append([f"{q1:.9g}", f"{q2:.9g}", f"{x + e[0]:.9g}", f"{y + e[1]:.9g}", f"{e[2]:.9g}"])
    return _csv(["joint1", "joint2", "x", "y", "z"], rows)


yaml_scalar = st.one_of(
    st.floats(-5, 5), st.integers(-10, 10), st.booleans(), st.none(), st.text(max_size=5),
    st.sampled_from([1e308, -1e308, 1e7, True, False, "true", "yes", "5"]),
)  # fmt: skip
vec3 = st.one_of(st.lists(st.floats(-3, 3), min_size=3, max_size=3), st.lists(yaml_scalar, max_size=4))
CONSTRAINT_ENTRIES = {
    "joint_limits": st.fixed_dictionaries({"margin_deg": st.one_of(st.floats(0, 20), yaml_scalar)}),
    "workspace_box": st.fixed_dictionaries(
        {"lower": vec3.map(lambda v: v), "upper": st.lists(st.floats(1, 3), min_size=3, max_size=3)}
    ),
    "half_space": st.fixed_dictionaries({"normal": vec3, "offset": st.floats(-2, 2)}),
    "visibility": st.fixed_dictionaries(
        {"tracker": vec3, "max_range": st.one_of(st.floats(0, 10), yaml_scalar)},
        optional={"min_range": st.floats(0, 1), "normal": vec3, "max_angle_deg": st.floats(0, 180)},
    ),
    "self_collision": st.one_of(st.booleans(), st.fixed_dictionaries({"min_distance": st.floats(0, 0.1)})),
    "min_spacing": st.fixed_dictionaries({"distance_deg": st.one_of(st.floats(0, 30), yaml_scalar)}),
}


@st.composite
def constraints_yaml(draw) -> str:
    keys = draw(st.lists(st.sampled_from(sorted(CONSTRAINT_ENTRIES)), unique=True, max_size=3))
    return yaml.safe_dump({k: draw(CONSTRAINT_ENTRIES[k]) for k in keys}, default_flow_style=True)


@st.composite
def dh_table(draw) -> str:
    """A DH table for urdf-from-dh: 1-7 rows (some prismatic), either convention, m or mm, rad or
    deg, optional names, limits, velocity/effort, base, tool and markers; or the shipped UR5's."""
    if DH_TABLE is not None and draw(st.integers(0, 4)) == 0:
        return DH_TABLE
    mm, deg = draw(st.booleans()), draw(st.booleans())
    length, angle = (1000.0 if mm else 1.0), (180 / math.pi if deg else 1.0)
    lengths = st.floats(-1.5, 1.5).map(lambda v: round(v * length, 6))
    angles = st.one_of(st.sampled_from([0.0, 0.5 * math.pi, -0.5 * math.pi, math.pi]), st.floats(-3.1, 3.1))
    angles = angles.map(lambda v: round(v * angle, 6))
    rows = []
    for i in range(draw(st.integers(1, 7))):
        row: dict = {"a": draw(lengths), "alpha": draw(angles), "d": draw(lengths), "theta": draw(angles)}
        if draw(st.integers(0, 4)) == 0:
            row.update(type="prismatic", limits=[0.0, round(draw(st.floats(0.01, 1)) * length, 6)])
        elif draw(st.booleans()):
            lo = draw(st.floats(-3.1, 0))
            row["limits"] = [round(lo * angle, 6), round(draw(st.floats(lo + 0.01, 3.2)) * angle, 6)]
        if draw(st.booleans()):
            row["name"] = f"j{i + 1}"
        if draw(st.integers(0, 3)) == 0:
            row.update(velocity=draw(st.floats(0, 3)), effort=draw(st.floats(0, 100)))
        if draw(st.integers(0, 9)) == 0:  # a YAML bool or a huge value where a number belongs
            row[draw(st.sampled_from(["a", "alpha", "d", "theta"]))] = draw(
                st.sampled_from([True, False, 1e308, -1e308, 1e7])
            )
        rows.append(row)
    table: dict = {"name": "fuzz_arm", "convention": draw(st.sampled_from(["standard", "modified"]))}
    table["units"] = {"length": "mm" if mm else "m", "angle": "deg" if deg else "rad"}
    table["joints"] = rows
    if draw(st.booleans()):
        table["base"] = {"xyz": [draw(lengths) for _ in range(3)], "rpy": [draw(angles) for _ in range(3)]}
    if draw(st.booleans()):
        table["tool"] = {"name": "tool0", "xyz": [draw(lengths) for _ in range(3)], "rpy": [0, 0, 0]}
    if draw(st.booleans()):
        table["markers"] = [[draw(lengths) for _ in range(3)] for _ in range(draw(st.integers(1, 3)))]
    return yaml.safe_dump(table, default_flow_style=draw(st.booleans()), sort_keys=False)


XACRO_NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


@st.composite
def xacro_text(draw) -> str:
    """planar_2r as a xacro source (the same geometry): link lengths as properties, optionally the
    limits as ${pi} expressions and the links made by a macro."""
    text = PLANAR_URDF.replace(
        '<robot name="planar_2r">',
        f'<robot name="planar_2r" {XACRO_NS}>\n  <xacro:property name="l1" value="1.0"/>\n'
        '  <xacro:property name="l2" value="${l1 * 0.8}"/>',
    )
    text = text.replace('xyz="1.0 0 0"', 'xyz="${l1} 0 0"').replace('xyz="0.8 0 0"', 'xyz="${l2} 0 0"')
    if draw(st.booleans()):
        text = text.replace('lower="-3.141592653589793"', 'lower="${-pi}"')
        text = text.replace('upper="3.141592653589793"', 'upper="${pi}"')
    if draw(st.booleans()):
        macro = '<xacro:macro name="bare_link" params="name"><link name="${name}"/></xacro:macro>'
        text = text.replace(
            '  <link name="base_link"/>', "  " + macro + '\n  <xacro:bare_link name="base_link"/>'
        )
        text = text.replace('<link name="link1"/>', '<xacro:bare_link name="link1"/>')
    return text


@st.composite
def urdf_text(draw) -> str:
    text = PLANAR_URDF
    if draw(st.booleans()):  # a vendor-like variant: joint2 continuous
        old = 'type="revolute">\n    <parent link="link1"/>'
        text = text.replace(old, old.replace("revolute", "continuous"))
    return text


# Prior values (--prior LEN,ANG): a length and an angle with units, in either order, or malformed.
prior_valid = st.builds(
    lambda length, lu, ang, au, swap: ",".join(
        reversed((f"{length:g}{lu}", f"{ang:g}{au}")) if swap else (f"{length:g}{lu}", f"{ang:g}{au}")
    ),
    st.floats(1e-3, 10),
    st.sampled_from(["mm", "um", "µm", "cm", "m"]),
    st.floats(1e-3, 10),
    st.sampled_from(["mrad", "urad", "µrad", "deg", "rad"]),
    st.booleans(),
) | st.sampled_from(["1mm,1mrad", "1e-3,1e-3", "0.5deg,2mm", " 1 mm , 1 mrad "])
PRIOR_MALFORMED = (
    "", ",", "1mm", "1mm,1mm", "1mrad,1mrad", "1mm,1mrad,1mm", "mm,mrad", "1km,1mrad", "1mm;1mrad",
    "-1mm,1mrad", "0mm,1mrad", "1mm,0", "nanmm,1mrad", "infmm,1mrad", "inf,inf", "1e999mm,1mrad",
    "1e-300mm,1mrad", "1e300,1e300", "5e-324,1", "1mm,1e999deg", "1MM,1MRAD", "1 m m,1mrad", "1e,1",
    "..1mm,1mrad", "+-1mm,1mrad", "1mm,1mrad,", "١mm,1mrad", "1mm\n,1mrad", "1_0mm,1mrad",
)  # fmt: skip
prior_malformed = st.one_of(
    st.sampled_from(PRIOR_MALFORMED),
    st.tuples(number_text, st.sampled_from(["mm", "m", "deg", "x", ""]))
    .map("".join)
    .map(lambda t: t + ",1mrad"),
    comma_list(2),
    st.text(max_size=12),
)
# --around ANGLE[,LENGTH]: an angle and perhaps a length, with units, huge, negative or malformed.
around_value = st.one_of(
    st.sampled_from(["10deg", "0.17rad", "5mrad", "10", "10deg,2cm", "2cm,10deg", "10deg,1e308m", "1e308",
                     "1e308deg", "-10deg", "0", "10deg,10deg", "10kg", "10deg,", "nan", "inf", "1e-300"]),
    st.tuples(number_text, st.sampled_from(["deg", "rad", "mrad", "", "cm", "mm", "m", "x"])).map("".join),
)  # fmt: skip
# --test-box X0,Y0,Z0,X1,Y1,Z1: six numbers, some at the edge of float range.
test_box_value = st.one_of(
    st.just("0.5,-0.5,-0.5,1.5,0.5,0.5"),
    st.lists(st.one_of(st.floats(-2, 2).map(lambda v: f"{v:.3g}"), st.sampled_from(HUGE_NUMBERS)),
             min_size=6, max_size=6).map(",".join),
)  # fmt: skip
# --joint-range NAME=LO,HI: a joint (or not) and two numbers, huge ones too.
joint_range_value = st.builds(
    lambda name, lo, hi: f"{name}={lo},{hi}",
    st.sampled_from([*JOINTS, "joint1", "nope", *ODD_NAMES[:4]]),
    st.one_of(st.sampled_from(["-1", "-3.2", "-1e308", "-1e7", "0"]), number_text),
    st.one_of(st.sampled_from(["1", "3.2", "1e308", "1e7", "0"]), number_text),
)
# Robot names and paths: long, missing, odd.
robot_value = st.sampled_from(["a" * 300, "b" * 300 + ".urdf", "kr270", "planar_2r", "x" * 5000, "ur10,ur5"])
# Argument values drawn for a {placeholder} in BASE_ARGV: (valid values, malformed values).
VALUE_KINDS = {
    "prior": (prior_valid, prior_malformed),
    "around": (st.sampled_from(["10deg", "0.1rad", "5", "20deg"]), around_value),
}
# Values for options with a form of their own (drawn beside the generic ones).
OPTION_VALUES = {
    "--around": around_value,
    "--test-box": test_box_value,
    "--joint-range": joint_range_value,
    "--sigma": st.sampled_from(["1e308", "1e-20", "1e-12", "1000", "1001", "0", "-0", "3e-5", "5e-324"]),
    "--tip": st.sampled_from(["t" * 300, "a,b", ""]),
}


# ------------------------------------------------------------------------------- mutations
JUNK = (
    "\0", "\ufeff", "\r", '"', ",", "#", "\t", "\\", "é", "<", "&", "]]>", ":", "- ", "{", "[", "*a",
    "&a ", "!!python/object:os.system", "\u2028", ",,,,", "\n\n", "x" * 1500, "1" * 200_000,
)  # fmt: skip
NUMBER = re.compile(r"-?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?")


def _replace_number(draw, text: str) -> str:
    spans = [m.span() for m in NUMBER.finditer(text)]
    if not spans:
        return text
    a, b = spans[draw(st.integers(0, len(spans) - 1))]
    return text[:a] + draw(number_text) + text[b:]


def _lines(draw, text: str, op: str) -> str:
    lines = text.split("\n")
    i = draw(st.integers(0, max(0, len(lines) - 1)))
    if op == "delete":
        del lines[i]
    elif op == "duplicate":
        lines.insert(i, lines[i])
    else:
        j = draw(st.integers(0, max(0, len(lines) - 1)))
        lines[i], lines[j] = lines[j], lines[i]
    return "\n".join(lines)


def _insert(draw, text: str) -> str:
    i = draw(st.integers(0, len(text)))
    return text[:i] + draw(st.sampled_from(JUNK)) + text[i:]


def _csv_column(draw, text: str) -> str:
    """Drop, add, rename or duplicate a column of a CSV table."""
    rows = [r.split(",") for r in text.rstrip("\n").split("\n")]
    op = draw(st.sampled_from(["drop", "add", "rename", "duplicate"]))
    j = draw(st.integers(0, len(rows[0]) - 1))
    for k, r in enumerate(rows):
        if j >= len(r):
            continue
        if op == "drop":
            del r[j]
        elif op == "add":
            r.append("extra" if k == 0 else draw(number_text))
        elif op == "rename" and k == 0:
            r[j] = draw(st.sampled_from(["joint3", "", "x", "1.5", "joint1", " joint2 ", "JOINT1"]))
        elif op == "duplicate":
            r.append(r[j])
    return "\n".join(",".join(r) for r in rows) + "\n"


def _yaml_structure(draw, text: str) -> str:
    kind = draw(st.sampled_from(["deep", "alias", "wrong_type", "huge_number", "tag", "list"]))
    if kind == "deep":
        n = draw(st.sampled_from([40, 1000, 5000]))
        return "joint_limits: " + "[" * n + "]" * n + "\n" + text
    if kind == "alias":
        return "a: &x [1, 2]\nb: *x\n" + text
    if kind == "huge_number":
        return text + "\nextra: " + draw(st.sampled_from(["1.0e+999", "1" * 5000, "-.inf", ".nan"]))
    if kind == "tag":
        return "!!python/object/apply:os.system ['true']\n"
    if kind == "list":
        return "- " + text.replace("\n", "\n  ")
    try:
        data = yaml.safe_load(text)
    except (yaml.YAMLError, RecursionError, ValueError):
        return text
    if isinstance(data, dict) and data:
        key = draw(st.sampled_from(sorted(data, key=str)))
        data[key] = draw(st.one_of(yaml_scalar, st.lists(yaml_scalar, max_size=3), st.just({"bad": 1})))
    return yaml.safe_dump(data)


def _urdf_structure(draw, text: str) -> str:
    kinds = ["many_joints", "entity", "joint_type", "axis", "limits", "drop", "xml", "tree", "name", "huge"]
    kind = draw(st.sampled_from(kinds))
    if kind == "tree":  # joints that do not make one tree: a self loop, two parents, an undefined link
        how = draw(st.sampled_from(["self", "two_parents", "undefined", "stray", "loop"]))
        if how == "self":  # joint2's child made its parent: link2 and the tip cut off silently, before
            return text.replace('<child link="link2"/>', '<child link="link1"/>', 1)
        if how == "two_parents":
            return text.replace('<child link="tip"/>', '<child link="link2"/>', 1)
        if how == "undefined":
            return text.replace('<child link="link2"/>', '<child link="nowhere"/>', 1)
        if how == "stray":
            return text.replace("</robot>", '<link name="stray"/></robot>')
        return text.replace('<parent link="base_link"/>', '<parent link="link2"/>', 1)
    if kind == "name":  # a joint or link renamed (plan and data columns then no longer match)
        old = draw(st.sampled_from(['"joint1"', '"joint2"', '"tip"', '"link1"']))
        return text.replace(old, '"' + draw(st.sampled_from(ODD_NAMES)).replace('"', "&quot;") + '"')
    if kind == "huge":  # limits or origins at the edge of float range
        value = draw(st.sampled_from(["1e308", "-1e308", "1e7", "1e300", "1.7976931348623157e308"]))
        if draw(st.booleans()):
            return text.replace('upper="3.141592653589793"', f'upper="{value}"', 1)
        return text.replace('xyz="1.0 0 0"', f'xyz="{value} 0 0"', 1)
    if kind == "many_joints":
        n = draw(st.sampled_from([30, 2100]))
        links = "".join(f'<link name="extra{i}"/>' for i in range(n))
        joints = "".join(
            f'<joint name="j{i}" type="revolute"><parent link="{"tip" if i == 0 else f"extra{i - 1}"}"/>'
            f'<child link="extra{i}"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
            "</joint>"
            for i in range(n)
        )
        return text.replace("</robot>", links + joints + "</robot>")
    if kind == "entity":
        bomb = '<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>'
        return text.replace('<?xml version="1.0"?>', '<?xml version="1.0"?>' + bomb).replace(
            'name="planar_2r"', 'name="&b;"'
        )
    if kind == "joint_type":
        new = draw(st.sampled_from(["prismatic", "continuous", "floating", "planar", "fixed", "weird"]))
        return text.replace('type="revolute"', f'type="{new}"', 1)
    if kind == "axis":
        return text.replace('xyz="0 0 1"', f'xyz="{draw(comma_list(3)).replace(",", " ")}"', 1)
    if kind == "limits":
        return text.replace('lower="-3.141592653589793"', f'lower="{draw(number_text)}"', 1)
    if kind == "drop":
        tag = draw(st.sampled_from(["<parent", "<child", "<origin", "<axis", "<limit", '<link name="tip"']))
        return re.sub(re.escape(tag) + r"[^>]*/>", "", text, count=1)
    return text.replace("</robot>", "")


def _xacro_structure(draw, text: str) -> str:
    """A URDF mutation, or one of xacro's own: an undefined property, a failing expression, an
    include of a missing file or of another input, a macro that calls itself, a property that
    expands to some 20 MB, an expression that runs for hours (``${10**10**10}``) or asks for 10 GB,
    xacro tags in a plain namespace (the runaways are stopped by pincal.model.xacro_expansion's
    limits: test_fuzz sets the time limit to 5 s)."""
    kinds = ["urdf", "undefined", "expression", "include", "recursion", "growth", "runaway", "ns"]
    kind = draw(st.sampled_from(kinds))
    if kind == "urdf":
        return _urdf_structure(draw, text)
    if kind == "undefined":
        return text.replace("${l1}", "${nope}", 1)
    if kind == "expression":
        expr = draw(st.sampled_from(["1/0", "l1 +", "float('nan')", "__import__('os').getcwd()"]))
        return text.replace("${l1}", "${" + expr + "}", 1)
    if kind == "include":
        target = draw(st.sampled_from(["missing.xacro", "input_plan.csv", "/dev/null", ""]))
        return text.replace("</robot>", f'<xacro:include filename="{target}"/></robot>')
    if kind == "runaway":
        expr = draw(st.sampled_from(["10**10**10", "'x' * 10**10"]))
        return text.replace("${l1}", "${" + expr + "}", 1)
    if kind == "recursion":
        loop = '<xacro:macro name="loop"><xacro:loop/></xacro:macro><xacro:loop/>'
        return text.replace("</robot>", loop + "</robot>")
    if kind == "growth":
        chain = '<xacro:property name="g0" value="xx"/>' + "".join(
            f'<xacro:property name="g{i}" value="${{g{i - 1} * 10}}"/>' for i in range(1, 8)
        )
        return text.replace("</robot>", chain + '<link name="${g7}"/></robot>')
    return text.replace(XACRO_NS, 'xmlns:xacro="urn:not-xacro"')


GENERIC_MUTATIONS = (
    lambda draw, t: _replace_number(draw, t),
    lambda draw, t: _insert(draw, t),
    lambda draw, t: _lines(draw, t, "delete"),
    lambda draw, t: _lines(draw, t, "duplicate"),
    lambda draw, t: _lines(draw, t, "swap"),
    lambda draw, t: t[: draw(st.integers(0, len(t)))],
    lambda draw, t: t.replace("\n", "\r\n"),
    lambda draw, t: "",
)
STRUCTURAL = {"csv": _csv_column, "yaml": _yaml_structure, "urdf": _urdf_structure, "xacro": _xacro_structure}


@dataclass(frozen=True)
class FileKind:
    valid: st.SearchStrategy[str]
    syntax: str  # csv, yaml, urdf or xacro: which structural mutations apply
    suffix: str


FILE_KINDS = {
    "plan": FileKind(plan_csv(), "csv", ".csv"),
    "pool": FileKind(plan_csv(rows=(1, 30)), "csv", ".csv"),
    "data": FileKind(measurement_csv(), "csv", ".csv"),
    "constraints": FileKind(constraints_yaml(), "yaml", ".yaml"),
    "urdf": FileKind(urdf_text(), "urdf", ".urdf"),
    "dh": FileKind(dh_table(), "yaml", ".yaml"),
    "path": FileKind(test_path_csv(), "csv", ".csv"),
    "validate": FileKind(measurement_csv(), "csv", ".csv"),
    "xacro": FileKind(xacro_text(), "xacro", ".urdf.xacro"),
}
# Which file kind an option's metavar reads.
METAVAR_KINDS = {
    "PLAN.csv": "plan",
    "FILE.csv": "pool",
    "MEAS.csv": "data",
    "FILE.yaml": "constraints",
    "TRUE.urdf": "urdf",
    "ROBOT": "urdf",
    "TABLE.yaml": "dh",
    "PATH.csv": "path",
    "OTHER.csv": "validate",
}


@st.composite
def file_content(draw, kind: str) -> tuple[bytes, bool]:
    """(bytes, mutated?) for a file of ``kind``: valid half of the time, else 1-3 mutations."""
    spec = FILE_KINDS[kind]
    text = draw(spec.valid)
    if draw(st.integers(0, 1)) == 0:
        return text.encode(), False
    for _ in range(draw(st.integers(1, 3))):
        if draw(st.integers(0, 2)) == 0:
            text = STRUCTURAL[spec.syntax](draw, text)
        else:
            text = draw(st.sampled_from(GENERIC_MUTATIONS))(draw, text)
    data = text.encode("utf-8", "surrogatepass")
    if draw(st.integers(0, 15)) == 0:
        data = data + b"\xff\xfe bad utf-8"
    return data, True


# ------------------------------------------------------------------------------ argument lists
# Valid argument lists, small and fast on planar_2r. {kind} is an input file of that kind,
# {out.SUFFIX} an output path. Options in PINNED keep their place (removing them would start a
# server, a process pool or a long run) and get only harmless values.
BASE_ARGV = {
    "params": "params {urdf} --tip tip --seed 1",
    "evaluate": "evaluate {urdf} --tip tip --plan {plan} --test-pose=0.3,1.2 --params joint2.tx,tip.tx",
    "design": "design {urdf} --tip tip -m 3 --test-pose=0.3,1.2 --params joint2.tx,tip.tx --starts 2 "
    "--workers 1 --no-progress --pool-size 40 --constraints {constraints} --out {out.csv}",
    "design-pool": "design {urdf} --tip tip -m 3 --test-pose=0.3,1.2 --params joint2.tx,tip.tx "
    "--starts 2 --workers 1 --no-progress --pool {pool} --out {out.csv}",
    "baseline": "baseline {urdf} --tip tip -m 3 --test-pose=0.3,1.2 --params joint2.tx,tip.tx --random 20 "
    "--workers 1 --starts 2",
    "simulate": "simulate {urdf} --tip tip --plan {plan} --test-pose=0.3,1.2 --params joint2.tx,tip.tx "
    "--trials 5",
    "measure-sim": "measure-sim {urdf} --tip tip --plan {plan} --error-std 1e-3,1e-3 --sigma 1e-5 "
    "--params joint2.tx,tip.tx --out {out.csv}",
    "identify": "identify {urdf} --tip tip --data {data} --params joint2.tx,tip.tx --out {out.urdf}",
    "show": "show {urdf} --tip tip --plan {plan} --test-pose=0.3,1.2 --params joint2.tx,tip.tx "
    "--html {out.html}",
    "show-plot": "show {urdf} --tip tip --plan {plan} --test-pose=0.3,1.2 --params joint2.tx,tip.tx "
    "--plot {out.png} --baseline 10",
    "urdf-from-dh": "urdf-from-dh {dh} --out {out.urdf}",
    "design-path": "design {urdf} --tip tip -m 3 --test-path {path} --prior {prior} "
    "--params joint2.tx,tip.tx --starts 2 --workers 1 --no-progress --pool-size 40 --out {out.csv}",
    "identify-validate": "identify {urdf} --tip tip --data {data} --validate {validate} --prior {prior} "
    "--params joint2.tx,tip.tx --out {out.urdf}",
    "params-xacro": "params {xacro} --tip tip --seed 1",
    # two outputs each: a command that fails must leave neither (the second one unwritable, ...)
    "measure-sim-true": "measure-sim {urdf} --tip tip --plan {plan} --error-std 1e-3,1e-3 --sigma 1e-5 "
    "--params joint2.tx,tip.tx --out {out.csv} --save-true {out.urdf}",
    "evaluate-region": "evaluate {urdf} --tip tip --plan {plan} --test-pose=0.3,1.2 --around {around} "
    "--params joint2.tx,tip.tx --accuracy-plot {out.png}",
}
PINNED = {
    "--workers": st.sampled_from(["1", "0", "-1", "x", str(2**63)]),
    "--starts": st.sampled_from(["1", "2", "0", "-3", "x", str(10**30)]),
    "--trials": st.sampled_from(["1", "3", "0", "-1", str(10**30)]),
    "--random": st.sampled_from(["1", "5", "0", "-1", str(2**63)]),
    "--baseline": st.sampled_from(["1", "5", "0", "-1", str(2**63)]),
    "--pool-size": st.sampled_from(["1", "3", "40", "0", "-5", str(2**63)]),
    "--html": None,  # without --html or --plot, 'show' serves meshcat forever
    "--plot": None,
    "--no-progress": None,
}
# Values that pass, to steer a mutation towards deeper code.
GOOD_VALUES = {
    "--tip": ["tip", "link2", "link1", "base_link", "tool0", "nonexistent"],
    "--params": ["joint2.tx,tip.tx", "full,offsets", "offsets", "lengths", "base", "markers", "x", ""],
    "--criterion": ["test-pose", "test-pose-worst", "D", "A", "E", "cond", "nope"],
    "--method": ["exchange", "continuous", "nope"],
    "--error-std": ["1e-3,1e-3", "0,0", "1e-3", "-1,1", "nan,1"],
    "--test-pose": ["0.3,1.2", "-0.3,1.2", "0,0", "4,4", "180,90"],
    "-m": ["1", "2", "3", "4", "6"],
}
OUTPUT_SUFFIX = {"FILE.png": ".png", "FILE.html": ".html", "PLAN.csv": ".csv", "MEAS.csv": ".csv"}
OUTPUT_FLAGS = ("--out", "--html", "--plot", "--save-true", "--accuracy-plot")


@dataclass
class Case:
    """One generated run: its argv (placeholders still in), files and what was mutated."""

    command: str
    argv: list[str]
    files: dict[str, bytes] = field(default_factory=dict)  # placeholder kind -> content
    mutated: set[str] = field(default_factory=set)  # input kinds and 'args', 'output'


def _option_actions(command: str) -> dict:
    parser = build_parser().commands[command]
    return {a.option_strings[-1]: a for a in parser._actions if a.option_strings and a.dest != "help"}


@st.composite
def option_value(draw, option: str, action) -> list[str]:
    """The argument tokens for ``option`` (a flag: []), drawn from its type and metavar."""
    if action.nargs == 0:
        return []
    if option in PINNED and PINNED[option] is not None:
        return [draw(PINNED[option])]
    metavar = action.metavar or ""
    if option in OUTPUT_FLAGS:  # --save-true's metavar is TRUE.urdf, like the input --true
        return ["{out" + OUTPUT_SUFFIX.get(metavar, ".urdf") + "}"]
    if metavar in METAVAR_KINDS:
        return ["{" + METAVAR_KINDS[metavar] + "}"]
    if option[2:] in VALUE_KINDS:
        valid, malformed = VALUE_KINDS[option[2:]]
        return [draw(st.one_of(valid, malformed))]
    strategies = [st.text(max_size=12)]
    if option in GOOD_VALUES:
        strategies += [st.sampled_from(GOOD_VALUES[option])] * 3
    if option in OPTION_VALUES:
        strategies += [OPTION_VALUES[option]] * 2
    parses = getattr(action.type, "parses", action.type)  # pincal's checked types read int or float
    if parses is int:
        strategies.append(int_text)
    elif parses is float:
        strategies.append(number_text)
    if "," in metavar or metavar in ("Q0",):
        strategies.append(comma_list(metavar.count(",") + 1 if "," in metavar else 2))
    return [draw(st.one_of(strategies))]


def _spans(argv: list[str]) -> list[tuple[int, int]]:
    """(start, end) of each option with its value in argv (positional tokens excluded)."""
    out, i = [], 1
    while i < len(argv):
        tok = argv[i]
        if tok.startswith("-") and not re.fullmatch(r"-[\d.].*", tok):
            j = i + 1
            if "=" not in tok and j < len(argv) and not argv[j].startswith("--"):
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


@st.composite
def argv_mutation(draw, command: str, argv: list[str]) -> tuple[str, list[str]]:
    """(what was mutated: 'args' or 'output', the new argv)."""
    actions = _option_actions(command)
    op = draw(st.sampled_from(["replace", "replace", "remove", "add", "output", "positional"]))
    spans = [(a, b) for a, b in _spans(argv) if argv[a].split("=")[0] not in PINNED or op == "replace"]
    if op in ("replace", "remove") and spans:
        a, b = draw(st.sampled_from(spans))
        name = argv[a].split("=")[0]
        if op == "remove" or name not in actions:
            return "args", argv[:a] + argv[b:]
        return "args", argv[:a] + [name, *draw(option_value(name, actions[name]))] + argv[b:]
    if op == "output":
        outs = [i for i, t in enumerate(argv) if t.startswith("{out")]
        if outs:
            i = draw(st.sampled_from(outs))
            return "output", argv[:i] + [draw(SPECIAL_OUTPUTS)] + argv[i + 1 :]
    if op == "positional":
        robots = ["{urdf}", "{xacro}", "kr270", "planar_2r", "nope", "", "-x", "{plan}", "{dir}"]
        robot = draw(st.one_of(st.sampled_from(robots), robot_value))
        return "args", argv[:1] + [robot] + argv[2:]
    name = draw(st.sampled_from(sorted(n for n in actions if n not in ("--html", "--plot") or n in argv)))
    return "args", argv + [name, *draw(option_value(name, actions[name]))]


# Outputs that must be refused (or, for a fresh name, accepted): an input, a folder, a FIFO, a
# missing folder, a file used as a folder, links to an input, odd names.
SPECIAL_OUTPUTS = st.sampled_from(
    [
        "{plan}", "{urdf}", "{data}", "{constraints}", "{pool}", "{dh}", "{path}", "{validate}",
        "{xacro}", "{dir}", "{fifo}",
        "{dir}/missing/out.csv", "{plan}/out.csv", "{link_to_input}", "{hardlink_to_input}",
        "{dir}/a b,c;'\".csv", "{dir}/" + "n" * 300 + ".csv", "", "{dir}/out.xyz", "{dir}/noext",
        "{dir}/out.PNG", "{dir}/out.svg", "/proc/pincal-fuzz.urdf", "/proc/pincal-fuzz.csv",
        "/sys/pincal-fuzz.png", "{dir}/" + "n" * 250 + ".csv",
    ]
)  # fmt: skip


@st.composite
def cases(draw, command: str) -> Case:
    argv = BASE_ARGV[command].split()
    mutated: set[str] = set()
    for _ in range(draw(st.integers(0, 3))):
        what, argv = draw(argv_mutation(argv[0], argv))
        mutated.add(what)
    files = {}
    for kind in sorted({m.group(1) for t in argv for m in re.finditer(r"\{(\w+)\}", t)} & set(FILE_KINDS)):
        files[kind], bad = draw(file_content(kind))
        if bad:
            mutated.add(kind)
    for i, token in enumerate(argv):  # value placeholders: valid half of the time
        kind = token[1:-1] if token.startswith("{") and token.endswith("}") else None
        if kind in VALUE_KINDS:
            bad = draw(st.booleans())
            argv[i] = draw(VALUE_KINDS[kind][bad])
            if bad:
                mutated.add(kind)
    return Case(command, argv, files, mutated)


# ------------------------------------------------------------------------------- run and check
@dataclass
class Outcome:
    code: int
    out: str
    err: str


NOT_TEXT_OUTPUT = re.compile(rb"\s*(<!DOCTYPE html|<html|\x89PNG|<\?xml[^>]*>\s*<svg|%PDF)")
"""A written file that is a page or a figure (its scripts and bytes may spell 'nan'), not a table."""
# A printed non-finite number: nan, inf or infinity (signed or not) standing alone, not a part of a
# name: 'tool-inf', 'x.nan' or 'nan_joint' are names a mutation may make, and are not numbers.
NAN = re.compile(r"(?<![\w.-])[-+]?(nan|inf|infinity)(?![\w.-]*\w)", re.IGNORECASE)


def _snapshot(folder: Path) -> dict[str, bytes | str]:
    snap: dict[str, bytes | str] = {}
    for p in sorted(folder.rglob("*")):
        mode = p.lstat().st_mode
        key = str(p.relative_to(folder))
        if stat.S_ISREG(mode):
            snap[key] = p.read_bytes()
        else:
            snap[key] = "dir" if stat.S_ISDIR(mode) else "fifo" if stat.S_ISFIFO(mode) else "link"
    return snap


def materialise(case: Case, folder: Path) -> tuple[list[str], set[str]]:
    """Write the case's files into ``folder``: (the argv with placeholders replaced, the names
    of the files it reads, which must come out unchanged)."""
    paths = {}
    for kind, data in case.files.items():
        path = folder / f"input_{kind}{FILE_KINDS[kind].suffix}"
        path.write_bytes(data)
        paths[kind] = str(path)
    os.mkfifo(folder / "fifo")
    first_input = next(iter(paths.values()), None)
    if first_input is not None:
        os.symlink(first_input, folder / "link.csv")
        os.link(first_input, folder / "hardlink.csv")
    paths.update(fifo=str(folder / "fifo"), dir=str(folder))
    paths.update(link_to_input=str(folder / "link.csv"), hardlink_to_input=str(folder / "hardlink.csv"))
    inputs = {"fifo"}

    def fill(token: str, output: bool) -> str:
        def one(m: re.Match) -> str:
            name = m.group(1)
            if name.startswith("out"):
                return str(folder / f"output{name[3:]}")
            path = paths.get(name, str(folder / f"absent_{name}"))
            if not output:
                inputs.add(Path(path).name)
            return path

        return re.sub(r"\{([\w.]+)\}", one, token)

    argv = []
    for i, token in enumerate(case.argv):
        output = (i > 0 and case.argv[i - 1] in OUTPUT_FLAGS) or token.split("=")[0] in OUTPUT_FLAGS
        argv.append(fill(token, output))
    return argv, inputs


@contextlib.contextmanager
def _captured_fd2():
    """What anything, native code included, writes to file descriptor 2."""
    text = io.StringIO()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield text
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            text.write(sink.read().decode(errors="replace"))


def run_case(case: Case) -> tuple[Outcome, dict, dict, set[str]]:
    """Run ``main`` on the case in a fresh folder: (outcome, files before, files after, names of
    the input files)."""
    with tempfile.TemporaryDirectory(prefix="pincal-fuzz-") as tmp:
        folder = Path(tmp)
        argv, inputs = materialise(case, folder)
        before = _snapshot(folder)
        out, err = io.StringIO(), io.StringIO()
        with _captured_fd2() as native, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(argv)
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 2
        after = _snapshot(folder)
    return Outcome(code, out.getvalue(), err.getvalue() + native.getvalue()), before, after, inputs


def check_run(outcome: Outcome, before: dict, after: dict, inputs: set[str]) -> None:
    """The property; an AssertionError names what broke."""
    code, out, err = outcome.code, outcome.out, outcome.err
    assert code in (0, 2), f"exit code {code}: {err[-2000:]}"
    assert "Traceback" not in out + err, err[-3000:]
    lines = [line for line in err.splitlines() if line.strip()]
    leaked = [line for line in lines if "encountered in" in line or "Warning:" in line]
    assert not leaked, f"leaked warnings: {leaked}"
    errors = [line for line in lines if not line.startswith("pincal: warning: ")]
    if code == 2:
        assert len(errors) == 1 and errors[0].startswith("pincal: error: "), f"stderr: {err!r}"
    else:
        assert not errors, f"exit 0 with stderr {err!r}"
    assert not NAN.search(out), f"NaN/inf in stdout: {out[:2000]}"
    for name in inputs & set(before):
        assert after.get(name) == before[name], f"input {name} changed (or replaced)"
    new = sorted(set(after) - set(before))
    assert not [n for n in new if n.endswith(".tmp")], f"temporary files left: {new}"
    if code == 2:
        changed = [n for n in set(before) | set(after) if before.get(n) != after.get(n)]
        assert not changed, f"partial output on error: {changed}"
    for name in new:  # written CSV and URDF files (not the figures, not the HTML page's scripts)
        content = after[name]
        if isinstance(content, bytes) and not NOT_TEXT_OUTPUT.match(content):
            text = content.decode("utf-8", "replace")
            assert not NAN.search(re.sub(r"<!--.*?-->", "", text, flags=re.S)), f"NaN/inf in {name}"


def fuzz_once(case: Case) -> Outcome:
    outcome, before, after, inputs = run_case(case)
    check_run(outcome, before, after, inputs)
    return outcome
