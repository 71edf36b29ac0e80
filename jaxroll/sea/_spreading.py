"""Directional spreading of a short-crested sea: D(θ) [1/rad] of the wave direction θ about the mean direction.

Two standard forms, each normalised so that ∫ D dθ = 1 (closed forms; tested by quadrature):

- cos-2s (Longuet-Higgins et al. 1963): D(θ) = C(s) cos^{2s}(θ/2) on |θ| ≤ π, C(s) = Γ(s + 1)/(2√π Γ(s + ½));
- cos^n: D(θ) = C(n) cos^n θ on |θ| < π/2 (no waves against the mean direction), C(n) = Γ(n/2 + 1)/(√π Γ(n/2 + ½)).

Both tend to the long-crested sea (a delta at θ = 0) as the exponent grows: cos-2s with s has about the spread of
cos^n with n = s/2 (σ_θ² ≈ 2/s and 1/n at large exponents).

The sea is discretised in Q directions θ_q with weights w_q (`directions`): Gauss–Legendre nodes on the support
cut where each tail holds `TAIL` = 1e-7 of the probability (so that the nodes follow a narrow spreading), the
weights those of the rule times D(θ_q), normalised to Σ w_q = 1. A quantity averaged over directions is then
Σ w_q f(θ_q): what the spread effective-wave spectrum, the shaping filter fitted to it, the superposition and the
direct moment all use, so that they are one discretised sea. With Q = 32 the variance of Grim's effective wave is
within 1e-4 of the double integral ∫∫ S D F² dθ dω for cos-2s, s ≥ 1, and cos^n, n ≥ 0.5 (docs/spreading.md; equal-
energy bins, the medians of Q bins of probability 1/Q, converge only as 1/Q: the quantile function is singular at
the tails). As the exponent grows the nodes close on θ = 0 and the sea becomes the long-crested one.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

KINDS = ("cos2s", "cosn")
DEFAULT_DIRECTIONS = 32  # Q: σ_G² within 1e-4 of the double integral (docs/spreading.md)
TAIL = 1e-7  # the probability left out of each tail of the directions' support


class Spreading(eqx.Module):
    """Directional spreading D(θ) [1/rad] of a short-crested sea about its mean direction (module docstring).

    `Spreading("cos2s", s)`: D ∝ cos^{2s}(θ/2) on |θ| ≤ π; `Spreading("cosn", n)`: D ∝ cos^n θ on |θ| < π/2.
    `num_directions` Q: the directions the sea is discretised in (`directions`)."""

    kind: str = eqx.field(static=True)
    exponent: float = eqx.field(static=True)
    num_directions: int = eqx.field(static=True, default=DEFAULT_DIRECTIONS)

    def __init__(self, kind: str, exponent: float, num_directions: int = DEFAULT_DIRECTIONS):
        """**Arguments:** `kind`: `"cos2s"` or `"cosn"`; `exponent`: s or n [-], finite and > 0 (larger is
        narrower); `num_directions`: Q, the directions of the discretised sea (an integer ≥ 1).

        **Raises:** `ValueError` for another kind, an exponent ≤ 0 or not finite, or Q < 1."""
        if kind not in KINDS:
            raise ValueError(f"spreading kind must be 'cos2s' or 'cosn'; got {kind!r}.")
        try:
            value = float(exponent)
        except (TypeError, ValueError):
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            what = "s of cos-2s" if kind == "cos2s" else "n of cos^n"
            raise ValueError(
                f"the spreading exponent {what} must be a finite number > 0 (larger is narrower: e.g. s = 10 for "
                f"wind sea, 25-75 for swell); got {exponent!r}."
            )
        if isinstance(num_directions, bool) or not (isinstance(num_directions, int) and num_directions >= 1):
            raise ValueError(f"`num_directions` must be an integer >= 1; got {num_directions!r}.")
        self.kind, self.exponent, self.num_directions = kind, value, num_directions

    @property
    def half_width(self) -> float:
        """The half-width of the support [rad]: π (cos-2s) or π/2 (cos^n)."""
        return math.pi if self.kind == "cos2s" else math.pi / 2

    @property
    def normalisation(self) -> float:
        """C [1/rad] in D = C cos^{2s}(θ/2) or C cos^n θ, in closed form (∫ D dθ = 1)."""
        e = self.exponent
        if self.kind == "cos2s":
            return math.exp(math.lgamma(e + 1) - math.lgamma(e + 0.5)) / (2 * math.sqrt(math.pi))
        return math.exp(math.lgamma(e / 2 + 1) - math.lgamma(e / 2 + 0.5)) / math.sqrt(math.pi)

    def __call__(self, theta: ArrayLike) -> Float[Array, "..."]:
        """D(θ) [1/rad] at directions θ [rad] relative to the mean direction (zero outside the support)."""
        theta = jnp.asarray(theta, dtype=float)
        inside = jnp.abs(theta) <= self.half_width
        c = jnp.cos(theta / 2) if self.kind == "cos2s" else jnp.cos(theta)
        c = jnp.where(inside, jnp.maximum(c, 0.0), 0.0)
        power = 2 * self.exponent if self.kind == "cos2s" else self.exponent
        return self.normalisation * c**power

    def _beta_b(self) -> float:
        """b of the incomplete beta I_x(½, b) that gives the probability within ±θ (module docstring)."""
        return self.exponent + 0.5 if self.kind == "cos2s" else (self.exponent + 1) / 2

    def cdf(self, theta: ArrayLike) -> np.ndarray:
        """P(direction ≤ θ) [-] at θ [rad] (host, closed form: ½ ± ½ I_x(½, b), x = sin²(θ/2) or sin²θ)."""
        from scipy.special import betainc

        theta = np.clip(np.asarray(theta, dtype=float), -self.half_width, self.half_width)
        x = np.sin(theta / 2) ** 2 if self.kind == "cos2s" else np.sin(theta) ** 2
        return 0.5 + 0.5 * np.sign(theta) * betainc(0.5, self._beta_b(), x)

    def quantile(self, u: ArrayLike) -> np.ndarray:
        """The direction θ [rad] with P(direction ≤ θ) = u, u in [0, 1] (host, closed form; inverse of `cdf`)."""
        from scipy.special import betaincinv

        u = np.asarray(u, dtype=float)
        x = betaincinv(0.5, self._beta_b(), np.abs(2 * u - 1))
        half = np.arcsin(np.sqrt(x))
        return np.sign(u - 0.5) * (2 * half if self.kind == "cos2s" else half)

    def directions(self) -> tuple[np.ndarray, np.ndarray]:
        """The Q directions θ_q [rad] relative to the mean and their weights w_q [-] (Σ w_q = 1; module
        docstring): Gauss–Legendre on |θ| ≤ Θ(1 − `TAIL`), weights ∝ the rule's × D(θ_q). Host, float64."""
        top = float(self.quantile(1 - TAIL))
        x, w = np.polynomial.legendre.leggauss(self.num_directions)
        theta = x * top
        w = w * np.asarray(self(theta))
        return theta, w / np.sum(w)

    def label(self) -> str:
        """The spreading as the CLI writes it: `cos2s:S` or `cosn:N`."""
        return f"{self.kind}:{self.exponent:g}"


def parse_spreading(text: str, num_directions: int = DEFAULT_DIRECTIONS) -> Spreading | None:
    """A `Spreading` from `cos2s:S`, `cosn:N`, or None from `none` (long-crested).

    **Raises:** `ValueError` for any other text or an exponent ≤ 0."""
    t = str(text).strip().lower()
    if t == "none":
        return None
    kind, sep, value = t.partition(":")
    if kind not in KINDS or not sep:
        raise ValueError(
            f"spreading must be cos2s:S, cosn:N (S, N > 0: the exponent, larger is narrower) or none; got {text!r}."
        )
    try:
        exponent = float(value)
    except ValueError:
        exponent = math.nan
    if not (math.isfinite(exponent) and exponent > 0):
        raise ValueError(
            f"the spreading exponent must be a finite number > 0 (larger is narrower: e.g. cos2s:10 for wind sea, "
            f"cos2s:25 to cos2s:75 for swell, cosn:2); got {text!r}."
        )
    return Spreading(kind, exponent, num_directions)
