"""Files written completely or not at all: into a temporary file beside the target, flushed to disk, then renamed
into place (`os.replace` is atomic within a file system). One implementation for the output sets, the netCDF
datasets, the Monte Carlo checkpoints and the program cache; and their reading (`read_regular`): regular files
only, so that a FIFO or a device planted in their place cannot hang a command."""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

#: A Ctrl-C the `jaxroll` command's handler raised and the command has not reported yet (`note_interrupt`). Python
#: ignores an exception raised in a finaliser (`__del__`) or a weakref callback — it prints it and carries on — so
#: a KeyboardInterrupt raised there was lost, and the run went on and wrote --out (issue 45: 1 in 15 tries within
#: 0.1 s of a long-term unit's save). Every save raises it again (`raise_if_interrupted`).
_INTERRUPT = {"pending": False}


def note_interrupt() -> None:
    """Record that a KeyboardInterrupt is being raised (the command's Ctrl-C handler, just before it raises)."""
    _INTERRUPT["pending"] = True


def clear_interrupt() -> None:
    """Forget the recorded interrupt (the command has reported it, or a new command starts)."""
    _INTERRUPT["pending"] = False


def raise_if_interrupted() -> None:
    """Raise `KeyboardInterrupt` where a Ctrl-C was raised and not reported (lost on its way): before and after
    every atomic write, and before an output set is committed."""
    if _INTERRUPT["pending"]:
        _INTERRUPT["pending"] = False
        raise KeyboardInterrupt


def atomic_write(path: str | os.PathLike, write: Callable[[str], None], *, mode: int | None = None) -> None:
    """Create or replace the file `path` with what `write(temporary_path)` writes, completely or not at all: a
    killed process or a failing `write` leaves `path` as it was and no temporary file. Permissions: `mode` (e.g.
    0o600), or what the user's umask gives a new file (0o666 & ~umask). A Ctrl-C that was lost on its way
    (`raise_if_interrupted`) is raised before and after the write."""
    raise_if_interrupted()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        if mode is None:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    raise_if_interrupted()  # (the file is whole: a unit saved stays saved)


def atomic_write_bytes(
    path: str | os.PathLike, data: bytes, *, mode: int | None = None, name_errors: bool = False
) -> None:
    """Create or replace the file `path` with `data`, completely or not at all (`atomic_write`). `name_errors`: an
    `OSError` that names no file (a failing write: a full disk) is raised naming `path` (a checkpoint, so that the
    command can name its option)."""
    try:
        atomic_write(path, lambda tmp: Path(tmp).write_bytes(data), mode=mode)
    except OSError as e:
        if not name_errors or e.filename is not None:
            raise
        raise OSError(e.errno, e.strerror or str(e), os.fspath(path)) from e


class NotRegularFile(OSError):
    """A path that is not a regular file (a FIFO, a device, a socket or a folder) where one is read."""


def read_regular(path: str | os.PathLike) -> bytes:
    """The bytes of the regular file `path`. Opened without blocking (`O_NONBLOCK`: opening a FIFO with no writer
    would wait for one forever, issue 45) and refused unless it is a regular file.

    **Raises:** `NotRegularFile` (an `OSError`) for a FIFO, device, socket or folder; `OSError` as `open`."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise NotRegularFile(f"{os.fspath(path)} is not a regular file (a FIFO, a device or a folder)")
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        with os.fdopen(fd, "rb") as f:
            fd = None
            return f.read()
    finally:
        if fd is not None:
            os.close(fd)
