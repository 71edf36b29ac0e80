"""Restoring: the GZ polynomial, the non-memory ΔGM(ζ_mid) polynomial and the parametric term P(t)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._compiled import cached_program
from ._ship import Ship


def _floating(x):
    """`x` as a JAX array of its own floating dtype (float32 stays float32: the Monte Carlo integrates in it);
    integers and Python numbers become float64."""
    x = jnp.asarray(x)
    return x if jnp.issubdtype(x.dtype, jnp.floating) else x.astype(float)


def restoring_moment(ship: Ship, phi) -> Float[Array, "..."]:
    """Calm-water restoring per unit roll inertia a1φ + a3φ³ + … + a9φ⁹ [1/s²] at roll angle φ [rad]."""
    phi = _floating(phi)
    a = ship.restoring_coefficients
    phi2 = phi * phi
    poly = a[0] + phi2 * (a[1] + phi2 * (a[2] + phi2 * (a[3] + phi2 * a[4])))
    return poly * phi


def restoring_potential(ship: Ship, phi) -> Float[Array, "..."]:
    """Calm-water restoring energy per unit roll inertia V(φ) = ∫₀^φ (a1x + a3x³ + … + a9x⁹) dx
    = a1φ²/2 + a3φ⁴/4 + … + a9φ¹⁰/10 [rad²/s²] at roll angle φ [rad]; increasing on [0, vanishing angle)."""
    phi = _floating(phi)
    a = ship.restoring_coefficients
    phi2 = phi * phi
    return phi2 * (a[0] / 2 + phi2 * (a[1] / 4 + phi2 * (a[2] / 6 + phi2 * (a[3] / 8 + phi2 * (a[4] / 10)))))


def righting_lever(ship: Ship, phi) -> Float[Array, "..."]:
    """Calm-water righting lever GZ(φ) [m] = GM0 · (restoring moment)/a1 at roll angle φ [rad]."""
    return ship.gm0 * restoring_moment(ship, phi) / ship.omega0**2


@cached_program
def _vanishing_angle(ship: Ship, num: int) -> Float[Array, ""]:
    phi = jnp.linspace(0.0, jnp.pi, num + 1)[1:]
    gz = restoring_moment(ship, phi)
    negative = gz <= 0
    idx = jnp.argmax(negative)
    found = negative[idx]
    lo = jnp.where(idx > 0, phi[idx - 1], 0.0)
    hi = phi[idx]
    for _ in range(40):
        mid = (lo + hi) / 2
        neg = restoring_moment(ship, mid) <= 0
        lo, hi = jnp.where(neg, lo, mid), jnp.where(neg, mid, hi)
    return jnp.where(found, (lo + hi) / 2, jnp.pi)


def vanishing_angle(ship: Ship, *, num: int = 4096) -> Float[Array, ""]:
    """Angle of vanishing stability [rad]: the first φ > 0 where GZ returns to zero (π if it never does).

    Found on a grid over (0, π] and refined by bisection; trajectories beyond it count as capsized.
    """
    return _vanishing_angle(ship, num)


def backbone_frequency(ship: Ship, amplitude) -> Float[Array, "..."]:
    """Natural frequency ω(A) [rad/s] of the undamped calm-water roll of amplitude A [rad] (the backbone curve):
    2π over the exact period T(A) = 4 ∫₀^{π/2} A cos θ dθ / √(2(V(A) − V(A sin θ))), V the restoring potential
    (64-point Gauss–Legendre in θ: the integrand is smooth). ω(0) = ω0; a softening GZ lowers it with A."""
    a = _floating(amplitude)[..., None]
    x, w = np.polynomial.legendre.leggauss(64)
    theta = (x + 1) * jnp.pi / 4
    weights = w * jnp.pi / 4
    small = a < 1e-6
    amp = jnp.where(small, 1e-6, a)
    gap = 2 * (restoring_potential(ship, amp) - restoring_potential(ship, amp * jnp.sin(theta)))
    period = 4 * jnp.sum(weights * amp * jnp.cos(theta) / jnp.sqrt(jnp.maximum(gap, 1e-300)), axis=-1)
    return jnp.where(small[..., 0], ship.omega0, 2 * jnp.pi / period)


def angle_of_maximum_gz(ship: Ship, *, num: int = 2048) -> Float[Array, ""]:
    """Heel [rad] of the largest calm-water GZ before the angle of vanishing stability (grid of `num` points)."""
    phi = vanishing_angle(ship) * jnp.linspace(0.0, 1.0, num + 1)[1:]
    return phi[jnp.argmax(restoring_moment(ship, phi))]


def delta_gm(ship: Ship, zeta_mid) -> Float[Array, "..."]:
    """Non-memory GM variation ΔGM(ζ_mid) = Σ_k C_k ζ_midᵏ [m]; ζ_mid [m] > 0 when a trough is amidships."""
    zeta_mid = _floating(zeta_mid)
    c = ship.delta_gm
    out = jnp.zeros_like(zeta_mid) + c[-1]
    for k in range(c.size - 2, -1, -1):
        out = out * zeta_mid + c[k]
    return out


def parametric_excitation(ship: Ship, zeta_g) -> Float[Array, "..."]:
    """P(t) = r · (ω0²/GM0) · ΔGM(ζ_mid) [1/s²] from Grim's effective wave ζ_G [m] (ζ_mid = −ζ_G), r = σ_obs/σ_thr."""
    return ship.gm_correction * ship.omega0**2 / ship.gm0 * delta_gm(ship, -_floating(zeta_g))
