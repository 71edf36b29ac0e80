"""Issue 37 (round two of bad input): every case fails on the code before the fix and passes after.

Items 2 (unit slips in tank records), 3 (implausible ship files), 4 (negative fitted damping), 6 (breaking seas and
the theories' range), 11 (options checked before any computation) and the "Figures and words" section; item 5
(edited checkpoints) is in tests/test_scaling.py. `benchmarks/bad_input_audit.py` re-runs the whole corpus.
"""

import json
import math
import re
import sys

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jxr
from jaxroll._cli import main
from jaxroll.calibration import calibrated_ship, check_wave_heights, nonnegative_damping
from jaxroll.io import RecordError, make_record, save_record
from jaxroll.ship import excitation_validity, validity_warnings

C11_TOML = jxr.ship_to_toml(jxr.c11_representative())


def _ship_file(tmp_path, old, new):
    assert old in C11_TOML
    path = tmp_path / "ship.toml"
    path.write_text(C11_TOML.replace(old, new))
    return path


# ----------------------------------------------------------------------------------------------------------------
# Item 3: implausible ship files
# ----------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "old, new, message",
    [
        # mm typed as m: no hull of B 40 m, d 11.5 m, C_b 0.56 has GM0 above d + B²/(12 C_b d) = 32.2 m
        (
            "gm0_m = 1.9299",
            "gm0_m = 1929.9",
            r"gm0_m = 1929.9 m is more than any hull .* = 32.2 m .*typed in mm, it "
            r"would be 1.93 m",
        ),
        (
            "lpp_m = 262.0",
            "lpp_m = 262000.0",
            r"lpp_m = 262000 m is beyond any ship .*typed in mm, it would be 262 m",
        ),
    ],
)
def test_impossible_ship_values_are_refused(tmp_path, old, new, message):
    with pytest.raises(ValueError, match=message):
        jxr.load_ship(_ship_file(tmp_path, old, new))


@pytest.mark.parametrize(
    "old, new, message",
    [
        (
            "c1 = 0.55",
            "c1 = 1000000000.0",
            r"ΔGM\(ζ_mid\) reaches 5.75e\+09 m at ζ_mid = 5.75 m .*check c1 = 1e\+09",
        ),
        ("a3 = -0.0165775403135739", "a3 = -50.0", r"angle of vanishing stability is 2.09° \(a3 = -50"),
        (
            "b1 = 0.007725227836696213",
            "b1 = 1000000.0",
            r"roll damping ratio at 20° is 1.942e\+06 \(b1 = 1e\+06",
        ),
        ("gm_ratio = 1.0", "gm_ratio = 4.3e-08", r"gm_ratio = 4.3e-08 is outside 0.2-5"),
        (
            "displacement_kg = 67247000.0",
            "displacement_kg = 67247.0",
            r"displacement_kg = 6.725e\+04 kg is 0.000972 × ρ C_b L B d",
        ),
        # GM0 in hectometres? Tφ 24.4 s with GM0 0.0193 m needs a roll radius of gyration of 0.042 B
        ("gm0_m = 1.9299", "gm0_m = 0.019299", r"imply a roll radius of gyration k = .* = 1.69 m = 0.0422 B"),
    ],
)
def test_implausible_ship_values_are_warned_with_the_value(tmp_path, old, new, message):
    with pytest.warns(UserWarning, match=message):
        jxr.load_ship(_ship_file(tmp_path, old, new))


def test_default_and_hull_derived_ships_raise_no_plausibility_warning():
    """The bands of `PLAUSIBLE` hold every ship the project ships (filterwarnings = error turns one into a failure)."""
    jxr.load_ship(_write_text(C11_TOML))
    jxr.c11_hull_ship()


def _write_text(text, name="ship.toml"):
    import tempfile
    from pathlib import Path

    path = Path(tempfile.mkdtemp()) / name
    path.write_text(text)
    return path


def test_max_possible_gm_is_the_box_bound():
    # A box barge (C_b = 1): BM = B²/(12 d) exactly, KB = d/2, so its GM with KG = 0 is d/2 + B²/(12 d) <= the bound.
    b, d = 40.0, 11.5
    assert jxr.ship.max_possible_gm(b, d, 1.0) == pytest.approx(d + b**2 / (12 * d), rel=1e-15)
    assert d / 2 + b**2 / (12 * d) < jxr.ship.max_possible_gm(b, d, 1.0)


def test_ship_show_and_pdf_name_the_real_cause(tmp_path, capsys):
    """`ship show` refuses Lpp 262 km with the unit slip, and `pdf` says the same (it used to fail on the filter fit
    with advice about --method superposition)."""
    path = _ship_file(tmp_path, "lpp_m = 262.0", "lpp_m = 262000.0")
    for argv in (
        ["ship", "show", "--ship", str(path)],
        ["pdf", "--ship", str(path), "--realizations", "2", "--out", str(tmp_path / "o")],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "lpp_m = 262000 m is beyond any ship" in err and "superposition" not in err
    assert not (tmp_path / "o").exists()


@pytest.mark.filterwarnings("default::UserWarning")  # shown, as the command shows them (not raised)
def test_ship_show_warns_on_a_vanishing_angle_of_two_degrees(tmp_path, capsys):
    assert (
        main(["ship", "show", "--ship", str(_ship_file(tmp_path, "a3 = -0.0165775403135739", "a3 = -50.0"))])
        == 0
    )
    err = capsys.readouterr().err
    assert (
        "jaxroll ship show: warning: ship 'C11 (representative)': the angle of vanishing stability is 2.09°"
        in err
    )


# ----------------------------------------------------------------------------------------------------------------
# Item 2: unit slips in tank records
# ----------------------------------------------------------------------------------------------------------------


def _captive(hs_header, wave_scale, seed=0, n=8000):
    """A captive record (full scale in memory) whose measured wave has 4σ = hs_header × wave_scale."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.5
    wave = rng.standard_normal(n)
    wave *= hs_header * wave_scale / 4 / wave.std()
    return make_record(
        "captive",
        t,
        {"wave": wave, "delta_gm": 0.01 * wave},
        scale=100.0,
        sampling_hz=20.0,
        wave_height_full_m=hs_header,
        wave_period_full_s=10.0,
        probe_x_model_m=0.0,
        speed_model_m_s=0.0,
        heel_deg=0.0,
    )


WHOLE = (0.0, 400.0)  # model-scale seconds: the whole of `_captive`'s records (8000 samples of 0.05 s)


def test_wave_height_check_measures_4_sigma():
    (row,) = check_wave_heights([_captive(7.0, 1.0), _captive(7.0, 1.0, seed=1)], WHOLE)
    np.testing.assert_allclose(row["hs_measured_m"], 7.0, rtol=1e-12, atol=0)  # each record exactly 4σ = 7 m
    assert row["n_records"] == 2 and row["hs_header_m"] == 7.0


@pytest.mark.parametrize(
    "scale, error, message",
    [
        (
            1000.0,
            True,
            r"4σ of the measured wave is 7000 m .* header says H1/3 = 7 m .*1e\+03 × the header's; likely "
            r"a wave column in mm labelled m",
        ),
        (1e-3, True, r"0.007 m .*likely a wave column in m labelled mm"),
        (100.0, True, r"likely full-scale wave values in a model-scale file \(scale λ = 100\)"),
        (1.4, False, r"4σ of the measured wave is 9.8 m .*1.4 × the header's. This warning appears because"),
        (0.9, None, None),  # within 25 %: a tank's sea
    ],
)
def test_wave_height_slip_refused_or_warned(scale, error, message):
    records = [_captive(7.0, scale)]
    if error is None:
        check_wave_heights(records, WHOLE)  # no warning (filterwarnings = error)
    elif error:
        with pytest.raises(RecordError, match=message):
            check_wave_heights(records, WHOLE)
    else:
        with pytest.warns(UserWarning, match=message):
            check_wave_heights(records, WHOLE)


def test_captive_fit_refuses_wave_in_mm_labelled_m():
    """Issue 37: the captive fit gave gm_ratio = 4.3e-08 and exit 0; now the records are refused first."""
    with pytest.raises(RecordError, match=r"likely a wave column in mm labelled m"):
        jxr.calibration.fit_captive([_captive(7.0, 1000.0)], jxr.c11_representative())


def test_cli_calibrate_refuses_mislabelled_wave_column(tmp_path, capsys):
    """The file route: records written with their wave in mm and a header that says m."""
    record = _captive(7.0, 1.0)
    save_record(record, tmp_path / "r.csv")  # wave written in mm (the default unit)
    text = (tmp_path / "r.csv").read_text().replace("# units: s, mm, mm", "# units: s, m, mm")
    (tmp_path / "r.csv").write_text(text)
    assert (
        main(
            [
                "calibrate",
                "captive",
                str(tmp_path / "r.csv"),
                "--window",
                "0",
                "400",
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert re.search(
        r"4σ of the measured wave is 7000 m \(full scale\) but the header says H1/3 = 7 m", err
    ), err
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------------------------------------------
# Item 4: negative fitted damping
# ----------------------------------------------------------------------------------------------------------------


def test_nonnegative_damping_is_the_constrained_least_squares_fit():
    """For a fit linear in its parameters the projection is exact: compare with the least-squares fit made with b2
    held at 0 (a design matrix whose columns are correlated, so b1 and b3 must move)."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((200, 3)) @ np.array([[1.0, 0.6, 0.1], [0.0, 1.0, 0.4], [0.0, 0.0, 1.0]])
    y = x @ np.array([0.5, -0.08, 0.3]) + 0.01 * rng.standard_normal(200)
    theta, *_ = np.linalg.lstsq(x, y, rcond=None)
    cov = np.linalg.inv(x.T @ x) * np.var(y - x @ theta, ddof=3)
    values, changed = nonnegative_damping(("b1", "b2", "b3"), theta, cov)
    free, *_ = np.linalg.lstsq(x[:, [0, 2]], y, rcond=None)
    np.testing.assert_allclose(values, [free[0], 0.0, free[1]], rtol=1e-10, atol=1e-14)
    assert changed["b2"]["fitted"] == theta[1] < 0 and changed["b2"]["written"] == 0.0
    assert set(changed) == {"b1", "b2", "b3"}
    untouched, none = nonnegative_damping(("b1", "b2", "b3"), np.abs(theta), cov)
    np.testing.assert_array_equal(untouched, np.abs(theta))
    assert none == {}


def _decay_fit(b, cov):
    from jaxroll.calibration import DecayFit, Estimate, LeastSquaresInfo

    est = {
        k: Estimate(float(v), float(math.sqrt(cov[i, i])), "-")
        for i, (k, v) in enumerate(zip(("b1", "b2", "b3"), b))
    }
    info = LeastSquaresInfo(
        n_obs=0, n_params=3, rss=0.0, sigma=0.0, num_steps=0, result="", condition_number=1.0
    )
    return DecayFit("extinction", est, np.asarray(cov), est, Estimate(24.4, 0.0, "s"), 0.2575, info, {}, {})


def test_calibrated_ship_says_when_it_holds_damping_at_zero():
    """Issue 37: b2 = −0.081 became 0 in ship.toml without a word (and b1 kept its value fitted beside −0.081)."""
    cov = np.array([[1e-8, -2e-7, 0.0], [-2e-7, 1e-4, 0.0], [0.0, 0.0, 1e-2]])
    fit = _decay_fit([0.012, -0.081, 0.0], cov)
    with pytest.warns(
        UserWarning,
        match=r"decay fit \(extinction\): b2 = -0.081 ± 0.01 \(8.1 standard errors below "
        r"0\).* b2 = 0 and b1 0.012 → 0.011838",
    ):
        ship = calibrated_ship(jxr.c11_representative(), decay=fit)
    np.testing.assert_allclose(ship.damping, [0.012 - 2e-7 / 1e-4 * 0.081, 0.0, 0.0], rtol=1e-12, atol=1e-15)
    assert "b2 held at 0 (fitted -0.081)" in ship.provenance


# ----------------------------------------------------------------------------------------------------------------
# Item 6: breaking seas, the model's range and the averaging theories' ε
# ----------------------------------------------------------------------------------------------------------------


def test_breaking_steepness_follows_dnv():
    assert jxr.breaking_steepness(5.0) == pytest.approx(1 / 15, rel=1e-15)
    assert jxr.breaking_steepness(20.0) == pytest.approx(1 / 25, rel=1e-15)
    assert jxr.breaking_steepness(11.5) == pytest.approx((1 / 15 + 1 / 25) / 2, rel=1e-15)  # linear between
    s = jxr.sea_steepness(jxr.ITTC(30.0, 10.0))
    tp = (
        2 * math.pi / ((0.8 * (2 * math.pi / math.gamma(0.75)) ** 4) ** 0.25 / 10.0)
    )  # ITTC peak: ω_p⁴ = 4B/5
    assert s["peak_period_s"] == pytest.approx(tp, rel=1e-13)
    assert s["steepness"] == pytest.approx(2 * math.pi * 30.0 / (9.80665 * tp**2), rel=1e-13)
    assert s["max_hs_m"] == pytest.approx(s["limit"] * 9.80665 * tp**2 / (2 * math.pi), rel=1e-13)


def test_steep_sea_is_warned_and_the_paper_seas_are_not():
    with pytest.warns(
        UserWarning,
        match=r"H1/3 = 30 m .* S_p = 2π H1/3/\(g T_p²\) = 0.114 .*beyond the breaking limit "
        r"1/20.9 .*H1/3 <= 12.5 m",
    ):
        jxr.EffectiveWave(jxr.ITTC(30.0, 10.0), 262.0)
    for hs in (5.0, 7.0):
        jxr.EffectiveWave(jxr.ITTC(hs, 10.0), 262.0)  # no warning (filterwarnings = error)


def test_excitation_validity_closed_form():
    """A linear ΔGM (c1 only): E[ΔGM] = 0 and σ[rΔGM] = r c1 σ_G exactly, so ε = r c1 σ_G / GM0."""
    ship = eqx.tree_at(
        lambda s: (s.delta_gm, s.gm_correction),
        jxr.c11_representative(),
        (jnp.array([0.0, 0.55, 0, 0, 0, 0, 0]), jnp.asarray(0.8)),
    )
    wave = jxr.EffectiveWave(jxr.ITTC(7.0, 10.0), 262.0)
    v = excitation_validity(ship, wave)
    sigma = math.sqrt(float(wave.variance()))
    np.testing.assert_allclose(v["sigma_zeta_mid_m"], sigma, rtol=1e-6, atol=0)  # trapezoid vs log quadrature
    np.testing.assert_allclose(
        v["stiffness_variation"], 0.8 * 0.55 * v["sigma_zeta_mid_m"] / 1.9299, rtol=1e-12, atol=0
    )
    assert v["mean_gm_shift"] == pytest.approx(0.0, abs=1e-15)
    assert v["zeta_range"] == pytest.approx(3 * v["sigma_zeta_mid_m"] / 11.5, rel=1e-12)


def test_validity_warnings_at_30_m_and_none_at_7_m():
    ship = jxr.c11_representative()
    with pytest.warns(UserWarning):  # the breaking-steepness warning of the wave itself
        steep = jxr.EffectiveWave(jxr.ITTC(30.0, 10.0), 262.0)
    messages = validity_warnings(excitation_validity(ship, steep), ("roberts", "esam", "moment"))
    assert len(messages) == 2
    assert re.search(
        r"σ = 5.34 m, so ζ_mid reaches 3σ = 16 m, beyond min\(draught, freeboard\) = 11.5 m", messages[0]
    )
    assert re.search(
        r"^roberts, esam: the GM in waves varies by ε = .* = 0.817 of its mean \(mean GM 1.74 × GM0\)",
        messages[1],
    )
    assert (
        validity_warnings(
            excitation_validity(ship, jxr.EffectiveWave(jxr.ITTC(7.0, 10.0), 262.0)),
            ("roberts", "esam", "envelope_fpk"),
        )
        == []
    )


@pytest.mark.filterwarnings("default::UserWarning")
def test_theory_cli_at_30_m_says_the_averaging_is_out_of_range(tmp_path, capsys):
    """Issue 37: `--hs 30` ran without a word and Roberts/ESAM gave 2.5° against 15° from the Monte Carlo."""
    assert main(["theory", "--hs", "30", "--theory", "roberts,esam", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert (
        "beyond the breaking limit" in err
        and "ζ_mid reaches 3σ" in err
        and "roberts, esam: the GM in waves" in err
    )
    warnings = json.loads((tmp_path / "theory.json").read_text())["warnings"]
    assert len(warnings) == 3 and len(err.strip().splitlines()) >= 3


# ----------------------------------------------------------------------------------------------------------------
# Item 11: options checked before any computation
# ----------------------------------------------------------------------------------------------------------------


@pytest.fixture
def no_computation(monkeypatch):
    """Any sea-state problem or filter fit fails the test: the command must refuse before building one."""

    def boom(*args, **kwargs):
        raise AssertionError("a computation started before the options were checked")

    monkeypatch.setattr(jxr.RollProblem, "from_sea", classmethod(boom))
    monkeypatch.setattr(jxr.roll._equation, "fit_filter", boom)


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["pdf", "--dt", "1e-9"],
            r"--duration / --dt = 3600 s / 1e-09 s = 3.6e\+12 time steps per realization",
        ),
        (["pdf", "--duration", "1e12"], r"--duration / --dt = 1e\+12 s / 0.5 s = 2e\+12 time steps"),
        (
            ["maxima", "--dt", "1e-9"],
            r"the duration max\(--n0\) needs \(--duration\) / --dt = 195749 s / 1e-09 s",
        ),
        (["maxima", "--n0", "1000000000"], r"the duration max\(--n0\) needs \(--duration\) / --dt"),
        (["risk", "--hours", "1e9"], r"--discard \+ --hours / --dt = 3.6e\+12 s"),
        (["sweep", "--duration", "1e12"], r"--duration / --dt = 1e\+12 s"),
        (["sensitivity", "--dt", "1e-9"], r"--duration / --dt = 3600 s / 1e-09 s"),
        (
            ["sensitivity", "--method", "superposition", "--wrt", "hs"],
            r"sea-parameter derivatives need the filter",
        ),
    ],
)
def test_step_counts_are_refused_before_any_fit(no_computation, tmp_path, capsys, argv, message):
    assert main([*argv, "--out", str(tmp_path / "o")]) == 2
    assert re.search(message, capsys.readouterr().err)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc is Linux's")
@pytest.mark.parametrize("command", ["pdf", "maxima", "risk", "sweep", "theory", "sensitivity"])
def test_unwritable_out_is_refused_before_any_fit(no_computation, capsys, command):
    """A folder no one can write into (here /proc, refused even for root, unlike a chmod) is reported at once."""
    assert main([command, "--out", "/proc/jaxroll-audit"]) == 2
    assert (
        "--out '/proc/jaxroll-audit' cannot be written: no file can be created in '/proc'"
        in capsys.readouterr().err
    )


# ----------------------------------------------------------------------------------------------------------------
# Figures and words
# ----------------------------------------------------------------------------------------------------------------


def test_sparse_tail_merged_so_p_star_has_no_zeros_inside_the_data():
    """P* of the Monte Carlo amplitude law had zeros near 65-70° at N0 = 10⁴: empty 1° bins in its tail."""
    from jaxroll.roll._statistics import _spread_sparse_bins

    counts = np.array([0.0, 3, 50, 40, 20, 8, 0, 1, 0, 2, 0, 0, 0])
    spread = _spread_sparse_bins(counts, 10)
    np.testing.assert_allclose(spread, [53 / 3] * 3 + [40, 20] + [11 / 5] * 5 + [0, 0, 0], rtol=1e-15, atol=0)
    assert spread.sum() == counts.sum()
    stats = jxr.AmplitudeStatistics(
        edges_deg=np.arange(0, 90.0001, 0.05),
        counts_zero_crossing=np.zeros(1800),
        counts_envelope=np.zeros(1800),
        capsized=np.zeros(1, bool),
        capsize_time=np.zeros(1),
    )
    per_degree = np.zeros(90)
    per_degree[:50] = 1000.0 * np.exp(-(((np.arange(50) - 15.0) / 10.0) ** 2))  # a bulk around 15°
    per_degree[45:52] = [40, 12, 5, 0, 2, 0, 1]  # a sparse tail with empty 1° bins, as 2000 trials give
    stats.counts_zero_crossing[::20] = np.round(per_degree)
    law = stats.law("zero_crossing", pool=20, min_count=10)
    a = np.deg2rad(np.linspace(44.0, 51.9, 80))  # the tail, up to the last amplitude seen
    assert np.all(np.asarray(jxr.max_pdf(law, a, 10_000)) > 0)
    sparse = stats.law("zero_crossing", pool=20)
    assert np.any(np.asarray(jxr.max_pdf(sparse, a, 10_000)) == 0)  # what it was


def test_maxima_terminal_line_has_no_infinity():
    from jaxroll._cli.maxima import maxima_line

    v = {
        "quantiles_deg": {"99": None},
        "n_known": 500,
        "n_capsized": 50,
        "capsize_probability": 0.1,
        "mean_deg": None,
        "mean_deg_given_no_capsize": 59.4,
    }
    line = maxima_line(v)
    assert "∞" not in line and "mean max 59.40° for the trials that did not capsize" in line
    assert maxima_line({**v, "n_capsized": 0, "mean_deg": 20.0, "quantiles_deg": {"99": 40.0}}).startswith(
        "mean max 20.00°, 99 % 40.00°"
    )


def test_risk_probability_near_one_keeps_its_digits():
    from jaxroll._cli.risk import _no_exceedance, probability_text

    q, n = 0.03, 885.0
    complement = _no_exceedance(q, n)
    np.testing.assert_allclose(complement, (1 - q) ** n, rtol=1e-12, atol=0)
    assert probability_text(1 - complement, complement) == "1 − 2e-12"  # it printed 1.0000 (CI 1.0000–1.0000)
    assert probability_text(0.25, 0.75) == "0.2500" and probability_text(1.0, 0.0) == "1"


def test_sensitivity_chart_labels_are_words():
    from jaxroll.plotting._sensitivity import parameter_label, statistic_label

    assert statistic_label("E_phi2_deg2") == "E[φ²] [deg²]"  # it read 'Δ E_phi2_deg2'
    assert statistic_label("P_exceed_20deg") == "P(envelope > 20°)"
    assert statistic_label("P_exceed_zc_30deg") == "P(zero-crossing amplitude > 30°)"
    assert parameter_label("hs", 0.7) == "H1/3\n+0.7 m"


def test_polar_chart_speed_labels_stop_short_of_the_rim():
    import matplotlib.pyplot as plt

    from jaxroll.plotting import polar_risk_chart

    fig, ax = plt.subplots(subplot_kw={"projection": "polar"})
    polar_risk_chart(ax, [0, 90, 180], [0, 2, 4], np.zeros((3, 3)))
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert labels == [
        "0",
        "2",
        "4 m/s",
    ]  # the grid's speeds; nothing at the rim (5 m/s), where it hit "180° head"
    plt.close(fig)
