"""`jaxroll records import|inspect`: a lab's files of tank data (CSV of any layout, HDF5 datasets) read into jaxroll
records (docs/records.md, "Importing lab files"), and what such a file holds."""

from __future__ import annotations

import gzip
from pathlib import Path

from ._common import CLIError, OutputFolder, atomic_write_bytes
from ._lab import add_lab_options, delimiter_arg, header_row_arg, import_lab_files, lab_settings


def register(sub) -> None:
    p = sub.add_parser(
        "records",
        help="tank data as labs keep it: import lab files (CSV, HDF5) as jaxroll records; inspect them",
        description="Reads a lab's files of tank data into jaxroll records (docs/records.md).",
    )
    cmds = p.add_subparsers(dest="records_command", metavar="SUBCOMMAND", required=True)
    imp = cmds.add_parser(
        "import",
        help="read lab files (CSV of any layout, HDF5 datasets) into jaxroll records",
        description="Reads each FILE (a delimited text file: delimiter, decimal mark, header row, units in the "
        "header such as 'Roll [deg]' found or given; or an HDF5 file, FILE.h5 or FILE.h5:/group, with datasets "
        "named by path) and writes it as a jaxroll record (model scale, docs/records.md), after the checks "
        "`jaxroll calibrate` makes. `jaxroll calibrate` takes the same options and reads lab files directly.",
    )
    imp.add_argument(
        "files",
        nargs="+",
        metavar="FILE",
        help="lab files: text (.csv, .txt, … .gz) or HDF5 (FILE.h5, FILE.h5:/group)",
    )
    imp.add_argument("--kind", choices=("decay", "captive", "roll"), required=True, help="what the test is")
    imp.add_argument(
        "--out",
        default=None,
        help="output folder (default ./jaxroll-out/records), or a .csv / .csv.gz file name for one FILE",
    )
    imp.add_argument("--gzip", action="store_true", help="write .csv.gz")
    imp.add_argument(
        "--start",
        type=float,
        default=None,
        metavar="S",
        help="keep the samples from this time [s, model scale: the file's own time] (default: the first)",
    )
    imp.add_argument(
        "--stop",
        type=float,
        default=None,
        metavar="S",
        help="keep the samples up to this time [s, model scale: the file's own time] (default: the last)",
    )
    imp.add_argument(
        "--resample",
        action="store_true",
        help="interpolate irregularly sampled data onto the nominal rate (gaps are still refused)",
    )
    add_lab_options(imp, for_calibrate=False)
    imp.set_defaults(func=run_import)
    ins = cmds.add_parser(
        "inspect",
        help="show a lab file's layout and columns (text) or datasets (HDF5): the names `import` takes",
        description="Prints what a lab file holds as jaxroll reads it: delimiter, decimal mark, the line of the "
        "column names, each column with its unit and range; for HDF5 every dataset with its shape and units.",
    )
    ins.add_argument("files", nargs="+", metavar="FILE")
    ins.add_argument("--delimiter", default=None, help="field separator (default: sniffed)")
    ins.add_argument("--decimal", choices=(".", ","), default=None, help="decimal mark (default: found)")
    ins.add_argument(
        "--header-row", default=None, metavar="N", help="1-based line of the column names; 0: none"
    )
    ins.add_argument(
        "--skip-rows", type=int, default=None, metavar="N", help="preamble lines before the names"
    )
    ins.set_defaults(func=run_inspect)


def _output_names(files, gz: bool) -> list[str]:
    suffix = ".csv.gz" if gz else ".csv"
    names = []
    for f in files:
        text = str(f)
        path, _, group = text.rpartition(":") if ":" in text and not Path(text).exists() else (text, "", "")
        stem = Path(path).name
        for ext in (".gz", ".csv", ".txt", ".dat", ".tsv", ".h5", ".hdf5", ".hdf", ".he5", ".mat"):
            if stem.lower().endswith(ext):
                stem = stem[: -len(ext)]
        if group.strip("/"):
            stem += "_" + group.strip("/").replace("/", "_")
        names.append(stem + suffix)
    clash = sorted({n for n in names if names.count(n) > 1})
    if clash:
        raise CLIError(f"two FILEs would be written as {clash[0]}; import them into separate --out folders.")
    return names


def run_import(args) -> int:
    from ..io import record_to_text

    settings = lab_settings(args, args.kind)
    out = Path(args.out or "jaxroll-out/records")
    single = out.name.endswith((".csv", ".csv.gz"))
    if single and len(args.files) != 1:
        raise CLIError(
            f"--out {str(out)!r} names one file but {len(args.files)} FILEs are given; give a folder."
        )
    records = import_lab_files(args.files, args.kind, settings, resample=args.resample)
    if args.start is not None or args.stop is not None:
        records = [r.window(args.start, args.stop) for r in records]
    texts = [record_to_text(r, decimals="shortest") for r in records]
    if single:
        data = texts[0].encode()
        atomic_write_bytes(out, gzip.compress(data, mtime=0) if out.name.endswith(".gz") else data)
        written = [out]
    else:
        names = _output_names(args.files, args.gzip)
        with OutputFolder(out) as tmp:
            for name, text in zip(names, texts):
                (tmp / name).write_bytes(
                    gzip.compress(text.encode(), mtime=0) if args.gzip else text.encode()
                )
        written = [out / n for n in names]
    for rec, path in zip(records, written):
        n = rec.time.size
        cols = ", ".join(f"{c} [{u}]" for c, u in zip(("time", *rec.channels), rec.meta["units"]))
        print(
            f"wrote {path}: {rec.kind} record, {n} samples at {rec.meta['sampling_hz']:g} Hz model scale, "
            f"{rec.model_time[-1] - rec.model_time[0]:.6g} s model = {rec.time[-1] - rec.time[0]:.6g} s full scale "
            f"(λ = {rec.scale:g}); {cols}"
        )
        if rec.kind == "decay":
            from ..calibration import find_release

            i = find_release(rec)
            print(
                f"  release found at {rec.model_time[i]:.3f} s model scale ({rec.time[i]:.1f} s full scale); "
                "`jaxroll calibrate decay` analyses from there (or from --start)"
            )
    return 0


def run_inspect(args) -> int:
    from ..io import describe_lab_file

    header_row = header_row_arg(args.header_row)
    delimiter = delimiter_arg(args.delimiter)
    for f in args.files:
        print(
            describe_lab_file(
                f, delimiter=delimiter, decimal=args.decimal, header_row=header_row, skip_rows=args.skip_rows
            )
        )
    return 0
