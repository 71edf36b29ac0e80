"""Spectrum of the parametric excitation P(t) = r κ ΔGM(ζ_mid(t)), exact for Gaussian ζ_mid (Hermite expansion).

ζ_mid = −ζ_G is a zero-mean stationary Gaussian process with the one-sided effective-wave spectrum S_G(ω)
(encounter frequency) and variance σ². Write ΔGM(σx) = Σ_k C_k σᵏ xᵏ = Σ_n h_n He_n(x) (probabilists' Hermite
polynomials), with

    h_n = Σ_{j≥0} C_{n+2j} σ^{n+2j} (n+2j)! / (2ʲ j! n!)      [m].

Mehler's formula E[He_n(x) He_m(y)] = n! ρⁿ δ_nm for unit Gaussians of correlation ρ gives exactly

    E[P] = r κ h_0,    Cov[P(t), P(t+τ)] = (r κ)² Σ_{n≥1} n! h_n² ρ(τ)ⁿ,   ρ(τ) = R_ζ(τ)/σ²,

so S_P = (r κ)² Σ_n n! h_n² × (n-fold self-convolution of the normalised two-sided S_ζ/σ²). ζ_mid = −ζ_G flips the
sign of the odd h_n but not S_P (quadratic in h_n). The convolutions are done exactly for the discretised spectrum
by FFT: R_ζ on a uniform lag grid from S_G on a uniform frequency grid, powers of ρ pointwise, and back.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
from jaxtyping import Array, ArrayLike, Float, PRNGKeyArray

from .._compiled import filter_jit
from ..sea._grim import EffectiveWave, superpose
from ..ship._restoring import parametric_excitation
from ..ship._ship import Ship

_NUM_COEFFS = 7  # C0 … C6


def hermite_coefficients(coefficients: ArrayLike, sigma: ArrayLike) -> Float[Array, " n"]:
    r"""Hermite coefficients $h_n$ of $f(\sigma x) = \sum_k C_k (\sigma x)^k = \sum_n h_n He_n(x)$.

    **Arguments:** `coefficients`: polynomial coefficients $C_0, C_1, …$ (shape `(K,)`) in powers of a Gaussian
    variable of standard deviation `sigma` (same unit as that variable).

    **Returns:** $h_0 … h_{K-1}$; $h_0 = E[f]$, and $\mathrm{Var}[f] = \sum_{n\ge1} n!\,h_n^2$.
    """
    c = jnp.asarray(coefficients, dtype=float)
    sigma = jnp.asarray(sigma, dtype=float)
    k = c.shape[0]
    rows = []
    for n in range(k):
        terms = [
            c[n + 2 * j]
            * sigma ** (n + 2 * j)
            * (math.factorial(n + 2 * j) / (2**j * math.factorial(j) * math.factorial(n)))
            for j in range((k - 1 - n) // 2 + 1)
        ]
        rows.append(sum(terms))
    return jnp.stack(rows)


def hermite_covariance(hermite: ArrayLike, rho: ArrayLike) -> Float[Array, "..."]:
    """Cov[f(ζ(t)), f(ζ(t+τ))] = Σ_{n≥1} n! h_n² ρⁿ for Gaussian ζ of correlation ρ(τ) (units of f²)."""
    h = jnp.asarray(hermite, dtype=float)
    rho = jnp.asarray(rho, dtype=float)
    out = jnp.zeros_like(rho)
    for n in range(h.shape[0] - 1, 0, -1):  # Horner in ρ
        out = (out + math.factorial(n) * h[n] ** 2) * rho
    return out


class ParametricSpectrum(eqx.Module):
    """One-sided spectrum S_P⁺(ω) [1/s³ = (1/s²)² per rad/s] of the parametric term P(t) = r κ ΔGM(ζ_mid).

    Tabulated on the uniform grid `omega` [rad/s] (encounter frequency); `__call__` interpolates linearly and
    returns 0 beyond the grid. The constant mean E[P] (`mean`) is *not* part of the spectrum (no δ at ω = 0):
    ∫₀^∞ S_P⁺ dω = `variance` = Var[P].
    """

    omega: Float[Array, " n"]
    values: Float[Array, " n"]
    hermite: Float[Array, " 7"]
    sigma: Float[Array, ""]
    scale: Float[Array, ""]

    def __call__(self, omega: ArrayLike) -> Float[Array, "..."]:
        """S_P⁺(|ω|) [1/s³] (one-sided) at `omega` [rad/s]."""
        w = jnp.abs(jnp.asarray(omega, dtype=float))
        # linear interpolation on the uniform grid by direct indexing (cheaper to compile than a searchsorted)
        step = self.omega[1] - self.omega[0]
        n = self.omega.shape[0]
        x = w / step
        i = jnp.clip(jnp.floor(x).astype(int), 0, n - 2)
        t = x - i.astype(x.dtype)
        value = (1 - t) * self.values[i] + t * self.values[i + 1]
        return jnp.where(x <= n - 1, value, 0.0)

    def two_sided(self, omega: ArrayLike) -> Float[Array, "..."]:
        """Two-sided S_P(ω) = S_P⁺(|ω|)/2 [1/s³], the convention R(τ) = ∫_{−∞}^{∞} S e^{iωτ} dω."""
        return self(omega) / 2

    @property
    def mean(self) -> Float[Array, ""]:
        """E[P] = r κ h_0 [1/s²]: the mean stiffness shift (see the averaging methods' `mean_shift`)."""
        return self.scale * self.hermite[0]

    @property
    def variance(self) -> Float[Array, ""]:
        """Var[P] = (r κ)² Σ_{n≥1} n! h_n² [1/s⁴] (exact)."""
        return self.scale**2 * hermite_covariance(self.hermite, 1.0)

    def covariance_from_correlation(self, rho: ArrayLike) -> Float[Array, "..."]:
        """Cov[P(t), P(t+τ)] [1/s⁴] given the correlation ρ(τ) of ζ_mid (Mehler; exact)."""
        return self.scale**2 * hermite_covariance(self.hermite, rho)


def _grid(num: int, domega: float):
    if num < 64 or num % 2:
        raise ValueError(f"`num` must be an even integer >= 64; got {num!r}.")
    if not (domega > 0):
        raise ValueError(f"`domega` must be > 0 [rad/s]; got {domega!r}.")
    return jnp.arange(num // 2 + 1, dtype=float) * domega


@filter_jit
def parametric_spectrum(
    ship: Ship, wave: EffectiveWave, *, num: int = 2**15, domega: float = 2.5e-3
) -> ParametricSpectrum:
    r"""Exact one-sided spectrum of the parametric term $P(t) = r\kappa\,\Delta GM(\zeta_{mid}(t))$, $\kappa = \omega_0^2/GM_0$.

    **Arguments:**

    - `ship`: supplies ΔGM's C0…C6 [m^(1−k)], GM0 [m], ω0 [rad/s] and r = `gm_correction`.
    - `wave`: Grim's effective wave; its one-sided spectrum S_G(ω_e) [m² s/rad] is the spectrum of ζ_mid.
    - `num`: FFT length (even). `domega`: frequency step [rad/s]. The defaults (Nyquist 41 rad/s, lags up to
      2500 s) resolve S_G's ~0.1 rad/s width and hold the 6-fold convolution without aliasing; the convolution
      sums are spectrally accurate for smooth S_G (checked against direct quadrature in the tests).

    **Returns:** `ParametricSpectrum` on ω = 0, Δω, …, (num/2)Δω.

    Differentiable with respect to the ship's fields and the sea's parameters.
    """
    omega = _grid(num, domega)
    s_one = wave.spectrum(omega).at[0].set(0.0)  # S_G⁺ [m² s]; S_G(0) = 0 for waves
    # Two-sided spectrum on the full FFT grid: index j ↔ ω_j = jΔω for j ≤ num/2, negative frequencies mirrored.
    s_two = jnp.concatenate([s_one, s_one[-2:0:-1]]) / 2
    # R_ζ(τ_k) = Σ_j s2_j e^{iω_j τ_k} Δω, τ_k = 2πk/(num Δω): exact for the line spectrum at ω_j.
    r_zeta = jnp.real(jnp.fft.ifft(s_two)) * num * domega
    variance = r_zeta[0]
    sigma = jnp.sqrt(variance)
    rho = r_zeta / jnp.where(variance > 0, variance, 1.0)  # beam seas: ζ_G ≡ 0, no 0/0
    hermite = hermite_coefficients(ship.delta_gm, sigma)
    scale = ship.gm_correction * ship.omega0**2 / ship.gm0
    r_p = scale**2 * hermite_covariance(hermite, rho)
    # S_P(ω_j) = (1/2π) Σ_k R_P(τ_k) e^{−iω_j τ_k} Δτ, Δτ = 2π/(num Δω); one-sided = 2 × two-sided.
    s_p_two = jnp.real(jnp.fft.fft(r_p)) / (num * domega)
    values = 2 * s_p_two[: num // 2 + 1]
    return ParametricSpectrum(omega, jnp.maximum(values, 0.0), hermite, sigma, scale)


def welch_parametric_spectrum(
    ship: Ship,
    wave: EffectiveWave,
    key: PRNGKeyArray,
    *,
    num_realizations: int = 64,
    num_samples: int = 8192,
    dt: float = 0.5,
    segment: int = 1024,
) -> tuple[Float[Array, " m"], Float[Array, " m"], Float[Array, " m"]]:
    """Welch estimate of the one-sided S_P⁺(ω) [1/s³] from Method-1 realizations of ζ_G (`jaxroll.superpose`).

    Independent check of `parametric_spectrum`: each realization of ζ_G [m] is mapped through
    `jaxroll.parametric_excitation` (the Monte Carlo's own P(t), sign convention included), cut into Hann-windowed
    segments of `segment` samples with 50 % overlap, each segment's mean removed, and the periodograms averaged.

    **Returns:** `(omega [rad/s], s_p [1/s³], standard_error [1/s³])` on the segment's FFT frequencies; the
    standard error is the scatter of the per-realization averages over √num_realizations (realizations are
    independent). The bins at ω = 0 (segment means removed) and at the Nyquist frequency are not meaningful.
    """
    if segment < 16 or segment > num_samples:
        raise ValueError(f"`segment` must be in [16, num_samples = {num_samples}]; got {segment!r}.")
    step = segment // 2
    starts = jnp.arange(0, num_samples - segment + 1, step)
    window = 0.5 - 0.5 * jnp.cos(2 * jnp.pi * jnp.arange(segment, dtype=float) / segment)  # periodic Hann
    norm = dt / (jnp.pi * jnp.sum(window**2))  # one-sided, per rad/s: ∫₀^∞ S dω = variance

    def one(k):
        zeta, _ = superpose(wave, k, num_samples, dt)
        p = parametric_excitation(ship, zeta)
        segs = jax.vmap(lambda s: jax.lax.dynamic_slice_in_dim(p, s, segment))(starts)
        segs = (segs - segs.mean(axis=1, keepdims=True)) * window
        per = jnp.abs(jnp.fft.rfft(segs, axis=1)) ** 2 * norm
        return per.mean(axis=0)

    per = jax.lax.map(one, jr.split(key, num_realizations))
    omega = 2 * jnp.pi * jnp.fft.rfftfreq(segment, dt)
    est = per.mean(axis=0)
    se = per.std(axis=0, ddof=1) / jnp.sqrt(num_realizations)
    return omega, est, se
