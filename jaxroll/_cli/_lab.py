"""Options that read a lab's file of tank data (CSV of any layout, HDF5 datasets) as a jaxroll record, shared by
`jaxroll records import` and `jaxroll calibrate` (docs/records.md, "Importing lab files")."""

from __future__ import annotations

import math

from ._common import CLIError

_DELIMITER_NAMES = {"tab": "\t", "\\t": "\t", "space": " ", "whitespace": " ", "semicolon": ";", "comma": ","}
#: The options that only describe a lab file (they need a column option).
LAB_ONLY = (
    "units",
    "units_file",
    "scale",
    "full_scale",
    "sampling_hz",
    "delimiter",
    "decimal",
    "header_row",
    "skip_rows",
    "hs",
    "t01",
    "probe_x",
    "speed",
    "heel",
)
_COLUMN_OPTIONS = ("time", "roll", "wave", "delta_gm")


def add_lab_options(parser, *, for_calibrate: bool) -> None:
    """The options of a lab file: its columns, units, scale, layout and the record's metadata."""
    how = (
        "with any of these, the RECORD files are a lab's files read with them (one layout for all) instead of "
        "jaxroll record files"
        if for_calibrate
        else None
    )
    g = parser.add_argument_group("lab file: columns and units", how)
    g.add_argument(
        "--time",
        metavar="COL",
        default=None,
        help="time column: a header name (with or without its unit) or a 1-based number; HDF5: a "
        "dataset path (relative to FILE:/group, or absolute). Without it, --sampling-hz from t = 0",
    )
    g.add_argument("--roll", metavar="COL", default=None, help="roll column (decay, roll)")
    g.add_argument("--wave", metavar="COL", default=None, help="wave-probe column (captive, roll)")
    g.add_argument("--delta-gm", metavar="COL", default=None, help="ΔGM column (captive)")
    g.add_argument(
        "--units",
        default=None,
        metavar="UNITS",
        help="units the file does not state, e.g. 'roll=deg,wave=mm' (or 's,deg,mm' in the order "
        "time, then the record's columns); time s|ms|min, roll deg|rad|mrad, lengths m|cm|mm",
    )
    g.add_argument(
        "--units-file",
        default=None,
        metavar="FILE",
        help="a side file of two rows, the column names and then their units (e.g. 'time,x,phi' over 's,m,rad'), "
        "for a data file whose header names its columns without units",
    )
    g.add_argument(
        "--scale",
        type=float,
        default=None,
        metavar="λ",
        help="model scale λ >= 1 (1: full-scale data); Froude scaling (docs/conventions.md)",
    )
    g.add_argument(
        "--full-scale",
        action="store_true",
        help="the file's time and lengths are already full scale (default: model scale)",
    )
    g.add_argument(
        "--sampling-hz",
        type=float,
        default=None,
        help="sampling rate [Hz, at the file's scale] (default: from the time column)",
    )
    lay = parser.add_argument_group("lab file: layout (found by default)")
    lay.add_argument(
        "--delimiter",
        default=None,
        help="field separator: ';' ',' '|' tab or space (default: sniffed from the data)",
    )
    lay.add_argument(
        "--decimal",
        choices=(".", ","),
        default=None,
        help="decimal mark (default: ',' when the data hold numbers like 0,25)",
    )
    lay.add_argument(
        "--header-row",
        default=None,
        metavar="N",
        help="1-based line holding the column names; 0 or none: no names (columns by number)",
    )
    lay.add_argument(
        "--skip-rows",
        type=int,
        default=None,
        metavar="N",
        help="preamble lines before the column names (instead of --header-row)",
    )
    sea = parser.add_argument_group("lab file: the test (written into the record's header)")
    sea.add_argument(
        "--hs", type=float, default=None, help="captive, roll: H1/3 of the ITTC sea [m, full scale]"
    )
    sea.add_argument("--t01", type=float, default=None, help="captive, roll: T01 [s, full scale]")
    sea.add_argument(
        "--probe-x",
        type=float,
        default=None,
        help="captive, roll: wave probe ahead of amidships [m, model scale]",
    )
    sea.add_argument(
        "--speed",
        type=float,
        default=None,
        help="captive, roll: model speed [m/s, model scale] (default 0; head seas)",
    )
    sea.add_argument("--heel", type=float, default=None, help="captive: the fixed heel [deg]")


def lab_mode(args) -> bool:
    """Whether the files are lab files (a column option or --sampling-hz given). Other lab options without a
    column are refused."""
    if any(getattr(args, o) is not None for o in ("roll", "wave", "delta_gm")):
        return True
    given = [o for o in ("time", *LAB_ONLY) if getattr(args, o) not in (None, False)]
    if given:
        names = ", ".join("--" + o.replace("_", "-") for o in given)
        raise CLIError(
            f"{names}: options of a lab file; give its columns too (--roll, --wave, --delta-gm), or leave them out "
            "for jaxroll record files."
        )
    return False


def _units(text: str | None, kind: str) -> dict[str, str]:
    from ..io import RECORD_COLUMNS

    if text is None:
        return {}
    columns = RECORD_COLUMNS[kind]
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if parts and all("=" in p for p in parts):
        units = {}
        for p in parts:
            key, _, unit = p.partition("=")
            key = key.strip().replace("-", "_")
            if key not in columns:
                raise CLIError(f"--units: {key!r} is not a column of a {kind} record ({', '.join(columns)}).")
            if key in units:  # the last one won without a word (issue 45)
                raise CLIError(
                    f"--units gives {key} twice ({units[key]}, {unit.strip()}): give each column's unit once."
                )
            units[key] = unit.strip()
        return units
    if parts and not any("=" in p for p in parts) and len(parts) == len(columns):
        return dict(zip(columns, parts))
    raise CLIError(
        f"--units: give 'COLUMN=UNIT,…' (e.g. roll=deg,wave=mm) or one unit per column of a {kind} record in "
        f"the order {', '.join(columns)}; got {text!r}."
    )


def header_row_arg(text: str | None) -> int | None:
    """--header-row: a line number >= 0, or `none` (0: the file has no column names)."""
    if text is None:
        return None
    if str(text).strip().lower() == "none":
        return 0
    try:
        row = int(text)
    except ValueError:
        raise CLIError(f"--header-row must be a line number (0 or none: no header); got {text!r}.") from None
    if row < 0:
        raise CLIError(f"--header-row must be >= 0; got {row}.")
    return row


def delimiter_arg(text: str | None) -> str | None:
    """--delimiter: one character, or tab, space, semicolon, comma by name."""
    if text is None:
        return None
    delimiter = _DELIMITER_NAMES.get(text.lower(), text)
    if len(delimiter) != 1:
        raise CLIError(f"--delimiter must be one character (or tab, space); got {text!r}.")
    return delimiter


def lab_settings(args, kind: str) -> dict:
    """The checked keyword arguments of `jaxroll.io.import_record` for these options (CLIError on a bad one)."""

    def finite(name, value):
        if value is not None and not math.isfinite(value):
            raise CLIError(f"--{name} must be a finite number; got {value}.")

    for name in ("scale", "sampling-hz", "hs", "t01", "probe-x", "speed", "heel"):
        finite(name, getattr(args, name.replace("-", "_")))
    if args.scale is None:
        raise CLIError("--scale: give the model scale λ of the lab file (1 for full-scale data).")
    if args.scale < 1:
        raise CLIError(
            f"--scale must be >= 1 (λ: model = full/λ; 1 for full-scale data); got {args.scale:g}."
        )
    if args.sampling_hz is not None and not args.sampling_hz > 0:
        raise CLIError(f"--sampling-hz must be > 0 [Hz]; got {args.sampling_hz:g}.")
    if args.time is None and args.sampling_hz is None:
        raise CLIError("--time: give the time column, or --sampling-hz for a file without one (time from 0).")
    header_row = header_row_arg(args.header_row)
    if header_row is not None and args.skip_rows is not None:
        raise CLIError("--header-row and --skip-rows: give one (--skip-rows N is --header-row N+1).")
    if args.skip_rows is not None and args.skip_rows < 0:
        raise CLIError(f"--skip-rows must be >= 0; got {args.skip_rows}.")
    delimiter = delimiter_arg(args.delimiter)
    meta = {}
    if kind == "decay":
        given = [
            f"--{o.replace('_', '-')}"
            for o in ("hs", "t01", "probe_x", "speed", "heel")
            if getattr(args, o) is not None
        ]
        if given:
            raise CLIError(f"{', '.join(given)}: a decay record has no sea state or heel; leave them out.")
    else:
        missing = [f"--{o.replace('_', '-')}" for o in ("hs", "t01", "probe_x") if getattr(args, o) is None]
        if kind == "captive" and args.heel is None:
            missing.append("--heel")
        if missing:
            raise CLIError(
                f"{', '.join(missing)}: a {kind} record needs the test's sea state (--hs, --t01: full scale), the "
                f"wave probe's position (--probe-x: m ahead of amidships, model scale)"
                + (" and the heel (--heel, deg)" if kind == "captive" else "")
                + "."
            )
        for name in ("hs", "t01"):
            if not getattr(args, name) > 0:
                raise CLIError(f"--{name} must be > 0 (full scale); got {getattr(args, name):g}.")
        speed = 0.0 if args.speed is None else args.speed
        if speed < 0:
            raise CLIError(f"--speed must be >= 0 [m/s, model scale] (head seas); got {speed:g}.")
        meta = {
            "wave_height_full_m": args.hs,
            "wave_period_full_s": args.t01,
            "probe_x_model_m": args.probe_x,
            "speed_model_m_s": speed,
        }
        if kind == "captive":
            if not 0 <= args.heel < 90:
                raise CLIError(f"--heel must be in [0, 90) [deg]; got {args.heel:g}.")
            meta["heel_deg"] = args.heel
        elif args.heel is not None:
            raise CLIError("--heel: only a captive record has a fixed heel; leave it out.")
    return {
        "time": args.time,
        "roll": args.roll,
        "wave": args.wave,
        "delta_gm": args.delta_gm,
        "units": _units(args.units, kind),
        "units_file": args.units_file,
        "scale": args.scale,
        "full_scale": args.full_scale,
        "sampling_hz": args.sampling_hz,
        "delimiter": delimiter,
        "decimal": args.decimal,
        "header_row": header_row,
        "skip_rows": args.skip_rows,
        **meta,
    }


def import_lab_files(files, kind: str, settings: dict, *, resample: bool) -> list:
    """Each lab file read as a record of `kind` (every file checked before anything is written or computed)."""
    from ..io import import_record

    return [import_record(f, kind, resample=resample, **settings) for f in files]
