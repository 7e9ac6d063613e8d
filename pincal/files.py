"""File helpers: bounded readers (text, CSV tables with row-numbered errors, YAML), and atomic
writes that never replace an input or a special file.

Readers refuse what is almost surely not the file meant, before it can exhaust memory or the
stack: files that are not regular files (folders, devices, pipes), files larger than
:data:`MAX_FILE_BYTES`, NUL bytes, lines longer than :data:`MAX_LINE_CHARS`, CSV cells longer than
:data:`MAX_CELL_CHARS`, YAML nested deeper than :data:`MAX_YAML_DEPTH` or with more than
:data:`MAX_YAML_NODES` values, YAML anchors/aliases, and non-finite numbers.

Writers (:func:`atomic_write_text`, :func:`atomic_write_bytes`) go through a temporary file and a
rename, and refuse (:func:`check_output`) an output that is a folder or special file, in a missing
or unwritable folder, or the same file as an input. Inside :func:`guard_inputs` (the CLI runs
every command in it) every file read through this module is an input no write may replace.

Several outputs are written all or nothing inside :func:`all_or_nothing` (the CLI runs every
command in it; :func:`pincal.export_urdf` writes its URDF and sidecar in it): each write goes to its
temporary file, and the renames happen only when the block ends without an error, so that a
command that fails leaves none of its outputs (and the files they would have replaced untouched).
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import io
import math
import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from pincal.errors import BadArgument, BadPlanFile, CannotWrite, OverwriteRefused

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

# Files read so far inside guard_inputs(): {(st_dev, st_ino): path}; None outside.
_INPUTS: contextvars.ContextVar[dict | None] = contextvars.ContextVar("pincal_inputs", default=None)
# Writes staged inside all_or_nothing(): {target: (temporary file, path as given, what)}; None outside.
_STAGED: contextvars.ContextVar[dict[Path, tuple[str, Path, str]] | None] = contextvars.ContextVar(
    "pincal_staged", default=None
)


def _error(error: type[Exception], message: str, path: object, line: int | None = None) -> Exception:
    """``error(message)``, carrying the file and line when it is a :class:`BadArgument`."""
    if issubclass(error, BadArgument):
        return error(message, file=str(path), line=line)
    return error(message)


@contextlib.contextmanager
def guard_inputs() -> Iterator[None]:
    """Within this block, no write through this module may replace a file read through it."""
    token = _INPUTS.set({})
    try:
        yield
    finally:
        _INPUTS.reset(token)


def note_input(path: str | os.PathLike) -> None:
    """Record ``path`` as an input of the current :func:`guard_inputs` block (no-op outside)."""
    inputs = _INPUTS.get()
    if inputs is None:
        return
    with contextlib.suppress(OSError):
        st = os.stat(path)
        inputs[(st.st_dev, st.st_ino)] = str(path)


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


def _umask() -> int:
    """The process umask, read without changing it (Linux), else the usual 0o022."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    return 0o022


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def check_output(
    path: str | os.PathLike, what: str = "output", inputs: Iterable[tuple[str, str | os.PathLike]] = ()
) -> Path:
    """``path`` as an output pincal may write, or :class:`CannotWrite` / :class:`OverwriteRefused`.

    Refused: an empty path, an existing folder or special file (device, pipe, socket), a path in
    a missing folder or in one pincal cannot write, and the same file as one of ``inputs``
    ((description, path) pairs) or as any file read inside :func:`guard_inputs`.
    """
    text = os.fspath(path)
    if not text.strip():
        raise CannotWrite(f"cannot write {what}: the file name is empty")
    path = Path(text)
    try:
        st = path.stat()
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise CannotWrite(f"cannot write {what} {text!r}: {exc.strerror or exc}") from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise CannotWrite(f"cannot write {what} {text!r}: it is a folder (give a file name)")
        if not stat.S_ISREG(st.st_mode):
            raise CannotWrite(
                f"cannot write {what} {text!r}: it exists and is not a regular file (a device, pipe "
                "or socket), which pincal does not replace"
            )
        read = _INPUTS.get() or {}
        if (st.st_dev, st.st_ino) in read:
            raise OverwriteRefused(
                f"{what} {text} is the input {read[(st.st_dev, st.st_ino)]}: pincal never overwrites an "
                "input; choose another output path"
            )
    for name, other in inputs:
        if other is not None and _same_file(path, Path(other)):
            raise OverwriteRefused(
                f"{what} {text} is {name}: pincal never overwrites an input; choose another output path"
            )
    folder = path.resolve().parent
    if not folder.is_dir():
        raise CannotWrite(f"cannot write {what} {text!r}: its folder does not exist ({str(folder)!r})")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise CannotWrite(f"cannot write {what} {text!r}: permission denied in folder {str(folder)!r}")
    try:  # the real test (root passes os.access everywhere; /proc, read-only mounts, quotas)
        fd, probe = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.", suffix=".probe")
    except OSError as exc:
        raise CannotWrite(f"cannot write {what} {text!r}: {exc.strerror or exc}") from None
    os.close(fd)
    Path(probe).unlink(missing_ok=True)
    return path


@contextlib.contextmanager
def all_or_nothing() -> Iterator[None]:
    """Within this block, the writes of :func:`atomic_write_bytes` are staged: each is written to
    its temporary file next to its target, and every target is replaced (renamed into place) only
    when the block ends without an exception. On an exception (or Ctrl-C) every temporary file is
    removed: no output appears and no file is replaced. A block inside another joins it (the
    outermost one commits). A target written twice keeps its last content.

    Raises:
        CannotWrite: a rename failed at the end (the outputs renamed before it stay written).
    """
    if _STAGED.get() is not None:
        yield
        return
    staged: dict[Path, tuple[str, Path, str]] = {}
    token = _STAGED.set(staged)
    try:
        yield
    except BaseException:
        for tmp, _, _ in staged.values():
            Path(tmp).unlink(missing_ok=True)
        raise
    finally:
        _STAGED.reset(token)
    pending = list(staged.items())
    for i, (target, (tmp, path, what)) in enumerate(pending):
        try:
            os.replace(tmp, target)
        except OSError as exc:
            for other, _, _ in (v for _, v in pending[i:]):
                Path(other).unlink(missing_ok=True)
            raise CannotWrite(f"cannot write {what} {str(path)!r}: {exc.strerror or exc}") from None


def atomic_write_text(path: str | os.PathLike, text: str, what: str = "output") -> Path:
    """Write ``text`` to ``path`` through a temporary file and a rename: never half-written,
    never over an input or a special file (see :func:`check_output`)."""
    return atomic_write_bytes(path, text.encode(), what)


def atomic_write_bytes(path: str | os.PathLike, data: bytes, what: str = "output") -> Path:
    """Write ``data`` to ``path`` like :func:`atomic_write_text`."""
    path = check_output(path, what)
    target = path.resolve()  # through a symbolic link, to the file it names
    try:
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    except OSError as exc:
        raise CannotWrite(f"cannot write {what} {str(path)!r}: {exc.strerror or exc}") from None
    try:
        # mkstemp makes owner-only files; give the result the permissions a plain open() would.
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        staged = _STAGED.get()
        if staged is not None:  # renamed into place when the all_or_nothing block ends
            earlier = staged.pop(target, None)
            if earlier is not None:
                Path(earlier[0]).unlink(missing_ok=True)
            staged[target] = (tmp, path, what)
            return path
        os.replace(tmp, target)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise CannotWrite(f"cannot write {what} {str(path)!r}: {exc.strerror or exc}") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
