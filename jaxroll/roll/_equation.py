"""The roll equation for one realization, written once (vmapped by `jaxroll.monte_carlo_*`).

    φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1φ + a3φ³ + … + a9φ⁹ + P(t) φ = 0,   P = r (ω0²/GM0) ΔGM(−ζ_G(t)).

Time stepping: classical RK4 at step h. The excitation ζ_G is known exactly at the step ends (exact filter
discretisation or FFT superposition) together with dζ_G/dt, and at the RK4 midpoint by cubic Hermite
interpolation (error O(h⁴), far below the RK4 error for this smooth excitation). Noise for time block j of
realization i comes from `fold_in(fold_in(key, i), j)`, so a realization is the same whatever the chunking,
the device count or the number of steps simulated after it.
"""

from __future__ import annotations

import math
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from ..sea._filters import FilterFit, check_filter_fit, fit_filter
from ..sea._grim import EffectiveWave
from ..sea._spectra import AbstractWaveSpectrum
from ..ship._restoring import parametric_excitation, restoring_moment, vanishing_angle
from ..ship._ship import Ship
from ._excitation import BLOCK, AbstractExcitation, FilterExcitation, SuperpositionExcitation


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
# One realization
# ----------------------------------------------------------------------------------------------------------------


_spectrum = eqx.filter_jit(lambda wave, omega: wave.spectrum(omega))  # one compiled program, not op by op


def excitation_bandwidth(wave: EffectiveWave, fraction: float = 0.999) -> float:
    """Encounter frequency [rad/s] below which `fraction` of the effective-wave variance lies."""
    w = np.linspace(0.0, 6.0, 12001)
    s = np.asarray(_spectrum(wave, w))
    cum = np.concatenate([[0.0], np.cumsum((s[1:] + s[:-1]) / 2 * np.diff(w))])
    if not cum[-1] > 0:
        return 0.0  # beam seas: ζ_G ≡ 0, no excitation bandwidth
    return float(np.interp(fraction * cum[-1], cum, w))


def check_time_step(dt: float, ship: Ship, wave: EffectiveWave) -> None:
    """Validate the time step [s] against the roll period and the excitation bandwidth.

    Error when dt > Tφ/10 or ω_max·dt > 1 (RK4 loses accuracy and may go unstable); a warning when
    dt > Tφ/40 or ω_max·dt > 0.6 (halving dt may then change the mean amplitude by more than ~1 %). ω_max is the
    encounter frequency below which 99.9 % of the effective-wave variance lies.
    """
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"`dt` must be a finite number > 0 [s]; got {dt!r}.")
    t_roll = float(ship.roll_period)
    w_max = max(excitation_bandwidth(wave), 1e-12)  # > 0 for the messages (beam seas have none)
    if dt > t_roll / 10 or w_max * dt > 1.0:
        raise ValueError(
            f"dt = {dt} s is too large: it must be <= Tφ/10 = {t_roll / 10:.3g} s and <= 1/ω_max = "
            f"{1 / w_max:.3g} s (ω_max = {w_max:.3g} rad/s holds 99.9 % of the effective-wave variance). "
            f"Use dt <= {min(t_roll / 40, 0.6 / w_max):.3g} s for ~1 % accuracy."
        )
    if dt > t_roll / 40 or w_max * dt > 0.6:
        warnings.warn(
            f"dt = {dt} s may bias the amplitudes by more than ~1 %. This warning appears because dt > Tφ/40 = "
            f"{t_roll / 40:.3g} s or ω_max·dt > 0.6 (ω_max = {w_max:.3g} rad/s); use dt <= "
            f"{min(t_roll / 40, 0.6 / w_max):.3g} s.",
            stacklevel=3,
        )


class RollProblem(eqx.Module):
    """Everything one realization needs: ship, excitation source(s), initial condition — and, when built from a
    sea state, the effective wave and the filter fit the theories must share with the Monte Carlo.

    Build it from a sea state with `RollProblem.from_sea(ship, sea, ...)`, or from parts with the constructor.
    """

    ship: Ship
    excitation: AbstractExcitation
    phi0: Float[Array, ""]
    dphi0: Float[Array, ""]
    capsize_angle: Float[Array, ""]
    moment_excitation: AbstractExcitation | None
    wave: EffectiveWave | None
    filter_fit: FilterFit | None

    def __init__(
        self,
        ship: Ship,
        excitation: AbstractExcitation,
        phi0=math.radians(5.0),
        dphi0=0.0,
        *,
        moment_excitation: AbstractExcitation | None = None,
        wave: EffectiveWave | None = None,
        filter_fit: FilterFit | None = None,
    ):
        """**Arguments:**

        - `ship`: the roll model's parameters.
        - `excitation`: source of Grim's effective wave ζ_G [m] (`FilterExcitation`, `SuperpositionExcitation`,
          `SampledExcitation`).
        - `phi0`: initial roll [rad] (5°, the paper's); `dphi0`: initial roll rate [rad/s].
        - `moment_excitation`: optional source of an external roll moment per unit inertia M_w(t) [rad/s²]
          (zero in long-crested head or following seas; used for beam-sea studies and exact test cases).
        - `wave`, `filter_fit`: the effective wave and the shaping-filter fit behind `excitation`, when known
          (`from_sea` sets them), so the theories use exactly what the Monte Carlo simulates.
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
        self.wave = wave
        self.filter_fit = filter_fit

    @classmethod
    def from_sea(
        cls,
        ship: Ship,
        sea: AbstractWaveSpectrum,
        *,
        speed: float = 0.0,
        heading: str | float = "head",
        excitation: str = "filter",
        dt: float = 0.5,
        filter_order: int = 4,
        phi0: float = math.radians(5.0),
        dphi0: float = 0.0,
        validate: bool = True,
    ) -> "RollProblem":
        """The roll problem of `ship` in the sea state `sea`: Grim's effective wave, its excitation, initial roll.

        **Arguments:**

        - `ship`: the roll model; `sea`: one-sided sea spectrum (`ITTC`, `JONSWAP`).
        - `speed` [m/s]; `heading`: "head" | "following" | χ [rad] in [0, π] (0 following, π/2 beam, π head;
          long-crested). In beam seas the projected wave number is 0: ζ_G ≡ 0 and the roll only decays.
        - `excitation`: "filter" (Method 2, the paper's for Monte Carlo: a shaping filter fitted once to S_G
          with extra weight at 2ω0, kept in `filter_fit` for the moment method) or "superposition" (Method 1).
        - `dt`: time step [s] (checked against the roll period and the excitation bandwidth).
        - `filter_order`: order of the shaping filter (Method 2).
        - `phi0` [rad], `dphi0` [rad/s]: initial condition (the paper's 5°, 0).
        - `validate`: check the inputs and gate the filter fit (default). `False` skips those concrete checks so
          that the construction can be traced (e.g. differentiated in the ship or sea parameters); validate the
          nominal problem first.

        **Raises:** `ValueError` for a bad method, time step, filter fit or initial roll (beyond the vanishing
        angle).
        """
        if excitation not in ("filter", "superposition"):
            raise ValueError(f"`excitation` must be 'filter' or 'superposition'; got {excitation!r}.")
        wave = EffectiveWave(sea, ship.lpp, speed, heading)
        if validate:
            for name, value in (("phi0", phi0), ("dphi0", dphi0)):
                if not math.isfinite(value):
                    raise ValueError(f"`{name}` must be finite; got {value!r}.")
            check_time_step(dt, ship, wave)
            capsize = float(vanishing_angle(ship))
            if abs(phi0) >= capsize:
                raise ValueError(
                    f"the initial roll {math.degrees(phi0):.4g}° is beyond the angle of vanishing stability "
                    f"({math.degrees(capsize):.1f}°)."
                )
        if excitation == "filter":
            fit = fit_filter(wave, order=filter_order, match_frequency=2 * ship.omega0)
            if validate:
                check_filter_fit(fit, dt)
            source = FilterExcitation(fit.filter, dt)
        else:
            fit = None
            source = SuperpositionExcitation(wave, dt)
        return cls(ship, source, phi0, dphi0, wave=wave, filter_fit=fit)

    @property
    def dt(self) -> float:
        """Time step [s]."""
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

    def block(carry, index, length=BLOCK):
        src_states, inner = carry
        new_states, xs, dxs = [], [], []
        for src, st, k in zip(sources, src_states, keys, strict=False):
            st, x, dx = src.block(k, st, index)
            new_states.append(st)
            xs.append(x[:length])
            dxs.append(dx[:length])
        inner, outs = jax.lax.scan(step, inner, (jnp.stack(xs, -1), jnp.stack(dxs, -1)))
        return (tuple(new_states), inner), outs

    # Whole blocks, then the first `rest` steps of one more: no step past num_steps is simulated, observed or
    # checked for capsize (a trial of 7200 steps used to run 29 whole blocks, 7424 steps, and count capsizes up
    # to 3712 s of a 3600 s trial). The noise of the steps simulated is unchanged.
    num_full, rest = divmod(num_steps, BLOCK)
    carry = (src_states, (y0, x0, dx0, jnp.array(True), jnp.array(-1), obs_state, jnp.array(0)))
    pieces = []
    if num_full:
        carry, outs = jax.lax.scan(block, carry, jnp.arange(num_full))
        pieces.append(jax.tree_util.tree_map(lambda o: o.reshape(num_full * BLOCK, *o.shape[2:]), outs))
    if rest:
        carry, outs = block(carry, jnp.array(num_full), rest)
        pieces.append(outs)
    _, inner = carry
    _, _, _, alive, k_cap, obs_state, _ = inner
    outs = jax.tree_util.tree_map(lambda *o: jnp.concatenate(o), *pieces)
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
