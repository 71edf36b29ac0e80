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
import time
import warnings
from collections.abc import Sequence

# The LAPACK that jaxlib calls on the CPU is SciPy's OpenBLAS, which starts a thread per core; on the small matrices
# of jaxroll's theories those threads only contend with XLA's own (a warm `jaxroll theory` took 5.8–8 s instead of
# 3.4–3.7 s on a 2-core machine with another job running; no difference when idle). One thread, unless set.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The `jaxroll` parser with every subcommand, or with `command`'s alone (the one being run: the others' modules
    and what they import are not loaded; `jaxroll --help` and a mistyped command get them all)."""
    from .. import __version__

    parser = argparse.ArgumentParser(
        prog="jaxroll",
        description="Parametric roll of ships in long-crested irregular waves (Katsumura et al., arXiv 2407.02728).",
    )
    parser.add_argument("--version", action="version", version=f"jaxroll {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in [command] if command in _commands() else _commands():
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


def _commands() -> list[str]:
    """The subcommands: the public modules of this package."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_"))


def _command_word(argv: Sequence[str] | None) -> str | None:
    """The subcommand named on the command line: its first word, where no option comes before it (`jaxroll -h`,
    `jaxroll --version`: None)."""
    words = list(sys.argv[1:] if argv is None else argv)
    return words[0] if words and not words[0].startswith("-") else None


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `jaxroll` command. Returns the process exit code."""
    try:
        # the CLI only writes files, never needs a display: Agg, set without importing matplotlib (a command that
        # draws no figure does not load it)
        if "matplotlib" in sys.modules:
            sys.modules["matplotlib"].use("Agg")
        else:
            os.environ["MPLBACKEND"] = "Agg"
        parser = build_parser(_command_word(argv))
    except KeyboardInterrupt:  # Ctrl-C while the command starts: nothing has been written
        print(_starting_interrupted(argv), file=sys.stderr)
        return 130
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    for name, value in sorted(
        vars(args).items()
    ):  # `jaxroll records import: error: …`, not `jaxroll records: …`
        if name.endswith("_command") and isinstance(value, str):
            args.command = f"{args.command} {value}"
    from .. import configure
    from ._common import COMMAND_LINE, WARNINGS

    WARNINGS.clear()
    COMMAND_LINE[:] = ["jaxroll", *(sys.argv[1:] if argv is None else argv)]
    try:
        with warnings.catch_warnings():
            warnings.showwarning = functools.partial(_warning_line, args.command)
            # The command's own process, set up fully: float64, XLA:CPU's platform-independent math and small loops
            # compiled whole, one JAX device per CPU core (docs/architecture.md, "Process-wide settings").
            configure()
            return _run(args)
    finally:  # a command's warnings and words are its own: none left for what runs next in this process
        WARNINGS.clear()
        COMMAND_LINE.clear()


def _warning_line(command: str, message, category, filename, lineno, file=None, line=None) -> None:
    """A warning of the library (or of the libraries under it) as the command shows it: one line on stderr,
    `jaxroll COMMAND: warning: …` (no source path or code line; a message already shown is not shown again), and
    kept for the JSON it writes (`warnings`)."""
    from ._common import WARNINGS

    text = str(message)
    if text not in WARNINGS:  # once: a check made before the computation and again inside it says it once
        print(f"jaxroll {command}: warning: {text}", file=sys.stderr)
    WARNINGS.append(text)


def _run(args) -> int:
    """The command's `func`, its errors as one line and exit code 2, Ctrl-C as 130. `--out` is checked first (a
    folder it can write, the debris of an earlier killed run cleared), before any computation; the compilation
    cache is switched on (JAXROLL_CACHE_DIR, default ~/.cache/jaxroll/xla; empty: off; refused, with a warning,
    where others could write to it)."""
    from .. import enable_compilation_cache
    from ..io import clear_interrupt
    from ._common import CLIError, check_folder, os_error_message, prepare_out

    if (
        signal.getsignal(signal.SIGINT) is _exit_at_once
    ):  # the `jaxroll` command: its Ctrl-C handling from now
        signal.signal(signal.SIGINT, _on_interrupt)
    if _STATE[
        "collector_paused"
    ]:  # the `jaxroll` command (`console`): what was imported stays, collect the rest
        _STATE["collector_paused"] = None
        gc.freeze()
        gc.enable()
    clear_interrupt()
    try:
        if getattr(args, "out", None) is not None:
            prepare_out(args.out)
        if getattr(args, "checkpoint", None) is not None:
            check_folder(args.checkpoint, "--checkpoint")
        enable_compilation_cache()
        return int(args.func(args) or 0)
    except CLIError as e:
        print(f"jaxroll {args.command}: error: {e}", file=sys.stderr)
        return 2
    except (ValueError, FileNotFoundError) as e:
        print(f"jaxroll {args.command}: error: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # a folder that cannot be written, a full disk, …: one line, not a traceback
        print(
            f"jaxroll {args.command}: error: {os_error_message(e, getattr(args, 'checkpoint', None))}",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        from ._common import interrupted_message

        clear_interrupt()
        print(interrupted_message(args.command, getattr(args, "out", None)), file=sys.stderr)
        return 130


def _on_interrupt(signum, frame) -> None:
    """Ctrl-C: `KeyboardInterrupt`, as Python's own handler — except inside a garbage-collector callback (JAX has
    one), where Python would ignore the exception (print it and carry on: the command would not stop); there the
    signal is raised again once the callback has returned (`_raise_again`)."""
    callbacks = {getattr(cb, "__code__", None) for cb in gc.callbacks}
    now = time.monotonic()
    while frame is not None:
        if frame.f_code in callbacks:
            with _LOCK:
                if _STATE["raised"] is not None and now - _STATE["raised"] < 1.0:
                    return  # a repeat of the Ctrl-C just raised (`_raise_again`'s, in flight)
                start = _STATE["deferred"] is None
                _STATE["deferred"] = now
            if start:
                threading.Thread(target=_raise_again, daemon=True).start()
            return
        frame = frame.f_back
    with _LOCK:
        echo = _STATE["raised"] is not None and now - _STATE["raised"] < 1.0 and _STATE["deferred"] is None
        _STATE["raised"], _STATE["deferred"] = now, None  # (no deferred signal: `_raise_again` stops)
    if echo:  # a repeat sent by `_raise_again` just as the first was raised (the command is reporting it)
        return
    from ..io import note_interrupt  # (imported by `_run` already: a look-up)

    note_interrupt()  # raised again at the next save where this one is lost (raised in a finaliser)
    raise KeyboardInterrupt


_STATE: dict[str, float | bool | None] = {
    "deferred": None,
    "raised": None,
    "collector_paused": None,
}  # when a Ctrl-C was deferred / last raised; whether `console` paused the garbage collector (True)
_LOCK = threading.Lock()


def _raise_again() -> None:
    """SIGINT to the main thread itself (so that a blocking call there, a wait or a sleep, is interrupted too),
    every 0.2 s until the handler has raised `KeyboardInterrupt` (for 10 s at most). More than once: a signal that
    lands after the main thread's last check and before it enters a blocking call is seen only when that call
    returns (the suite's `time.sleep(20)` then ran to its end under load: 'interrupted after 20.06 s')."""
    time.sleep(0.05)
    for _ in range(50):
        with _LOCK:
            if _STATE["deferred"] is None:
                return
        if hasattr(signal, "pthread_kill"):
            signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)
        else:  # pragma: no cover  (Windows)
            signal.raise_signal(signal.SIGINT)
        time.sleep(0.2)
    with _LOCK:
        _STATE["deferred"] = None


def _exit_at_once(signum, frame) -> None:
    """Ctrl-C before the command has started (imports, parsing): one line, exit code 130 at once (nothing has been
    written). The `jaxroll` console script (`_jaxroll_console`) installs the same before `import jaxroll`."""
    sys.stdout.flush()
    print(_starting_interrupted(None), file=sys.stderr, flush=True)
    os._exit(130)


def _starting_interrupted(argv: Sequence[str] | None) -> str:
    """The line printed on Ctrl-C while the command starts (its name read from the arguments, where there is one)."""
    words = [a for a in (sys.argv[1:] if argv is None else argv) if not a.startswith("-")]
    return f"jaxroll{' ' + words[0] if words else ''}: interrupted while starting; nothing was written."


def console() -> None:  # pragma: no cover  (the console script; tests call `main`)
    """The `jaxroll` command: `main()`, and after Ctrl-C (exit code 130) an immediate exit. The theories' programs
    compile in background threads (`jaxroll.theory.iter_theory_summaries`): a normal exit would wait for them (up
    to 8 s measured), and the interpreter's teardown while XLA is busy in another thread could crash (a segfault
    was seen on Ctrl-C during `jaxroll pdf`). Nothing is lost: outputs and checkpoints are written atomically.
    Ctrl-C while the command starts (importing, parsing) exits at once with one line (`_exit_at_once`); once it
    runs, `_on_interrupt` turns Ctrl-C into `KeyboardInterrupt`, reported by `main`. A process started with Ctrl-C
    ignored (a background job of a script) keeps ignoring it.

    Python's cyclic garbage collector is paused while the command starts (its imports, 200 000 objects with JAX,
    matplotlib and xarray, make almost no garbage, but each full collection walked them all: 0.1–0.2 s) and the
    objects they made are frozen when it runs (`gc.freeze`: collections look at what the command makes), and frozen
    again at the end: the interpreter's teardown collects what it frees, and walked every object once more (0.2–0.5
    s of a 3 s command on a 2-core CPU; the memory goes back with the process)."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _exit_at_once)
    gc.disable()
    _STATE["collector_paused"] = True
    code = main()
    if code == 130:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    gc.freeze()
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    console()
