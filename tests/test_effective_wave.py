"""Grim's effective wave: transfer function, Method 1 (superposition) and Method 2 (shaping filter)."""

import re

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
import scipy.linalg
import scipy.signal

import jaxroll
from jaxroll.sea._filters import filter_from_parameters

L = 262.0


def test_grim_transfer_special_values():
    np.testing.assert_allclose(jaxroll.grim_transfer(2 * np.pi / L, L), 1.0, rtol=1e-14, atol=0)
    np.testing.assert_allclose(jaxroll.grim_transfer(2 * np.pi / (0.8 * L), L), 1.0004, atol=1e-4, rtol=0)
    for n in (2, 3, 4):
        np.testing.assert_allclose(jaxroll.grim_transfer(2 * np.pi * n / L, L), 0.0, atol=1e-14, rtol=0)
    assert abs(float(jaxroll.grim_transfer(1e-6, L))) < 1e-6


@pytest.mark.parametrize("wavelength_over_l", [0.6, 0.85, 1.0, 1.3, 2.0, 4.0])
def test_grim_transfer_equals_least_squares_fit(wavelength_over_l):
    """F(k) is the least-squares amplitude of cos(2πx/L) fitted to a sampled profile a·cos(kx) over the hull."""
    k = 2 * np.pi / (wavelength_over_l * L)
    x = -L / 2 + (np.arange(20000) + 0.5) * L / 20000  # midpoint rule: the discrete fit is the continuous one
    profile = np.cos(k * x)
    basis = np.stack([np.cos(2 * np.pi * x / L), np.ones_like(x)], 1)  # a mean level changes nothing
    coef, *_ = np.linalg.lstsq(basis, profile, rcond=None)
    np.testing.assert_allclose(jaxroll.grim_transfer(k, L), coef[0], rtol=1e-6, atol=1e-8)


def test_effective_wave_numbers_match_theory():
    # THEORY.md §1 table: σ_G = 1.246 m (7 m), 0.890 m (5 m). Its S_G⁺(2ω0) = 9.33 / 4.76 m²s are 0.17 % high:
    # the closed form F(k)²S(ω) at zero speed gives 9.3144 / 4.7522 (checked here independently in numpy).
    w0 = 2 * np.pi / 24.4
    w = 2 * w0
    kl = w**2 / 9.80665 * L
    f = kl * np.sin(kl / 2) / (np.pi**2 - (kl / 2) ** 2)
    b = (2 * np.pi / 1.2254167024651779) ** 4 / 10.0**4  # Γ(3/4) = 1.2254167024651779
    for hs, sigma in ((7.0, 1.246), (5.0, 0.890)):
        wave = jaxroll.EffectiveWave(jaxroll.ITTC(hs, 10.0), L)
        np.testing.assert_allclose(jnp.sqrt(wave.variance()), sigma, atol=1e-3, rtol=0)
        s = b * hs**2 / 4 * w**-5 * np.exp(-b * w**-4)
        np.testing.assert_allclose(wave.spectrum(w), f**2 * s, rtol=1e-12, atol=0)
    np.testing.assert_allclose(
        jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L).spectrum(w), 9.3144, atol=1e-4
    )


def test_superposition_variance_and_derivative(getkey):
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L)
    n, dt = 7201, 0.5
    zs, dzs = jax.vmap(lambda k: jaxroll.superpose(wave, k, n, dt))(jr.split(getkey(), 64))
    var = float(jnp.var(zs))
    # Each realization is exactly Gaussian with the discretised spectrum; the sample variance of 64 records of
    # 3600 s scatters by ~sqrt(2 τ_c / T / 64) ≈ 1.5 %: allow 4 standard errors.
    np.testing.assert_allclose(var, wave.variance(), rtol=0.06, atol=0)
    # The derivative channel is the exact derivative of the synthesised series.
    fd = (zs[:, 2:] - zs[:, :-2]) / (2 * dt)
    err = jnp.sqrt(jnp.mean((fd - dzs[:, 1:-1]) ** 2) / jnp.mean(dzs**2))
    assert float(err) < 0.05  # central difference error (ωdt)²/6 at ω ≈ 0.6 rad/s
    # Does not repeat within the trial: the FFT period exceeds the record length.
    assert jaxroll.sea._grim.superposition_length(n) >= n


def test_filter_spectrum_matches_scipy_freqs():
    f = filter_from_parameters(jnp.array([np.log(0.5), np.log(0.2), np.log(0.7), np.log(0.3), 1.0, 0.3]), 4)
    num = np.asarray(f.c)[::-1]
    den = np.concatenate([[1.0], -np.asarray(f.a[-1])[::-1]])
    w = np.linspace(0.05, 2.0, 200)
    _, h = scipy.signal.freqs(np.trim_zeros(num, "f"), den, worN=w)
    np.testing.assert_allclose(f.spectrum(w), np.abs(h) ** 2 / np.pi, rtol=1e-10, atol=0)


def test_filter_fit_derivative_in_the_sea():
    """The fit's derivative in the sea parameters (the implicit function theorem at the optimum, `_at_optimum`):
    in H1/3 exact — S_G ∝ H², so the fitted shape is fixed and only the gain scales, dc/dH = c/H —; in T01 equal
    to a central difference of two fits (h = 1e-3 s: the fits' tolerance limits the agreement to ~2e-4; it also
    equals optimistix's own implicit adjoint of the same fit within rtol 1e-8, measured in session 12). Reverse mode:
    test_sensitivity's d(filter gain)/d(H1/3)."""

    def fitted(hs, t01):
        f = jaxroll.fit_filter(jaxroll.EffectiveWave(jaxroll.ITTC(hs, t01), L), match_frequency=0.515).filter
        return jnp.concatenate([f.a[-1], f.c])

    jvp = jax.jit(lambda hs, t01, dh, dt: jax.jvp(fitted, (hs, t01), (dh, dt)))
    value, d_hs = jvp(7.0, 10.0, 1.0, 0.0)
    np.testing.assert_allclose(d_hs, np.concatenate([np.zeros(4), value[4:] / 7.0]), rtol=1e-7, atol=1e-12)
    _, d_t01 = jvp(7.0, 10.0, 0.0, 1.0)
    d_t01 = np.asarray(d_t01)
    central = (fitted(7.0, 10.0 + 1e-3) - fitted(7.0, 10.0 - 1e-3)) / 2e-3
    np.testing.assert_allclose(d_t01, central, rtol=5e-4, atol=1e-9 * np.abs(d_t01).max())
    assert np.all(np.abs(d_t01[[0, 1, 2, 3, 5]]) > 1e-3 * np.abs(d_t01).max())  # every coefficient moves


@pytest.mark.parametrize("order", [3, 4, 6])
def test_filter_fit_variance_and_lyapunov(order):
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L)
    fit = jaxroll.fit_filter(wave, order=order, match_frequency=2 * 2 * np.pi / 24.4)
    f = fit.filter
    sigma = f.stationary_covariance()
    ref = scipy.linalg.solve_continuous_lyapunov(np.asarray(f.a), -np.outer(f.b, f.b))
    np.testing.assert_allclose(sigma, ref, rtol=1e-8, atol=1e-12 * np.abs(ref).max())
    # Variance matched exactly; equal to the integral of the filter's own spectrum.
    np.testing.assert_allclose(f.variance(), wave.variance(), rtol=1e-10, atol=0)
    np.testing.assert_allclose(jaxroll.spectral_moment(f.spectrum, 0), wave.variance(), rtol=1e-6, atol=0)
    assert np.all(np.linalg.eigvals(np.asarray(f.a)).real < 0)
    assert float(f.c @ f.b) == 0.0  # relative degree ≥ 2: ζ_G differentiable
    # THEORY.md §6: an order-4 fit has relative L2 error ≈ 0.06; higher orders fit better.
    assert float(fit.relative_l2_error) < {3: 0.25, 4: 0.07, 6: 0.03}[order]
    np.testing.assert_allclose(fit.spectrum_filter_at_match, fit.spectrum_target_at_match, rtol=0.03, atol=0)


def test_filter_exact_discretisation_statistics(getkey):
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L)
    f = jaxroll.fit_filter(wave, order=4).filter
    for m in (1, 4):
        exc = jaxroll.FilterExcitation(f, 0.5, m)
        # Exact step of H = m·dt: the stationary Σ is invariant under z' = Φz + Lε.
        sigma = f.stationary_covariance()
        np.testing.assert_allclose(
            exc.phi @ sigma @ exc.phi.T + exc.chol @ exc.chol.T,
            sigma,
            rtol=1e-9,
            atol=1e-12 * float(jnp.abs(sigma).max()),
        )

        def run(key, exc=exc, m=m):
            z, _ = exc.init(key, 0, m, jnp.float64)

            def body(z, i):
                return jax.lax.scan(lambda z, e: exc.advance(z, e, m), z, exc.block_inputs(key, z, i, m))

            _, values = jax.lax.scan(body, z, jnp.arange(7 if m == 4 else 28))
            return jnp.stack(values, -1)  # ζ_G at every half step

        zs = jax.vmap(run)(jr.split(getkey(), 64))
        np.testing.assert_allclose(jnp.var(zs), wave.variance(), rtol=0.06, atol=0)  # ≈ 4 standard errors
        # the lag-dt/2 autocovariance of the bridged series is the filter's own, cᵀ e^{A dt/2} Σ c
        half, _ = f.discretise(0.25)
        flat = zs.reshape(64, -1)
        lag = jnp.mean(flat[:, 1:] * flat[:, :-1])
        np.testing.assert_allclose(lag, f.c @ half @ sigma @ f.c, rtol=0.06, atol=0)


def test_filter_errors():
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L)
    with pytest.raises(ValueError, match="`order` must be >= 3"):
        jaxroll.fit_filter(wave, order=2)
    with pytest.raises(ValueError, match="`heading` must be 'head' or 'following'"):
        jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L, 0.0, "beam")
    with pytest.raises(ValueError, match="`speed` must be >= 0"):
        jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L, -1.0)


def test_filter_order_bounded_and_fit_gated():
    """Issue 13: order 30/40 corrupted the sea silently (indefinite Σ, |eig Φ| > 1); now refused or gated."""
    import equinox as eqx

    from jaxroll.sea._filters import MAX_FILTER_ORDER, check_filter_fit

    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L)
    for order in (MAX_FILTER_ORDER + 1, 30, 40):
        with pytest.raises(ValueError, match="`order` must be <="):
            jaxroll.fit_filter(wave, order=order)
    fit = jaxroll.fit_filter(wave, order=4, match_frequency=2 * 2 * np.pi / 24.4)
    assert check_filter_fit(fit, 0.5) == []  # a good fit passes every gate silently
    # A filter whose gain is wrong (variance by quadrature 4× the target) is refused, not simulated.
    bad = eqx.tree_at(lambda f: f.filter.c, fit, fit.filter.c * 2.0)
    with pytest.raises(ValueError, match="not usable.*variance.*Use the superposition excitation"):
        check_filter_fit(bad, 0.5)
    # An unstable filter (Σ not positive definite / Φ not contracting) is refused.
    unstable = eqx.tree_at(lambda f: f.filter.a, fit, fit.filter.a.at[-1, -1].set(1.0))
    with pytest.raises(ValueError, match="not usable"):
        check_filter_fit(unstable, 0.5)


def test_filter_fit_message_where_the_sea_has_no_energy_at_2w0():
    """Short waves (T01 = 4 s) have ≈ 2e-14 m² s at 2ω0, and the filter's tail 2e-4: the error gives the ratio
    and says why (it read '954071029177 % off'); a miss of a few hundred % keeps its percentage."""
    from jaxroll.sea._filters import check_filter_fit

    w2 = 2 * 2 * np.pi / 24.4
    # 2 m: a sea that exists at T01 = 4 s (7 m would be beyond breaking, S_p = 0.16 against 1/15, and is warned
    # about); the filter's miss at 2ω0 is a ratio of spectra, the same at any height
    short = jaxroll.fit_filter(jaxroll.EffectiveWave(jaxroll.ITTC(2.0, 4.0), L), order=4, match_frequency=w2)
    ratio = float(short.filter.spectrum(w2)) / float(short.spectrum_target_at_match)
    assert ratio > 1e9
    with pytest.raises(
        ValueError,
        match=rf"\(2ω0\) is .* \({re.escape(f'{ratio:.3g}')} times the target; the sea "
        "has almost no energy at 2ω0",
    ):
        check_filter_fit(short)
    following = jaxroll.fit_filter(jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), L, 8.0, "following"), order=4,
                                   match_frequency=w2)  # fmt: skip
    with pytest.raises(ValueError, match=r"\(3\d\d % off\)"):
        check_filter_fit(following)


# ----------------------------------------------------------------------------------------------------------------
# The filter's order chosen on the band the roll responds to (issue 42)
# ----------------------------------------------------------------------------------------------------------------


def test_backbone_frequency_equals_the_exact_duffing_period():
    """ω(A) of x'' + a x + b x³ = 0 is 2π / [4 K(m) / √(a + b A²)], m = b A² / (2(a + b A²)) (complete elliptic
    integral of the first kind, scipy's parameter m): the softening default ship's GZ with a5 = 0."""
    import math

    import equinox as eqx
    from scipy.special import ellipk

    ship = jaxroll.c11_representative()
    duffing = eqx.tree_at(lambda s: s.restoring, ship, ship.restoring.at[1].set(0.0))
    a, b = float(duffing.omega0) ** 2, float(duffing.restoring[0])
    amp = np.radians([1e-8, 5.0, 20.0, 40.0, 60.0])
    exact = 2 * np.pi / (4 * ellipk(b * amp**2 / (2 * (a + b * amp**2))) / np.sqrt(a + b * amp**2))
    got = np.asarray(jaxroll.ship.backbone_frequency(duffing, jnp.asarray(amp)))
    np.testing.assert_allclose(got, exact, rtol=1e-10)
    assert math.isclose(float(jaxroll.ship.backbone_frequency(ship, 0.0)), float(ship.omega0), rel_tol=1e-14)
    np.testing.assert_allclose(
        float(jaxroll.ship.angle_of_maximum_gz(ship)), np.radians(45.97), atol=np.radians(0.05)
    )


def test_parametric_band_of_the_default_ship():
    from jaxroll.roll._equation import parametric_band

    ship = jaxroll.c11_representative()
    lo, hi = parametric_band(ship)
    w_top = float(jaxroll.ship.backbone_frequency(ship, jaxroll.ship.angle_of_maximum_gz(ship)))
    np.testing.assert_allclose([lo, hi], [0.9 * 2 * w_top, 1.1 * 2 * float(ship.omega0)], rtol=1e-14)
    np.testing.assert_allclose([lo, hi], [0.4177, 0.5665], atol=5e-4)


def _spectra_on(fit, wave, band, num=301):
    """The filter's and S_G on the band by the JAX spectra themselves (not `band_error`'s interpolation)."""
    grid = jnp.linspace(band[0], band[1], num)
    return np.asarray(fit.filter.spectrum(grid)), np.asarray(wave.spectrum(grid))


def test_filter_order_chosen_on_the_band_follows_the_spectrum_there():
    """T01 = 8 s head seas: the paper's order 4 is off by up to 30 % of S_G on the band the roll feels (0.42–0.57
    rad/s); `fit_filter_in_band` goes to order 8, within 5 %, and reports it."""
    from jaxroll.roll._equation import parametric_band

    ship = jaxroll.c11_representative()
    band = parametric_band(ship)
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(6.0, 8.0), ship.lpp)
    four = jaxroll.fit_filter(wave, order=4, match_frequency=2 * ship.omega0)
    s4, sg = _spectra_on(four, wave, band)
    level = np.maximum(sg, 0.1 * sg.max())
    assert np.max(np.abs(s4 - sg) / level) > 0.25
    fit = jaxroll.sea.fit_filter_in_band(wave, band, match_frequency=2 * ship.omega0)
    assert fit.filter.order == 8
    sf, sg = _spectra_on(fit, wave, band)
    err = np.max(np.abs(sf - sg) / level)
    assert err <= 0.05 and abs(err - float(fit.band_error)) < 2e-3
    np.testing.assert_allclose(float(fit.variance_filter), float(wave.variance()), rtol=1e-10)
    assert fit.summary()["order_chosen"] == "auto" and fit.summary()["band_error"] == float(fit.band_error)


def test_filter_order_auto_is_the_default_and_the_papers_order_stays_selectable():
    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    auto = jaxroll.RollProblem.from_sea(ship, sea)
    assert auto.filter_fit.filter.order == 8 and float(auto.filter_fit.band_error) <= 0.05
    with pytest.warns(
        UserWarning, match=r"order-4 shaping filter's spectrum is 1\d % off .* 0.418–0.567 rad/s"
    ):
        paper = jaxroll.RollProblem.from_sea(ship, sea, filter_order=4)
    assert paper.filter_fit.filter.order == 4 and paper.filter_fit.band_error is None
    with pytest.raises(ValueError, match="integer >= 3 or 'auto'"):
        jaxroll.RollProblem.from_sea(ship, sea, filter_order="eight")

    def traced(hs):
        return jaxroll.RollProblem.from_sea(
            ship, jaxroll.ITTC(hs, 10.0), validate=False
        ).filter_fit.variance_target

    with pytest.raises(ValueError, match="give the nominal problem's order"):
        jax.jit(traced)(7.0)


def test_a_band_no_order_follows_is_said_with_its_error():
    """Head seas at 5 m/s, T01 8 s: encounter moves the sea's peak off the band and no order of 4 or 8 follows S_G
    there within 5 %: a warning gives the best order's error and names the superposition."""
    from jaxroll.roll._equation import parametric_band

    ship = jaxroll.c11_representative()
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(6.0, 8.0), ship.lpp, 5.0)
    with pytest.warns(UserWarning, match=r"order 8, is 1\d % off there.*superposition"):
        fit = jaxroll.sea.fit_filter_in_band(wave, parametric_band(ship), match_frequency=2 * ship.omega0)
    assert 0.1 < float(fit.band_error) < 0.2
    with pytest.raises(ValueError, match="0 < lo < hi"):
        jaxroll.sea.fit_filter_in_band(wave, (0.5, 0.4))
