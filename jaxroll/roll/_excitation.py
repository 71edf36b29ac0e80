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
import numpy as np
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
    """Method 2: exact discretisation of a shaping filter, started from its stationary law (no transient).

    Besides the step-dt discretisation (`phi`, `chol`, used by `jaxroll.simulate`), it carries the coarse grid
    of the batched Monte Carlo kernel (`jaxroll.roll._batched`, docs/numerics.md): the filter stepped exactly
    every H = `coarse`·dt (`coarse_phi`, `coarse_chol`) and the conditional-mean ("bridge") weights that give
    ζ_G at the 2·`coarse` − 1 RK4 stage times in between, E[ζ_G(τ) | z(0), z(H)] = a·z(0) + b·z(H).
    `coarse` is the largest of (4, 2, 1) whose bridge leaves out at most `COARSE_TOLERANCE`·σ_G² of the
    variance at every stage time (1 when the filter is traced, i.e. built inside `jit`).
    """

    phi: Float[Array, "n n"]
    chol: Float[Array, "n n"]
    stationary_chol: Float[Array, "n n"]
    c: Float[Array, " n"]
    c_a: Float[Array, " n"]
    coarse_phi: Float[Array, "n n"]
    coarse_chol: Float[Array, "n n"]
    bridge: Float[Array, "2 s n"]
    dt: float = eqx.field(static=True)
    coarse: int = eqx.field(static=True)

    def __init__(self, shaping_filter: ShapingFilter, dt: float, coarse: int | None = None):
        """**Arguments:** `shaping_filter` (e.g. `fit_filter(...).filter`); `dt`: time step [s]; `coarse`: the
        batched kernel's filter grid in steps (None: `choose_coarse`)."""
        self.dt = float(dt)
        self.phi, self.chol, sigma, self.stationary_chol, half = _discretisation(shaping_filter, self.dt)
        self.c = shaping_filter.c
        self.c_a = shaping_filter.c @ shaping_filter.a
        if coarse is None:
            coarse = choose_coarse(half, sigma, self.c)
        if not (isinstance(coarse, int) and coarse >= 1):
            raise ValueError(f"`coarse` must be an integer >= 1; got {coarse!r}.")
        self.coarse = coarse
        self.coarse_phi, self.coarse_chol, self.bridge = _coarse_grid(self.phi, sigma, half, self.c, coarse)

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


COARSE_TOLERANCE = 1e-6  # largest bridge interpolation error variance / σ_G² accepted for the coarse grid


def _half_powers(half, m: int):
    """[e^{A·j·dt/2} for j = 0 … 2m] from `half` = e^{A dt/2}."""
    powers = [jnp.eye(half.shape[0], dtype=half.dtype)]
    for _ in range(2 * m):
        powers.append(half @ powers[-1])
    return powers


@eqx.filter_jit
def _discretisation(shaping_filter: ShapingFilter, dt: float):
    """Φ, L (exact step dt), Σ, its square root and e^{A dt/2}, as one compiled program."""
    phi, chol = shaping_filter.discretise(dt)
    sigma = shaping_filter.stationary_covariance()
    half, _ = shaping_filter.discretise(dt / 2)
    return phi, chol, sigma, psd_sqrt(sigma), half


@eqx.filter_jit
def _coarse_grid(phi, sigma, half, c, coarse: int):
    """The batched kernel's coarse filter step (Φ^m, its noise factor) and bridge weights, compiled once per m."""
    coarse_phi = jnp.linalg.matrix_power(phi, coarse)
    return coarse_phi, psd_sqrt(sigma - coarse_phi @ sigma @ coarse_phi.T), jnp.stack(bridge_weights(half, sigma, c, coarse))


def bridge_weights(half, sigma, c, m: int):
    """(a, b), each [2m − 1, n]: E[ζ_G(τ_j) | z(0), z(H)] = a_j·z(0) + b_j·z(H) at τ_j = j·dt/2, j = 1 … 2m − 1,
    H = m·dt (the Gaussian bridge of the stationary filter: cᵀ[Φ_τ z(0) + Q_τ Φ_{H−τ}ᵀ Q_H⁻¹ (z(H) − Φ_H z(0))],
    Q_τ = Σ − Φ_τ Σ Φ_τᵀ). `half` = e^{A dt/2}, `sigma`: stationary covariance, `c`: output vector."""
    powers = _half_powers(half, m)
    q = [sigma - p @ sigma @ p.T for p in powers]
    phi_h, q_h = powers[2 * m], q[2 * m]
    a, b = [], []
    for j in range(1, 2 * m):
        gain = jnp.linalg.solve(q_h.T, (q[j] @ powers[2 * m - j].T).T).T  # Q_τ Φ_{H−τ}ᵀ Q_H⁻¹
        a.append(c @ (powers[j] - gain @ phi_h))
        b.append(c @ gain)
    return jnp.stack(a), jnp.stack(b)


def interpolation_error_variance(half, sigma, c, m: int, weights=None):
    """Relative error variance E[(ζ̂ − ζ_G)²]/σ_G² at τ_j = j·dt/2, j = 1 … 2m − 1, of the interpolant
    ζ̂ = a_j·z(0) + b_j·z(H) (default: the bridge weights), exact for the stationary filter."""
    powers = _half_powers(half, m)
    phi_h = powers[2 * m]
    k = jnp.block([[sigma, sigma @ phi_h.T], [phi_h @ sigma, sigma]])  # Cov([z(0); z(H)])
    a, b = bridge_weights(half, sigma, c, m) if weights is None else weights
    var = c @ sigma @ c
    out = []
    for j in range(1, 2 * m):
        g = jnp.concatenate([c @ powers[j] @ sigma, c @ (powers[2 * m - j] @ sigma).T])  # Cov(ζ(τ), [z0; z1])
        w = jnp.concatenate([a[j - 1], b[j - 1]])
        out.append((var - 2 * w @ g + w @ k @ w) / var)
    return jnp.stack(out)


_interpolation_error_variance = eqx.filter_jit(lambda half, sigma, c, m: interpolation_error_variance(half, sigma, c, m))


def choose_coarse(half, sigma, c, tol: float = COARSE_TOLERANCE, candidates=(4, 2, 1)) -> int:
    """The largest m of `candidates` whose bridge interpolation leaves out at most `tol`·σ_G² (host side; 1 when
    the filter is traced). m = 4 (H = 2 s at dt = 0.5 s) for the paper's protocol (3.7e-7)."""
    try:
        half, sigma, c = (np.asarray(x) for x in (half, sigma, c))
    except jax.errors.TracerArrayConversionError:
        return 1
    for m in candidates:
        err = np.asarray(_interpolation_error_variance(half, sigma, c, m))
        if np.all(np.isfinite(err)) and float(err.max()) <= tol:
            return m
    return 1


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


