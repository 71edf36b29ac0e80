"""benchmarks/maxima_theory.py (issue 14 item 4): its Kolmogorov–Smirnov distance, and P* from the envelope
Fokker–Planck method's per-half-cycle law."""

import importlib.util
import math
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats as sps

import jaxroll
from jaxroll import extremes, theory

_PATH = Path(__file__).resolve().parent.parent / "benchmarks" / "maxima_theory.py"
_spec = importlib.util.spec_from_file_location("maxima_theory", _PATH)
mt = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mt)


def _rayleigh_maxima(n_trials, n0, seed):
    """A small Monte Carlo of the paper's protocol on Rayleigh amplitudes (σ = 1): max of n0 per trial."""
    rng = np.random.default_rng(seed)
    return rng.rayleigh(1.0, size=(n_trials, n0)).max(axis=1)


def test_ks_distance_equals_scipy():
    x = _rayleigh_maxima(400, 20, seed=1)
    for cdf in (
        lambda a: sps.rayleigh.cdf(a) ** 20,
        lambda a: sps.rayleigh.cdf(a / 1.05) ** 20,
        sps.norm(2.6).cdf,
    ):
        ref = sps.kstest(x, cdf)
        assert mt.ks_distance(x, cdf) == pytest.approx(ref.statistic, rel=1e-12, abs=1e-15)
        assert mt.ks_p_value(ref.statistic, x.size) == pytest.approx(ref.pvalue, rel=1e-6)
    # The 5 % critical value is where the exact p-value is 0.05.
    assert mt.ks_p_value(mt.ks_critical(400), 400) == pytest.approx(0.05, rel=1e-6)


def test_ks_distance_counts_capsizes_as_infinite():
    """A capsize (+inf) is a maximum beyond every finite angle: same D as a finite sample placed beyond the
    support of the hypothesised CDF."""
    x = _rayleigh_maxima(300, 20, seed=2)
    x[:7] = np.inf

    def cdf(a):
        return np.where(a < 50.0, sps.rayleigh.cdf(np.minimum(a, 50.0)) ** 20, 1.0)

    stand_in = np.where(np.isinf(x), 1e3, x)
    d = mt.ks_distance(x, cdf)
    assert d == pytest.approx(sps.kstest(stand_in, cdf).statistic, rel=1e-12)
    # Enough capsizes make the top gap the distance: F(∞) − n_finite/n.
    y = x.copy()
    y[:60] = np.inf
    assert mt.ks_distance(y, cdf) == pytest.approx(
        max(60 / 300, sps.kstest(np.where(np.isinf(y), 1e3, y), cdf).statistic)
    )
    with pytest.raises(ValueError):
        mt.ks_distance(np.array([1.0, np.nan]), cdf)


def test_ks_of_rayleigh_maxima_against_p_star():
    """P* from `jaxroll.extremes` with the KS distance: a correct law passes at the 1 % level, a 5 % scale error
    is rejected (N = 2000 trials of N0 = 100)."""
    x = _rayleigh_maxima(2000, 100, seed=3)
    law = jaxroll.RayleighLaw(1.0)

    def cdf(a):
        return np.asarray(extremes.max_cdf(law, jnp.asarray(a), 100))

    d = mt.ks_distance(x, cdf)
    assert mt.ks_p_value(d, x.size) > 0.01
    assert d < mt.ks_critical(x.size, 0.01)
    wrong = mt.ks_distance(x, lambda a: cdf(a / 1.05))
    assert wrong > mt.ks_critical(x.size, 0.001)
    # The kernel-density mode of the maxima estimates the mode of P* (Rayleigh: closed form via the library).
    mode, se = mt.kde_mode(x, bootstrap=20, seed=0)
    assert abs(mode - float(extremes.most_probable_maximum(law, 100))) < 4 * se + 0.02


@pytest.fixture(scope="module")
def fpk_zero_crossing():
    ship = jaxroll.c11_representative()
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), ship.lpp)
    return theory.envelope_fpk_pdf(ship, wave, estimator="zero_crossing")


@pytest.mark.parametrize("n0", [20, 1000, 10_000])
def test_envelope_fpk_p_star_normalised_and_mode(fpk_zero_crossing, n0):
    law = fpk_zero_crossing
    assert law.estimator == "zero_crossing"
    top = float(law.support_max)
    mode = float(extremes.most_probable_maximum(law, n0))
    # ∫ P* dA = 1: trapezoid on a grid fine enough for the exponential-within-cell PDF (P* is steep near its mode).
    grid = np.concatenate([np.linspace(0.0, top, 40_001), mode + np.linspace(-0.02, 0.02, 4001)])
    grid = np.unique(np.clip(grid, 0.0, top))
    p = np.asarray(extremes.max_pdf(law, jnp.asarray(grid), n0))
    assert np.all(np.isfinite(p)) and np.all(p >= 0)
    assert np.trapezoid(p, grid) == pytest.approx(1.0, abs=2e-3)
    # ... and its running integral is the CDF of the maximum.
    mid = float(extremes.max_quantile(law, 0.5, n0))
    below = grid <= mid
    assert np.trapezoid(p[below], grid[below]) == pytest.approx(0.5, abs=2e-3)
    # The mode is the argmax of P* on the fine grid. The law's PDF is exponential within each log-amplitude cell
    # and may step (by ~0.2 % here) at a cell edge; where the mode sits on an edge (N0 = 1000) the supremum is
    # the one-sided limit, so the value is compared with the larger side.
    fine = mode + np.linspace(-0.01, 0.01, 2001)
    pf = np.asarray(extremes.max_logpdf(law, jnp.asarray(fine), n0))
    assert abs(fine[np.argmax(pf)] - mode) <= 2 * (fine[1] - fine[0])
    at_mode = np.asarray(extremes.max_logpdf(law, jnp.asarray(mode + np.array([-1e-7, 0.0, 1e-7])), n0)).max()
    assert at_mode >= pf.max() - 1e-6
    assert at_mode >= np.log(p.max()) - 1e-6  # the global maximum, not a local one
    assert 0 < mode < top and math.isfinite(mode)
