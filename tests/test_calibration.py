"""Calibration round trips through the virtual tank: decay (extinction curve and ODE fit), captive tests
(σ_obs/σ_thr),
free-running roll PDFs; standard errors against repeated synthetic experiments; the CLI; the notebook.

Tolerances are derived from each fit's own standard error (k = 4, as for statistical tests elsewhere), and the
standard errors themselves are checked against the spread of repeated synthetic experiments.
"""

import dataclasses
import json
import math
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_labelled_output, run_notebook

import jaxroll as jxr
from jaxroll.calibration import (
    DEFAULT_BANDS,
    band_means,
    calibrated_ship,
    damping_to_extinction,
    decay_agreement,
    decay_solution,
    effective_wave_from_probe,
    extinction_to_damping,
    fit_captive,
    fit_decay_ode,
    fit_extinction,
    fit_roll_pdf,
    virtual_captive_record,
    virtual_decay_record,
    virtual_roll_record,
    virtual_sea,
)
from jaxroll.calibration._roll_pdf import _np_band_means

K = 4.0  # tolerance in standard errors
BASE = jxr.c11_representative()
B_TRUE = np.array([0.0077252, 0.5, 2.0])  # b3 ≠ 0 so that all three are exercised
DECAY_SHIP = eqx.tree_at(lambda s: s.damping, BASE, jnp.asarray(B_TRUE))
NAMES = ("b1", "b2", "b3")
ALL3 = "linear+quadratic+cubic"  # B_TRUE has all three terms


def _with_noise(rec, sigma_deg, seed):
    rng = np.random.default_rng(seed)
    return dataclasses.replace(
        rec, channels={"roll": rec.roll + np.radians(sigma_deg) * rng.normal(size=rec.roll.size)}
    )


@pytest.fixture(scope="module")
def clean_decay():
    return virtual_decay_record(DECAY_SHIP, initial_roll_deg=20.0, duration_model_s=60.0)


# ------------------------------------------------------------------------------------------------------------
# Decay
# ------------------------------------------------------------------------------------------------------------


def test_extinction_conversion_is_energy_balance():
    """THEORY.md §3: a = πb1/(2ω0), b = 4b2/3, c = 3πω0b3/8 — checked by the energy lost over one half swing
    of φ = A cos ω0 t, by quadrature."""
    omega0 = float(BASE.omega0)
    b = B_TRUE
    a_, b_, c_ = damping_to_extinction(*b, omega0)
    np.testing.assert_allclose(extinction_to_damping(a_, b_, c_, omega0), b, rtol=1e-13, atol=0)
    for amp in (0.05, 0.2, 0.4):
        t = np.linspace(0, math.pi / omega0, 200_001)
        v = -amp * omega0 * np.sin(omega0 * t)
        power = v * (b[0] * v + b[1] * v * np.abs(v) + b[2] * v**3)
        energy = np.sum((power[1:] + power[:-1]) / 2 * np.diff(t))
        decrement = energy / (omega0**2 * amp)  # dE = ω0² A dA
        np.testing.assert_allclose(decrement, a_ * amp + b_ * amp**2 + c_ * amp**3, rtol=1e-9, atol=0)


def test_first_order_conversion_bias_is_small_and_corrected(clean_decay):
    """Noise-free decay: the plain conversion is off by O(damping) (documented), the bias correction removes
    it."""
    raw = fit_extinction(clean_decay, BASE, correct_bias=False, damping_model=ALL3)
    corrected = fit_extinction(clean_decay, BASE, correct_bias=True, damping_model=ALL3)
    rel = (raw.b - B_TRUE) / B_TRUE
    assert abs(rel[0]) < 0.02 and abs(rel[1]) < 0.03 and abs(rel[2]) < 0.1  # first-order theory, 20° release
    np.testing.assert_allclose(corrected.b, B_TRUE, rtol=4e-3, atol=0)  # two multiplicative updates


def test_decay_methods_recover_truth_and_agree(clean_decay):
    rec = _with_noise(clean_decay, 0.05, seed=7)
    ext = fit_extinction(rec, BASE, damping_model=ALL3)
    ode = fit_decay_ode(rec, BASE, damping_model=ALL3)
    assert ode.info.converged and ext.info.converged
    for fit in (ext, ode):
        for name, truth in zip(NAMES, B_TRUE):
            e = fit.damping[name]
            assert abs(e.value - truth) < K * e.std_error, (fit.method, name, e, truth)
    assert abs(ode.roll_period.value - 24.4) < K * ode.roll_period.std_error + 1e-4
    z = decay_agreement(ext, ode)
    assert all(abs(v) < 3.0 for v in z.values()), z
    # the ODE fit uses every sample: it is far more precise than the extremes alone
    assert all(ode.damping[n].std_error < 0.5 * ext.damping[n].std_error for n in NAMES)


def test_extinction_standard_errors_match_repeated_experiments(clean_decay):
    est, se = [], []
    for seed in range(12):
        fit = fit_extinction(
            _with_noise(clean_decay, 0.1, seed), BASE, correct_bias=False, damping_model=ALL3
        )  # same SE, faster
        est.append(fit.b)
        se.append([fit.damping[n].std_error for n in NAMES])
    ratio = np.std(est, axis=0, ddof=1) / np.mean(se, axis=0)
    # 12 repeats estimate a std within about ±25 %; decrements share extremes (MA(1) errors), so the
    # independent-residual SE is somewhat conservative: accept a factor of 3 either way.
    assert np.all((ratio > 1 / 3) & (ratio < 3)), ratio


def test_decay_recovery_degrades_gracefully_with_noise(clean_decay):
    errors, ses = [], []
    for sigma in (0.02, 0.1, 0.5):
        ode = fit_decay_ode(_with_noise(clean_decay, sigma, seed=3), BASE, damping_model=ALL3)
        ext = fit_extinction(_with_noise(clean_decay, sigma, seed=3), BASE, damping_model=ALL3)
        assert np.all(np.isfinite(ode.b)) and np.all(np.isfinite(ext.b))
        errors.append(abs(ode.b[0] - B_TRUE[0]))
        ses.append([ode.damping["b1"].std_error, ext.damping["b1"].std_error])
        assert abs(ode.b[0] - B_TRUE[0]) < K * ode.damping["b1"].std_error
    ses = np.array(ses)
    assert np.all(np.diff(ses, axis=0) > 0), ses  # the uncertainty grows with the noise
    assert errors[-1] > errors[0]


@pytest.mark.slow
def test_ode_standard_errors_match_repeated_experiments(clean_decay):
    est, se = [], []
    for seed in range(12):
        fit = fit_decay_ode(_with_noise(clean_decay, 0.1, seed), BASE, damping_model=ALL3)
        est.append(fit.b)
        se.append([fit.damping[n].std_error for n in NAMES])
    ratio = np.std(est, axis=0, ddof=1) / np.mean(se, axis=0)
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio


def test_decay_solution_matches_project_integrator():
    """The diffrax decay used for fitting agrees with the RK4 integrator that writes the virtual records."""
    rec = virtual_decay_record(DECAY_SHIP, initial_roll_deg=20.0, duration_model_s=20.0)
    phi = decay_solution(DECAY_SHIP, math.radians(20.0), 0.0, jnp.asarray(rec.time))
    np.testing.assert_allclose(np.asarray(phi), rec.roll, rtol=0, atol=1e-6)


def test_decay_solution_is_diffraxs_solve_bit_for_bit_and_nan_where_it_fails():
    """Issue 43: `decay_solution` runs diffrax's Tsit5 step and PID controller in its own loop (no host callback,
    so its programs can be stored): the same values and forward-mode derivatives as `diffrax.diffeqsolve` with
    `SaveAt(ts=...)`, to the last bit; NaN at every sample where the integration fails, instead of raising."""
    import diffrax

    from jaxroll.calibration._decay import _decay_field

    ts = jnp.asarray(np.arange(400) * 0.37)

    def reference(p):
        return diffrax.diffeqsolve(
            diffrax.ODETerm(_decay_field),
            diffrax.Tsit5(),
            t0=0.0,
            t1=ts[-1],
            dt0=None,
            y0=p,
            args=DECAY_SHIP,
            saveat=diffrax.SaveAt(ts=ts),
            stepsize_controller=diffrax.PIDController(rtol=1e-9, atol=1e-12),
            adjoint=diffrax.ForwardMode(),
            max_steps=200_000,
        ).ys[:, 0]

    p = jnp.asarray([math.radians(12.0), 0.01])
    ours = eqx.filter_jit(lambda p: decay_solution(DECAY_SHIP, p[0], p[1], ts))
    np.testing.assert_array_equal(np.asarray(ours(p)), np.asarray(eqx.filter_jit(reference)(p)))
    np.testing.assert_array_equal(
        np.asarray(jax.jacfwd(ours)(p)), np.asarray(eqx.filter_jit(jax.jacfwd(reference))(p))
    )
    assert "callback" not in jax.jit(lambda p: decay_solution(DECAY_SHIP, p[0], p[1], ts)).lower(p).as_text()
    short = decay_solution(DECAY_SHIP, p[0], p[1], ts, max_steps=50)  # 50 steps do not reach 148 s
    assert np.all(np.isnan(np.asarray(short)))
    capsize = decay_solution(DECAY_SHIP, math.radians(74.0), 0.0, ts)  # beyond the vanishing angle (71.6°)
    assert np.all(np.isnan(np.asarray(capsize)))


def test_decay_fits_are_stored_programs_a_new_process_reads_back(tmp_path, monkeypatch):
    """Issue 43 (`calibrate decay` warm): with the persistent cache on (as the `jaxroll` command runs), the
    extinction and ODE fits export their programs once; a new process (here: the loaded programs forgotten) reads
    them back, tracing nothing, and gives the same estimates to the last bit."""
    pytest.importorskip("flatbuffers")
    from jaxroll import _compiled
    from jaxroll.calibration import _decay

    rec = virtual_decay_record(DECAY_SHIP, initial_roll_deg=20.0, duration_model_s=40.0)
    monkeypatch.setattr(_compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(_compiled, "_LOADED", {})
    traced = []
    solution = _decay.decay_solution
    monkeypatch.setattr(_decay, "decay_solution", lambda *a, **k: traced.append(1) or solution(*a, **k))
    first = [fit_extinction(rec, BASE), fit_decay_ode(rec, BASE)]
    stored = sorted(tmp_path.glob("*.npz"))
    assert len(stored) == 2 and all(p.stat().st_size > 1000 for p in stored)  # programs, not "cannot export"
    assert traced  # the ODE fit's program traced once, to export it
    traced.clear()
    _compiled._LOADED.clear()
    again = [fit_extinction(rec, BASE), fit_decay_ode(rec, BASE)]
    assert sorted(tmp_path.glob("*.npz")) == stored and not traced  # read back, not traced or exported again
    for a, b in zip(first, again):
        np.testing.assert_array_equal(a.b, b.b)
        assert a.roll_period == b.roll_period and a.damping == b.damping  # values and standard errors
    assert (
        first[1].b[0] > 0
        and first[1].b[1] > 0
        and first[1].roll_period.value == pytest.approx(24.4, rel=0.01)
    )


# ------------------------------------------------------------------------------------------------------------
# Captive
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("probe_x, speed", [(200.0, 0.0), (0.0, 0.0), (-150.0, 0.0), (200.0, 3.0)])
def test_effective_wave_from_one_probe(probe_x, speed):
    """ζ_G rebuilt from a single probe by FFT + dispersion equals the synthesis, away from the record ends."""
    n, dt = 7201, 0.5
    elev, zg, _ = virtual_sea(
        jxr.ITTC(5.0, 10.0), jax.random.key(3), n, dt, length=262.0, probes=(probe_x,), speed=speed
    )
    rebuilt = np.asarray(effective_wave_from_probe(elev[0], dt, length=262.0, probe_x=probe_x, speed=speed))
    inner = slice(1400, 6800)  # the paper's 70–340 s model-scale window
    err = rebuilt[inner] - np.asarray(zg)[inner]
    assert np.sqrt(np.mean(err**2)) < 1e-4 * np.std(np.asarray(zg))


CAPTIVE_SEAS = [(5.0, 10.0), (5.0, 12.37), (7.0, 10.0)]


def _captive_records(ratio, wave_mm, gm_mm, n=3, heels=(0.0, 10.0)):
    ship = eqx.tree_at(lambda s: s.gm_correction, BASE, jnp.asarray(ratio))
    return [
        virtual_captive_record(
            ship,
            jxr.ITTC(hs, t),
            heel_deg=h,
            seed=1000 * i + 100 * int(h) + k,
            wave_noise_mm=wave_mm,
            gm_noise_mm=gm_mm,
        )
        for i, (hs, t) in enumerate(CAPTIVE_SEAS)
        for h in heels
        for k in range(n)
    ]


def test_captive_recovers_gm_ratio_and_degrades_gracefully():
    truth = 0.8
    errors = []
    for wave_mm, gm_mm in ((0.1, 0.1), (0.5, 0.5), (2.0, 2.0)):
        fit = fit_captive(_captive_records(truth, wave_mm, gm_mm), BASE, fit_polynomial=True)
        assert fit.info.converged
        ls = fit.ls_scale
        assert abs(ls.value - truth) < K * ls.std_error, (wave_mm, ls)
        # σ_obs/σ_thr is inflated by ΔGM noise: σ_obs² = r²σ_thr² + σ_n² (σ_n in full-scale metres)
        sigma_n = gm_mm * 1e-3 * 100
        x2 = np.mean(np.concatenate([(s["theory"] - s["theory"].mean()) ** 2 for s in fit.series]))
        expected = math.sqrt(truth**2 + sigma_n**2 / x2)
        assert abs(fit.std_ratio.value - expected) < K * fit.std_ratio.std_error + 2e-3, (
            fit.std_ratio,
            expected,
        )
        # the observed polynomial: C1 = r·0.55
        assert abs(fit.polynomial["c1"].value - truth * 0.55) < K * fit.polynomial["c1"].std_error
        # standard error of a group against the spread of its realizations
        for g in fit.groups:
            spread = np.std(g.per_record_ratio, ddof=1) / math.sqrt(g.n_records)
            assert 0.2 < g.std_ratio.std_error / spread < 5.0, (g, spread)
        errors.append(abs(ls.value - truth))
        ses = fit.ls_scale.std_error
    assert ses > 0 and errors[-1] > errors[0]


# ------------------------------------------------------------------------------------------------------------
# Free-running roll
# ------------------------------------------------------------------------------------------------------------


def test_band_means_and_hysteresis_helpers():
    rng = np.random.default_rng(0)
    x = rng.exponential(size=2001)
    mask = np.ones(x.size, bool)
    mask[::5] = False
    got = np.asarray(band_means(jnp.asarray(x), jnp.asarray(mask), DEFAULT_BANDS))
    np.testing.assert_allclose(got, _np_band_means(x[mask], DEFAULT_BANDS), rtol=1e-12, atol=0)
    s = np.sort(x[mask])
    n = s.size
    np.testing.assert_allclose(got[4], s[int(0.4 * n) : int(0.5 * n)].mean(), rtol=5e-3, atol=0)
    # band means are smooth in the samples: their gradient spreads over the band
    g = jax.grad(lambda v: band_means(v, jnp.asarray(mask), DEFAULT_BANDS)[4])(jnp.asarray(x))
    assert int(jnp.sum(g > 0)) > 0.09 * n
    phi = jnp.asarray(np.sin(np.linspace(0.5, 40, 4001)) * np.linspace(1, 2, 4001))
    # independent reference: split at sign changes (φ ≥ 0 counts as positive), max |φ| of each complete half cycle
    x = np.asarray(phi)
    ends = np.nonzero((x[1:] >= 0) != (x[:-1] >= 0))[0] + 1
    ref = [np.abs(x[a:b]).max() for a, b in zip(ends[:-1], ends[1:])]
    got_amps = np.asarray(jxr.zero_crossing_amplitudes(phi, 0.0))
    np.testing.assert_allclose(got_amps[got_amps > 0], ref, rtol=0, atol=1e-15)
    noisy = phi + 0.02 * jnp.asarray(rng.normal(size=phi.size))
    amps = np.asarray(jxr.zero_crossing_amplitudes(noisy, 0.1))
    assert np.sum(amps > 0) == np.sum(np.asarray(jxr.zero_crossing_amplitudes(phi)) > 0)


@pytest.fixture(scope="module")
def roll_records():
    ship = eqx.tree_at(lambda s: s.gm_correction, BASE, jnp.asarray(0.8))
    return [
        virtual_roll_record(
            ship,
            jxr.ITTC(7.0, 10.0),
            seed=700 + k,
            sampling_hz=10.0,
            duration_model_s=345.0,
            roll_noise_deg=0.05,
        )[0]
        for k in range(10)
    ]


def test_roll_pdf_fit_recovers_gm_correction(roll_records):
    fit = fit_roll_pdf(roll_records, BASE, num_realizations=32)
    r = fit.estimates["gm_correction"]
    assert fit.info.converged, fit.info
    assert abs(r.value - 0.8) < K * r.std_error, r
    assert 0.005 < r.std_error < 0.1
    comp = fit.comparisons[0]
    err_before = np.abs(comp.model_band_means_before - comp.experiment_band_means)
    err_after = np.abs(comp.model_band_means_after - comp.experiment_band_means)
    assert err_after.mean() < 0.3 * err_before.mean()
    ship = calibrated_ship(BASE, roll=fit)
    np.testing.assert_allclose(float(ship.gm_correction), r.value, rtol=1e-12, atol=0)
    json.dumps(fit.to_dict())


def roberts_envelope_pdf(ship, sea, a):
    """Roberts' SAM stationary amplitude PDF (THEORY.md §4, linear ΔGM term), unnormalised, in JAX."""
    omega0 = ship.omega0
    s_g = jxr.EffectiveWave(sea, ship.lpp).spectrum(2 * omega0)  # one-sided
    s_xi = (ship.gm_correction * ship.delta_gm[1] / ship.gm0) ** 2 * s_g
    k = jnp.pi / 8 * omega0**2 * s_xi
    nu = 1 - ship.damping[0] / k
    c2 = 8 * ship.damping[1] * omega0 / (3 * jnp.pi * k)
    safe = jnp.where(a > 0, a, 1.0)
    return jnp.where(a > 0, jnp.exp(nu * jnp.log(safe) - c2 * safe), 0.0)


def test_roll_pdf_fit_with_a_theory_pdf(roll_records):
    fit = fit_roll_pdf(roll_records, BASE, theory=roberts_envelope_pdf, estimators=("envelope",))
    comp = fit.comparisons[0]
    assert fit.info.converged and np.isfinite(fit.estimates["gm_correction"].std_error)
    err_before = np.abs(comp.model_band_means_before - comp.experiment_band_means).mean()
    err_after = np.abs(comp.model_band_means_after - comp.experiment_band_means).mean()
    assert err_after < err_before


def test_roll_pdf_fit_input_errors(roll_records):
    with pytest.raises(ValueError, match="unknown parameter 'gm'"):
        fit_roll_pdf(roll_records, BASE, params=("gm",))
    with pytest.raises(ValueError, match="needs at least 3 per sea state"):
        fit_roll_pdf(roll_records[:2], BASE)
    with pytest.raises(ValueError, match="name the one estimator"):
        fit_roll_pdf(roll_records, BASE, theory=roberts_envelope_pdf)
    with pytest.raises(ValueError, match="a roll record is needed here; this is a decay record"):
        fit_roll_pdf([virtual_decay_record(BASE, duration_model_s=5.0)], BASE)


@pytest.mark.slow
def test_roll_pdf_fit_paper_protocol_two_sea_states():
    """24 realizations per sea state (5 m and 7 m), the paper's window, sensor noise: r within 4 SE."""
    ship = eqx.tree_at(lambda s: s.gm_correction, BASE, jnp.asarray(0.8))
    recs = [
        virtual_roll_record(ship, jxr.ITTC(hs, 10.0), seed=100 * int(hs) + k, roll_noise_deg=0.05)[0]
        for hs in (5.0, 7.0)
        for k in range(24)
    ]
    fit = fit_roll_pdf(recs, BASE, num_realizations=96)
    r = fit.estimates["gm_correction"]
    assert abs(r.value - 0.8) < K * r.std_error, r


@pytest.mark.slow
def test_roll_pdf_standard_error_matches_repeated_experiments():
    """Six independent tanks of 10 records: the spread of r̂ agrees with the reported SE, and r̂ is unbiased."""
    ship = eqx.tree_at(lambda s: s.gm_correction, BASE, jnp.asarray(0.8))
    est, se = [], []
    for d in range(6):
        recs = [
            virtual_roll_record(
                ship,
                jxr.ITTC(7.0, 10.0),
                seed=5000 * d + k,
                sampling_hz=10.0,
                duration_model_s=345.0,
                roll_noise_deg=0.05,
            )[0]
            for k in range(10)
        ]
        e = fit_roll_pdf(recs, BASE, num_realizations=32, seed=d).estimates["gm_correction"]
        est.append(e.value)
        se.append(e.std_error)
    ratio = np.std(est, ddof=1) / np.mean(se)
    assert 0.4 < ratio < 2.5, (est, se)  # 6 repeats: the std is known to about ±30 %
    assert abs(np.mean(est) - 0.8) < K * np.mean(se) / math.sqrt(len(est))


# ------------------------------------------------------------------------------------------------------------
# Plots, CLI, notebook
# ------------------------------------------------------------------------------------------------------------


def test_plots_return_axes(clean_decay):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jaxroll.plotting._calibration import (
        plot_captive,
        plot_captive_series,
        plot_decay_fit,
        plot_extinction,
    )

    ext = fit_extinction(clean_decay, BASE, correct_bias=True, damping_model=ALL3)
    ode = fit_decay_ode(clean_decay, BASE, damping_model=ALL3)
    cap = fit_captive(_captive_records(0.8, 0.3, 0.3, n=2, heels=(0.0,)), BASE)
    for ax in (plot_extinction([ext, ode]), plot_decay_fit(ode), plot_captive(cap), plot_captive_series(cap)):
        assert isinstance(ax, matplotlib.axes.Axes)
    with pytest.raises(ValueError, match="needs a fit from `fit_decay_ode`"):
        plot_decay_fit(ext)
    plt.close("all")


def test_cli_tank_then_calibrate_decay(tmp_path, capsys):
    from jaxroll._cli import main

    tank = tmp_path / "tank"
    assert (
        main(["tank", "--out", str(tank), "--tests", "decay", "--damping", *map(str, B_TRUE), "--quiet"]) == 0
    )
    truth = json.loads((tank / "truth.json").read_text())
    assert truth["truth"]["damping"]["b3_s_rad2"] == B_TRUE[2]
    out = tmp_path / "cal"
    # --roll-period: the ship tested (C11's GZ shape at 24.4 s), so a ship.toml is written
    cmd = [
        "calibrate",
        "decay",
        str(tank / "decay"),
        "--out",
        str(out),
        "--damping-model",
        "linear+quadratic+cubic",
    ]
    assert main([*cmd, "--roll-period", "24.4"]) == 0
    ship = jxr.load_ship(out / "ship.toml")
    cal = json.loads((out / "calibration.json").read_text())
    assert cal["jaxroll_version"] == jxr.__version__
    for name, truth_b in zip(NAMES, B_TRUE):
        e = cal["estimates"]["ode"]["damping"][name]
        assert abs(e["value"] - truth_b) < K * e["std_error"]
        assert getattr(ship, "damping")[NAMES.index(name)] == pytest.approx(max(e["value"], 0.0), rel=1e-12)
    assert (out / "extinction.png").stat().st_size > 0 and (out / "decay_fit.png").stat().st_size > 0
    assert_labelled_output(out, "calibration")
    assert main(["calibrate", "decay", str(tmp_path / "missing.csv"), "--out", str(out)]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_cli_calibrate_captive_on_example_records(tmp_path):
    from importlib.resources import files

    from jaxroll._cli import main

    records = Path(str(files("jaxroll") / "data" / "records" / "captive"))
    out = tmp_path / "cal"
    assert main(["calibrate", "captive", str(records), "--out", str(out), "--estimator", "ls"]) == 0
    ship = jxr.load_ship(out / "ship.toml")
    cal = json.loads((out / "calibration.json").read_text())
    ls = cal["estimates"]["ls_scale"]
    assert abs(float(ship.gm_correction) - ls["value"]) < 1e-12
    assert abs(ls["value"] - 0.8) < K * ls["std_error"] + 1e-3  # the examples' truth is 0.8
    assert_labelled_output(out, "calibration")


def test_notebook_04_runs_in_smoke_mode(tmp_path, monkeypatch):
    ns = run_notebook("04_calibration.ipynb", tmp_path, monkeypatch)
    assert ns["SMOKE"] and ns["rfit"].estimates["gm_correction"].std_error > 0


def test_dense_decay_records_are_decimated_not_overfitted():
    """Issue 13 case 7: a record sampled far more densely than the roll (a 10⁶-row record took 97 s and gave
    standard errors 30× too small) is decimated to ~50 samples per roll period: the same damping within its SE."""
    base = virtual_decay_record(DECAY_SHIP, initial_roll_deg=20.0, duration_model_s=60.0, sampling_hz=200.0)
    rec = _with_noise(base, 0.05, seed=11)
    fit = fit_decay_ode(rec, BASE, damping_model=ALL3)
    per_period = BASE.roll_period / rec.dt
    assert fit.config["decimation"] == [int(per_period) // 50] and fit.config["decimation"][0] >= 4
    for name, truth in zip(NAMES, B_TRUE):
        e = fit.damping[name]
        assert abs(e.value - truth) < K * e.std_error, (name, e, truth)


def test_a_fit_whose_solver_fails_says_what_to_check():
    """Issue 13 case 7: a decay near the vanishing angle made the ODE solver fail inside the fit and escape as an
    EquinoxRuntimeError traceback; now a ValueError (exit 2 on the command line) saying what to check."""
    from jaxroll.calibration._least_squares import FitFailure

    rec = virtual_decay_record(DECAY_SHIP, initial_roll_deg=20.0, duration_model_s=30.0)
    wild = dataclasses.replace(
        rec, channels={"roll": rec.roll * 3.7}
    )  # 74°: beyond the vanishing angle (71.6°), the model capsizes
    with (
        pytest.raises(FitFailure, match="roll unit"),
        pytest.warns(UserWarning, match="beyond any decay test"),
    ):
        fit_decay_ode(wild, BASE, damping_model=ALL3)
