"""The public surface: the workflow's names at the top level and each stage's in its subpackage,
every name in every ``__all__`` imports, the names moved in 0.2 still work with a warning naming
their new home, ``import pincal`` imports no stage, and the README's Python example runs."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import pincal
from pincal.stages import PUBLIC_LISTS, STAGES
from tests.conftest import ROOT

PACKAGE = Path(pincal.__file__).resolve().parent
"""The package under test (the checkout's pincal/, or the installed wheel's under .ci/run)."""

PUBLIC_MODULES = tuple(f"pincal.{module}" for module in PUBLIC_LISTS)
"""The stages' public faces (:data:`pincal.stages.PUBLIC_LISTS`): each has its own ``__all__``,
sorted (constants first, as ruff and isort sort them)."""


def test_all_names_import():
    for name in pincal.__all__:
        assert hasattr(pincal, name), name
    assert pincal.__all__ == sorted(pincal.__all__)
    assert isinstance(pincal.__version__, str)
    declared = re.search(r'^version = "([^"]+)"', (ROOT / "pyproject.toml").read_text(), re.M)
    assert declared and declared.group(1) == pincal.__version__


def test_the_top_level_is_the_workflow():
    """About 30 names (pink has 11, mink 15): each also public in its stage, and the imports type
    checkers read (under TYPE_CHECKING) are the names imported at run time."""
    assert 20 <= len(pincal.__all__) <= 35, len(pincal.__all__)
    tree = ast.parse((PACKAGE / "__init__.py").read_text())
    homes = {
        alias.name: node.module
        for block in tree.body
        if isinstance(block, ast.If) and ast.unparse(block.test) == "TYPE_CHECKING"
        for node in ast.walk(block)
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
    }
    assert sorted(homes) == sorted(set(pincal.__all__) - {"__version__"})
    for name, home in homes.items():
        stage = importlib.import_module(".".join(home.split(".")[:2]))  # pincal.model, pincal.errors
        holders = [s for s in pincal._STAGE_LISTS if name in importlib.import_module(s).__all__]
        assert holders == [stage.__name__], f"{name} is in the __all__ of {holders}, not {stage.__name__}"
        assert getattr(pincal, name) is getattr(stage, name) is getattr(importlib.import_module(home), name)


@pytest.mark.parametrize("module", PUBLIC_MODULES)
def test_every_stage_has_a_public_face(module):
    stage = importlib.import_module(module)
    assert stage.__all__ == sorted(stage.__all__, key=lambda n: (not n.isupper(), n)), module
    for name in stage.__all__:
        assert hasattr(stage, name), f"{module}.{name}"
        assert not name.startswith("_"), f"{module}.{name}"


def test_moved_names_warn_and_name_their_new_home():
    """Every name that was top-level in 0.1 still works, as the same object, with a
    DeprecationWarning naming its new home (once, at the caller's line, for a from-import too)."""
    for home, names in pincal._MOVED.items():
        module = importlib.import_module(home)
        for name in names:
            assert home == "pincal.arguments" or name in module.__all__, f"{home}.{name}"
            with pytest.warns(DeprecationWarning, match=rf"pincal\.{name} is deprecated: use {home}\.{name}"):
                value = getattr(pincal, name)
            assert value is getattr(module, name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from pincal import rho0_each  # noqa: F401
    assert [w.filename for w in caught] == [__file__]
    assert set(pincal._MOVED_TO).isdisjoint(pincal.__all__)
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        pincal.no_such_name  # noqa: B018


def test_each_moved_name_has_one_home_in_a_stage_list():
    """The moved names are the 0.1 top level less the workflow's, and each one's home is found in
    the ``__all__`` of exactly one stage (written there once), so the warning names one home."""
    assert pincal._MOVED_NAMES == pincal._TOP_LEVEL_0_1 - set(pincal.__all__)
    assert {"rho0_each", "JointLimits", "BadArgument", "DEFAULT_SIGMA"} <= pincal._MOVED_NAMES
    for name in pincal._MOVED_NAMES - set(pincal._NO_LIST):
        holders = [s for s in pincal._STAGE_LISTS if name in importlib.import_module(s).__all__]
        assert holders == [pincal._MOVED_TO[name]], name
    for name, home in pincal._NO_LIST.items():
        assert pincal._MOVED_TO[name] == home and hasattr(importlib.import_module(home), name)


def test_every_stage_is_an_attribute_of_pincal():
    """``pincal.campaign`` works after a bare ``import pincal``, as ``pincal.model`` does."""
    code = "import pincal; print(sorted(m for m in {!r} if getattr(pincal, m) is None))"
    stages = sorted({m.split(".")[1] for m in PUBLIC_MODULES})
    out = subprocess.run(
        [sys.executable, "-c", code.format(stages)], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[]"
    assert set(stages) <= set(dir(pincal))


def test_import_pincal_imports_no_stage():
    """``import pincal`` and ``pincal --help`` import neither NumPy nor Pinocchio (nor SciPy,
    matplotlib, meshcat, scikit-learn): each public name is imported from its stage when used."""
    heavy = ("numpy", "pinocchio", "scipy", "matplotlib", "meshcat", "sklearn", "pincal.model")
    script = (
        "import sys, pincal, pincal.cli\n"
        "import contextlib, io\n"
        "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
        "    pincal.cli.main(['--help'])\n"
        f"print(sorted(m for m in {heavy!r} if m in sys.modules))\n"
        "pincal.load_robot\n"
        "print('pincal.model' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True).stdout
    assert out.split("\n")[:2] == ["[]", "True"], out


def test_no_import_inside_a_function_but_optional_ones():
    """Import cycles are not broken by imports inside functions: only the optional viewer
    (meshcat, through pincal.viewing.scene and its static page) is imported late, and the CLI's
    helpers once a subcommand is parsed (so that ``pincal --help`` imports neither NumPy nor
    Pinocchio)."""
    allowed = {
        ("pincal/cli/show.py", "pincal.viewing.scene"),
        ("pincal/cli/campaign.py", "pincal.viewing.animation"),
        ("pincal/viewing/scene.py", "pincal.viewing.static_page"),
        ("pincal/cli/__init__.py", "pincal.cli._common"),
        ("pincal/cli/__init__.py", "pincal.outputs"),
    }
    for path in sorted(PACKAGE.rglob("*.py")):
        name = path.relative_to(PACKAGE.parent).as_posix()
        for function in ast.walk(ast.parse(path.read_text())):
            if not isinstance(function, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(function):
                modules = [node.module or ""] if isinstance(node, ast.ImportFrom) else []
                modules += [a.name for a in node.names] if isinstance(node, ast.Import) else []
                for module in modules:
                    if module.split(".")[0] == "pincal":
                        assert (name, module) in allowed, f"{name}: {function.name} imports {module}"


def test_data_flows_one_way():
    """Each stage imports only the stages before it (robot → parameters → Jacobians → criteria →
    design → identify → campaign → view → CLI); the foundation modules (errors, files, arguments,
    ...) none. pincal.typing names stage classes in its aliases, for type checkers only (under
    TYPE_CHECKING)."""
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE).parts
        stage = parts[0] if len(parts) > 1 else None
        if stage is None and parts[0] in ("__init__.py", "__main__.py"):
            continue  # the public surface gathers every stage
        tree = ast.parse(path.read_text())
        annotations_only = {
            id(node)
            for block in tree.body
            if parts == ("typing.py",)
            and isinstance(block, ast.If)
            and ast.unparse(block.test) == "TYPE_CHECKING"
            for node in ast.walk(block)
        }
        for node in ast.walk(tree):
            if id(node) in annotations_only:
                continue
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("pincal."):
                target = node.module.split(".")[1]
                if target not in STAGES:
                    continue
                where = path.relative_to(PACKAGE.parent).as_posix()
                assert stage is not None, f"foundation module {where} imports the stage {target}"
                assert STAGES.index(target) <= STAGES.index(stage), f"{where} imports the later {target}"


def test_errors_share_one_root():
    for module in PUBLIC_MODULES:
        stage = importlib.import_module(module)
        for name in stage.__all__:
            obj = getattr(stage, name)
            if isinstance(obj, type) and issubclass(obj, Exception):
                assert issubclass(obj, pincal.PincalError), f"{module}.{name}"
                assert obj.__module__ == "pincal.errors" and name in pincal.errors.__all__


@pytest.mark.filterwarnings("ignore::pincal.errors.DegenerateOptimumWarning")  # the README explains it
def test_readme_python_blocks_run(tmp_path, monkeypatch):
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, flags=re.S)
    assert blocks, "the README has Python examples"
    monkeypatch.chdir(ROOT)
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {"__name__": "readme"})


def test_docstring_examples_run():
    import doctest

    import pincal.model.loading

    for module in (pincal, pincal.model.loading):
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
        assert result.attempted > 0 and result.failed == 0, module.__name__


def test_every_subcommand_is_listed():
    """``pincal --help`` lists the subcommands from pincal.cli.COMMANDS without importing them: every
    module with an ``add_parser`` is there, under the name its parser takes."""
    from pincal.cli import COMMANDS, build_parser

    modules = {
        f"pincal.cli.{path.stem}"
        for path in (PACKAGE / "cli").glob("*.py")
        if "\ndef add_parser(" in path.read_text()
    }
    assert modules == {command.module for command in COMMANDS.values()}
    parser = build_parser()
    assert list(parser.commands) == list(COMMANDS)
    for name, command in COMMANDS.items():
        assert parser.commands[name].description == command.help + "."


KEYWORD_ONLY_AFTER = {
    "pincal.rho0": 3,
    "pincal.accuracy": 3,
    "pincal.design": 3,
    "pincal.identify": 2,
    "pincal.simulate_measurements": 3,
    "pincal.random_errors": 1,
    "pincal.monte_carlo": 3,
    "pincal.validate": 2,
    "pincal.export_urdf": 2,
    "pincal.scene": 3,
    "pincal.show": 3,
    "pincal.cartesian_box": 3,
    "pincal.evaluation.rho0_each": 3,
    "pincal.evaluation.rho0_split": 3,
    "pincal.evaluation.position_covariance": 3,
    "pincal.evaluation.expected_error": 4,
    "pincal.evaluation.error_profile": 3,
    "pincal.evaluation.worst_found": 2,
    "pincal.evaluation.check_plan": 2,
    "pincal.calibration.holdout": 3,
    "pincal.calibration.kfold": 3,
    "pincal.model.identifiability": 1,
}
"""The public functions whose arguments after the first few are keyword-only (0.2)."""


def _public(path: str):
    module, _, name = path.rpartition(".")
    return getattr(importlib.import_module(module), name)


@pytest.mark.parametrize("path", sorted(KEYWORD_ONLY_AFTER))
def test_arguments_after_the_first_few_are_keyword_only(path):
    """The signature says it (``*``, for type checkers and help()); every public function takes
    at most four arguments by position."""
    parameters = inspect.signature(_public(path)).parameters.values()
    positional = [p.name for p in parameters if p.kind is p.POSITIONAL_OR_KEYWORD]
    assert len(positional) == KEYWORD_ONLY_AFTER[path], positional
    assert any(p.kind is p.KEYWORD_ONLY for p in parameters)


def test_every_public_function_takes_few_arguments_by_position():
    for module in PUBLIC_MODULES:
        stage = importlib.import_module(module)
        for name in stage.__all__:
            function = getattr(stage, name)
            if not inspect.isfunction(function):
                continue
            parameters = inspect.signature(function).parameters.values()
            positional = [p.name for p in parameters if p.kind is p.POSITIONAL_OR_KEYWORD]
            assert len(positional) <= 4 or name == "make_criterion", f"{module}.{name}: {positional}"


def test_arguments_by_position_still_work_with_a_warning(planar):
    """As pincal 0.1 allowed, until 0.3: the same value, one DeprecationWarning at the caller's
    line naming the keywords to write; too many, or one given twice, is a TypeError."""
    params = planar.parameters("full").identifiable().identifiable
    plan = [[0.3, 1.2], [1.0, -0.8], [-0.6, 1.9], [2.0, 0.4], [0.1, -1.5]]
    expected = pincal.rho0(params, plan, [0.2, 1.0], sigma=1e-4, aggregate="worst")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = pincal.rho0(params, plan, [0.2, 1.0], 1e-4, "worst")
    assert value == expected
    assert [(w.category, w.filename) for w in caught] == [(DeprecationWarning, __file__)]
    message = str(caught[0].message)
    assert (
        "rho0(): passing sigma, aggregate by position is deprecated: write sigma=..., aggregate=..."
        in message
    )
    assert "pincal 0.3" in message
    with pytest.raises(TypeError, match=r"rho0\(\) takes 3 positional arguments, then keywords"):
        # one more than its keywords: sigma, aggregate, prior, task_payload, measure, instrument,
        # orientation_length
        pincal.rho0(params, plan, [0.2, 1.0], 1e-4, "worst", None, None, None, None, None, "extra")
    with pytest.raises(TypeError, match="multiple values for argument 'sigma'"), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        pincal.rho0(params, plan, [0.2, 1.0], 1e-4, sigma=1e-4)
