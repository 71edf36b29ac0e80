"""Amplitude estimators: Hilbert envelope vs scipy, zero-crossing amplitudes vs the Rayleigh law."""

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import scipy.signal
import scipy.stats

import jaxroll
from jaxroll.roll._amplitudes import envelope_rfft, integer_counts, pdf_from_counts


def test_hilbert_envelope_matches_scipy(getkey):
    for n in (1000, 1001):
        x = jr.normal(getkey(), (3, n))
        np.testing.assert_allclose(
            jaxroll.hilbert_envelope(x),
            np.abs(scipy.signal.hilbert(np.asarray(x), axis=-1)),
            rtol=1e-10,
            atol=1e-12,
        )


def test_envelope_rfft_matches_scipy(getkey):
    for n in (1000, 1001):
        x = jr.normal(getkey(), (3, n))
        np.testing.assert_allclose(
            envelope_rfft(x), np.abs(scipy.signal.hilbert(np.asarray(x), axis=-1)), rtol=1e-10, atol=1e-12
        )


def test_zero_crossing_of_a_sine():
    t = np.arange(0, 100, 0.01)
    phi = 0.3 * np.sin(2 * np.pi * t / 10 + 0.1)
    amps = np.asarray(jaxroll.zero_crossing_amplitudes(jnp.asarray(phi)))
    amps = amps[amps > 0]
    # 20 half cycles; the first (incomplete) and the last (unfinished) are not counted.
    assert amps.size == 19
    np.testing.assert_allclose(amps, 0.3, rtol=2e-5, atol=0)


def test_zero_crossing_half_cycles_alternate_max_and_min():
    phi = jnp.array([0.1, 0.5, 0.2, -0.1, -0.7, -0.3, 0.2, 0.4, -0.2, -0.1, 0.1])
    amps = np.asarray(jaxroll.zero_crossing_amplitudes(phi))
    np.testing.assert_allclose(amps[amps > 0], [0.7, 0.4, 0.2], rtol=0, atol=1e-15)


def test_zero_crossing_amplitudes_of_narrow_band_gaussian_are_rayleigh(getkey):
    # A narrow-band Gaussian process (bandwidth 2 % of the centre frequency): amplitudes per half cycle follow
    # Rayleigh(σ). Synthesised by superposition so the law is exact up to the band's width.
    dt, n = 0.25, 2**16
    w = 2 * np.pi * np.fft.rfftfreq(n, dt)
    s = np.exp(-0.5 * ((w - 0.5) / 0.005) ** 2)
    key = getkey()
    xy = jr.normal(key, (2, w.size))
    coef = jnp.asarray(np.sqrt(s * (w[1] - w[0])) * n / 2, dtype=complex) * jax.lax.complex(xy[0], xy[1])
    x = jnp.fft.irfft(coef, n=n)
    sigma = float(jnp.sqrt(jnp.sum(s * (w[1] - w[0]))))
    amps = np.asarray(jaxroll.zero_crossing_amplitudes(x))
    amps = amps[amps > 0]
    # Successive half-cycle amplitudes are strongly correlated (narrow band): thin to one per ~band correlation
    # time so that the KS test sees nearly independent samples.
    thin = amps[::40]
    p = scipy.stats.kstest(thin / sigma, scipy.stats.rayleigh.cdf).pvalue
    assert p > 0.01, p
    # Mean amplitude σ√(π/2): standard error from the effective number of independent samples.
    se = np.std(amps) / np.sqrt(thin.size)
    assert abs(amps.mean() - sigma * np.sqrt(np.pi / 2)) < 4 * se


def test_envelope_of_a_sine_is_constant():
    t = np.arange(0, 200, 0.05)
    x = jnp.asarray(0.2 * np.cos(2 * np.pi * t / 10))
    env = np.asarray(jaxroll.hilbert_envelope(x))
    np.testing.assert_allclose(env, 0.2, rtol=1e-9, atol=0)  # 20 whole periods: periodic, exact


def test_histogram_and_pdf_normalisation():
    values = jnp.array([0.1, 0.5, 0.5, 2.9, 10.0])
    counts = integer_counts(values, jnp.array([True, True, True, True, True]), 1.0, 3)
    np.testing.assert_array_equal(counts, [3, 0, 2])  # larger values in the last bin
    kept = integer_counts(values, jnp.array([True, False, True, True, False]), 1.0, 3)
    np.testing.assert_array_equal(kept, [2, 0, 1])  # left-out values are not counted anywhere
    edges = jnp.arange(4.0)
    np.testing.assert_allclose(jnp.sum(pdf_from_counts(counts, edges) * jnp.diff(edges)), 1.0, rtol=1e-15)
    jax.block_until_ready(counts)
