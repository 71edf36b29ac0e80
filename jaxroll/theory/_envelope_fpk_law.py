"""The amplitude law of the envelope Fokker–Planck method: probabilities of amplitude cells (finite volumes).

The finite-volume solution gives the probability of each amplitude cell. The law keeps these probabilities
exactly and shapes the density inside each cell as an exponential in A whose rate is the slope of ln(cell-average
density) between the neighbouring cells (a mass-preserving reconstruction: smooth on log axes, exact for
exponential tails). The survival function is summed from the top, so the upper tail keeps full relative accuracy.
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from ..laws._abstract import AbstractAmplitudeLaw


class EnvelopeExcitation(eqx.Module):
    """Complex Ornstein–Uhlenbeck model of the parametric excitation's complex envelope about the carrier 2ω.

    dX = (−γ + iΔ) X dt + 2√γ dW_c (E|X|² = 2 for unit variance); its spectrum is a Lorentzian of half-width γ
    centred at 2ω + Δ (fitted by `fit_envelope`).

    **Fields:** `gamma` γ [1/s] (the correlation time is 1/γ); `shift` Δ [rad/s] (centre of the Lorentzian minus
    2ω); `variance` v [-] (the Lorentzian's variance in units of σ²: v ≠ 1 because the sea's spectrum is not a
    Lorentzian; v scales the linear coupling so that the resonant level S(2ω) is exact); `sigma` σ [m] (standard
    deviation of ζ_mid); `omega` ω [rad/s] (half the carrier: the linearised roll frequency ω_l).
    """

    gamma: Float[Array, ""]
    shift: Float[Array, ""]
    variance: Float[Array, ""]
    sigma: Float[Array, ""]
    omega: Float[Array, ""]


class EnvelopeFPKLaw(AbstractAmplitudeLaw):
    """Roll-amplitude law A [rad] from the envelope Fokker–Planck method (`envelope_fpk_pdf`).

    `edges` [rad]: amplitude cell edges (log-spaced: coarse cells from `edges[0]` up to the fine region, fine ones
    up to the vanishing angle); `mass` [-]: probability of each cell (sums to 1). Within a cell the probability is
    spread uniformly, so `pdf` is the cell average [1/rad] and `cdf`/`sf` are linear between the edges.

    `estimator`: `"envelope"` (time-sampled, the s-marginal of the stationary density) or `"zero_crossing"` (per
    half cycle: the same weighted by the instantaneous half-cycle rate (ω + ψ̇)/π). `lyapunov_exponent` λ [1/s]:
    growth rate of ln A of the linearised roll (λ ≤ 0: the roll dies out, `exists` is False). `mass_top_cell`:
    probability of the top cell (the reflecting boundary at the vanishing angle; the capsize range).
    `method` names the variant ("envelope_fpk" stationary, "envelope_fpk_protocol" the Monte Carlo protocol),
    `grid` the numerical settings (both recorded by `details()`).
    """

    edges: Float[Array, " n1"]
    mass: Float[Array, " n"]
    lyapunov_exponent: Float[Array, ""]
    mass_top_cell: Float[Array, ""]
    excitation: EnvelopeExcitation
    exists: Bool[Array, ""]
    method: str = eqx.field(static=True)
    grid: tuple = eqx.field(static=True)
    estimator: str = eqx.field(static=True)

    @property
    def amplitude(self) -> Float[Array, " n"]:
        """Cell centres [rad] (geometric)."""
        return jnp.sqrt(self.edges[1:] * self.edges[:-1])

    @property
    def density(self) -> Float[Array, " n"]:
        """Cell-average density [1/rad]."""
        return self.mass / jnp.diff(self.edges)

    @property
    def support_max(self) -> Float[Array, ""]:
        """Top of the amplitude domain [rad]: the vanishing angle (reflecting boundary)."""
        return self.edges[-1]

    def _locate(self, a):
        """Cell index i, fractional position t ∈ [0, 1] of `a` inside it (clamped) and the cell's shape x_i."""
        e = self.edges
        i = jnp.clip(jnp.searchsorted(e, a, side="right") - 1, 0, e.shape[0] - 2)
        t = jnp.clip((a - e[i]) / (e[i + 1] - e[i]), 0.0, 1.0)
        return i, t, self._shape()[i]

    def _shape(self):
        """x_i = β_i w_i: the cell's exponential rate β [1/rad] (slope of ln density between the neighbouring
        cells' centres) times its width w [rad], clipped to ±30; 0 where a neighbour has no mass."""
        e = self.edges
        w = jnp.diff(e)
        c = (e[1:] + e[:-1]) / 2
        d = self.mass / w
        positive = d > 0
        logd = jnp.log(jnp.where(positive, d, 1.0))
        slope_in = (logd[2:] - logd[:-2]) / (c[2:] - c[:-2])
        slope = jnp.concatenate(
            [
                ((logd[1] - logd[0]) / (c[1] - c[0]))[None],
                slope_in,
                ((logd[-1] - logd[-2]) / (c[-1] - c[-2]))[None],
            ]
        )
        ok_lo = jnp.concatenate([positive[:1], positive[:-1]])
        ok_hi = jnp.concatenate([positive[1:], positive[-1:]])
        ok = positive & ok_lo & ok_hi
        return jnp.clip(jnp.where(ok, slope * w, 0.0), -30.0, 30.0)

    def _logpdf(self, a):
        i, t, x = self._locate(a)
        w = self.edges[i + 1] - self.edges[i]
        small = jnp.abs(x) < 1e-8
        xs = jnp.where(small, 1.0, x)
        shape = jnp.where(small, 1.0, xs * jnp.exp(xs * t) / jnp.expm1(xs))  # density / (mass/width)
        inside = (a >= self.edges[0]) & (a <= self.edges[-1])
        return jnp.where(inside, jnp.log(self.mass[i] * shape / w), -jnp.inf)

    def _logsf(self, a):
        i, t, x = self._locate(a)
        above = jnp.concatenate([jnp.cumsum(self.mass[::-1])[::-1][1:], jnp.zeros(1)])  # P(A > edges[i+1])
        sf = above[i] + self.mass[i] * _fraction_above(x, t)
        return jnp.log(jnp.where(a >= self.edges[-1], 0.0, jnp.where(a < self.edges[0], 1.0, sf)))

    def _logcdf(self, a):
        i, t, x = self._locate(a)
        below = jnp.concatenate([jnp.zeros(1), jnp.cumsum(self.mass)[:-1]])  # P(A ≤ edges[i])
        cdf = below[i] + self.mass[i] * _fraction_above(-x, 1 - t)
        return jnp.log(jnp.where(a >= self.edges[-1], 1.0, jnp.where(a < self.edges[0], 0.0, cdf)))

    def support(self):
        return self.edges[0], self.edges[-1]

    def scale(self):
        return self.mean()

    def mean(self) -> Float[Array, ""]:
        """E[A] [rad], exact for the reconstructed law: Σ mass_i (edge_i + w_i g(x_i)), g the mean position of
        the truncated exponential in its cell."""
        e = self.edges
        x = self._shape()
        small = jnp.abs(x) < 1e-6
        xs = jnp.where(small, 1.0, x)
        g = jnp.where(small, 0.5 + x / 12, -1 / jnp.expm1(-xs) - 1 / xs)
        return jnp.sum(self.mass * (e[:-1] + jnp.diff(e) * g))

    def details(self) -> dict:
        """What produced the law, for JSON: method, existence, Lyapunov exponent [1/s], top-cell mass, the fitted
        envelope (γ [1/s], Δ [rad/s], v, σ [m], ω [rad/s]) and the grid."""
        x = self.excitation  # numbers read on the host (NumPy): no compiled program per number
        return {
            "method": self.method,
            "exists": bool(self.exists),
            "support_max_deg": float(np.rad2deg(np.asarray(self.edges)[-1])),
            "parameters": {
                "lyapunov_exponent": float(self.lyapunov_exponent),
                "mass_top_cell": float(self.mass_top_cell),
                "envelope_gamma": float(x.gamma),
                "envelope_correlation_time_s": 1 / float(x.gamma),
                "envelope_shift": float(x.shift),
                "envelope_variance": float(x.variance),
                "sigma_zeta": float(x.sigma),
                "omega": float(x.omega),
            },
            "grid": dict(self.grid),
        }


def _fraction_above(x, t):
    """Share of a cell's mass above the fractional position t for the density ∝ e^{x t'} on t' ∈ [0, 1]:
    e^{xt} (e^{x(1−t)} − 1)/(eˣ − 1) (→ 1 − t as x → 0); the CDF's share is `_fraction_above(−x, 1 − t)`."""
    small = jnp.abs(x) < 1e-8
    xs = jnp.where(small, 1.0, x)
    return jnp.where(small, 1 - t, jnp.exp(xs * t) * jnp.expm1(xs * (1 - t)) / jnp.expm1(xs))
