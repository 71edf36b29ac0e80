"""The `jaxroll` console script: Ctrl-C handled from the command's first instant.

`import jaxroll` takes 1–4 s (JAX, XLA and the package), and the command's own Ctrl-C handling
(`jaxroll._cli.console`) can only be installed once that import is done: a Ctrl-C meanwhile ended in a
`KeyboardInterrupt` traceback. This module lies outside the package and uses the standard library only, so it
installs the handling before anything heavy is imported: a Ctrl-C while the command starts prints one line and
exits with code 130 (nothing has been written yet). `python -m jaxroll` imports the package first and has no such
guard during that import.
"""

import gc
import os
import signal
import sys


def _interrupted(signum, frame) -> None:
    words = [a for a in sys.argv[1:] if not a.startswith("-")]
    sys.stderr.write(
        f"jaxroll{' ' + words[0] if words else ''}: interrupted while starting; nothing was written.\n"
    )
    sys.stderr.flush()
    os._exit(130)


def main() -> None:
    """The `jaxroll` command (`jaxroll._cli.console`, imported under the Ctrl-C guard). A process started with
    Ctrl-C ignored (a background job of a script) keeps ignoring it."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _interrupted)
    gc.disable()  # the imports make almost no garbage; `console` turns collection back on when the command runs
    from jaxroll._cli import console

    console()


if __name__ == "__main__":  # pragma: no cover
    main()
