"""The batched Monte Carlo kernel (jaxroll.roll._batched, issue 15) and the capsize horizon of `simulate`."""

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from helpers import default_problem

from jaxroll.roll import _batched
from jaxroll.roll._equation import simulate


def test_block_normals_are_jax_random_normal():
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(3), i))(jnp.arange(37))
    ours = _batched.block_normals(keys, 5, (128, 4))
    ref = jax.vmap(lambda k: jr.normal(jr.fold_in(k, 5), (128, 4), jnp.float32))(keys)
    np.testing.assert_array_equal(np.asarray(ours), np.moveaxis(np.asarray(ref), 0, -1))


def test_coarse_grid_chosen_from_interpolation_error():
    exc = default_problem().excitation
    assert exc.coarse == 4 and exc.bridge.shape == (2, 7, exc.c.size)


def _run(problem, keys, num_steps, dtype):
    def observe(state, k, y, alive):
        return state, y[0]

    _, phi, end = _batched.simulate_batch(problem, keys, num_steps, observe, jnp.zeros(keys.shape[0]), dtype=dtype)
    return phi, end


def test_float32_statistics_equal_float64_on_the_same_noise():
    problem = default_problem()
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(2), i))(jnp.arange(32))
    p32, e32 = _run(problem, keys, 1200, jnp.float32)
    p64, e64 = _run(problem, keys, 1200, jnp.float64)
    env32 = _batched.envelope_rfft(jnp.asarray(p32, jnp.float64).T)
    env64 = _batched.envelope_rfft(p64.T)
    ok = ~np.asarray(e64.capsized)
    np.testing.assert_array_equal(np.asarray(e32.capsized), np.asarray(e64.capsized))
    m32, m64 = float(env32[ok].mean()), float(env64[ok].mean())
    assert abs(m32 / m64 - 1) < 1e-3


def test_simulate_counts_no_capsize_after_num_steps():
    problem = default_problem(12.0, 10.0)
    keys = jax.vmap(lambda i: jr.fold_in(jr.key(0), i))(jnp.arange(16))

    def run(n):
        return jax.vmap(lambda k: simulate(problem, k, n, lambda s, k, y, a: (s, None), None)[2])(keys)

    num_steps = 300  # not a multiple of the 256-step noise block
    end = run(num_steps)
    t = np.asarray(end.capsize_time)
    assert np.all(t[np.asarray(end.capsized)] <= num_steps * problem.dt)
    longer = run(512)  # the same noise: capsizes up to num_steps agree, later ones are not counted above
    tl = np.asarray(longer.capsize_time)
    np.testing.assert_array_equal(np.asarray(end.capsized), tl <= num_steps * problem.dt)
