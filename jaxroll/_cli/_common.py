"""Helpers shared by the subcommands: atomic output files, JSON with provenance, progress, ship loading."""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ..io import to_jsonable as to_jsonable


class CLIError(Exception):
    """A user error on the command line; printed as `jaxroll CMD: error: ...` with exit code 2."""


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` completely or not at all (temporary file in the same folder, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


#: The warnings the library gave during this command, in order (`jaxroll._cli.main` collects them; `write_json`
#: writes them as `warnings`).
WARNINGS: list[str] = []


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
    parser.add_argument("--memory-gb", type=float, default=None,
                        help="memory a chunk of realizations may use [GiB] (default: a quarter of the available "
                        "memory; on GPUs 0.9 of their free memory); the chunk is cut to fit, so any --dt runs")


def add_chunk_option(parser, streaming: bool, what: str = "realizations") -> None:
    """--chunk-size: realizations per compiled batch (default: `jaxroll.default_chunk_size` for the devices)."""
    gpu = "2.5e5" if streaming else "1e5"  # jaxroll.default_chunk_size (tested)
    parser.add_argument("--chunk-size", type=int, default=None,
                        help=f"{what} per compiled batch (default: 500 per CPU core, {gpu} per GPU; cut to the "
                        "memory budget)")


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
    """A one-line progress display on stderr (only when stderr is a terminal, or when forced)."""

    def __init__(self, total: int, label: str, *, enabled: bool | None = None, resuming: str | None = None):
        """`resuming`: a line printed (stdout) at the first call, which a Monte Carlo resumed from a checkpoint makes
        once it has read the checkpoint and found it belongs to this run; the time left is then estimated from the
        realizations done in this run only."""
        self.total, self.label, self.start = total, label, time.time()
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.done = self.baseline = 0
        self.resuming = resuming

    def __call__(self, done: int) -> None:
        if self.resuming is not None:
            print(self.resuming, flush=True)
            self.resuming, self.baseline, self.start = None, done, time.time()
        self.done = done
        if not self.enabled:
            return
        elapsed = time.time() - self.start
        eta = elapsed / (done - self.baseline) * (self.total - done) if done > self.baseline else float("nan")
        sys.stderr.write(f"\r{self.label}: {done}/{self.total} ({100 * done / self.total:5.1f} %), "
                         f"{elapsed:6.1f} s elapsed, ~{eta:6.1f} s left ")
        sys.stderr.flush()
        if done >= self.total:
            sys.stderr.write("\n")


class OutputFolder:
    """Write a command's outputs as one set: into a temporary sibling folder, renamed into place at the end.

    Use as `with OutputFolder(out) as tmp:` and write every file under `tmp`. On success the new set replaces the
    previous contents of `out` (files of `out` the new set does not write — e.g. a user's own files — are kept);
    on an error or Ctrl-C the temporary folder is removed and `out` is left exactly as it was. A folder never
    holds the figures of one run beside the JSON of another.
    """

    def __init__(self, out: str | Path):
        self.out = Path(out)
        self.tmp: Path | None = None

    def __enter__(self) -> Path:
        parent = self.out.resolve().parent
        parent.mkdir(parents=True, exist_ok=True)
        if self.out.exists() and not self.out.is_dir():
            raise CLIError(f"--out {str(self.out)!r} exists and is not a folder.")
        self.tmp = Path(tempfile.mkdtemp(dir=parent, prefix=f".{self.out.resolve().name}.partial-"))
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> bool:
        import shutil

        assert self.tmp is not None
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return False
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self.tmp, 0o777 & ~umask)
        target = self.out.resolve()
        if not target.exists():
            os.rename(self.tmp, target)
            return False
        # Carry the entries the new set does not write over into it, then swap the folders.
        new = {p.name for p in self.tmp.iterdir()}
        for entry in target.iterdir():
            if entry.name not in new and not entry.name.startswith(f".{target.name}.partial-"):
                os.replace(entry, self.tmp / entry.name) if not entry.is_dir() else shutil.move(entry, self.tmp)
        old = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.old-"))
        try:
            os.replace(target, old / "x")
        except OSError:  # a mount point or the working directory: move the entries one by one instead
            for entry in self.tmp.iterdir():
                dest = target / entry.name
                if dest.is_dir() and not dest.is_symlink():
                    shutil.rmtree(dest)
                os.replace(entry, dest)
            shutil.rmtree(self.tmp, ignore_errors=True)
            shutil.rmtree(old, ignore_errors=True)
            return False
        os.rename(self.tmp, target)
        shutil.rmtree(old, ignore_errors=True)
        return False


def interrupted_message(command: str, out: str | None) -> str:
    """The one line printed on Ctrl-C."""
    where = f"; {out} is unchanged (outputs are written as a complete set or not at all)" if out else ""
    return f"jaxroll {command}: interrupted{where}."
