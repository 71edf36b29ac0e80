"""Tests of jaxroll.extremes: maximum-value distributions and exposure-time risk measures.

References are computed independently here (scipy.integrate.quad, scipy.special, numpy closed forms, and
mpmath where float64 is not enough). Statistical tolerances are k standard errors computed in the test.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate, special, stats

import jaxroll  # noqa: F401  (enables float64)
import jaxroll as ex

EULER_GAMMA = 0.5772156649015329


@pytest.fixture(autouse=True)
def _strict_promotion():
    # The project's conftest settings (STYLE.md §7), applied here too so that this file is strict on its own.
    with jax.numpy_dtype_promotion("strict"), jax.numpy_rank_promotion("raise"):
        yield


def _rayleigh_exact_emax(n):
    """E[max of n standard Rayleigh] = ∫_0^∞ [1 − (1 − e^{−a²/2})^n] da by adaptive quadrature (scipy)."""
    f = lambda a: -np.expm1(n * np.log1p(-np.exp(-0.5 * a * a)))  # noqa: E731
    m = math.sqrt(2 * math.log(n))
    pts = [0.0, m - 1.0, m - 0.3, m, m + 0.3, m + 1.0, m + 3.0, 40.0]
    return sum(
        integrate.quad(f, pts[i], pts[i + 1], epsabs=0.0, epsrel=1e-13, limit=200)[0]
        for i in range(len(pts) - 1)
    )


RAYLEIGH = ex.RayleighLaw(1.0)


# ------------------------------------------------------------------------------------------------------------
# Expected maximum of Rayleigh amplitudes
# ------------------------------------------------------------------------------------------------------------

THEORY_TABLE = {20: 2.6442, 50: 2.9719, 100: 3.1983, 1000: 3.8559}  # THEORY.md §7, 4 decimals
N_VALUES = [20, 50, 100, 1000, 10**4, 10**5, 10**6, 10**7]


def test_expected_maximum_rayleigh_matches_quadrature_and_theory_table():
    for n in N_VALUES:
        got = float(ex.expected_maximum(RAYLEIGH, n))
        ref = _rayleigh_exact_emax(n)
        np.testing.assert_allclose(got, ref, rtol=1e-8, atol=0.0, err_msg=f"N = {n}")
        if n in THEORY_TABLE:
            np.testing.assert_allclose(got, THEORY_TABLE[n], rtol=0.0, atol=5e-5, err_msg=f"table, N = {n}")
    # Scale invariance: E[max] is proportional to σ.
    np.testing.assert_allclose(
        float(ex.expected_maximum(ex.RayleighLaw(0.2), 100)),
        0.2 * _rayleigh_exact_emax(100),
        rtol=1e-8,
        atol=0,
    )


def test_expected_maximum_rayleigh_against_mpmath():
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 30
    n = 1000
    m = mp.sqrt(2 * mp.log(n))
    ref = mp.quad(lambda a: 1 - (1 - mp.e ** (-a * a / 2)) ** n, [0, m - 1, m, m + 1, m + 3, mp.inf])
    np.testing.assert_allclose(float(ex.expected_maximum(RAYLEIGH, n)), float(ref), rtol=1e-12, atol=0)


def test_expected_maximum_approaches_longuet_higgins_asymptote():
    # √(2 ln N) + γ/√(2 ln N) overestimates; the gap shrinks monotonically like (ln N)^{-3/2}, with the
    # coefficient (γ² + π²/6)/(4√2) = 0.3497 in the limit (expand √(2(ln N + G)), G Gumbel, E G² = γ² + π²/6).
    gaps, scaled = [], []
    for n in N_VALUES:
        root = math.sqrt(2 * math.log(n))
        gap = root + EULER_GAMMA / root - float(ex.expected_maximum(RAYLEIGH, n))
        gaps.append(gap)
        scaled.append(gap * math.log(n) ** 1.5)
    assert all(g > 0 for g in gaps)
    assert all(b < a for a, b in zip(gaps, gaps[1:])), gaps
    limit = (EULER_GAMMA**2 + math.pi**2 / 6) / (4 * math.sqrt(2))
    assert all(b > a for a, b in zip(scaled, scaled[1:])), scaled  # approaches the limit from below
    assert 0.55 * limit < scaled[0] and scaled[-1] < limit, scaled  # 0.204 at N = 20, 0.324 at N = 1e7


def test_monte_carlo_maxima_match_exact_distribution():
    rng = np.random.default_rng(12345)
    n0, trials = 50, 4000
    maxima = rng.rayleigh(scale=1.0, size=(trials, n0)).max(axis=1)
    cdf = lambda x: np.asarray(ex.max_cdf(RAYLEIGH, np.asarray(x), n0))  # noqa: E731
    assert stats.kstest(maxima, cdf).pvalue > 0.01
    se = maxima.std(ddof=1) / math.sqrt(trials)
    assert abs(maxima.mean() - float(ex.expected_maximum(RAYLEIGH, n0))) < 4 * se


# ------------------------------------------------------------------------------------------------------------
# The PDF of the maximum
# ------------------------------------------------------------------------------------------------------------

DISTS = {
    "rayleigh": ex.RayleighLaw(0.3),
    "roberts_nu_negative": ex.RobertsLaw(-0.5, 2.0),
    "roberts_nu_positive": ex.RobertsLaw(2.5, 0.8),
}


@pytest.mark.parametrize("name", list(DISTS))
def test_max_pdf_is_a_normalised_density(name):
    dist = DISTS[name]
    for n0 in [20, 50, 100, 1000, 10**4, 10**6]:
        lo, hi = np.asarray(ex.max_quantile(dist, jnp.asarray([1e-14, 1 - 1e-15]), n0))
        a = np.linspace(lo, hi, 4001)
        pdf = np.asarray(ex.max_pdf(dist, a, n0))
        assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0)
        mass = integrate.simpson(pdf, x=a)
        # Simpson on 4001 points: error ~ h⁴ max|P*''''| ≈ 1e-10 here; the truncated tails hold ~1e-14.
        np.testing.assert_allclose(mass, 1.0, rtol=0, atol=1e-8, err_msg=f"N0 = {n0}")
        # and its running integral is the CDF of the maximum
        running = integrate.cumulative_simpson(pdf, x=a, initial=0.0)
        cdf = np.asarray(ex.max_cdf(dist, a, n0))
        np.testing.assert_allclose(running + cdf[0], cdf, rtol=0, atol=1e-7, err_msg=f"N0 = {n0}")


def test_max_pdf_log_space_matches_naive_where_accurate_and_stays_finite_where_not():
    sigma = 1.0
    a = np.linspace(0.5, 8.0, 3001)
    sf = np.exp(-0.5 * a**2 / sigma**2)
    p = a / sigma**2 * sf
    for n0 in [10**4, 10**6]:
        naive = n0 * (1.0 - sf) ** (n0 - 1) * p
        logp = np.asarray(ex.max_logpdf(RAYLEIGH, a, n0))
        assert np.all(np.isfinite(logp))
        ok = naive > 1e-200
        # The naive (1 − F̄)^(N0−1) carries the rounding of 1 − F̄ amplified N0-fold: N0·eps ≤ 2e-10.
        np.testing.assert_allclose(np.exp(logp[ok]), naive[ok], rtol=1e-9, atol=0)
    # N0 = 1e6: where the naive product underflows to 0, log P* is still accurate (mpmath reference).
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 50
    n0 = 10**6
    for x in [1.0, 2.0, 3.0, 3.5]:
        assert n0 * (1.0 - math.exp(-0.5 * x * x)) ** (n0 - 1) * x * math.exp(-0.5 * x * x) == 0.0
        xm = mp.mpf(x)
        ref = mp.log(n0) + (n0 - 1) * mp.log(1 - mp.e ** (-xm * xm / 2)) + mp.log(xm) - xm * xm / 2
        np.testing.assert_allclose(float(ex.max_logpdf(RAYLEIGH, x, n0)), float(ref), rtol=1e-13, atol=0)


def test_asymptotic_form_of_theory_md():
    dist = ex.RayleighLaw(1.0)
    n0 = 10**4
    a = np.linspace(3.0, 6.0, 601)
    xi = n0 * np.exp(-0.5 * a**2)
    ratio = np.asarray(ex.max_pdf_asymptotic(dist, a, n0)) / np.asarray(ex.max_pdf(dist, a, n0))
    bulk = xi < 30
    # e^{−ξ} / (1 − F̄)^{N0} = exp(N0 (F̄²/2 + F̄³/3 + …)) = exp(ξ²/2N0) (1 + O(ξ³/N0²)): 0.2 % of the
    # gap at ξ = 30.
    np.testing.assert_allclose(ratio[bulk] - 1, np.expm1(xi[bulk] ** 2 / (2 * n0)), rtol=0.01, atol=1e-14)
    # It is not normalisable: as F̄ → 1 its factor P/(1 − F̄) ~ 2/a blows up at a → 0 (with weight e^{-N0}).
    small = np.asarray(ex.max_pdf_asymptotic(dist, np.asarray([1e-3, 1e-4]), 20))
    np.testing.assert_allclose(small[1] / small[0], 10.0, rtol=1e-5, atol=0)


# ------------------------------------------------------------------------------------------------------------
# Closed-form families and tabulated distributions
# ------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("nu", [-0.5, 1.5, 4.0, 20.0])
def test_roberts_survival_is_regularised_incomplete_gamma(nu):
    c3 = 0.7
    k = 0.5 * (nu + 1)
    dist = ex.RobertsLaw(nu, c3)
    a = np.concatenate([np.linspace(0.01, 5.0, 200), [8.0, 12.0, 12.5, 20.0, 30.0]])  # c3 a² up to 630
    x = c3 * a**2
    np.testing.assert_allclose(np.asarray(dist.sf(a)), special.gammaincc(k, x), rtol=1e-12, atol=0)
    p, q = special.gammainc(k, x), special.gammaincc(k, x)
    # References in log space use log1p of the small one: log(1 − 1e-11) in float64 is only good to ~1e-5.
    with np.errstate(divide="ignore"):  # the branch np.where discards may be log(0)
        ref_logsf = np.where(p < 0.5, np.log1p(-p), np.log(q))
        ref_logcdf = np.where(q < 0.5, np.log1p(-q), np.log(p))
    np.testing.assert_allclose(np.asarray(dist.logsf(a)), ref_logsf, rtol=1e-12, atol=0)
    np.testing.assert_allclose(np.asarray(dist.logcdf(a)), ref_logcdf, rtol=1e-12, atol=0)
    # The PDF is the generalised gamma distribution (Stacy; shape k, power 2, scale c3^{-1/2}): its
    # normalisation and mean from scipy.stats.
    ref = stats.gengamma(a=k, c=2.0, scale=1.0 / math.sqrt(c3))
    np.testing.assert_allclose(np.asarray(dist.logpdf(a)), ref.logpdf(a), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(float(dist.mean()), ref.mean(), rtol=1e-10, atol=0)


def test_roberts_with_nu_one_is_rayleigh():
    sigma = 0.4
    rob = ex.RobertsLaw(1.0, 1.0 / (2 * sigma**2))
    ray = ex.RayleighLaw(sigma)
    a = np.linspace(0.05, 3.0, 50)
    for f in ("logpdf", "logsf", "logcdf"):
        np.testing.assert_allclose(getattr(rob, f)(a), getattr(ray, f)(a), rtol=1e-12, atol=1e-14)


def test_tabulated_max_cdf_converges_to_closed_form():
    nu, c3, n0 = 1.5, 0.5, 100
    k = 0.5 * (nu + 1)
    a = np.array([1.5, 2.5, 3.0, 3.5, 4.0, 4.5])
    exact = np.exp(n0 * np.log1p(-special.gammaincc(k, c3 * a**2)))
    errors = []
    for n in (801, 1601):
        grid = np.linspace(0.0, 8.0, n)
        dist = ex.TabulatedAmplitudeLaw.from_pdf(grid, grid**nu * np.exp(-c3 * grid**2))
        errors.append(np.max(np.abs(np.asarray(ex.max_cdf(dist, a, n0)) - exact)))
    # Trapezoidal rule: second order. The error is 2.3e-5 at h = 0.01 and drops by 4.00.
    assert errors[1] < 1e-5
    assert 3.8 < errors[0] / errors[1] < 4.2, errors


def test_tabulated_far_tail_from_logpdf():
    # A Rayleigh log-PDF down to -800: from_pdf underflows there, from_logpdf keeps the tail.
    grid = np.linspace(0.0, 40.0, 4001)
    log_pdf = np.log(np.maximum(grid, 1e-300)) - 0.5 * grid**2
    dist = ex.TabulatedAmplitudeLaw.from_logpdf(grid, log_pdf)
    a = np.array([5.0, 20.0, 30.0, 38.0])
    got = np.asarray(dist.logsf(a))
    assert np.all(np.isfinite(got))
    # Linear interpolation of an exponentially decaying PDF: relative error (a h)²/12 per segment in F̄, i.e.
    # an error in log F̄ of ~1e-2 at a = 38 (h = 0.01), ~2e-5 relative to log F̄ = −722.
    np.testing.assert_allclose(got, -0.5 * a**2, rtol=3e-5, atol=0)
    assert np.isneginf(np.asarray(ex.TabulatedAmplitudeLaw.from_pdf(grid, np.exp(log_pdf)).logsf(a))[-1])
    # cdf + sf = 1 and quantile inverts cdf
    b = np.linspace(0.1, 6.0, 37)
    np.testing.assert_allclose(np.asarray(dist.cdf(b) + dist.sf(b)), 1.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(
        np.asarray(dist.cdf(dist.quantile(jnp.asarray([0.01, 0.5, 0.99])))),
        [0.01, 0.5, 0.99],
        rtol=1e-12,
        atol=0,
    )
    levels = jnp.asarray([1e-3, 1e-8, 1e-12])
    np.testing.assert_allclose(np.asarray(dist.sf(dist.isf(levels))), levels, rtol=1e-10, atol=0)


def test_from_samples_has_exact_empirical_survival_and_histogram_pdf():
    rng = np.random.default_rng(7)
    x = rng.rayleigh(size=5000)
    dist = ex.TabulatedAmplitudeLaw.from_samples(x, bins=40)
    assert dist.n_samples == 5000
    nodes = np.asarray(dist.grid)
    np.testing.assert_allclose(
        np.asarray(dist.sf(nodes[1:-1])),
        (x[None, :] > nodes[1:-1, None]).mean(1),
        rtol=1e-12,
        atol=1e-15,
    )
    density, edges = np.histogram(x, bins=40, range=(0.0, x.max()), density=True)
    # atol: a zero-count bin's centre is interpolated with a rounding-level weight of its neighbour.
    np.testing.assert_allclose(
        np.asarray(dist.pdf(0.5 * (edges[1:] + edges[:-1]))), density, rtol=1e-12, atol=1e-12
    )
    k, n = ex.count_exceedances(np.append(x, np.nan), 2.0)
    assert int(n) == 5000 and int(k) == int(np.sum(x > 2.0))


# ------------------------------------------------------------------------------------------------------------
# Quantiles and the most probable maximum
# ------------------------------------------------------------------------------------------------------------


def test_max_quantile_and_mode_rayleigh_closed_forms():
    sigma = 0.2
    dist = ex.RayleighLaw(sigma)
    q = np.array([1e-6, 0.5, 0.9, 0.99, 1 - 1e-9])
    for n0 in [1, 20, 10**7]:
        # (1 − e^{−a²/2σ²})^N0 = q  ⇔  a²/2σ² = −log(1 − q^{1/N0}), with log(1 − e^y) evaluated accurately.
        y = np.log(q) / n0
        log_s = np.where(y < -math.log(2), np.log1p(-np.exp(y)), np.log(-np.expm1(y)))
        exact = sigma * np.sqrt(-2 * log_s)
        np.testing.assert_allclose(np.asarray(ex.max_quantile(dist, q, n0)), exact, rtol=1e-12, atol=0)
    # Mode of P*: N0 = 1 gives σ; otherwise d/da log P* = 0, i.e. (N0−1) a e^{−u}/(1−e^{−u}) = a − 1/a (σ = 1,
    # u = a²/2), checked with the residual of that equation.
    np.testing.assert_allclose(float(ex.most_probable_maximum(dist, 1)), sigma, rtol=1e-12, atol=0)
    for n0 in [20, 1000, 10**6]:
        m = float(ex.most_probable_maximum(RAYLEIGH, n0))
        u = 0.5 * m * m
        residual = (n0 - 1) * m * math.exp(-u) / -math.expm1(-u) - (m - 1 / m)
        assert abs(residual) < 1e-10 * m


# ------------------------------------------------------------------------------------------------------------
# Exposure-time risk
# ------------------------------------------------------------------------------------------------------------


def test_exceedance_probability_rayleigh_closed_form():
    sigma, rate, duration = 0.15, 2.0 / 12.0, 3 * 3600.0  # σ [rad], two amplitudes per 12 s cycle, 3 h
    n = rate * duration
    dist = ex.RayleighLaw(sigma)
    angles = np.deg2rad([20.0, 30.0, 60.0])
    sf = np.exp(-0.5 * angles**2 / sigma**2)
    exact = -np.expm1(n * np.log1p(-sf))  # 60°: 4.7e-8, where 1 − (1 − F̄)^n in float64 keeps ~8 digits only
    got = np.asarray(ex.exceedance_probability(dist, angles, rate=rate, duration=duration))
    np.testing.assert_allclose(got, exact, rtol=1e-12, atol=0)
    poisson = np.asarray(ex.exceedance_probability(dist, angles, rate=rate, duration=duration, poisson=True))
    np.testing.assert_allclose(poisson, -np.expm1(-n * sf), rtol=1e-12, atol=0)
    assert np.all(poisson <= got)
    risk = ex.exposure_risk(dist, angles[1], rate=rate, duration=duration)
    np.testing.assert_allclose(float(risk.probability), exact[1], rtol=1e-12, atol=0)
    np.testing.assert_allclose(float(risk.n_cycles), n, rtol=1e-15, atol=0)
    np.testing.assert_allclose(
        float(risk.most_probable_largest), float(ex.most_probable_maximum(dist, n)), rtol=1e-12, atol=0
    )
    np.testing.assert_allclose(
        float(risk.expected_largest), sigma * _rayleigh_exact_emax(n), rtol=1e-8, atol=0
    )
    np.testing.assert_allclose(
        float(risk.characteristic_largest),
        sigma * math.sqrt(-2 * math.log(-math.expm1(-1 / n))),
        rtol=1e-12,
        atol=0,
    )
    np.testing.assert_allclose(float(risk.angle_deg), 30.0, rtol=1e-14, atol=0)
    np.testing.assert_allclose(
        float(risk.expected_largest_deg), math.degrees(float(risk.expected_largest)), rtol=1e-14, atol=0
    )
    assert np.isnan(float(risk.probability_lower)) and np.isnan(float(risk.characteristic_largest_upper))


def test_wilson_interval_closed_form():
    z = stats.norm.ppf(0.975)
    for k, n in [(0, 1000), (3, 1000), (500, 1000), (1000, 1000), (7, 10**7)]:
        lo, hi = (float(v) for v in ex.wilson_interval(k, n, 0.95))
        # Roots of (p̂ − p)² = z² p (1 − p) / n, the score-test inversion that defines the interval.
        p_hat = k / n
        roots = np.sort(np.roots([1 + z**2 / n, -(2 * p_hat + z**2 / n), p_hat**2]).real)
        np.testing.assert_allclose([lo, hi], roots, rtol=1e-7, atol=1e-15)
    assert float(ex.wilson_interval(0, 1000)[0]) == 0.0


def test_confidence_intervals_cover_the_truth():
    rng = np.random.default_rng(20240701)
    reps, m = 200, 20000
    angle, rate, duration = 3.717, 1.0 / 6.0, 3 * 3600.0  # F̄(angle) = 1e-3: ~20 exceedances per experiment
    n = rate * duration
    truth_p = -math.expm1(n * math.log1p(-math.exp(-0.5 * angle**2)))
    truth_char = math.sqrt(-2 * math.log(-math.expm1(-1 / n)))

    @jax.jit  # one compilation for the 200 experiments (jit of the public path, validation included)
    def experiment(x):
        dist = ex.TabulatedAmplitudeLaw.from_samples(x, bins=200)
        k, _ = ex.count_exceedances(x, angle)
        risk = ex.exposure_risk(dist, angle, rate=rate, duration=duration, n_exceed=k)
        return jnp.stack(
            [
                risk.probability_lower,
                risk.probability_upper,
                risk.characteristic_largest_lower,
                risk.characteristic_largest_upper,
            ]
        )

    bounds = np.array([experiment(jnp.asarray(rng.rayleigh(size=m))) for _ in range(reps)])
    cover_p = np.sum((bounds[:, 0] <= truth_p) & (truth_p <= bounds[:, 1]))
    cover_char = np.sum((bounds[:, 2] <= truth_char) & (truth_char <= bounds[:, 3]))
    band = 3 * math.sqrt(0.95 * 0.05 / reps)  # 3 binomial standard errors of a 95 % coverage: ±0.046
    assert abs(cover_p / reps - 0.95) < band, cover_p
    assert abs(cover_char / reps - 0.95) < band, cover_char


# ------------------------------------------------------------------------------------------------------------
# Gradients
# ------------------------------------------------------------------------------------------------------------


def test_gradients_match_central_differences():
    angle, rate, duration = 0.5, 0.2, 3600.0

    def prob(sigma):
        return ex.exceedance_probability(ex.RayleighLaw(sigma), angle, rate=rate, duration=duration)

    sigma, h = 0.15, 1e-6
    fd = (float(prob(sigma + h)) - float(prob(sigma - h))) / (2 * h)
    # central difference: truncation (h²/6)·f‴ and rounding eps/h are both below 1e-9 relative here.
    np.testing.assert_allclose(float(jax.grad(prob)(sigma)), fd, rtol=1e-6, atol=0)

    # E[max], a quantile and the mode of the maximum scale with σ: each derivative is the value at σ = 1.
    def scaled(s):
        d = ex.RayleighLaw(s)
        return jnp.stack(
            [ex.expected_maximum(d, 100), ex.max_quantile(d, 0.9, 100), ex.most_probable_maximum(d, 100)]
        )

    # the mode's implicit-function derivative is taken at the golden-section point, within ~1e-8 of the mode
    np.testing.assert_allclose(
        np.asarray(jax.jacfwd(scaled)(0.7)), np.asarray(scaled(1.0)), rtol=1e-7, atol=0
    )


# ------------------------------------------------------------------------------------------------------------
# Empirical maxima
# ------------------------------------------------------------------------------------------------------------


def test_empirical_maxima_statistics():
    rng = np.random.default_rng(99)
    n0, trials = 100, 3000
    amplitudes = rng.rayleigh(size=(trials, n0 + 20))
    amplitudes[:5, 50:] = np.nan  # five short (or capsized) trials
    maxima = ex.maxima_of_first(amplitudes, n0)
    assert int(np.sum(np.isnan(np.asarray(maxima)))) == 5
    emp = ex.empirical_maxima(maxima, bins=30)
    assert int(emp.n_trials) == trials - 5 and int(emp.n_excluded) == 5
    assert abs(float(emp.mean) - float(ex.expected_maximum(RAYLEIGH, n0))) < 4 * float(emp.mean_se)
    theory_q = np.asarray(ex.max_quantile(RAYLEIGH, jnp.asarray([0.5, 0.9, 0.99]), n0))
    assert np.all(np.abs(np.asarray(emp.quantiles) - theory_q) < 4 * np.asarray(emp.quantile_se))
    assert np.all((np.asarray(emp.quantile_lower) <= theory_q) & (theory_q <= np.asarray(emp.quantile_upper)))
    np.testing.assert_allclose(
        np.asarray(emp.quantiles), np.quantile(np.asarray(maxima)[5:], [0.5, 0.9, 0.99]), rtol=1e-14, atol=0
    )
    np.testing.assert_allclose(float(np.sum(emp.pdf * np.diff(emp.edges))), 1.0, rtol=1e-12, atol=0)
    # histogram vs P* bin averages, within 4 binomial standard errors (plus a floor for empty tail bins)
    centres = np.asarray(emp.centres)
    theory_pdf = np.asarray(ex.max_pdf(RAYLEIGH, centres, n0))
    assert np.all(np.abs(np.asarray(emp.pdf) - theory_pdf) < 4 * np.asarray(emp.pdf_se) + 0.05)
    np.testing.assert_allclose(float(emp.mean_deg), math.degrees(float(emp.mean)), rtol=1e-14, atol=0)


# ------------------------------------------------------------------------------------------------------------
# Validation errors
# ------------------------------------------------------------------------------------------------------------

GRID = np.linspace(0.0, 1.0, 11)
PDF = GRID * np.exp(-(GRID**2))


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: ex.RayleighLaw(-1.0), r"`sigma` must be > 0 \[rad\]; got -1.0"),
        (lambda: ex.RayleighLaw([1.0, 2.0]), r"`sigma` must be a scalar; got shape \(2,\)"),
        (lambda: ex.RobertsLaw(-1.0, 1.0), r"`nu` must be > -1 .*got -1.0"),
        (lambda: ex.RobertsLaw(1.0, 0.0), r"`c3` must be > 0"),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID, PDF[:-1]),
            r"same length; got shapes \(11,\) and \(10,\)",
        ),
        (lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID[:2], PDF[:2]), r"at least 3 grid points; got 2"),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID, np.where(GRID == 0.5, np.nan, PDF)),
            r"`pdf` must be finite .*pdf\[5\] = nan",
        ),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_pdf(np.where(GRID == 1.0, np.inf, GRID), PDF),
            r"`grid` must be finite; grid\[10\] = inf",
        ),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID[::-1], PDF),
            r"diff\(grid\)` must be > 0.*strictly increasing",
        ),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_pdf(np.r_[0.0, 0.1, 0.1, 0.2], np.ones(4)),
            r"diff\(grid\)\[1\] = 0.0",
        ),
        (lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID - 0.5, PDF), r"non-negative, but grid\[0\] = -0.5"),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID, PDF - 0.1),
            r"`pdf` must be >= 0; pdf\[0\] = -0.1.*clip",
        ),
        (lambda: ex.TabulatedAmplitudeLaw.from_pdf(GRID, 0 * PDF), r"integrates to 0"),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_logpdf(GRID, np.where(GRID == 0.2, np.inf, 0.0)),
            r"`log_pdf` must not be NaN or \+inf; log_pdf\[2\] = inf",
        ),
        (lambda: ex.TabulatedAmplitudeLaw(GRID, PDF, PDF), r"`log_mass` of length n − 1"),
        (lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0]), r"at least 2 samples .*; got 1"),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0, np.nan, np.inf]),
            r"contains 2 non-finite .*capsize",
        ),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0, -0.5]),
            r"`amplitudes` must be >= 0; amplitudes\[1\]",
        ),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0, 2.0], bins=0),
            r"`bins` must be a positive number",
        ),
        (lambda: ex.TabulatedAmplitudeLaw.from_samples([0.0, 0.0]), r"All amplitudes are 0"),
        (lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0, 2.0], bins=[[0.0, 3.0]]), r"edges must be 1-D"),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0, 2.0], bins=[0.0, 3.0, 2.0]),
            r"strictly increasing",
        ),
        (
            lambda: ex.TabulatedAmplitudeLaw.from_samples([1.0, 2.0], bins=[0.0, 1.5]),
            r"outside the bin edges",
        ),
        (lambda: ex.expected_maximum(RAYLEIGH, 0), r"`n0` .* must be >= 1; got 0.0"),
        (lambda: ex.expected_maximum(RAYLEIGH, 10, num_panels=0), r"`num_panels` must be >= 1"),
        (lambda: ex.max_pdf(RAYLEIGH, 1.0, 0.5), r"`n0` .* must be >= 1"),
        (lambda: ex.max_quantile(RAYLEIGH, 1.0, 10), r"`q` must lie strictly between 0 and 1"),
        (
            lambda: ex.exceedance_probability(RAYLEIGH, 0.5, rate=0.0, duration=1.0),
            r"`rate` must be > 0.*2/T_mean",
        ),
        (
            lambda: ex.exceedance_probability(RAYLEIGH, 0.5, rate=1.0, duration=-1.0),
            r"`duration` must be > 0 \[s\]",
        ),
        (
            lambda: ex.exceedance_probability(RAYLEIGH, -0.5, rate=1.0, duration=1.0),
            r"`angle` must be >= 0.*deg2rad",
        ),
        (lambda: ex.exposure_risk(RAYLEIGH, [0.5, 0.6], rate=1.0, duration=1.0), r"`angle` must be a scalar"),
        (
            lambda: ex.exposure_risk(RAYLEIGH, 0.5, rate=1.0, duration=1.0, confidence=1.0),
            r"`confidence` must lie",
        ),
        (lambda: ex.exposure_risk(RAYLEIGH, 0.5, rate=1.0, duration=1.0, n_exceed=3), r"`n_exceed` needs"),
        (
            lambda: ex.exposure_risk(RAYLEIGH, 0.5, rate=1.0, duration=1.0, n_exceed=30, n_amplitudes=20),
            r"`n_exceed` must lie in \[0, n_amplitudes\]; got 30.0",
        ),
        (
            lambda: ex.exposure_risk(RAYLEIGH, 0.5, rate=1.0, duration=1.0, n_amplitudes=0),
            r"`n_amplitudes` must be > 0",
        ),
        (
            lambda: ex.exposure_risk(RAYLEIGH, 0.5, rate=1.0, duration=1.0, n_amplitudes=0.5),
            r"`n_amplitudes` must be >= 1",
        ),
        (lambda: ex.maxima_of_first(np.ones(5), 2), r"shape \(trials, m\); got shape \(5,\)"),
        (
            lambda: ex.maxima_of_first(np.ones((3, 5)), 6),
            r"`n0` must be an integer in \[1, 5\].*longer trials",
        ),
        (lambda: ex.empirical_maxima(np.ones((2, 2))), r"`maxima` must be 1-D"),
        (lambda: ex.empirical_maxima(np.ones(5), levels=(0.5, 1.0)), r"`levels` must be quantile levels"),
        (lambda: ex.empirical_maxima(np.ones(5), confidence=0.0), r"`confidence` must lie"),
        (lambda: ex.empirical_maxima(np.array([1.0, np.nan])), r"has 1 finite value\(s\)"),
        (lambda: ex.empirical_maxima(np.array([1.0, -1.0])), r"non-negative; got -1.0"),
        (lambda: ex.empirical_maxima(np.ones(5), bins=0), r"`bins` must be a positive number"),
        (lambda: ex.empirical_maxima(np.ones(5), bins=[0.0, 2.0, 1.0]), r"strictly increasing"),
        (lambda: ex.empirical_maxima(np.ones(5), bins=[0.0, 0.5]), r"outside the bin edges"),
    ],
)
def test_validation_errors(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_validation_under_jit_raises_runtime_error():
    @eqx.filter_jit
    def build(sigma):
        return ex.RayleighLaw(sigma).sigma

    with pytest.raises(RuntimeError, match=r"`sigma` must be > 0"):
        build(jnp.asarray(-1.0))
