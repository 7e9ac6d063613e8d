"""Outputs: written atomically, all or nothing, never over an input or a special file.

Writers (:func:`atomic_write_text`, :func:`atomic_write_bytes`) go through a temporary file and a
rename, and refuse (:func:`check_output`) an output that is a folder or special file, in a missing
or unwritable folder, or the same file as an input. Inside :func:`guard_inputs` (the CLI runs
every command in it) every file read through :mod:`pincal.files` is an input no write may replace.

Several outputs are written all or nothing inside :func:`all_or_nothing` (the CLI runs every
command in it; :func:`pincal.export_urdf` writes its URDF and sidecar in it): each write goes to its
temporary file, and the renames happen only when the block ends without an error, so that a
command that fails leaves none of its outputs (and the files they would have replaced untouched).
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from pincal.errors import CannotWrite, OverwriteRefused

# Files read so far inside guard_inputs(): {(st_dev, st_ino): path}; None outside.
_INPUTS: contextvars.ContextVar[dict | None] = contextvars.ContextVar("pincal_inputs", default=None)
# Writes staged inside all_or_nothing(): {target: (temporary file, path as given, what)}; None outside.
_STAGED: contextvars.ContextVar[dict[Path, tuple[str, Path, str]] | None] = contextvars.ContextVar(
    "pincal_staged", default=None
)


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


def _umask() -> int:
    """The process umask, read without changing it (Linux), else the usual 0o022."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except OSError:
        pass
    return 0o022


def same_file(a: Path, b: Path) -> bool:
    """Whether paths ``a`` and ``b`` name one file (a link or another spelling of it; paths that do
    not exist yet: the same resolved path)."""
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
        if other is not None and same_file(path, Path(other)):
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
