"""File helpers: CSV tables with row-numbered errors, and atomic writes."""

from __future__ import annotations

import csv
import io
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pincal.errors import BadArgument, BadPlanFile, CannotWrite


def _error(error: type[Exception], message: str, path: object, line: int | None = None) -> Exception:
    """``error(message)``, carrying the file and line when it is a :class:`BadArgument`."""
    if issubclass(error, BadArgument):
        return error(message, file=str(path), line=line)
    return error(message)


def read_text(path: str | os.PathLike, what: str, error: type[Exception]) -> str:
    """The text of a user's file, or ``error`` saying it is missing or unreadable."""
    path = Path(path)
    try:
        return path.read_text()
    except FileNotFoundError:
        raise _error(error, f"{what} file {str(path)!r} does not exist", path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise _error(error, f"cannot read {what} file {str(path)!r}: {exc}", path) from None


def read_yaml(path: str | os.PathLike, what: str, error: type[Exception]) -> object:
    """The content of a user's YAML file, or ``error`` saying it is missing, unreadable or not YAML
    (with the line of the syntax error)."""
    import yaml

    text = read_text(path, what, error)
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f", line {where.line + 1}" if where is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        at = where.line + 1 if where is not None else None
        raise _error(
            error, f"{what} file {str(path)!r}{line}: not valid YAML ({problem})", path, at
        ) from None


def column_mismatch(expected: Sequence[str], found: Sequence[str]) -> str:
    """'; missing a, b; unknown column(s) c' for columns that differ from ``expected`` ('' if none)."""
    missing = [n for n in expected if n not in found]
    unknown = [n for n in found if n not in expected]
    return (f"; missing {', '.join(missing)}" if missing else "") + (
        f"; unknown column(s) {', '.join(unknown)}" if unknown else ""
    )


def read_numeric_csv(
    path: str | os.PathLike, what: str = "plan", error: type[Exception] = BadPlanFile
) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Read a CSV file with one header row and numeric rows.

    Blank lines and lines starting with ``#`` are skipped. Every other row must have as many cells
    as the header, all finite numbers.

    Returns:
        (header names, (rows, columns) float array, (rows,) line number of each row in the file).

    Raises:
        ``error`` naming the file and the line of the first bad row.
    """
    path = Path(path)
    text = read_text(path, what, error)
    lines = [
        (n, row)
        for n, row in enumerate(csv.reader(io.StringIO(text)), start=1)
        if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")
    ]
    if not lines:
        raise _error(
            error, f"{what} file {str(path)!r} is empty: expected a header row of column names", path
        )
    _, header = lines[0]
    header = [h.strip() for h in header]
    if any(_is_number(h) for h in header):
        raise _error(
            error,
            f"{what} file {str(path)!r}: the first row must be a header of column names, "
            f"got {','.join(header)}",
            path,
            lines[0][0],
        )
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise _error(
            error, f"{what} file {str(path)!r}: duplicate column(s) {', '.join(dup)}", path, lines[0][0]
        )
    rows, numbers = [], []
    for n, row in lines[1:]:
        if len(row) != len(header):
            raise _error(
                error,
                f"{what} file {str(path)!r}, line {n}: {len(row)} values, expected {len(header)} "
                f"({','.join(header)})",
                path,
                n,
            )
        values = []
        for name, cell in zip(header, row):
            try:
                v = float(cell)
            except ValueError:
                raise _error(
                    error,
                    f"{what} file {str(path)!r}, line {n}: column {name} is {cell.strip()!r}, not a number",
                    path,
                    n,
                ) from None
            if not np.isfinite(v):
                raise _error(
                    error,
                    f"{what} file {str(path)!r}, line {n}: column {name} is {cell.strip()} (must be finite)",
                    path,
                    n,
                )
            values.append(v)
        rows.append(values)
        numbers.append(n)
    if not rows:
        raise _error(error, f"{what} file {str(path)!r} has a header but no rows", path)
    return header, np.array(rows, dtype=float), np.array(numbers, dtype=int)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _umask() -> int:
    """The process umask, read without changing it (Linux), else the usual 0o022."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    return 0o022


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file and a rename: never half-written."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        reason = "its folder does not exist" if not directory.is_dir() else exc.strerror or str(exc)
        raise CannotWrite(f"cannot write {str(path)!r}: {reason}") from None
    try:
        # mkstemp makes owner-only files; give the result the permissions a plain open() would.
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "w", newline="") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError):  # e.g. the path is a folder, or the disk is full
            raise CannotWrite(f"cannot write {str(path)!r}: {exc.strerror or exc}") from None
        raise
    return path
