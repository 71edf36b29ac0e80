"""Decay records as labs hand them over (issue 43): a realistic virtual record (rest before the release, roll
offset, sensor noise and drift, 100 Hz, radians in a lab file with a two-row units file, model scale 1:68, forward
speed) read from file and fitted: the release found, the offset fitted, b1 + b2 recovered within 3 standard errors,
ζ_eq within 2 %, no negative damping; the angle-unit warning; every listed output file of `calibrate` and `risk`
written."""

import json
import math
import re
import warnings

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jxr
from jaxroll.calibration import (
    decay_segment,
    find_release,
    fit_decay_ode,
    fit_extinction,
    virtual_decay_record,
    write_lab_file,
)
from jaxroll.calibration._decay_results import equivalent_damping_gradient
from jaxroll.io import import_record

# KVLCC2-like model: scale 1:68, Tφ 21 s full scale, ζ_eq ≈ 0.005 at 5°
B_TRUE = np.array([0.0020, 0.045, 0.0])
SHIP = eqx.tree_at(
    lambda s: (s.roll_period, s.damping), jxr.c11_representative(), (jnp.asarray(21.0), jnp.asarray(B_TRUE))
)
REST, RAMP = 9.0, 1.5  # s model scale before the release
OFFSET_DEG = 0.3


@pytest.fixture(scope="module")
def lab_record(tmp_path_factory):
    rec = virtual_decay_record(
        SHIP,
        initial_roll_deg=9.0,
        duration_model_s=110.0,
        scale=68.0,
        sampling_hz=100.0,
        roll_noise_deg=0.01,
        seed=4,
        max_dt=0.05,
        rest_model_s=REST,
        roll_offset_deg=OFFSET_DEG,
        drift_deg_per_min=0.01,
        speed_model_m_s=0.96,
    )
    data, units = write_lab_file(rec, tmp_path_factory.mktemp("lab") / "run1.csv")
    assert units.read_text().splitlines() == ["time,x,y,z,phi,theta,psi", "s,m,m,m,rad,rad,rad"]
    return data, units


def _import(data, units, **kw):
    return import_record(data, "decay", time="time", roll="phi", units_file=units, scale=68.0, **kw)


def test_units_file_release_and_time_scale(lab_record):
    data, units = lab_record
    rec = _import(data, units)
    assert rec.meta["units"] == ["s", "rad"] and rec.time.size == int((REST + RAMP + 110.0) * 100) + 1
    i = find_release(rec)
    assert abs(rec.model_time[i] - (REST + RAMP)) < 0.05  # found within 5 samples of the true release
    seg = decay_segment(rec)
    assert seg.released and abs(seg.start_model_s - (REST + RAMP)) < 0.05
    assert abs(math.degrees(seg.offset) - OFFSET_DEG) < 0.03
    # one time scale everywhere: model-scale seconds of the record's own time column
    seg2 = decay_segment(rec, start_model_s=30.0, stop_model_s=60.0)
    assert (
        not seg2.released
        and seg2.start_model_s == pytest.approx(30.0)
        and seg2.stop_model_s == pytest.approx(60.0)
    )
    win = rec.window(30.0, None)
    assert win.model_time[0] == pytest.approx(30.0) and win.model_time[-1] == pytest.approx(
        rec.model_time[-1]
    )
    with pytest.raises(ValueError, match=r"stop = 500 s \(model scale\) is outside the record"):
        decay_segment(rec, stop_model_s=500.0)


def test_realistic_record_damping_recovered(lab_record):
    """Truth b1 + b2 within 3 standard errors (the fit with the ship's GZ shape); ζ_eq within 2 % at the record's
    amplitudes with and without a ship; the extinction curve within 10 %, positive."""
    rec = _import(*lab_record)
    fit = fit_decay_ode(rec, SHIP, damping_model="linear+quadratic")
    assert fit.info.converged and fit.fitted_parameters == ("b1", "b2")
    for k, truth in zip(("b1", "b2"), B_TRUE):
        e = fit.damping[k]
        assert abs(e.value - truth) < 3 * e.std_error, (k, e, truth)
    assert fit.damping["b3"].value == 0 and fit.damping["b3"].std_error == 0
    assert abs(fit.roll_period.value - 21.0) / 21.0 < 0.005  # (the amplitude-dependent period of the GZ)
    assert abs(fit.records[0]["roll_offset_deg"] - OFFSET_DEG) < 0.03
    lo, hi = np.degrees(fit.amplitude_range)
    assert 8.5 < hi < 9.5 and lo < 3.0
    corr = fit.damping_correlation()
    assert corr[0, 0] == pytest.approx(1.0) and -1 < corr[0, 1] < 0 and np.isnan(corr[2, 2])
    ic = fit.information_criteria()
    assert ic["bic"] > ic["aic"] and ic["n_params"] == 2 + 1 + 3
    no_ship = fit_decay_ode(rec, damping_model="linear+quadratic")
    ext = fit_extinction(rec, damping_model="linear+quadratic")
    omega = 2 * math.pi / 21.0
    for f, tol in ((fit, 0.02), (no_ship, 0.02), (ext, 0.10)):
        eq = f.equivalent_damping_table()
        a = np.radians(eq["amplitude_deg"])
        truth = equivalent_damping_gradient(a, omega) @ B_TRUE / (2 * omega)
        np.testing.assert_allclose(eq["zeta"], truth, rtol=tol, err_msg=f.method)
        assert not any(eq["extrapolated"]) and np.all(f.b >= 0)
    with pytest.warns(UserWarning, match="outside the amplitudes the records cover"):
        out = fit.equivalent_damping([5.0, 15.0])
    assert list(out["extrapolated"]) == [False, True]
    # the ship's period 24.4 s against the observed 21 s: said, and the observed one used
    with pytest.warns(UserWarning, match=r"differs from the records' observed"):
        ext2 = fit_extinction(rec, jxr.c11_representative(), damping_model="linear+quadratic")
    np.testing.assert_allclose(ext2.b, ext.b, rtol=1e-9)


def test_damping_models_keep_the_signs_physical():
    """A purely linear decay fitted with every model: no coefficient below zero (log-parametrised), and the
    linear model's ζ_eq the truth's."""
    ship = eqx.tree_at(lambda s: s.damping, SHIP, jnp.asarray([0.004, 0.0, 0.0]))
    rec = virtual_decay_record(
        ship, initial_roll_deg=8.0, duration_model_s=40.0, scale=68.0, roll_noise_deg=0.05
    )
    for model in ("linear", "linear+quadratic", "linear+cubic", "linear+quadratic+cubic"):
        fit = fit_extinction(rec, ship, damping_model=model)
        assert np.all(fit.b >= 0), (model, fit.b)
        zeta = fit.equivalent_damping([4.0], warn=False)["zeta"][0]
        assert (
            abs(zeta - 0.004 / (2 * 2 * math.pi / 21.0))
            < 4 * fit.equivalent_damping([4.0], warn=False)["zeta_std_error"][0] + 2e-4
        )


def test_radians_labelled_degrees_are_said(lab_record):
    data, _ = lab_record
    rec = import_record(
        data, "decay", time="time", roll="phi", units={"time": "s", "roll": "deg"}, scale=68.0
    )
    with (
        pytest.raises(ValueError, match=r"radians labelled degrees it would be 8\.\d+°"),
        pytest.warns(UserWarning, match="check the roll unit"),
    ):
        fit_extinction(rec)


def _listed(out: str) -> list[str]:
    (line,) = [x for x in out.splitlines() if x.startswith("wrote ")]
    return [p.strip() for p in re.sub(r"^wrote ", "", line).split(",")]


def test_cli_decay_from_lab_file_lists_only_files_it_wrote(lab_record, tmp_path, capsys):
    """Item 6 for `calibrate decay` (both methods, with and without a ship): every file on the "wrote" line
    exists, the netCDF among them; no ship.toml without a ship."""
    from jaxroll._cli import main

    data, units = lab_record
    lab = ["--time", "time", "--roll", "phi", "--units-file", str(units), "--scale", "68"]
    for extra, ship in ((["--method", "extinction"], False), (["--roll-period", "21", "--gm", "5.7"], True)):
        out = tmp_path / f"cal{int(ship)}"
        assert main(["calibrate", "decay", str(data), *lab, "--out", str(out), *extra]) == 0
        listed = _listed(capsys.readouterr().out)
        assert str(out / "calibration.nc") in listed and (str(out / "ship.toml") in listed) == ship
        assert all((tmp_path / p).exists() for p in listed) and sorted(
            p.name for p in out.iterdir()
        ) == sorted(p.rsplit("/", 1)[-1] for p in listed)
    cal = json.loads((tmp_path / "cal1" / "calibration.json").read_text())
    ode = cal["estimates"]["ode"]
    assert ode["damping_model"] == "linear+quadratic" and ode["records"][0]["start_from"] == "release found"
    assert len(ode["equivalent_damping"]["zeta"]) == 7 and set(cal["model_comparison"]) >= {"linear"}
    assert float(jxr.load_ship(tmp_path / "cal1" / "ship.toml").gm0) == 5.7


@pytest.mark.parametrize(
    "argv",
    [
        ["calibrate", "captive", "{records}/captive"],
        ["calibrate", "roll", "{records}/roll", "--realizations", "2", "--window", "70", "120"],
        ["calibrate", "roll", "{records}/roll", "--estimator", "time-domain", "--params", "b1,gm_correction"],
        ["risk", "--realizations", "4", "--duration", "600", "--hours", "0.2", "--quiet"],
        ["risk", "--realizations", "4", "--duration", "600", "--hours", "0.2", "--quiet", "--estimator",
         "splitting", "--splitting-trials", "10"],
    ],
    ids=["captive", "roll-pdf", "roll-time-domain", "risk-direct", "risk-splitting"],
)  # fmt: skip
def test_every_command_lists_only_files_it_wrote(argv, tmp_path, capsys):
    """Item 6 of issue 43: the netCDF is written on every path and the "wrote" line lists only files that exist
    (a risk.nc without a unit for one field was listed but not written)."""
    from importlib.resources import files

    from jaxroll._cli import main

    records = str(files("jaxroll") / "data" / "records")
    out = tmp_path / "out"
    assert main([a.format(records=records) for a in argv] + ["--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "not written" not in captured.err
    listed = _listed(captured.out)
    stem = "risk" if argv[0] == "risk" else "calibration"
    names = {p.rsplit("/", 1)[-1] for p in listed}
    assert f"{stem}.nc" in names and f"{stem}.json" in names
    assert names == {p.name for p in out.iterdir()}


def test_bad_decay_options_and_units_files_are_one_line_errors(lab_record, tmp_path, capsys):
    """Each new error of issue 43, from the command line: exit 2, one line naming what to fix, nothing written."""
    from jaxroll._cli import main

    data, units = lab_record
    lab = ["--time", "time", "--roll", "phi", "--scale", "68"]
    bad = {
        "two_rows.csv": "time,x,phi\n",
        "short_row.csv": "time,x,phi\ns,m\n",
        "no_phi.csv": "time,x\ns,m\n",
    }
    for name, text in bad.items():
        (tmp_path / name).write_text(text)
    cases = [
        (["--units-file", str(units), "--gm", "-1"], r"--gm must be > 0 \(full scale\); got -1\."),
        (["--units-file", str(units), "--roll-period", "nan"], r"--roll-period must be > 0"),
        (
            ["--units-file", str(units), "--start", "500"],
            r"run1\.csv: start = 500 s \(model scale\) is outside the record, which covers 0\.000–120\.500 s "
            r"model scale \(0\.0–993\.7 s full scale\)\.",
        ),
        (
            ["--units-file", str(units), "--start", "20", "--stop", "20.1"],
            r"the analysis from 20\.000 s to 20\.100 s \(model scale\) leaves 11 samples; at least 16",
        ),
        (["--units-file", str(tmp_path / "none.csv")], r"Units file '.*none\.csv' does not exist\."),
        (["--units-file", str(tmp_path / "two_rows.csv")], r"two_rows\.csv: a units file holds two rows .* has 1\."),
        (
            ["--units-file", str(tmp_path / "short_row.csv")],
            r"short_row\.csv:2: the units row has 2 fields but the names row 3; give one unit a column\.",
        ),
        (
            ["--units-file", str(tmp_path / "no_phi.csv")],
            r"no_phi\.csv: no unit for column `phi` \(roll\) of .*run1\.csv: the units file names time, x; add the "
            r"column there, or give its unit \(CLI --units roll=…\)\.",
        ),
    ]  # fmt: skip
    for extra, message in cases:
        out = tmp_path / "out"
        assert main(["calibrate", "decay", str(data), *lab, *extra, "--out", str(out)]) == 2, extra
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and re.search(message, err), (extra, err)
        assert err.startswith("jaxroll calibrate: error: ") and not out.exists()
    for window, message in (
        (["--start", "500"], r"run1\.csv: start = 500 s \(model scale\) is outside the record"),
        (["--stop", "-3"], r"run1\.csv: stop = -3 s \(model scale\) is outside the record"),
        (
            ["--start", "30", "--stop", "20"],
            r"analysis window 30\.0–20\.0 s is empty \(stop must be > start\)",
        ),
    ):
        argv = ["records", "import", str(data), "--kind", "decay", *lab, "--units-file", str(units), *window]
        assert main([*argv, "--out", str(tmp_path / "imp")]) == 2
        assert re.search(message, capsys.readouterr().err), window
    with pytest.raises(
        ValueError, match=r"damping model 'quadratic' is not one of linear, linear\+quadratic"
    ):
        fit_extinction(_import(data, units), damping_model="quadratic")


def test_degrees_labelled_radians_and_the_deprecated_start_are_said():
    """A 1°-ish decay written in degrees but read as radians starts at ~52°: warned; `start_s` (full scale)
    warns and means start_model_s = start_s/√λ."""
    from jaxroll.calibration._decay_inputs import check_angle_unit
    from jaxroll.io import make_record

    t = np.arange(0, 40, 0.01)
    roll = (
        0.9 * np.exp(-0.02 * t) * np.cos(2 * math.pi * t / 2.5)
    )  # "rad": 0.9 rad = 51.6° (51.5° about the offset)
    rec = make_record("decay", t * math.sqrt(68.0), {"roll": roll}, scale=68.0, sampling_hz=100.0)
    with pytest.warns(UserWarning, match=r"starts at 51\.5°, beyond any decay test; .* would be 0\.899°"):
        assert "check the roll unit (CLI --units roll=deg)" in check_angle_unit(decay_segment(rec))
    small = make_record("decay", t * math.sqrt(68.0), {"roll": roll / 60}, scale=68.0, sampling_hz=100.0)
    with pytest.warns(DeprecationWarning, match=r"`start_s` \[s, full scale\] is deprecated"):
        with pytest.raises(ValueError, match=r"start = 41\.5 s \(model scale\) is outside the record"):
            fit_decay_ode(small, start_s=41.5 * math.sqrt(68.0))


def test_cli_decay_warnings_are_in_the_json(lab_record, tmp_path, capsys):
    """The ship's period 16 % off the observed one: one warning line, and in calibration.json's `warnings`."""
    from jaxroll._cli import main

    data, units = lab_record
    out = tmp_path / "cal"
    lab = ["--time", "time", "--roll", "phi", "--scale", "68", "--units-file", str(units)]
    argv = ["calibrate", "decay", str(data), *lab, "--roll-period", "24.4", "--method", "extinction"]
    with warnings.catch_warnings():
        warnings.simplefilter("default")  # as the command runs (the suite turns warnings into errors)
        assert main([*argv, "--stop", "60", "--out", str(out)]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if "warning" in ln]
    assert len(err) == 1 and re.search(
        r"roll period 24\.4 s differs from the records' observed 2\d\.\d+ s", err[0]
    )
    assert json.loads((out / "calibration.json").read_text())["warnings"] == [err[0].split("warning: ", 1)[1]]
