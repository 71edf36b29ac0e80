"""The Monte Carlo kernel (issue 15): one realization written once (`simulate`), vmapped; the shaping filter
stepped every m time steps and bridged in between; float32 integration; the capsize horizon."""

import jax
import jax.extend.random
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
import scipy.stats
from helpers import default_problem

import jaxroll
from jaxroll.roll._amplitudes import envelope_rfft, hilbert_envelope, row_sums
from jaxroll.roll._equation import simulate
from jaxroll.roll._excitation import (
    BLOCK,
    _bits_to_normal,
    block_normals,
    block_normals_by_column,
    interpolation_error_variance,
    threefry2x32,
)


def test_block_normals_are_threefry_words_mapped_as_jax_random_normal():
    """Our unrolled Threefry-2x32 equals JAX's, both output words are used, and each word becomes a normal exactly as
    `jax.random.normal` maps bits (checked on JAX's own XOR'd words)."""
    key = jr.fold_in(jr.key(3), 7)
    ours = np.asarray(block_normals(key, 5, (BLOCK, 4)))
    kd = jr.key_data(jr.fold_in(key, 5))
    ctr = jnp.arange(BLOCK * 2, dtype=jnp.uint32)
    words = jax.extend.random.threefry_2x32(kd, jnp.concatenate([jnp.zeros_like(ctr), ctr]))  # JAX's hash
    b0, b1 = threefry2x32(kd[0], kd[1], jnp.zeros_like(ctr), ctr)
    np.testing.assert_array_equal(np.asarray(jnp.concatenate([b0, b1])), np.asarray(words))
    np.testing.assert_array_equal(
        ours.reshape(-1), np.asarray(_bits_to_normal(jnp.stack([b0, b1], -1).reshape(-1)))
    )
    # the bits → normal map is jax.random.normal's: on JAX's own bits (the XOR of the two words) it gives its numbers
    ref = jr.normal(jr.fold_in(key, 5), (BLOCK, 2), jnp.float32)
    np.testing.assert_array_equal(np.asarray(_bits_to_normal(b0 ^ b1)).reshape(BLOCK, 2), np.asarray(ref))


def test_block_normals_by_column_are_block_normals_columns():
    """The filter's normals, hashed column by column, are `block_normals`' columns bit for bit, for even and odd
    filter orders, under vmap over realizations, and with another PRNG (its own normals, the same columns)."""
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(3), i))(jnp.arange(6))
    for n in (3, 4, 5, 6):
        cols = jax.vmap(lambda k, n=n: jnp.stack(block_normals_by_column(k, 9, n), -1))(keys)
        ref = jax.vmap(lambda k, n=n: block_normals(k, 9, (BLOCK, n)))(keys)
        assert cols.shape == (6, BLOCK, n) and cols.dtype == jnp.float32
        np.testing.assert_array_equal(np.asarray(cols), np.asarray(ref))
    rbg = jr.key(3, impl="rbg")
    np.testing.assert_array_equal(
        np.asarray(jnp.stack(block_normals_by_column(rbg, 2, 4), -1)),
        np.asarray(block_normals(rbg, 2, (BLOCK, 4))),
    )


def test_block_normals_are_standard_normal_and_independent():
    """Kolmogorov–Smirnov against N(0, 1) on 2·10⁵ draws, and lag-1 and cross-word correlations within 4 SE of 0."""
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(5), i))(jnp.arange(100))
    z = np.asarray(jax.vmap(lambda k: block_normals(k, 0, (BLOCK, 16)))(keys), dtype=np.float64)
    assert scipy.stats.kstest(z.reshape(-1), "norm").pvalue > 1e-3
    flat = z.reshape(100, -1)
    se = 1 / np.sqrt(flat.size)
    assert abs(np.mean(flat[:, 1:] * flat[:, :-1])) < 4 * se * np.sqrt(2)
    assert abs(np.mean(z[:, :, 0::2] * z[:, :, 1::2])) < 4 * se * np.sqrt(2)


def test_filter_step_chosen_from_the_bridge_error():
    exc = default_problem().excitation
    assert exc.substeps == 4 and exc.bridge.shape == (2, 7, exc.c.size)
    # the chosen step leaves out at most 1e-6 of the variance at every stage time; the next coarser would not do
    f = default_problem().filter_fit.filter
    half, _ = f.discretise(exc.dt / 2)
    sigma = f.stationary_covariance()
    assert float(jnp.max(interpolation_error_variance(half, sigma, f.c, 4))) <= 1e-6
    assert float(jnp.max(interpolation_error_variance(half, sigma, f.c, 8))) > 1e-6


def test_filter_source_steps_reproduce_the_stationary_law(getkey):
    """Σ is invariant under the step H = m·dt (z' = Φz + Lε), and the bridged ζ_G at every half step has the
    target variance and the filter's own autocovariance at lag dt/2 (exact Gaussian-process identities)."""
    problem = default_problem()
    exc, f = problem.excitation, problem.filter_fit.filter
    sigma = f.stationary_covariance()
    full = jaxroll.FilterExcitation(f, exc.dt, exc.substeps, noise_rank=f.order)
    np.testing.assert_allclose(
        full.phi @ sigma @ full.phi.T + full.chol @ full.chol.T,
        sigma,
        rtol=1e-9,
        atol=1e-12 * float(jnp.abs(sigma).max()),
    )
    num_steps = 4 * BLOCK * exc.substeps
    p, _ = jax.vmap(lambda k: jaxroll.roll.forcing_series(problem, k, num_steps))(jr.split(getkey(), 64))
    # P is a polynomial of ζ_G; recover ζ_G from the linear term's sign-free second moment through its variance
    zeta_var = float(problem.wave.variance())
    ship = problem.ship
    kappa = float(ship.gm_correction * ship.omega0**2 / ship.gm0)
    c1 = float(ship.delta_gm[1])
    # E[P] = κ(C0 + C2 σ²) exactly for a Gaussian ζ (C3 ζ³ odd); Var[P] to leading order κ²C1²σ².
    c2 = float(ship.delta_gm[2])
    mean_p = float(jnp.mean(p))
    se = float(jnp.std(p)) / np.sqrt(p.shape[0] * p.shape[1] / 60)  # ~60 correlated samples per effective one
    assert abs(mean_p - kappa * c2 * zeta_var) < 4 * se, (mean_p, kappa * c2 * zeta_var, se)
    assert abs(float(jnp.var(p)) / (kappa * c1) ** 2 / zeta_var - 1) < 0.08


def test_float32_statistics_equal_float64_on_the_same_noise():
    problem = default_problem()
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(2), i))(jnp.arange(32))

    def run(dtype):
        return jax.vmap(lambda k: jaxroll.roll_time_series(problem, k, 600.0, dtype=dtype))(keys)

    p32, _, e32 = run(jnp.float32)
    p64, _, e64 = run(jnp.float64)
    assert p32.dtype == jnp.float32 and p64.dtype == jnp.float64
    np.testing.assert_array_equal(np.asarray(e32.capsized), np.asarray(e64.capsized))
    ok = ~np.asarray(e64.capsized)
    # the same trajectory to float32 round-off accumulated over 1200 steps
    assert float(jnp.max(jnp.abs(p32[ok].astype(jnp.float64) - p64[ok]))) < 1e-4
    m32 = float(hilbert_envelope(jnp.asarray(p32, jnp.float64))[ok].mean())
    m64 = float(hilbert_envelope(p64)[ok].mean())
    assert abs(m32 / m64 - 1) < 1e-4


def test_envelope_rows_are_independent_of_the_batch():
    """The float32 envelope of a row is bit for bit the same in any batch: the histograms do not depend on the
    chunk size."""
    x = (jr.normal(jr.key(1), (40, 1200)) * 0.2).astype(jnp.float32)
    full = np.asarray(jax.jit(envelope_rfft)(x))
    for lo, hi in ((0, 1), (3, 11), (7, 40)):
        np.testing.assert_array_equal(np.asarray(jax.jit(envelope_rfft)(x[lo:hi])), full[lo:hi])
    np.testing.assert_allclose(full, np.asarray(hilbert_envelope(x.astype(jnp.float64))), rtol=0, atol=2e-6)


def test_row_sums_are_float64_sums_independent_of_the_batch():
    """The histogram observer's sums over time: float64 sums of float32 records, in one pass, each row the same
    bits in any batch (the per-realization sums do not depend on the chunk size)."""
    x = (jr.normal(jr.key(2), (40, 1800)) * 0.2).astype(jnp.float32)
    sums = jax.jit(lambda x: row_sums(x, x.astype(jnp.float64) ** 2, jnp.abs(x)))
    full = [np.asarray(s) for s in sums(x)]
    x64 = np.asarray(x).astype(np.float64)
    for got, want in zip(full, (x64, x64 * x64, np.abs(x64)), strict=True):
        assert got.dtype == np.float64
        np.testing.assert_allclose(got, want.sum(1), rtol=1e-12, atol=1e-12)
    for lo, hi in ((0, 1), (3, 11), (7, 40)):
        for got, whole in zip(sums(x[lo:hi]), full, strict=True):
            np.testing.assert_array_equal(np.asarray(got), whole[lo:hi])


def test_monte_carlo_trial_is_the_time_series_of_its_key():
    """Trial i of the Monte Carlo is `roll_time_series` with key fold_in(key, i): one realization, written once."""
    problem = default_problem()
    key = jr.key(4)
    stats = jaxroll.monte_carlo_max_roll(
        problem, key, angle_deg=30.0, num_realizations=3, duration=900.0, chunk_size=3
    )
    for i in range(3):
        phi, _, _ = jaxroll.roll_time_series(problem, jr.fold_in(key, i), 900.0, dtype=jnp.float32)
        np.testing.assert_allclose(
            stats.max_abs_phi_deg[i], np.rad2deg(float(jnp.max(jnp.abs(phi[1:])))), rtol=1e-6
        )


def test_simulate_counts_no_capsize_after_num_steps():
    problem = default_problem(12.0, 10.0)
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(0), i))(jnp.arange(16))

    def run(n):
        return jax.vmap(lambda k: simulate(problem, k, n, lambda s, k, y, a: (s, None), None)[2])(keys)

    num_steps = 301  # neither a multiple of the filter's 4-step source step nor of a block
    end = run(num_steps)
    t = np.asarray(end.capsize_time)
    assert np.all(t[np.asarray(end.capsized)] <= num_steps * problem.dt)
    longer = run(
        4 * BLOCK * 4
    )  # the same noise: capsizes up to num_steps agree, later ones are not counted above
    tl = np.asarray(longer.capsize_time)
    np.testing.assert_array_equal(np.asarray(end.capsized), tl <= num_steps * problem.dt)


def test_simulate_refuses_more_steps_than_an_int32_counts():
    with pytest.raises(ValueError, match="at most 2³¹ − 1 time steps per realization; got 2147483648"):
        simulate(default_problem(), jr.key(0), 2**31, lambda s, k, y, a: (s, None), None)


def test_the_filter_step_draws_the_principal_directions_of_its_noise():
    """The step's noise covariance Q = Σ − ΦΣΦᵀ over H = 2 s is nearly singular (eigenvalues falling ×10–40 each):
    the default order-8 filter draws r = 6 normals per step, its r largest directions. Checked with scipy's discrete
    Lyapunov solver (not the library's Kronecker solve): the stationary covariance Σ_r of z' = Φz + L_r ε differs
    from Σ by at most 1e-6 of the variance of any linear function of the state (Σ^{-1/2}-whitened), where r − 2
    normals would leave out more; the full rank reproduces Σ; a traced filter keeps every direction."""
    import scipy.linalg

    from jaxroll.roll._excitation import choose_noise_rank

    problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0))  # order 8
    exc, f = problem.excitation, problem.filter_fit.filter
    assert (f.order, exc.noise_rank, exc.chol.shape) == (8, 6, (8, 6))
    assert (
        default_problem().excitation.noise_rank == 4
    )  # the paper's order 4: every direction (r = 2 leaves 8e-3)
    sigma = np.asarray(f.stationary_covariance())
    w, v = np.linalg.eigh(sigma)
    whiten = v / np.sqrt(w)

    def worst(rank):
        chol = np.asarray(jaxroll.FilterExcitation(f, exc.dt, exc.substeps, noise_rank=rank).chol)
        sigma_r = scipy.linalg.solve_discrete_lyapunov(np.asarray(exc.phi), chol @ chol.T)
        return np.abs(np.linalg.eigvalsh(whiten.T @ (sigma - sigma_r) @ whiten)).max()

    assert worst(6) < 1e-6 < worst(4)
    assert worst(8) < 1e-9
    # the r columns are the r largest of the full square root (the same directions and lengths)
    full = np.asarray(jaxroll.FilterExcitation(f, exc.dt, exc.substeps, noise_rank=8).chol)
    np.testing.assert_array_equal(np.asarray(exc.chol), full[:, 2:])
    assert jax.jit(lambda g: choose_noise_rank(g, exc.dt, exc.substeps) + jnp.zeros(()))(f) == 8
    with pytest.raises(ValueError, match="`noise_rank` must be an integer in 1 … 8"):
        jaxroll.FilterExcitation(f, exc.dt, exc.substeps, noise_rank=9)
