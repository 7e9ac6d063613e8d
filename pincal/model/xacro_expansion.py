"""Expanding a xacro source into URDF text, bounded: in a child Python process with a time limit
(:data:`XACRO_SECONDS`) and, where the OS has ``resource``, a memory limit (:data:`XACRO_MEMORY`),
and its output no larger than the URDF reader takes. A xacro file is a program (``${10**10**10}``
runs for hours, ``${'x' * 10**10}`` asks for 10 GB): pincal's own process never runs it.

ROS is not needed: xacro's ``$(find NAME)`` asks ``ament_index_python`` for a package's folder;
the child gets a stand-in index that answers with :func:`package_roots` (``--package-dir
NAME=PATH``, then a folder ``NAME`` above the file), then ROS 2's own index when it is installed.
xacro prints its warnings on stderr itself: they are returned, as text, for one pincal warning.

This module imports only the standard library (and xacro, in the child): the child runs it as a
script, without importing pincal.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import os
import re
import subprocess
import sys
import types
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

XACRO_SECONDS = 60.0
"""Wall time a xacro expansion may take [s] (real descriptions expand in well under a second)."""

XACRO_MEMORY = 2 * 2**30
"""Address space the expanding process may use [bytes] (Python and xacro themselves: ~50 MB)."""

_ANSI = re.compile(r"\x1b\[[0-9;]*m")


@dataclass(frozen=True)
class Expansion:
    """What a xacro expansion gave: the URDF text, or the one-line reason it failed; and xacro's
    own warnings."""

    text: str | None
    error: str | None
    warnings: tuple[str, ...] = ()


def package_roots(
    package: str, urdf: Path, extra: Mapping[str, str] | None = None, search: Iterable[str] = ()
) -> list[Path]:
    """The folders package ``package`` may be, most trusted first: the one given for it
    (``--package-dir NAME=PATH``), ``DIR/NAME`` for each ``search`` folder, then ``NAME`` next to
    each folder above the URDF and each folder above it named ``NAME`` (a checkout of the
    description package)."""
    roots = [Path(p) for name, p in (extra or {}).items() if name == package]
    roots += [Path(d) / package for d in search]
    roots += [parent / package for parent in urdf.resolve().parents]
    roots += [parent for parent in urdf.resolve().parents if parent.name == package]
    return roots


def expand(
    path: Path,
    package_dirs: Mapping[str, str] | None = None,
    max_bytes: int = 16 * 2**20,
    seconds: float | None = None,
    memory: int | None = None,
) -> Expansion:
    """Expand the xacro file ``path`` in a child process (see module doc).

    Returns an :class:`Expansion` whose ``error`` is set (one line) when xacro is not installed
    (``"no xacro"``), fails, runs out of time or memory, or expands to more than ``max_bytes``.
    ``seconds`` and ``memory`` default to :data:`XACRO_SECONDS` and :data:`XACRO_MEMORY`.
    """
    try:
        installed = importlib.util.find_spec("xacro") is not None
    except (ValueError, AttributeError):  # sys.modules["xacro"] is None: taken as absent
        installed = False
    if not installed:
        return Expansion(None, "no xacro")
    seconds = XACRO_SECONDS if seconds is None else seconds
    memory = XACRO_MEMORY if memory is None else memory
    dirs = dict(package_dirs or {})
    # absolute: xacro resolves a relative name (xacro.abs_filename, load_yaml) against the folder of
    # the file as it was named, which a relative name breaks once an include changes folder
    request = json.dumps(
        {"path": str(Path(path).resolve()), "package_dirs": dirs, "max_bytes": max_bytes, "memory": memory}
    )
    # PYTHONPATH is kept (ROS puts xacro there); the current folder is not searched.
    script = (
        "import runpy, sys; sys.path[:] = filter(None, sys.path); "
        f"runpy.run_path({__file__!r}, run_name='__main__')"
    )
    command = [sys.executable, "-c", script]
    try:
        done = subprocess.run(
            command,
            input=request,
            capture_output=True,
            text=True,
            timeout=seconds,
            preexec_fn=_limit_memory(memory) if os.name == "posix" else None,  # noqa: PLW1509
        )
    except subprocess.TimeoutExpired:
        return Expansion(
            None, f"the expansion took over {seconds:g} s and was stopped (a runaway expression?)"
        )
    try:
        answer = json.loads(done.stdout)
    except ValueError:  # killed (memory), or died without a word
        why = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit code {done.returncode}"
        return Expansion(None, f"the expansion failed ({why}; the limit is {memory / 2**30:g} GiB of memory)")
    return Expansion(answer.get("text"), answer.get("error"), tuple(answer.get("warnings", ())))


def _limit_memory(memory: int):
    def limit() -> None:  # in the child, before it runs Python
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (memory, memory))

    return limit


def expand_here(
    path: Path, package_dirs: Mapping[str, str] | None, max_bytes: int, memory: int = XACRO_MEMORY
) -> Expansion:
    """The expansion itself, in this process (the child's work, under a ``memory`` limit)."""
    try:
        import xacro
    except ImportError:
        return Expansion(None, "no xacro")
    said = io.StringIO()  # xacro prints its warnings (and error context) on stderr itself
    failures: list[str] = []
    try:
        with contextlib.redirect_stderr(said), _ros_packages(path, package_dirs) as failures:
            text = xacro.process_file(str(path)).toxml()
    except Exception as exc:  # xacro's own types with long texts, wrapping others (MemoryError) in .exc
        inner = exc
        while getattr(inner, "exc", None) is not None:
            inner = inner.exc  # type: ignore[attr-defined]  # xacro's wrapped error
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        if isinstance(inner, MemoryError):
            first += f" (out of memory: the limit is {memory / 2**30:g} GiB; a runaway expression?)"
        return Expansion(None, failures[-1] if failures else first)
    if len(text.encode("utf-8")) > max_bytes:
        return Expansion(None, f"it expands to over {max_bytes / 2**20:g} MiB of URDF")
    lines = (line.strip() for line in _ANSI.sub("", said.getvalue()).splitlines())
    notes = [line.removeprefix("warning: ") for line in lines if line.startswith("warning")]
    return Expansion(text, None, tuple(notes))  # (not xacro's 'when processing file: ...' lines)


@contextlib.contextmanager
def _ros_packages(path: Path, package_dirs: Mapping[str, str] | None) -> Iterator[list[str]]:
    """A stand-in ``ament_index_python`` while xacro runs (see module doc); the failures it
    reports are kept in the list yielded (xacro wraps them in its own text)."""
    try:
        from ament_index_python import packages as ament  # type: ignore[import-not-found]
    except ImportError:
        ament = None
    failures: list[str] = []

    def share(name: str) -> str:
        found = next((root for root in package_roots(name, path, package_dirs) if root.is_dir()), None)
        if found is not None:
            return str(found)
        if ament is not None:
            with contextlib.suppress(Exception):
                return ament.get_package_share_directory(name)
        failures.append(
            f"$(find {name}): package {name!r} not found above {path.name}; give --package-dir "
            f"{name}=PATH (package_dirs=)"
        )
        raise LookupError(failures[-1])

    index = types.ModuleType("ament_index_python")
    packages = types.ModuleType("ament_index_python.packages")
    packages.get_package_share_directory = share  # type: ignore[attr-defined]
    packages.PackageNotFoundError = LookupError  # type: ignore[attr-defined]
    index.packages = packages  # type: ignore[attr-defined]
    import unittest.mock  # in the child only: it brings asyncio, slow for every import of pincal

    with unittest.mock.patch.dict(
        sys.modules, {"ament_index_python": index, "ament_index_python.packages": packages}
    ):
        yield failures


def _child() -> None:
    request = json.loads(sys.stdin.read())
    result = expand_here(
        Path(request["path"]), request["package_dirs"], request["max_bytes"], request["memory"]
    )
    json.dump({"text": result.text, "error": result.error, "warnings": list(result.warnings)}, sys.stdout)


if __name__ == "__main__":
    _child()
