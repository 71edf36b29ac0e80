"""Sources of Grim's effective wave ζ_G(t) for one realization: shaping filter, superposition, or a record.

Each source delivers ζ_G [m] and dζ_G/dt [m/s] at the step ends, one block of `BLOCK` steps at a time; noise
for block j of a realization keyed `key` comes from `fold_in(key, j)`, so a realization is the same whatever the
chunking, the device count or the number of steps simulated after it.
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, Float, PRNGKeyArray

from ..sea._filters import ShapingFilter, psd_sqrt
from ..sea._grim import EffectiveWave, superpose, superposition_length

BLOCK = 256  # time steps per noise block


class AbstractExcitation(eqx.Module):
    """Source of Grim's effective wave ζ_G [m] and dζ_G/dt [m/s] on the time grid t_k = k·dt."""

    dt: eqx.AbstractVar[float]

    @abc.abstractmethod
    def init(self, key: PRNGKeyArray, num_steps: int):
        """State before the first block, and (ζ_G, dζ_G/dt) at t = 0."""

    @abc.abstractmethod
    def block(self, key: PRNGKeyArray, state, index):
        """Advance one block: returns (state, ζ_G[BLOCK], dζ_G/dt[BLOCK]) at steps index·BLOCK + 1 … + BLOCK."""


class FilterExcitation(AbstractExcitation):
    """Method 2: exact discretisation of a shaping filter, started from its stationary law (no transient)."""

    phi: Float[Array, "n n"]
    chol: Float[Array, "n n"]
    stationary_chol: Float[Array, "n n"]
    c: Float[Array, " n"]
    c_a: Float[Array, " n"]
    dt: float = eqx.field(static=True)

    def __init__(self, shaping_filter: ShapingFilter, dt: float):
        """**Arguments:** `shaping_filter` (e.g. `fit_filter(...).filter`); `dt`: time step [s]."""
        self.dt = float(dt)
        self.phi, self.chol = shaping_filter.discretise(self.dt)
        self.stationary_chol = psd_sqrt(shaping_filter.stationary_covariance())
        self.c = shaping_filter.c
        self.c_a = shaping_filter.c @ shaping_filter.a

    def init(self, key, num_steps):
        z = self.stationary_chol @ jr.normal(jr.fold_in(key, 0x7FFFFFFF), self.c.shape)
        return z, self.c @ z, self.c_a @ z

    def block(self, key, state, index):
        # float32 normals (cast to float64) are ~25 % faster to draw; their ±5.4σ tail limit does not matter
        # after the filter sums many innovations (its output is Gaussian to that precision).
        eps = jr.normal(jr.fold_in(key, index), (BLOCK, self.c.size), jnp.float32).astype(float)

        def step(z, e):
            z = self.phi @ z + self.chol @ e
            return z, z

        z, zs = jax.lax.scan(step, state, eps)
        return z, zs @ self.c, zs @ self.c_a


def _slice_block(series, index):
    return jax.lax.dynamic_slice_in_dim(series, index * BLOCK + 1, BLOCK)


class SampledExcitation(AbstractExcitation):
    """A given record of ζ_G [m] and dζ_G/dt [m/s] on t_k = k·dt (e.g. a measured or precomputed wave).

    The record must cover the simulated time: at least `num_steps + 1` samples (padded with zeros to a whole
    number of blocks).
    """

    zeta: Float[Array, " n"]
    dzeta: Float[Array, " n"]
    dt: float = eqx.field(static=True)

    def __init__(self, zeta, dzeta, dt: float):
        """**Arguments:** `zeta` [m], `dzeta` [m/s]: 1-D records of equal length; `dt`: their sampling step [s]."""
        zeta, dzeta = jnp.asarray(zeta, dtype=float), jnp.asarray(dzeta, dtype=float)
        if zeta.ndim != 1 or zeta.shape != dzeta.shape:
            raise ValueError(f"`zeta` and `dzeta` must be 1-D of equal length; got {zeta.shape} and {dzeta.shape}.")
        self.zeta, self.dzeta, self.dt = zeta, dzeta, float(dt)

    def init(self, key, num_steps):
        if self.zeta.size < num_steps + 1:
            raise ValueError(
                f"the excitation record has {self.zeta.size} samples; {num_steps + 1} are needed "
                f"({num_steps} steps of {self.dt} s)."
            )
        pad = -(-num_steps // BLOCK) * BLOCK + 1 - self.zeta.size
        padded = [jnp.pad(x, (0, max(pad, 0))) for x in (self.zeta, self.dzeta)]
        return tuple(padded), self.zeta[0], self.dzeta[0]

    def block(self, key, state, index):
        return state, _slice_block(state[0], index), _slice_block(state[1], index)


class SuperpositionExcitation(AbstractExcitation):
    """Method 1: component superposition synthesised by FFT over the whole trial (see `jaxroll.superpose`)."""

    wave: EffectiveWave
    dt: float = eqx.field(static=True)

    def __init__(self, wave: EffectiveWave, dt: float):
        """**Arguments:** `wave`: Grim's effective wave; `dt`: time step [s]."""
        self.wave = wave
        self.dt = float(dt)

    def init(self, key, num_steps):
        n = -(-num_steps // BLOCK) * BLOCK + 1
        if superposition_length(n) > 2**24:
            raise ValueError(
                f"superposition of {n} samples is too long for one FFT; use the filter method for long trials."
            )
        zeta, dzeta = superpose(self.wave, key, n, self.dt)
        return (zeta, dzeta), zeta[0], dzeta[0]

    def block(self, key, state, index):
        return state, _slice_block(state[0], index), _slice_block(state[1], index)


