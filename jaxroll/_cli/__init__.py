"""The `jaxroll` command line: parses arguments, calls the public API, writes files. No numerics here.

Each subcommand lives in its own module of this package and exposes `register(subparsers)`, which adds its
parser and sets `func=run(args) -> int` as the default. Modules are discovered, so adding a subcommand touches
no other file.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence


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
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    from ._common import CLIError

    try:
        return int(args.func(args) or 0)
    except CLIError as e:
        print(f"jaxroll {args.command}: error: {e}", file=sys.stderr)
        return 2
    except (ValueError, FileNotFoundError) as e:
        print(f"jaxroll {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
