"""Tests of the parametric-excitation spectrum S_P, Roberts' SAM and ESAM (jaxroll.theory)."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
import scipy.integrate as si
import scipy.special as sc

import jaxroll as jxr
from jaxroll.theory import (
    RobertsCoefficients,
    esam_additive_pdf,
    esam_pdf,
    hermite_coefficients,
    hermite_covariance,
    parametric_spectrum,
    roberts_coefficients,
    roberts_log_normaliser,
    roberts_pdf,
    welch_parametric_spectrum,
)

SHIP = jxr.c11_representative()


def _wave(hs, ship=SHIP):
    return jxr.EffectiveWave(jxr.ITTC(hs, 10.0), ship.lpp)


def _s_g_numpy(omega, hs=7.0, t01=10.0, length=262.0):
    """Independent numpy S_G⁺(ω) [m² s] at zero speed: ITTC (exact constants) × Grim's F(k)², k = ω²/g."""
    omega = np.abs(np.asarray(omega, dtype=float))
    b = (2 * np.pi / math.gamma(0.75)) ** 4 / t01**4
    safe = np.where(omega > 0, omega, 1.0)
    s = np.where(omega > 0, b * hs**2 / 4 * safe**-5 * np.exp(-b * safe**-4), 0.0)
    x = safe**2 / 9.80665 * length / 2
    f = 2 * x * np.sin(x) / (np.pi**2 - x**2)
    return f**2 * s


@pytest.fixture(scope="module")
def spectra():
    return {hs: parametric_spectrum(SHIP, _wave(hs)) for hs in (5.0, 7.0)}


@pytest.fixture(scope="module")
def pdfs(spectra):
    """The default ship's PDFs, computed once (each configuration compiles once)."""
    out = {}
    for hs, sp in spectra.items():
        out["roberts", hs] = roberts_pdf(SHIP, sp)
        out["roberts_nonlinear_zc", hs] = roberts_pdf(
            SHIP, sp, restoring="nonlinear", estimator="zero_crossing"
        )
        out["esam", hs] = esam_pdf(SHIP, sp)
    out["esam_zc", 7.0] = esam_pdf(SHIP, spectra[7.0], estimator="zero_crossing")
    return out


# ------------------------------------------------------------------------------------------------------------
# S_P
# ------------------------------------------------------------------------------------------------------------


def _gauss_hermite_2d(num=12):
    x, w = np.polynomial.hermite_e.hermegauss(num)
    w = w / w.sum()
    return x[:, None], x[None, :], w[:, None] * w[None, :]


def test_hermite_coefficients_are_projections():
    # h_n = E[f(σx) He_n(x)]/n!, exact by Gauss–Hermite for a degree-6 polynomial.
    c = np.array([0.1, 0.55, 0.05, -0.004, 0.002, -3e-4, 1e-4])
    sigma = 1.3
    x, w = np.polynomial.hermite_e.hermegauss(20)
    w = w / w.sum()
    f = np.polynomial.polynomial.polyval(sigma * x, c)
    ref = [
        np.sum(w * f * np.polynomial.hermite_e.hermeval(x, np.eye(7)[n])) / math.factorial(n)
        for n in range(7)
    ]
    np.testing.assert_allclose(hermite_coefficients(c, sigma), ref, rtol=1e-12, atol=1e-14)


def test_spectrum_covariance_is_exact(spectra):
    """Cov[P(t), P(t+τ)]: bivariate Gauss–Hermite (exact) = Mehler sum = cosine transform of our S_P⁺."""
    sp = spectra[7.0]
    ref = _s_g_numpy(sp.omega[1:2000])
    np.testing.assert_allclose(
        np.asarray(_wave(7.0).spectrum(sp.omega[1:2000])), ref, rtol=1e-12, atol=1e-14 * ref.max()
    )
    s_g = _s_g_numpy
    var = si.quad(s_g, 0, 8, limit=400, epsabs=0, epsrel=1e-12)[0]
    np.testing.assert_allclose(float(sp.sigma) ** 2, var, rtol=1e-9)
    x, y, w = _gauss_hermite_2d()
    scale = float(sp.scale)
    omega = np.asarray(sp.omega)
    values = np.asarray(sp.values)
    domega = omega[1] - omega[0]
    for tau in (0.0, 4.0, 11.0, 25.0):
        rho = si.quad(lambda v: s_g(v) * math.cos(v * tau), 0, 8, limit=800, epsabs=1e-13)[0] / var
        z1 = float(sp.sigma) * x
        z2 = float(sp.sigma) * (rho * x + math.sqrt(max(1 - rho**2, 0.0)) * y)
        # ΔGM is evaluated at ζ_mid; the sign flip ζ_mid = −ζ_G leaves the covariance unchanged.
        f1 = scale * np.asarray(jxr.delta_gm(SHIP, z1))
        f2 = scale * np.asarray(jxr.delta_gm(SHIP, z2))
        cov_gh = np.sum(w * f1 * f2) - np.sum(w * f1) * np.sum(w * f2)
        cov_mehler = float(sp.covariance_from_correlation(rho))
        trapezoid = domega * (np.sum(values * np.cos(omega * tau)) - values[0] / 2)
        np.testing.assert_allclose(cov_mehler, cov_gh, rtol=1e-10, atol=1e-12 * cov_gh)
        np.testing.assert_allclose(trapezoid, cov_gh, rtol=1e-7, atol=1e-7 * float(sp.variance))
    np.testing.assert_allclose(
        float(sp.mean), scale * np.sum(w * np.asarray(jxr.delta_gm(SHIP, sp.sigma * x))), rtol=1e-12
    )


def test_spectrum_second_order_term_by_direct_convolution():
    """With only C2, S_P is the 2-fold convolution: S⁺_P(ω) = 2·(rκC2)²·2∫ s(ω')s(ω−ω') dω' (two-sided s = S_G/2)."""
    ship = eqx.tree_at(lambda s: s.delta_gm, SHIP, jnp.array([0.0, 0.0, 0.05, 0, 0, 0, 0]))
    sp = parametric_spectrum(ship, _wave(7.0))
    s2 = lambda v: _s_g_numpy(v) / 2
    k = float(sp.scale) * 0.05
    for omega in (0.05, 0.3, 1.0):
        conv = si.quad(
            lambda v: s2(v) * s2(omega - v), -6, 6, points=[-0.5, 0.5, omega - 0.5, omega + 0.5], limit=400
        )[0]
        # ζ² − σ² has covariance 2R²: two-sided spectrum 2 k² (s * s); one-sided doubles it.
        np.testing.assert_allclose(float(sp(omega)), 2 * 2 * k**2 * conv, rtol=1e-6)


def test_spectrum_matches_welch_of_method1_realizations(spectra):
    sp = spectra[7.0]
    omega, est, se = welch_parametric_spectrum(
        SHIP, _wave(7.0), jr.key(3), num_realizations=48, num_samples=8192
    )
    omega, est, se = np.asarray(omega), np.asarray(est), np.asarray(se)
    exact = np.asarray(sp(omega))
    # Where S_P is smooth on the window's resolution (~0.025 rad/s): the difference-frequency (n = 2) band and the
    # main peak. Near Grim's zero at λ = L/2 (0.686 rad/s) and the dip at 0.3 rad/s the window's leakage biases Welch.
    band = ((omega > 0.08) & (omega < 0.25)) | ((omega > 0.36) & (omega < 0.62))
    # 4 standard errors plus 2 % for the window's smoothing of S_P's curvature and the segment-mean removal.
    assert np.all(np.abs(est[band] - exact[band]) < 4 * se[band] + 0.02 * exact[band])
    peak = (omega > 0.40) & (omega < 0.60)
    pooled = est[peak].sum() / exact[peak].sum()
    assert abs(pooled - 1) < 4 * np.sqrt(np.sum(se[peak] ** 2)) / exact[peak].sum() + 0.01


def test_spectrum_integrates_to_variance(spectra):
    for sp in spectra.values():
        d = float(sp.omega[1] - sp.omega[0])
        integral = d * (float(jnp.sum(sp.values)) - float(sp.values[0]) / 2)
        np.testing.assert_allclose(integral, float(sp.variance), rtol=1e-9)
        h = np.asarray(sp.hermite)
        np.testing.assert_allclose(
            float(hermite_covariance(h, 1.0)), sum(math.factorial(n) * h[n] ** 2 for n in range(1, 7))
        )


# ------------------------------------------------------------------------------------------------------------
# Roberts
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "nu,c2,c3", [(0.5, 6.5, 0.0), (0.5, 6.5, 3.0), (-0.7, 2.0, 10.0), (0.9, 0.0, 5.0), (0.3, 30.0, 0.5)]
)
def test_roberts_normaliser_closed_forms(nu, c2, c3):
    if c3 > 0:
        d, _ = sc.pbdv(-(nu + 1), c2 / math.sqrt(2 * c3))
        ref = sc.gammaln(nu + 1) - (nu + 1) / 2 * math.log(2 * c3) + c2**2 / (8 * c3) + math.log(d)
    else:
        ref = sc.gammaln(nu + 1) - (nu + 1) * math.log(c2)
    value = roberts_log_normaliser(jnp.asarray(nu), jnp.asarray(c2), jnp.asarray(c3))
    np.testing.assert_allclose(float(value), ref, rtol=0, atol=1e-10)


def test_roberts_pdf_from_sde_coefficients():
    """p = C σ⁻² exp∫2m/σ² of the averaged SDE (scipy quadrature) equals C A^ν e^{−c2A−c3A²}; shapes of ν ≷ 0."""
    for k in (0.05, 0.012):  # ν = 0.8 (hump) and ν = −0.25 (divergent at 0)
        rc = RobertsCoefficients(0.3, k, [0.009, 0.4, 0.8])
        pdf = rc.stationary_pdf()
        m, s2 = lambda a: float(rc.drift(a)), lambda a: float(rc.diffusion(a)) ** 2
        a_ref = 0.2
        log_p = lambda a: -math.log(s2(a)) + si.quad(lambda x: 2 * m(x) / s2(x), a_ref, a, epsrel=1e-12)[0]
        grid = np.array([0.01, 0.1, 0.3, 0.6])
        ratio = np.exp([log_p(a) for a in grid]) / np.asarray(pdf.pdf(grid))
        np.testing.assert_allclose(ratio / ratio[0], 1.0, rtol=1e-6)
        assert float(rc.nu) == pytest.approx(1 - 0.009 / k)
        np.testing.assert_allclose(float(pdf.moment(0.0)), 1.0, rtol=1e-10)
        small = np.asarray(pdf.pdf(np.array([1e-4, 1e-3])))
        assert (small[0] > small[1]) == (float(rc.nu) < 0)


def test_roberts_gamma_case_moments():
    rc = RobertsCoefficients(0.26, 0.017, [0.0077, 0.5, 0.0])  # b3 = 0: gamma law, E[A] = (ν+1)/c2
    pdf = rc.stationary_pdf()
    np.testing.assert_allclose(float(pdf.mean()), (float(rc.nu) + 1) / float(rc.c2), rtol=1e-9)
    np.testing.assert_allclose(
        float(pdf.sf(0.4)), sc.gammaincc(float(rc.nu) + 1, float(rc.c2) * 0.4), rtol=1e-6
    )
    np.testing.assert_allclose(
        float(pdf.quantile(0.99)), sc.gammainccinv(float(rc.nu) + 1, 0.01) / float(rc.c2), rtol=1e-7
    )


def test_white_parametric_noise_mean_square_threshold():
    """§8.2: the exact second-moment system of φ̈ + 2ζω0φ̇ + ω0²(1+ξ)φ = 0 (ξ white, intensity D) loses stability
    at D = 4ζ/ω0, exactly where SAM's E[A²] growth rate 4K − b1 (K = Dω0²/8) changes sign; its slow eigenvalue
    (real, near 0) equals 4K − b1 up to a relative O(ζ² + rate/ω0)."""
    omega0, zeta = 0.9, 0.02
    for factor in (0.25, 0.5, 1.0, 1.5, 2.0):
        d = factor * 4 * zeta / omega0
        m = np.array(
            [
                [0, 2, 0],
                [-(omega0**2), -2 * zeta * omega0, 1],
                [omega0**4 * d, -2 * omega0**2, -4 * zeta * omega0],
            ]
        )
        exact = np.max(np.linalg.eigvals(m).real)
        rc = RobertsCoefficients(omega0, d * omega0**2 / 8, [2 * zeta * omega0, 0.0, 0.0])
        sam = float(rc.mean_square_exponent)
        np.testing.assert_allclose(exact, sam, rtol=3e-3, atol=1e-14)
        assert (float(rc.lyapunov_exponent) > 0) == (float(rc.nu) > -1)


def _white_parametric_mc(key, d, zeta, b3, renormalise, *, omega0=1.0, dt=0.1, t_end=2000.0, burn=300.0):
    """Stochastic Heun (Stratonovich; = Itô here, the noise multiplies φ only) for
    φ̈ + 2ζω0φ̇ + b3φ̇³ + ω0²(1 + ξ)φ = 0, ξ white of intensity d (per-path arrays).

    **Returns:** the Lyapunov exponent estimate (1/t) ln(A(t)/A(0)) (exact renormalisation for linear paths) and
    the time average of A² = φ² + φ̇²/ω0² after `burn`.
    """
    n = d.shape[0]
    steps, burn_steps = int(round(t_end / dt)), int(round(burn / dt))

    def f(y):
        return jnp.stack(
            [y[:, 1], -2 * zeta * omega0 * y[:, 1] - b3 * y[:, 1] ** 3 - omega0**2 * y[:, 0]], -1
        )

    def g(y):
        return jnp.stack([jnp.zeros(n), -(omega0**2) * jnp.sqrt(d) * y[:, 0]], -1)

    def step(carry, k):
        y, log_sum, a2_sum = carry
        dw = jnp.sqrt(dt) * jr.normal(jr.fold_in(key, k), (n,))[:, None]
        yp = y + f(y) * dt + g(y) * dw
        y1 = y + (f(y) + f(yp)) * dt / 2 + (g(y) + g(yp)) * dw / 2
        amp = jnp.sqrt(y1[:, 0] ** 2 + (y1[:, 1] / omega0) ** 2)
        r = jnp.where(renormalise, amp, 1.0)
        a2_sum = a2_sum + jnp.where(k >= burn_steps, amp**2, 0.0)
        return (y1 / r[:, None], log_sum + jnp.log(r), a2_sum), None

    y0 = jnp.stack([jnp.full(n, 0.1), jnp.zeros(n)], -1)
    (y, log_sum, a2_sum), _ = jax.lax.scan(step, (y0, jnp.zeros(n), jnp.zeros(n)), jnp.arange(steps))
    final = jnp.sqrt(y[:, 0] ** 2 + (y[:, 1] / omega0) ** 2)
    return (log_sum + jnp.log(final / 0.1)) / t_end, a2_sum / (steps - burn_steps)


def test_white_parametric_noise_lyapunov_and_pdf_vs_sde_monte_carlo():
    """§8.3–8.4: Roberts' Lyapunov exponent K − b1/2 = −ζω0 + Dω0²/8 and its stationary E[A²] (b3 = 0.5)
    against a Monte Carlo of the oscillator itself (100 paths per case, 2000 s, Heun dt = 0.1)."""
    zeta, n = 0.02, 100
    d = jnp.concatenate([jnp.full(n, 0.08), jnp.full(n, 0.32), jnp.full(n, 0.64)])
    b3 = jnp.concatenate([jnp.zeros(2 * n), jnp.full(n, 0.5)])
    lam, a2 = jax.jit(_white_parametric_mc)(jr.key(0), d, zeta, b3, b3 == 0)
    lam, a2 = np.asarray(lam), np.asarray(a2)
    for i, intensity in enumerate((0.08, 0.32)):
        rc = RobertsCoefficients(1.0, intensity / 8, [2 * zeta, 0.0, 0.0])
        est = lam[i * n : (i + 1) * n]
        se = est.std(ddof=1) / math.sqrt(n)
        # 4 SE plus 1.5e-3: SAM's O(D²) error (THEORY §8.3 measured 0.0191 vs 0.02 at D = 0.32)
        assert abs(est.mean() - float(rc.lyapunov_exponent)) < 4 * se + 1.5e-3
    sam = float(RobertsCoefficients(1.0, 0.64 / 8, [2 * zeta, 0.0, 0.5]).stationary_pdf().moment(2.0))
    np.testing.assert_allclose(sam, 0.32, rtol=1e-9)  # (ν+1)/(2c3) = 1.5/(2·2.34375)
    est = a2[2 * n :]
    se = est.std(ddof=1) / math.sqrt(n)
    # 4 SE plus 6 %: SAM's averaging error (THEORY §8.4: SAM 0.320 vs MC 0.309, the MC tail is heavier)
    assert abs(est.mean() - sam) < 4 * se + 0.06 * sam


# ------------------------------------------------------------------------------------------------------------
# ESAM
# ------------------------------------------------------------------------------------------------------------


def test_esam_additive_white_noise_reproduces_caughey():
    """Caughey: p(φ, φ̇) ∝ exp(−2b1H/D) (linear damping, nonlinear restoring); conditioned on the potential well,
    P(A ≤ a) = F(a)/F(top), F(a) = ∫_{−a}^{a} e^{−βG(φ)} erf(√(β(G(a) − G(φ)))) dφ (up to a constant), β = 2b1/D."""
    b1 = float(SHIP.damping[0])
    ship = eqx.tree_at(lambda s: s.damping, SHIP, jnp.array([b1, 0.0, 0.0]))
    a = np.asarray(ship.restoring_coefficients)
    big_g = lambda x: sum(a[n] * x ** (2 * n + 2) / (2 * n + 2) for n in range(5))
    beta = 96.0  # β·G(vanishing angle) ≈ 3: the law spans the whole well
    out = esam_additive_pdf(ship, 2 * b1 / beta)

    def big_f(x):
        gx = big_g(x)
        integrand = lambda p: (
            math.exp(-beta * big_g(p)) * math.erf(math.sqrt(max(beta * (gx - big_g(p)), 0.0)))
        )
        return si.quad(integrand, -x, x, limit=200, epsabs=0, epsrel=1e-12)[0]

    top = big_f(float(out.support_max))
    for deg in (5.0, 20.0, 45.0, 65.0):
        x = math.radians(deg)
        # 5e-6: second order in the last grid cell, which holds T's log singularity 0.1 % above the support
        np.testing.assert_allclose(float(out.cdf(x)), big_f(x) / top, rtol=0, atol=5e-6)
    np.testing.assert_allclose(float(out.moment(0.0)), 1.0, rtol=1e-12)


@pytest.mark.parametrize("hs", [5.0, 7.0])
def test_esam_linear_restoring_reproduces_roberts(hs, spectra):
    ship = eqx.tree_at(lambda s: s.restoring, SHIP, jnp.zeros(4))
    roberts = roberts_pdf(ship, spectra[hs])
    esam = esam_pdf(ship, spectra[hs])
    nonlinear = roberts_pdf(
        ship, spectra[hs], restoring="nonlinear", estimator="zero_crossing"
    )  # = envelope here
    a = esam.amplitude[::64]
    # ESAM lives on [0, π] (no vanishing angle): renormalise Roberts there.
    conditional = np.asarray(roberts.pdf(a)) / (1 - float(roberts.sf(jnp.pi)))
    np.testing.assert_allclose(np.asarray(esam.pdf(a)), conditional, rtol=1e-6)
    np.testing.assert_allclose(np.asarray(nonlinear.pdf(a)), conditional, rtol=1e-6)
    np.testing.assert_allclose(float(esam.mean()), float(roberts.mean()), rtol=1e-6)


def test_esam_estimators_differ_by_period(pdfs):
    """Per half cycle (zero-crossing) ∝ time-sampled (envelope) / T(A); T by independent scipy quadrature."""
    env, zc = pdfs["esam", 7.0], pdfs["esam_zc", 7.0]
    a_coef = np.asarray(SHIP.restoring_coefficients) + np.array(
        [float(env.parameters["mean_stiffness_shift"]), 0, 0, 0, 0]
    )
    big_g = lambda x: sum(a_coef[n] * x ** (2 * n + 2) / (2 * n + 2) for n in range(5))

    def period(amp):  # T = 4∫₀^{π/2} A cos θ dθ / √(2(G(A) − G(A sin θ)))
        f = lambda t: amp * math.cos(t) / math.sqrt(2 * (big_g(amp) - big_g(amp * math.sin(t))))
        return 4 * si.quad(f, 0, math.pi / 2, epsrel=1e-12, limit=200)[0]

    grid = np.asarray(env.amplitude)
    idx = np.searchsorted(
        grid, np.radians([1.0, 10.0, 30.0, 50.0, 70.0, 71.5])
    )  # grid points: no interpolation
    ratio = (
        np.asarray(zc.density)[idx] / np.asarray(env.density)[idx] * np.array([period(x) for x in grid[idx]])
    )
    np.testing.assert_allclose(ratio / ratio[0], 1.0, rtol=1e-9)
    assert float(zc.mean()) < float(env.mean())  # longer periods at large amplitude: fewer half cycles there


# ------------------------------------------------------------------------------------------------------------
# All PDFs: normalisation, errors, Monte Carlo, gradients
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("hs", [5.0, 7.0])
def test_pdfs_are_normalised_and_nonnegative(hs, pdfs):
    bins = np.arange(0.0, 90.5, 0.5)
    for out in (pdfs["roberts", hs], pdfs["roberts_nonlinear_zc", hs], pdfs["esam", hs]):
        assert bool(out.exists)
        assert np.all(np.asarray(out.density) >= 0)
        np.testing.assert_allclose(float(out.moment(0.0)), 1.0, rtol=1e-12)
        np.testing.assert_allclose(float(out.cdf(0.2) + out.sf(0.2)), 1.0, rtol=1e-9)
        per_deg = np.asarray(out.pdf_per_degree(bins))
        assert np.all(per_deg >= -1e-15)
        mass = per_deg.sum() * 0.5 + float(out.sf(math.radians(90.0)))
        np.testing.assert_allclose(mass, 1.0, rtol=1e-9)
        summary = out.summary(bins_deg=bins[:5])
        q = summary["quantiles_deg"]
        assert 0 < q["50"] < q["90"] < q["99"] and summary["mean_amplitude_deg"] > 0
        np.testing.assert_allclose(float(out.cdf(out.quantile(0.99))), 0.99, rtol=1e-9)


def test_no_stationary_pdf_errors():
    weak = parametric_spectrum(SHIP, _wave(1.0))  # K ≪ b1/2
    with pytest.raises(
        ValueError, match=r"roll dies out.*K = .* below b1/2.*Increase H1/3 or the GM correction r"
    ):
        roberts_pdf(SHIP, weak)
    with pytest.raises(ValueError, match="roll dies out"):
        esam_pdf(SHIP, weak)
    unmodulated = eqx.tree_at(lambda s: s.gm_correction, SHIP, jnp.asarray(0.0))  # K = 0: nothing to increase
    with pytest.raises(
        ValueError, match=r"K = 0 1/s .* no parametric excitation at all.*GM correction r = 0"
    ):
        roberts_pdf(unmodulated, _wave(7.0))
    out = roberts_pdf(SHIP, weak, throw=False)
    assert not bool(out.exists) and np.all(np.isnan(np.asarray(out.density)))
    assert float(out.parameters["nu"]) < -1
    with pytest.raises(RuntimeError, match="roll dies out"):
        jax.jit(lambda sp: roberts_pdf(SHIP, sp).mean())(weak)
    linear = eqx.tree_at(
        lambda s: (s.restoring, s.damping), SHIP, (jnp.zeros(4), jnp.array([0.0077, 0.0, 0.0]))
    )
    with pytest.raises(ValueError, match="purely linear damping"):
        roberts_pdf(linear, parametric_spectrum(linear, _wave(7.0)))
    with pytest.raises(ValueError, match="estimator"):
        roberts_pdf(SHIP, weak, estimator="peaks")
    with pytest.raises(ValueError, match="restoring"):
        roberts_pdf(SHIP, weak, restoring="cubic")


def test_mean_stiffness_shift(spectra):
    sp = spectra[7.0]
    h = np.asarray(sp.hermite)
    np.testing.assert_allclose(h[0], 0.05 * float(sp.sigma) ** 2, rtol=1e-12)  # h_0 = E[ΔGM] = C2 σ²
    on = roberts_coefficients(SHIP, sp)
    off = roberts_coefficients(SHIP, sp, mean_shift=False)
    np.testing.assert_allclose(float(off.omega), float(SHIP.omega0), rtol=1e-14)
    np.testing.assert_allclose(float(on.omega) ** 2, float(SHIP.omega0) ** 2 + float(sp.mean), rtol=1e-14)
    np.testing.assert_allclose(
        float(on.k), math.pi / 8 * float(sp(2 * on.omega)) / float(on.omega) ** 2, rtol=1e-14
    )


def test_means_against_method1_monte_carlo(pdfs):
    """Default ship, H1/3 = 7 m: Roberts and ESAM over-predict the Monte Carlo envelope mean.

    Measured (2000 trials × 3600 s, Method 1, 300 s discarded): MC envelope mean 9.93° (SE 0.05°); Roberts (linear)
    13.62° (×1.37), ESAM 14.26° (×1.44). The averaging assumes excitation correlation times short against the
    envelope's, but S_G is about as narrow as the roll resonance: that is the method (THEORY §6), not tuned away.
    """
    problem = jxr.RollProblem.from_sea(SHIP, jxr.ITTC(7.0, 10.0), excitation="superposition", dt=0.5)
    stats = jxr.monte_carlo_amplitudes(
        problem, jr.key(11), num_realizations=400, duration=1800.0, discard=300.0, chunk_size=200
    )
    pr = stats.per_realization
    ok = pr["n_env"] > 0
    per = np.rad2deg(pr["sum_env"][ok] / pr["n_env"][ok])
    mc, se = np.rad2deg(stats.mean("envelope")), per.std(ddof=1) / math.sqrt(ok.sum())
    assert abs(mc - 9.93) < 4 * se + 0.1  # the same process as the reference run above
    for theory, ratio in ((pdfs["roberts", 7.0], 1.37), (pdfs["esam", 7.0], 1.44)):
        measured = math.degrees(float(theory.mean())) / mc
        # 4 SE of the small Monte Carlo (~1.5 % each) plus 3 % for the reference ratio
        assert abs(measured - ratio) < ratio * (4 * se / mc + 0.03)


def _tail_probabilities(which):
    @jax.jit
    def tails(x):
        gm0, b1, b2, hs = x
        ship = eqx.tree_at(lambda s: (s.gm0, s.damping), SHIP, (gm0, jnp.stack([b1, b2, SHIP.damping[2]])))
        fn = roberts_pdf if which == "roberts" else esam_pdf
        return fn(ship, _wave(hs, ship)).sf(math.radians(20.0))

    return tails


def _check_gradient(which):
    tails = _tail_probabilities(which)
    x0 = jnp.array([float(SHIP.gm0), float(SHIP.damping[0]), float(SHIP.damping[1]), 7.0])
    grad = np.asarray(jax.jit(jax.grad(tails))(x0))
    assert 0.1 < float(tails(x0)) < 0.4
    for i in range(4):
        h = 1e-4 * float(x0[i])
        e = jnp.zeros(4).at[i].set(h)
        fd = (float(tails(x0 + e)) - float(tails(x0 - e))) / (2 * h)
        np.testing.assert_allclose(grad[i], fd, rtol=1e-5)


def test_roberts_tail_gradient_matches_finite_differences():
    """∂P(A > 20°)/∂(GM0, b1, b2, H1/3), reverse mode through S_P and Roberts, vs central differences."""
    _check_gradient("roberts")


@pytest.mark.slow  # ~20 s of compilation on a 2-core machine
def test_esam_tail_gradient_matches_finite_differences():
    _check_gradient("esam")


def test_esam_tail_derivative_forward_mode():
    """The ESAM tail is differentiable in H1/3 (forward mode, cheaper to compile than the reverse-mode test)."""
    tails = _tail_probabilities("esam")
    x0 = jnp.array([float(SHIP.gm0), float(SHIP.damping[0]), float(SHIP.damping[1]), 7.0])
    e = jnp.array([0.0, 0.0, 0.0, 1.0])
    value, slope = jax.jit(lambda x: jax.jvp(tails, (x,), (e,)))(x0)
    h = 1e-3
    fd = (float(tails(x0 + h * e)) - float(tails(x0 - h * e))) / (2 * h)
    np.testing.assert_allclose(float(slope), fd, rtol=1e-5)


# ------------------------------------------------------------------------------------------------------------
# The command line's path: each theory in one compiled program (`theory_summary`), stored between runs
# ------------------------------------------------------------------------------------------------------------

BINS = np.arange(0.0, 73.0, 1.0)  # the command line's bins for the default ship (vanishing angle 71.6°)


def _same(got, ref, rtol=1e-12):
    assert got.keys() == ref.keys()
    for key, value in ref.items():
        if isinstance(value, dict):
            _same(got[key], value, rtol)
        elif isinstance(value, str | bool):
            assert got[key] == value, key
        else:  # the PDF per degree is a difference of the CDF: 1 ulp of 1 in its tail
            np.testing.assert_allclose(got[key], value, rtol=rtol, atol=1e-15, err_msg=key)


@pytest.mark.parametrize("name", ["roberts", "esam"])
def test_theory_summary_is_the_public_law_and_summary(name):
    """`theory_summary(name, …)`: the law of `roberts_pdf(restoring="nonlinear")` / `esam_pdf` and its `summary` and
    `details`, computed in one program (law, mean, quantiles, CDF on the bins), to 1e-12."""
    wave = _wave(7.0)
    ref = roberts_pdf(SHIP, wave, restoring="nonlinear") if name == "roberts" else esam_pdf(SHIP, wave)
    law, summary = jxr.theory.theory_summary(name, SHIP, wave, BINS)
    _same(summary, ref.summary(BINS))
    _same(law.details(), ref.details())
    assert summary["mean_amplitude_deg"] == pytest.approx({"roberts": 14.69, "esam": 14.26}[name], abs=0.005)


def test_stored_program_is_read_back_with_the_same_numbers(tmp_path, monkeypatch):
    """With the persistent cache on (as the `jaxroll` command runs), the program is exported to disk once and a new
    process (here: the loaded programs forgotten) reads it back instead of tracing: the same numbers; a theory that
    has no law raises the public function's error from the stored program too."""
    pytest.importorskip("flatbuffers")
    from jaxroll import _compiled

    monkeypatch.setattr(_compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(_compiled, "_LOADED", {})
    wave = _wave(7.0)
    first = jxr.theory.theory_summary("roberts", SHIP, wave, BINS)[1]
    stored = sorted(tmp_path.glob("*.npz"))
    assert stored and all(p.stat().st_size > 1000 for p in stored)  # programs, not "cannot export" markers
    _compiled._LOADED.clear()
    again = jxr.theory.theory_summary("roberts", SHIP, wave, BINS)[1]
    assert sorted(tmp_path.glob("*.npz")) == stored  # read, not exported again
    _same(again, first, rtol=0)
    with pytest.raises(ValueError, match=r"roll dies out.*K = .* below b1/2"):
        jxr.theory.theory_summary("roberts", SHIP, _wave(1.0), BINS)
    with pytest.raises(ValueError, match="unknown theory"):
        jxr.theory.theory_law("magic", SHIP, wave)
    assert list(jxr.theory.iter_theory_summaries((), SHIP, wave, BINS)) == []  # no theory asked, none started


def test_roberts_and_esam_together_are_one_program_with_the_same_numbers(tmp_path, monkeypatch):
    """Asked together (`jaxroll theory`, `jaxroll pdf`), Roberts and ESAM are one stored program (`_averaging_program`:
    the two laws and their summaries, vmapped over the two tables): the same laws and summaries as each on its own
    (to 1e-12: the summary's root searches batched), one program exported instead of two."""
    pytest.importorskip("flatbuffers")
    from jaxroll import _compiled
    from jaxroll.sea._grim import effective_wave_std

    monkeypatch.setattr(_compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(_compiled, "_LOADED", {})
    wave = _wave(7.0)
    effective_wave_std(
        wave
    )  # the set-up checks' own stored program (S_G on a grid), exported before counting
    before = set(tmp_path.glob("*.npz"))
    both = dict(jxr.theory.iter_theory_summaries(("esam", "roberts"), SHIP, wave, BINS))
    assert list(both) == ["esam", "roberts"]
    assert len(set(tmp_path.glob("*.npz")) - before) == 1
    for name in ("roberts", "esam"):
        law, summary = jxr.theory.theory_summary(name, SHIP, wave, BINS)
        _same(both[name][1], summary)
        _same(both[name][0].details(), law.details())
        assert type(both[name][0]) is type(law) and both[name][0].method == law.method
    with pytest.raises(ValueError, match=r"roll dies out.*K = .* below b1/2"):
        dict(jxr.theory.iter_theory_summaries(("roberts", "esam"), SHIP, _wave(1.0), BINS))
    failed = dict(jxr.theory.iter_theory_summaries(("roberts", "esam"), SHIP, _wave(1.0), BINS,
                                                   return_exceptions=True))  # fmt: skip
    assert all(isinstance(e, ValueError) for e in failed.values())
