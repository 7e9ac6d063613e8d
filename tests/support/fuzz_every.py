"""The every-command fuzzer (issue 32, item 7): every command and every option of ``pincal``, the
calibration sidecar, meshes, MJCF robots, the measurement kinds and the export formats.

The options are found by walking the parsers ``pincal.cli.build_parser`` makes (:func:`option_table`):
a new option is fuzzed without editing this file, its values drawn from its type, choices and
metavar (:func:`option_tokens`: numbers with 0, negative, 1e-320, 1e308, nan and inf; strings with
commas and unicode; an input file missing, empty, a folder, of another kind, huge or broken; an
output over an input, a file an input names, a folder). A case (:func:`make_case`) is a valid run of
a command on rail_arm (``BASES``) with its inputs drawn valid or broken (tests/support/fuzz_inputs.py) and
one to three options added, replaced or removed; the n-th case of a command adds its n-th option,
so every option is reached in as many cases as the command has options.

Each case runs in a forked child (``pincal.cli.main``, already imported) with a CPU limit, a time
limit and an address-space limit (``resource.setrlimit``); the contract (:func:`contract`):

* exit code 0, 2, 130 or 143 (not 1, a crash or a limit hit); no traceback or "internal error";
* every file that was there before (the inputs and the files they name: a sidecar, a mesh) unchanged;
* on exit 2 no new file; no NaN or infinity in stdout or in a written file;
* every file pincal wrote reads back with pincal (:func:`read_back`, in the child).
"""

from __future__ import annotations

import contextlib
import random
import re
from dataclasses import dataclass, field
from pathlib import Path

from pincal.cli import build_parser
from pincal.cli._common import OUTPUT_OPTIONS
from tests.support.fuzz_inputs import (
    EDGE_NUMBERS,
    JOINTS,
    MEASUREMENT_KINDS,
    MUTATE,
    STRINGS,
    TEST_POSE,
    UNITS,
    Seeds,
    mesh_variant,
    number,
)

# A valid, fast run of each command on rail_arm: {kind} is an input of that kind, {out} the output.
BASES = {
    "params": "params {robot}",
    "evaluate": f"evaluate {{robot}} --plan {{plan}} {TEST_POSE}",
    "design": f"design {{robot}} -m 6 {TEST_POSE} --starts 2 --workers 1 --no-progress --pool-size 40 "
    "--out {out}",
    "baseline": f"baseline {{robot}} -m 6 {TEST_POSE} --random 10 --starts 2 --workers 1 --no-progress",
    "campaign": "campaign {robot} --plan {plan} --no-progress --out {out}",
    "next": f"next {{robot}} --data {{meas}} --plan {{plan}} -k 2 {TEST_POSE} --starts 1 --workers 1 "
    "--no-progress --out {out}",
    "simulate": f"simulate {{robot}} --plan {{plan}} {TEST_POSE} --trials 5 --no-progress",
    "measure-sim": "measure-sim {robot} --plan {plan} --error-std 1e-3,1e-3 --out {out}",
    "identify": "identify {robot} --data {meas} --no-progress --out {out}",
    "compensate": "compensate {robot} --calibration {calibration} --targets {program} --out {out}",
    "iso9283": "iso9283 --data {cycles} --mm --deg",
    "show": f"show {{robot}} --plan {{plan}} {TEST_POSE} --html {{out}} --baseline 10",
    "robots": "robots {robot}",
    "export": "export {calibration} --format {format} --out {out}",
    "urdf-from-dh": "urdf-from-dh {dh} --out {out}",
    "example": "example {example}",
}
OUT_SUFFIX = {"identify": ".urdf", "show": ".html", "urdf-from-dh": ".urdf", "example": ".txt"}
EXPORT_SUFFIX = {"mjcf": ".xml", "sdf": ".sdf", "urdf": ".urdf", "xacro": ".urdf.xacro", "yaml": ".yaml",
                 "robot_calibration": ".yaml", "ros2_control": ".ros2_control.xacro"}  # fmt: skip
# Options whose removal or value would make a run without end or a server: kept, values chosen.
PINNED = {"--html": "show", "--workers": None, "--no-progress": None}
# Values that pass (steering a case towards deeper code); an option without a line gets generic ones.
GOOD = {
    "--tip": ["tool0", "forearm", "base_link", "nope"],
    "--params": ["full,offsets", "offsets", "lengths", "base", "markers", "gains", "compliance", "x"],
    "--criterion": ["test-pose", "test-pose-worst", "D", "A", "E", "cond", "nope"],
    "--method": ["exchange", "continuous", "trf", "lm"],
    "--measure": ["point", "pose", "distance", "image", "x,y,rz", "x,y,z,rx", "rz", "x,x"],
    "--instrument": ["tracker", "2,0,1", "nope"],
    "--mount": ["floor", "wall", "ceiling", "none", "nope"],
    "--dwell": ["tracker", "probe", "2", "0", "-1", "1e308", "nan"],
    "--starts": ["1", "2", "auto", "0"],
    "--workers": ["1", "0", "-1", "x", str(2**63), "2"],
    "--place-screen": ["1", "2", "all", "0"],
    "--campaign-m": ["6:8:2", "6:1000000:1", "8", "x", "6:8:0"],
    "--format": ["pincal", "figaroh", "csv", "ipa", "mjcf"],
    "--pair": ["P1,P2", "P1,P1", "P9,P1", "x"],
    "--test": ["cube1", "x"],
    "--package-dir": ["pkg=.", "pkg=/nonexistent", "=", "a,b=."],
    "--root": ["base_link", "carriage", "tool0", "nope"],
    "--sensor": ["camera", "x"],
    "--joint-range": [
        "rail=0,1",
        "waist=-1,1",
        "waist=1,-1",
        "waist=-1e308,1e308",
        "nope=0,1",
        "waist=nan,1",
    ],
    "--loss": ["huber", "cauchy"],
    "--residual-model": ["gp"],
}
NUMBER_METAVARS = re.compile(r"^(LENGTH|ANGLE.*|LEN,ANG.*|KG|S|L|RAD|PX|X|K|FRACTION|KIND\|S)$")
# Which seed kind an input option reads, by its metavar (a new metavar with a file suffix is given
# a seed of another kind: the generator still reaches the option).
METAVAR_FILES = {
    "PLAN.csv": "plan", "FILE.csv": "pool", "POOL.csv": "pool", "MEAS.csv": "meas", "MEASURED.csv": "meas",
    "OTHER.csv": "meas", "FILE.yaml": "constraints", "TRUE.urdf": "urdf", "PATH.csv": "path",
    "CAL.urdf": "calibration", "RIG.yaml": "rig", "CYCLES.csv": "cycles", "PROGRAM.csv": "program",
    "TABLE.yaml": "dh", "ROBOT.urdf": "urdf", "ROBOT": "robot", "CALIBRATION": "calibration",
}  # fmt: skip
FLAG_FILES = {"--joint-states": "joint_states"}
FILE_SUFFIXES = (".csv", ".yaml", ".urdf", ".json", ".stl", ".xml")


@dataclass(frozen=True)
class Option:
    """One option (or positional) of one command, as its parser declares it."""

    command: str
    flag: str  # '--out', or the metavar of a positional
    nargs: object
    metavar: str
    parses: object  # int, float, or None
    choices: tuple
    dest: str

    @property
    def positional(self) -> bool:
        return not self.flag.startswith("-")


def option_table() -> dict[str, list[Option]]:
    """{command: its options}, from the parsers (``_actions``), --help left out."""
    table = {}
    for name, parser in build_parser().commands.items():
        table[name] = [
            Option(
                name,
                a.option_strings[0] if a.option_strings else str(a.metavar or a.dest),
                a.nargs,
                str(a.metavar or ""),
                getattr(a.type, "parses", a.type),
                tuple(a.choices or ()),
                a.dest,
            )
            for a in parser._actions
            if a.dest != "help"
        ]
    return table


def value_kind(opt: Option) -> str:
    """How values of ``opt`` are drawn: flag, output, file:KIND, choice, int, float, list, number, text."""
    if opt.nargs == 0:
        return "flag"
    if opt.dest in OUTPUT_OPTIONS:
        return "output"
    kind = FLAG_FILES.get(opt.flag) or METAVAR_FILES.get(opt.metavar)
    if kind is None and opt.metavar.endswith(FILE_SUFFIXES):
        kind = "any"
    if kind is not None:
        return f"file:{kind}"
    if opt.choices:
        return "choice"
    if opt.parses in (int, float):
        return opt.parses.__name__
    if "," in opt.metavar or opt.metavar in ("Q", "Q0", "SIZES"):
        return "list"
    if NUMBER_METAVARS.match(opt.metavar):
        return "number"
    return "text"


def _list(rng: random.Random, metavar: str) -> str:
    n = len(JOINTS) if metavar in ("Q", "Q0") else metavar.count(",") + 1
    if "..." in metavar or metavar == "SIZES":
        n = rng.randrange(0, 6)
    if "=" in metavar:  # NAME=LO,HI, NAME=PATH
        return f"{rng.choice(JOINTS + ('nope', 'a,b', ''))}={number(rng)},{number(rng)}"
    good = rng.random() < 0.4
    values = [
        f"{rng.uniform(-1, 1):.3g}" if good else number(rng) for _ in range(n + rng.choice((0, 0, 0, 1, -1)))
    ]
    if rng.random() < 0.2:
        values = [v + rng.choice(UNITS) for v in values]
    return ",".join(values)


def option_tokens(rng: random.Random, opt: Option) -> list[str]:
    """The tokens after ``opt.flag`` for one value of it (placeholders for files and outputs)."""
    kind = value_kind(opt)
    if kind == "flag":
        return []
    if kind == "output":
        return ["{out}"]
    if kind.startswith("file:"):
        return ["{" + kind[5:] + "}"]
    if opt.flag in GOOD and rng.random() < 0.5:
        return [rng.choice(GOOD[opt.flag])]
    if kind == "choice":
        return [rng.choice(opt.choices) if rng.random() < 0.85 else rng.choice(STRINGS)]
    if kind == "int":
        return [
            rng.choice(
                ("0", "-1", "1", "2", "3", "5", "1e3", "2.5", "abc", "10000001", str(2**63), "9" * 400)
            )
        ]
    if kind in ("float", "number"):
        value = number(rng)
        return [value + (rng.choice(UNITS) if kind == "number" and rng.random() < 0.5 else "")]
    if kind == "list":
        return [_list(rng, opt.metavar)]
    return [rng.choice(STRINGS + tuple(EDGE_NUMBERS[:8]))]


# ------------------------------------------------------------------------------------ a case
@dataclass
class Case:
    command: str
    argv: list[str]  # placeholders still in
    variants: dict[str, str] = field(default_factory=dict)  # input kind -> valid, mutated, missing, ...
    options: list[str] = field(default_factory=list)  # the options added or replaced
    mesh: str = ""  # how the robot's or the cell's mesh was drawn
    seed: int = 0

    def describe(self) -> str:
        return (
            f"seed {self.seed}: pincal {' '.join(self.argv)}; inputs {self.variants}; mesh {self.mesh or '-'}"
        )


def _base(rng: random.Random, command: str, table: list[Option]) -> list[str]:
    text = BASES[command]
    text = text.replace("{format}", rng.choice(sorted(EXPORT_SUFFIX)))
    text = text.replace(
        "{example}", rng.choice(("rig", "cell", "fixture", "program", "cycles", "table", "nope"))
    )
    argv = text.split()
    flags = {o.flag for o in table}
    if "{meas}" in argv or "--measure" in flags:
        kind = rng.choice(sorted(MEASUREMENT_KINDS))
        extra = MEASUREMENT_KINDS[kind]
        if extra and extra[0] in flags and (rng.random() < 0.5 or "{meas}" in argv):
            argv += extra
            if kind == "distance":  # one coordinate per pose: 14 parameters need 14 poses
                argv = ["16" if t == "6" and argv[i - 1] == "-m" else t for i, t in enumerate(argv)]
        argv = [f"{{meas_{kind}}}" if t == "{meas}" else t for t in argv]
    return argv


def _spans(argv: list[str]) -> list[tuple[int, int]]:
    """(start, end) of each option with its value in argv."""
    out, i = [], 1
    while i < len(argv):
        if argv[i].startswith("-") and not re.fullmatch(r"-[\d.].*", argv[i]):
            j = i + 1
            if "=" not in argv[i] and j < len(argv) and not argv[j].startswith("--"):
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


def make_case(rng: random.Random, command: str, index: int, table: list[Option], seed: int = 0) -> Case:
    """The ``index``-th case of ``command``: its base, the ``index``-th option added (every option in
    turn), then up to two more changes (an option added, replaced or removed; an output pointed at
    an input)."""
    argv = _base(rng, command, table)
    case = Case(command, argv, seed=seed)
    chosen = [table[index % len(table)]] + [rng.choice(table) for _ in range(rng.choice((0, 0, 1, 2)))]
    for opt in chosen:
        tokens = option_tokens(rng, opt)
        case.options.append(opt.flag)
        if opt.positional:
            positions = [
                i
                for i, t in enumerate(argv[1:], 1)
                if not t.startswith("-") and (i == 1 or not argv[i - 1].startswith("-"))
            ]
            if positions and tokens:
                argv[positions[0]] = tokens[0]
            continue
        spans = [(a, b) for a, b in _spans(argv) if argv[a].split("=")[0] == opt.flag]
        if spans and opt.flag not in PINNED and rng.random() < 0.3:  # removed
            a, b = spans[0]
            del argv[a:b]
        elif spans and opt.nargs != "*" and rng.random() < 0.7:  # replaced
            a, b = spans[0]
            argv[a:b] = [opt.flag, *tokens]
        elif opt.flag != "--plot" or command != "show" or rng.random() < 0.5:
            argv += [opt.flag, *tokens]
    if rng.random() < 0.15 and "{out}" in argv:  # the output over an input, or a file an input names
        argv[argv.index("{out}")] = rng.choice(("{@input}", "{@named}", "{@folder}", "{@missing}/x.csv"))
    return case


def draw_inputs(rng: random.Random, case: Case, seeds: Seeds) -> dict[str, bytes | None]:
    """{file name: bytes (None: a folder)} of the case's inputs, each drawn valid (about half the
    time), broken, missing, empty, a folder, of another kind or huge; ``case.argv``'s placeholders
    become those names."""
    files: dict[str, bytes | None] = {}
    kinds = sorted({m.group(1) for t in case.argv for m in re.finditer(r"\{(\w+)\}", t)} - {"out"})
    for kind in kinds:
        seed_kind = kind
        if kind == "robot":
            seed_kind = rng.choice(("urdf", "urdf", "mjcf", "mesh", "name"))
        elif kind == "meas":
            seed_kind = f"meas_{rng.choice(sorted(MEASUREMENT_KINDS))}"
        elif kind == "any":
            seed_kind = rng.choice(sorted(seeds.files))
        if seed_kind == "name":
            case.variants[kind] = "name"
            case.argv = [t.replace("{robot}", "rail_arm") for t in case.argv]
            continue
        group = dict(seeds.files[seed_kind])
        main_name = next(iter(group))
        how = rng.choice(
            ("valid",) * 48 + ("mutated",) * 10 + ("missing", "empty", "folder", "wrong") * 2 + ("huge",)
        )
        if how == "mutated":
            for _ in range(rng.choice((1, 1, 2))):
                name = rng.choice(sorted(group))
                mutate = MUTATE.get(Path(name).suffix)
                if mutate is not None and group[name]:
                    with contextlib.suppress(ValueError, IndexError, RecursionError):
                        group[name] = mutate(rng, group[name])
        elif how == "missing":
            del group[main_name]
        elif how == "empty":
            group[main_name] = b""
        elif how == "folder":
            group[main_name] = None
        elif how == "wrong":
            other = rng.choice(sorted(seeds.files))
            group[main_name] = next(iter(seeds.files[other].values()))
        elif how == "huge":
            data = group[main_name] or b""
            head, _, body = data.partition(b"\n")
            group[main_name] = head + b"\n" + body * max(1, (20 << 20) // max(1, len(body)))
        if "part.stl" in group or "fixture.stl" in group:  # the mesh a robot or a cell names
            mesh_name = "part.stl" if "part.stl" in group else "fixture.stl"
            case.mesh, mesh, scale = mesh_variant(rng)
            group.pop(mesh_name, None)
            if mesh is not None:
                group[mesh_name] = mesh
            text = group.get(main_name)
            if text:
                text = text.replace(b'scale="1 1 1"', f'scale="{scale} {scale} {scale}"'.encode())
                group[main_name] = text.replace(b"scale: 0.001", f"scale: {scale}".encode())
        case.variants[kind] = f"{seed_kind}:{how}"
        files.update(group)
        case.argv = [t.replace("{" + kind + "}", main_name) for t in case.argv]
    return files


def valid_case(rng: random.Random, command: str, seeds: Seeds) -> tuple[Case, dict[str, bytes | None]]:
    """The base case of ``command`` with valid inputs (the robot a URDF): it must exit 0."""
    case = Case(command, _base(rng, command, option_table()[command]))
    files: dict[str, bytes | None] = {}
    for kind in sorted({m.group(1) for t in case.argv for m in re.finditer(r"\{(\w+)\}", t)} - {"out"}):
        group = seeds.files["urdf" if kind == "robot" else kind]
        files.update(group)
        case.argv = [t.replace("{" + kind + "}", next(iter(group))) for t in case.argv]
        case.variants[kind] = "valid"
    return case, files
