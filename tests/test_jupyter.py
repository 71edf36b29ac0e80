"""Jupyter (issue 35, item 6): `explore()` draws what the library computes, headless; the result types' HTML
summaries hold their key numbers; `progress=True` draws a bar; the command's progress uses tqdm's notebook widget in
a kernel."""

import math
import sys
from importlib.resources import files
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxroll as jxr
from jaxroll._display import fmt
from jaxroll.notebook import Explorer, explore, explore_curves, explore_monte_carlo

EXAMPLES = Path(str(files("jaxroll") / "data" / "records"))
BINS = np.arange(0.0, 60.5, 0.5)


def wave_of(ship, hs, t01, speed=0.0, heading="head"):
    return jxr.EffectiveWave(jxr.ITTC(hs, t01), ship.lpp, speed, heading)


def test_explore_curves_equal_the_library_call():
    """The redraw's numbers for given slider values are `theory_summary`'s for that sea state and GM correction."""
    ship = jxr.c11_representative()
    got = explore_curves(
        ship,
        hs=6.5,
        t01=10.5,
        heading_deg=180.0,
        speed=1.0,
        gm_correction=0.9,
        theories=("envelope_fpk", "roberts"),
    )
    import equinox as eqx

    corrected = eqx.tree_at(lambda s: s.gm_correction, ship, jax.numpy.asarray(0.9))
    for name in ("envelope_fpk", "roberts"):
        _, direct = jxr.theory.theory_summary(name, corrected, wave_of(ship, 6.5, 10.5, 1.0), BINS)
        np.testing.assert_array_equal(got[name]["pdf_per_degree"], direct["pdf_per_degree"])
        assert got[name]["mean_amplitude_deg"] == direct["mean_amplitude_deg"]
    # the GM correction matters (a check that the slider reaches the ship)
    other = explore_curves(ship, hs=6.5, t01=10.5, speed=1.0, gm_correction=1.1, theories=("roberts",))
    assert other["roberts"]["mean_amplitude_deg"] > got["roberts"]["mean_amplitude_deg"] * 1.05
    # a sea state where a theory has no law: its reason, not an exception
    calm = explore_curves(ship, hs=1.0, t01=10.0, theories=("roberts",))
    assert isinstance(calm["roberts"], str) and calm["roberts"]
    with pytest.raises(ValueError, match=r"`heading_deg` must be in \[0, 180\]"):
        explore_curves(ship, heading_deg=200.0)
    with pytest.raises(ValueError, match="`gm_correction`"):
        explore_curves(ship, gm_correction=-1.0)


def test_explorer_headless_redraws_what_explore_curves_gives():
    ex = explore(hs=6.0, theories=("roberts",))
    assert isinstance(ex, Explorer) and ex.values()["hs"] == 6.0
    line = ex.ax.get_lines()[0]
    np.testing.assert_array_equal(
        line.get_ydata(), explore_curves(hs=6.0, theories=("roberts",))["roberts"]["pdf_per_degree"]
    )
    ex.sliders["hs"].value = 7.5  # the slider's callback redraws
    ex.sliders["gm_correction"].value = 0.85
    expected = explore_curves(hs=7.5, gm_correction=0.85, theories=("roberts",))["roberts"]
    np.testing.assert_array_equal(ex.ax.get_lines()[0].get_ydata(), expected["pdf_per_degree"])
    assert f"mean {expected['mean_amplitude_deg']:.2f}°" in ex.status.value
    assert "H1/3 = 7.5 m" in ex.ax.get_title() and "r = 0.85" in ex.ax.get_title()
    ex.checks["roberts"].value = False  # no theory ticked: nothing drawn, said so
    assert not ex.ax.get_lines() and "no theory ticked" in ex.status.value
    ex.log_scale.value = True
    assert ex.ax.get_yscale() == "log"
    bundle = ex._repr_mimebundle_()
    assert "application/vnd.jupyter.widget-view+json" in bundle


def test_explorer_monte_carlo_button_runs_the_library_monte_carlo():
    ex = Explorer(hs=7.0, theories=(), num_realizations=4, duration=600.0, discard=100.0, seed=3)
    stats = ex.run_monte_carlo()
    direct = explore_monte_carlo(hs=7.0, num_realizations=4, duration=600.0, discard=100.0, seed=3)
    problem = jxr.RollProblem.from_sea(jxr.c11_representative(), jxr.ITTC(7.0, 10.0), dt=0.5)
    lib = jxr.monte_carlo_amplitudes(
        problem, jax.random.key(3), num_realizations=4, duration=600.0, discard=100.0
    )
    for other in (direct, lib):
        np.testing.assert_array_equal(stats.counts_envelope, other.counts_envelope)
        np.testing.assert_array_equal(stats.capsized, other.capsized)
    (step,) = ex.ax.get_lines()
    np.testing.assert_array_equal(step.get_ydata(), stats.pdf_per_degree("envelope", BINS))
    assert "Monte Carlo: 4 trials" in ex.status.value
    ex.sliders["hs"].value = 6.0  # the Monte Carlo belongs to other values now: no longer drawn
    assert not ex.ax.get_lines()
    html = stats._repr_html_()  # the amplitude statistics' HTML summary holds its key numbers
    for estimator in ("zero_crossing", "envelope"):
        assert f"<td>{fmt(np.rad2deg(stats.mean(estimator)))}</td>" in html
        assert f"<td>{stats.n_amplitudes(estimator)}</td>" in html
        assert f"<td>{fmt(np.rad2deg(stats.quantiles(estimator))[2])}</td>" in html
    assert "4 realizations of 600 s (dt 0.5 s)" in html and "conditional on no capsize" in html


def test_explore_without_ipywidgets_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ipywidgets", None)  # import ipywidgets -> ImportError
    with pytest.raises(ImportError, match=r"pip install 'jaxroll\[notebook\]'"):
        jxr.explore()


def test_html_summaries_hold_their_key_numbers():
    law = jxr.RayleighLaw(math.radians(5.0))
    html = law._repr_html_()
    mean_deg = 5.0 * math.sqrt(math.pi / 2)  # Rayleigh mean σ√(π/2)
    assert f"<td>{fmt(mean_deg)}</td>" in html and "zero_crossing (per half cycle)" in html
    assert f"<td>{fmt(math.exp(-0.5 * (20 / 5) ** 2))}</td>" in html  # P(A > 20°) = exp(−a²/2σ²)
    assert "RayleighLaw" in html
    risk = jxr.exposure_risk(law, math.radians(20.0), rate=0.1, duration=10800.0, n_amplitudes=5000)
    html = risk._repr_html_()
    assert f"<td>{fmt(float(risk.probability))}</td>" in html and "<td>3</td>" in html  # 3 h
    assert f"<td>{fmt(float(np.rad2deg(risk.characteristic_largest)))}</td>" in html
    ship = jxr.c11_representative()
    html = ship._repr_html_()
    assert "C11 (representative)" in html and "<td>1.93</td>" in html and "<td>24.4</td>" in html
    assert "262, 40, 24.45, 11.5" in html and "representative" in html
    maxima = jxr.MaximaStatistics(
        n0=(20, 100),
        maxima_deg=np.array([[10.0, 12.0], [14.0, np.nan], [8.0, 9.0], [np.nan, np.nan]]),
        capsized=np.array([False, True, False, True]),
        capsize_time=np.array([np.inf, 900.0, np.inf, 100.0]),
        count=np.array([100, 40, 100, 5]),
    )
    html = maxima._repr_html_()
    # N0 = 20: 3 maxima known + 1 capsize before; mean of the survivors' maxima 32/3
    assert "<td>20</td><td>4</td><td>1</td><td>0.25</td>" in html and f"<td>{fmt(32 / 3)}</td>" in html
    assert "<td>100</td><td>4</td><td>2</td><td>0.5</td>" in html and "capsize" in html
    max_roll = jxr.MaxRollStatistics(
        max_abs_phi_deg=np.array([10.0, 35.0, 20.0, 50.0]),
        capsized=np.array([False, False, False, True]),
        capsize_time=np.array([np.inf, np.inf, np.inf, 50.0]),
        angle_deg=30.0,
        n_exceeded=2,
        config={"duration_s": 1800.0},
    )
    html = max_roll._repr_html_()
    assert "P(max |φ| &gt; 30°, or capsize)</td><td>0.5</td>" in html and "4 realizations of 1800 s" in html
    sweep = jxr.SweepResult(
        grid={"heading": ["head"], "speed_m_s": [0.0], "hs_m": [5.0, 7.0], "t01_s": [10.0]},
        n_realizations=10,
        angle_deg=30.0,
        confidence=0.95,
        n_capsized=np.array([[[[0], [2]]]]),
        n_exceeded=np.array([[[[1], [5]]]]),
    )
    html = sweep._repr_html_()
    assert "<td>head</td><td>0</td><td>7</td><td>10</td><td>0.2</td>" in html and "<td>0.5</td>" in html


def test_fit_summaries_hold_the_estimates():
    from jaxroll.io import load_records

    ship = jxr.c11_representative()
    fit = jxr.fit_captive(load_records(EXAMPLES / "captive", kind="captive"), ship)
    html = fit._repr_html_()
    r = fit.std_ratio
    decimals = max(0, 1 - math.floor(math.log10(r.std_error)))
    assert f"{r.value:.{decimals}f} ± {r.std_error:.2g}" in html and "3 records in 3 sea-state" in html
    decay = jxr.fit_extinction(load_records(EXAMPLES / "decay", kind="decay"), ship)
    html = decay._repr_html_()
    b1 = decay.damping["b1"]
    assert f"<td>b1</td><td>{b1.value:.{max(0, 1 - math.floor(math.log10(b1.std_error)))}f}" in html
    assert ("1/s" in html or "s-1" in html) and "Tφ: observed" in html  # issue 43: the observed period


def test_progress_true_draws_a_bar_and_changes_nothing(capsys):
    problem = jxr.RollProblem.from_sea(jxr.c11_representative(), jxr.ITTC(7.0, 10.0), dt=0.5)
    kw = dict(num_realizations=6, duration=300.0, chunk_size=3)
    plain = jxr.monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=20.0, **kw)
    barred = jxr.monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=20.0, progress=True, **kw)
    np.testing.assert_array_equal(plain.max_abs_phi_deg, barred.max_abs_phi_deg)
    err = capsys.readouterr().err
    assert "Monte Carlo" in err and "6/6" in err  # tqdm's text bar outside a notebook
    seen = []
    jxr.monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=20.0, progress=seen.append, **kw)
    assert seen[-1] == 6 and len(seen) >= 2 and seen == sorted(seen)  # after each chunk
    with pytest.raises(TypeError, match="`progress` must be True, False, None or a callable"):
        jxr.monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=20.0, progress="yes", **kw)


def test_cli_progress_uses_the_notebook_widget_in_a_kernel(monkeypatch):
    import jaxroll.notebook
    from jaxroll._cli._common import Progress

    quiet = Progress(10, "pdf")
    assert quiet.bar is None and not quiet.enabled  # not a terminal, not a kernel: silent (as before)
    monkeypatch.setattr(jaxroll.notebook, "in_notebook", lambda: True)
    p = Progress(10, "pdf")
    from tqdm.notebook import tqdm as notebook_tqdm

    assert isinstance(p.bar, notebook_tqdm) and p.enabled
    p(4)
    assert p.bar.n == 4
    p(10)
    assert p.bar.n == 10
    forced = Progress(10, "pdf", enabled=False)  # an explicit choice is kept
    assert forced.bar is None and not forced.enabled
