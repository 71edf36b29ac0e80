"""Tank data as labs keep it: delimited text tables of any layout and HDF5 datasets, read into jaxroll records.

A lab's file has its own column names, units, delimiter, decimal mark and preamble, often several extra channels,
and may be at model or full scale. `import_record` reads the columns it is told (by name or number), takes each
column's unit from the header (`Roll [deg]`, `WP1 (mm)`, or a row of units under the names) or from `units=`,
applies Froude scaling, and returns a `Record` validated with the same checks and messages as `load_record`
(docs/records.md, "Importing lab files"). Nothing is guessed silently: a unit that is neither in the file nor
given, a name that matches no column, or two readings of the layout that disagree are errors that say what to
give.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ._lab_units import read_units_file
from ._records import (
    _FROUDE_POWER,
    _NUMERIC_KEYS,
    COLUMN_UNITS,
    FORMAT_VERSION,
    RECORD_COLUMNS,
    Record,
    _check_header,
    _check_roll_range,
    _check_time,
    _err,
    _parse_number,
    read_text_bytes,
)

#: Units a lab file may use, per quantity: alias (lower case) -> (the record format's unit, factor to it).
LAB_UNITS: dict[str, dict[str, tuple[str, float]]] = {
    "time": {
        "s": ("s", 1.0),
        "sec": ("s", 1.0),
        "second": ("s", 1.0),
        "seconds": ("s", 1.0),
        "ms": ("s", 1e-3),
        "min": ("s", 60.0),
    },
    "angle": {
        "deg": ("deg", 1.0),
        "degree": ("deg", 1.0),
        "degrees": ("deg", 1.0),
        "°": ("deg", 1.0),
        "rad": ("rad", 1.0),
        "radian": ("rad", 1.0),
        "radians": ("rad", 1.0),
        "mrad": ("rad", 1e-3),
    },
    "length": {"m": ("m", 1.0), "cm": ("mm", 10.0), "mm": ("mm", 1.0)},
}
_QUANTITY = {"time": "time", "roll": "angle", "wave": "length", "delta_gm": "length"}
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf", ".he5", ".mat")
_DELIMITERS = (
    ";",
    "\t",
    ",",
    "|",
    " ",
)  # in order of preference when more than one reads the data consistently
_COMMENT = ("#", "%", "//")
_UNIT_IN_NAME = re.compile(r"^(?P<name>.*?)\s*[\[(]\s*(?P<unit>[^\])]*?)\s*[\])]\s*$")
_NUMBER = re.compile(
    r"^[+-]?(\d+([.,]\d*)?|[.,]\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf|infinity)$", re.IGNORECASE
)


def _normal_unit(text: str) -> str:
    return text.strip().strip("[]()").strip().lower()


def _known_unit(text: str) -> bool:
    unit = _normal_unit(text)
    return any(unit in table for table in LAB_UNITS.values()) or unit in ("-", "")


@dataclasses.dataclass(frozen=True)
class LabTable:
    """A delimited text file as read: column names and units from its header, raw fields per data row.

    - `source`: the file; `names`: the column names without their units (None when the file has no header row);
      `units`: each column's unit as the header gives it (None where it gives none).
    - `rows`: the data rows' fields (text); `lines`: the 1-based file line of each row.
    - `layout`: what was found or given: `delimiter`, `decimal`, `header_line`, `units_line`, `first_data_line`,
      `encoding`.
    """

    source: str
    names: tuple[str, ...] | None
    units: tuple[str | None, ...]
    rows: list[list[str]]
    lines: np.ndarray
    layout: Mapping[str, Any]

    @property
    def n_columns(self) -> int:
        """Number of columns."""
        return len(self.units)

    def describe(self) -> str:
        """The columns as the header gives them, e.g. `1 Time [s], 2 Roll [deg], 3 WP1 [mm]`."""
        names = self.names or tuple("" for _ in self.units)
        return ", ".join(
            f"{i + 1} {n}{f' [{u}]' if u else ''}".rstrip() for i, (n, u) in enumerate(zip(names, self.units))
        )


def _read_text(path: Path) -> tuple[str, str]:
    data = read_text_bytes(path)  # at most MAX_TEXT_BYTES (a gzip bomb is refused after reading that much)
    if b"\x00" in data[:4096]:
        raise _err(
            str(path), None, "not a text file (it holds NUL bytes); an HDF5 file is read by its datasets."
        )
    try:
        return data.decode("utf-8-sig"), "utf-8"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"  # labs' Windows exports (° in cp1252 is Latin-1's)


def _splitter(delimiter: str):
    if delimiter == " ":
        return lambda lines: [line.split() for line in lines]
    return lambda lines: [[f.strip() for f in row] for row in csv.reader(lines, delimiter=delimiter)]


def _is_comment(line: str) -> bool:
    return line.lstrip().startswith(_COMMENT)


def _sniff_delimiter(lines: list[str], source: str) -> str:
    """The first delimiter (in the order of `_DELIMITERS`) that splits most of the file's last lines (its data) into
    mostly numeric rows of one number (≥ 2) of fields."""
    tail = [ln for ln in lines if ln.strip() and not _is_comment(ln)][-50:]
    if not tail:
        raise _err(source, None, "the file holds no data lines.")
    for d in _DELIMITERS:
        counts = [len(r) for r in _splitter(d)(tail) if len(r) >= 2 and _numeric_share(r) > 0.5]
        if len(counts) >= 0.5 * len(tail):
            mode = max(set(counts), key=counts.count)
            if counts.count(mode) >= 0.9 * len(counts):
                return d
    return " "  # one column (or fields of varying number: reported with the line where they change)


def _numeric_share(fields: list[str]) -> float:
    return sum(bool(_NUMBER.match(f)) for f in fields) / max(len(fields), 1)


def _sniff_decimal(rows: list[list[str]], delimiter: str, source: str) -> str:
    if delimiter == ",":
        return "."
    fields = [f for row in rows[:200] for f in row]
    comma = any(re.match(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$", f) for f in fields)
    point = any(re.match(r"^[+-]?\d*\.\d+([eE][+-]?\d+)?$", f) for f in fields)
    if comma and point:
        raise _err(
            source,
            None,
            "the data hold numbers with a decimal point and numbers with a decimal comma; give the decimal mark "
            "(decimal=',' or '.'; CLI --decimal).",
        )
    return "," if comma else "."


def read_lab_table(
    path: str | Path,
    *,
    delimiter: str | None = None,
    decimal: str | None = None,
    header_row: int | None = None,
    skip_rows: int | None = None,
) -> LabTable:
    """Read a delimited text file of tank data as a lab writes it (the layout is found, or given).

    **Arguments:**

    - `path`: a text file (`.csv`, `.txt`, `.dat`, …, or any of them `.gz`), UTF-8 or Latin-1.
    - `delimiter`: the field separator (`";"`, `","`, `"\\t"`, `"|"`, or `" "` for runs of spaces); default: the
      one that splits the data lines into a constant number of fields (preferring `;`, tab, `,`, `|`, spaces).
    - `decimal`: the decimal mark, `"."` or `","`; default: `","` when the data hold numbers like `0,25` (and the
      delimiter is not a comma), else `"."`.
    - `header_row`: the 1-based line that holds the column names (lines above it are a preamble); `0`: the file
      has no column names (columns are then given by number). Default: the line above the first data line (or
      above a row of units under the names).
    - `skip_rows`: the number of preamble lines before the column names (instead of `header_row`).

    A header cell may carry its unit, `Time [s]` or `Roll (deg)`; a row of units right under the names
    (`s;deg;mm`) is read too. Comment lines (`#`, `%`, `//`) and blank lines may precede the header.

    **Raises:** `RecordError` (a `ValueError`) naming the file, the line and the problem; `FileNotFoundError`.
    """
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise FileNotFoundError(f"Lab file {source!r} does not exist.")
    if header_row is not None and skip_rows is not None:
        raise ValueError("give either header_row or skip_rows, not both (skip_rows=N is header_row=N+1).")
    if header_row is not None and header_row < 0:
        raise ValueError(f"header_row must be >= 0 (0: no header row); got {header_row}.")
    if skip_rows is not None and skip_rows < 0:
        raise ValueError(f"skip_rows must be >= 0; got {skip_rows}.")
    if decimal not in (None, ".", ","):
        raise ValueError(f"decimal must be '.' or ','; got {decimal!r}.")
    if delimiter is not None and (len(delimiter) != 1 or delimiter in "\r\n\"'"):
        raise ValueError(f"delimiter must be one character (e.g. ';', ',', '\\t'); got {delimiter!r}.")
    text, encoding = _read_text(path)
    lines = text.splitlines()
    if skip_rows is not None:
        header_row = skip_rows + 1
    if header_row is not None and header_row > len(lines):
        raise _err(
            source, None, f"header row {header_row} is beyond the end of the file ({len(lines)} lines)."
        )
    delim = delimiter if delimiter is not None else _sniff_delimiter(lines, source)
    split = _splitter(delim)
    fields = split(lines)
    end = len(lines)
    while end > 0 and not lines[end - 1].strip():
        end -= 1
    tail = [len(f) for f, ln in zip(fields[:end], lines[:end]) if ln.strip() and not _is_comment(ln)][-50:]
    ncol = max(set(tail), key=tail.count) if tail else 0

    def data_like(i: int) -> bool:
        return (
            bool(lines[i].strip())
            and not _is_comment(lines[i])
            and len(fields[i]) == ncol
            and (_numeric_share(fields[i]) > 0.5)
        )

    units_line = None
    if header_row is None or header_row == 0:
        first = None
        for i in range(end):
            if data_like(i) and all(data_like(j) for j in range(i + 1, min(i + 6, end - 1))):
                first = i
                break
        if first is None:
            raise _err(
                source,
                None,
                f"found no data: no run of lines with {ncol} numeric fields (delimiter "
                f"{delim!r}); give the delimiter and the header row (CLI --delimiter, --header-row).",
            )
        header = None
        if header_row is None:
            above = first - 1
            if (
                above >= 0
                and len(fields[above]) == ncol
                and lines[above].strip()
                and not _is_comment(lines[above])
            ):
                if (
                    all(_known_unit(f) for f in fields[above])
                    and above >= 1
                    and len(fields[above - 1]) == ncol
                ):
                    units_line, header = above, above - 1
                else:
                    header = above
    else:
        header = header_row - 1
        first = header + 1
        if first < end and len(fields[first]) == ncol and _numeric_share(fields[first]) <= 0.5:
            if all(_known_unit(f) for f in fields[first]):
                units_line, first = first, first + 1
        if header >= end or not lines[header].strip():
            raise _err(
                source, header_row, "the header row is blank; give the line that holds the column names."
            )
        if len(fields[header]) != ncol:
            raise _err(
                source,
                header_row,
                f"the header row has {len(fields[header])} fields but the data have {ncol} (delimiter {delim!r}); "
                "check the header row and the delimiter.",
            )
    names = units = None
    if header is not None:
        names, units = [], []
        for cell in fields[header]:
            m = _UNIT_IN_NAME.match(cell)
            names.append(m.group("name").strip() if m else cell.strip())
            units.append(m.group("unit").strip() if m and m.group("unit").strip() else None)
        if units_line is not None:
            for j, u in enumerate(fields[units_line]):
                u = _normal_unit(u)
                if u and u != "-":
                    if units[j] is not None and _normal_unit(units[j]) != u:
                        raise _err(
                            source,
                            units_line + 1,
                            f"column `{names[j]}`: the unit row says {u!r} but the header says {units[j]!r}.",
                        )
                    units[j] = u
    rows, linenos = [], []
    for i in range(first, end):
        lineno = i + 1
        if not lines[i].strip():
            raise _err(source, lineno, "blank line inside the data (gaps are not allowed).")
        if _is_comment(lines[i]):
            raise _err(source, lineno, "comment line inside the data; the header must come before the data.")
        if len(fields[i]) != ncol:
            if i == end - 1 and len(fields[i]) < ncol:
                raise _err(
                    source, lineno, f"truncated file: the last line has {len(fields[i])} of {ncol} columns."
                )
            raise _err(
                source, lineno, f"expected {ncol} columns (delimiter {delim!r}); got {len(fields[i])}."
            )
        rows.append(fields[i])
        linenos.append(lineno)
    dec = decimal if decimal is not None else _sniff_decimal(rows, delim, source)
    if dec == "," and delim == ",":
        raise ValueError("decimal ',' needs another delimiter than ','.")
    layout = {
        "delimiter": delim,
        "decimal": dec,
        "header_line": None if header is None else header + 1,
        "units_line": None if units_line is None else units_line + 1,
        "first_data_line": first + 1,
        "encoding": encoding,
    }
    return LabTable(
        source,
        None if names is None else tuple(names),
        tuple(units) if units is not None else (None,) * ncol,
        rows,
        np.asarray(linenos, dtype=int),
        layout,
    )


def _column_index(table: LabTable, spec: str | int, role: str) -> int:
    """The 0-based column `spec` names: a header name (without or with its unit, case-insensitive if unique), or
    a 1-based column number."""
    where = f"line {table.layout['header_line']}" if table.names is not None else "no header row"
    if table.names is not None and not isinstance(spec, int):
        text = str(spec).strip()
        full = [f"{n} [{u}]" if u else n for n, u in zip(table.names, table.units)]
        for candidates, fold in ((table.names, False), (full, False), (table.names, True), (full, True)):
            hits = [i for i, n in enumerate(candidates) if (n.lower() == text.lower() if fold else n == text)]
            if len(hits) == 1:
                return hits[0]
            if len(hits) > 1:
                raise _err(
                    table.source,
                    table.layout["header_line"],
                    f"column name {text!r} ({role}) matches columns {', '.join(str(h + 1) for h in hits)}; "
                    "give the column by number.",
                )
    try:
        number = int(spec)
    except (TypeError, ValueError):
        number = None
    if number is not None and 1 <= number <= table.n_columns:
        return number - 1
    raise _err(
        table.source,
        table.layout["header_line"],
        f"no column {spec!r} for `{role}` (columns, {where}: {table.describe()}); give one of these names or a "
        "column number (1 = first).",
    )


def _resolve_unit(
    role: str, label: str, from_file: str | None, given: str | None, source: str, line: int | None
) -> tuple[str, float, str]:
    """(the record format's unit, factor to it, the unit as read) of one column."""
    quantity = _QUANTITY[role]
    table = LAB_UNITS[quantity]
    choices = ", ".join(dict.fromkeys(table))

    def parse(text: str, where: str) -> tuple[str, float]:
        unit = _normal_unit(text)
        if unit not in table:
            raise _err(
                source,
                line,
                f"unit {text!r} of column {label} ({where}) is not understood; a {role} column takes "
                f"{choices}.",
            )
        return table[unit]

    if given is None and from_file is None:
        example = {"time": "s", "roll": "deg", "wave": "mm", "delta_gm": "mm"}[role]
        raise _err(
            source,
            line,
            f"column {label} has no unit in the file; state it: units={{'{role}': '{example}'}} "
            f"(CLI --units {role}={example}); a {role} column takes {choices}.",
        )
    if given is not None:
        native, factor = parse(given, "given")
        if from_file is not None and parse(from_file, "in the file") != (native, factor):
            raise _err(
                source,
                line,
                f"column {label}: the file says its unit is {from_file!r} but {given!r} was given; leave the "
                "unit out, or correct it.",
            )
        return native, factor, given
    native, factor = parse(from_file, "in the file")
    return native, factor, from_file


def _split_hdf5(path: str | Path) -> tuple[Path, str | None] | None:
    """(file, group) when `path` names an HDF5 file, optionally as `FILE:/group`; None for a text file."""
    text = str(path)
    p = Path(text)
    if not p.is_file() and ":" in text:
        head, _, group = text.rpartition(":")
        if Path(head).is_file() and group.startswith("/"):
            return Path(head), group
    if p.is_file():
        with open(p, "rb") as f:
            magic = f.read(8)
        if magic == _HDF5_MAGIC or p.suffix.lower() in _HDF5_SUFFIXES:
            return p, None
    return None


def _hdf5_columns(path: Path, group: str | None, specs: Mapping[str, str]) -> tuple[str, dict]:
    """Read the 1-D datasets `specs` (role -> dataset path, relative to `group` or absolute) of an HDF5 file.

    Returns (source, {role: (values, unit from the dataset's `units`/`unit` attribute or None, label)})."""
    import h5py

    source = f"{path}:{group}" if group else str(path)
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise _err(
            str(path), None, f"not a readable HDF5 file ({e}); is it complete (not truncated)?"
        ) from None
    with f:
        base = f
        if group:
            if group in f and isinstance(f[group], h5py.Dataset):
                parent, _, name = group.rpartition("/")
                raise _err(
                    str(path),
                    None,
                    f"{group!r} is a dataset; name the group, {path}:{parent or '/'}, and the "
                    f"datasets as columns (e.g. roll={name!r}; CLI --roll {name}).",
                )
            if group not in f or not isinstance(f[group], h5py.Group):
                top = ", ".join(f"/{k}" for k in f.keys())
                raise _err(
                    str(path), None, f"no group {group!r} in the file (top level: {top or 'nothing'})."
                )
            base = f[group]
        out = {}
        for role, spec in specs.items():
            spec = str(spec)
            node = f if spec.startswith("/") else base
            name = spec if spec.startswith("/") else f"{base.name.rstrip('/')}/{spec}"
            if spec not in node or not isinstance(node[spec], h5py.Dataset):
                there = ", ".join(k for k in base.keys()) or "nothing"
                raise _err(
                    source,
                    None,
                    f"no dataset {spec!r} for `{role}` ({base.name} holds: {there}); give a dataset path, relative "
                    "to the group or absolute (/run3/roll).",
                )
            ds = node[spec]
            shape = tuple(d for d in ds.shape if d != 1)
            if len(shape) != 1 or ds.dtype.kind not in "iuf":
                raise _err(
                    source,
                    None,
                    f"dataset {name} ({role}) must be a 1-D array of numbers; it has shape {ds.shape} and type "
                    f"{ds.dtype}.",
                )
            unit = None
            for key in ("units", "unit", "Units", "Unit", "UNITS"):
                if key in ds.attrs:
                    value = np.asarray(ds.attrs[key]).ravel()[0]
                    unit = value.decode() if isinstance(value, bytes) else str(value)
                    break
            out[role] = (np.asarray(ds[()], dtype=float).reshape(-1), unit, f"`{name}` ({role})")
    return source, out


def import_record(
    path: str | Path,
    kind: str,
    *,
    time: str | int | None = None,
    roll: str | int | None = None,
    wave: str | int | None = None,
    delta_gm: str | int | None = None,
    units: Mapping[str, str] | None = None,
    units_file: str | Path | None = None,
    scale: float,
    full_scale: bool = False,
    sampling_hz: float | None = None,
    resample: bool = False,
    delimiter: str | None = None,
    decimal: str | None = None,
    header_row: int | None = None,
    skip_rows: int | None = None,
    min_samples: int = 16,
    **meta: Any,
) -> Record:
    """Read a lab's file of tank data into a `Record` (full scale, SI), as `load_record` returns a record file.

    **Arguments:**

    - `path`: a delimited text file (layout found by `read_lab_table`, or given by `delimiter`, `decimal`,
      `header_row`, `skip_rows`), or an HDF5 file, `FILE.h5` or `FILE.h5:/group`, whose 1-D datasets are named
      by path (relative to the group, or absolute: `/run3/roll`).
    - `kind`: `"decay"` (needs `roll`), `"captive"` (`wave`, `delta_gm`) or `"roll"` (`roll`, `wave`).
    - `time`, `roll`, `wave`, `delta_gm`: the columns (a header name, with or without its unit, or a 1-based
      column number) or datasets. Without `time`, the samples are taken as uniform at `sampling_hz` from t = 0.
    - `units`: units by column (`{"roll": "deg", "wave": "mm"}`) where the file gives none; time s, ms or min;
      roll deg or rad (mrad); wave and delta_gm m, cm or mm. A unit given here that contradicts the file's is
      an error.
    - `units_file`: a side file of two rows, the column names and their units (`read_units_file`), for a file
      whose header has names but no units; a column is looked up by its name, else by its position.
    - `scale`: λ ≥ 1 of the model (1 for full-scale data).
    - `full_scale`: the file's time and lengths are already full scale (default: model scale, as tank records
      are); the record is kept at model scale λ all the same.
    - `sampling_hz`: the sampling rate [Hz, at the file's scale]; default: from the time column's median step.
    - `resample`, `min_samples`: as `load_record`.
    - `**meta`: the record's header entries (docs/records.md): a captive or roll record needs
      `wave_height_full_m`, `wave_period_full_s`, `probe_x_model_m`, `speed_model_m_s` (captive also
      `heel_deg`).

    **Returns:** the `Record`; `meta["imported_from"]` says which file, columns and units it came from.

    **Raises:** `RecordError` (a `ValueError`) naming the file, the line (HDF5: the sample) and the problem — an
    unknown column, a unit not understood or missing, NaN or text in a column, a truncated last line, time that
    does not increase, gaps, too few samples — with the messages of `load_record`; `FileNotFoundError`.
    """
    if kind not in RECORD_COLUMNS:
        raise ValueError(f"`kind` must be one of {', '.join(RECORD_COLUMNS)}; got {kind!r}.")
    wanted = RECORD_COLUMNS[kind][1:]
    given = {"roll": roll, "wave": wave, "delta_gm": delta_gm}
    missing = [c for c in wanted if given[c] is None]
    if missing:
        raise ValueError(
            f"a {kind} record needs the column(s) {', '.join(wanted)}; give {', '.join(f'{c}=' for c in missing)} "
            f"(CLI {' '.join('--' + c.replace('_', '-') for c in missing)})."
        )
    extra = [c for c, v in given.items() if v is not None and c not in wanted]
    if extra:
        raise ValueError(f"a {kind} record has no {' or '.join(extra)} column; leave {', '.join(extra)} out.")
    units = dict(units or {})
    unknown = [k for k in units if k not in ("time", *wanted)]
    if unknown:
        raise ValueError(
            f"units given for {', '.join(map(repr, unknown))}: a {kind} record's columns are "
            f"{', '.join(('time',) + wanted)}."
        )
    if not (isinstance(scale, int | float) and math.isfinite(scale) and scale >= 1):
        raise ValueError(
            f"scale must be a number >= 1 (λ: model = full/λ; 1 for full-scale data); got {scale!r}."
        )
    if sampling_hz is not None and not (math.isfinite(sampling_hz) and sampling_hz > 0):
        raise ValueError(f"sampling_hz must be > 0 [Hz]; got {sampling_hz!r}.")
    if time is None and sampling_hz is None:
        raise ValueError(
            "without a time column (time=), give the sampling rate (sampling_hz=; CLI --sampling-hz)."
        )
    if time is None and "time" in units:
        raise ValueError("units for `time` given, but no time column (time=).")
    specs = {r: s for r, s in (("time", time), *((c, given[c]) for c in wanted)) if s is not None}
    # --- the columns, in the file's units ---
    hdf5 = _split_hdf5(path)
    columns: dict[str, np.ndarray] = {}
    labels: dict[str, str] = {}
    names: dict[str, str] = {}
    file_units: dict[str, str | None] = {}
    if hdf5 is not None:
        source, data = _hdf5_columns(*hdf5, specs)
        lengths = {role: v.size for role, (v, _, _) in data.items()}
        n = max(lengths.values())
        for role, (values, unit, label) in data.items():
            if values.size != n:
                longest = max(lengths, key=lengths.get)
                raise _err(
                    source,
                    None,
                    f"truncated data: {label} has {values.size} samples, {data[longest][2]} has {n}; every column "
                    "needs one value per sample.",
                )
            bad = np.nonzero(~np.isfinite(values))[0]
            if bad.size:
                i = int(bad[0])
                what = (
                    "is NaN (gaps and missing values are not allowed)"
                    if np.isnan(values[i])
                    else (f"is not finite ({values[i]})")
                )
                raise _err(source, i + 1, f"{label} {what}.")
            columns[role], file_units[role], labels[role] = values, unit, label
            names[role] = label.split("`")[1]
        lines = np.arange(1, n + 1)
        where = {role: None for role in specs}
        layout = "HDF5"
    else:
        table = read_lab_table(
            path, delimiter=delimiter, decimal=decimal, header_row=header_row, skip_rows=skip_rows
        )
        source = table.source
        for role, spec in specs.items():
            j = _column_index(table, spec, role)
            name = table.names[j] if table.names is not None else f"{j + 1}"
            labels[role] = f"`{name}` ({role})" if table.names is not None else f"{j + 1} ({role})"
            names[role] = name if table.names is not None else f"column {j + 1}"
            file_units[role] = table.units[j]
            label = f"column {labels[role]}"
            dec = table.layout["decimal"]
            raw = [row[j] for row in table.rows]
            try:
                values = np.array([r.replace(dec, ".") if dec != "." else r for r in raw], dtype=float)
                ok = bool(np.all(np.isfinite(values))) and "" not in raw
            except ValueError:
                ok = False
            if not ok:  # find the first bad field, for its message
                for field, lineno in zip(raw, table.lines):
                    _parse_number(label, field, source, int(lineno), dec)
            columns[role] = values
        lines = table.lines
        where = {role: table.layout["header_line"] for role in specs}
        layout = f"delimiter {table.layout['delimiter']!r}, decimal {table.layout['decimal']!r}" + (
            f", header line {table.layout['header_line']}" if table.layout["header_line"] else ", no header"
        )
    # --- units, scale, sampling ---
    if units_file is not None:
        side = read_units_file(units_file)
        folded = {k.lower(): v for k, v in side.items()}
        for role in specs:
            if file_units[role] is None:
                position = f"#{_column_index(table, specs[role], role) + 1}" if hdf5 is None else None
                file_units[role] = (
                    side.get(names[role]) or folded.get(names[role].lower()) or side.get(position)
                )
                if file_units[role] is None and units.get(role) is None:
                    listed = ", ".join(k for k in side if not k.startswith("#"))
                    raise _err(
                        str(units_file),
                        None,
                        f"no unit for column {labels[role]} of {source}: the units file names {listed}; add the "
                        f"column there, or give its unit (CLI --units {role}=…).",
                    )
    record_units, factors, read_units = {}, {}, {}
    for role in specs:
        native, factor, read = _resolve_unit(
            role, f"{labels[role]}", file_units[role], units.get(role), source, where[role]
        )
        record_units[role], factors[role], read_units[role] = native, factor, read
    model = {}
    lam = float(scale)
    for role, values in columns.items():
        v = values if factors[role] == 1.0 else values * factors[role]
        model[role] = v / lam ** _FROUDE_POWER[role] if full_scale and lam != 1.0 else v
    n = next(iter(model.values())).size
    if n < min_samples:
        raise _err(
            source,
            int(lines[-1]) if n else None,
            f"too few samples: {n} data rows (at least {min_samples} needed).",
        )
    fs = None if sampling_hz is None else float(sampling_hz) * (math.sqrt(lam) if full_scale else 1.0)
    if "time" in model:
        t = model["time"] * COLUMN_UNITS["time"][record_units["time"]]
        if fs is None:
            steps = np.diff(t)
            if not np.median(steps) > 0:
                _check_time(t, lines, 1.0, source, False)  # names the first step that does not increase
            fs = float(f"{1.0 / float(np.median(steps)):.6g}")
        resampled = _check_time(t, lines, fs, source, resample)
    else:
        record_units["time"], resampled = "s", False
        model["time"] = np.arange(n) / fs
    unit_list = [record_units[c] for c in RECORD_COLUMNS[kind]]
    origin = ", ".join(f"{role} = {names[role]} [{read_units[role]}]" for role in specs)
    for key in _NUMERIC_KEYS & meta.keys():
        try:
            meta[key] = float(meta[key])
        except (TypeError, ValueError):
            raise ValueError(f"header entry `{key}` must be a number; got {meta[key]!r}.") from None
    header = {
        "format_version": FORMAT_VERSION,
        "scale": lam,
        "sampling_hz": fs,
        "units": unit_list,
        **meta,
        "imported_from": f"{source} ({origin}; {layout}; {'full' if full_scale else 'model'} scale)",
    }
    _check_header(kind, header, dict.fromkeys(header), source, None)
    data = np.column_stack([model[c] for c in RECORD_COLUMNS[kind]])
    if resampled:
        dt = 1.0 / fs
        t = data[:, 0]
        m = int(math.floor((t[-1] - t[0]) / dt * (1 + 1e-9))) + 1
        grid = t[0] + dt * np.arange(m)
        data = np.column_stack([grid] + [np.interp(grid, t, data[:, j]) for j in range(1, data.shape[1])])
        lines = lines[np.clip(np.searchsorted(t, grid), 0, t.size - 1)]
        header["resampled"] = "linear interpolation onto 1/sampling_hz (import_record resample=True)"
    full = {
        name: data[:, j] * COLUMN_UNITS[name][unit] * lam ** _FROUDE_POWER[name]
        for j, (name, unit) in enumerate(zip(RECORD_COLUMNS[kind], unit_list))
    }
    if "roll" in full:
        _check_roll_range(
            full["roll"], read_units["roll"], source, "give units={'roll': 'deg'}; CLI --units roll=deg"
        )
    time_full = full.pop("time")
    return Record(kind, time_full, full, lam, header, source, None if hdf5 is not None else lines)


def describe_lab_file(
    path: str | Path,
    *,
    delimiter: str | None = None,
    decimal: str | None = None,
    header_row: int | None = None,
    skip_rows: int | None = None,
) -> str:
    """What a lab file holds, as text: a text file's layout (delimiter, decimal mark, header and data lines) and
    columns with their units and ranges; an HDF5 file's datasets with their shapes and `units` attributes.
    The names it prints are what `import_record` (CLI `jaxroll records import`) takes."""
    hdf5 = _split_hdf5(path)
    if hdf5 is not None:
        import h5py

        file, group = hdf5
        try:
            f = h5py.File(file, "r")
        except OSError as e:
            raise _err(
                str(file), None, f"not a readable HDF5 file ({e}); is it complete (not truncated)?"
            ) from None
        out = [f"{file}: HDF5"]
        with f:
            base = f[group] if group and group in f else f

            def visit(name, node):
                if isinstance(node, h5py.Dataset):
                    unit = next(
                        (node.attrs[k] for k in ("units", "unit", "Units", "Unit") if k in node.attrs), None
                    )
                    unit = unit.decode() if isinstance(unit, bytes) else unit
                    out.append(
                        f"  {node.name}  shape {node.shape}, {node.dtype}"
                        + (f", units {unit}" if unit else "")
                    )
                else:
                    out.append(f"  {node.name}/")

            base.visititems(visit)
        return "\n".join(out)
    t = read_lab_table(path, delimiter=delimiter, decimal=decimal, header_row=header_row, skip_rows=skip_rows)
    lay = t.layout
    out = [
        f"{t.source}: text ({lay['encoding']}), delimiter {lay['delimiter']!r}, decimal {lay['decimal']!r}; "
        + (f"column names on line {lay['header_line']}" if lay["header_line"] else "no column names")
        + (f", units on line {lay['units_line']}" if lay["units_line"] else "")
        + f"; data on lines {lay['first_data_line']}–{int(t.lines[-1]) if t.lines.size else lay['first_data_line']}"
        f" ({len(t.rows)} rows)"
    ]
    for j in range(t.n_columns):
        name = t.names[j] if t.names is not None else ""
        unit = f" [{t.units[j]}]" if t.units[j] else " (no unit)"
        fields = [row[j] for row in t.rows]
        try:
            v = np.array([x.replace(lay["decimal"], ".") for x in fields], dtype=float)
            span = f"{np.nanmin(v):.6g} … {np.nanmax(v):.6g}" if v.size else "empty"
        except ValueError:
            span = "text"
        out.append(f"  {j + 1:>3}  {name}{unit}: {span}")
    return "\n".join(out)
