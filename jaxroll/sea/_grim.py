"""Grim's effective wave: transfer function, effective-wave spectrum, and Method 1 (component superposition).

ζ_G(t) is the least-squares fit of the wave profile over the hull x ∈ [−L/2, L/2] by a wave of length L with its
crest amidships; its amplitude transfer function for a component of wave number k is

    F(k) = (kL) sin(kL/2) / (π² − (kL/2)²),   F(2π/L) = 1.

In an oblique long-crested sea of heading χ the profile along the ship's axis is a wave of number k|cos χ|, so the
transfer is F(k|cos χ|): beam seas (cos χ = 0) give ζ_G ≡ 0, no parametric excitation in this model (the direct
roll moment of oblique waves is `jaxroll.WaveMomentExcitation`).

In a short-crested sea (`spreading`, `jaxroll.sea.Spreading`) every wave direction θ_q of the spreading's
discretisation meets the ship at its own relative heading χ + θ_q: its own encounter frequency, its own Grim
transfer F(k|cos(χ + θ_q)|); S_G is the weighted sum of the Q long-crested S_G's (docs/spreading.md).

The roll model uses ζ_mid = −ζ_G (positive when a trough is amidships); see `jaxroll.delta_gm`.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from .._compiled import array_module, as_float, cached_program, is_concrete, require
from ._spectra import (
    GRAVITY,
    AbstractWaveSpectrum,
    encounter_branches,
    heading_angle,
    heading_cosine,
    spectral_moment,
    warn_if_breaking,
)
from ._spreading import Spreading


def grim_transfer(k, length):
    """Grim's amplitude transfer F(k) [-] of a wave of number k [rad/m] for a hull of length L [m] (λ/L = 1)."""
    k = jnp.asarray(k, dtype=float)
    x = k * length / 2
    # 2x sin x / (π² − x²) = 2x/(π + x) · sin(π − x)/(π − x): no 0/0 at λ = L.
    return 2 * x / (jnp.pi + x) * jnp.sinc((jnp.pi - x) / jnp.pi)


class EffectiveWave(eqx.Module):
    """Grim's effective wave of a long-crested sea for a ship of length L at speed U and heading χ."""

    sea: AbstractWaveSpectrum
    length: Float[Array, ""]
    speed: Float[Array, ""]
    heading: Float[Array, ""]  # χ [rad]
    cos_heading: Float[Array, ""]  # cos χ, exactly −1, 0, 1 for head, beam, following seas
    following: bool = eqx.field(static=True)  # cos χ > 0: the encounter transform has up to three branches
    # |cos χ| < 1: oblique or beam. Head and following seas skip the projection, so that they compile to exactly
    # the computation they had before headings were angles (a shaping-filter fit is bitwise the same).
    projected: bool = eqx.field(static=True)
    spreading: Spreading | None = None  # None: long-crested (the paper's sea)
    # cos(χ + θ_q) of the spreading's directions θ_q and their weights (host floats; None when long-crested)
    direction_cosines: tuple[float, ...] | None = eqx.field(static=True, default=None)
    direction_weights: tuple[float, ...] | None = eqx.field(static=True, default=None)

    def __init__(
        self,
        sea: AbstractWaveSpectrum,
        length,
        speed=0.0,
        heading: str | float = "head",
        *,
        spreading: Spreading | None = None,
        validate: bool = True,
    ):
        """**Arguments:** `sea`: one-sided sea spectrum; `length`: L = Lpp [m]; `speed`: U [m/s] ≥ 0;
        `heading`: `"head"`, `"following"` or the angle χ [rad] in [0, π] between the ship's course and the
        (mean) wave direction (0 following, π/2 beam, π head); `spreading`: a `Spreading` for a short-crested
        sea about that mean direction, or None (long-crested, the default). `validate=False` skips the checks of
        `length` and `speed` (for a traced construction whose nominal values were checked: a traced check is a
        host callback, which keeps the compiled program out of JAX's disk cache)."""
        chi, cos_chi = heading_angle(heading), heading_cosine(heading)  # validates
        if spreading is not None and not isinstance(spreading, Spreading):
            raise TypeError(f"`spreading` must be a jaxroll.sea.Spreading or None; got {spreading!r}.")
        self.spreading = spreading
        if spreading is None:
            self.direction_cosines = self.direction_weights = None
        else:
            self.direction_cosines, self.direction_weights = direction_cosines(chi, spreading)
        self.sea = sea
        length, speed = as_float(length), as_float(speed)
        if validate:
            length = require(
                length, ~(array_module(length).asarray(length) > 0), "ship length must be > 0 [m]."
            )
            speed = require(speed, ~(array_module(speed).asarray(speed) >= 0),
                            "`speed` must be >= 0 [m/s]; use `heading` for direction.")  # fmt: skip
        if validate and is_concrete(sea):
            warn_if_breaking(sea, stacklevel=2)
        self.length, self.speed = length, speed
        self.heading = as_float(chi)
        self.cos_heading = as_float(cos_chi)
        self.following = cos_chi > 0
        self.projected = abs(cos_chi) != 1.0

    @property
    def is_beam_sea(self) -> bool:
        """True when cos χ = 0 in a long-crested sea: the projected wave number, hence ζ_G and the parametric
        excitation, vanish (a short-crested beam sea has waves of other directions: False)."""
        return float(self.cos_heading) == 0.0 and self.spreading is None

    def spectrum(self, omega_e) -> Float[Array, "..."]:
        """One-sided effective-wave spectrum S_G(ω_e) = Σ F(k|cos χ|)² S(ω)/|dω_e/dω| [m² s/rad] in encounter
        frequency (k = ω²/g; zero in long-crested beam seas). Short-crested: the weighted sum over the spreading's
        directions θ_q of the same sum at χ + θ_q (`spread_spectrum`)."""
        if self.spreading is not None:
            return spread_spectrum(self, omega_e)
        if self.projected:
            projection = jnp.abs(self.cos_heading)
            omegas, weights = encounter_branches(omega_e, self.speed * projection, self.following)
            f = grim_transfer(omegas**2 / GRAVITY * projection, self.length)
        else:
            omegas, weights = encounter_branches(omega_e, self.speed, self.following)
            f = grim_transfer(omegas**2 / GRAVITY, self.length)
        return jnp.sum(f**2 * self.sea(omegas) * weights, axis=-1)

    def variance(self) -> Float[Array, ""]:
        """σ_G² = ∫ S_G dω_e [m²]."""
        return spectral_moment(self.spectrum, 0)


def direction_cosines(heading: float, spreading: Spreading) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """cos(χ + θ_q) [-] of the spreading's directions θ_q about the mean heading χ [rad] (below 1e-12 in magnitude
    taken as 0, as `heading_cosine` does) and their weights w_q (`Spreading.directions`); host floats."""
    theta, weights = spreading.directions()
    c = np.cos(heading + theta)
    return tuple(float(x) if abs(x) >= 1e-12 else 0.0 for x in c), tuple(float(w) for w in weights)


def spread_spectrum(wave: EffectiveWave, omega_e) -> Float[Array, "..."]:
    """S_G(ω_e) [m² s/rad] of a short-crested sea: Σ_q w_q Σ_b F(k_b|cos χ_q|)² S(ω_b)/|dω_e/dω|_q, each
    direction χ_q = χ + θ_q with its own encounter branches (head-going, cos χ_q ≤ 0: one; following-going: up to
    three) and its own projected wave number."""
    omega_e = jnp.asarray(omega_e, dtype=float)
    cos, w = np.asarray(wave.direction_cosines), np.asarray(wave.direction_weights)
    total = jnp.zeros(omega_e.shape)
    for following in (False, True):
        group = (cos > 0) == following
        if not np.any(group):
            continue
        c = np.abs(cos[group])
        grid = jnp.broadcast_to(omega_e[..., None], (*omega_e.shape, c.size))
        omegas, jacobians = encounter_branches(grid, wave.speed * c, following)  # [..., directions, 3]
        f = grim_transfer(omegas**2 / GRAVITY * c[:, None], wave.length)
        per_direction = jnp.sum(f**2 * wave.sea(omegas) * jacobians, axis=-1)
        total = total + per_direction @ w[group]
    return total


#: The encounter frequencies [rad/s] on which `spectrum_on_grid` tabulates S_G (0-6 rad/s, step 5e-4 rad/s).
SPECTRUM_GRID = np.linspace(0.0, 6.0, 12001)


@cached_program
def spectrum_on_grid(wave: EffectiveWave):
    """S_G [m² s/rad] on `SPECTRUM_GRID`, one stored program: what the set-up checks (the time step's bandwidth,
    the model's validity) read on the host."""
    return wave.spectrum(jnp.linspace(0.0, 6.0, 12001))


def effective_wave_std(wave: EffectiveWave) -> float:
    """σ_G [m], the standard deviation of Grim's effective wave (trapezoid rule on `SPECTRUM_GRID`, host
    arithmetic on `spectrum_on_grid`)."""
    s = np.asarray(spectrum_on_grid(wave))
    return float(np.sqrt(np.sum((s[1:] + s[:-1]) / 2 * np.diff(SPECTRUM_GRID))))


def _fft_length(n: int) -> int:
    """Smallest 2^a 3^b 5^c ≥ n (fast FFT sizes)."""
    best = 1 << (n - 1).bit_length()
    p5 = 1
    while p5 < 2 * n:
        p35 = p5
        while p35 < 2 * n:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


def superposition_length(num_samples: int) -> int:
    """FFT length M ≥ num_samples: the synthesised process has period M·dt, longer than the trial."""
    return _fft_length(int(num_samples))


def superpose(
    wave: EffectiveWave, key: PRNGKeyArray, num_samples: int, dt: float
) -> tuple[Float[Array, " num_samples"], Float[Array, " num_samples"]]:
    """Method 1: one realization of ζ_G and dζ_G/dt on t = 0, dt, …, by component superposition (FFT).

    Components sit at ω_j = 2πj/(M dt) with M ≥ `num_samples` (so the record never repeats within the trial)
    and complex Gaussian amplitudes of variance S_G(ω_j)Δω: the realization is exactly Gaussian with the
    discretised spectrum. Two standard normals per component.

    **Returns:** `(zeta_g [m], dzeta_g [m/s])`, each of length `num_samples`.
    """
    m = superposition_length(num_samples)
    domega = 2 * jnp.pi / (m * dt)
    j = jnp.arange(m // 2 + 1, dtype=float)
    omega = j * domega
    s = wave.spectrum(omega)
    s = s.at[0].set(0.0).at[-1].set(0.0)
    xy = jr.normal(key, (2, m // 2 + 1))
    coef = (jnp.sqrt(s * domega) * (m / 2)).astype(complex) * jax.lax.complex(xy[0], xy[1])
    zeta = jnp.fft.irfft(coef, n=m)[:num_samples]
    dzeta = jnp.fft.irfft(1j * omega.astype(complex) * coef, n=m)[:num_samples]
    return zeta, dzeta
