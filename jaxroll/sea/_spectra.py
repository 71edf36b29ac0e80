"""Sea spectra (one-sided, in angular frequency), spectral moments and the encounter-frequency transform.

Conventions (docs/conventions.md): S(ω) [m² s/rad] is one-sided, ∫₀^∞ S dω = m0 = H1/3²/16; ω is the absolute
wave frequency [rad/s]; deep water, k = ω²/g. Heading χ [rad]: 0 following seas, π/2 beam, π head seas.
"""

from __future__ import annotations

import abc
import math

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._compiled import array_module, as_float, require
from .._display import module_repr

GRAVITY = 9.80665  # [m/s²]

# B T01⁴ for the ITTC (H1/3, T01) spectrum: (2π/Γ(3/4))⁴ = 691.17…, so that 2π m0/m1 = T01 exactly.
_ITTC_B_T01_4 = (2 * math.pi / math.gamma(0.75)) ** 4


class AbstractWaveSpectrum(eqx.Module):
    """A one-sided sea spectrum S(ω) [m² s/rad] of the absolute wave frequency ω [rad/s]."""

    def __repr__(self) -> str:
        return module_repr(self)  # `ITTC(hs=5.0, t01=10.0)`: the numbers, not `f64[]`

    @abc.abstractmethod
    def __call__(self, omega: ArrayLike) -> Float[Array, "..."]:
        """S(ω) [m² s/rad] at `omega` [rad/s] (zero at ω ≤ 0)."""

    @property
    @abc.abstractmethod
    def significant_height(self) -> Float[Array, ""]:
        """Nominal significant wave height H1/3 [m]."""

    @property
    @abc.abstractmethod
    def peak_frequency(self) -> Float[Array, ""]:
        """Frequency ω_p [rad/s] of the spectrum's peak."""


def _check_positive(name: str, value, unit: str):
    value = as_float(value)
    if value.shape != ():
        raise ValueError(f"`{name}` must be a scalar; got shape {value.shape}.")
    xp = array_module(value)
    bad = ~(xp.asarray(value) > 0) | ~xp.isfinite(value)
    return require(value, bad, f"`{name}` must be a finite number > 0 [{unit}].")


class ITTC(AbstractWaveSpectrum):
    r"""ITTC two-parameter spectrum in (H1/3, T01): $S(\omega) = A\omega^{-5}e^{-B\omega^{-4}}$ [m² s/rad].

    $B = (2\pi/\Gamma(3/4))^4/T_{01}^4$ and $A = B H^2/4$, the exact constants for which $m_0 = H^2/16$ and
    $2\pi m_0/m_1 = T_{01}$ (the rounded 173/691 of the literature are off by ~1e-3).
    """

    hs: Float[Array, ""]
    t01: Float[Array, ""]

    def __init__(self, hs, t01):
        """**Arguments:** `hs`: significant wave height H1/3 [m] (> 0); `t01`: mean period 2π m0/m1 [s] (> 0)."""
        self.hs = _check_positive("hs", hs, "m")
        self.t01 = _check_positive("t01", t01, "s")

    def __call__(self, omega):
        omega = jnp.asarray(omega, dtype=float)
        b = _ITTC_B_T01_4 / self.t01**4
        a = b * self.hs**2 / 4
        safe = jnp.where(omega > 0, omega, 1.0)
        return jnp.where(omega > 0, a * safe**-5 * jnp.exp(-b * safe**-4), 0.0)

    @property
    def significant_height(self):
        return self.hs

    @property
    def peak_frequency(self) -> Float[Array, ""]:
        """ω_p = (4B/5)^(1/4) [rad/s]."""
        return (0.8 * _ITTC_B_T01_4) ** 0.25 / array_module(self.t01).asarray(self.t01)


class JONSWAP(AbstractWaveSpectrum):
    r"""JONSWAP spectrum in (Hs, Tp, γ) [m² s/rad], scaled so that $m_0 = H_s^2/16$ exactly.

    $S = \alpha\,\omega^{-5}e^{-1.25(\omega_p/\omega)^4}\gamma^{r}$, $r = e^{-(\omega-\omega_p)^2/(2s^2\omega_p^2)}$,
    s = 0.07 (ω ≤ ω_p) or 0.09; α is fixed by the exact variance (computed by quadrature at construction).
    """

    hs: Float[Array, ""]
    tp: Float[Array, ""]
    gamma: Float[Array, ""]
    _alpha: Float[Array, ""]

    def __init__(self, hs, tp, gamma=3.3):
        """**Arguments:** `hs` [m] > 0; `tp`: peak period [s] > 0; `gamma`: peak enhancement [-] ≥ 1 (3.3)."""
        self.hs = _check_positive("hs", hs, "m")
        self.tp = _check_positive("tp", tp, "s")
        gamma = jnp.asarray(gamma, dtype=float)
        self.gamma = require(gamma, ~(gamma >= 1), "`gamma` must be >= 1 (3.3 is the usual value).")
        # Normalise on a dimensionless grid x = ω/ω_p, so that ∫S dω = Hs²/16.
        x, weight = log_quadrature()
        integral = jnp.sum(weight * self._shape(x))
        wp = 2 * jnp.pi / self.tp
        self._alpha = self.hs**2 / 16 / (integral * wp**-3)

    def _shape(self, x):
        """Dimensionless shape in x = ω/ω_p (without α and ω_p⁻⁴)."""
        safe = jnp.where(x > 0, x, 1.0)
        s = jnp.where(safe <= 1.0, 0.07, 0.09)
        r = jnp.exp(-((safe - 1.0) ** 2) / (2 * s**2))
        return jnp.where(x > 0, safe**-5 * jnp.exp(-1.25 * safe**-4) * self.gamma**r, 0.0)

    def __call__(self, omega):
        wp = 2 * jnp.pi / self.tp
        return self._alpha * wp**-4 * self._shape(jnp.asarray(omega, dtype=float) / wp)

    @property
    def significant_height(self):
        return self.hs

    @property
    def peak_frequency(self) -> Float[Array, ""]:
        """ω_p = 2π/T_p [rad/s]."""
        return 2 * math.pi / array_module(self.tp).asarray(self.tp)


# Breaking: a sea state cannot be steeper than its waves can be. DNV-RP-C205 (2010), §3.5.5.4: the significant
# steepness S_p = 2π H_s/(g T_p²) (= H_s/λ_p, λ_p the deep-water length of a wave of the peak period) is limited to
# 1/15 for T_p <= 8 s and 1/25 for T_p >= 15 s, linearly interpolated between; a regular wave breaks at H/λ ≈ 0.142
# ≈ 1/7 (Michell 1893), and an irregular sea's significant steepness stays well below it because its highest
# waves break first.
BREAKING_STEEPNESS = ((8.0, 1 / 15), (15.0, 1 / 25))


def breaking_steepness(peak_period: float) -> float:
    """The limiting significant steepness S_p [-] of a sea state of peak period T_p [s] (DNV-RP-C205 §3.5.5.4:
    1/15 for T_p <= 8 s, 1/25 for T_p >= 15 s, linear in between)."""
    (t0, s0), (t1, s1) = BREAKING_STEEPNESS
    return float(s0 + (s1 - s0) * min(max((peak_period - t0) / (t1 - t0), 0.0), 1.0))


def sea_steepness(sea: AbstractWaveSpectrum) -> dict[str, float]:
    """The sea state's significant steepness against the breaking limit (concrete values, host arithmetic):
    `hs_m`, `peak_period_s`, `steepness` S_p = 2π H_s/(g T_p²), `limit` (`breaking_steepness`), `max_hs_m` (the
    highest H_s at this T_p)."""
    import numpy as np

    hs = float(np.asarray(sea.significant_height))
    tp = 2 * math.pi / float(np.asarray(sea.peak_frequency))
    steepness = 2 * math.pi * hs / (GRAVITY * tp**2)
    limit = breaking_steepness(tp)
    return {
        "hs_m": hs,
        "peak_period_s": tp,
        "steepness": steepness,
        "limit": limit,
        "max_hs_m": limit * GRAVITY * tp**2 / (2 * math.pi),
    }


def warn_if_breaking(sea: AbstractWaveSpectrum, stacklevel: int = 2) -> None:
    """A `UserWarning` when the sea state is steeper than waves can be (`sea_steepness`)."""
    import warnings

    s = sea_steepness(sea)
    if s["steepness"] > s["limit"]:
        warnings.warn(
            f"H1/3 = {s['hs_m']:g} m with peak period T_p = {s['peak_period_s']:.3g} s has significant steepness "
            f"S_p = 2π H1/3/(g T_p²) = {s['steepness']:.3g} (1/{1 / s['steepness']:.3g}), beyond the breaking limit "
            f"1/{1 / s['limit']:.3g} at this period (DNV-RP-C205 §3.5.5.4: 1/15 for T_p <= 8 s, 1/25 for T_p >= 15 s; "
            f"a regular wave breaks at H/λ ≈ 1/7): no sea is this steep, its waves break first. This warning appears "
            f"because the linear (Gaussian) sea, Grim's effective wave and the ΔGM polynomial all assume waves that "
            f"do not break; at this period H1/3 <= {s['max_hs_m']:.3g} m.",
            stacklevel=stacklevel + 1,
        )


def log_quadrature(num: int = 6001, lo: float = 1e-3, hi: float = 1e4):
    """Nodes ω [rad/s] and weights of the trapezoid rule in s = ln ω on [lo, hi].

    For spectra that vanish smoothly at 0 and decay like a power of ω, the trapezoid rule in ln ω converges
    exponentially: m0 and m1 of the ITTC spectrum come out to ~1e-13 relative.
    """
    s = jnp.linspace(jnp.log(lo), jnp.log(hi), num)
    h = s[1] - s[0]
    w = jnp.full(num, h).at[0].set(h / 2).at[-1].set(h / 2)
    omega = jnp.exp(s)
    return omega, w * omega


def spectral_moment(spectrum, order: int) -> Float[Array, ""]:
    """Spectral moment m_n = ∫₀^∞ ωⁿ S(ω) dω [m² (rad/s)ⁿ] of a one-sided spectrum (callable S(ω))."""
    omega, weight = log_quadrature()
    return jnp.sum(weight * omega**order * spectrum(omega))


# Headings: χ is the angle between the ship's course and the direction the waves travel (docs/conventions.md):
# 0 following seas, π/2 beam seas (waves from starboard or port: long-crested, so the side does not matter here),
# π head seas. Below this |cos χ| the sea counts as beam (cos(π/2) is 6e-17 in floating point, not 0).
_BEAM_COS = 1e-12
HEADING_NAMES = {"head": math.pi, "following": 0.0}


def heading_angle(heading) -> float:
    """Heading χ [rad] in [0, π] from `"head"` (π), `"following"` (0) or an angle in radians.

    **Raises:** `ValueError` for any other string, a non-finite angle or one outside [0, π].
    """
    if isinstance(heading, str):
        if heading in HEADING_NAMES:
            return HEADING_NAMES[heading]
    else:
        try:
            chi = float(heading)
        except (TypeError, ValueError):
            chi = math.nan
        if 0.0 <= chi <= math.pi:
            return chi
    raise ValueError(
        f"`heading` must be 'head' or 'following', or an angle χ in [0, π] rad (0 following, π/2 beam, π head); "
        f"got {heading!r}."
    )


def heading_cosine(heading) -> float:
    """cos χ [-] of a heading (`heading_angle`), exactly −1 for head, 1 for following and 0 for beam seas."""
    c = math.cos(heading_angle(heading))
    return 0.0 if abs(c) < _BEAM_COS else c


def encounter_frequency(omega, speed, heading="head"):
    """Encounter frequency ω_e [rad/s] of waves of frequency ω [rad/s] at ship speed U [m/s] and heading χ.

    ω_e = |ω − ω²U cos χ/g| (deep water, k = ω²/g): head seas (χ = π, `"head"`) ω + ω²U/g; following seas
    (χ = 0, `"following"`) |ω − ω²U/g|; beam seas ω. `heading`: `"head"`, `"following"` or χ [rad] in [0, π].
    """
    cos_chi = heading_cosine(heading)
    omega = jnp.asarray(omega, dtype=float)
    shift = omega**2 * (speed * abs(cos_chi)) / GRAVITY
    if cos_chi <= 0:
        return omega + shift
    return jnp.abs(omega - shift)


def wave_frequencies_from_encounter(omega_e, speed, heading="head"):
    """All absolute wave frequencies ω ≥ 0 that meet the ship at encounter frequency ω_e.

    Only the speed component along the wave direction, U|cos χ|, matters: head-going headings (χ ≥ π/2) have one
    branch, following-going ones (χ < π/2) up to three. `heading`: `"head"`, `"following"` or χ [rad] in [0, π].

    **Returns:** `(omega, weight)`, each of shape `omega_e.shape + (3,)`: up to three branches (following seas);
    `weight` = 1/|dω_e/dω| for a valid branch and 0 otherwise (the Jacobian of the variance-preserving transform).
    """
    cos_chi = heading_cosine(heading)
    speed = jnp.asarray(speed, dtype=float)
    return encounter_branches(omega_e, speed if abs(cos_chi) == 1 else speed * abs(cos_chi), cos_chi > 0)


def encounter_branches(omega_e, projected_speed, following: bool):
    """`wave_frequencies_from_encounter` given the projected speed U|cos χ| [m/s] (an array, so that headings of one
    kind share a compiled function) and whether the heading is following-type (cos χ > 0: up to three branches)."""
    omega_e = jnp.asarray(omega_e, dtype=float)
    c = projected_speed / GRAVITY  # [s²/m]
    small = c * jnp.maximum(omega_e, 1e-12) < 1e-9
    safe_c = jnp.where(small, 1.0, c)
    zero = jnp.zeros_like(omega_e)
    if not following:
        # c ω² + ω − ω_e = 0 → ω = 2ω_e / (1 + √(1 + 4cω_e)) (stable for c → 0).
        w = 2 * omega_e / (1 + jnp.sqrt(1 + 4 * c * omega_e))
        jac = 1 / (1 + 2 * c * w)
        omegas = jnp.stack([w, zero, zero], -1)
        weights = jnp.stack([jac, zero, zero], -1)
        return omegas, weights
    # following: ω − cω² = ±ω_e.
    disc_p = 1 - 4 * c * omega_e  # for ω − cω² = +ω_e (two roots when ≥ 0)
    sq_p = jnp.sqrt(jnp.maximum(disc_p, 0.0))
    w1 = 2 * omega_e / (1 + sq_p)  # the branch that tends to ω_e as c → 0
    w2 = (1 + sq_p) / (2 * safe_c)
    sq_m = jnp.sqrt(1 + 4 * c * omega_e)  # ω − cω² = −ω_e: one positive root
    w3 = (1 + sq_m) / (2 * safe_c)
    valid_p = (disc_p > 0) & ~small
    w1 = jnp.where(small, omega_e, w1)
    jac = lambda w: 1 / jnp.maximum(jnp.abs(1 - 2 * c * w), 1e-12)
    omegas = jnp.stack([w1, jnp.where(valid_p, w2, 0.0), jnp.where(small, 0.0, w3)], -1)
    weights = jnp.stack(
        [
            jnp.where(small | valid_p, jac(w1), 0.0),
            jnp.where(valid_p, jac(w2), 0.0),
            jnp.where(small, 0.0, jac(w3)),
        ],
        -1,
    )
    return omegas, weights


def encounter_spectrum(spectrum: AbstractWaveSpectrum, omega_e, speed=0.0, heading="head"):
    """One-sided spectrum in encounter frequency S_e(ω_e) = Σ_branches S(ω)/|dω_e/dω| [m² s/rad] (variance kept).

    `heading`: `"head"`, `"following"` or χ [rad] in [0, π] (long-crested; docs/conventions.md)."""
    omegas, weights = wave_frequencies_from_encounter(omega_e, speed, heading)
    return jnp.sum(spectrum(omegas) * weights, axis=-1)
