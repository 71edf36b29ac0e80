"""The roll equation for one realization, written once (vmapped by `jaxroll.monte_carlo_*`).

    φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1φ + a3φ³ + … + a9φ⁹ + P(t) φ = 0,   P = r (ω0²/GM0) ΔGM(−ζ_G(t)).

Time stepping: classical RK4 at step h. The excitation ζ_G is known exactly at the step ends (exact filter
discretisation or FFT superposition) together with dζ_G/dt, and at the RK4 midpoint by cubic Hermite
interpolation (error O(h⁴), far below the RK4 error for this smooth excitation). Noise for time block j of
realization i comes from `fold_in(fold_in(key, i), j)`, so a realization is the same whatever the chunking,
the device count or the number of steps simulated after it.
"""

from __future__ import annotations

import abc
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, Float, PRNGKeyArray

from ..sea._filters import ShapingFilter
from ..sea._grim import EffectiveWave, superpose, superposition_length
from ..ship._restoring import parametric_excitation, restoring_moment, vanishing_angle
from ..ship._ship import Ship

BLOCK = 256  # time steps per noise block


def roll_acceleration(ship: Ship, phi, dphi, p, m=0.0) -> Float[Array, "..."]:
    """φ̈ [rad/s²] at roll φ [rad], rate φ̇ [rad/s], parametric term P [1/s²] and roll moment M_w [rad/s²]."""
    b1, b2, b3 = ship.damping[0], ship.damping[1], ship.damping[2]
    damping = dphi * (b1 + b2 * jnp.abs(dphi) + b3 * dphi * dphi)
    return m - damping - restoring_moment(ship, phi) - p * phi


def roll_vector_field(t, y, args):
    """Vector field f(t, y, args) of y = (φ, φ̇), args = (ship, P(t) callable) — for diffrax and checks."""
    ship, p_of_t = args
    return jnp.stack([y[1], roll_acceleration(ship, y[0], y[1], p_of_t(t))])


def rk4_step(ship: Ship, y, p, m, h):
    """One RK4 step of (φ, φ̇) over h [s]; `p`, `m` = (start, middle, end) values of P [1/s²] and M_w [rad/s²]."""

    def f(y, i):
        return jnp.stack([y[1], roll_acceleration(ship, y[0], y[1], p[i], m[i])])

    k1 = f(y, 0)
    k2 = f(y + h / 2 * k1, 1)
    k3 = f(y + h / 2 * k2, 1)
    k4 = f(y + h * k3, 2)
    return y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


# ----------------------------------------------------------------------------------------------------------------
# Excitation sources: ζ_G and dζ_G/dt at the step ends, one block of BLOCK steps at a time.
# ----------------------------------------------------------------------------------------------------------------


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
        from ..sea._filters import psd_sqrt

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


# ----------------------------------------------------------------------------------------------------------------
# One realization
# ----------------------------------------------------------------------------------------------------------------


class RollProblem(eqx.Module):
    """Everything one realization needs: ship, excitation source(s) and initial condition."""

    ship: Ship
    excitation: AbstractExcitation
    phi0: Float[Array, ""]
    dphi0: Float[Array, ""]
    capsize_angle: Float[Array, ""]
    moment_excitation: AbstractExcitation | None

    def __init__(
        self,
        ship: Ship,
        excitation: AbstractExcitation,
        phi0=math.radians(5.0),
        dphi0=0.0,
        *,
        moment_excitation: AbstractExcitation | None = None,
    ):
        """**Arguments:**

        - `ship`: the roll model's parameters.
        - `excitation`: source of Grim's effective wave ζ_G [m] (`FilterExcitation`, `SuperpositionExcitation`).
        - `phi0`: initial roll [rad] (5°, the paper's); `dphi0`: initial roll rate [rad/s].
        - `moment_excitation`: optional source of an external roll moment per unit inertia M_w(t) [rad/s²]
          (zero in long-crested head or following seas; used for beam-sea studies and exact test cases).
        """
        self.ship = ship
        self.excitation = excitation
        self.phi0 = jnp.asarray(phi0, dtype=float)
        self.dphi0 = jnp.asarray(dphi0, dtype=float)
        self.capsize_angle = vanishing_angle(ship)
        if moment_excitation is not None and moment_excitation.dt != excitation.dt:
            raise ValueError(
                f"`moment_excitation.dt` ({moment_excitation.dt}) must equal `excitation.dt` ({excitation.dt})."
            )
        self.moment_excitation = moment_excitation

    @property
    def dt(self) -> float:
        return self.excitation.dt


class RealizationEnd(eqx.Module):
    """Capsize outcome of one realization: whether |φ| passed the vanishing angle (or diverged), and when [s]."""

    capsized: Array
    capsize_time: Array


def simulate(problem: RollProblem, key: PRNGKeyArray, num_steps: int, observe, obs_state):
    """Integrate one realization for `num_steps` steps, feeding every new state to an observer.

    `observe(obs_state, k, y, alive) -> (obs_state, output)` is called after step k (1-based) with
    y = (φ, φ̇); its per-step outputs are stacked (length `num_steps`). After a capsize the state is frozen
    and `alive` is False, so observers can ignore it.

    **Returns:** `(obs_state, outputs, RealizationEnd)`.
    """
    ship, h = problem.ship, problem.dt
    sources = [problem.excitation]
    if problem.moment_excitation is not None:
        sources.append(problem.moment_excitation)
    keys = [key, jr.fold_in(key, 0x7FFFFFFE)]
    num_blocks = -(-num_steps // BLOCK)
    inits = [src.init(k, num_steps) for src, k in zip(sources, keys, strict=False)]
    src_states = tuple(i[0] for i in inits)
    x0 = jnp.stack([i[1] for i in inits])
    dx0 = jnp.stack([i[2] for i in inits])
    y0 = jnp.stack([problem.phi0, problem.dphi0])

    def forcing(x0, dx0, x1, dx1):
        xm = (x0 + x1) / 2 + h * (dx0 - dx1) / 8  # cubic Hermite midpoint
        p = parametric_excitation(ship, jnp.stack([x0[0], xm[0], x1[0]]))
        m = jnp.stack([x0[1], xm[1], x1[1]]) if len(sources) > 1 else jnp.zeros(3)
        return p, m

    def step(carry, inp):
        y, x, dx, alive, k_cap, obs, k = carry
        x1, dx1 = inp
        y1 = rk4_step(ship, y, *forcing(x, dx, x1, dx1), h)
        ok = jnp.all(jnp.isfinite(y1)) & (jnp.abs(y1[0]) < problem.capsize_angle)
        newly = alive & ~ok
        k_cap = jnp.where(newly, k + 1, k_cap)
        alive = alive & ok
        y1 = jnp.where(alive, y1, y)
        obs, out = observe(obs, k + 1, y1, alive)
        return (y1, x1, dx1, alive, k_cap, obs, k + 1), out

    def block(carry, index):
        src_states, inner = carry
        new_states, xs, dxs = [], [], []
        for src, st, k in zip(sources, src_states, keys, strict=False):
            st, x, dx = src.block(k, st, index)
            new_states.append(st)
            xs.append(x)
            dxs.append(dx)
        inner, outs = jax.lax.scan(step, inner, (jnp.stack(xs, -1), jnp.stack(dxs, -1)))
        return (tuple(new_states), inner), outs

    inner0 = (y0, x0, dx0, jnp.array(True), jnp.array(-1), obs_state, jnp.array(0))
    (_, inner), outs = jax.lax.scan(block, (src_states, inner0), jnp.arange(num_blocks))
    _, _, _, alive, k_cap, obs_state, _ = inner
    outs = jax.tree_util.tree_map(lambda o: o.reshape(num_blocks * BLOCK, *o.shape[2:])[:num_steps], outs)
    end = RealizationEnd(~alive, jnp.where(alive, jnp.inf, k_cap * h))
    return obs_state, outs, end


def roll_time_series(problem: RollProblem, key: PRNGKeyArray, duration: float):
    """φ(t) and φ̇(t) [rad, rad/s] of one realization on t = 0, dt, …, duration [s], and its `RealizationEnd`."""
    num_steps = int(round(duration / problem.dt))

    def observe(obs, k, y, alive):
        return obs, y

    _, ys, end = simulate(problem, key, num_steps, observe, None)
    ys = jnp.concatenate([jnp.stack([problem.phi0, problem.dphi0])[None], ys])
    return ys[:, 0], ys[:, 1], end
