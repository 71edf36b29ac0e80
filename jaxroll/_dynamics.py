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

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, Float, PRNGKeyArray

from ._filters import ShapingFilter
from ._grim import EffectiveWave, superpose, superposition_length
from ._restoring import parametric_excitation, restoring_moment, vanishing_angle
from ._ship import Ship

BLOCK = 256  # time steps per noise block


def roll_acceleration(ship: Ship, phi, dphi, p) -> Float[Array, "..."]:
    """φ̈ [rad/s²] of the paper's equation at roll φ [rad], rate φ̇ [rad/s], parametric term P [1/s²]."""
    b1, b2, b3 = ship.damping[0], ship.damping[1], ship.damping[2]
    damping = dphi * (b1 + b2 * jnp.abs(dphi) + b3 * dphi * dphi)
    return -damping - restoring_moment(ship, phi) - p * phi


def roll_vector_field(t, y, args):
    """Vector field f(t, y, args) of y = (φ, φ̇), args = (ship, P(t) callable) — for diffrax and checks."""
    ship, p_of_t = args
    return jnp.stack([y[1], roll_acceleration(ship, y[0], y[1], p_of_t(t))])


def rk4_step(ship: Ship, y, p0, pm, p1, h):
    """One RK4 step of (φ, φ̇) over h [s] with P at the start, middle and end of the step."""

    def f(y, p):
        return jnp.stack([y[1], roll_acceleration(ship, y[0], y[1], p)])

    k1 = f(y, p0)
    k2 = f(y + h / 2 * k1, pm)
    k3 = f(y + h / 2 * k2, pm)
    k4 = f(y + h * k3, p1)
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
        from ._filters import psd_sqrt

        self.dt = float(dt)
        self.phi, self.chol = shaping_filter.discretise(self.dt)
        self.stationary_chol = psd_sqrt(shaping_filter.stationary_covariance())
        self.c = shaping_filter.c
        self.c_a = shaping_filter.c @ shaping_filter.a

    def init(self, key, num_steps):
        z = self.stationary_chol @ jr.normal(jr.fold_in(key, 0x7FFFFFFF), self.c.shape)
        return z, self.c @ z, self.c_a @ z

    def block(self, key, state, index):
        eps = jr.normal(jr.fold_in(key, index), (BLOCK, self.c.size))

        def step(z, e):
            z = self.phi @ z + self.chol @ e
            return z, z

        z, zs = jax.lax.scan(step, state, eps)
        return z, zs @ self.c, zs @ self.c_a


class SuperpositionExcitation(AbstractExcitation):
    """Method 1: component superposition synthesised by FFT over the whole trial (see `jaxroll.superpose`)."""

    wave: EffectiveWave
    dt: float = eqx.field(static=True)

    def __init__(self, wave: EffectiveWave, dt: float):
        """**Arguments:** `wave`: Grim's effective wave; `dt`: time step [s]."""
        self.wave = wave
        self.dt = float(dt)

    def init(self, key, num_steps):
        num_blocks = -(-num_steps // BLOCK)
        n = num_blocks * BLOCK + 1
        if superposition_length(n) > 2**24:
            raise ValueError(
                f"superposition of {n} samples is too long for one FFT; use the filter method for long trials."
            )
        zeta, dzeta = superpose(self.wave, key, n, self.dt)
        return (zeta, dzeta), zeta[0], dzeta[0]

    def block(self, key, state, index):
        zeta, dzeta = state
        start = index * BLOCK + 1
        return (
            state,
            jax.lax.dynamic_slice_in_dim(zeta, start, BLOCK),
            jax.lax.dynamic_slice_in_dim(dzeta, start, BLOCK),
        )


# ----------------------------------------------------------------------------------------------------------------
# One realization
# ----------------------------------------------------------------------------------------------------------------


class RollProblem(eqx.Module):
    """Everything one realization needs: ship, excitation source and initial condition."""

    ship: Ship
    excitation: AbstractExcitation
    phi0: Float[Array, ""]
    dphi0: Float[Array, ""]
    capsize_angle: Float[Array, ""]

    def __init__(self, ship: Ship, excitation: AbstractExcitation, phi0=jnp.deg2rad(5.0), dphi0=0.0):
        """**Arguments:** `ship`; `excitation`: `FilterExcitation` or `SuperpositionExcitation`;
        `phi0`: initial roll [rad] (5°, the paper's); `dphi0`: initial roll rate [rad/s]."""
        self.ship = ship
        self.excitation = excitation
        self.phi0 = jnp.asarray(phi0, dtype=float)
        self.dphi0 = jnp.asarray(dphi0, dtype=float)
        self.capsize_angle = vanishing_angle(ship)

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
    ship, exc, h = problem.ship, problem.excitation, problem.dt
    num_blocks = -(-num_steps // BLOCK)
    exc_state, zeta0, dzeta0 = exc.init(key, num_steps)
    y0 = jnp.stack([problem.phi0, problem.dphi0])
    pe = lambda z: parametric_excitation(ship, z)

    def step(carry, inp):
        y, zeta, dzeta, alive, k_cap, obs, k = carry
        zeta1, dzeta1 = inp
        zm = (zeta + zeta1) / 2 + h * (dzeta - dzeta1) / 8
        y1 = rk4_step(ship, y, pe(zeta), pe(zm), pe(zeta1), h)
        ok = jnp.all(jnp.isfinite(y1)) & (jnp.abs(y1[0]) < problem.capsize_angle)
        newly = alive & ~ok
        k_cap = jnp.where(newly, k + 1, k_cap)
        alive = alive & ok
        y1 = jnp.where(alive, y1, y)
        obs, out = observe(obs, k + 1, y1, alive)
        return (y1, zeta1, dzeta1, alive, k_cap, obs, k + 1), out

    def block(carry, index):
        exc_state, inner = carry
        exc_state, zetas, dzetas = exc.block(key, exc_state, index)
        inner, outs = jax.lax.scan(step, inner, (zetas, dzetas))
        return (exc_state, inner), outs

    inner0 = (y0, zeta0, dzeta0, jnp.array(True), jnp.array(-1), obs_state, jnp.array(0))
    (_, inner), outs = jax.lax.scan(block, (exc_state, inner0), jnp.arange(num_blocks))
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
