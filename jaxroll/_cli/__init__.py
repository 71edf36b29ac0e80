"""The `jaxroll` command line: parses arguments, calls the public API, writes files. No numerics here.

Each subcommand lives in its own module of this package and exposes `register(subparsers)`, which adds its
parser and sets `func=run(args) -> int` as the default. Modules are discovered, so adding a subcommand touches
no other file.
"""

from __future__ import annotations

import argparse
import functools
import gc
import importlib
import os
import pkgutil
import signal
import sys
import threading
import warnings
from collections.abc import Sequence

# The LAPACK that jaxlib calls on the CPU is SciPy's OpenBLAS, which starts a thread per core; on the small matrices
# of jaxroll's theories those threads only contend with XLA's own (a warm `jaxroll theory` took 5.8–8 s instead of
# 3.4–3.7 s on a 2-core machine with another job running; no difference when idle). One thread, unless set.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="jaxroll",
        description="Parametric roll of ships in long-crested irregular waves (Katsumura et al., arXiv 2407.02728).",
    )
    parser.add_argument("--version", action="version", version=f"jaxroll {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `jaxroll` command. Returns the process exit code."""
    import matplotlib

    matplotlib.use("Agg")  # the CLI only writes files; never needs a display
    parser = build_parser()
    args = parser.parse_args(argv)
    from .. import enable_compilation_cache

    enable_compilation_cache()  # JAXROLL_CACHE_DIR, default ~/.cache/jaxroll/xla; empty: off
    if args.command is None:
        parser.print_help()
        return 2
    from .. import configure
    from ._common import WARNINGS

    WARNINGS.clear()
    with warnings.catch_warnings():
        warnings.showwarning = functools.partial(_warning_line, args.command)
        # The command's own process, set up fully: float64, XLA:CPU's platform-independent math and small loops
        # compiled whole, one JAX device per CPU core (docs/architecture.md, "Process-wide settings").
        configure()
        return _run(args)


def _warning_line(command: str, message, category, filename, lineno, file=None, line=None) -> None:
    """A warning of the library (or of the libraries under it) as the command shows it: one line on stderr,
    `jaxroll COMMAND: warning: …` (no source path or code line), and kept for the JSON it writes (`warnings`)."""
    from ._common import WARNINGS

    text = str(message)
    WARNINGS.append(text)
    print(f"jaxroll {command}: warning: {text}", file=sys.stderr)


def _run(args) -> int:
    """The command's `func`, its errors as one line and exit code 2, Ctrl-C as 130."""
    from ._common import CLIError

    try:
        return int(args.func(args) or 0)
    except CLIError as e:
        print(f"jaxroll {args.command}: error: {e}", file=sys.stderr)
        return 2
    except (ValueError, FileNotFoundError) as e:
        print(f"jaxroll {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        from ._common import interrupted_message

        print(interrupted_message(args.command, getattr(args, "out", None)), file=sys.stderr)
        return 130


def _on_interrupt(signum, frame) -> None:
    """Ctrl-C: `KeyboardInterrupt`, as Python's own handler — except inside a garbage-collector callback (JAX has
    one), where Python would ignore the exception (print it and carry on: the command would not stop); there the
    signal is raised again once the callback has returned."""
    callbacks = {getattr(cb, "__code__", None) for cb in gc.callbacks}
    while frame is not None:
        if frame.f_code in callbacks:
            threading.Timer(0.05, _interrupt_main_thread).start()
            return
        frame = frame.f_back
    raise KeyboardInterrupt


def _interrupt_main_thread() -> None:
    """SIGINT to the main thread itself, so that a blocking call there (a wait, a sleep) is interrupted too."""
    if hasattr(signal, "pthread_kill"):
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
    else:  # pragma: no cover  (Windows)
        signal.raise_signal(signal.SIGINT)


def console() -> None:  # pragma: no cover  (the console script; tests call `main`)
    """The `jaxroll` command: `main()`, and after Ctrl-C (exit code 130) an immediate exit. The theories' programs
    compile in background threads (`jaxroll.theory.iter_theory_summaries`): a normal exit would wait for them (up
    to 8 s measured), and the interpreter's teardown while XLA is busy in another thread could crash (a segfault
    was seen on Ctrl-C during `jaxroll pdf`). Nothing is lost: outputs and checkpoints are written atomically."""
    signal.signal(signal.SIGINT, _on_interrupt)
    code = main()
    if code == 130:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    console()
