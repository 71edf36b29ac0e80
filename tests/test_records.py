"""Tank records: format round trips, Froude scaling, the example records, and every loader error message."""

import gzip
import math
import re
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

import jaxroll as jxr
from jaxroll.calibration import virtual_decay_record
from jaxroll.io import (
    RecordError,
    load_record,
    load_records,
    make_record,
    record_to_text,
    save_record,
)

EXAMPLES = Path(str(files("jaxroll") / "data" / "records"))

HEADER = {
    "decay": [
        "# jaxroll-record: decay",
        "# format_version: 1",
        "# scale: 100",
        "# sampling_hz: 10",
        "# units: s, deg",
    ],
    "captive": [
        "# jaxroll-record: captive",
        "# format_version: 1",
        "# scale: 100",
        "# sampling_hz: 10",
        "# units: s, mm, mm",
        "# wave_height_full_m: 5",
        "# wave_period_full_s: 10",
        "# probe_x_model_m: 2.0",
        "# speed_model_m_s: 0",
        "# heel_deg: 5",
    ],
    "roll": [
        "# jaxroll-record: roll",
        "# format_version: 1",
        "# scale: 100",
        "# sampling_hz: 10",
        "# units: s, deg, mm",
        "# wave_height_full_m: 7",
        "# wave_period_full_s: 10",
        "# probe_x_model_m: 0",
        "# speed_model_m_s: 0",
    ],
}
COLUMNS = {"decay": "time,roll", "captive": "time,wave,delta_gm", "roll": "time,roll,wave"}


def rows(kind, n=40, dt=0.1):
    ncol = COLUMNS[kind].count(",") + 1
    return [
        ",".join([f"{k * dt:.4f}"] + [f"{math.sin(0.3 * k + j):.4f}" for j in range(ncol - 1)])
        for k in range(n)
    ]


def write(tmp_path, lines, name="rec.csv"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def good(kind="decay", n=40):
    return HEADER[kind] + [COLUMNS[kind]] + rows(kind, n)


def line_of(lines, prefix):
    """1-based line number of the first line starting with `prefix`."""
    return next(i + 1 for i, line in enumerate(lines) if line.startswith(prefix))


# ------------------------------------------------------------------------------------------------------------
# Round trips and scaling
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["decay", "captive", "roll"])
def test_valid_records_load_with_froude_scaling(tmp_path, kind):
    lines = good(kind)
    rec = load_record(write(tmp_path, lines))
    assert rec.kind == kind
    t = np.array([float(r.split(",")[0]) for r in rows(kind)])
    np.testing.assert_allclose(rec.time, 10.0 * t, rtol=1e-12, atol=1e-12)  # time × √100
    np.testing.assert_allclose(rec.dt, 1.0, rtol=1e-12, atol=0)
    col1 = np.array([float(r.split(",")[1]) for r in rows(kind)])
    if kind in ("decay", "roll"):
        np.testing.assert_allclose(rec.roll, np.radians(col1), rtol=1e-12, atol=1e-15)  # angles unchanged
    else:
        np.testing.assert_allclose(rec.wave, col1 * 1e-3 * 100, rtol=1e-12, atol=1e-15)  # mm model → m full
        np.testing.assert_allclose(rec.probe_x, 200.0, rtol=1e-12, atol=0)
        np.testing.assert_allclose(rec.heel, math.radians(5), rtol=1e-12, atol=0)
    if kind != "decay":
        assert rec.sea_state == (float(rec.meta["wave_height_full_m"]), 10.0)


@pytest.mark.parametrize("suffix", [".csv", ".csv.gz"])
def test_write_then_load_round_trip(tmp_path, suffix):
    rng = np.random.default_rng(0)
    t = np.arange(200) * 0.5  # full scale, λ = 100, 20 Hz model
    rec = make_record(
        "roll",
        t,
        {"roll": rng.normal(0, 0.1, 200), "wave": rng.normal(0, 1.5, 200)},
        scale=100,
        sampling_hz=20,
        wave_height_full_m=7.0,
        wave_period_full_s=10.0,
        probe_x_model_m=0.0,
        speed_model_m_s=0.0,
        realization=3,
    )
    path = save_record(rec, tmp_path / f"r{suffix}")
    back = load_record(path, kind="roll")
    np.testing.assert_allclose(back.time, t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        back.roll, rec.roll, rtol=0, atol=np.radians(0.5e-4) * 1.01
    )  # 4 decimals in deg
    np.testing.assert_allclose(
        back.wave, rec.wave, rtol=0, atol=0.5e-3 * 1e-3 * 100 * 1.01
    )  # 3 decimals in mm
    assert back.meta["realization"] == 3
    if suffix == ".csv.gz":
        assert gzip.decompress(path.read_bytes()).startswith(b"# jaxroll-record: roll")


def test_example_records_load():
    recs = {kind: load_records(EXAMPLES / kind, kind=kind) for kind in ("decay", "captive", "roll")}
    assert len(recs["decay"]) == 1 and len(recs["captive"]) == 3 and len(recs["roll"]) == 8
    for r in recs["roll"]:
        r.window(70.0, 340.0)  # the paper's analysis window fits
    total = sum(p.stat().st_size for p in EXAMPLES.rglob("*") if p.is_file())
    assert total < 400_000, "keep the shipped examples small"


def test_window_in_model_seconds(tmp_path):
    rec = load_record(write(tmp_path, good("roll", n=100)))  # 0–9.9 s model
    w = rec.window(2.0, 5.0)
    np.testing.assert_allclose(w.model_time[[0, -1]], [2.0, 5.0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(w.time[[0, -1]], [20.0, 50.0], rtol=0, atol=1e-8)


def test_resample_irregular_time(tmp_path):
    lines = good("decay")
    k = len(HEADER["decay"]) + 1 + 10  # 0-based index of data row 10
    lines[k] = "1.0300," + lines[k].split(",")[1]  # jitter 3 % of the 0.1 s interval
    path = write(tmp_path, lines)
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}:{k + 1}: irregular time step"):
        load_record(path)
    rec = load_record(path, resample=True)
    np.testing.assert_allclose(np.diff(rec.model_time), 0.1, rtol=1e-9, atol=0)
    assert "resampled" in rec.meta


def test_virtual_decay_record_starts_at_release():
    ship = jxr.c11_representative()
    rec = virtual_decay_record(ship, initial_roll_deg=15.0, duration_model_s=5.0)
    np.testing.assert_allclose(np.degrees(rec.roll[0]), 15.0, rtol=0, atol=1e-12)
    assert rec.kind == "decay" and rec.meta["initial_roll_deg"] == 15.0
    text = record_to_text(rec)
    assert text.splitlines()[0] == "# jaxroll-record: decay" and "time,roll" in text


# ------------------------------------------------------------------------------------------------------------
# Every loader error: file, line and problem
# ------------------------------------------------------------------------------------------------------------


def _mutate(kind, how):
    """A good record with one defect; returns (lines, 1-based line of the defect or None, message regex)."""
    lines = good(kind)
    nh = len(HEADER[kind])
    data0 = nh + 2  # 1-based line of the first data row
    if how == "not_record":
        lines[0] = "time,roll"
        return lines, 1, "not a jaxroll record"
    if how == "bad_magic":
        lines[0] = "# jaxroll record decay"
        return lines, 1, "not a jaxroll record"
    if how == "unknown_kind":
        lines[0] = "# jaxroll-record: sway"
        return lines, 1, "unknown record kind 'sway'"
    if how == "header_syntax":
        lines.insert(2, "# scale 100")
        return lines, 3, "header line must be '# key: value'"
    if how == "duplicate":
        lines.insert(3, "# scale: 50")
        return lines, 4, "duplicate header key `scale` \\(first on line 3\\)"
    if how == "missing_key":
        lines = [line for line in lines if not line.startswith("# sampling_hz")]
        return lines, nh - 1, "missing header key\\(s\\) sampling_hz"
    if how == "missing_units":
        lines = [line for line in lines if not line.startswith("# units")]
        return lines, nh - 1, "missing header key\\(s\\) units"
    if how == "not_number":
        i = line_of(lines, "# scale")
        lines[i - 1] = "# scale: one hundred"
        return lines, i, "header key `scale` must be a number; got 'one hundred'"
    if how == "version":
        i = line_of(lines, "# format_version")
        lines[i - 1] = "# format_version: 2"
        return lines, i, "format_version 2 is not supported"
    if how == "bad_scale":
        i = line_of(lines, "# scale")
        lines[i - 1] = "# scale: 0.5"
        return lines, i, "header key `scale` = 0.5 must be >= 1"
    if how == "bad_rate":
        i = line_of(lines, "# sampling_hz")
        lines[i - 1] = "# sampling_hz: 0"
        return lines, i, "header key `sampling_hz` = 0 must be > 0"
    if how == "bad_spectrum":
        lines.insert(2, "# spectrum: JONSWAP")
        return lines, 3, "header key `spectrum` = 'JONSWAP' is not supported"
    if how == "unit_count":
        i = line_of(lines, "# units")
        lines[i - 1] = "# units: s"
        return lines, i, "`units` must list one unit per column \\(time, roll\\); got s"
    if how == "wrong_unit":
        i = line_of(lines, "# units")
        lines[i - 1] = "# units: s, degree"
        return lines, i, "wrong unit 'degree' for column `roll`; expected one of deg, rad"
    if how == "wrong_time_unit":
        i = line_of(lines, "# units")
        lines[i - 1] = "# units: ms, deg"
        return lines, i, "wrong unit 'ms' for column `time`"
    if how == "column_names":
        lines[nh] = "t,phi"
        return lines, nh + 1, "column names must be 'time,roll' for a decay record; got 't,phi'"
    if how == "no_column_line":
        lines = lines[:nh]
        return lines, nh + 1, "missing column-name line 'time,roll'"
    if how == "columns_middle":
        lines[data0 + 4] = "0.5000,1.0,2.0"
        return lines, data0 + 5, "expected 2 columns \\(time, roll\\); got 3"
    if how == "truncated":
        lines[-1] = lines[-1].split(",")[0]
        return lines, len(lines), "truncated file: the last line has 1 of 2 columns"
    if how == "not_numeric":
        lines[data0 + 2] = lines[data0 + 2].split(",")[0] + ",abc"
        return lines, data0 + 3, "column `roll`: cannot read 'abc' as a number"
    if how == "nan":
        lines[data0 + 3] = lines[data0 + 3].split(",")[0] + ",nan"
        return lines, data0 + 4, "column `roll` is NaN"
    if how == "empty":
        lines[data0 + 3] = lines[data0 + 3].split(",")[0] + ","
        return lines, data0 + 4, "empty value in column `roll` \\(gaps are not allowed\\)"
    if how == "inf":
        lines[data0 + 3] = lines[data0 + 3].split(",")[0] + ",inf"
        return lines, data0 + 4, "column `roll` is not finite"
    if how == "blank_line":
        lines.insert(data0 + 5, "")
        return lines, data0 + 6, "blank line inside the data"
    if how == "comment_in_data":
        lines.insert(data0 + 5, "# note: splash")
        return lines, data0 + 6, "comment line inside the data"
    if how == "non_monotonic":
        a, b = lines[data0 + 6], lines[data0 + 7]
        lines[data0 + 6], lines[data0 + 7] = b, a
        return lines, data0 + 8, "time 0.7 s does not increase \\(previous sample: 0.8 s\\)"
    if how == "gap":
        del lines[data0 + 10 : data0 + 15]
        return lines, data0 + 11, "gap in the record: time jumps from 1 s to 1.6 s"
    if how == "irregular":
        lines[data0 + 10] = "1.1300," + lines[data0 + 10].split(",")[1]
        return lines, data0 + 11, "irregular time step 0.13 s .*pass resample=True"
    if how == "too_few":
        lines = lines[: data0 + 4]
        return lines, data0 + 4, "too few samples: 5 data rows"
    raise AssertionError(how)


DEFECTS = [
    "not_record",
    "bad_magic",
    "unknown_kind",
    "header_syntax",
    "duplicate",
    "missing_key",
    "missing_units",
    "not_number",
    "version",
    "bad_scale",
    "bad_rate",
    "bad_spectrum",
    "unit_count",
    "wrong_unit",
    "wrong_time_unit",
    "column_names",
    "no_column_line",
    "columns_middle",
    "truncated",
    "not_numeric",
    "nan",
    "empty",
    "inf",
    "blank_line",
    "comment_in_data",
    "non_monotonic",
    "gap",
    "irregular",
    "too_few",
]


@pytest.mark.parametrize("how", DEFECTS)
def test_loader_error_names_file_line_and_problem(tmp_path, how):
    lines, line, message = _mutate("decay", how)
    path = write(tmp_path, lines)
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}:{line}: {message}"):
        load_record(path)


def test_gap_refused_even_with_resample(tmp_path):
    lines, line, message = _mutate("decay", "gap")
    path = write(tmp_path, lines)
    with pytest.raises(RecordError, match=rf"{re.escape(str(path))}:{line}: .*Gaps are never filled"):
        load_record(path, resample=True)


def test_captive_missing_heel_and_bad_heel(tmp_path):
    lines = [line for line in good("captive") if not line.startswith("# heel_deg")]
    path = write(tmp_path, lines)
    with pytest.raises(
        ValueError,
        match=rf"{re.escape(str(path))}:\d+: missing header key\(s\) heel_deg for a "
        "captive record",
    ):
        load_record(path)
    lines = good("captive")
    i = line_of(lines, "# heel_deg")
    lines[i - 1] = "# heel_deg: 95"
    path = write(tmp_path, lines, "b.csv")
    with pytest.raises(
        ValueError, match=rf"{re.escape(str(path))}:{i}: header key `heel_deg` = 95 must be in"
    ):
        load_record(path)


def test_roll_missing_sea_keys(tmp_path):
    lines = [line for line in good("roll") if not line.startswith(("# wave_height", "# speed"))]
    path = write(tmp_path, lines)
    with pytest.raises(ValueError, match="missing header key\\(s\\) wave_height_full_m, speed_model_m_s"):
        load_record(path)


def test_wrong_kind_requested(tmp_path):
    path = write(tmp_path, good("decay"))
    with pytest.raises(ValueError, match=rf"{re.escape(str(path))}:1: this is a decay record; a roll record"):
        load_record(path, kind="roll")


def test_window_too_short_names_last_line(tmp_path):
    lines = good("roll", n=100)  # 0–9.9 s model scale
    path = write(tmp_path, lines)
    rec = load_record(path)
    with pytest.raises(
        ValueError,
        match=rf"{re.escape(str(path))}:{len(lines)}: record too short for the "
        r"requested analysis window: it covers 0.000–9.900 s model scale .* "
        r"the window is 70–340 s model scale \(700.0–3400.0 s full scale\)",
    ):
        rec.window(70.0, 340.0)
    with pytest.raises(ValueError, match="analysis window 5.0–2.0 s is empty"):
        rec.window(5.0, 2.0)


def test_missing_file_corrupt_gzip_and_empty_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_record(tmp_path / "nope.csv")
    bad = tmp_path / "bad.csv.gz"
    bad.write_bytes(b"not gzip at all")
    with pytest.raises(ValueError, match=rf"{re.escape(str(bad))}: not a readable gzip file"):
        load_record(bad)
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="holds no record files"):
        load_records(tmp_path / "empty")


def test_load_records_refuses_mixed_kinds_and_scales(tmp_path):
    a = write(tmp_path, good("decay"), "a.csv")
    b = write(tmp_path, good("roll"), "b.csv")
    with pytest.raises(ValueError, match=rf"{re.escape(str(b))}:1: this is a roll record; a decay record"):
        load_records([a, b])
    lines = good("decay")
    lines[line_of(lines, "# scale") - 1] = "# scale: 50"
    c = write(tmp_path, lines, "c.csv")
    with pytest.raises(ValueError, match=rf"{re.escape(str(c))}: scale 50 differs from"):
        load_records([a, c])


def test_issue13_bom_accepted_and_degrees_labelled_rad_refused(tmp_path):
    """Issue 13: a UTF-8 BOM (Excel) is accepted; a decay record in degrees labelled `rad` is refused early."""
    lines = good("decay")
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + ("\n".join(lines) + "\n").encode("utf-8"))
    np.testing.assert_allclose(
        load_record(path).roll, load_record(write(tmp_path, lines)).roll, rtol=0, atol=0
    )
    deg = [ln.replace("# units: s, deg", "# units: s, rad") for ln in HEADER["decay"]] + [COLUMNS["decay"]]
    deg += [f"{k * 0.1:.4f},{20 * math.cos(0.3 * k):.4f}" for k in range(40)]
    with pytest.raises(RecordError, match="probably in degrees"):
        load_record(write(tmp_path, deg, "deg.csv"))


# ------------------------------------------------------------------------------------------------------------
# Issue 45: sizes, sampling rates and units that were accepted or exhausted the memory
# ------------------------------------------------------------------------------------------------------------


def test_a_gzip_bomb_or_a_huge_file_is_refused_after_reading_at_most_the_limit(tmp_path, monkeypatch, capsys):
    """Issue 45 item 8: a 1 MiB .csv.gz expanding to 256 MiB took 5.6 GiB (MemoryError), a 2 GiB sparse file
    2.2 GiB before its refusal. Text is read up to `MAX_TEXT_BYTES` (24 MiB; 64 KiB here) and refused beyond."""
    from jaxroll._cli import main
    from jaxroll.io import _records

    monkeypatch.setattr(_records, "MAX_TEXT_BYTES", 64 * 1024)
    bomb = tmp_path / "bomb.csv.gz"
    bomb.write_bytes(gzip.compress("\n".join(good("roll")).encode() + b"\n0.1,1.0,2.0" * 100_000, 9))
    assert bomb.stat().st_size < 64 * 1024  # small on disk, 1.2 MB of text
    reads = []
    real_open = gzip.open

    def counting_open(*args, **kwargs):
        f = real_open(*args, **kwargs)
        real_read = f.read
        f.read = lambda size=-1: reads.append(size) or real_read(size)
        return f

    monkeypatch.setattr(gzip, "open", counting_open)
    with pytest.raises(RecordError, match=r"bomb\.csv\.gz: more than 0\.0625 MiB of text once decompressed"):
        load_record(bomb)
    assert reads == [64 * 1024 + 1]  # read up to the limit, never the whole
    sparse = tmp_path / "sparse.csv"
    with open(sparse, "wb") as f:
        f.truncate(2**31)  # 2 GiB, sparse: refused by its size before any reading
    with pytest.raises(
        RecordError, match=r"sparse\.csv: more than 0\.0625 MiB of text: far more than a tank record"
    ):
        load_record(sparse)
    argv = ["records", "import", str(bomb), "--kind", "roll", "--time", "1", "--roll", "2", "--wave", "3"]
    argv += ["--scale", "100", "--hs", "7", "--t01", "10", "--probe-x", "0", "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll records import: error: ") and "more than 0.0625 MiB" in err  # item 17


def test_a_time_column_in_ms_read_as_s_and_a_unit_given_twice_are_refused(tmp_path, capsys):
    """Issue 45 item 4: a time column in ms labelled s (a "0.02 Hz" record) and a column's unit given twice in
    --units (the last one won) were accepted."""
    from jaxroll._cli import main

    lines = [x.replace("sampling_hz: 10", "sampling_hz: 0.02") for x in HEADER["roll"]] + [COLUMNS["roll"]]
    lines += rows("roll", dt=50.0)
    with pytest.raises(RecordError, match=r"a sample every 50 s at model scale \(0\.02 Hz; 500 s full scale\): "
                       r"slower than any roll record .*--units time=ms"):  # fmt: skip
        load_record(write(tmp_path, lines))
    lab = write(tmp_path, ["Time [s],Roll [deg],WP1 [mm]"] + rows("roll", n=60, dt=20.0), "lab.csv")
    base = ["records", "import", str(lab), "--kind", "roll", "--time", "1", "--roll", "2", "--wave", "3"]
    base += ["--scale", "100", "--hs", "7", "--t01", "10", "--probe-x", "0", "--out", str(tmp_path / "o")]
    assert main(base) == 2
    assert "a sample every 20 s at model scale (0.05 Hz" in capsys.readouterr().err
    assert main([*base, "--units", "roll=deg,roll=rad"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll records import: error: --units gives roll twice (deg, rad)")
    assert not (tmp_path / "o").exists()
