"""Time-domain calibration from free-running roll records: multiple shooting (`fit_roll_time_domain`) and the
extended-Kalman-filter likelihood (`fit_roll_kalman`); bad inputs; the CLI (`calibrate roll --estimator`).

Virtual-tank records (default ship "C11 (representative)" with r = 0.8, b = (0.0077252, 0.5, 0)), 120 s model
(1200 s full scale) at 20 Hz, H1/3 = 7 m, T01 = 10 s, roll noise 0.05°, wave-probe noise 0.1 mm (model), fixed
seeds. Measured numbers and the 20-record studies: docs/calibration.md, "Time-domain calibration"."""

import dataclasses
import json
import math
import warnings

import equinox as eqx
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
from helpers import assert_labelled_output

import jaxroll as jxr
from jaxroll.calibration import (
    effective_wave_from_probe,
    effective_wave_on_grid,
    fit_roll_kalman,
    fit_roll_time_domain,
    virtual_decay_record,
    virtual_roll_record,
)
from jaxroll.calibration._time_domain import (
    analysis_span,
    parameter_values,
    prepare_record,
    window_jacobian,
    window_roll,
)
from jaxroll.calibration._time_domain_results import _issue, identifiability, t_quantile_975
from jaxroll.io import save_record
from jaxroll.roll import RollProblem, SampledExcitation, simulate

PARAMS = ("b1", "b2", "gm_correction")
SHIP = jxr.c11_representative()
TRUTH = eqx.tree_at(lambda s: s.gm_correction, SHIP, jnp.asarray(0.8))
TRUE_VALUES = dict(zip(PARAMS, parameter_values(TRUTH, PARAMS)))
SEA = jxr.ITTC(7.0, 10.0)


def _record(seed, **kw):
    kw = {"duration_model_s": 120.0, "roll_noise_deg": 0.05, "wave_noise_mm": 0.1, **kw}
    rec, _ = virtual_roll_record(TRUTH, SEA, seed=seed, **kw)
    return rec


@pytest.fixture(scope="module")
def records():
    return [_record(2), _record(3)]


# ---------------------------------------------------------------------------------------------------------------
# Building blocks
# ---------------------------------------------------------------------------------------------------------------


def test_effective_wave_on_grid_matches_probe_reconstruction(records):
    rec = records[0]
    z, dz = effective_wave_on_grid(rec.wave, rec.dt, 2, length=float(SHIP.lpp), probe_x=rec.probe_x)
    ref = effective_wave_from_probe(rec.wave, rec.dt, length=float(SHIP.lpp), probe_x=rec.probe_x)
    np.testing.assert_allclose(
        np.asarray(z[::2]), np.asarray(ref), rtol=0, atol=1e-12 * float(jnp.max(jnp.abs(ref)))
    )
    # the spectral derivative agrees with a central difference of the fine series (O(h²), 1e-3 relative here)
    h = rec.dt / 2
    fd = (np.asarray(z[2:]) - np.asarray(z[:-2])) / (2 * h)
    np.testing.assert_allclose(np.asarray(dz[1:-1]), fd, rtol=0, atol=2e-2 * np.std(fd))


def test_window_integrator_is_the_projects_simulate(records):
    prep = prepare_record(records[0], SHIP, analysis_span(records[0], None))
    n = 120
    zeta, dzeta = jnp.asarray(prep.zeta[: (n - 1) * 2 + 1]), jnp.asarray(prep.dzeta[: (n - 1) * 2 + 1])
    y0 = jnp.array([math.radians(3.0), 0.01])
    a = window_roll(TRUTH, zeta, dzeta, y0, prep.h, prep.sub)
    problem = RollProblem(TRUTH, SampledExcitation(zeta, dzeta, prep.h), y0[0], y0[1])
    _, phis, _ = simulate(problem, jr.key(0), zeta.shape[0] - 1, lambda obs, k, y, alive: (obs, y[0]), None)
    b = jnp.concatenate([y0[:1], phis[prep.sub - 1 :: prep.sub]])
    np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=1e-14)


def test_t_quantile():
    # Student t 0.975 quantiles (tables): ν = 3, 10, 30, ∞
    for v, t in ((3, 3.182446), (10, 2.228139), (30, 2.042272), (math.inf, 1.959964)):
        assert abs(t_quantile_975(v) - t) < 2e-3 * t


def test_virtual_tank_moment_option_adds_roll_not_wave():
    plain = _record(7, duration_model_s=40.0)
    moved = _record(7, duration_model_s=40.0, moment_std=5e-4)
    np.testing.assert_array_equal(plain.wave, moved.wave)  # same sea, same probe noise
    assert np.std(moved.roll - plain.roll) > np.radians(
        0.5
    )  # the extra moment rolls the ship (3–4° rms alone)
    assert "extra random roll moment" in moved.meta["generator"]
    with pytest.raises(ValueError, match="`moment_std` must be >= 0"):
        _record(7, duration_model_s=40.0, moment_std=-1.0)


# ---------------------------------------------------------------------------------------------------------------
# AD Jacobian through the RK4 integrator = central differences
# ---------------------------------------------------------------------------------------------------------------


def test_ad_jacobian_equals_central_differences(records):
    names = ("b1", "b2", "b3", "gm_correction", "roll_period", "delta_gm_nonlinear")
    rec = records[0]
    j_ad, _ = window_jacobian(TRUTH, rec, names, start_s=400.0, window=300.0)
    j_fd, _ = window_jacobian(TRUTH, rec, names, start_s=400.0, window=300.0, fd=True, step=1e-5)
    assert j_ad.shape == (601, len(names) + 2)
    err = np.max(np.abs(j_ad - j_fd), axis=0) / np.max(np.abs(j_ad), axis=0)
    # central differences at a relative step 1e-5: truncation ≲ 1e-8 (measured ≤ 4.4e-8, the roll-period
    # column, whose phase drift over 300 s has the largest third derivative), round-off ≲ 1e-9
    assert np.all(err < 1e-6), err


# ---------------------------------------------------------------------------------------------------------------
# Recovery within 3 SE
# ---------------------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ms_fit(records):
    return fit_roll_time_domain(SHIP, records, params=PARAMS)


@pytest.fixture(scope="module")
def kf_fit(records):
    return fit_roll_kalman(SHIP, records[0], params=PARAMS)


def test_multiple_shooting_recovers_truth(ms_fit):
    fit = ms_fit
    assert fit.info.converged and fit.warnings == ()
    assert fit.n_windows == 22  # 2 records × ⌊1100 s / 97.6 s⌋
    assert fit.window_s == pytest.approx(4 * 24.4)
    for k in PARAMS:
        e = fit.estimates[k]
        assert abs(e.value - TRUE_VALUES[k]) < 3 * e.std_error, (k, e, TRUE_VALUES[k])
        assert e.std_error < 0.02 * abs(TRUE_VALUES[k])  # measured 0.1–0.4 %
        lo, hi = e.ci95
        assert lo < e.value < hi and e.dof == 21
    # measured (docs): b1 0.0077124 ± 2.9e-5, b2 0.50052 ± 0.00065, r 0.80061 ± 0.00059
    assert fit.estimates["b1"].value == pytest.approx(0.0077124, rel=1e-4)
    assert fit.estimates["gm_correction"].std_error == pytest.approx(5.9e-4, rel=0.05)
    # the residual is the sensor noise: the model is exact here
    for d in fit.records:
        assert abs(d.residual_to_noise - 1) < 0.1 and d.n_windows == 11
    assert fit.correlation.shape == (3, 3) and np.allclose(np.diag(fit.correlation), 1)
    assert fit.correlation[0, 1] == pytest.approx(-0.73, abs=0.02)  # b1–b2; b1–r only +0.24
    assert 1 <= fit.condition_number < 100
    assert fit.identifiability.not_identified == ()
    assert len(fit.curves["fitted"]) == 22 and fit.curves["fitted"][0].shape == (196,)
    d = fit.to_dict()
    assert d["estimates"]["gm_correction"]["unit"] == "-" and len(d["records"]) == 2
    assert d["correlation"]["names"] == list(PARAMS) and d["windows"] == 22
    json.dumps(d)
    ship = jxr.calibrated_ship(SHIP, roll=fit)
    assert float(ship.gm_correction) == fit.estimates["gm_correction"].value


def test_kalman_recovers_truth(kf_fit):
    fit = kf_fit
    assert fit.info["converged"] and fit.warnings == ()
    for k in PARAMS:
        e = fit.estimates[k]
        assert abs(e.value - TRUE_VALUES[k]) < 3 * e.std_error, (k, e, TRUE_VALUES[k])
    # no model error: the fitted measurement noise is the sensor noise, the process noise is ≈ 0
    sv = fit.estimates["measurement_noise"].value
    assert abs(math.degrees(sv) / 0.05 - 1) < 0.05
    assert fit.estimates["process_noise"].value < 1e-5  # 1.6e-6 measured; 7.8–8.6e-4 with a 5e-4 moment
    assert abs(fit.info["normalised_innovation_rms"] - 1) < 0.05
    assert fit.names == PARAMS + ("process_noise", "measurement_noise")


# ---------------------------------------------------------------------------------------------------------------
# Identifiability report
# ---------------------------------------------------------------------------------------------------------------


def test_identifiability_flags_a_degenerate_pair():
    cov = np.array([[1.0, 0.999, 0.0], [0.999, 1.0, 0.0], [0.0, 0.0, 1e-4]]) * 1e-6
    ident = identifiability(
        ("b1", "gm_correction", "b2"), [0.0077, 0.8, 0.5], cov, [0.005, 1.0, 0.1], condition_number=50.0
    )
    assert ident.not_identified == ("b1", "gm_correction")
    assert "b1–gm_correction +0.999" in ident.message
    assert ident.variance_inflation["b1"] > 400
    with pytest.warns(UserWarning, match="This warning appears because parameter"):
        assert _issue([ident.message], True) == (ident.message,)


# ---------------------------------------------------------------------------------------------------------------
# Bad input: clear ValueErrors, raised before anything is computed
# ---------------------------------------------------------------------------------------------------------------


@pytest.fixture
def no_compute(monkeypatch):
    """Fail loudly if a fit gets past its checks (the probe reconstruction is the first computation)."""

    def boom(*a, **k):
        raise AssertionError("computed before checking the inputs")

    monkeypatch.setattr("jaxroll.calibration._time_domain.prepare_record", boom)
    monkeypatch.setattr("jaxroll.calibration._kalman.prepare_record", boom)


FITS = pytest.mark.parametrize("fit", [fit_roll_time_domain, fit_roll_kalman])


@FITS
def test_record_without_wave_column(no_compute, fit):
    decay = virtual_decay_record(TRUTH, duration_model_s=30.0)
    with pytest.raises(
        ValueError, match="needs a free-running roll record with `roll` and `wave` columns.*no `wave`"
    ):
        fit(SHIP, decay)


@FITS
def test_probe_position_missing(records, no_compute, fit):
    rec = dataclasses.replace(
        records[0], meta={k: v for k, v in records[0].meta.items() if k != "probe_x_model_m"}
    )
    with pytest.raises(ValueError, match="needs the header entry `probe_x_model_m`.*not amidships"):
        fit(SHIP, [records[1], rec])


def test_window_longer_than_record(records, no_compute):
    with pytest.raises(
        ValueError, match=r"`window` = 5000 s \(full scale\) is longer than the record's analysis span"
    ):
        fit_roll_time_domain(SHIP, records[0], window=5000.0)
    with pytest.raises(ValueError, match="`window` must be a positive number"):
        fit_roll_time_domain(SHIP, records[0], window=-1.0)


@FITS
def test_parameter_not_in_model(records, no_compute, fit):
    with pytest.raises(ValueError, match="unknown parameter 'a7'.*choose from b1, b2, b3, gm_correction"):
        fit(SHIP, records[0], params=("b1", "a7"))
    with pytest.raises(ValueError, match="uniform scale of the ΔGM polynomial is `gm_correction`"):
        fit(SHIP, records[0], params=("delta_gm_scale",))
    with pytest.raises(ValueError, match="names a parameter twice"):
        fit(SHIP, records[0], params=("b1", "b1"))
    with pytest.raises(ValueError, match="`initial` names 'b3', which is not fitted"):
        fit(SHIP, records[0], params=("b1",), initial={"b3": 1.0})


def test_span_and_sampling(records, no_compute):
    with pytest.raises(ValueError, match="analysis span 70–340 s model scale is not covered"):
        fit_roll_time_domain(SHIP, records[0], span_model_s=(70.0, 340.0))
    r = records[1]
    coarse = dataclasses.replace(
        r,
        time=r.time[::2],
        channels={k: v[::2] for k, v in r.channels.items()},
        meta={**r.meta, "sampling_hz": 10.0},
    )
    with pytest.raises(ValueError, match="sampling interval 1 s differs"):
        fit_roll_kalman(SHIP, [records[0], coarse])


# ---------------------------------------------------------------------------------------------------------------
# Figures and the CLI
# ---------------------------------------------------------------------------------------------------------------


def test_cli_time_domain_end_to_end(records, tmp_path, capsys):
    from jaxroll._cli import main

    folder = tmp_path / "roll"
    for i, rec in enumerate(records):
        save_record(rec, folder / f"roll_H7_T10_r{i + 1:02d}.csv")
    out = tmp_path / "cal"
    code = main(["calibrate", "roll", str(folder), "--estimator", "time-domain", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    text = capsys.readouterr().out
    assert "multiple shooting: 22 windows of 97.6 s" in text
    cal = json.loads((out / "calibration.json").read_text())
    assert cal["jaxroll_version"] == jxr.__version__
    assert cal["method"] == "multiple shooting" and cal["windows"] == 22
    assert cal["config"]["estimator"] == "time-domain" and cal["config"][
        "shooting_window_s"
    ] == pytest.approx(97.6)
    assert cal["correlation"]["names"] == list(PARAMS) and len(cal["correlation"]["matrix"]) == 3
    assert cal["condition_number"] > 1 and 0.04 < cal["residual_rms_deg"] < 0.06
    assert len(cal["records"]) == 2 and cal["warnings"] == []
    for k in PARAMS:
        e = cal["estimates"][k]
        assert set(e) >= {"value", "std_error", "ci95", "unit"}
        assert abs(e["value"] - TRUE_VALUES[k]) < 3 * e["std_error"]  # the file rounds roll to 0.0001°
    ship = jxr.load_ship(out / "ship.toml")
    assert float(ship.gm_correction) == pytest.approx(cal["estimates"]["gm_correction"]["value"], rel=1e-12)
    for name in ("roll_fit.png", "residual_spectrum.png"):
        assert (out / name).stat().st_size > 0
    assert_labelled_output(out, "calibration")


def test_cli_checks_before_computing(records, tmp_path, capsys, monkeypatch):
    from jaxroll._cli import main

    def boom(*a, **k):
        raise AssertionError("fitted before checking the inputs")

    monkeypatch.setattr("jaxroll.calibration.fit_roll_time_domain", boom)
    monkeypatch.setattr("jaxroll.calibration.fit_roll_kalman", boom)
    folder = tmp_path / "roll"
    save_record(records[0], folder / "r1.csv")
    out = str(tmp_path / "cal")
    base = ["calibrate", "roll", str(folder), "--out", out]
    cases = [
        (["--estimator", "time-domain", "--params", "b1,a7"], "--params: unknown parameter 'a7'"),
        (["--estimator", "kalman", "--params", "delta_gm_scale"], "is `gm_correction` itself"),
        (["--params", "roll_period"], "not a parameter of the roll model the pdf estimator fits"),
        (
            ["--estimator", "time-domain", "--shooting-window", "5000"],
            "is longer than the record's analysis span",
        ),
        (["--estimator", "time-domain", "--method", "filter"], "--method belong(s) to --estimator pdf"),
        (["--estimator", "kalman", "--shooting-window", "100"], "belongs to --estimator time-domain"),
        (["--estimator", "time-domain", "--window", "70", "340"], "70–340 s model scale is not covered"),
    ]
    for extra, message in cases:
        assert main(base + extra) == 2, extra
        err = capsys.readouterr().err
        assert message in err, (extra, err)
    # parameters are checked before the records are even read
    assert (
        main(
            [
                "calibrate",
                "roll",
                str(tmp_path / "missing.csv"),
                "--estimator",
                "time-domain",
                "--params",
                "a7",
            ]
        )
        == 2
    )
    assert "unknown parameter 'a7'" in capsys.readouterr().err
    # a decay record has no wave column
    dec = tmp_path / "decay"
    save_record(virtual_decay_record(TRUTH, duration_model_s=30.0), dec / "d.csv")
    assert main(["calibrate", "roll", str(dec), "--estimator", "kalman", "--out", out]) == 2
    assert "no `wave` column" in capsys.readouterr().err
    # a record file that does not say where its probe is
    text = (folder / "r1.csv").read_text().splitlines()
    bad = tmp_path / "noprobe"
    bad.mkdir()
    (bad / "r.csv").write_text("\n".join(line for line in text if "probe_x_model_m" not in line) + "\n")
    assert main(["calibrate", "roll", str(bad), "--estimator", "time-domain", "--out", out]) == 2
    assert "probe_x_model_m" in capsys.readouterr().err


def test_plots_return_figures(ms_fit, kf_fit):
    import matplotlib
    import matplotlib.pyplot as plt

    from jaxroll.plotting import plot_residual_spectrum, plot_time_domain_fit

    for fit in (ms_fit, kf_fit):  # shooting windows; the Kalman filter's record cut into blocks
        fig = plot_time_domain_fit(fit, windows=3)
        assert isinstance(fig, matplotlib.figure.Figure) and len(fig.axes) == 3
        assert isinstance(plot_residual_spectrum(fit), matplotlib.axes.Axes)
    with pytest.raises(ValueError, match="no curves for record 4"):
        plot_time_domain_fit(ms_fit, record=4)
    plt.close("all")


def test_cli_kalman_end_to_end(records, kf_fit, tmp_path, capsys):
    from jaxroll._cli import main

    save_record(records[0], tmp_path / "roll" / "r1.csv.gz")
    out = tmp_path / "cal"
    code = main(
        [
            "calibrate",
            "roll",
            str(tmp_path / "roll"),
            "--estimator",
            "kalman",
            "--out",
            str(out),
            "--params",
            "b1,b2,gm_correction",
        ]
    )
    assert code == 0, capsys.readouterr().err
    cal = json.loads((out / "calibration.json").read_text())
    assert cal["method"] == "extended Kalman filter (ML)" and cal["config"]["shooting_window_s"] is None
    assert set(cal["estimates"]) == set(PARAMS) | {"process_noise", "measurement_noise"}
    for k in PARAMS:  # the same record as `kf_fit`, written to 0.0001° and 0.001 mm
        e, ref = cal["estimates"][k], kf_fit.estimates[k]
        assert abs(e["value"] - ref.value) < 0.1 * ref.std_error and e["std_error"] == pytest.approx(
            ref.std_error, rel=0.05
        )
    assert jxr.load_ship(out / "ship.toml").damping[1] == pytest.approx(
        cal["estimates"]["b2"]["value"], rel=1e-12
    )


# ---------------------------------------------------------------------------------------------------------------
# Slow: SE against the spread of 20 independent records; coverage under model error (docs/calibration.md)
# ---------------------------------------------------------------------------------------------------------------


def _z_scores(fits, k):
    return np.array([(f.estimates[k].value - TRUE_VALUES[k]) / f.estimates[k].std_error for f in fits])


@pytest.mark.slow
def test_standard_error_matches_spread_over_20_records():
    fits = []
    for i in range(20):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fits.append(fit_roll_time_domain(SHIP, _record(1000 + i, wave_noise_mm=0.0), params=PARAMS))
    for k in PARAMS:
        rms_z = float(np.sqrt(np.mean(_z_scores(fits, k) ** 2)))
        # records differ in roll amplitude, so their SEs differ: the spread in SE units (rms z) must be 1 ± 30 %.
        # Measured: b1 1.02, b2 1.26, r 0.85 (noise-free probe). With 0.1 mm probe noise b2 reaches 1.45: the
        # noisy excitation is not in the shooting model.
        assert 0.7 < rms_z < 1.3, (k, rms_z)


@pytest.mark.slow
def test_kalman_covers_truth_under_model_error():
    kalman, shooting = [], []
    for i in range(20):
        rec = _record(1000 + i, moment_std=5e-4)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            kalman.append(fit_roll_kalman(SHIP, rec, params=PARAMS))
            shooting.append(fit_roll_time_domain(SHIP, rec, params=PARAMS))
    for k in PARAMS:
        cover = np.mean([f.estimates[k].ci95[0] <= TRUE_VALUES[k] <= f.estimates[k].ci95[1] for f in kalman])
        assert cover >= 0.8, (k, cover)  # measured 90 / 95 / 100 %
        # the filter is the more precise estimator under model error (measured: SD 2.6×, 3.6×, 4.8× smaller)
        sd_k = np.std([f.estimates[k].value for f in kalman], ddof=1)
        sd_s = np.std([f.estimates[k].value for f in shooting], ddof=1)
        assert sd_k < sd_s, (k, sd_k, sd_s)
