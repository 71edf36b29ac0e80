r"""Maximum-value distributions of roll amplitudes, and exposure-time risk measures.

Everything here works on a **per-cycle** amplitude distribution: the distribution of the amplitudes that the
zero-crossing method returns (two per roll cycle: the maximum between an up-crossing and the next
down-crossing, and |minimum| between a down-crossing and the next up-crossing). The time-sampled envelope PDF
(Hilbert method, every sample) is a different distribution and must not be fed to these formulas; see
`docs/maxima.md`.

Amplitudes are in **radians** (non-negative). Degrees appear only in the `*_deg` helpers of results.

Maximum of $N_0$ independent amplitudes with PDF $P$ and survival $\bar F(a) = \int_a^\infty P\,dA$
(docs/maxima.md, after Goda 2000):

$$P^*(A_M) = N_0\,[1 - \bar F(A_M)]^{N_0 - 1} P(A_M),\qquad
\Pr(A_{\max} \le a) = [1 - \bar F(a)]^{N_0},$$

evaluated in log space as $\log P^* = \log N_0 + (N_0 - 1)\log(1 - \bar F) + \log P$, where
$\log(1 - \bar F)$ is `logcdf`, computed as `log1p(-F̄)` in the upper tail and directly in the lower tail, so
that nothing cancels for $N_0 = 10^4 \ldots 10^7$ and nothing underflows before the final `exp`.
"""

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._compiled import filter_jit
from .._config import require_float64
from ..laws._abstract import (
    AbstractAmplitudeLaw,
    _bracket_targets,
    _expected_maximum,
    _solve_levels,
    require_zero_crossing,
)
from ..laws._checks import _GOLDEN, _count_n0, _log1mexp, _probability_levels

# ------------------------------------------------------------------------------------------------------------
# The maximum of N0 amplitudes
# ------------------------------------------------------------------------------------------------------------


def _max_logpdf(dist, a, n0):
    lp = dist._logpdf(a)
    lc = dist._logcdf(a)
    finite = jnp.isfinite(lc)
    lc_safe = jnp.where(finite, lc, 0.0)
    out = jnp.log(n0) + (n0 - 1.0) * lc_safe + lp
    # F̄ = 1 (a at or below the support's lower end): P* = 0 for N0 > 1, P for N0 = 1.
    return jnp.where(finite, out, jnp.where(n0 > 1, -jnp.inf, lp))


def max_logpdf(dist: AbstractAmplitudeLaw, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\log P^*(a)$ [log(1/rad)] of the maximum of `n0` independent amplitudes.

    $\log P^* = \log N_0 + (N_0 - 1)\log(1 - \bar F(a)) + \log P(a)$, with $\log(1 - \bar F)$ from
    `dist.logcdf` (`log1p(−F̄)` in the tail). Finite wherever $P^* > 0$, even where $P^*$ itself underflows.

    **Arguments:**

    - `dist`: per-cycle amplitude distribution.
    - `a`: candidate maxima [rad], any shape.
    - `n0`: number of amplitudes $N_0$ (>= 1; need not be an integer).
    """
    require_float64("jaxroll.max_logpdf")
    require_zero_crossing(dist, "`max_logpdf`")
    n0 = _count_n0(n0)
    return _max_logpdf_jit(dist, jnp.asarray(a, dtype=float), n0)


_max_logpdf_jit = filter_jit(_max_logpdf)


def max_pdf(dist: AbstractAmplitudeLaw, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$P^*(a) = N_0 [1 - \bar F(a)]^{N_0 - 1} P(a)$ [1/rad], the PDF of the maximum of `n0` amplitudes
    (computed as `exp(max_logpdf)`; arguments as there)."""
    require_float64("jaxroll.max_pdf")
    require_zero_crossing(dist, "`max_pdf`")
    return jnp.exp(max_logpdf(dist, a, n0))


def max_pdf_asymptotic(dist: AbstractAmplitudeLaw, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""The asymptotic form (docs/maxima.md), $P^* \approx \xi e^{-\xi} [\bar F (1 - \bar F)]^{-1} P$,
    $\xi = N_0 \bar F$ [1/rad].

    It replaces $(1 - \bar F)^{N_0}$ by $e^{-\xi}$; its ratio to the exact $P^*$ is
    $\exp(-N_0[\bar F + \log(1 - \bar F)]) = \exp(\xi^2/2N_0)\,(1 + O(\xi^3/N_0^2))$.

    !!! note
        It is not a normalised PDF: the factor $1/(1 - \bar F)$ makes it diverge like
        $N_0 e^{-N_0} P/(1 - \bar F)$ at $a \to 0$ (non-integrable for Rayleigh-like $P \propto a$), although
        with weight $e^{-N_0}$. $N_0 e^{-\xi} P$ (the derivative of $e^{-\xi}$) is the consistent
        Poisson/Gumbel form.

    **Arguments:** `dist`; `a` [rad], any shape; `n0` >= 1.
    """
    require_float64("jaxroll.max_pdf_asymptotic")
    require_zero_crossing(dist, "`max_pdf_asymptotic`")
    n0 = _count_n0(n0)
    return _max_pdf_asymptotic(dist, jnp.asarray(a, dtype=float), n0)


@filter_jit
def _max_pdf_asymptotic(dist, a, n0):
    xi = n0 * jnp.exp(dist._logsf(a))
    # ξ e^{−ξ} / F̄ = N0 e^{−ξ}: written this way it stays finite where F̄ underflows.
    return jnp.exp(jnp.log(n0) - xi - dist._logcdf(a) + dist._logpdf(a))


def max_logcdf(dist: AbstractAmplitudeLaw, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\log \Pr(A_{\max} \le a) = N_0 \log(1 - \bar F(a))$ [-]."""
    require_float64("jaxroll.max_logcdf")
    require_zero_crossing(dist, "`max_logcdf`")
    n0 = _count_n0(n0)
    return _max_logcdf(dist, jnp.asarray(a, dtype=float), n0)


@filter_jit
def _max_logcdf(dist, a, n0):
    return n0 * dist._logcdf(a)


def max_cdf(dist: AbstractAmplitudeLaw, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\Pr(A_{\max} \le a) = (1 - \bar F(a))^{N_0} = \exp(N_0\,\mathrm{log1p}(-\bar F))$ [-]."""
    require_float64("jaxroll.max_cdf")
    require_zero_crossing(dist, "`max_cdf`")
    return jnp.exp(max_logcdf(dist, a, n0))


def max_sf(dist: AbstractAmplitudeLaw, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\Pr(A_{\max} > a) = 1 - (1 - \bar F)^{N_0}$ [-], as `-expm1(N0·log1p(−F̄))`: accurate when tiny."""
    require_float64("jaxroll.max_sf")
    require_zero_crossing(dist, "`max_sf`")
    return -jnp.expm1(max_logcdf(dist, a, n0))


def max_quantile(dist: AbstractAmplitudeLaw, q: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""The `q`-quantile [rad] of the maximum of `n0` amplitudes: $(1 - \bar F(a))^{N_0} = q$.

    Solved as $\bar F(a) = -\mathrm{expm1}(\log q / N_0)$, accurate for $N_0 = 10^7$. Differentiable.

    **Arguments:** `dist`; `q` in (0, 1), any shape; `n0` >= 1.
    """
    require_float64("jaxroll.max_quantile")
    require_zero_crossing(dist, "`max_quantile`")
    n0 = _count_n0(n0)
    q = _probability_levels(q)
    return _max_quantile(dist, q, n0)


@filter_jit
def _max_quantile(dist, q, n0):
    log_c = jnp.log(q) / n0
    return _solve_levels(dist, log_c, _log1mexp(log_c))


def expected_maximum(dist: AbstractAmplitudeLaw, n0: ArrayLike, *, num_panels: int = 256) -> Float[Array, ""]:
    r"""The expected maximum [rad] of `n0` amplitudes.

    $E[A_{\max}] = \int_0^\infty [1 - (1 - \bar F(a))^{N_0}]\,da$ by composite 8-point Gauss–Legendre on the
    interval where the integrand is neither 1 to within 1e-30 nor 0 to within 1e-20 (left of it the
    integrand counts as exactly 1), with nodes clustered at its left end. About 1e-15 relative for Rayleigh
    with $N_0 = 20 \ldots 10^7$; never the alternating binomial sum, which loses all accuracy in float64 by
    $N_0 \approx 50$. Differentiable.

    **Arguments:**

    - `dist`: per-cycle amplitude distribution.
    - `n0`: number of amplitudes $N_0$ >= 1.
    - `num_panels`: Gauss–Legendre panels (8 nodes each).
    """
    require_float64("jaxroll.expected_maximum")
    require_zero_crossing(dist, "`expected_maximum`")
    n0 = _count_n0(n0)
    if num_panels < 1:
        raise ValueError(f"`num_panels` must be >= 1; got {num_panels}.")
    return _expected_maximum(dist, n0, num_panels)


def _mode_in(dist, n0, left, right):
    d0 = jax.lax.stop_gradient(dist)
    n0s = jax.lax.stop_gradient(n0)
    lo_support, _ = d0.support()
    left = jax.lax.stop_gradient(jnp.maximum(left, lo_support))
    xs = jnp.linspace(left, jax.lax.stop_gradient(right), 1025)

    def f(x):
        v = _max_logpdf(d0, x, n0s)
        return jnp.where(jnp.isnan(v), -jnp.inf, v)

    k = jnp.argmax(f(xs))
    a = xs[jnp.maximum(k - 1, 0)]
    b = xs[jnp.minimum(k + 1, xs.shape[0] - 1)]

    def golden(_, c):
        a, b = c
        x1 = b - _GOLDEN * (b - a)
        x2 = a + _GOLDEN * (b - a)
        left_better = f(x1) >= f(x2)
        return jnp.where(left_better, a, x1), jnp.where(left_better, x2, b)

    a, b = jax.lax.fori_loop(0, 90, golden, (a, b))
    x0 = 0.5 * (a + b)
    # Implicit-function gradient: x* solves g'(x) = 0 (g = log P*), so dx*/dθ = −∂θ g' / g''. g'' by a central
    # difference (1e-8 relative here), g' by autodiff with live parameters.
    delta = 1e-5 * (xs[-1] - xs[0])
    g = f(x0 + delta * jnp.asarray([-1.0, 0.0, 1.0]))
    g2 = (g[0] - 2.0 * g[1] + g[2]) / delta**2
    g1 = jax.grad(lambda x: _max_logpdf(dist, x, n0))(x0)
    step = -g1 / jnp.where(g2 < 0, g2, -1.0)
    ok = jnp.isfinite(g1) & jnp.isfinite(g2) & (g2 < 0) & (jnp.abs(step) <= (b - a) + 1e-6 * jnp.abs(x0))
    # The Newton step also polishes the value: golden section alone stops at ~√eps relative on a flat maximum.
    return x0 + jnp.where(ok, step, 0.0)


@filter_jit
def _most_probable_maximum(dist, n0):
    log_c, log_s = _bracket_targets(n0)
    ends = _solve_levels(jax.lax.stop_gradient(dist), log_c[:2], log_s[:2])
    return _mode_in(dist, n0, ends[0], ends[1])


def most_probable_maximum(dist: AbstractAmplitudeLaw, n0: ArrayLike) -> Float[Array, ""]:
    r"""The mode of $P^*$ [rad]: the most probable maximum of `n0` amplitudes.

    A 1025-point scan of $\log P^*$ between the $10^{-15}$ and $1 - 10^{-12}$ quantiles of the maximum,
    refined by golden-section search and one Newton step. Differentiable (implicit function theorem) where
    $\log P^*$ is twice differentiable at the mode (closed forms; tabulated PDFs give the derivative of the
    local piece). For a histogram from samples the mode follows the noise of the tail's PDF: prefer the
    characteristic largest value of `exposure_risk`, which needs only $\bar F$.

    **Arguments:** `dist`; `n0` >= 1.
    """
    require_float64("jaxroll.most_probable_maximum")
    require_zero_crossing(dist, "`most_probable_maximum`")
    n0 = _count_n0(n0)
    return _most_probable_maximum(dist, n0)
