"""The roll integrator and the Monte Carlo against exact stochastic results (THEORY.md §8)."""

import math
import warnings

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
from scipy import integrate

import jaxroll


def white_noise_filter(intensity, omega_f=8.0, zeta_f=0.7):
    """A broadband 2nd-order filter whose output approximates white noise of two-sided intensity D (E[w w'] = Dδ)
    for frequencies well below ω_f (flat to 0.1 % at ω ≤ 2 rad/s for ω_f = 8): H = ω_f²√D/(s² + 2ζω_f s + ω_f²)."""
    a = jnp.array([[0.0, 1.0], [-(omega_f**2), -2 * zeta_f * omega_f]])
    return jaxroll.ShapingFilter(a, jnp.array([0.0, 1.0]), jnp.array([omega_f**2 * np.sqrt(intensity), 0.0]))


def unit_ship(*, a3=0.0, b1=0.1, c1=0.0):
    """ω0 = 1 rad/s, GM0 = 1 m, so P = C1·ζ_mid and ΔGM/GM0 = C1 ζ_mid."""
    return jaxroll.Ship(
        lpp=100.0,
        breadth=10.0,
        depth=10.0,
        draught=5.0,
        displacement=1e6,
        block_coefficient=0.6,
        gm0=1.0,
        roll_period=2 * np.pi,
        restoring=[a3, 0.0, 0.0, 0.0],
        damping=[b1, 0.0, 0.0],
        delta_gm=[0.0, c1, 0.0, 0.0, 0.0, 0.0, 0.0],
    )


def run_moments(problem, key, n, duration, discard):
    stats = jaxroll.monte_carlo_amplitudes(
        problem, key, num_realizations=n, duration=duration, discard=discard, chunk_size=n
    )
    pr = stats.per_realization
    # Parametric white noise gives heavy (power-law) tails: a rare trial passes |φ| = π and is counted as
    # capsized (excluded); more than 2 % would bias E[φ²] beyond the tolerance, so it fails the test.
    assert stats.n_capsized <= 0.02 * n, stats.n_capsized
    ok = ~stats.capsized
    e2 = pr["sum_phi2"][ok] / pr["n_samples"][ok]
    e4 = pr["sum_phi4"][ok] / pr["n_samples"][ok]
    m = ok.sum()
    return stats, (e2.mean(), e2.std(ddof=1) / np.sqrt(m)), (e4.mean(), e4.std(ddof=1) / np.sqrt(m))


def test_caughey_exact_stationary_law_nonlinear_restoring(getkey):
    """Additive white noise on φ̈ + cφ̇ + φ + a3φ³ = W: p(φ) ∝ exp(−(2c/D) G(φ)) exactly (Caughey)."""
    c, d, a3 = 0.1, 0.05, 2.0
    ship = unit_ship(a3=a3, b1=c)
    dt = 0.05
    zero = jaxroll.FilterExcitation(
        white_noise_filter(1e-30), dt
    )  # no parametric excitation (ΔGM = 0 anyway)
    problem = jaxroll.RollProblem(
        ship, zero, 0.0, 0.0, moment_excitation=jaxroll.FilterExcitation(white_noise_filter(d), dt)
    )
    _, (e2, se2), (e4, se4) = run_moments(problem, getkey(), 96, 1100.0, 100.0)
    g = lambda x: x**2 / 2 + a3 * x**4 / 4
    w = lambda x: np.exp(-2 * c / d * g(x))
    z = integrate.quad(w, -np.inf, np.inf)[0]
    m2 = integrate.quad(lambda x: x**2 * w(x), -np.inf, np.inf)[0] / z
    m4 = integrate.quad(lambda x: x**4 * w(x), -np.inf, np.inf)[0] / z
    assert abs(e2 - m2) < 4 * se2, (e2, m2, se2)
    assert abs(e4 - m4) < 4 * se4, (e4, m4, se4)
    # The nonlinearity matters at this level: the linear result D/(2c) is 30 % off, so the test can tell.
    assert abs(d / (2 * c) - m2) > 10 * se2


@pytest.mark.parametrize("fraction", [0.25, 0.5])
def test_white_parametric_noise_stationary_second_moment(getkey, fraction):
    """φ̈ + 2ζω0φ̇ + ω0²(1 + ξ)φ = W_e: mean-square stable iff D < 4ζ/ω0; E[φ²] = D_e/(ω0³(4ζ − ω0 D))."""
    zeta, d_e = 0.05, 0.01
    threshold = 4 * zeta
    d = fraction * threshold
    dt = 0.05
    ship = unit_ship(b1=2 * zeta, c1=1.0)
    problem = jaxroll.RollProblem(
        ship,
        jaxroll.FilterExcitation(white_noise_filter(d), dt),
        0.0,
        0.0,
        moment_excitation=jaxroll.FilterExcitation(white_noise_filter(d_e), dt),
    )
    _, (e2, se2), _ = run_moments(problem, getkey(), 128, 1100.0, 100.0)
    exact = d_e / (threshold - d)
    # 4 standard errors plus 1 % for the colour of the "white" filter noise.
    assert abs(e2 - exact) < 4 * se2 + 0.01 * exact, (e2, exact, se2)


def test_white_parametric_noise_above_threshold_grows(getkey):
    """Above the mean-square threshold D = 4ζ/ω0 the second moment grows without bound (here 3× threshold)."""
    zeta, dt = 0.05, 0.05
    ship = unit_ship(b1=2 * zeta, c1=1.0)
    problem = jaxroll.RollProblem(ship, jaxroll.FilterExcitation(white_noise_filter(0.6), dt), 0.01, 0.0)

    def run(key):
        phi, _, _ = jaxroll.roll_time_series(problem, key, 400.0)
        return phi

    phi = jax.vmap(run)(jr.split(getkey(), 64))
    early = jnp.mean(phi[:, 100:1000] ** 2)
    late = jnp.mean(phi[:, -900:] ** 2)
    # Exact growth rate of E[φ²] is the largest root of λ³ + 6ζλ² + (8ζ²+4)λ + 8ζ − 2D: ≈ 0.2 /s here.
    rate = max(np.roots([1, 6 * zeta, 8 * zeta**2 + 4, 8 * zeta - 2 * 0.6]).real)
    assert rate > 0.1
    assert float(late) > 100 * float(early)


def test_time_step_convergence_with_common_random_numbers(getkey):
    """Halving dt changes the mean zero-crossing amplitude of the default ship (H1/3 = 7 m) by < 1 %.

    The same effective-wave path drives both runs: the exact filter discretisation at dt/2, subsampled for dt.
    """
    ship = jaxroll.c11_representative()
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), ship.lpp)
    f = jaxroll.fit_filter(wave, order=4, match_frequency=2 * ship.omega0).filter
    dt, duration = 0.5, 1800.0
    n_fine = int(duration / (dt / 2))
    phi_f, chol_f = f.discretise(dt / 2)  # the exact one-step law at dt/2
    sigma_chol = jnp.linalg.cholesky(f.stationary_covariance())

    def path(key):
        def step(z, e):
            z = phi_f @ z + chol_f @ e
            return z, z

        z0 = sigma_chol @ jr.normal(jr.fold_in(key, 1), (f.order,))
        _, zs = jax.lax.scan(step, z0, jr.normal(key, (n_fine, f.order)))
        zs = jnp.concatenate([z0[None], zs])
        return zs @ f.c, zs @ (f.a.T @ f.c)  # ζ_G and dζ_G/dt = cᵀA z

    def mean_amp(key):
        zeta, dzeta = path(key)
        out = []
        for step, sub in ((dt, 2), (dt / 2, 1)):
            problem = jaxroll.RollProblem(ship, jaxroll.SampledExcitation(zeta[::sub], dzeta[::sub], step))
            phi, _, end = jaxroll.roll_time_series(problem, key, duration)
            a = jaxroll.zero_crossing_amplitudes(phi)
            out.append(jnp.sum(a) / jnp.sum(a > 0).astype(float))
        return jnp.stack(out), end.capsized

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        means, capsized = jax.vmap(mean_amp)(jr.split(getkey(), 48))
    means = np.asarray(means)[~np.asarray(capsized)]
    rel = means[:, 0].mean() / means[:, 1].mean() - 1
    assert abs(rel) < 0.01, rel


def test_capsize_counted_and_never_poisons_statistics(getkey):
    ship = jaxroll.c11_representative()
    problem = jaxroll.RollProblem.from_sea(ship, jaxroll.ITTC(12.0, 10.0), dt=0.5)
    stats = jaxroll.monte_carlo_amplitudes(
        problem, getkey(), num_realizations=40, duration=1200.0, chunk_size=20
    )
    assert 0 < stats.n_capsized < 40
    assert np.all(np.isfinite(stats.counts_zero_crossing)) and np.all(np.isfinite(stats.counts_envelope))
    assert np.all(np.isfinite(stats.capsize_time[stats.capsized]))
    assert np.all(np.isinf(stats.capsize_time[~stats.capsized]))
    pr = stats.per_realization
    assert np.all(pr["n_zc"][stats.capsized] == 0)  # excluded from amplitude statistics
    assert stats.n_amplitudes("zero_crossing") == pr["n_zc"].sum()
    assert np.isfinite(stats.mean("zero_crossing"))
    assert stats.quantiles("envelope")[-1] < float(problem.capsize_angle)


def test_results_independent_of_chunk_size(getkey):
    problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0), dt=0.5)
    key = getkey()
    runs = [
        jaxroll.monte_carlo_amplitudes(problem, key, num_realizations=7, duration=600.0, chunk_size=c)
        for c in (3, 7)
    ]
    np.testing.assert_array_equal(runs[0].counts_zero_crossing, runs[1].counts_zero_crossing)
    np.testing.assert_array_equal(runs[0].counts_envelope, runs[1].counts_envelope)
    for k in runs[0].per_realization:
        np.testing.assert_allclose(runs[0].per_realization[k], runs[1].per_realization[k], rtol=1e-13, atol=0)
    assert runs[0].mean("envelope") == pytest.approx(runs[1].mean("envelope"), rel=1e-13)
    # The histogram as a distribution: its mean is the exact mean to within the bin width.
    for pool, width in ((1, 0.05), (20, 1.0)):
        law = runs[0].law("zero_crossing", pool=pool)
        assert abs(np.rad2deg(float(law.mean())) - np.rad2deg(runs[0].mean("zero_crossing"))) < width / 2
    with pytest.raises(ValueError, match="`pool` must divide"):
        runs[0].law("zero_crossing", pool=7)


def _observe_series(observer, phi, dt=0.5, phi0=0.0):
    """`observer` fed the roll series `phi` [rad] step by step as `simulate` does (outputs kept after the steps
    r, 2r, …), then reduced: `(summed, per)` of one realization."""
    import types

    problem = types.SimpleNamespace(dt=dt, phi0=jnp.asarray(phi0))
    r = observer.record_every(problem)

    @jax.jit
    def run(phi):
        def step(state, kv):
            k, v = kv
            return observer.observe(problem, state, k, jnp.stack([v, 0.0 * v]), True)

        steps = jnp.arange(1, phi.size + 1)
        state, outs = jax.lax.scan(step, observer.init(problem, None), (steps, phi))
        outputs = jax.tree.map(lambda o: o[r - 1 :: r][None], outs)
        end = jaxroll.RealizationEnd(jnp.array([False]), jnp.array([jnp.inf]))
        return observer.reduce(
            problem, jax.tree.map(lambda x: x[None], state), outputs, end, jnp.array([True])
        )

    return run(jnp.asarray(phi))


def test_recorded_zero_crossing_bins_are_every_amplitude():
    """The histogram observer records φ and the zero-crossing bins every r steps, but its detector sees every step:
    on a made-up series of 1003 steps (not a multiple of r = 4, so the last amplitudes end after the last record)
    its zero-crossing histogram is exactly that of `zero_crossing_amplitudes` over the whole series after the
    discard, for r = 1 and 4; its envelope is that of φ[r-1::r]."""
    from jaxroll.roll._amplitudes import envelope_rfft, zero_crossing_amplitudes

    t = 0.5 * np.arange(1, 1004)
    phi = np.radians(10 + 5 * np.sin(0.01 * t)) * np.sin(0.26 * t + 0.3) + np.radians(0.5) * np.sin(1.3 * t)
    amps = np.asarray(zero_crossing_amplitudes(jnp.asarray(np.concatenate([[0.0], phi]))))[1:]
    amps = amps[101:]  # after the discard of 50.5 s = 101 steps
    expected = np.bincount(np.floor(np.degrees(amps[amps > 0]) / 0.05).astype(int), minlength=1800)
    for every in (1, 4):
        summed, per = _observe_series(jaxroll.AmplitudeHistogram(50.5, every=every), phi)
        np.testing.assert_array_equal(summed["counts_zero_crossing"], expected)
        assert int(summed["zero_crossing_merged"]) == 0 and float(per["n_zc"][0]) == expected.sum() > 30
        kept = phi[every - 1 :: every][101 // every :]
        assert per["n_env"][0] == kept.size
        np.testing.assert_allclose(
            per["sum_env"][0], np.asarray(envelope_rfft(jnp.asarray(kept))).sum(), rtol=1e-6
        )


def test_zero_crossings_in_one_record_interval_are_counted_and_reported():
    """A roll with half cycles shorter than the record interval (3 steps against r = 4: a sea the observer's
    default never meets, Tφ ≥ 12 records) puts two amplitudes in one interval: the later one is binned, the
    overwritten ones are counted (`zero_crossing_merged`, so the histogram plus them is every amplitude) and
    `result` warns with the count and the way out."""
    phi = np.radians(5.0) * np.sin(np.pi / 3 * np.arange(1, 401) + 0.5)
    observer = jaxroll.AmplitudeHistogram(every=4)
    summed, per = _observe_series(observer, phi)
    merged = int(summed["zero_crossing_merged"])
    assert merged > 20 and float(summed["counts_zero_crossing"].sum()) + merged == float(per["n_zc"][0])
    per = {k: np.asarray(v) for k, v in per.items()}
    with pytest.warns(
        UserWarning, match=f"{merged} zero-crossing amplitudes ended in the same record interval"
    ):
        observer.result({k: np.asarray(v) for k, v in summed.items()}, per, {"dt_s": 0.5})


def test_envelope_recorded_every_filter_step_estimates_the_same_law(getkey):
    """Every r = 4 steps (2 s, 12 records per roll period) against every step, on the same 32 trials of the paper's
    sea: the zero-crossing histograms are identical (the detector sees every step), and the envelope law, its mean
    and E[φ²] agree far inside their standard errors (the envelope is time-weighted: sampling it every 2 s
    estimates the same law). Measured on 10⁴ trials: KS distance 5e-5, mean 2e-5 (0.01 SE)."""
    problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0), dt=0.5)
    assert jaxroll.envelope_record_every(problem) == 4
    superposition = jaxroll.RollProblem.from_sea(
        jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0), dt=0.5, excitation="superposition"
    )
    assert jaxroll.envelope_record_every(superposition) == 1  # one time step per source step
    key = getkey()
    # every = 4 is the stationarity test's 7 m run (the same program: compiled once per process)
    runs = {
        every: jaxroll.monte_carlo(
            problem,
            key,
            jaxroll.AmplitudeHistogram(500.0, every=every),
            num_realizations=32,
            duration=3600.0,
            chunk_size=32,
        )
        for every in (1, 4)
    }
    fine, coarse = runs[1], runs[4]
    np.testing.assert_array_equal(fine.counts_zero_crossing, coarse.counts_zero_crossing)
    assert coarse.per_realization["n_env"][0] * 4 == fine.per_realization["n_env"][0]
    m_fine, m_coarse = fine.mean("envelope"), coarse.mean("envelope")
    per = fine.per_realization["sum_env"] / fine.per_realization["n_env"]
    se = per.std(ddof=1) / np.sqrt(per.size)
    assert abs(m_coarse - m_fine) < 0.05 * se and abs(m_coarse / m_fine - 1) < 1e-3
    cdf = [np.cumsum(r.counts_envelope) / r.counts_envelope.sum() for r in (fine, coarse)]
    assert np.abs(cdf[0] - cdf[1]).max() < 2e-3
    e2 = [r.phi_moments()["E_phi2"] for r in (fine, coarse)]
    assert e2[1] == pytest.approx(e2[0], rel=2e-3)


def test_rk4_order_on_free_decay():
    """Deterministic free decay (no waves): RK4 error falls as dt⁴ against a fine diffrax reference."""
    import diffrax

    ship = jaxroll.c11_representative()
    no_wave = lambda t: 0.0
    term = diffrax.ODETerm(jaxroll.roll_vector_field)
    ref = diffrax.diffeqsolve(
        term,
        diffrax.Dopri8(),
        0.0,
        120.0,
        0.01,
        jnp.array([0.5, 0.0]),
        args=(ship, no_wave),
        stepsize_controller=diffrax.PIDController(rtol=1e-12, atol=1e-12),
        max_steps=100000,
    )
    errors = []
    for dt in (2.0, 1.0, 0.5):
        exc = jaxroll.SampledExcitation(jnp.zeros(4096), jnp.zeros(4096), dt)
        phi, _, _ = jaxroll.roll_time_series(jaxroll.RollProblem(ship, exc, 0.5, 0.0), jr.key(0), 120.0)
        errors.append(abs(float(phi[-1] - ref.ys[-1, 0])))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 3.6), orders


def test_problem_errors():
    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    with pytest.raises(ValueError, match="dt = 3.0 s is too large"):
        jaxroll.RollProblem.from_sea(ship, sea, dt=3.0)
    with pytest.warns(UserWarning, match="This warning appears because dt"):
        jaxroll.RollProblem.from_sea(ship, sea, dt=0.9)
    with pytest.raises(ValueError, match="`dt` must be a finite number > 0"):
        jaxroll.RollProblem.from_sea(ship, sea, dt=-1.0)
    with pytest.raises(ValueError, match="`excitation` must be 'auto', 'filter' or 'superposition'"):
        jaxroll.RollProblem.from_sea(ship, sea, excitation="magic")
    with pytest.raises(ValueError, match="beyond the angle of vanishing stability"):
        jaxroll.RollProblem.from_sea(ship, sea, phi0=math.radians(80.0))
    problem = jaxroll.RollProblem.from_sea(ship, sea)
    with pytest.raises(ValueError, match="`num_realizations` must be a positive integer"):
        jaxroll.monte_carlo_amplitudes(problem, jr.key(0), num_realizations=0)
    with pytest.raises(ValueError, match="`discard` must be in"):
        jaxroll.monte_carlo_amplitudes(problem, jr.key(0), num_realizations=2, duration=100.0, discard=200.0)
    with pytest.raises(ValueError, match="the excitation record has 10 samples"):
        exc = jaxroll.SampledExcitation(jnp.zeros(10), jnp.zeros(10), 0.5)
        jaxroll.roll_time_series(jaxroll.RollProblem(ship, exc), jr.key(0), 100.0)
    with pytest.raises(ValueError, match="must equal `excitation.dt`"):
        jaxroll.RollProblem(
            ship,
            jaxroll.SampledExcitation(jnp.zeros(10), jnp.zeros(10), 0.5),
            moment_excitation=jaxroll.SampledExcitation(jnp.zeros(10), jnp.zeros(10), 0.25),
        )


def test_a_roll_that_dies_out_is_reported_as_not_stationary(getkey):
    """At H1/3 = 3 m the default ship's roll dies out, slowly (every theory says so): a run from φ0 = 5° has a
    mean envelope amplitude well above zero that depends on φ0 and the duration. `stationarity()` compares the two
    halves of the kept window (exact per-realization sums, checked here against scipy's Hilbert envelope of
    `roll_time_series`) and says so; at 7 m the roll is stationary."""
    from scipy.signal import hilbert

    ship = jaxroll.c11_representative()
    key = getkey()
    out = {}
    for hs in (3.0, 7.0):
        problem = jaxroll.RollProblem.from_sea(ship, jaxroll.ITTC(hs, 10.0), dt=0.5)
        stats = jaxroll.monte_carlo_amplitudes(
            problem, key, num_realizations=32, duration=3600.0, discard=500.0, chunk_size=32
        )
        out[hs] = stats.stationarity()
    s = out[3.0]
    assert s["stationary"] is False and s["relative_change"] < -0.5 and s["change_in_standard_errors"] < -3
    assert "dying out" in s["note"] and "500–2050 s" in s["note"]
    assert out[7.0]["stationary"] is True and abs(out[7.0]["relative_change"]) < 0.1
    # The halves' sums: realization 0 of the 7 m run, float64 series and scipy's envelope (float32 Monte Carlo).
    # φ is recorded every r = 4 steps (2 s): the records after the discard are steps 1004, 1008, …, 7200
    assert jaxroll.envelope_record_every(problem) == 4 and stats.config["record_interval_s"] == 2.0
    phi, _, _ = jaxroll.roll_time_series(problem, jr.fold_in(key, 0), 3600.0)
    env = np.abs(hilbert(np.asarray(phi)[1004::4]))
    pr = stats.per_realization
    assert (
        pr["n_env"][0] == env.size
    )  # its first half, n_env // 2 samples, is pinned by the sum below (rtol 1e-4: float32 round-off over 7 200
    # steps, 2.6e-5 with the default order-8 filter, under 2e-5 with order 4)
    np.testing.assert_allclose(pr["sum_env_first_half"][0], env[: env.size // 2].sum(), rtol=1e-4)
    np.testing.assert_allclose(pr["sum_env"][0], env.sum(), rtol=1e-4)


def test_stationarity_needs_a_change_both_large_and_significant():
    """The decision of `stationarity()` on per-realization sums made up with a known drift and spread: a 30 %
    fall well beyond its standard error is flagged; a 5 % one is not (below the tolerance); a 30 % one within
    its noise is not (not significant); two realizations or no amplitude cannot tell."""
    rng = np.random.default_rng(0)

    def stats(n, first, second, spread):
        m1 = first + spread * rng.standard_normal(n)
        m2 = second + spread * rng.standard_normal(n)
        half = np.full(n, 1000.0)
        per = {"n_env": 2 * half, "sum_env": half * (m1 + m2), "sum_env_first_half": half * m1}
        return jaxroll.AmplitudeStatistics(
            np.arange(3.0),
            np.zeros(2),
            np.zeros(2),
            np.zeros(n, bool),
            np.zeros(n),
            per,
            {"discard_s": 0.0, "duration_s": 3600.0},
        ).stationarity()

    s = stats(200, 0.10, 0.07, 0.01)
    assert s["stationary"] is False and s["relative_change"] == pytest.approx(-0.3, abs=0.02)
    assert "0–1800 s" in s["note"] and "1800–3600 s" in s["note"]
    assert stats(200, 0.10, 0.095, 0.001)["stationary"] is True  # 5 %: significant, but below the tolerance
    assert stats(4, 0.10, 0.07, 0.2)["stationary"] is True  # 30 %, but within a few standard errors
    assert stats(1, 0.10, 0.07, 0.01)["stationary"] is None and stats(1, 0.1, 0.07, 0.01)["note"] is None
    assert stats(50, 0.0, 0.0, 0.0)["stationary"] is None
    alike = stats(
        50, 0.10, 0.02, 0.0
    )  # identical trials (an unexcited decay from the same φ0): an exact change
    assert alike["stationary"] is False and alike["change_in_standard_errors"] is None
    assert "every trial alike" in alike["note"]
