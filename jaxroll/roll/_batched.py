"""The batched Monte Carlo kernel: a chunk of realizations as vectors, the shaping filter on a coarse grid, float32.

`simulate_batch` is the batched counterpart of `simulate` (one realization) for a `FilterExcitation` without a
moment excitation; `simulate_chunk` uses it for every such problem (docs/numerics.md, "Monte Carlo kernel").
Same model and scheme as `simulate`: the shaping filter discretised exactly and started from its stationary law,
classical RK4 at dt on (φ, φ̇) with P(t) at the step ends and midpoint, capsize = |φ| ≥ the vanishing angle or a
non-finite state, the state frozen after a capsize. What differs, each measured (issue 15):

1. **The filter on a coarse grid** H = m·dt (m = `excitation.coarse`, 4 for the paper's protocol): stepped
   exactly (Φ_H = Φᵐ, L_H L_Hᵀ = Σ − Φ_H Σ Φ_Hᵀ), so n/m normals per RK4 step instead of n. Between filter
   samples ζ_G is its conditional mean given the filter state at both ends (the Gaussian bridge, the best
   interpolant; `FilterExcitation.bridge`), which leaves out ≤ 1e-6 σ_G² (3.7e-7 at H = 2 s for the paper's
   sea; cubic Hermite at H = 2 s leaves out 3.1e-5 and biased the mean amplitudes by −0.32 %).
2. **Realizations are the vector axis**: one scan over time of [chunk]-vectors (explicit scalar algebra, no
   vmap of a scan); the noise of each block is drawn before the block's scan by an unrolled threefry that gives
   `jax.random.normal`'s numbers bit for bit; `optimization_barrier`s stop XLA:CPU from recomputing the
   excitation and earlier RK4 steps inside the loop body (−15…25 % time, bit-identical results).
3. **float32 integration** (`dtype`): the statistics equal float64's on the same noise to ~1e-5 deg.

Random numbers: realization i uses only k_i = `fold_in(key, i)`: its filter start is
`stationary_chol @ jr.normal(fold_in(k_i, 0x7FFFFFFF), (n,))` (float64, as `FilterExcitation.init`), and the
innovations of coarse block j (`BLOCK_COARSE` coarse steps) are `jr.normal(fold_in(k_i, j), (BLOCK_COARSE, n),
float32)`. So results are the same bit for bit whatever the chunk size or the device count, and a realization
does not depend on the duration simulated after it. The stream is not `simulate`'s (another grid): the two
kernels agree statistically, not sample by sample.

Only steps 1 … num_steps are simulated, observed and checked for capsize (when num_steps is not a multiple of m
the last coarse step's extra fine steps are masked).
"""

from __future__ import annotations

import math
from functools import partial

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ._equation import RealizationEnd, RollProblem
from ._excitation import FilterExcitation

BLOCK_COARSE = 128  # coarse filter steps per noise block (block j keyed by fold_in(k_i, j))


def supported(problem: RollProblem) -> bool:
    """Whether `simulate_batch` handles `problem`: a `FilterExcitation` without a moment excitation."""
    return isinstance(problem.excitation, FilterExcitation) and problem.moment_excitation is None


# ----------------------------------------------------------------------------------------------------------------
# Random numbers: jax.random.normal's stream, computed in one fused elementwise pass
# ----------------------------------------------------------------------------------------------------------------


def _rotl(x, r: int):
    return (x << np.uint32(r)) | (x >> np.uint32(32 - r))


def threefry2x32(k0, k1, x0, x1):
    """Threefry-2x32 (20 rounds), unrolled, elementwise on uint32 arrays: `jax.random`'s default hash.

    JAX lowers its own on CPU as a 5-iteration loop over whole arrays; unrolled, XLA fuses it into one pass
    (2.3–2.6× faster) with bit-identical results.
    """
    rot = ((13, 15, 26, 6), (17, 29, 16, 24))
    ks = (k0, k1, k0 ^ k1 ^ np.uint32(0x1BD11BDA))
    x0, x1 = x0 + ks[0], x1 + ks[1]
    for i in range(5):
        for r in rot[i % 2]:
            x0 = x0 + x1
            x1 = _rotl(x1, r) ^ x0
        x0 = x0 + ks[(i + 1) % 3]
        x1 = x1 + ks[(i + 2) % 3] + np.uint32(i + 1)
    return x0, x1


def _bits_to_normal(bits):
    """Standard normal (float32) from 32 random bits exactly as `jax.random.normal`: √2·erf⁻¹(u), u ∈ (−1, 1)."""
    f = jax.lax.bitcast_convert_type((bits >> np.uint32(9)) | np.uint32(0x3F800000), jnp.float32)  # [1, 2)
    lo = np.nextafter(np.float32(-1), np.float32(0))
    u = jnp.maximum((f - np.float32(1)) * (np.float32(1) - lo) + lo, lo)
    return np.float32(math.sqrt(2)) * jax.lax.erf_inv(u)


def block_normals(keys, index, shape):
    """`jax.random.normal(fold_in(k, index), shape, float32)` for every key k of `keys` [chunk], bit for bit, as
    an array [*shape, chunk] (threefry with `jax_threefry_partitionable` counters; other PRNGs: `jr.normal`)."""
    if not jax.config.jax_threefry_partitionable or jr.key_impl(keys) != jr.key_impl(jr.key(0)):
        eps = jax.vmap(lambda k: jr.normal(jr.fold_in(k, index), shape, jnp.float32))(keys)
        return jnp.moveaxis(eps, 0, -1)
    kd = jax.vmap(lambda k: jr.key_data(jr.fold_in(k, index)))(keys)  # [chunk, 2] uint32
    ctr = jnp.arange(math.prod(shape), dtype=jnp.uint32).reshape(*shape, 1)
    b0, b1 = threefry2x32(kd[:, 0], kd[:, 1], jnp.zeros_like(ctr), ctr)
    return _bits_to_normal(b0 ^ b1)


# ----------------------------------------------------------------------------------------------------------------
# A batch of realizations
# ----------------------------------------------------------------------------------------------------------------


def _cast_like(new, old):
    """`new` with the dtypes of `old` leaf by leaf (keeps an observer's scan carry type fixed)."""

    def cast(n, o):
        if isinstance(o, jax.Array) and not jnp.issubdtype(o.dtype, jax.dtypes.prng_key):
            return n.astype(o.dtype)
        return n

    return jax.tree_util.tree_map(cast, new, old)


def _to_dtype(tree, dtype):
    """Floating leaves of `tree` cast to `dtype`."""

    def cast(x):
        if isinstance(x, jax.Array) and jnp.issubdtype(x.dtype, jnp.floating):
            return x.astype(dtype)
        return x

    return jax.tree_util.tree_map(cast, tree)


def simulate_batch(
    problem: RollProblem,
    keys,
    num_steps: int,
    observe,
    obs_state,
    *,
    dtype=jnp.float32,
    block: int = BLOCK_COARSE,
):
    """Integrate one realization per key of `keys` [chunk] for `num_steps` steps of dt, as vectors over the chunk.

    `observe(state, k, y, alive) -> (state, output)` is the per-realization observer of `simulate` (vmapped over
    the chunk here): it is called after step k (1-based, k ≤ `num_steps`) with y = (φ, φ̇) in `dtype`; `alive`
    is False after a capsize (the state is then frozen). `obs_state`: the observers' states with a leading
    [chunk] axis (floating leaves are cast to `dtype`, and every update is cast back to the state's dtypes).

    **Returns:** `(obs_state [chunk, …], outputs [num_steps, chunk, …] (time first), RealizationEnd [chunk])`.
    """
    if not supported(problem):
        raise NotImplementedError("simulate_batch handles a FilterExcitation without a moment excitation.")
    exc = problem.excitation
    m = exc.coarse
    h = float(exc.dt)
    n = exc.c.size
    nb = keys.shape[0]
    ship = problem.ship

    def f(x):
        return jnp.asarray(x).astype(dtype)

    phi_h, chol_h, wa, wb, c = f(exc.coarse_phi), f(exc.coarse_chol), f(exc.bridge[0]), f(exc.bridge[1]), f(exc.c)
    a = f(ship.restoring_coefficients)
    b1, b2, b3 = f(ship.damping[0]), f(ship.damping[1]), f(ship.damping[2])
    kappa = ship.gm_correction * ship.omega0**2 / ship.gm0
    pc = f(kappa * ship.delta_gm * jnp.asarray((-1.0) ** np.arange(ship.delta_gm.size)))  # P(ζ_G) = Σ_k pc_k ζ_Gᵏ
    cap = f(problem.capsize_angle)
    hf, h2, h6 = f(h), f(h / 2), f(h / 6)

    def p_of(zeta):
        out = pc[-1]
        for i in range(pc.size - 2, -1, -1):
            out = out * zeta + pc[i]
        return out

    def acc(phi, dphi, p):
        phi2 = phi * phi
        rest = a[0] + p + phi2 * (a[1] + phi2 * (a[2] + phi2 * (a[3] + phi2 * a[4])))
        return -dphi * (b1 + b2 * jnp.abs(dphi) + b3 * dphi * dphi) - phi * rest

    def rk4(phi, dphi, p0, pm, p1):
        k1p, k1v = dphi, acc(phi, dphi, p0)
        k2p, k2v = dphi + h2 * k1v, acc(phi + h2 * k1p, dphi + h2 * k1v, pm)
        k3p, k3v = dphi + h2 * k2v, acc(phi + h2 * k2p, dphi + h2 * k2v, pm)
        k4p, k4v = dphi + hf * k3v, acc(phi + hf * k3p, dphi + hf * k3v, p1)
        return phi + h6 * (k1p + 2 * k2p + 2 * k3p + k4p), dphi + h6 * (k1v + 2 * k2v + 2 * k3v + k4v)

    observe_all = jax.vmap(observe, in_axes=(0, None, 1, 0))
    ragged = num_steps % m != 0  # the last coarse step runs past num_steps: mask its extra fine steps

    def z_init(k):
        return exc.stationary_chol @ jr.normal(jr.fold_in(k, 0x7FFFFFFF), exc.c.shape)

    z0 = f(jax.vmap(z_init)(keys).T)  # [n, chunk]
    z0 = tuple(z0[i] for i in range(n))
    ones = jnp.ones(nb, dtype)
    phi0, dphi0 = f(problem.phi0) * ones, f(problem.dphi0) * ones
    obs_state = _to_dtype(obs_state, dtype)

    def coarse_step(carry, eps):
        z, p_start, phi, dphi, alive, k_cap, obs, k = carry
        z1 = tuple(
            sum(phi_h[i, j] * z[j] for j in range(n)) + sum(chol_h[i, j] * eps[j] for j in range(n))
            for i in range(n)
        )
        ps = [p_start]
        for j in range(2 * m - 1):
            ps.append(p_of(sum(wa[j, i] * z[i] + wb[j, i] * z1[i] for i in range(n))))
        ps.append(p_of(sum(c[i] * z1[i] for i in range(n))))
        ps = list(jax.lax.optimization_barrier(ps))
        outs = []
        for s in range(m):
            phi1, dphi1 = rk4(phi, dphi, ps[2 * s], ps[2 * s + 1], ps[2 * s + 2])
            ok = jnp.isfinite(phi1) & jnp.isfinite(dphi1) & (jnp.abs(phi1) < cap)
            inside = k < num_steps
            newly = alive & ~ok & inside if ragged else alive & ~ok
            k_cap = jnp.where(newly, k + 1, k_cap)
            alive = alive & ~newly
            phi, dphi = jnp.where(alive, phi1, phi), jnp.where(alive, dphi1, dphi)
            phi, dphi = jax.lax.optimization_barrier((phi, dphi))
            new_obs, out = observe_all(obs, k + 1, jnp.stack([phi, dphi]), alive)
            new_obs = _cast_like(new_obs, obs)
            if ragged:
                new_obs = jax.tree_util.tree_map(lambda x, y: jnp.where(inside, x, y), new_obs, obs)
            obs = new_obs
            outs.append(out)
            k = k + 1
        outs = jax.tree_util.tree_map(lambda *o: jnp.stack(o), *outs)
        return (z1, ps[-1], phi, dphi, alive, k_cap, obs, k), outs

    num_coarse = -(-num_steps // m)
    num_full, rest = divmod(num_coarse, block)

    def run_block(carry, index, length):
        eps = block_normals(keys, index, (block, n))[:length].astype(dtype)  # [length, n, chunk]
        return jax.lax.scan(coarse_step, carry, eps)

    zeta0 = sum(c[i] * z0[i] for i in range(n))
    carry = (z0, p_of(zeta0), phi0, dphi0, jnp.ones(nb, bool), jnp.full(nb, -1), obs_state, jnp.array(0))
    pieces = []
    if num_full:
        carry, outs = jax.lax.scan(partial(run_block, length=block), carry, jnp.arange(num_full))
        pieces.append(jax.tree_util.tree_map(lambda o: o.reshape(num_full * block * m, *o.shape[3:]), outs))
    if rest:
        carry, outs = run_block(carry, num_full, rest)
        pieces.append(jax.tree_util.tree_map(lambda o: o.reshape(rest * m, *o.shape[2:]), outs))
    outs = jax.tree_util.tree_map(lambda *o: jnp.concatenate(o)[:num_steps], *pieces)
    _, _, _, _, alive, k_cap, obs_state, _ = carry
    end = RealizationEnd(~alive, jnp.where(alive, jnp.inf, k_cap * h))
    return obs_state, outs, end


# ----------------------------------------------------------------------------------------------------------------
# Cheaper statistics (used by AmplitudeHistogram.reduce on both kernels' outputs)
# ----------------------------------------------------------------------------------------------------------------


def envelope_rfft(x):
    """|x + i·H[x]| along the last axis by rfft/irfft in x's dtype (the same as `hilbert_envelope`, which uses
    fft/ifft: half the FFT work, and float32 stays float32)."""
    nt = x.shape[-1]
    spec = jnp.fft.rfft(x, axis=-1)
    k = jnp.arange(spec.shape[-1])
    mask = (k > 0) & (k < (nt + 1) // 2)  # H = 0 at DC and Nyquist (as scipy's h)
    hx = jnp.fft.irfft(jnp.where(mask, -1j * spec, 0), n=nt, axis=-1)
    return jnp.sqrt(x * x + hx * hx)


def integer_counts(values, keep, width: float, num_bins: int):
    """Histogram (float64 of integer counts) of `values` where `keep`: bins [k·width, (k+1)·width), larger values
    in the last bin; integer scatter-adds with the dropped entries left out (2× float64 weights)."""
    idx = jnp.clip(jnp.floor(values / width).astype(jnp.int32), 0, num_bins - 1)
    idx = jnp.where(keep, idx, num_bins)  # out of range: dropped
    itype = jnp.int32 if values.size < 2**31 else jnp.int64
    counts = jnp.zeros(num_bins, itype).at[idx.reshape(-1)].add(jnp.ones((), itype), mode="drop")
    return counts.astype(jnp.float64)


def sum_last(x, group: int = 64):
    """Σ over the last axis as float64; a float32 `x` is summed in float32 within groups of `group` samples and
    in float64 across (relative error ~1e-7, no float64 copy of x)."""
    if x.dtype == jnp.float64:
        return jnp.sum(x, -1)
    t = x.shape[-1]
    x = jnp.pad(x, [(0, 0)] * (x.ndim - 1) + [(0, -t % group)])
    partial_sums = jnp.sum(x.reshape(*x.shape[:-1], -1, group), -1)
    return jnp.sum(partial_sums.astype(jnp.float64), -1)
