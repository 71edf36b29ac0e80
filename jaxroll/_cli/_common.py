"""Helpers shared by the subcommands: atomic output files, JSON with provenance, progress, ship loading."""

from __future__ import annotations

import json
import math
import os
import re
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ..io import atomic_write_bytes as atomic_write_bytes, raise_if_interrupted, to_jsonable as to_jsonable


class CLIError(Exception):
    """A user error on the command line; printed as `jaxroll CMD: error: ...` with exit code 2."""


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write `text` (UTF-8) to `path` completely or not at all."""
    atomic_write_bytes(path, text.encode())


#: The warnings the library gave during this command, in order (`jaxroll._cli.main` collects them; `write_json`
#: writes them as `warnings`).
WARNINGS: list[str] = []
#: This command's words (`jaxroll pdf --hs 7 …`; `jaxroll._cli.main` sets them): the netCDF files' `history`.
COMMAND_LINE: list[str] = []


def write_json(path: str | Path, payload: dict[str, Any]) -> None:
    """Write `payload` as JSON atomically, with `jaxroll_version` first, then the payload's fields, `versions`
    (`jaxroll.io.provenance()`: the versions of jaxroll, JAX, jaxlib and the libraries under it, the backend, the
    device kind and whether float64 was on — what the bit-for-bit claims depend on; the fields of the netCDF
    files' attributes) and the command's `warnings` (if any)."""
    from .. import __version__
    from ..io import provenance

    data = {"jaxroll_version": __version__, **payload, "versions": provenance()}
    if WARNINGS:
        data["warnings"] = list(dict.fromkeys(WARNINGS))
    atomic_write_text(path, json.dumps(to_jsonable(data), indent=2) + "\n")


def write_netcdf(path: str | Path, command: str, payload: dict[str, Any], parts=None) -> bool:
    """Write the labelled twin of a command's JSON (`payload`) as netCDF, atomically: its numbers with dimensions,
    units and long names, plus `parts` (the results' `.to_xarray()`: per-trial arrays, histogram counts), the
    configuration, versions and this command's warnings in the attributes (`jaxroll.io.output_dataset`;
    docs/outputs.md). A JSON field the output's layout does not describe leaves the netCDF out with a warning
    (the set is still written: a run's results are never lost to their labels; the tests refuse it).

    **Returns:** whether the file was written (the command's "wrote" line lists only files that exist)."""
    from ..io import output_dataset, write_dataset

    try:
        dataset = output_dataset(
            command, payload, parts, warnings=list(dict.fromkeys(WARNINGS)), command_line=COMMAND_LINE or None
        )
    except ValueError as e:  # a field its layout does not describe: the JSON and figures are still written
        if not str(e).startswith("labelled results:"):
            raise
        print(
            f"jaxroll {command}: warning: {Path(path).name} not written ({e}); the JSON holds every number. "
            "Please report it.",
            file=sys.stderr,
        )
        return False
    write_dataset(path, dataset)
    return True


def import_output_libraries() -> None:
    """Import what the figures and the netCDF files need (matplotlib's pyplot and Agg, xarray, h5netcdf: ≈ 0.4 s on
    a 2-core CPU) now: called while XLA computes a dispatched program in its own threads, the imports take no time
    from the command."""
    import h5netcdf  # noqa: F401
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.pyplot  # noqa: F401
    import xarray  # noqa: F401


def save_figure(fig, path: str | Path) -> None:
    """Save a matplotlib figure atomically (PNG, 150 dpi) and close it."""
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=150, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def load_ship_arg(path: str | None):
    """The ship named on the command line: a ship file, `c11-hull` (GZ and ΔGM from the shipped representative
    hull), or by default C11 (representative)."""
    from ..io import load_ship
    from ..ship import c11_representative

    if path is None:
        return c11_representative()
    if path == "c11-hull":
        from ..ship import c11_hull_ship

        return c11_hull_ship()
    return load_ship(path)


def add_memory_option(parser) -> None:
    """--memory-gb: the memory a compiled chunk of realizations may use."""
    parser.add_argument(
        "--memory-gb",
        type=float,
        default=None,
        help="memory a chunk of realizations may use [GiB] (default: a quarter of the available "
        "memory; on GPUs 0.9 of their free memory); the chunk is cut to fit, so any --dt runs",
    )


def add_chunk_option(parser, streaming: bool, what: str = "realizations") -> None:
    """--chunk-size: realizations per compiled batch (default: `jaxroll.default_chunk_size` for the devices)."""
    gpu = "2.5e5" if streaming else "1e5"  # jaxroll.default_chunk_size (tested)
    parser.add_argument(
        "--chunk-size",
        type=int,
        default=None,
        help=f"{what} per compiled batch (default: 500 per CPU core, {gpu} per GPU; cut to the "
        "memory budget)",
    )


def check_chunk_size(args) -> None:
    """--chunk-size, when given, is a positive integer."""
    if args.chunk_size is not None and args.chunk_size < 1:
        raise CLIError(f"--chunk-size must be >= 1; got {args.chunk_size}.")


def memory_budget(args) -> float | None:
    """--memory-gb in bytes (None: the library's default), checked."""
    value = getattr(args, "memory_gb", None)
    if value is None:
        return None
    if not (math.isfinite(value) and value > 0):
        raise CLIError(f"--memory-gb must be a finite number > 0 [GiB]; got {value}.")
    return value * 2**30


class Progress:
    """A one-line progress display on stderr (only when stderr is a terminal, or when forced); run inside a Jupyter
    kernel (`jaxroll._cli.main([...])` in a notebook), tqdm's notebook bar instead, when tqdm and ipywidgets are
    installed."""

    def __init__(self, total: int, label: str, *, enabled: bool | None = None, resuming: str | None = None):
        """`resuming`: a line printed (stdout) at the first call, which a Monte Carlo resumed from a checkpoint makes
        once it has read the checkpoint and found it belongs to this run; the time left is then estimated from the
        realizations done in this run only."""
        self.total, self.label, self.start = total, label, time.time()
        self.bar = _notebook_bar(total, label) if enabled is None else None
        self.enabled = (sys.stderr.isatty() or self.bar is not None) if enabled is None else enabled
        self.done = self.baseline = 0
        self.resuming = resuming

    def __call__(self, done: int) -> None:
        if self.resuming is not None:
            print(self.resuming, flush=True)
            self.resuming, self.baseline, self.start = None, done, time.time()
        self.done = done
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(done - self.bar.n)
            if done >= self.total:
                self.bar.close()
            return
        elapsed = time.time() - self.start
        eta = elapsed / (done - self.baseline) * (self.total - done) if done > self.baseline else float("nan")
        sys.stderr.write(
            f"\r{self.label}: {done}/{self.total} ({100 * done / self.total:5.1f} %), "
            f"{elapsed:6.1f} s elapsed, ~{eta:6.1f} s left "
        )
        sys.stderr.flush()
        if done >= self.total:
            sys.stderr.write("\n")


def _notebook_bar(total: int, label: str):
    """tqdm's notebook widget when this process is a Jupyter kernel and tqdm and ipywidgets are installed, else
    None (the stderr line)."""
    from ..notebook import in_notebook

    if not in_notebook():
        return None
    try:
        import ipywidgets  # noqa: F401  (tqdm's widget needs it)
        from tqdm.notebook import tqdm
    except ImportError:
        return None
    return tqdm(total=total, desc=label, unit=" realizations")


class OutputFolder:
    """Write a command's outputs as one set: a folder never holds the figures of one run beside the JSON of another,
    and an interrupted or failed run leaves `out` as it was.

    Use as `with OutputFolder(out) as tmp:` and write every file under `tmp`. The set is written inside `out`'s own
    file system — in a hidden folder inside `out` (`.jaxroll-partial.HOST.PID.RANDOM`), or, where `out` does not
    exist yet, beside it (`.NAME.jaxroll-partial.…`, renamed to `out` at the end) — so that a mount point (a Docker
    volume, a tmpfs) or `--out .` (the working directory, never renamed) work like any folder. On success each entry
    of the new set takes the place of the entry of that name in `out` (files of `out` the new set does not write —
    e.g. a user's own files — are kept): the entries it replaces are first moved aside
    (`.jaxroll-replaced.HOST.PID.RANDOM`), with a journal of the moves, then the new entries moved in, renames
    within one folder that take microseconds. A run killed during those renames (even by SIGKILL) is rolled back
    by the next command writing to `out` (`prepare_out`), which also removes the hidden folders of killed runs
    — only those with this machine's name and the PID of a process that no longer runs. The commit and that
    clean-up hold an exclusive lock on `out` (`flock`, where the system has it), so two runs writing into one
    folder do not interleave their sets.
    """

    def __init__(self, out: str | Path):
        self.out = Path(out)
        self.tmp: Path | None = None
        self.beside = False  # the set is written beside `out` (which did not exist), to be renamed to it

    def __enter__(self) -> Path:
        if self.out.exists() and not self.out.is_dir():
            raise CLIError(f"--out {str(self.out)!r} exists and is not a folder.")
        self.beside = not self.out.is_dir()
        if not self.beside:
            self.tmp = self.out / _hidden_name(_PARTIAL)
        else:
            target = Path(os.path.abspath(self.out))
            target.parent.mkdir(parents=True, exist_ok=True)
            self.tmp = target.parent / _hidden_name(f".{target.name}{_PARTIAL}")
        self.tmp.mkdir()
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> bool:
        import shutil

        assert self.tmp is not None
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return False
        try:
            raise_if_interrupted()  # a Ctrl-C lost on its way never commits the set
            if self.beside and not self.out.exists():
                try:
                    os.rename(self.tmp, self.out)  # the whole set appears at once
                    return False
                except OSError:
                    if not self.out.is_dir():  # not a folder created meanwhile by another run
                        raise
            with _locked(self.out):
                try:
                    _commit(self.tmp, self.out)
                except BaseException:  # a rename refused, or Ctrl-C, half way: the previous set back in place
                    if (self.tmp / _JOURNAL).exists():
                        _roll_back(self.tmp, self.out, killed=False)
                    raise
        except BaseException:
            shutil.rmtree(self.tmp, ignore_errors=True)
            raise
        return False


_PARTIAL = ".jaxroll-partial"  # the new set, being written
_REPLACED = ".jaxroll-replaced"  # the entries it replaces, during the commit
_JOURNAL = (
    ".jaxroll-commit.json"  # in the partial folder: what the commit moves (present only while it moves)
)


def _host() -> str:
    import socket

    return re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname())[:40] or "host"


def _hidden_name(prefix: str) -> str:
    """`PREFIX.HOST.PID.RANDOM`: whose it is, so that a later run can tell when it is stale."""
    return f"{prefix}.{_host()}.{os.getpid()}.{os.urandom(4).hex()}"


def _commit(tmp: Path, out: Path) -> None:
    """Move the entries of `tmp` into `out`, those they replace aside first, with a journal (see `OutputFolder`)."""
    import shutil

    new = sorted(p.name for p in tmp.iterdir())
    replaced = [n for n in new if os.path.lexists(out / n)]
    aside = out / _hidden_name(_REPLACED)
    aside.mkdir()
    atomic_write_text(tmp / _JOURNAL, json.dumps({"new": new, "replaced": replaced, "aside": aside.name}))
    for name in replaced:
        os.rename(out / name, aside / name)
    for name in new:
        os.rename(tmp / name, out / name)
    os.unlink(tmp / _JOURNAL)  # the commit point: the new set is in place
    shutil.rmtree(aside, ignore_errors=True)
    shutil.rmtree(tmp, ignore_errors=True)


class _locked:
    """An exclusive `flock` on folder `path` (none where the system or the file system has none)."""

    def __init__(self, path: Path):
        self.path, self.fd = path, None

    def __enter__(self):
        try:
            import fcntl

            self.fd = os.open(self.path, os.O_RDONLY)
            fcntl.flock(self.fd, fcntl.LOCK_EX)
        except (ImportError, OSError):
            if self.fd is not None:
                os.close(self.fd)
            self.fd = None
        return self

    def __exit__(self, *exc):
        if self.fd is not None:
            os.close(self.fd)  # releases the lock


def _process_ended(host: str, pid: str) -> bool:
    """Whether the process that named a folder `…HOST.PID…` has ended: only for this machine (a PID of another
    machine writing to a shared folder says nothing here), and never on Windows (`os.kill` would end it)."""
    if host != _host() or os.name == "nt" or int(pid) == os.getpid():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except OSError:  # PermissionError: it runs, as another user
        return False
    return False


def check_folder(folder: str | Path, option: str) -> None:
    """Check, before any computation, that the folder of `option` (`--out`, `--checkpoint`) can be created and
    written: not a file, not a symbolic link to nothing, a file can be created in it (or, where it does not exist
    yet, in the nearest folder above it). Raises `CLIError` naming `option` and the reason."""
    import errno

    folder = Path(folder)
    if folder.is_symlink() and not folder.exists():  # (was refused only after the computation, issue 45)
        raise CLIError(
            f"{option} {str(folder)!r} is a symbolic link to {os.readlink(folder)!r}, which does not exist: create "
            f"that folder, or give {option} another path."
        )
    if folder.exists() and not folder.is_dir():
        raise CLIError(f"{option} {str(folder)!r} exists and is not a folder.")
    base = Path(os.path.abspath(folder))
    while not base.exists() and base != base.parent:
        base = base.parent
    if not base.is_dir():
        raise CLIError(
            f"{option} {str(folder)!r}: {str(base)!r} is a file, so the folder cannot be created there."
        )
    try:
        fd, probe = tempfile.mkstemp(dir=base, prefix=".jaxroll-probe.")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        why = "it is on a read-only file system" if e.errno == errno.EROFS else (e.strerror or str(e)).lower()
        raise CLIError(
            f"{option} {str(folder)!r} cannot be written: no file can be created in {str(base)!r} ({why}). "
            "Choose a folder you can write, or fix its permissions."
        ) from None


def prepare_out(out: str | Path) -> None:
    """Check `--out` before any computation, and clear what killed runs left there.

    Raises `CLIError` where `out` is a file, or where no file can be created in it (or, where it does not exist
    yet, in the nearest folder above it that does): read-only, no permission. Rolls back a commit that a killed
    run left half done (`OutputFolder`) and removes the hidden folders of killed runs (this machine, PID no
    longer running). Folders left by jaxroll before 0.2 beside `out` (`.NAME.partial-*`, `.NAME.old-*`: no PID in
    their names, so not provably stale) are named in a warning."""
    import shutil
    import warnings

    out = Path(out)
    check_folder(out, "--out")
    pattern = re.compile(
        rf"^({re.escape(_PARTIAL)}|{re.escape(_REPLACED)})\.([A-Za-z0-9-]+)\.(\d+)\.[0-9a-f]+$"
    )
    if out.is_dir():
        with _locked(out):
            stale = [
                (m.group(1), p)
                for p in out.iterdir()
                if (m := pattern.match(p.name)) and _process_ended(m.group(2), m.group(3))
            ]
            for kind, path in sorted(stale, key=lambda x: x[0] != _PARTIAL):  # roll back before clearing
                if kind == _PARTIAL and (path / _JOURNAL).exists():
                    try:
                        _roll_back(path, out)
                    except (ValueError, KeyError, TypeError):  # not a journal jaxroll wrote: leave it alone
                        continue
                shutil.rmtree(path, ignore_errors=True)
    parent, name = Path(os.path.abspath(out)).parent, Path(os.path.abspath(out)).name
    if parent.is_dir():
        beside = re.compile(rf"^\.{re.escape(name)}{re.escape(_PARTIAL)}\.([A-Za-z0-9-]+)\.(\d+)\.[0-9a-f]+$")
        old = []
        for p in parent.iterdir():
            if (m := beside.match(p.name)) and _process_ended(m.group(1), m.group(2)):
                shutil.rmtree(p, ignore_errors=True)
            elif p.name.startswith((f".{name}.partial-", f".{name}.old-")) and p.is_dir():
                old.append(p.name)
        if old:
            warnings.warn(
                f"{len(old)} folder(s) beside --out were left by an interrupted run of an earlier jaxroll "
                f"(before 0.2): {', '.join(sorted(old))} in {str(parent)!r}. Remove them once no jaxroll "
                "command writes there (a '.old-' folder holds that run's previous set).",
                stacklevel=2,
            )


def _roll_back(tmp: Path, out: Path, killed: bool = True) -> None:
    """Undo a commit left half done (by a run `killed` since, or by this one): its new entries out of `out`, the
    entries it replaced back, the folder they were moved aside to removed."""
    import shutil
    import warnings

    journal = json.loads((tmp / _JOURNAL).read_text())
    names = [*journal["new"], *journal["replaced"]]
    if not (
        all(
            isinstance(n, str) and n not in ("", ".", "..") and os.sep not in n and "/" not in n
            for n in names
        )
        and re.fullmatch(rf"{re.escape(_REPLACED)}\.[A-Za-z0-9-]+\.\d+\.[0-9a-f]+", str(journal["aside"]))
    ):
        raise ValueError(
            f"{tmp / _JOURNAL} is not a journal jaxroll wrote"
        )  # names outside `out`: touch nothing
    aside = out / journal["aside"]
    for name in journal["new"]:
        moved_in = not os.path.lexists(tmp / name)
        if moved_in and os.path.lexists(out / name):
            target = out / name
            shutil.rmtree(target) if target.is_dir() and not target.is_symlink() else target.unlink()
    for name in journal["replaced"]:
        if os.path.lexists(aside / name) and not os.path.lexists(out / name):
            os.rename(aside / name, out / name)
    shutil.rmtree(aside, ignore_errors=True)
    (tmp / _JOURNAL).unlink()
    if killed:
        warnings.warn(
            f"--out {str(out)!r}: a run killed while it renamed its files into place was rolled back; the "
            "folder holds the set it held before that run.",
            stacklevel=3,
        )


def os_error_message(e: OSError, checkpoint: str | None = None) -> str:
    """An operating-system error (a folder that cannot be written, a full disk, …) as one line that says what to
    do; the command's outputs are written as a set, so `--out` is unchanged. An error writing in the `checkpoint`
    folder names `--checkpoint`."""
    import errno

    option = "--out"
    prefix = ""
    if checkpoint and e.filename and os.path.abspath(str(e.filename)).startswith(os.path.abspath(checkpoint)):
        option, prefix = "--checkpoint", f"--checkpoint {checkpoint!r}: "
    advice = {
        errno.ENOSPC: f"free some space or choose another {option}",
        errno.EDQUOT: f"free some space (a disk quota is full) or choose another {option}",
        errno.EROFS: f"choose a folder on a writable file system ({option})",
        errno.EACCES: "fix the permissions or choose another path",
        errno.EPERM: "fix the permissions or choose another path",
    }.get(e.errno, "")
    where = f" ({e.filename})" if e.filename else ""
    text = f"{prefix}{e.strerror or e}{where}"
    return f"{text}; outputs are written as a complete set or not at all, so --out is unchanged" + (
        f"; {advice}." if advice else "."
    )


def interrupted_message(command: str, out: str | None) -> str:
    """The one line printed on Ctrl-C."""
    where = f"; {out} is unchanged (outputs are written as a complete set or not at all)" if out else ""
    return f"jaxroll {command}: interrupted{where}."
