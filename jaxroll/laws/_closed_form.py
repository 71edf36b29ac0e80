"""Closed-form amplitude laws: Rayleigh and the Roberts family with c2 = 0."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.special as jsp
from jaxtyping import Array, ArrayLike, Float

from .._compiled import require
from ._abstract import AbstractAmplitudeLaw, check_estimator
from ._checks import _is_traced, _log1mexp, _positive, _scalar


class RayleighLaw(AbstractAmplitudeLaw):
    r"""Rayleigh amplitudes, $P(a) = (a/\sigma^2)\,e^{-a^2/2\sigma^2}$, $\bar F(a) = e^{-a^2/2\sigma^2}$.

    The per-cycle amplitude distribution of a narrow-band Gaussian roll with standard deviation $\sigma$; the
    closed-form test case of docs/maxima.md.
    """

    sigma: Float[Array, ""]
    estimator: str = eqx.field(static=True)

    def __init__(self, sigma: ArrayLike, *, estimator: str = "zero_crossing"):
        self.estimator = check_estimator(estimator)
        self.sigma = _positive(sigma, "sigma", "[rad]", " It is the standard deviation of the roll angle.")

    def _logpdf(self, a):
        a = jnp.asarray(a, dtype=float)
        pos = a > 0
        a_safe = jnp.where(pos, a, 1.0)
        s2 = self.sigma**2
        return jnp.where(pos, jnp.log(a_safe) - jnp.log(s2) - 0.5 * a_safe**2 / s2, -jnp.inf)

    def _logsf(self, a):
        a = jnp.asarray(a, dtype=float)
        return jnp.where(a > 0, -0.5 * a**2 / self.sigma**2, 0.0)

    def _logcdf(self, a):
        a = jnp.asarray(a, dtype=float)
        pos = a > 0
        a_safe = jnp.where(pos, a, 1.0)
        return jnp.where(pos, _log1mexp(-0.5 * a_safe**2 / self.sigma**2), -jnp.inf)

    def support(self):
        return jnp.asarray(0.0), jnp.asarray(jnp.inf)

    def scale(self):
        return self.sigma


RayleighLaw.__init__.__doc__ = """**Arguments:**

- `sigma`: Rayleigh scale σ [rad] (the roll standard deviation for a narrow-band Gaussian roll); must be > 0.
- `estimator`: what the amplitudes are (default "zero_crossing": for a narrow-band Gaussian roll the
  per-half-cycle peaks and the envelope are both Rayleigh).
"""


def roberts_logpdf(a: ArrayLike, nu: ArrayLike, c2: ArrayLike, c3: ArrayLike) -> Float[Array, "..."]:
    r"""Unnormalised log of the Roberts-family amplitude PDF, $\nu \log A - c_2 A - c_3 A^2$.

    For $c_2 \ne 0$ tabulate it and normalise with `TabulatedAmplitudeLaw.from_logpdf(grid,
    roberts_logpdf(grid, nu, c2, c3))`; for $c_2 = 0$ use the closed form `RobertsLaw`.

    **Arguments:** `a` amplitudes [rad] (−inf is returned at a ≤ 0), `nu` [-], `c2` [1/rad],
    `c3` [1/rad²].
    """
    a = jnp.asarray(a, dtype=float)
    pos = a > 0
    a_safe = jnp.where(pos, a, 1.0)
    return jnp.where(pos, nu * jnp.log(a_safe) - c2 * a_safe - c3 * a_safe**2, -jnp.inf)


def _log_gammaincc_cf(k, x, terms: int = 150):
    """log Q(k, x) by its continued fraction (Numerical Recipes eq. 6.2.7), evaluated backwards; x >= k + 1.

    150 terms give ~1e-15 relative for k <= 50 at x = k + 1 (faster convergence further out)."""
    t0 = x + 2.0 * (terms + 1) - 1.0 - k

    def body(i, t):
        n = jnp.asarray(terms - i, dtype=x.dtype)
        return x + 2.0 * n - 1.0 - k - n * (n - k) / t

    t = jax.lax.fori_loop(0, terms, body, t0)
    return k * jnp.log(x) - x - jsp.gammaln(k) - jnp.log(t)


def _log_gammainc_series(k, x, terms: int = 250):
    """log P(k, x) by its power series (Numerical Recipes eq. 6.2.5), for 0 < x <= k + 1.

    250 terms give ~1e-15 relative for k <= 50 at x = k + 1 (faster convergence for smaller x)."""

    def body(i, c):
        term, total = c
        term = term * x / (k + jnp.asarray(i, dtype=x.dtype))
        return term, total + term

    one = jnp.ones_like(x)
    _, total = jax.lax.fori_loop(1, terms + 1, body, (one, one))
    return k * jnp.log(x) - x - jsp.gammaln(k + 1.0) + jnp.log(total)


class RobertsLaw(AbstractAmplitudeLaw):
    r"""Roberts-family amplitudes with $c_2 = 0$: $P(A) \propto A^\nu e^{-c_3 A^2}$.

    With $k = (\nu + 1)/2$: $P(A) = 2 c_3^k A^\nu e^{-c_3 A^2} / \Gamma(k)$ and
    $\bar F(a) = Q(k, c_3 a^2)$, the regularised upper incomplete gamma function (docs/maxima.md).
    $\nu = 1$ is Rayleigh with $\sigma^2 = 1/(2 c_3)$. For $c_2 \ne 0$ there is no closed form: tabulate
    `roberts_logpdf`.

    $P$ and $Q$ come from their power series below $x = k + 1$ and continued fraction above, with fixed term
    counts: ~1e-13 relative in log space for $\nu \le 99$ (checked against `scipy.special` in the tests).
    """

    nu: Float[Array, ""]
    c3: Float[Array, ""]
    estimator: str = eqx.field(static=True)

    def __init__(self, nu: ArrayLike, c3: ArrayLike, *, estimator: str = "zero_crossing"):
        self.estimator = check_estimator(estimator)
        nu = _scalar(nu, "nu")
        shown = "a traced value" if _is_traced(nu) else f"{float(nu)!r}"
        self.nu = require(nu, ~(nu > -1), f"`nu` must be > -1 so that A^nu is integrable at 0; got {shown}.")
        self.c3 = _positive(c3, "c3", "[1/rad²]", " The PDF must decay like exp(-c3 A²).")

    @property
    def _k(self):
        return 0.5 * (self.nu + 1.0)

    def _logpdf(self, a):
        a = jnp.asarray(a, dtype=float)
        k = self._k
        norm = math.log(2.0) + k * jnp.log(self.c3) - jsp.gammaln(k)
        return roberts_logpdf(a, self.nu, 0.0, self.c3) + norm

    def _log_p_q(self, a):
        # (log P, log Q) of the regularised incomplete gamma at x = c3 a²: the series below k + 1, the
        # continued fraction above, and the other one as log(1 − e^{·}), where it is not small. Loops of fixed
        # length only: differentiable in a, ν and c3, and far cheaper to compile than jax.scipy's gammainc.
        a = jnp.asarray(a, dtype=float)
        k = self._k
        x = self.c3 * jnp.maximum(a, 0.0) ** 2
        upper = x > k + 1.0
        zero = x <= 0.0
        x_low = jnp.where(upper | zero, 0.5 * (k + 1.0), x)
        x_up = jnp.where(upper, x, k + 2.0)
        log_p_low = _log_gammainc_series(k, x_low)
        log_q_up = _log_gammaincc_cf(k, x_up)
        log_p = jnp.where(upper, _log1mexp(log_q_up), jnp.where(zero, -jnp.inf, log_p_low))
        log_q = jnp.where(upper, log_q_up, jnp.where(zero, 0.0, _log1mexp(log_p_low)))
        return log_p, log_q

    def _logsf(self, a):
        return self._log_p_q(a)[1]

    def _logcdf(self, a):
        return self._log_p_q(a)[0]

    def support(self):
        return jnp.asarray(0.0), jnp.asarray(jnp.inf)

    def scale(self):
        return jnp.sqrt(self._k / self.c3)


RobertsLaw.__init__.__doc__ = """**Arguments:**

- `nu`: exponent ν [-] of the amplitude power law near zero; must be > −1.
- `c3`: coefficient of A² in the exponent [1/rad²]; must be > 0.
- `estimator`: what the amplitudes are: "zero_crossing" (default) or "envelope" (Roberts' stationary law is
  an envelope law; for linear restoring the two coincide).
"""
