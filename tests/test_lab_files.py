"""Tank data as labs keep it (issue 35, item 5): lab-style CSV and HDF5 files read into records that equal the
native record files, Froude scaling, every bad case with its message, and the CLI (`jaxroll records import`,
`jaxroll calibrate` on lab files)."""

import gzip
import json
import math
import re
from importlib.resources import files
from pathlib import Path

import h5py
import numpy as np
import pytest

from jaxroll._cli import main
from jaxroll.io import (
    RecordError,
    describe_lab_file,
    import_record,
    load_record,
    read_lab_table,
    record_to_text,
)

EXAMPLES = Path(str(files("jaxroll") / "data" / "records"))
ROLL = EXAMPLES / "roll" / "roll_H7_T10_r01.csv.gz"
CAPTIVE = EXAMPLES / "captive" / "captive_H7_T10_heel00_r01.csv.gz"
ROLL_META = dict(wave_height_full_m=7.0, wave_period_full_s=10.0, probe_x_model_m=0.0, speed_model_m_s=0.0)


def native_rows(path: Path) -> list[list[str]]:
    """The data fields of a native record file, as text (so a lab file can carry the very same digits)."""
    text = gzip.decompress(path.read_bytes()).decode() if path.suffix == ".gz" else path.read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    return [ln.split(",") for ln in lines[1:]]


def lab_csv(path: Path, source: Path = ROLL, *, comma: bool = True) -> Path:
    """A lab's export of `source` (a roll record): a free-text preamble and comment lines, semicolons, decimal
    commas, units in the header, extra channels before, between and after (one of them text), model scale."""
    dec = (lambda x: x.replace(".", ",")) if comma else (lambda x: x)
    out = [
        "Towing tank, parametric roll series 3; model 1:100",
        "# operator: A. N. Other; DAQ 2026-11-27 10:31",
        "Sampling: 10 Hz",
        "",
        "Time [s];Heave [mm];Roll [deg];Pitch [deg];WP1 [mm];Carriage [m/s];Status",
    ]
    for i, (t, r, w) in enumerate(native_rows(source)):
        out.append(
            ";".join(
                [
                    dec(t),
                    dec(f"{0.5 * math.sin(0.1 * i):.3f}"),
                    dec(r),
                    dec(f"{0.01 * i:.2f}"),
                    dec(w),
                    "0",
                    "ok",
                ]
            )
        )
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return path


def assert_same_record(a, b):
    assert a.kind == b.kind and a.scale == b.scale
    np.testing.assert_array_equal(a.time, b.time)
    assert set(a.channels) == set(b.channels)
    for k in a.channels:
        np.testing.assert_array_equal(a.channels[k], b.channels[k])
    assert a.dt == b.dt and a.meta["sampling_hz"] == b.meta["sampling_hz"]


# ------------------------------------------------------------------------------------------------------------
# Layouts a lab writes: the same numbers as the native record, bit for bit
# ------------------------------------------------------------------------------------------------------------


def test_semicolon_decimal_comma_preamble_extra_columns_equal_native_record(tmp_path):
    path = lab_csv(tmp_path / "run3.csv")
    table = read_lab_table(path)
    assert table.layout["delimiter"] == ";" and table.layout["decimal"] == ","
    assert table.layout["header_line"] == 5 and table.layout["first_data_line"] == 6
    assert table.names == ("Time", "Heave", "Roll", "Pitch", "WP1", "Carriage", "Status")
    assert table.units == ("s", "mm", "deg", "deg", "mm", "m/s", None)
    rec = import_record(path, "roll", time="Time", roll="Roll", wave="WP1", scale=100, **ROLL_META)
    native = load_record(ROLL)
    assert_same_record(rec, native)
    assert rec.sea_state == native.sea_state and rec.probe_x == native.probe_x
    assert rec.lines[0] == 6 and rec.lines[-1] == 5 + len(native_rows(ROLL))
    assert "Roll [deg]" in rec.meta["imported_from"] and "delimiter ';'" in rec.meta["imported_from"]
    # the same columns by header text with its unit, by another case, and by number
    again = import_record(path, "roll", time="time [s]", roll=3, wave="wp1", scale=100, **ROLL_META)
    assert_same_record(again, native)


def test_written_record_reads_back_exactly(tmp_path):
    """`record_to_text(decimals="shortest")` (what `jaxroll records import` writes) loses no digit."""
    rec = import_record(
        lab_csv(tmp_path / "a.csv"), "roll", time="Time", roll="Roll", wave="WP1", scale=100, **ROLL_META
    )
    out = tmp_path / "a_record.csv"
    out.write_text(record_to_text(rec, decimals="shortest"))
    assert_same_record(load_record(out), rec)
    assert "# imported_from: " in out.read_text()


def test_units_row_tabs_other_units_and_full_scale_data_follow_froude(tmp_path):
    """A row of units under the names, tab-separated, ms / rad / cm, at full scale with λ = 40: the record holds
    model-scale data and gives back full scale (time ×√λ, lengths ×λ, angles unchanged)."""
    lam = 40.0
    n = 400
    t_full = np.arange(n) * 0.25  # s, full scale
    roll_rad = 0.2 * np.sin(0.4 * t_full)
    wave_cm = 150.0 * np.cos(0.6 * t_full)
    lines = ["t\troll\twave probe", "ms\trad\tcm"]
    lines += [f"{1000 * a:.1f}\t{b:.6f}\t{c:.3f}" for a, b, c in zip(t_full, roll_rad, wave_cm)]
    path = tmp_path / "full.txt"
    path.write_text("\n".join(lines) + "\n")
    table = read_lab_table(path)
    assert (
        table.layout["delimiter"] == "\t"
        and table.layout["units_line"] == 2
        and table.units == ("ms", "rad", "cm")
    )
    rec = import_record(
        path, "roll", time="t", roll="roll", wave="wave probe", scale=lam, full_scale=True, **ROLL_META
    )
    np.testing.assert_allclose(rec.time, t_full, rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(rec.roll, np.round(roll_rad, 6), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(rec.wave, np.round(wave_cm, 3) / 100, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(rec.model_time, t_full / math.sqrt(lam), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(
        rec.meta["sampling_hz"], 4.0 * math.sqrt(lam), rtol=1e-6, atol=0
    )  # model scale
    assert rec.meta["units"] == ["s", "rad", "mm"]
    # the same file read as model scale: every length ×λ and time ×√λ
    model = import_record(path, "roll", time="t", roll="roll", wave="wave probe", scale=lam, **ROLL_META)
    np.testing.assert_allclose(model.time, t_full * math.sqrt(lam), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(model.wave, np.round(wave_cm, 3) / 100 * lam, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(model.roll, rec.roll, rtol=0, atol=0)


def test_headerless_file_by_number_with_units_and_sampling_rate(tmp_path):
    rows = native_rows(ROLL)
    path = tmp_path / "plain.dat"
    path.write_text("\n".join(f"  {r}   {w}" for _, r, w in rows) + "\n")  # spaces, no time, no names
    rec = import_record(
        path,
        "roll",
        roll=1,
        wave=2,
        units={"roll": "deg", "wave": "mm"},
        sampling_hz=10,
        scale=100,
        header_row=0,
        **ROLL_META,
    )
    native = load_record(ROLL)
    np.testing.assert_array_equal(rec.roll, native.roll)
    np.testing.assert_array_equal(rec.wave, native.wave)
    np.testing.assert_allclose(rec.time, native.time, rtol=0, atol=1e-9)


def test_explicit_layout_options(tmp_path):
    path = lab_csv(tmp_path / "run.csv")
    for kw in ({"header_row": 5}, {"skip_rows": 4}, {"delimiter": ";", "decimal": ","}):
        rec = import_record(path, "roll", time="Time", roll="Roll", wave="WP1", scale=100, **kw, **ROLL_META)
        assert_same_record(rec, load_record(ROLL))
    plain = lab_csv(tmp_path / "point.csv", comma=False)  # semicolons with decimal points
    assert read_lab_table(plain).layout["decimal"] == "."
    assert_same_record(
        import_record(plain, "roll", time="Time", roll="Roll", wave="WP1", scale=100, **ROLL_META),
        load_record(ROLL),
    )


def write_hdf5(path: Path, *, truncate: bool = False, nan_at: int | None = None) -> Path:
    """A lab's HDF5 file: runs in groups, channels as 1-D datasets with a `units` attribute (roll as float32-free
    float64 of the native digits), the sampling rate as an attribute."""
    rows = np.array(native_rows(ROLL), dtype=float)
    with h5py.File(path, "w") as f:
        f.attrs["facility"] = "towing tank"
        for name in ("run1", "run3"):
            g = f.create_group(f"series_A/{name}")
            g.attrs["sampling_rate_hz"] = 10.0
            g.create_dataset("time", data=rows[:, 0]).attrs["units"] = "s"
            roll = rows[:, 1].copy()
            if nan_at is not None:
                roll[nan_at] = np.nan
            g.create_dataset("roll", data=roll).attrs["units"] = b"deg"
            g.create_dataset("wp1", data=rows[:-1, 2] if truncate else rows[:, 2]).attrs["unit"] = "mm"
            g.create_dataset("heave", data=np.zeros(len(rows)))
    return path


def test_hdf5_groups_equal_native_record(tmp_path):
    h5 = write_hdf5(tmp_path / "tank.h5")
    native = load_record(ROLL)
    rec = import_record(
        f"{h5}:/series_A/run3", "roll", time="time", roll="roll", wave="wp1", scale=100, **ROLL_META
    )
    assert_same_record(rec, native)
    assert rec.source == f"{h5}:/series_A/run3"
    absolute = import_record(
        h5,
        "roll",
        time="/series_A/run1/time",
        roll="/series_A/run1/roll",
        wave="/series_A/run1/wp1",
        scale=100,
        **ROLL_META,
    )
    assert_same_record(absolute, native)
    text = describe_lab_file(h5)
    assert "/series_A/run3/roll  shape (3501,), float64, units deg" in text


# ------------------------------------------------------------------------------------------------------------
# Bad cases: one clear message each (file, line or sample, problem)
# ------------------------------------------------------------------------------------------------------------


def _edit_line(path: Path, lineno: int, new: str | None) -> Path:
    lines = path.read_text().splitlines()
    if new is None:
        del lines[lineno - 1]
    else:
        lines[lineno - 1] = new
    path.write_text("\n".join(lines) + "\n")
    return path


def test_bad_lab_files_are_refused_with_their_line(tmp_path):
    def lab(name):
        return lab_csv(tmp_path / name)

    def imp(path, **kw):
        args = dict(time="Time", roll="Roll", wave="WP1", scale=100) | kw
        return import_record(path, "roll", **args, **ROLL_META)

    p = lab("unknown.csv")
    with pytest.raises(
        RecordError,
        match=rf"^{re.escape(str(p))}:5: no column 'Rol' for `roll` \(columns, line 5: "
        r"1 Time \[s\], 2 Heave \[mm\], 3 Roll \[deg\].*give one of these names or a column number",
    ):
        imp(p, roll="Rol")
    with pytest.raises(
        RecordError,
        match=r"unit 'furlong' of column `WP1` \(wave\) \(in the file\) is not "
        "understood; a wave column takes m, cm, mm",
    ):
        imp(_edit_line(lab("unit.csv"), 5, "Time [s];Heave [mm];Roll [deg];Pitch [deg];WP1 [furlong];C;S"))
    with pytest.raises(RecordError, match=r"column `Status` \(wave\): cannot read 'ok' as a number"):
        imp(lab("text.csv"), wave="Status")
    with pytest.raises(
        RecordError,
        match=r"column `Carriage` \(wave\) has no unit in the file; state it: "
        r"units=\{'wave': 'mm'\} \(CLI --units wave=mm\)",
    ):
        imp(
            _edit_line(
                lab("nounit.csv"), 5, "Time [s];Heave [mm];Roll [deg];Pitch [deg];WP1 [mm];Carriage;S"
            ),
            wave="Carriage",
        )
    with pytest.raises(
        RecordError,
        match=r"column `Roll` \(roll\): the file says its unit is 'deg' but 'rad' was "
        "given",
    ):
        imp(lab("conflict.csv"), units={"roll": "rad"})
    p = _edit_line(lab("nonmono.csv"), 11, "0,4;0;1,0;0;1,0;0;ok")
    with pytest.raises(
        RecordError,
        match=rf"^{re.escape(str(p))}:11: time 0.4 s does not increase \(previous "
        r"sample: 0.4 s\); time must be strictly increasing",
    ):
        imp(p)
    p = _edit_line(lab("nan.csv"), 20, "1,4;0;NaN;0;1,0;0;ok")
    with pytest.raises(
        RecordError,
        match=rf"^{re.escape(str(p))}:20: column `Roll` \(roll\) is NaN \(gaps and "
        "missing values are not allowed\\)",
    ):
        imp(p)
    p = lab("empty.csv")
    _edit_line(p, 21, "1,5;0;;0;1,0;0;ok")
    with pytest.raises(RecordError, match=rf"^{re.escape(str(p))}:21: empty value in column `Roll` \(roll\)"):
        imp(p)
    p = lab("truncated.csv")
    n = len(p.read_text().splitlines())
    _edit_line(p, n, "349,9;0,1;-3,2")
    with pytest.raises(
        RecordError,
        match=rf"^{re.escape(str(p))}:{n}: truncated file: the last line has 3 of 7 "
        "columns",
    ):
        imp(p)
    p = lab("blank.csv")
    lines = p.read_text().splitlines()
    lines.insert(40, "")
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordError, match=rf"^{re.escape(str(p))}:41: blank line inside the data"):
        imp(p)
    p = lab("gap.csv")
    lines = p.read_text().splitlines()
    del lines[30:40]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(
        RecordError,
        match=rf"^{re.escape(str(p))}:31: gap in the record: time jumps from 2.4 s to "
        r"3.5 s.*Gaps are never filled",
    ):
        imp(p)
    with pytest.raises(
        RecordError,
        match=r"the roll reaches .* with unit `rad`: beyond 90°.*probably in degrees "
        r"\(give units=\{'roll': 'deg'\}; CLI --units roll=deg\)",
    ):
        imp(_edit_line(lab("rad.csv"), 5, "Time [s];Heave [mm];Roll [rad];Pitch [deg];WP1 [mm];C;S"))
    with pytest.raises(RecordError, match="too few samples: 10 data rows"):
        p = lab("short.csv")
        p.write_text("\n".join(p.read_text().splitlines()[:15]) + "\n")
        imp(p)
    mixed = _edit_line(lab("mixed.csv"), 30, "2,4;0;1.5;0;1,0;0;ok")
    with pytest.raises(
        RecordError,
        match="numbers with a decimal point and numbers with a decimal comma; give the "
        r"decimal mark \(decimal=',' or '.'; CLI --decimal\)",
    ):
        imp(mixed)


def test_bad_arguments(tmp_path):
    p = lab_csv(tmp_path / "a.csv")
    with pytest.raises(
        ValueError, match=r"a roll record needs the column\(s\) roll, wave; give wave= \(CLI --wave\)"
    ):
        import_record(p, "roll", time="Time", roll="Roll", scale=100, **ROLL_META)
    with pytest.raises(ValueError, match="a decay record has no wave column; leave wave out"):
        import_record(p, "decay", time="Time", roll="Roll", wave="WP1", scale=100)
    with pytest.raises(ValueError, match="scale must be a number >= 1"):
        import_record(p, "decay", time="Time", roll="Roll", scale=0.01)
    with pytest.raises(ValueError, match="without a time column"):
        import_record(p, "decay", roll="Roll", scale=100)
    with pytest.raises(RecordError, match=r"missing header key\(s\) probe_x_model_m for a roll record"):
        import_record(
            p,
            "roll",
            time="Time",
            roll="Roll",
            wave="WP1",
            scale=100,
            wave_height_full_m=7,
            wave_period_full_s=10,
            speed_model_m_s=0,
        )
    with pytest.raises(FileNotFoundError, match="does not exist"):
        import_record(tmp_path / "nope.csv", "decay", time=1, roll=2, scale=1)


def test_bad_hdf5_files(tmp_path):
    h5 = write_hdf5(tmp_path / "t.h5")
    kw = dict(time="time", roll="roll", wave="wp1", scale=100, **ROLL_META)
    with pytest.raises(
        RecordError,
        match=r"no dataset 'phi' for `roll` \(/series_A/run3 holds: heave, roll, time, "
        r"wp1\)",
    ):
        import_record(f"{h5}:/series_A/run3", "roll", **(kw | {"roll": "phi"}))
    with pytest.raises(
        RecordError,
        match=r"'/series_A/run3/roll' is a dataset; name the group, .*:/series_A/run3, "
        r"and the datasets as columns \(e.g. roll='roll'; CLI --roll roll\)",
    ):
        import_record(f"{h5}:/series_A/run3/roll", "roll", **kw)
    with pytest.raises(RecordError, match=r"no group '/series_B' in the file \(top level: /series_A\)"):
        import_record(f"{h5}:/series_B", "roll", **kw)
    with pytest.raises(
        RecordError,
        match=r"truncated data: `/series_A/run3/wp1` \(wave\) has 3500 samples, "
        r"`/series_A/run3/time` \(time\) has 3501",
    ):
        import_record(f"{write_hdf5(tmp_path / 'tr.h5', truncate=True)}:/series_A/run3", "roll", **kw)
    bad = write_hdf5(tmp_path / "nan.h5", nan_at=99)
    with pytest.raises(
        RecordError,
        match=rf"^{re.escape(str(bad))}:/series_A/run3:100: `/series_A/run3/roll` "
        r"\(roll\) is NaN",
    ):
        import_record(f"{bad}:/series_A/run3", "roll", **kw)
    cut = tmp_path / "cut.h5"
    cut.write_bytes(h5.read_bytes()[:3000])  # a copy that stopped half-way
    with pytest.raises(RecordError, match=r"not a readable HDF5 file .*is it complete \(not truncated\)\?"):
        import_record(f"{cut}:/series_A/run3", "roll", **kw)


# ------------------------------------------------------------------------------------------------------------
# The command line
# ------------------------------------------------------------------------------------------------------------


def test_cli_records_import_and_inspect(tmp_path, capsys):
    lab = lab_csv(tmp_path / "run3.csv")
    h5 = write_hdf5(tmp_path / "tank.h5")
    out = tmp_path / "records"
    assert (
        main(
            [
                "records",
                "import",
                str(lab),
                f"{h5}:/series_A/run1",
                "--kind",
                "roll",
                "--time",
                "1",
                "--roll",
                "Roll",
                "--wave",
                "3",
                "--scale",
                "100",
                "--hs",
                "7",
                "--t01",
                "10",
                "--probe-x",
                "0",
                "--out",
                str(out),
                "--header-row",
                "none",
                "--units",
                "s,deg,mm",
                "--skip-rows",
                "0",
            ]
        )
        == 2
    )
    assert "--header-row and --skip-rows: give one" in capsys.readouterr().err
    code = main(
        [
            "records",
            "import",
            str(lab),
            "--kind",
            "roll",
            "--time",
            "Time",
            "--roll",
            "Roll",
            "--wave",
            "WP1",
            "--scale",
            "100",
            "--hs",
            "7",
            "--t01",
            "10",
            "--probe-x",
            "0",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    code = main(
        [
            "records",
            "import",
            f"{h5}:/series_A/run1",
            "--kind",
            "roll",
            "--time",
            "time",
            "--roll",
            "roll",
            "--wave",
            "wp1",
            "--scale",
            "100",
            "--hs",
            "7",
            "--t01",
            "10",
            "--probe-x",
            "0",
            "--out",
            str(tmp_path / "one.csv.gz"),
        ]
    )
    assert code == 0
    printed = capsys.readouterr().out
    assert (
        "roll record, 3501 samples at 10 Hz model scale, 350 s model = 3500 s full scale (λ = 100)" in printed
    )
    native = load_record(ROLL)
    assert_same_record(load_record(out / "run3.csv", kind="roll"), native)
    assert_same_record(load_record(tmp_path / "one.csv.gz", kind="roll"), native)
    assert main(["records", "inspect", str(lab), str(h5)]) == 0
    shown = capsys.readouterr().out
    assert "delimiter ';', decimal ','; column names on line 5; data on lines 6–3506 (3501 rows)" in shown
    assert "3  Roll [deg]: -23.889 … 23.22" in shown and "/series_A/run3/wp1  shape (3501,), float64" in shown


@pytest.mark.parametrize(
    "extra, message",
    [
        ([], "--scale: give the model scale λ of the lab file"),
        (["--scale", "100", "--units", "roll:deg"], "--units: give 'COLUMN=UNIT,…'"),
        (["--scale", "100", "--units", "pitch=deg"], "--units: 'pitch' is not a column of a roll record"),
        (["--scale", "0.5"], "--scale must be >= 1"),
        (["--scale", "100", "--heel", "5"], "--heel: only a captive record has a fixed heel"),
        (["--scale", "100", "--delimiter", "::"], "--delimiter must be one character"),
        (["--scale", "100", "--header-row", "x"], "--header-row must be a line number"),
    ],
)
def test_cli_import_option_errors(tmp_path, capsys, extra, message):
    lab = lab_csv(tmp_path / "run3.csv")
    argv = [
        "records",
        "import",
        str(lab),
        "--kind",
        "roll",
        "--time",
        "Time",
        "--roll",
        "Roll",
        "--wave",
        "WP1",
        "--hs",
        "7",
        "--t01",
        "10",
        "--probe-x",
        "0",
        "--out",
        str(tmp_path / "o"),
        *extra,
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll records import: error: ") and message in err  # issue 45
    assert not (tmp_path / "o").exists()


def test_cli_lab_options_need_columns_and_sea_state(tmp_path, capsys):
    assert main(["calibrate", "captive", str(CAPTIVE), "--scale", "100", "--out", str(tmp_path / "x")]) == 2
    assert "--scale: options of a lab file; give its columns too" in capsys.readouterr().err
    assert (
        main(
            [
                "calibrate",
                "captive",
                "lab.csv",
                "--time",
                "t",
                "--wave",
                "w",
                "--delta-gm",
                "g",
                "--scale",
                "100",
                "--hs",
                "7",
                "--t01",
                "10",
                "--probe-x",
                "2",
                "--out",
                str(tmp_path / "x"),
            ]
        )
        == 2
    )
    assert "--heel: a captive record needs the test's sea state" in capsys.readouterr().err
    assert (
        main(
            [
                "calibrate",
                "decay",
                "lab.csv",
                "--time",
                "t",
                "--roll",
                "r",
                "--scale",
                "100",
                "--hs",
                "7",
                "--out",
                str(tmp_path / "x"),
            ]
        )
        == 2
    )
    assert "--hs: a decay record has no sea state or heel" in capsys.readouterr().err


def captive_lab_files(tmp_path: Path) -> tuple[Path, Path]:
    """The example captive record as a lab writes it: a CSV with a unit row and decimal commas, and an HDF5 run."""
    rows = native_rows(CAPTIVE)
    csv_path = tmp_path / "captive_H7.csv"
    lines = ["Time;WaveProbe;dGM;Heel", "s;mm;mm;deg"] + [
        ";".join(x.replace(".", ",") for x in r) + ";0,0" for r in rows
    ]
    csv_path.write_text("\n".join(lines) + "\n")
    h5 = tmp_path / "captive.h5"
    data = np.array(rows, dtype=float)
    with h5py.File(h5, "w") as f:
        g = f.create_group("H7_T10/heel0")
        for j, (name, unit) in enumerate((("t", "s"), ("probe", "mm"), ("dgm", "mm"))):
            g.create_dataset(name, data=data[:, j]).attrs["units"] = unit
    return csv_path, h5


def test_calibrate_lab_csv_and_hdf5_equal_native_record(tmp_path):
    """`jaxroll calibrate` on a lab's CSV and on its HDF5 file: the same estimates as on the native record."""
    csv_path, h5 = captive_lab_files(tmp_path)
    sea = ["--scale", "100", "--hs", "7", "--t01", "10", "--probe-x", "2", "--heel", "0"]
    assert main(["calibrate", "captive", str(CAPTIVE), "--out", str(tmp_path / "native")]) == 0
    assert (
        main(
            [
                "calibrate",
                "captive",
                str(csv_path),
                "--time",
                "Time",
                "--wave",
                "WaveProbe",
                "--delta-gm",
                "dGM",
                *sea,
                "--out",
                str(tmp_path / "lab"),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "calibrate",
                "captive",
                f"{h5}:/H7_T10/heel0",
                "--time",
                "t",
                "--wave",
                "probe",
                "--delta-gm",
                "dgm",
                *sea,
                "--out",
                str(tmp_path / "h5"),
            ]
        )
        == 0
    )
    native = json.loads((tmp_path / "native" / "calibration.json").read_text())
    for run in ("lab", "h5"):
        got = json.loads((tmp_path / run / "calibration.json").read_text())
        native["estimates"]["config"]["records"] = got["estimates"]["config"][
            "records"
        ]  # the file names differ
        assert got["estimates"] == native["estimates"] and got["written"] == native["written"]
        assert len(got["config"]["lab_import"]) == 1
        assert (tmp_path / run / "ship.toml").read_text() == (tmp_path / "native" / "ship.toml").read_text()
