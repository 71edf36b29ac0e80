"""Tank records: the file format, validating loaders and writers (the only file-format code besides the CLI).

A record is a CSV file at **model scale** with a `#`-comment header of metadata (format: docs/records.md):

    # jaxroll-record: roll
    # format_version: 1
    # scale: 100
    # sampling_hz: 20
    # units: s, deg, mm
    # wave_height_full_m: 7.0
    # wave_period_full_s: 10.0
    # probe_x_model_m: 0.0
    # speed_model_m_s: 0.0
    time,roll,wave
    0.0000,5.0000,-12.345
    ...

Three kinds, with their columns: `decay` (time, roll), `captive` (time, wave, delta_gm) and `roll` (time,
roll, wave). `time` counts seconds from the release of the model (decay) or from the start of the wave maker
(captive, roll), so the paper's analysis window 70–340 s is in these model-scale seconds.

Loaders convert to **full scale, SI** (Froude, scale λ: length ×λ, time ×√λ, angles unchanged) and refuse a
bad record with a `RecordError` (a `ValueError`) that names the file, the line and the problem. Nothing is
dropped or repaired silently: irregular sampling is resampled only when asked (`resample=True`), and never
across a gap.
"""

from __future__ import annotations

import dataclasses
import gzip
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

FORMAT_VERSION = 1

#: Columns of each record kind, in file order.
RECORD_COLUMNS: dict[str, tuple[str, ...]] = {
    "decay": ("time", "roll"),
    "captive": ("time", "wave", "delta_gm"),
    "roll": ("time", "roll", "wave"),
}

#: Accepted units of each column and the factor to SI (before Froude scaling).
COLUMN_UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0},
    "roll": {"deg": math.pi / 180, "rad": 1.0},
    "wave": {"m": 1.0, "mm": 1e-3},
    "delta_gm": {"m": 1.0, "mm": 1e-3},
}

#: Froude exponent of each column: full = model · λ^p.
_FROUDE_POWER = {"time": 0.5, "roll": 0.0, "wave": 1.0, "delta_gm": 1.0}

_COMMON_KEYS = ("format_version", "scale", "sampling_hz", "units")
_SEA_KEYS = ("wave_height_full_m", "wave_period_full_s", "probe_x_model_m", "speed_model_m_s")
#: Header keys every record of a kind must carry.
REQUIRED_KEYS: dict[str, tuple[str, ...]] = {
    "decay": _COMMON_KEYS,
    "captive": _COMMON_KEYS + _SEA_KEYS + ("heel_deg",),
    "roll": _COMMON_KEYS + _SEA_KEYS,
}
_NUMERIC_KEYS = {
    "format_version",
    "scale",
    "sampling_hz",
    "wave_height_full_m",
    "wave_period_full_s",
    "probe_x_model_m",
    "speed_model_m_s",
    "heel_deg",
    "initial_roll_deg",
    "realization",
}
_KNOWN_STRING_VALUES = {"spectrum": ("ITTC",), "heading": ("head",)}

#: The longest full-scale interval between samples of a record [s]: roll periods are 5–30 s at full scale and a
#: cycle needs several samples; a slower record is a time column in another unit (ms read as s).
MAX_FULL_SCALE_INTERVAL_S = 5.0
#: Relative tolerance on the sampling interval (jitter beyond it is "irregular sampling").
SAMPLING_RTOL = 0.02
#: A step longer than this many nominal intervals is a gap (refused even with `resample=True`).
GAP_FACTOR = 1.5


class RecordError(ValueError):
    """A tank record that cannot be used; the message names the file, the line and the problem."""


def _err(source: str, line: int | None, problem: str) -> RecordError:
    where = f"{source}:{line}" if line is not None else source
    return RecordError(f"{where}: {problem}")


@dataclasses.dataclass(frozen=True)
class Record:
    """One tank record at **full scale, SI** (converted from the model-scale file on load).

    - `kind`: "decay", "captive" or "roll".
    - `time` [s, full scale]: from the release (decay) or the start of the wave maker (captive, roll).
    - `channels`: full-scale SI arrays: `roll` [rad], `wave` [m] (elevation at the probe), `delta_gm` [m].
    - `scale`: λ (model = full / λ); `meta`: the header as parsed (model-scale values where the key says
      `_model_`, full scale where it says `_full_`); `source`: the file, for messages; `lines`: the file line
      of each sample (for messages; None for records built in memory).
    """

    kind: str
    time: np.ndarray
    channels: Mapping[str, np.ndarray]
    scale: float
    meta: Mapping[str, Any]
    source: str = "<memory>"
    lines: np.ndarray | None = None

    # --- convenient views (full scale, SI) ---
    def _channel(self, name: str) -> np.ndarray:
        if name not in self.channels:
            raise RecordError(f"{self.source}: a {self.kind} record has no `{name}` column.")
        return self.channels[name]

    @property
    def roll(self) -> np.ndarray:
        """Roll angle φ [rad]."""
        return self._channel("roll")

    @property
    def wave(self) -> np.ndarray:
        """Wave elevation at the probe [m, full scale]."""
        return self._channel("wave")

    @property
    def delta_gm(self) -> np.ndarray:
        """Measured GM variation ΔGM at the fixed heel [m, full scale]."""
        return self._channel("delta_gm")

    @property
    def dt(self) -> float:
        """Sampling interval [s, full scale]."""
        return math.sqrt(self.scale) / float(self.meta["sampling_hz"])

    @property
    def model_time(self) -> np.ndarray:
        """Time [s, model scale]."""
        return self.time / math.sqrt(self.scale)

    @property
    def wave_height(self) -> float:
        """H1/3 of the sea [m, full scale]."""
        return float(self._meta("wave_height_full_m"))

    @property
    def wave_period(self) -> float:
        """T01 of the sea [s, full scale]."""
        return float(self._meta("wave_period_full_s"))

    @property
    def probe_x(self) -> float:
        """Wave-probe position relative to amidships, positive towards the bow [m, full scale]."""
        return float(self._meta("probe_x_model_m")) * self.scale

    @property
    def speed(self) -> float:
        """Ship speed [m/s, full scale] (Froude: ×√λ)."""
        return float(self._meta("speed_model_m_s")) * math.sqrt(self.scale)

    @property
    def heel(self) -> float:
        """Fixed heel of a captive test [rad]."""
        return math.radians(float(self._meta("heel_deg")))

    @property
    def sea_state(self) -> tuple[float, float]:
        """(H1/3 [m], T01 [s]) at full scale."""
        return (self.wave_height, self.wave_period)

    def to_xarray(self):
        """The record as an `xarray.Dataset` at full scale, SI: its channels (`roll` [rad], `wave` [m], `delta_gm`
        [m]) on the dimension `time` [s, full scale], with `model_time` [s, model scale] and the file's `line`
        (records read from a file) as coordinates; `kind`, `scale`, `source` and the header (`meta`, lists and
        mappings as JSON text) in the attributes."""
        import json

        from .._labels import labelled_values, to_jsonable

        names = {
            "roll": ("rad", "roll angle φ (positive to starboard)"),
            "wave": ("m", "wave elevation at the probe"),
        }
        names["delta_gm"] = ("m", "measured GM variation ΔGM at the fixed heel")
        coords = {
            "time": (
                ("time",),
                self.time,
                "s",
                "time, full scale (from the release or the wave maker's start)",
            ),
            "model_time": (("time",), self.model_time, "s", "time, model scale"),
        }
        if self.lines is not None:
            coords["line"] = (("time",), self.lines, "1", "line of the sample in the record's file")
        attrs = {"kind": self.kind, "scale": float(self.scale), "source": self.source}
        for key, value in self.meta.items():
            value = to_jsonable(value)
            attrs[f"meta_{key}"] = value if isinstance(value, int | float | str) else json.dumps(value)
        return labelled_values(
            {k: (("time",), v, *names.get(k, ("1", k))) for k, v in self.channels.items()}, attrs, coords
        )

    def _meta(self, key: str):
        if key not in self.meta:
            raise RecordError(f"{self.source}: header key `{key}` is missing.")
        return self.meta[key]

    def check_model_time(self, t_model_s: float, name: str) -> None:
        """`RecordError` (naming `name`, e.g. "start") unless `t_model_s` [s, model scale, the record's own time]
        lies within the record (half a sample's tolerance)."""
        tm = self.model_time
        tol = 0.5 / float(self.meta["sampling_hz"])
        if not (tm[0] - tol <= t_model_s <= tm[-1] + tol):
            raise RecordError(
                f"{self.source}: {name} = {t_model_s:g} s (model scale) is outside the record, which covers "
                f"{tm[0]:.3f}–{tm[-1]:.3f} s model scale ({self.time[0]:.1f}–{self.time[-1]:.1f} s full scale)."
            )

    def window(self, start_model_s: float | None, stop_model_s: float | None) -> Record:
        """The samples with start ≤ t ≤ stop, the bounds in **model-scale seconds** of the record's own time (the
        paper's 70–340 s; the time scale of every start, stop and window jaxroll takes); None: the record's first
        (last) sample.

        **Raises:** `RecordError` if the record does not cover the window (it names the last line)."""
        t_model = self.model_time
        tol = 0.5 / float(self.meta["sampling_hz"])
        if start_model_s is None or stop_model_s is None:  # one bound given: it must lie in the record
            for name, v in (("start", start_model_s), ("stop", stop_model_s)):
                if v is not None:
                    self.check_model_time(v, name)
        start_model_s = float(t_model[0]) if start_model_s is None else start_model_s
        stop_model_s = float(t_model[-1]) if stop_model_s is None else stop_model_s
        if not stop_model_s > start_model_s:
            raise RecordError(
                f"{self.source}: analysis window {start_model_s}–{stop_model_s} s is empty "
                "(stop must be > start)."
            )
        if t_model[0] > start_model_s + tol or t_model[-1] < stop_model_s - tol:
            last = f"line {int(self.lines[-1])}" if self.lines is not None else "the last sample"
            raise _err(
                self.source,
                int(self.lines[-1]) if self.lines is not None else None,
                f"record too short for the requested analysis window: it covers {t_model[0]:.3f}–"
                f"{t_model[-1]:.3f} s model scale (ends at {last}) but the window is {start_model_s:g}–"
                f"{stop_model_s:g} s model scale ({start_model_s * math.sqrt(self.scale):.1f}–"
                f"{stop_model_s * math.sqrt(self.scale):.1f} s full scale).",
            )
        keep = (t_model >= start_model_s - tol) & (t_model <= stop_model_s + tol)
        return dataclasses.replace(
            self,
            time=self.time[keep],
            channels={k: v[keep] for k, v in self.channels.items()},
            lines=None if self.lines is None else self.lines[keep],
        )


# ------------------------------------------------------------------------------------------------------------
# Building and writing
# ------------------------------------------------------------------------------------------------------------


def make_record(
    kind: str,
    time,
    channels: Mapping[str, Any],
    *,
    scale: float,
    sampling_hz: float,
    units: Sequence[str] | None = None,
    source: str = "<memory>",
    **meta: Any,
) -> Record:
    """Build a `Record` in memory from **full-scale SI** arrays (time [s], roll [rad], wave [m], delta_gm
    [m]).

    `sampling_hz` is the model-scale sampling rate (the full-scale interval is √λ/`sampling_hz`); `units` are
    the units the file will use when saved (default: s, deg for roll, mm for wave and ΔGM); the other keyword
    arguments become header entries (e.g. `wave_height_full_m=7.0`, `heel_deg=5.0`).
    """
    if kind not in RECORD_COLUMNS:
        raise ValueError(f"`kind` must be one of {sorted(RECORD_COLUMNS)}; got {kind!r}.")
    columns = RECORD_COLUMNS[kind]
    if units is None:
        units = [{"time": "s", "roll": "deg", "wave": "mm", "delta_gm": "mm"}[c] for c in columns]
    if set(channels) != set(columns[1:]):
        raise ValueError(f"a {kind} record needs channels {list(columns[1:])}; got {sorted(channels)}.")
    time = np.asarray(time, dtype=float)
    chans = {k: np.asarray(v, dtype=float) for k, v in channels.items()}
    for k, v in chans.items():
        if v.shape != time.shape:
            raise ValueError(f"channel `{k}` has shape {v.shape}; `time` has {time.shape}.")
    header = {
        "format_version": FORMAT_VERSION,
        "scale": float(scale),
        "sampling_hz": float(sampling_hz),
        "units": list(units),
        **meta,
    }
    missing = [k for k in REQUIRED_KEYS[kind] if k not in header]
    if missing:
        raise ValueError(f"a {kind} record needs header entries {missing}.")
    return Record(kind, time, chans, float(scale), header, source)


def _format_number(value: float, decimals: int) -> str:
    s = f"{value:.{decimals}f}"
    return "0." + "0" * decimals if s.lstrip("-").strip("0.") == "" else s


def _shortest_decimals(values: np.ndarray, most: int = 12) -> int:
    """The fewest digits after the point that write every value back to itself (to float round-off from the
    unit and scale conversions), at most `most`."""
    tol = 8 * np.spacing(np.abs(values))
    for d in range(most):
        if np.all(np.abs(np.round(values, d) - values) <= tol):
            return d
    return most


def record_to_text(record: Record, *, decimals: Mapping[str, int] | str | None = None) -> str:
    """The record as file text (model scale, the units in `record.meta["units"]`).

    `decimals`: digits after the point per column name (defaults by unit: s 4, deg 4, rad 6, mm 3, m 6), or
    `"shortest"`: per column, the fewest digits (at most 12) that write every value exactly as it was read (what
    `import_record`'s records are written with, so that nothing is rounded away)."""
    columns = RECORD_COLUMNS[record.kind]
    units = list(record.meta["units"])
    lam = record.scale
    default_dec = {"s": 4, "deg": 4, "rad": 6, "mm": 3, "m": 6}
    lines = [f"# jaxroll-record: {record.kind}"]
    order = ["format_version", "scale", "sampling_hz", "units"]
    for key in order + [k for k in record.meta if k not in order]:
        value = record.meta[key]
        if key == "units":
            value = ", ".join(units)
        elif isinstance(value, float) and value.is_integer():
            value = int(value)
        lines.append(f"# {key}: {value}")
    lines.append(",".join(columns))
    cols = []
    for name, unit in zip(columns, units):
        raw = record.time if name == "time" else record.channels[name]
        model = raw / lam ** _FROUDE_POWER[name] / COLUMN_UNITS[name][unit]
        if decimals == "shortest":
            dec = _shortest_decimals(model)
        else:
            dec = (decimals or {}).get(name, default_dec[unit])
        cols.append([_format_number(v, dec) for v in model])
    lines.extend(",".join(row) for row in zip(*cols))
    return "\n".join(lines) + "\n"


def save_record(record: Record, path: str | Path, **kwargs) -> Path:
    """Write `record` to `path` (model scale; gzip-compressed when the name ends in `.gz`). Returns the
    path."""
    path = Path(path)
    text = record_to_text(record, **kwargs)
    data = gzip.compress(text.encode(), mtime=0) if path.suffix == ".gz" else text.encode()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


# ------------------------------------------------------------------------------------------------------------
# Loading and validation
# ------------------------------------------------------------------------------------------------------------


#: The most text a record file (or a lab's text file) may hold, decompressed [bytes]: parsing keeps about 30 bytes
#: per byte of text in memory, so a file at the limit stays under 1 GiB; a record of the paper's protocol is ~0.1 MiB
#: (a 1 MiB `.csv.gz` expanding to 256 MiB took 5.6 GiB, issue 45). Read in blocks: a larger file, or a gzip bomb,
#: is refused after reading at most this much.
MAX_TEXT_BYTES = 24 * 2**20


def read_text_bytes(path: Path) -> bytes:
    """The bytes of a text file, gunzipped where its name ends in `.gz`, at most `MAX_TEXT_BYTES` (checked on the
    file's size first, then while decompressing). **Raises:** `RecordError` naming the file for a larger file or an
    unreadable gzip file."""
    limit = MAX_TEXT_BYTES
    too_big = (
        f"more than {limit / 2**20:g} MiB of text{' once decompressed' if path.suffix == '.gz' else ''}: far more "
        "than a tank record (10^5 samples of three channels are ~3 MiB); split it into realizations, or check that "
        "it is the file meant."
    )
    if path.stat().st_size > limit:
        raise _err(str(path), None, too_big)
    if path.suffix != ".gz":
        with open(path, "rb") as f:
            data = f.read(limit + 1)
    else:
        try:
            with gzip.open(path, "rb") as f:
                data = f.read(limit + 1)
        except (OSError, EOFError) as e:
            raise _err(str(path), None, f"not a readable gzip file ({e}).") from None
    if len(data) > limit:
        raise _err(str(path), None, too_big)
    return data


def _read_text(path: Path) -> str:
    if not path.is_file():
        raise FileNotFoundError(f"Record file {str(path)!r} does not exist.")
    data = read_text_bytes(path)
    try:
        return data.decode("utf-8-sig")  # a UTF-8 byte-order mark (Excel writes one) is dropped
    except UnicodeDecodeError as e:
        raise _err(str(path), None, f"not UTF-8 text ({e}).") from None


def _parse_header(lines: list[str], source: str) -> tuple[str, dict[str, Any], dict[str, int], int]:
    """Parse the comment header. Returns (kind, meta, line number of each key, index of the first data
    line)."""
    if not lines or not lines[0].startswith("#"):
        raise _err(
            source,
            1,
            "not a jaxroll record: the first line must be '# jaxroll-record: KIND' "
            f"with KIND one of {', '.join(RECORD_COLUMNS)}.",
        )
    first = lines[0].lstrip("#").strip()
    key, sep, value = first.partition(":")
    if key.strip() != "jaxroll-record" or not sep:
        raise _err(
            source,
            1,
            "not a jaxroll record: the first line must be '# jaxroll-record: KIND' "
            f"with KIND one of {', '.join(RECORD_COLUMNS)}; got {lines[0].strip()!r}.",
        )
    kind = value.strip()
    if kind not in RECORD_COLUMNS:
        raise _err(source, 1, f"unknown record kind {kind!r}; expected one of {', '.join(RECORD_COLUMNS)}.")
    meta: dict[str, Any] = {}
    where: dict[str, int] = {}
    i = 1
    while i < len(lines) and lines[i].startswith("#"):
        lineno = i + 1
        body = lines[i][1:].strip()
        i += 1
        if not body:
            continue
        key, sep, value = body.partition(":")
        key, value = key.strip(), value.strip()
        if not sep or not key:
            raise _err(
                source, lineno, f"header line must be '# key: value'; got {lines[lineno - 1].strip()!r}."
            )
        if key in meta:
            raise _err(source, lineno, f"duplicate header key `{key}` (first on line {where[key]}).")
        where[key] = lineno
        if key == "units":
            meta[key] = [u.strip() for u in value.split(",")]
        elif key in _NUMERIC_KEYS:
            try:
                number = float(value)
            except ValueError:
                raise _err(source, lineno, f"header key `{key}` must be a number; got {value!r}.") from None
            if not math.isfinite(number):
                raise _err(source, lineno, f"header key `{key}` must be finite; got {value!r}.")
            meta[key] = number
        else:
            meta[key] = value
    return kind, meta, where, i


def _check_header(kind: str, meta: dict[str, Any], where: dict[str, int], source: str, header_end: int):
    missing = [k for k in REQUIRED_KEYS[kind] if k not in meta]
    if missing:
        raise _err(
            source,
            header_end,
            f"missing header key(s) {', '.join(missing)} for a {kind} record (see docs/records.md).",
        )
    if meta["format_version"] != FORMAT_VERSION:
        raise _err(
            source,
            where["format_version"],
            f"format_version {meta['format_version']:g} is not supported "
            f"(this jaxroll reads {FORMAT_VERSION}).",
        )
    checks = {
        "scale": (lambda v: v >= 1, "must be >= 1 (λ: model = full/λ; use 1 for full-scale records)"),
        "sampling_hz": (lambda v: v > 0, "must be > 0 [Hz, model scale]"),
        "wave_height_full_m": (lambda v: v > 0, "must be > 0 [m, full scale]"),
        "wave_period_full_s": (lambda v: v > 0, "must be > 0 [s, full scale]"),
        "speed_model_m_s": (lambda v: v >= 0, "must be >= 0 [m/s, model scale] (head seas)"),
        "heel_deg": (lambda v: 0 <= v < 90, "must be in [0, 90) [deg]"),
    }
    for key, (ok, why) in checks.items():
        if key in meta and not ok(meta[key]):
            raise _err(source, where[key], f"header key `{key}` = {meta[key]:g} {why}.")
    full_interval = math.sqrt(meta["scale"]) / meta["sampling_hz"]
    if (
        full_interval > MAX_FULL_SCALE_INTERVAL_S
    ):  # a time column in ms read as s (issue 45: a "0.02 Hz" record)
        raise _err(
            source,
            where["sampling_hz"],
            f"a sample every {1 / meta['sampling_hz']:g} s at model scale ({meta['sampling_hz']:g} Hz; "
            f"{full_interval:g} s full scale): slower than any roll record (at most {MAX_FULL_SCALE_INTERVAL_S:g} "
            "s full scale between samples, a roll cycle needs several). A time column in ms read as s? Give its "
            "unit (CLI --units time=ms).",
        )
    for key, allowed in _KNOWN_STRING_VALUES.items():
        if key in meta and meta[key] not in allowed:
            raise _err(
                source,
                where[key],
                f"header key `{key}` = {meta[key]!r} is not supported; jaxroll handles {', '.join(allowed)}.",
            )
    columns = RECORD_COLUMNS[kind]
    units = meta["units"]
    lineno = where["units"]
    if len(units) != len(columns) or any(not u for u in units):
        raise _err(
            source,
            lineno,
            f"`units` must list one unit per column ({', '.join(columns)}); "
            f"got {', '.join(units) or 'nothing'}.",
        )
    for name, unit in zip(columns, units):
        if unit not in COLUMN_UNITS[name]:
            raise _err(
                source,
                lineno,
                f"wrong unit {unit!r} for column `{name}`; expected one of {', '.join(COLUMN_UNITS[name])}.",
            )


def _parse_number(label: str, field: str, source: str, lineno: int | None, decimal: str = ".") -> float:
    """One data field as a finite number, or a `RecordError` naming the column (`label`, e.g. "column `roll`"),
    the line and the problem (the messages of docs/records.md, shared by the record loader and the lab-file
    import)."""
    if field == "":
        raise _err(source, lineno, f"empty value in {label} (gaps are not allowed).")
    try:
        v = float(field if decimal == "." else field.replace(decimal, "."))
    except ValueError:
        raise _err(source, lineno, f"{label}: cannot read {field!r} as a number.") from None
    if math.isnan(v):
        raise _err(source, lineno, f"{label} is NaN (gaps and missing values are not allowed).")
    if not math.isfinite(v):
        raise _err(source, lineno, f"{label} is not finite ({field}).")
    return v


def _check_roll_range(roll_full: np.ndarray, unit: str, source: str, fix: str) -> None:
    """Refuse a roll beyond 90°: no ship record holds that, so the unit is wrong (degrees labelled rad)."""
    if roll_full.size:
        peak = float(np.max(np.abs(roll_full)))
        if peak > math.pi / 2:
            raise _err(
                source,
                None,
                f"the roll reaches {peak:.4g} rad ({math.degrees(peak):.4g}°) with unit `{unit}`: beyond 90°, no "
                f"ship record holds that; the column is probably in degrees ({fix}).",
            )


def _parse_data(lines: list[str], start: int, ncol: int, columns, source: str):
    rows, linenos = [], []
    n_lines = len(lines)
    while n_lines > start and not lines[n_lines - 1].strip():
        n_lines -= 1
    for i in range(start, n_lines):
        lineno = i + 1
        text = lines[i].strip()
        if not text:
            raise _err(source, lineno, "blank line inside the data (gaps are not allowed).")
        if text.startswith("#"):
            raise _err(
                source, lineno, "comment line inside the data; the header must come before the column names."
            )
        fields = [f.strip() for f in text.split(",")]
        if len(fields) != ncol:
            if i == n_lines - 1 and len(fields) < ncol:
                raise _err(
                    source,
                    lineno,
                    f"truncated file: the last line has {len(fields)} of {ncol} columns "
                    f"({', '.join(columns)}).",
                )
            raise _err(source, lineno, f"expected {ncol} columns ({', '.join(columns)}); got {len(fields)}.")
        rows.append(
            [_parse_number(f"column `{name}`", field, source, lineno) for name, field in zip(columns, fields)]
        )
        linenos.append(lineno)
    return np.asarray(rows, dtype=float).reshape(-1, ncol), np.asarray(linenos, dtype=int)


def _check_time(t, linenos, sampling_hz: float, source: str, resample: bool):
    dt = 1.0 / sampling_hz
    steps = np.diff(t)
    bad = np.nonzero(steps <= 0)[0]
    if bad.size:
        j = bad[0] + 1
        raise _err(
            source,
            int(linenos[j]),
            f"time {t[j]:g} s does not increase (previous sample: {t[j - 1]:g} s); "
            "time must be strictly increasing.",
        )
    gaps = np.nonzero(steps > GAP_FACTOR * dt)[0]
    if gaps.size:
        j = gaps[0] + 1
        raise _err(
            source,
            int(linenos[j]),
            f"gap in the record: time jumps from {t[j - 1]:g} s to {t[j]:g} s "
            f"({steps[j - 1]:g} s; the sampling interval is 1/sampling_hz = {dt:g} s). Gaps are never "
            "filled; cut the record or supply the missing samples.",
        )
    irregular = np.nonzero(np.abs(steps - dt) > SAMPLING_RTOL * dt)[0]
    if irregular.size and not resample:
        j = irregular[0] + 1
        raise _err(
            source,
            int(linenos[j]),
            f"irregular time step {steps[j - 1]:g} s (1/sampling_hz = {dt:g} s, "
            f"tolerance {SAMPLING_RTOL:.0%}); pass resample=True (CLI: --resample) to interpolate onto "
            "a uniform grid.",
        )
    return irregular.size > 0


def load_record(
    path: str | Path, *, kind: str | None = None, resample: bool = False, min_samples: int = 16
) -> Record:
    """Read and validate one tank record (format: docs/records.md); returns it at full scale, SI.

    **Arguments:**

    - `path`: a `.csv` file (or `.csv.gz`).
    - `kind`: the expected kind ("decay", "captive", "roll"); None accepts any.
    - `resample`: interpolate irregularly sampled (jittered) time onto the uniform grid of `sampling_hz`
      (linear interpolation, from the first sample). Gaps are refused all the same.
    - `min_samples`: fewer data rows than this is an error.

    **Raises:** `RecordError` (a `ValueError`) naming the file, the line and the problem: a missing or unknown
    header key value, missing/wrong units, non-numeric, empty or NaN values, a truncated last line, time that
    does not increase, gaps, irregular sampling (without `resample`), too few samples; `FileNotFoundError`.
    """
    path = Path(path)
    source = str(path)
    lines = _read_text(path).splitlines()
    got, meta, where, i = _parse_header(lines, source)
    if kind is not None and got != kind:
        raise _err(source, 1, f"this is a {got} record; a {kind} record was expected.")
    _check_header(got, meta, where, source, i)
    columns = RECORD_COLUMNS[got]
    if i >= len(lines) or not lines[i].strip():
        raise _err(source, i + 1, f"missing column-name line '{','.join(columns)}' after the header.")
    names = [c.strip() for c in lines[i].split(",")]
    if names != list(columns):
        raise _err(
            source,
            i + 1,
            f"column names must be '{','.join(columns)}' for a {got} record; got '{lines[i].strip()}'.",
        )
    data, linenos = _parse_data(lines, i + 1, len(columns), columns, source)
    if data.shape[0] < min_samples:
        raise _err(
            source,
            int(linenos[-1]) if linenos.size else i + 1,
            f"too few samples: {data.shape[0]} data rows (at least {min_samples} needed).",
        )
    t = data[:, 0]
    irregular = _check_time(t, linenos, meta["sampling_hz"], source, resample)
    if irregular:
        dt = 1.0 / meta["sampling_hz"]
        n = int(math.floor((t[-1] - t[0]) / dt * (1 + 1e-9))) + 1
        grid = t[0] + dt * np.arange(n)
        data = np.column_stack([grid] + [np.interp(grid, t, data[:, j]) for j in range(1, data.shape[1])])
        linenos = linenos[np.clip(np.searchsorted(t, grid), 0, t.size - 1)]
        meta = {**meta, "resampled": "linear interpolation onto 1/sampling_hz (load_record resample=True)"}
    lam = meta["scale"]
    full = {}
    for j, (name, unit) in enumerate(zip(columns, meta["units"])):
        full[name] = data[:, j] * COLUMN_UNITS[name][unit] * lam ** _FROUDE_POWER[name]
    if "roll" in full:
        unit = meta["units"][list(columns).index("roll")]
        _check_roll_range(full["roll"], unit, source, "set `units` to deg for roll")
    time = full.pop("time")
    return Record(got, time, full, float(lam), meta, source, linenos)


def _expand(paths: Iterable[str | Path]) -> list[Path]:
    out: list[Path] = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            found = sorted([*p.glob("*.csv"), *p.glob("*.csv.gz")])
            if not found:
                raise FileNotFoundError(f"Folder {str(p)!r} holds no record files (*.csv, *.csv.gz).")
            out.extend(found)
        else:
            out.append(p)
    return out


def load_records(
    paths: Iterable[str | Path] | str | Path, *, kind: str | None = None, resample: bool = False
) -> list[Record]:
    """Load several records (files, or folders whose `*.csv`/`*.csv.gz` are read in name order).

    All must be of the same kind (`kind`, or the first file's) and the same scale.
    """
    if isinstance(paths, str | Path):
        paths = [paths]
    files = _expand(paths)
    if not files:
        raise ValueError("no record files given.")
    records = []
    for f in files:
        rec = load_record(f, kind=kind, resample=resample)
        if kind is None:
            kind = rec.kind
        if records and rec.scale != records[0].scale:
            raise RecordError(
                f"{rec.source}: scale {rec.scale:g} differs from {records[0].source} "
                f"({records[0].scale:g}); load records of one model at a time."
            )
        records.append(rec)
    return records


def group_by_sea_state(records: Sequence[Record]) -> dict[tuple[float, float], list[Record]]:
    """Records grouped by (H1/3 [m], T01 [s]) full scale, in order of first appearance."""
    groups: dict[tuple[float, float], list[Record]] = {}
    for r in records:
        groups.setdefault(r.sea_state, []).append(r)
    return groups
