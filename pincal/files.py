"""File helpers: bounded readers (text, CSV tables with row-numbered errors, YAML).

Readers refuse what is almost surely not the file meant, before it can exhaust memory or the
stack: files that are not regular files (folders, devices, pipes), files larger than
:data:`MAX_FILE_BYTES`, NUL bytes, lines longer than :data:`MAX_LINE_CHARS`, CSV cells longer than
:data:`MAX_CELL_CHARS`, YAML nested deeper than :data:`MAX_YAML_DEPTH` or with more than
:data:`MAX_YAML_NODES` values, YAML anchors/aliases, and non-finite numbers.

The writers (atomic, all or nothing, never over an input) are :mod:`pincal.outputs`'.
"""

from __future__ import annotations

import csv
import io
import math
import os
import stat
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from pincal.errors import BadArgument, BadPlanFile
from pincal.outputs import note_input

MAX_FILE_BYTES = 64 * 2**20
"""Largest input file read (64 MiB): a plan or measurement file of a million rows fits."""
MAX_LINE_CHARS = 100_000
"""Longest line of a CSV file."""
MAX_CELL_CHARS = 1_000
"""Longest CSV cell (a number or a column name)."""
MAX_YAML_DEPTH = 32
"""Deepest nesting of lists and mappings in a YAML file."""
MAX_YAML_NODES = 100_000
"""Most values (scalars, lists, mappings) in a YAML file."""


def _error(error: type[Exception], message: str, path: object, line: int | None = None) -> Exception:
    """``error(message)``, carrying the file and line when it is a :class:`BadArgument`."""
    if issubclass(error, BadArgument):
        return error(message, file=str(path), line=line)
    return error(message)


def _regular_file(path: Path, what: str, error: type[Exception], max_bytes: int) -> os.stat_result:
    """The stat of an existing, regular, not too large input file, or ``error`` saying why not."""
    try:
        st = path.stat()
    except FileNotFoundError:
        raise _error(error, f"{what} file {str(path)!r} does not exist", path) from None
    except OSError as exc:
        raise _error(error, f"cannot read {what} file {str(path)!r}: {exc.strerror or exc}", path) from None
    if stat.S_ISDIR(st.st_mode):
        raise _error(error, f"{what} file {str(path)!r} is a folder, not a file", path)
    if not stat.S_ISREG(st.st_mode):
        raise _error(
            error, f"{what} file {str(path)!r} is not a regular file (a device, pipe or socket)", path
        )
    if st.st_size > max_bytes:
        raise _error(
            error,
            f"{what} file {str(path)!r} is {st.st_size / 2**20:.1f} MiB, more than the "
            f"{max_bytes / 2**20:g} MiB pincal reads",
            path,
        )
    return st


def read_text(
    path: str | os.PathLike,
    what: str,
    error: type[Exception],
    max_bytes: int = MAX_FILE_BYTES,
    strict_utf8: bool = True,
) -> str:
    """The UTF-8 text of a user's file (a leading byte-order mark dropped), or ``error`` saying
    it is missing, unreadable, not a regular file, too large, binary (NUL bytes) or, with
    ``strict_utf8``, not UTF-8 (else undecodable bytes are replaced)."""
    path = Path(path)
    _regular_file(path, what, error, max_bytes)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _error(error, f"cannot read {what} file {str(path)!r}: {exc.strerror or exc}", path) from None
    note_input(path)
    if len(data) > max_bytes:  # grew since the stat
        raise _error(
            error, f"{what} file {str(path)!r} is more than the {max_bytes / 2**20:g} MiB pincal reads", path
        )
    if b"\0" in data:
        line = data.count(b"\n", 0, data.index(b"\0")) + 1
        raise _error(
            error,
            f"{what} file {str(path)!r}, line {line}: a NUL byte (binary data, not a text file)",
            path,
            line,
        )
    try:
        return data.decode("utf-8-sig", "strict" if strict_utf8 else "replace")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise _error(
            error, f"{what} file {str(path)!r}, line {line}: not UTF-8 text ({exc.reason})", path, line
        ) from None


def csv_header(names: Iterable[str]) -> str:
    """A CSV header line of column names that :func:`read_numeric_csv` reads back as they are: a
    name holding a comma, a quote or a line break, or beginning with ``#`` (a comment line
    otherwise), is quoted (CSV's rule: in double quotes, a quote doubled)."""

    def cell(name: str) -> str:
        if any(c in name for c in ',"\r\n') or name.startswith("#"):
            return '"' + name.replace('"', '""') + '"'
        return name

    return ",".join(cell(n) for n in names) + "\n"


def column_mismatch(expected: Sequence[str], found: Sequence[str]) -> str:
    """'; missing a, b; unknown column(s) c' for columns that differ from ``expected`` ('' if none)."""
    missing = [n for n in expected if n not in found]
    unknown = [n for n in found if n not in expected]
    return (f"; missing {', '.join(missing)}" if missing else "") + (
        f"; unknown column(s) {', '.join(unknown)}" if unknown else ""
    )


def read_numeric_csv(
    path: str | os.PathLike,
    what: str = "plan",
    error: type[Exception] = BadPlanFile,
    may_be_empty: Callable[[str], bool] | None = None,
) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Read a CSV file with one header row and numeric rows.

    Blank lines and lines starting with ``#`` are skipped. Every other row must have as many cells
    as the header, all finite numbers; an empty cell of a column for which ``may_be_empty(name)``
    is True is read as NaN (a value not measured: a target point out of a camera's view).

    Returns:
        (header names, (rows, columns) float array, (rows,) line number of each row in the file).

    Raises:
        ``error`` naming the file and the line of the first bad row.
    """
    path = Path(path)
    lines = [
        (n, row)
        for n, row, comment in _csv_rows(path, what, error)
        if row and any(c.strip() for c in row) and not comment
    ]
    if not lines:
        raise _error(
            error, f"{what} file {str(path)!r} is empty: expected a header row of column names", path
        )
    _, header = lines[0]
    header = [h.strip() for h in header]
    if all(_is_number(h) for h in header):  # a row of numbers: data, no header (a name may be nan)
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
            if may_be_empty is not None and not cell.strip() and may_be_empty(name):
                values.append(np.nan)
                continue
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


def _csv_rows(path: Path, what: str, error: type[Exception]) -> Iterator[tuple[int, list[str], bool]]:
    """(line number, cells, a comment: its line begins with '#') of each CSV row, within the line
    and cell limits (a quoted cell "#..." is not a comment)."""
    text = read_text(path, what, error)
    raw = text.splitlines()
    for n, line in enumerate(raw, start=1):
        if len(line) > MAX_LINE_CHARS:
            raise _error(
                error,
                f"{what} file {str(path)!r}, line {n}: {len(line)} characters, more than the "
                f"{MAX_LINE_CHARS} a line may have",
                path,
                n,
            )
    reader = csv.reader(io.StringIO(text, newline=""))
    first = 1  # the line the next row begins on
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise _error(
                error, f"{what} file {str(path)!r}, line {reader.line_num}: {exc}", path, reader.line_num
            ) from None
        for cell in row:
            if len(cell) > MAX_CELL_CHARS:
                raise _error(
                    error,
                    f"{what} file {str(path)!r}, line {reader.line_num}: a cell of {len(cell)} "
                    f"characters, more than the {MAX_CELL_CHARS} a cell may have",
                    path,
                    reader.line_num,
                )
        comment = first <= len(raw) and raw[first - 1].lstrip().startswith("#")
        first = reader.line_num + 1
        yield reader.line_num, row, comment


def read_yaml(path: str | os.PathLike, what: str, error: type[Exception], documents: bool = False) -> object:
    """The data of a YAML file, within the depth and size limits, every number finite.

    Anchors and aliases are refused (they can expand a small file into a huge tree), and so are
    numbers that are not finite or beyond float range. With ``documents``, the list of the
    file's documents (a stream separated by ``---``, as ``ros2 topic echo`` prints messages).
    """
    import yaml

    path = Path(path)
    text = read_text(path, what, error, max_bytes=2**20)
    where = f"{what} file {str(path)!r}"
    depth = nodes = 0
    try:
        for event in yaml.parse(text, Loader=yaml.SafeLoader):
            line = event.start_mark.line + 1 if event.start_mark is not None else 0
            if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None):
                raise _error(
                    error,
                    f"{where}, line {line}: anchors and aliases (&name, *name) are not supported",
                    path,
                    line,
                )
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
                depth += 1
                if depth > MAX_YAML_DEPTH:
                    raise _error(
                        error,
                        f"{where}, line {line}: nested more than {MAX_YAML_DEPTH} levels deep",
                        path,
                        line,
                    )
            elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
                depth -= 1
            if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent, yaml.ScalarEvent)):
                nodes += 1
                if nodes > MAX_YAML_NODES:
                    raise _error(error, f"{where}: more than {MAX_YAML_NODES} values", path)
        data = list(yaml.safe_load_all(text)) if documents else yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f", line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise _error(
            error, f"{where}{at}: not valid YAML ({problem})", path, mark.line + 1 if mark else None
        ) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise _error(error, f"{where}: {exc}", path) from None
    _check_finite(data, path, where, error)
    return data


def _check_finite(data: object, path: Path, where: str, error: type[Exception]) -> None:
    """Every number in a parsed YAML tree is finite and within float range."""
    stack: list[tuple[object, str]] = [(data, "")]
    while stack:
        value, key = stack.pop()
        if isinstance(value, dict):
            stack.extend((v, f"{key}.{k}" if key else str(k)) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, f"{key}[{i}]") for i, v in enumerate(value))
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            if isinstance(value, int) and abs(value) > 1e300:  # no float: '{:g}' would overflow
                digits = len(str(abs(value)))
                raise _error(
                    error, f"{where}: {key or 'the value'} is an integer of {digits} digits, over 1e300", path
                )
            if isinstance(value, float) and not math.isfinite(value):
                raise _error(
                    error, f"{where}: {key or 'the value'} is {value:.6g}, not a finite number", path
                )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
