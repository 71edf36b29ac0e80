r"""Parametric rolling, Level 2 second check C2 (MSC.1/Circ.1627 2.5): roll in regular waves, jaxroll's equation.

For each speed V = K V_S (K = 1, 0.866, 0.5) in head and following seas and V = 0 (7 cases): for every sea state
(H_s, T_z) of the IACS Rec. 34 scatter table, the roll of a jaxroll `Ship` in a regular wave λ = L of height
h_eff = 4.0043 σ_eff (σ_eff of Grim's effective wave of that sea state), met at the encounter frequency, from
φ(0) = 5°; C = 1 where the maximum roll over the second half of 100 natural periods exceeds 25° (or the ship
capsizes). C2 = the mean over the 7 cases of Σ W C, W = the scatter table's probabilities. UNVERIFIED rules (see
docs/sgisc.md). All sea states of one case, and all cases, run as one vmapped RK4 scan (one compilation).

GZ in waves is jaxroll's model, GZ_calm(φ) + ΔGM(ζ_mid(t)) φ with the hull's ΔGM polynomial (the non-memory
ΔGM of Katsumura et al.), not GZ(φ) at each crest position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .._compiled import filter_jit
from ..roll._equation import rk4_step
from ..sea._grim import grim_transfer
from ..sea._spectra import GRAVITY, ITTC, log_quadrature
from ..ship._restoring import parametric_excitation, vanishing_angle
from ..ship._ship import Ship
from ._parametric_roll import R_PR2, REC34_HS, REC34_SCATTER, REC34_TZ, T01_OVER_TZ

ROLL_ANGLE_LIMIT_DEG = 25.0
"""C2: a sea state counts (C = 1) when the maximum roll angle exceeds 25°. UNVERIFIED (transcribed)."""

ROLL_ANGLE_LIMIT = math.radians(ROLL_ANGLE_LIMIT_DEG)
"""The same limit [rad]."""

SPEED_FACTORS = (1.0, 0.866, 0.5)
"""C2: speeds V_i = K_i V_S in head and following seas, plus zero speed (7 cases averaged). UNVERIFIED."""

SIGNIFICANT_HEIGHT_FACTOR = 4.0043
"""C2: effective wave height h_eff = 4.0043 σ_eff (the significant height of a Rayleigh-distributed narrow-band
process, 4.0043 √m0). UNVERIFIED as the guideline's wording; the number is the Rayleigh H1/3 factor."""

INITIAL_ROLL = math.radians(5.0)
"""φ(0) [rad] of every C2 simulation (our choice, documented in docs/sgisc.md)."""


def effective_wave_height(lpp: float, hs_m, tz_s) -> np.ndarray:
    """h_eff = 4.0043 σ_eff [m] of Grim's effective wave (λ = L) for ITTC seas (H_s [m], T01 = 1.086435 T_z [s])."""
    hs_m, tz_s = np.broadcast_arrays(np.asarray(hs_m, float), np.asarray(tz_s, float))
    w, dw = log_quadrature()
    transfer2 = grim_transfer(w**2 / GRAVITY, lpp) ** 2

    def one(h, tz):
        s = ITTC(h, T01_OVER_TZ * tz)(w)
        return SIGNIFICANT_HEIGHT_FACTOR * jnp.sqrt(jnp.sum(s * transfer2 * dw))

    out = jax.vmap(one)(jnp.asarray(hs_m.ravel()), jnp.asarray(tz_s.ravel()))
    return np.asarray(out).reshape(hs_m.shape)


@filter_jit
def _max_roll(ship: Ship, amplitude, omega_e, dt, phi0, n_steps: int, n_keep: int):
    """Max |φ| [rad] over the last n_keep steps of φ̈ + … + P(t) φ = 0 with ζ_mid(t) = amplitude cos(ω_e t), for
    arrays of amplitudes [m], encounter frequencies [rad/s] and steps dt [s] (π where the ship capsizes)."""
    phi_v = vanishing_angle(ship)

    def one(a, we, h):
        def p_at(t):
            return parametric_excitation(ship, -a * jnp.cos(we * t))

        def step(carry, i):
            y, big = carry
            t = i * h
            p = jnp.stack([p_at(t), p_at(t + h / 2), p_at(t + h)])
            y_new = rk4_step(ship, y, p, jnp.zeros(3), h)
            big = big | (jnp.abs(y_new[0]) > phi_v) | ~jnp.all(jnp.isfinite(y_new))
            y_new = jnp.where(big, y, y_new)  # frozen after capsize
            return (y_new, big), jnp.abs(y_new[0])

        init = (jnp.stack([phi0, jnp.zeros(())]), jnp.array(False))
        (_, big), amp = jax.lax.scan(step, init, jnp.arange(n_steps, dtype=float))
        return jnp.where(big, jnp.pi, jnp.max(amp[n_steps - n_keep :]))

    return jax.vmap(one)(amplitude, omega_e, dt)


def regular_wave_max_roll(
    ship: Ship,
    *,
    wave_heights,
    encounter_frequencies,
    duration_periods: float = 100.0,
    steps_per_period: int = 40,
    initial_roll: float = INITIAL_ROLL,
) -> np.ndarray:
    """Maximum roll [rad] of `ship` in regular waves λ = L met at the given encounter frequencies.

    **Arguments:** `ship`; `wave_heights` H [m] (crest to trough; ζ_mid = (H/2) cos ω_e t) and
    `encounter_frequencies` ω_e [rad/s], broadcast together; `duration_periods`: simulated time in natural
    roll periods (the maximum is taken over the second half); `steps_per_period`: RK4 steps per the shorter of
    the roll and encounter periods; `initial_roll` φ(0) [rad].

    **Returns:** max |φ| [rad] with the broadcast shape (π where the ship capsizes).
    """
    h, we = np.broadcast_arrays(np.asarray(wave_heights, float), np.asarray(encounter_frequencies, float))
    t_phi = float(ship.roll_period)
    period = np.minimum(t_phi, 2 * np.pi / np.maximum(we, 1e-9))
    dt = period / steps_per_period
    # one step count for all (one compilation): the shortest step covers `duration_periods`, longer ones more
    n = int(math.ceil(duration_periods * t_phi / float(np.min(dt))))
    amp = _max_roll(
        ship,
        jnp.asarray(h.ravel() / 2),
        jnp.asarray(we.ravel()),
        jnp.asarray(dt.ravel()),
        jnp.asarray(float(initial_roll)),
        n,
        n // 2,
    )
    return np.asarray(amp).reshape(h.shape)


@dataclass
class C2Result:
    """Level-2 second check: C2 [-] against its standard; per speed/heading case and per sea state."""

    c2: float
    standard: float
    vulnerable: bool
    per_case: list  # dict(heading, speed_factor, speed_m_s, froude, encounter_frequency_rad_s, c)
    max_roll: np.ndarray  # [rad], (cases, H_s, T_z); 0 where the scatter table is empty
    effective_wave_height: np.ndarray  # h_eff [m], (H_s, T_z)


def c2_cases(service_speed: float) -> list[tuple[str, float]]:
    """The 7 (heading, speed factor K) cases of C2: zero speed, then head and following seas at K V_S."""
    return [("head", 0.0)] + [(hd, k) for hd in ("head", "following") for k in SPEED_FACTORS]


def encounter_frequency_regular(lpp: float, speed: float, heading: str) -> float:
    """ω_e [rad/s] of a regular wave λ = L met at `speed` [m/s] in head or following seas: |ω ± ω² V/g|."""
    omega = math.sqrt(2 * math.pi * GRAVITY / lpp)
    k = omega**2 / GRAVITY
    return abs(omega + k * speed) if heading == "head" else abs(omega - k * speed)


def level2_c2(
    ship: Ship,
    *,
    service_speed: float,
    duration_periods: float = 100.0,
    steps_per_period: int = 40,
    initial_roll: float = INITIAL_ROLL,
) -> C2Result:
    """Level-2 second check C2 (Circ.1627 2.5, Level 2, second check), roll by time-domain simulation.

    **Arguments:** `ship`: a jaxroll `Ship` of the loading condition (GZ polynomial, ΔGM(ζ_mid) polynomial fitted
    over the wave heights used, damping b1, b2 — e.g. from [`jaxroll.ship.ikeda_damping`][]); `service_speed`
    V_S [m/s]; the simulation settings of [`regular_wave_max_roll`][].

    **Returns:** a [`C2Result`][]; `vulnerable` is True when C2 > R_PR2.
    """
    if not (math.isfinite(service_speed) and service_speed >= 0):
        raise ValueError(f"`service_speed` must be a finite speed >= 0 [m/s]; got {service_speed}.")
    L = float(ship.lpp)
    weights = REC34_SCATTER / REC34_SCATTER.sum()
    hh, tt = np.meshgrid(REC34_HS, REC34_TZ, indexing="ij")
    mask = weights > 0
    heff = effective_wave_height(L, hh[mask], tt[mask])
    cases = c2_cases(service_speed)
    we = np.array([encounter_frequency_regular(L, k * service_speed, hd) for hd, k in cases])
    amp = regular_wave_max_roll(
        ship,
        wave_heights=heff[None, :],
        encounter_frequencies=we[:, None],
        duration_periods=duration_periods,
        steps_per_period=steps_per_period,
        initial_roll=initial_roll,
    )
    out, rolls = [], []
    for i, (heading, k) in enumerate(cases):
        c = (amp[i] > ROLL_ANGLE_LIMIT).astype(float)
        full = np.zeros_like(weights)
        full[mask] = amp[i]
        rolls.append(full)
        v = k * service_speed
        out.append(
            dict(
                heading=heading,
                speed_factor=k,
                speed_m_s=v,
                froude=v / math.sqrt(GRAVITY * L),
                encounter_frequency_rad_s=float(we[i]),
                c=float(np.sum(weights[mask] * c)),
            )
        )
    c2 = float(np.mean([o["c"] for o in out]))
    heff_full = np.zeros_like(weights)
    heff_full[mask] = heff
    return C2Result(c2, R_PR2, c2 > R_PR2, out, np.asarray(rolls), heff_full)


def roll_versus_speed(
    ship: Ship,
    *,
    wave_height: float,
    speeds,
    duration_periods: float = 100.0,
    steps_per_period: int = 40,
) -> dict[str, np.ndarray]:
    """Maximum roll [rad] in a regular wave λ = L of height `wave_height` [m] against speed [m/s], head and
    following seas: `{"speed_m_s", "head", "following"}` (for the roll-amplitude-versus-speed figure)."""
    v = np.asarray(speeds, float)
    L = float(ship.lpp)
    we = np.array([[encounter_frequency_regular(L, s, hd) for s in v] for hd in ("head", "following")])
    amp = regular_wave_max_roll(
        ship,
        wave_heights=np.full(we.shape, float(wave_height)),
        encounter_frequencies=we,
        duration_periods=duration_periods,
        steps_per_period=steps_per_period,
    )
    return {"speed_m_s": v, "head": amp[0], "following": amp[1]}
