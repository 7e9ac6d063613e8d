"""The house rules a maintainer can check without reading: no module of pincal/ over 500 lines, no
function over 80 lines of code; names moved between modules keep working, with a warning naming
their home; every cache of the package is a store of pincal/kept.py that follows its one rule."""

from __future__ import annotations

import ast
import importlib
import io
import threading
import tokenize
from pathlib import Path

import pytest

import pincal
from pincal import kept

PACKAGE = Path(pincal.__file__).resolve().parent

MODULE_LINES = 500
FUNCTION_LINES = 80

TOO_LONG: dict[str, str] = {}
"""What is over a limit, with the reason it is still allowed. It only shrinks: an entry that is no
longer over its limit must be removed (a test says so)."""


def code_lines(source: str) -> tuple[int, dict[str, int]]:
    """(lines of the module, {qualified function name: lines of code}): a function's lines of code
    are those of its decorators, signature and body holding a token, docstrings and comments left
    out (a nested function's lines count in the function around it too)."""
    tree = ast.parse(source)
    docstrings: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            first = node.body[0] if node.body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                if isinstance(first.value.value, str):
                    docstrings.update(range(first.lineno, (first.end_lineno or first.lineno) + 1))
    skip = {
        tokenize.COMMENT,
        tokenize.NL,
        tokenize.NEWLINE,
        tokenize.INDENT,
        tokenize.DEDENT,
        tokenize.ENDMARKER,
    }
    code: set[int] = set()
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type not in skip:
            code.update(range(token.start[0], token.end[0] + 1))
    code -= docstrings
    functions: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                start = min([child.lineno, *(d.lineno for d in child.decorator_list)])
                end = child.end_lineno or child.lineno
                name = prefix + child.name
                functions[name] = max(functions.get(name, 0), sum(1 for n in code if start <= n <= end))
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(tree, "")
    return len(source.splitlines()), functions


def over_the_limits() -> dict[str, int]:
    """{module path or path:function: its size} of everything in pincal/ over a limit."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        where = path.relative_to(PACKAGE.parent).as_posix()
        lines, functions = code_lines(path.read_text(encoding="utf-8"))
        if lines > MODULE_LINES:
            out[where] = lines
        out.update({f"{where}:{name}": n for name, n in functions.items() if n > FUNCTION_LINES})
    return out


def test_the_counter_counts_code_only():
    """Docstrings, comments and blank lines are not code; decorators, signatures and nested
    functions are."""
    source = '''"""Module."""


@decorator
def f(
    a,
):
    """Doc
    string."""
    # a comment

    x = [
        1,
    ]

    def g():
        """Doc."""
        return x

    return g


class C:
    def m(self):
        return 1
'''
    lines, functions = code_lines(source)
    assert lines == 25
    assert functions == {"f": 10, "f.g": 2, "C.m": 2}


def test_no_module_over_500_lines_no_function_over_80_lines_of_code():
    found = over_the_limits()
    new = {k: v for k, v in found.items() if k not in TOO_LONG}
    assert not new, f"over {MODULE_LINES} lines (module) or {FUNCTION_LINES} lines of code (function): {new}"


def test_the_allow_list_only_shrinks():
    """An entry of TOO_LONG that is within its limit now is removed from it (or names nothing)."""
    found = over_the_limits()
    gone = sorted(k for k in TOO_LONG if k not in found)
    assert not gone, f"within the limits now: remove {gone} from TOO_LONG"


MOVED = {
    "pincal.evaluation.accuracy": {
        "PredictedError": "pincal.evaluation.predicted_error",
        "worst_found": "pincal.evaluation.predicted_error",
        "AccuracyReport": "pincal.evaluation.accuracy_report",
        "ErrorSummary": "pincal.evaluation.accuracy_report",
        "error_profile": "pincal.evaluation.error_profile",
        "PRISMATIC_PER_RADIAN": "pincal.evaluation.accuracy_samples",
        "sample_sets": "pincal.evaluation.accuracy_samples",
    },
    "pincal.calibration": {
        "export_urdf": "pincal.export",
        "export_mjcf": "pincal.export",
        "export_sdf": "pincal.export",
    },
    "pincal.calibration.urdf_export": {
        "export_urdf": "pincal.export.urdf",
        "sidecar_path": "pincal.export.urdf",
    },
    "pincal.calibration.xacro_export": {
        "export_xacro": "pincal.export.xacro",
        "corrections_path": "pincal.export.xacro",
    },
    "pincal.campaign": {
        "next_poses": "pincal.adaptive",
        "NextPoses": "pincal.adaptive",
        "MeasuredPrior": "pincal.adaptive",
    },
    "pincal.campaign.adaptive": {
        "next_poses": "pincal.adaptive.loop",
        "AVOID_DISTANCE": "pincal.adaptive.loop",
    },
    "pincal.calibration.result": {
        "identification_result": "pincal.calibration.assembly",
        "residual_rms": "pincal.calibration.assembly",
        "SHOWN": "pincal.calibration.result_report",
    },
}


@pytest.mark.parametrize("module", sorted(MOVED))
def test_names_moved_between_modules_keep_working(module):
    """A name moved out of a module in 0.2 is still found there, the same object: imported there
    (the module uses it), or with a DeprecationWarning naming its home; an unknown name is still an
    AttributeError."""
    old = importlib.import_module(module)
    warned = 0
    for name, home in MOVED[module].items():
        value = getattr(importlib.import_module(home), name)
        if name in vars(old):
            assert getattr(old, name) is value
            continue
        with pytest.warns(DeprecationWarning, match=rf"{module}\.{name} moved: import it from {home}"):
            assert getattr(old, name) is value
        warned += 1
    assert warned >= 2
    with pytest.raises(AttributeError, match="no_such_name"):
        old.no_such_name  # noqa: B018


def test_no_cache_outside_kept():
    """The package's caches are the stores of pincal/kept.py: no module keeps values per thread, in
    a functools cache or a weak dictionary of its own."""
    allowed = {"pincal/kept.py"}
    for path in sorted(PACKAGE.rglob("*.py")):
        where = path.relative_to(PACKAGE.parent).as_posix()
        text = path.read_text(encoding="utf-8")
        if where in allowed:
            continue
        for word in (
            "threading.local(",
            "lru_cache",
            "functools.cache",
            "threading.Lock(",
            "WeakKeyDictionary(",
        ):
            assert word not in text, f"{where} keeps values itself ({word}): declare a Kept in pincal/kept.py"
    stores = (kept.ENGINES, kept.CRITERIA, kept.REPORTS, kept.REGIONS, kept.PROBLEMS)
    assert set(kept.STORES) >= {s.name for s in stores}


class _Owner:
    pass


def test_a_store_keeps_by_owner_identity_and_key_value_the_most_recent():
    store: kept.Kept[list] = kept.Kept("test store", 2)
    a, b = _Owner(), _Owner()
    built = []

    def build(tag):
        def make():
            built.append(tag)
            return [tag]

        return make

    first = store.get((a,), (1, b"x"), build("a1"))
    assert store.get((b,), (1, b"x"), build("b1")) == ["b1"]  # another owner
    assert store.get((a,), (1, b"x"), build("again")) is first  # same owner, equal key: now the newest
    assert store.get((a,), (2, b"x"), build("a2")) == ["a2"]  # another key; drops (b, 1), the oldest
    assert store.get((a,), (1, b"x"), build("again")) is first
    assert store.get((b,), (1, b"x"), build("b1 again")) == ["b1 again"]
    assert built == ["a1", "b1", "a2", "b1 again"]
    other = []
    thread = threading.Thread(target=lambda: other.append(store.get((a,), (1, b"x"), build("thread"))))
    thread.start()
    thread.join()
    assert other == [["thread"]]  # each thread its own values
    store.forget()
    assert store.get((a,), (1, b"x"), build("after forget")) == ["after forget"]
    del kept.STORES["test store"]


def test_a_store_drops_one_value_and_keeps_the_others():
    """Kept.drop (the multistart problems: a design drops its own when its search ends)."""
    for shared in (False, True):
        store: kept.Kept[list] = kept.Kept("test store", 4, shared=shared)
        a = _Owner()
        x = store.get((a,), 1, lambda: ["x"])
        assert store.get((), "spec", lambda: ["y"]) == ["y"]
        store.drop((), "spec")
        store.drop((a,), 2)  # nothing kept there: nothing happens
        assert store.get((a,), 1, lambda: ["x again"]) is x
        assert store.get((), "spec", lambda: ["y again"]) == ["y again"]  # dropped: built anew
        assert store.get((), "spec", lambda: ["third"]) == ["y again"]
        del kept.STORES["test store"]
