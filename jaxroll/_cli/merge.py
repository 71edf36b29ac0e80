"""`jaxroll merge`: one long-term result from the partial datasets of `jaxroll longterm --part i/N`."""

from __future__ import annotations

import time
from pathlib import Path

from ._common import CLIError


def register(sub) -> None:
    p = sub.add_parser(
        "merge",
        help="merge the partial datasets of `jaxroll longterm --part i/N` into the whole result",
        description="Reads the N partial datasets (longterm.part-i-of-N.nc) of one `jaxroll longterm` run split "
        "with --part (e.g. the tasks of a SLURM job array), checks that they are the parts 1 … N of one "
        "configuration, unchanged since they were written (each carries a digest of its content and "
        "configuration) and written by this jaxroll and JAX, and writes the result a single run writes into --out: "
        "longterm.nc with the same variables, coordinates and attributes, bit for bit (not the same bytes: the file "
        "itself records when it was made), longterm.json (its run_time_s: the parts' run times summed) and the "
        "figures.",
    )
    p.add_argument("parts", nargs="+", metavar="PART.nc", help="the partial datasets, in any order")
    p.add_argument(
        "--out", default="jaxroll-out/longterm", help="output folder (default jaxroll-out/longterm)"
    )
    p.set_defaults(func=run)


def run(args) -> int:
    from .. import merge_longterm
    from ..io import read_dataset
    from .longterm import print_summary, write_outputs

    out = Path(args.out)  # checked writable before the command ran (`prepare_out`)
    datasets = []
    for name in args.parts:
        path = Path(name)
        if not path.is_file():
            raise CLIError(f"{name}: no such file (a partial dataset of `jaxroll longterm --part i/N`).")
        try:
            datasets.append(read_dataset(path))
        except (OSError, ValueError) as e:
            raise CLIError(f"{name}: not a netCDF dataset ({type(e).__name__}: {e}).") from None
        if "part" not in datasets[-1].attrs:
            raise CLIError(f"{name} is not a partial dataset of `jaxroll longterm --part i/N`.")
    t0 = time.time()
    try:
        ds = merge_longterm(datasets, names=args.parts)
    except ValueError as e:
        raise CLIError(str(e)) from None
    times = [d.attrs.get("run_time_s") for d in datasets]
    run_time = float(sum(times)) if all(isinstance(t, int | float) for t in times) else None
    summary = write_outputs(ds, out, run_time)
    print(f"merged {len(datasets)} parts in {time.time() - t0:.1f} s")
    print_summary(summary, out)
    return 0
