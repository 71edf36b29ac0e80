r"""Maximum-value distributions of roll amplitudes, and exposure-time risk measures.

Everything here works on a **per-cycle** amplitude distribution: the distribution of the amplitudes that the
zero-crossing method returns (two per roll cycle: the maximum between an up-crossing and the next
down-crossing, and |minimum| between a down-crossing and the next up-crossing). The time-sampled envelope PDF
(Hilbert method, every sample) is a different distribution and must not be fed to these formulas; see
`docs/maxima.md`.

Amplitudes are in **radians** (non-negative). Degrees appear only in the `*_deg` helpers of results.

Maximum of $N_0$ independent amplitudes with PDF $P$ and survival $\bar F(a) = \int_a^\infty P\,dA$
(THEORY.md §7, after Goda 2000):

$$P^*(A_M) = N_0\,[1 - \bar F(A_M)]^{N_0 - 1} P(A_M),\qquad
\Pr(A_{\max} \le a) = [1 - \bar F(a)]^{N_0},$$

evaluated in log space as $\log P^* = \log N_0 + (N_0 - 1)\log(1 - \bar F) + \log P$, where
$\log(1 - \bar F)$ is `logcdf`, computed as `log1p(-F̄)` in the upper tail and directly in the lower tail, so
that nothing cancels for $N_0 = 10^4 \ldots 10^7$ and nothing underflows before the final `exp`.
"""

import abc
import math
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.special as jsp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

__all__ = [
    "AbstractAmplitudeDistribution",
    "AmplitudeDistribution",
    "RayleighAmplitudes",
    "RobertsAmplitudes",
    "roberts_logpdf",
    "max_logpdf",
    "max_pdf",
    "max_pdf_asymptotic",
    "max_logcdf",
    "max_cdf",
    "max_sf",
    "max_quantile",
    "expected_maximum",
    "most_probable_maximum",
    "exceedance_probability",
    "wilson_interval",
    "count_exceedances",
    "ExposureRisk",
    "exposure_risk",
    "EmpiricalMaxima",
    "empirical_maxima",
    "maxima_of_first",
]

_LOG_HALF = -math.log(2.0)
_GL_NODES, _GL_WEIGHTS = (np.asarray(v) for v in np.polynomial.legendre.leggauss(8))
_BISECTION_STEPS = 110  # halves the bracket to below one ulp from any float64 starting width
_DOUBLING_STEPS = 64
_UPPER_TAIL = 1e-20  # E[max] integrals stop where N0·F̄ has fallen to this
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


# ------------------------------------------------------------------------------------------------------------
# Small numerical helpers
# ------------------------------------------------------------------------------------------------------------


def _log1mexp(y):
    """log(1 − e^y) for y ≤ 0, accurate at both ends (Mächler 2012)."""
    y = jnp.minimum(y, 0.0)
    near = y > _LOG_HALF
    y_near = jnp.where(near, y, _LOG_HALF)
    y_far = jnp.where(near, _LOG_HALF, y)
    return jnp.where(near, jnp.log(-jnp.expm1(y_near)), jnp.log1p(-jnp.exp(y_far)))


def _is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _scalar(value, name: str) -> Float[Array, ""]:
    arr = jnp.asarray(value, dtype=float)
    if arr.shape != ():
        raise ValueError(f"`{name}` must be a scalar; got shape {arr.shape}.")
    return arr


def _require(value, bad, message: str):
    """Raise `ValueError(message)` when `bad` holds (concrete values), or attach `eqx.error_if` under tracing.

    The return value must be used: it carries the run-time check when tracing.
    """
    if _is_traced(bad):
        return eqx.error_if(value, bad, message)
    if bool(np.any(np.asarray(bad))):
        raise ValueError(message)
    return value


def _positive(value, name: str, unit: str, hint: str = ""):
    arr = _scalar(value, name)
    shown = "a traced value" if _is_traced(arr) else f"{float(arr)!r}"
    return _require(arr, ~(arr > 0), f"`{name}` must be > 0 {unit}; got {shown}.{hint}")


def _count_n0(n0, name: str = "n0"):
    arr = _scalar(n0, name)
    shown = "a traced value" if _is_traced(arr) else f"{float(arr)!r}"
    return _require(
        arr,
        ~(arr >= 1),
        f"`{name}` (the number of amplitudes whose maximum is taken) must be >= 1; got {shown}.",
    )


def _probability_levels(q, name: str = "q"):
    arr = jnp.asarray(q, dtype=float)
    shown = "a traced value" if _is_traced(arr) else f"{np.asarray(arr)!r}"
    return _require(
        arr, ~((arr > 0) & (arr < 1)), f"`{name}` must lie strictly between 0 and 1; got {shown}."
    )


def _gauss_legendre(f, a, b, num_panels: int):
    """Composite 8-point Gauss–Legendre quadrature of a vectorised `f` on [a, b]."""
    edges = jnp.linspace(a, b, num_panels + 1)
    mid = 0.5 * (edges[1:] + edges[:-1])
    half = 0.5 * (edges[1:] - edges[:-1])
    x = mid[:, None] + half[:, None] * _GL_NODES[None, :]
    return jnp.sum(f(x) * (half[:, None] * _GL_WEIGHTS[None, :]))


# ------------------------------------------------------------------------------------------------------------
# Amplitude distributions
# ------------------------------------------------------------------------------------------------------------


@eqx.filter_jit
def _evaluate(kernel: str, dist, a):
    return getattr(dist, kernel)(a)


class AbstractAmplitudeDistribution(eqx.Module):
    r"""A per-cycle amplitude distribution on $[0, \infty)$, amplitudes in radians.

    Subclasses provide the kernels of `logpdf`, `logsf` ($\log \bar F$) and `logcdf` ($\log(1 - \bar F)$),
    each accurate in its own tail, plus `support` and `scale`. Everything else (quantiles, the mean, the
    maximum-value functions of this module) is built on those, so any source of amplitudes (a tabulated PDF
    from theory, Monte Carlo samples, a closed form) plugs in the same way.
    """

    @abc.abstractmethod
    def _logpdf(self, a: Float[Array, "..."]) -> Float[Array, "..."]:
        """log P(a) for a float array `a`; the kernel behind `logpdf`."""

    @abc.abstractmethod
    def _logsf(self, a: Float[Array, "..."]) -> Float[Array, "..."]:
        """log F̄(a) for a float array `a`; the kernel behind `logsf`."""

    @abc.abstractmethod
    def _logcdf(self, a: Float[Array, "..."]) -> Float[Array, "..."]:
        """log(1 − F̄(a)) for a float array `a`; the kernel behind `logcdf`."""

    @abc.abstractmethod
    def support(self) -> tuple[Float[Array, ""], Float[Array, ""]]:
        """Lower and upper ends of the support [rad]; the upper end may be `inf`."""

    @abc.abstractmethod
    def scale(self) -> Float[Array, ""]:
        """A typical amplitude [rad], used to bracket root searches."""

    def logpdf(self, a: ArrayLike) -> Float[Array, "..."]:
        """log P(a), P in [1/rad]; −inf outside the support. `a` [rad], any shape."""
        return _evaluate("_logpdf", self, jnp.asarray(a, dtype=float))

    def logsf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$\log \bar F(a) = \log \int_a^\infty P\,dA$ [-], accurate far into the upper tail."""
        return _evaluate("_logsf", self, jnp.asarray(a, dtype=float))

    def logcdf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$\log(1 - \bar F(a))$ [-], accurate where $\bar F \to 0$ (as `log1p(−F̄)`) and where
        $\bar F \to 1$."""
        return _evaluate("_logcdf", self, jnp.asarray(a, dtype=float))

    def pdf(self, a: ArrayLike) -> Float[Array, "..."]:
        """P(a) [1/rad]."""
        return jnp.exp(self.logpdf(a))

    def survival(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$\bar F(a) = \Pr(A > a)$ [-]."""
        return jnp.exp(self.logsf(a))

    def cdf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$1 - \bar F(a) = \Pr(A \le a)$ [-]."""
        return jnp.exp(self.logcdf(a))

    def quantile(self, q: ArrayLike) -> Float[Array, "..."]:
        """The amplitude [rad] with `cdf(a) = q`, 0 < q < 1, any shape. Differentiable (implicit function)."""
        q = _probability_levels(q)
        return _solve_levels_jit(self, jnp.log(q), jnp.log1p(-q))

    def isf(self, s: ArrayLike) -> Float[Array, "..."]:
        r"""Inverse survival: the amplitude [rad] with $\bar F(a) = s$, accurate for tiny `s` (e.g. 1e-12)."""
        s = _probability_levels(s, "s")
        return _solve_levels_jit(self, jnp.log1p(-s), jnp.log(s))

    def mean(self) -> Float[Array, ""]:
        r"""Mean amplitude [rad], $\int_0^\infty \bar F\,da$ (Gauss–Legendre; the $N_0 = 1$ case of
        `expected_maximum`)."""
        return _expected_maximum(self, jnp.asarray(1.0), 256)


class RayleighAmplitudes(AbstractAmplitudeDistribution):
    r"""Rayleigh amplitudes, $P(a) = (a/\sigma^2)\,e^{-a^2/2\sigma^2}$, $\bar F(a) = e^{-a^2/2\sigma^2}$.

    The per-cycle amplitude distribution of a narrow-band Gaussian roll with standard deviation $\sigma$; the
    closed-form test case of THEORY.md §7.
    """

    sigma: Float[Array, ""]

    def __init__(self, sigma: ArrayLike):
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


RayleighAmplitudes.__init__.__doc__ = """**Arguments:**

- `sigma`: Rayleigh scale σ [rad] (the roll standard deviation for a narrow-band Gaussian roll); must be > 0.
"""


def roberts_logpdf(a: ArrayLike, nu: ArrayLike, c2: ArrayLike, c3: ArrayLike) -> Float[Array, "..."]:
    r"""Unnormalised log of the Roberts-family amplitude PDF, $\nu \log A - c_2 A - c_3 A^2$.

    For $c_2 \ne 0$ tabulate it and normalise with `AmplitudeDistribution.from_logpdf(grid,
    roberts_logpdf(grid, nu, c2, c3))`; for $c_2 = 0$ use the closed form `RobertsAmplitudes`.

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


class RobertsAmplitudes(AbstractAmplitudeDistribution):
    r"""Roberts-family amplitudes with $c_2 = 0$: $P(A) \propto A^\nu e^{-c_3 A^2}$.

    With $k = (\nu + 1)/2$: $P(A) = 2 c_3^k A^\nu e^{-c_3 A^2} / \Gamma(k)$ and
    $\bar F(a) = Q(k, c_3 a^2)$, the regularised upper incomplete gamma function (THEORY.md §7).
    $\nu = 1$ is Rayleigh with $\sigma^2 = 1/(2 c_3)$. For $c_2 \ne 0$ there is no closed form: tabulate
    `roberts_logpdf`.

    $P$ and $Q$ come from their power series below $x = k + 1$ and continued fraction above, with fixed term
    counts: ~1e-13 relative in log space for $\nu \le 99$ (checked against `scipy.special` in the tests).
    """

    nu: Float[Array, ""]
    c3: Float[Array, ""]

    def __init__(self, nu: ArrayLike, c3: ArrayLike):
        nu = _scalar(nu, "nu")
        shown = "a traced value" if _is_traced(nu) else f"{float(nu)!r}"
        self.nu = _require(nu, ~(nu > -1), f"`nu` must be > -1 so that A^nu is integrable at 0; got {shown}.")
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


RobertsAmplitudes.__init__.__doc__ = """**Arguments:**

- `nu`: exponent ν [-] of the amplitude power law near zero; must be > −1.
- `c3`: coefficient of A² in the exponent [1/rad²]; must be > 0.
"""


@jax.jit
def _tabulate(log_pdf, log_mass):
    # Normalise, then cumulative log-sum-exp of the segment masses from the right (F̄) and from the left
    # (1 − F̄).
    log_total = jax.scipy.special.logsumexp(log_mass)
    log_pdf = log_pdf - log_total
    log_mass = log_mass - log_total
    ninf = jnp.full((1,), -jnp.inf)
    log_sf = jnp.concatenate([jax.lax.cumlogsumexp(log_mass, reverse=True), ninf])
    log_cdf = jnp.concatenate([ninf, jax.lax.cumlogsumexp(log_mass)])
    return log_pdf, jnp.exp(log_pdf), log_mass, log_sf, log_cdf


@jax.jit
def _histogram_table(xs, edges):
    # xs sorted. Nodes: the outer edges and the bin centres; masses between nodes are exact empirical counts.
    n = xs.shape[0]
    centres = 0.5 * (edges[1:] + edges[:-1])
    counts, _ = jnp.histogram(xs, bins=edges)
    log_density = jnp.log(counts / (n * jnp.diff(edges)))
    grid = jnp.concatenate([edges[:1], centres, edges[-1:]])
    log_pdf = jnp.concatenate([log_density[:1], log_density, log_density[-1:]])
    above = n - jnp.searchsorted(xs, grid, side="right")  # exact empirical n·F̄ at the nodes
    above = above.at[0].set(n)
    log_mass = jnp.log((above[:-1] - above[1:]).astype(float)) - jnp.log(float(n))
    return grid, log_pdf, log_mass


class AmplitudeDistribution(AbstractAmplitudeDistribution):
    r"""A tabulated amplitude distribution: node values of the PDF on an increasing grid [rad].

    Between nodes the PDF is linear; the probability mass of each grid segment is stored (in log space) and
    the survival function at the nodes is its cumulative sum **from the right** (a cumulative `logaddexp`),
    so $\bar F$ keeps full relative accuracy in the upper tail, where the maxima live, even where the PDF
    itself is below the float64 range (`from_logpdf`). The CDF at the nodes is summed from the left. Inside a
    segment, $\bar F$ is the node value plus the exact share of the segment's mass above $a$ under the linear
    PDF.

    There is no mass outside `[grid[0], grid[-1]]`: the maximum of $N_0$ amplitudes can never exceed
    `grid[-1]`, so the grid must reach far enough into the tail for the $N_0$ of interest
    ($N_0 \bar F(\text{grid}[-1]) \ll 1$ before truncation).

    Build it with `AmplitudeDistribution.from_pdf`, `.from_logpdf` or `.from_samples`.
    """

    grid: Float[Array, " n"]
    pdf_values: Float[Array, " n"]
    log_pdf: Float[Array, " n"]
    log_mass: Float[Array, " n-1"]
    log_sf_nodes: Float[Array, " n"]
    log_cdf_nodes: Float[Array, " n"]
    n_samples: int | None = eqx.field(static=True, default=None)

    def __init__(
        self,
        grid: Float[ArrayLike, " n"],
        log_pdf: Float[ArrayLike, " n"],
        log_mass: Float[ArrayLike, " n-1"],
        n_samples: int | None = None,
    ):
        grid = jnp.asarray(grid, dtype=float)
        log_pdf = jnp.asarray(log_pdf, dtype=float)
        log_mass = jnp.asarray(log_mass, dtype=float)
        if grid.ndim != 1 or log_pdf.shape != grid.shape or log_mass.shape != (grid.shape[0] - 1,):
            raise ValueError(
                "`grid` and `log_pdf` must be 1-D of the same length n and `log_mass` of length n − 1; got "
                f"shapes {grid.shape}, {log_pdf.shape}, {log_mass.shape}. "
                "Use AmplitudeDistribution.from_pdf(grid, pdf)."
            )
        self.grid = grid
        self.log_pdf, self.pdf_values, self.log_mass, self.log_sf_nodes, self.log_cdf_nodes = _tabulate(
            log_pdf, log_mass
        )
        self.n_samples = n_samples

    # -- constructors ----------------------------------------------------------------------------------------

    @classmethod
    def from_pdf(cls, grid: Float[ArrayLike, " n"], pdf: Float[ArrayLike, " n"]) -> "AmplitudeDistribution":
        """A distribution from PDF values on a grid (normalised here with the trapezoidal rule).

        **Arguments:**

        - `grid`: amplitudes [rad], 1-D, strictly increasing, >= 0, at least 3 points. Extend it far
          enough into the tail: there is no mass beyond `grid[-1]`.
        - `pdf`: PDF values [1/rad] at `grid`, finite and >= 0 (any normalisation).

        **Raises:** `ValueError` naming the offending index and value for a bad grid or PDF.
        """
        grid, pdf = _check_table(grid, pdf, "pdf")
        pdf = _require(pdf, pdf < 0, _first_bad_message(pdf, pdf < 0, "pdf", "must be >= 0", _NEG_PDF_HINT))
        log_pdf = jnp.log(pdf)
        return cls._from_log_nodes(grid, log_pdf)

    @classmethod
    def from_logpdf(
        cls, grid: Float[ArrayLike, " n"], log_pdf: Float[ArrayLike, " n"]
    ) -> "AmplitudeDistribution":
        """A distribution from log-PDF values on a grid, for tails below the float64 range (`log p = −900`).

        **Arguments:**

        - `grid`: amplitudes [rad], as in `from_pdf`.
        - `log_pdf`: log of the PDF [log(1/rad)] at `grid`, any additive constant; `-inf` marks zero density,
          NaN and `+inf` are rejected.
        """
        grid, log_pdf = _check_table(grid, log_pdf, "log_pdf", allow_neg_inf=True)
        return cls._from_log_nodes(grid, log_pdf)

    @classmethod
    def _from_log_nodes(cls, grid, log_pdf):
        h = jnp.diff(grid)
        log_mass = jnp.log(0.5 * h) + jnp.logaddexp(log_pdf[:-1], log_pdf[1:])
        total = jax.scipy.special.logsumexp(log_mass)
        shown = "" if _is_traced(total) else " (every value is 0 or −inf)"
        log_mass = _require(
            log_mass,
            ~jnp.isfinite(total),
            f"The PDF integrates to 0 on the grid{shown}; tabulate it where the amplitudes actually lie.",
        )
        return cls(grid, log_pdf, log_mass)

    @classmethod
    def from_samples(
        cls, amplitudes: Float[ArrayLike, "..."], bins: int | Float[ArrayLike, " m+1"] = 100
    ) -> "AmplitudeDistribution":
        r"""The empirical distribution of sampled amplitudes (e.g. Monte Carlo zero-crossing amplitudes).

        The PDF is the histogram density, placed at the bin centres (and repeated at the two outer edges);
        the survival function at every node is the **exact empirical** fraction of samples above it (not the
        integral of the histogram), and between nodes it is interpolated with the segment's mass. `n_samples`
        records the sample size, which `exposure_risk` uses for confidence intervals.

        **Arguments:**

        - `amplitudes`: sampled amplitudes [rad], any shape (flattened); finite and >= 0. Drop capsized or
          failed trials first (and report their count separately).
        - `bins`: number of equal bins on `[0, max(amplitudes)]`, or strictly increasing bin edges [rad]
          that cover every sample.

        **Raises:** `ValueError` for non-finite or negative amplitudes, too few samples, or bad bins.
        """
        x = jnp.ravel(jnp.asarray(amplitudes, dtype=float))
        n = int(x.shape[0])
        if n < 2:
            raise ValueError(f"`amplitudes` needs at least 2 samples to build a distribution; got {n}.")
        bad = ~jnp.isfinite(x)
        count = "some" if _is_traced(bad) else str(int(np.sum(np.asarray(bad))))
        x = _require(
            x,
            bad,
            f"`amplitudes` contains {count} non-finite value(s) (capsized or failed trials?). Drop them "
            "first, e.g. `a[jnp.isfinite(a)]`, and count them separately as capsizes.",
        )
        x = _require(
            x, x < 0, _first_bad_message(x, x < 0, "amplitudes", "must be >= 0", " Pass absolute values |φ|.")
        )
        xs = jax.jit(jnp.sort)(x)
        if isinstance(bins, int | np.integer) and not isinstance(bins, bool):
            if bins < 1:
                raise ValueError(
                    f"`bins` must be a positive number of bins or an array of edges; got {bins}."
                )
            top = _require(xs[-1], xs[-1] <= 0, "All amplitudes are 0; there is no distribution to tabulate.")
            edges = jnp.linspace(0.0, top, bins + 1)
        else:
            edges = jnp.asarray(bins, dtype=float)
            if edges.ndim != 1 or edges.shape[0] < 2:
                raise ValueError(
                    f"`bins` as edges must be 1-D with at least 2 values; got shape {edges.shape}."
                )
            d = jnp.diff(edges)
            edges = _require(
                edges,
                d <= 0,
                _first_bad_message(
                    d, d <= 0, "diff(bins)", "must be > 0", " Bin edges must be strictly increasing."
                ),
            )
            outside = (xs[0] < edges[0]) | (xs[-1] > edges[-1])
            shown = "" if _is_traced(outside) else f" [{float(xs[0])!r}, {float(xs[-1])!r}]"
            edges = _require(
                edges,
                outside,
                f"The samples{shown} reach outside the bin edges [edges[0], edges[-1]]; widen the edges: "
                "samples beyond the last edge would be dropped from the tail, which is exactly what maxima "
                "depend on.",
            )
        grid, log_pdf, log_mass = _histogram_table(xs, edges)
        return cls(grid, log_pdf, log_mass, n_samples=n)

    # -- evaluation ------------------------------------------------------------------------------------------

    def _locate(self, a):
        a = jnp.asarray(a, dtype=float)
        x = self.grid
        i = jnp.clip(jnp.searchsorted(x, a, side="right") - 1, 0, x.shape[0] - 2)
        t = jnp.clip((a - x[i]) / (x[i + 1] - x[i]), 0.0, 1.0)
        lp0, lp1 = self.log_pdf[i], self.log_pdf[i + 1]
        m = jnp.maximum(lp0, lp1)
        empty = m == -jnp.inf
        m_safe = jnp.where(empty, 0.0, m)
        p0 = jnp.exp(jnp.where(empty, 0.0, lp0 - m_safe))  # scaled node values, max(p0, p1) = 1
        p1 = jnp.exp(jnp.where(empty, 0.0, lp1 - m_safe))
        inside = (a >= x[0]) & (a <= x[-1])
        return a, i, t, p0, p1, m_safe, empty, inside

    def _logpdf(self, a):
        a, i, t, p0, p1, m, empty, inside = self._locate(a)
        p = (1.0 - t) * p0 + t * p1
        ok = inside & ~empty & (p > 0)
        return jnp.where(ok, m + jnp.log(jnp.where(ok, p, 1.0)), -jnp.inf)

    def _shares(self, t, p0, p1, empty):
        # Shares of the segment's mass above (w) and below (1 − w) the point t under the linear PDF.
        denom = jnp.where(empty, 1.0, p0 + p1)
        above = jnp.where(empty, 1.0 - t, (1.0 - t) * ((1.0 - t) * p0 + (1.0 + t) * p1) / denom)
        below = jnp.where(empty, t, t * ((2.0 - t) * p0 + t * p1) / denom)
        return above, below

    def _logsf(self, a):
        a, i, t, p0, p1, _, empty, _ = self._locate(a)
        above, _ = self._shares(t, p0, p1, empty)
        inner = jnp.logaddexp(self.log_sf_nodes[i + 1], self.log_mass[i] + jnp.log(above))
        return jnp.where(a < self.grid[0], 0.0, jnp.where(a >= self.grid[-1], -jnp.inf, inner))

    def _logcdf(self, a):
        a, i, t, p0, p1, _, empty, _ = self._locate(a)
        _, below = self._shares(t, p0, p1, empty)
        inner = jnp.logaddexp(self.log_cdf_nodes[i], self.log_mass[i] + jnp.log(below))
        return jnp.where(a < self.grid[0], -jnp.inf, jnp.where(a >= self.grid[-1], 0.0, inner))

    def support(self):
        return self.grid[0], self.grid[-1]

    def scale(self):
        return self.grid[-1] - self.grid[0]


AmplitudeDistribution.__init__.__doc__ = """Low-level constructor; most users call `from_pdf`, `from_logpdf`
or `from_samples`.

**Arguments:**

- `grid`: increasing amplitudes [rad], shape (n,).
- `log_pdf`: log PDF at the nodes (any additive constant), shape (n,).
- `log_mass`: log probability mass of each segment (same constant), shape (n − 1,).
- `n_samples`: the sample size when the table comes from samples, else `None`.
"""

_NEG_PDF_HINT = (
    " Small negative values from interpolation or smoothing can be clipped with jnp.clip(pdf, 0); large "
    "ones mean the PDF is wrong."
)


def _first_bad_message(values, bad, name: str, requirement: str, hint: str = "") -> str:
    if _is_traced(bad) or _is_traced(values):
        return f"`{name}` {requirement}.{hint}"
    bad_np = np.atleast_1d(np.asarray(bad))
    if not bad_np.any():
        return ""
    idx = int(np.argmax(bad_np))
    value = np.atleast_1d(np.asarray(values))[idx]
    count = int(bad_np.sum())
    return f"`{name}` {requirement}; {name}[{idx}] = {float(value)!r} ({count} offending value(s)).{hint}"


def _check_table(grid, values, name: str, allow_neg_inf: bool = False):
    grid = jnp.asarray(grid, dtype=float)
    values = jnp.asarray(values, dtype=float)
    if grid.ndim != 1 or values.shape != grid.shape:
        raise ValueError(
            f"`grid` and `{name}` must be 1-D arrays of the same length; got shapes {grid.shape} and "
            f"{values.shape}. Tabulate the PDF at the grid points."
        )
    if grid.shape[0] < 3:
        raise ValueError(
            f"A tabulated distribution needs at least 3 grid points; got {grid.shape[0]}. Tabulate the PDF "
            "on a grid of a few hundred points that reaches far into the tail."
        )
    bad = ~jnp.isfinite(grid)
    grid = _require(grid, bad, _first_bad_message(grid, bad, "grid", "must be finite"))
    bad = jnp.isnan(values) | (values == jnp.inf) if allow_neg_inf else ~jnp.isfinite(values)
    req = "must not be NaN or +inf" if allow_neg_inf else "must be finite (no NaN or inf)"
    values = _require(values, bad, _first_bad_message(values, bad, name, req))
    d = jnp.diff(grid)
    grid = _require(
        grid,
        d <= 0,
        _first_bad_message(
            d,
            d <= 0,
            "diff(grid)",
            "must be > 0",
            " The grid must be strictly increasing: sort it and remove duplicate points.",
        ),
    )
    grid = _require(
        grid,
        grid[0] < 0,
        f"Amplitudes are non-negative, but grid[0] = "
        f"{'a traced value' if _is_traced(grid) else repr(float(grid[0]))} < 0. "
        "Start the grid at 0 or above.",
    )
    return grid, values


# ------------------------------------------------------------------------------------------------------------
# Root finding on the distribution's levels (bisection + one implicit-function Newton step for gradients)
# ------------------------------------------------------------------------------------------------------------


def _level_residual(dist, x, log_c, log_s, use_cdf):
    # Increasing in x; zero at the level. The branch is the better-conditioned one.
    return jnp.where(use_cdf, dist._logcdf(x) - log_c, log_s - dist._logsf(x))


def _solve_level(dist, log_c, log_s):
    """Scalar x with logcdf(x) = log_c (equivalently logsf(x) = log_s): the two targets describe one level."""
    d0 = jax.lax.stop_gradient(dist)
    lc0, ls0 = jax.lax.stop_gradient(log_c), jax.lax.stop_gradient(log_s)
    use_cdf = ls0 > _LOG_HALF
    lo, upper = d0.support()
    scale = d0.scale()

    def grow(_, w):
        x = jnp.minimum(lo + w, upper)
        return jnp.where((d0._logsf(x) > ls0) & (x < upper), 2.0 * w, w)

    width = jax.lax.fori_loop(0, _DOUBLING_STEPS, grow, scale)
    hi = jnp.minimum(lo + width, upper)

    def bisect(_, c):
        a, b = c
        m = 0.5 * (a + b)
        r = _level_residual(d0, m, lc0, ls0, use_cdf)
        return jnp.where(r > 0, a, m), jnp.where(r > 0, m, b)

    a, b = jax.lax.fori_loop(0, _BISECTION_STEPS, bisect, (lo, hi))
    x0 = 0.5 * (a + b)
    # One Newton step at the root with live parameters: zero change in value, implicit-function-theorem
    # gradient.
    r = _level_residual(dist, x0, log_c, log_s, use_cdf)
    ref = jnp.where(use_cdf, d0._logcdf(x0), d0._logsf(x0))
    slope = jnp.exp(d0._logpdf(x0) - ref)
    ok = jnp.isfinite(r) & jnp.isfinite(slope) & (slope > 0)
    corr = jnp.where(ok, -r / jnp.where(ok, slope, 1.0), 0.0)
    return x0 + (corr - jax.lax.stop_gradient(corr))


def _solve_levels(dist, log_c, log_s):
    log_c, log_s = jnp.broadcast_arrays(jnp.asarray(log_c, float), jnp.asarray(log_s, float))
    flat = jax.vmap(lambda c, s: _solve_level(dist, c, s))(log_c.ravel(), log_s.ravel())
    return flat.reshape(log_c.shape)


_solve_levels_jit = eqx.filter_jit(_solve_levels)


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


def max_logpdf(dist: AbstractAmplitudeDistribution, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\log P^*(a)$ [log(1/rad)] of the maximum of `n0` independent amplitudes.

    $\log P^* = \log N_0 + (N_0 - 1)\log(1 - \bar F(a)) + \log P(a)$, with $\log(1 - \bar F)$ from
    `dist.logcdf` (`log1p(−F̄)` in the tail). Finite wherever $P^* > 0$, even where $P^*$ itself underflows.

    **Arguments:**

    - `dist`: per-cycle amplitude distribution.
    - `a`: candidate maxima [rad], any shape.
    - `n0`: number of amplitudes $N_0$ (>= 1; need not be an integer).
    """
    n0 = _count_n0(n0)
    return _max_logpdf_jit(dist, jnp.asarray(a, dtype=float), n0)


_max_logpdf_jit = eqx.filter_jit(_max_logpdf)


def max_pdf(dist: AbstractAmplitudeDistribution, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$P^*(a) = N_0 [1 - \bar F(a)]^{N_0 - 1} P(a)$ [1/rad], the PDF of the maximum of `n0` amplitudes
    (computed as `exp(max_logpdf)`; arguments as there)."""
    return jnp.exp(max_logpdf(dist, a, n0))


def max_pdf_asymptotic(
    dist: AbstractAmplitudeDistribution, a: ArrayLike, n0: ArrayLike
) -> Float[Array, "..."]:
    r"""The asymptotic form of THEORY.md §7, $P^* \approx \xi e^{-\xi} [\bar F (1 - \bar F)]^{-1} P$,
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
    n0 = _count_n0(n0)
    return _max_pdf_asymptotic(dist, jnp.asarray(a, dtype=float), n0)


@eqx.filter_jit
def _max_pdf_asymptotic(dist, a, n0):
    xi = n0 * jnp.exp(dist._logsf(a))
    # ξ e^{−ξ} / F̄ = N0 e^{−ξ}: written this way it stays finite where F̄ underflows.
    return jnp.exp(jnp.log(n0) - xi - dist._logcdf(a) + dist._logpdf(a))


def max_logcdf(dist: AbstractAmplitudeDistribution, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\log \Pr(A_{\max} \le a) = N_0 \log(1 - \bar F(a))$ [-]."""
    n0 = _count_n0(n0)
    return _max_logcdf(dist, jnp.asarray(a, dtype=float), n0)


@eqx.filter_jit
def _max_logcdf(dist, a, n0):
    return n0 * dist._logcdf(a)


def max_cdf(dist: AbstractAmplitudeDistribution, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\Pr(A_{\max} \le a) = (1 - \bar F(a))^{N_0} = \exp(N_0\,\mathrm{log1p}(-\bar F))$ [-]."""
    return jnp.exp(max_logcdf(dist, a, n0))


def max_sf(dist: AbstractAmplitudeDistribution, a: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""$\Pr(A_{\max} > a) = 1 - (1 - \bar F)^{N_0}$ [-], as `-expm1(N0·log1p(−F̄))`: accurate when tiny."""
    return -jnp.expm1(max_logcdf(dist, a, n0))


def max_quantile(dist: AbstractAmplitudeDistribution, q: ArrayLike, n0: ArrayLike) -> Float[Array, "..."]:
    r"""The `q`-quantile [rad] of the maximum of `n0` amplitudes: $(1 - \bar F(a))^{N_0} = q$.

    Solved as $\bar F(a) = -\mathrm{expm1}(\log q / N_0)$, accurate for $N_0 = 10^7$. Differentiable.

    **Arguments:** `dist`; `q` in (0, 1), any shape; `n0` >= 1.
    """
    n0 = _count_n0(n0)
    q = _probability_levels(q)
    return _max_quantile(dist, q, n0)


@eqx.filter_jit
def _max_quantile(dist, q, n0):
    log_c = jnp.log(q) / n0
    return _solve_levels(dist, log_c, _log1mexp(log_c))


# Levels that bracket the work of `expected_maximum` and `most_probable_maximum`, as (log CDF, log F̄)
# targets of the per-cycle distribution: the mode scan runs between the 1e-15 and 1 − 1e-12 quantiles of the
# maximum; the E[max] integrand is 1 to within 1e-30 left of the first end and N0·F̄ < 1e-20 right of the
# second.
def _bracket_targets(n0):
    log_c_max = jnp.stack([jnp.log(1e-15), jnp.log1p(-1e-12), jnp.log(1e-30)]) / n0
    log_s_right = jnp.log(_UPPER_TAIL) - jnp.log(n0)
    log_c = jnp.concatenate([log_c_max, _log1mexp(log_s_right)[None]])
    log_s = jnp.concatenate([_log1mexp(log_c_max), log_s_right[None]])
    return log_c, log_s


def _expected_in(dist, n0, a_left, a_right, num_panels):
    lo_support, _ = dist.support()
    a_left = jax.lax.stop_gradient(jnp.maximum(a_left, lo_support))
    width = jax.lax.stop_gradient(a_right) - a_left

    def integrand(u):
        # a = a_left + width·u²: clusters nodes at a_left, which removes the √-type end-point singularity of
        # 1 − F̄ for Roberts-family PDFs with ν < 0 (and costs nothing for smooth integrands).
        return -jnp.expm1(n0 * dist._logcdf(a_left + width * u**2)) * 2.0 * width * u

    return a_left + _gauss_legendre(integrand, 0.0, 1.0, num_panels)


@eqx.filter_jit
def _expected_maximum(dist, n0, num_panels):
    log_c, log_s = _bracket_targets(n0)
    ends = _solve_levels(jax.lax.stop_gradient(dist), log_c[2:], log_s[2:])
    return _expected_in(dist, n0, ends[0], ends[1], num_panels)


def expected_maximum(
    dist: AbstractAmplitudeDistribution, n0: ArrayLike, *, num_panels: int = 256
) -> Float[Array, ""]:
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


@eqx.filter_jit
def _most_probable_maximum(dist, n0):
    log_c, log_s = _bracket_targets(n0)
    ends = _solve_levels(jax.lax.stop_gradient(dist), log_c[:2], log_s[:2])
    return _mode_in(dist, n0, ends[0], ends[1])


def most_probable_maximum(dist: AbstractAmplitudeDistribution, n0: ArrayLike) -> Float[Array, ""]:
    r"""The mode of $P^*$ [rad]: the most probable maximum of `n0` amplitudes.

    A 1025-point scan of $\log P^*$ between the $10^{-15}$ and $1 - 10^{-12}$ quantiles of the maximum,
    refined by golden-section search and one Newton step. Differentiable (implicit function theorem) where
    $\log P^*$ is twice differentiable at the mode (closed forms; tabulated PDFs give the derivative of the
    local piece). For a histogram from samples the mode follows the noise of the tail's PDF: prefer the
    characteristic largest value of `exposure_risk`, which needs only $\bar F$.

    **Arguments:** `dist`; `n0` >= 1.
    """
    n0 = _count_n0(n0)
    return _most_probable_maximum(dist, n0)


# ------------------------------------------------------------------------------------------------------------
# Exposure-time risk
# ------------------------------------------------------------------------------------------------------------


def _exposure_cycles(rate, duration):
    rate = _positive(
        rate,
        "rate",
        "[amplitudes/s]",
        " Use amplitudes counted per second, or 2/T_mean for zero-crossing amplitudes (two per roll cycle).",
    )
    duration = _positive(duration, "duration", "[s]", " It is the exposure time, e.g. 3 h = 10800 s.")
    return rate * duration


def _check_angle(angle):
    angle = jnp.asarray(angle, dtype=float)
    shown = "a traced value" if _is_traced(angle) else f"{np.asarray(angle)!r}"
    return _require(
        angle, ~(angle >= 0), f"`angle` must be >= 0 [rad]; got {shown}. Convert degrees with jnp.deg2rad."
    )


def exceedance_probability(
    dist: AbstractAmplitudeDistribution,
    angle: ArrayLike,
    *,
    rate: ArrayLike,
    duration: ArrayLike,
    poisson: bool = False,
) -> Float[Array, "..."]:
    r"""Probability that the roll amplitude exceeds `angle` at least once within `duration`.

    With $n = \text{rate} \cdot \text{duration}$ independent amplitudes: $1 - (1 - \bar F(a))^n$
    (`-expm1(n·log1p(−F̄))`, accurate down to 1e-300). With `poisson=True`: $1 - e^{-n \bar F(a)}$, the
    probability of at least one event of a Poisson stream of exceedances with mean $n\bar F$; it is never
    larger, and the two differ by $O(n\bar F^2)$, negligible unless $\bar F$ itself is not small.

    **Arguments:**

    - `dist`: per-cycle (zero-crossing) amplitude distribution.
    - `angle`: roll angle [rad], >= 0, any shape.
    - `rate`: mean number of amplitudes per second [1/s] (2/T_z for zero-crossing amplitudes).
    - `duration`: exposure time [s].
    - `poisson`: use the Poisson form.

    **Returns:** the probability [-], shape of `angle`. Differentiable in the distribution's parameters.
    """
    n = _exposure_cycles(rate, duration)
    angle = _check_angle(angle)
    return _exceedance(dist, angle, n, poisson)


@eqx.filter_jit
def _exceedance(dist, angle, n, poisson):
    if poisson:
        return -jnp.expm1(-n * jnp.exp(dist._logsf(angle)))
    return -jnp.expm1(n * dist._logcdf(angle))


def wilson_interval(
    n_exceed: ArrayLike, n_total: ArrayLike, confidence: float = 0.95
) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
    r"""Wilson score interval for a binomial probability $p$ from `n_exceed` successes in `n_total` trials.

    $\hat p = k/n$, $z = \Phi^{-1}(1 - \alpha/2)$; bounds
    $\frac{\hat p + z^2/2n \pm z\sqrt{\hat p(1-\hat p)/n + z^2/4n^2}}{1 + z^2/n}$, the roots of
    $(\hat p - p)^2 = z^2 p(1 - p)/n$. The lower one is computed as $\hat p^2 / [(1 + z^2/n)\,\text{upper}]$
    so it keeps its relative accuracy for $\hat p \ll 1$. With $k = 0$ it is $[0, \approx z^2/n]$.
    Non-integer `n_exceed` is accepted ($n \hat p$ from an interpolated survival function).

    **Arguments:** `n_exceed` [-], `n_total` [-] (broadcastable arrays), `confidence` in (0, 1).

    **Returns:** `(lower, upper)` [-].
    """
    if not 0 < confidence < 1:
        raise ValueError(f"`confidence` must be in (0, 1); got {confidence!r}.")
    k = jnp.asarray(n_exceed, dtype=float)
    n = jnp.asarray(n_total, dtype=float)
    k = _require(k, (n < 1) | (k < 0) | (k > n),
                 f"need 0 <= successes <= trials and trials >= 1; got {n_exceed!r} of {n_total!r}.")
    z = jsp.ndtri(1.0 - 0.5 * (1.0 - confidence))
    p = k / n
    denom = 1.0 + z**2 / n
    centre = (p + z**2 / (2.0 * n)) / denom
    half = z / denom * jnp.sqrt(jnp.maximum(p * (1.0 - p) / n + z**2 / (4.0 * n**2), 0.0))
    upper = jnp.minimum(centre + half, 1.0)
    lower = p**2 / (denom * (centre + half))
    return lower, upper


def count_exceedances(amplitudes: ArrayLike, angle: ArrayLike) -> tuple[Array, Array]:
    r"""`(n_exceed, n_total)`: the number of finite amplitudes above `angle` [rad] and of finite amplitudes.

    `n_exceed / n_total` is the exact empirical $\bar F(\text{angle})$. Non-finite entries (capsized trials,
    NaN padding) are not counted.
    """
    x = jnp.ravel(jnp.asarray(amplitudes, dtype=float))
    ok = jnp.isfinite(x)
    return jnp.sum(ok & (x > angle)), jnp.sum(ok)


class ExposureRisk(eqx.Module):
    r"""Risk measures for an exposure of `duration` seconds. Angles in radians; `*_deg` properties in degrees.

    **Fields:**

    - `angle` [rad], `duration` [s], `rate` [1/s], `n_cycles` $n$ = rate·duration [-].
    - `exceedance_per_cycle`: $\hat F = \bar F(\text{angle})$ [-]; `exceedance_per_cycle_lower/upper`: its
      Wilson interval.
    - `probability`: $1 - (1 - \hat F)^n$ [-], at least one exceedance within the exposure (independent
      amplitudes); `probability_poisson`: $1 - e^{-n\hat F}$; `probability_lower/upper`: the Wilson bounds of
      $\bar F$ mapped through the increasing map $\bar F \mapsto 1 - (1 - \bar F)^n$, so they cover exactly as
      often as the Wilson interval does.
    - `most_probable_largest` [rad]: the mode of the PDF of the largest of $n$ amplitudes.
    - `characteristic_largest` [rad]: the $e^{-1}$-quantile of the largest, $\bar F(a) = 1 - e^{-1/n}
      \approx 1/n$. It is the mode of the Gumbel limit and equals `most_probable_largest` up to
      $O(1/\log n)$ (0.45 % for Rayleigh at $n = 1800$), but it needs only $\bar F$, not the noisy tail of a
      histogram PDF: prefer it for Monte Carlo input. `characteristic_largest_lower/upper`: the Wilson band of
      $\bar F$ propagated through this quantile (bootstrap-free; `upper` is `inf` when the sample has too few
      exceedances to bound it).
    - `expected_largest` [rad]: $E[A_{\max}]$ for $n$ amplitudes.
    - `n_amplitudes`: the sample size behind the intervals; NaN, and NaN intervals, when none is known.
    - `confidence` [-]: the level of the intervals.
    """

    angle: Float[Array, ""]
    duration: Float[Array, ""]
    rate: Float[Array, ""]
    n_cycles: Float[Array, ""]
    exceedance_per_cycle: Float[Array, ""]
    exceedance_per_cycle_lower: Float[Array, ""]
    exceedance_per_cycle_upper: Float[Array, ""]
    probability: Float[Array, ""]
    probability_poisson: Float[Array, ""]
    probability_lower: Float[Array, ""]
    probability_upper: Float[Array, ""]
    most_probable_largest: Float[Array, ""]
    characteristic_largest: Float[Array, ""]
    characteristic_largest_lower: Float[Array, ""]
    characteristic_largest_upper: Float[Array, ""]
    expected_largest: Float[Array, ""]
    n_amplitudes: Float[Array, ""]
    confidence: float = eqx.field(static=True, default=0.95)

    @property
    def angle_deg(self) -> Float[Array, ""]:
        """`angle` [deg]."""
        return jnp.rad2deg(self.angle)

    @property
    def most_probable_largest_deg(self) -> Float[Array, ""]:
        """`most_probable_largest` [deg]."""
        return jnp.rad2deg(self.most_probable_largest)

    @property
    def characteristic_largest_deg(self) -> Float[Array, ""]:
        """`characteristic_largest` [deg]."""
        return jnp.rad2deg(self.characteristic_largest)

    @property
    def characteristic_largest_lower_deg(self) -> Float[Array, ""]:
        """`characteristic_largest_lower` [deg]."""
        return jnp.rad2deg(self.characteristic_largest_lower)

    @property
    def characteristic_largest_upper_deg(self) -> Float[Array, ""]:
        """`characteristic_largest_upper` [deg]."""
        return jnp.rad2deg(self.characteristic_largest_upper)

    @property
    def expected_largest_deg(self) -> Float[Array, ""]:
        """`expected_largest` [deg]."""
        return jnp.rad2deg(self.expected_largest)


def exposure_risk(
    dist: AbstractAmplitudeDistribution,
    angle: ArrayLike,
    *,
    rate: ArrayLike,
    duration: ArrayLike,
    confidence: float = 0.95,
    n_amplitudes: ArrayLike | None = None,
    n_exceed: ArrayLike | None = None,
) -> ExposureRisk:
    r"""The risk measures a naval architect asks for, for one threshold angle and one exposure time.

    **Arguments:**

    - `dist`: per-cycle (zero-crossing) amplitude distribution, e.g. `AmplitudeDistribution.from_samples`
      of the Monte Carlo amplitudes.
    - `angle`: threshold roll angle [rad], scalar (e.g. `jnp.deg2rad(30.0)`).
    - `rate`: mean number of amplitudes per second [1/s]: amplitudes counted / time simulated, or 2/T_z.
    - `duration`: exposure time [s] (3 h = 10800 s).
    - `confidence`: level of the intervals, in (0, 1).
    - `n_amplitudes`: the number of amplitudes behind `dist`'s survival function, for the intervals.
      Defaults to `dist.n_samples` for `from_samples` distributions, otherwise no intervals. Successive
      amplitudes of one record are correlated; pass an effective sample size if you know it (the intervals
      assume independence).
    - `n_exceed`: counted amplitudes above `angle` (`count_exceedances`): then
      $\hat F$ = `n_exceed / n_amplitudes` exactly, instead of `dist.survival(angle)`.

    **Returns:** an `ExposureRisk`.

    **Raises:** `ValueError` for a negative or non-scalar angle, non-positive rate/duration/n_amplitudes, a
    confidence outside (0, 1), `n_exceed` without `n_amplitudes`, or `n_exceed` outside [0, n_amplitudes].
    """
    n = _exposure_cycles(rate, duration)
    angle = _check_angle(angle)
    if angle.shape != ():
        raise ValueError(
            f"`angle` must be a scalar; got shape {angle.shape}. Call exposure_risk once per angle."
        )
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"`confidence` must lie strictly between 0 and 1; got {confidence!r}.")
    if n_amplitudes is None and isinstance(dist, AmplitudeDistribution) and dist.n_samples is not None:
        n_amplitudes = dist.n_samples
    if n_exceed is not None and n_amplitudes is None:
        raise ValueError("`n_exceed` needs `n_amplitudes` (the number of amplitudes it was counted among).")
    if n_amplitudes is None:
        n_amp = jnp.asarray(jnp.nan)
    else:
        n_amp = _positive(n_amplitudes, "n_amplitudes", "[-]", " It is the number of amplitudes counted.")
    if n_exceed is None:
        k = None
    else:
        k = _scalar(n_exceed, "n_exceed")
        shown = "a traced value" if _is_traced(k) else f"{float(k)!r}"
        k = _require(k, ~((k >= 0) & (k <= n_amp)), f"`n_exceed` must lie in [0, n_amplitudes]; got {shown}.")
    rate = jnp.asarray(rate, dtype=float)
    duration = jnp.asarray(duration, dtype=float)
    return _exposure_risk(dist, angle, n, rate, duration, n_amp, k, confidence)


@eqx.filter_jit
def _exposure_risk(dist, angle, n, rate, duration, n_amp, k, confidence):
    if k is None:
        p = jnp.exp(dist._logsf(angle))
        log_c = dist._logcdf(angle)
    else:
        p = k / n_amp
        log_c = jnp.log1p(-p)
    p_lo, p_hi = wilson_interval(p * n_amp, n_amp, confidence)
    binom = lambda lc: -jnp.expm1(n * lc)  # noqa: E731
    # Characteristic largest: F̄(a) = p_c = 1 − e^{−1/n}. Its interval by inverting the Wilson score test at
    # the fixed level p_c: F̄_upper(a) = p_c ⇔ F̄(a) = p_c − z·SE(p_c), and F̄_lower(a) = p_c ⇔ + z·SE(p_c).
    p_c = -jnp.expm1(-1.0 / n)
    z = jsp.ndtri(1.0 - 0.5 * (1.0 - confidence))
    se = z * jnp.sqrt(p_c * (1.0 - p_c) / n_amp)
    s = jnp.stack([p_c, jnp.minimum(p_c + se, 1.0), p_c - se])
    s_safe = jnp.where(s > 0, s, 0.5)
    # One batched root solve for every level: the interval, and the brackets of the mode and of E[max].
    bracket_c, bracket_s = _bracket_targets(n)
    solved = _solve_levels(
        dist, jnp.concatenate([jnp.log1p(-s_safe), bracket_c]), jnp.concatenate([jnp.log(s_safe), bracket_s])
    )
    levels = jnp.where(s > 0, solved[:3], jnp.inf)
    ends = solved[3:]
    no_ci = jnp.isnan(n_amp)
    nan = jnp.asarray(jnp.nan)
    return ExposureRisk(
        angle=angle,
        duration=duration,
        rate=rate,
        n_cycles=n,
        exceedance_per_cycle=p,
        exceedance_per_cycle_lower=jnp.where(no_ci, nan, p_lo),
        exceedance_per_cycle_upper=jnp.where(no_ci, nan, p_hi),
        probability=binom(log_c),
        probability_poisson=-jnp.expm1(-n * p),
        probability_lower=jnp.where(no_ci, nan, binom(jnp.log1p(-p_lo))),
        probability_upper=jnp.where(no_ci, nan, binom(jnp.log1p(-p_hi))),
        most_probable_largest=_mode_in(dist, n, ends[0], ends[1]),
        characteristic_largest=levels[0],
        characteristic_largest_lower=jnp.where(no_ci, nan, levels[1]),
        characteristic_largest_upper=jnp.where(no_ci, nan, levels[2]),
        expected_largest=_expected_in(dist, n, ends[2], ends[3], 256),
        n_amplitudes=n_amp,
        confidence=confidence,
    )


# ------------------------------------------------------------------------------------------------------------
# Empirical maxima from Monte Carlo
# ------------------------------------------------------------------------------------------------------------


def maxima_of_first(amplitudes: Float[ArrayLike, "trials m"], n0: int) -> Float[Array, " trials"]:
    r"""Per-trial maximum [rad] of the first `n0` amplitudes (the THEORY.md §7 protocol).

    **Arguments:**

    - `amplitudes`: per-trial amplitudes [rad], shape (trials, m), in time order after the discarded
      transient, NaN-padded where a trial has fewer than m amplitudes.
    - `n0`: number of amplitudes per maximum; 1 <= n0 <= m.

    **Returns:** shape (trials,); NaN for a trial with fewer than `n0` finite amplitudes (short or capsized),
    which `empirical_maxima` then excludes and counts.
    """
    x = jnp.asarray(amplitudes, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"`amplitudes` must have shape (trials, m); got shape {x.shape}.")
    if not isinstance(n0, int | np.integer) or not 1 <= n0 <= x.shape[1]:
        raise ValueError(
            f"`n0` must be an integer in [1, {x.shape[1]}] (the number of amplitudes per trial); got {n0!r}. "
            "Simulate longer trials to get more amplitudes."
        )
    first = x[:, :n0]
    return jnp.where(jnp.all(jnp.isfinite(first), axis=1), jnp.max(first, axis=1), jnp.nan)


class EmpiricalMaxima(eqx.Module):
    r"""Statistics of per-trial maxima from a Monte Carlo. Radians; `*_deg` properties in degrees.

    **Fields:**

    - `n_trials`: finite maxima used; `n_excluded`: non-finite maxima left out (capsized/short trials).
    - `mean` [rad] and `mean_se` = std/√N; `std` [rad] (sample, ddof = 1).
    - `levels`: quantile levels [-]; `quantiles` [rad] (linear interpolation between order statistics, as
      `numpy.quantile`); `quantile_lower`/`_upper`: the distribution-free order-statistic interval
      $[X_{(j)}, X_{(k)}]$, $j, k = Nq \mp z\sqrt{Nq(1-q)}$; `quantile_se` = its half-width / z.
    - `edges` [rad] (bins + 1), `pdf` [1/rad] histogram density, `pdf_se` [1/rad] its binomial standard error.
    """

    n_trials: Array
    n_excluded: Array
    mean: Float[Array, ""]
    mean_se: Float[Array, ""]
    std: Float[Array, ""]
    levels: Float[Array, " k"]
    quantiles: Float[Array, " k"]
    quantile_lower: Float[Array, " k"]
    quantile_upper: Float[Array, " k"]
    quantile_se: Float[Array, " k"]
    edges: Float[Array, " bins+1"]
    pdf: Float[Array, " bins"]
    pdf_se: Float[Array, " bins"]
    confidence: float = eqx.field(static=True, default=0.95)

    @property
    def mean_deg(self) -> Float[Array, ""]:
        """`mean` in degrees."""
        return jnp.rad2deg(self.mean)

    @property
    def quantiles_deg(self) -> Float[Array, " k"]:
        """`quantiles` in degrees."""
        return jnp.rad2deg(self.quantiles)

    @property
    def centres(self) -> Float[Array, " bins"]:
        """Bin centres [rad]."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])


def empirical_maxima(
    maxima: Float[ArrayLike, " trials"],
    *,
    bins: int | Float[ArrayLike, " m+1"] = 50,
    levels: Sequence[float] = (0.5, 0.9, 0.99),
    confidence: float = 0.95,
) -> EmpiricalMaxima:
    r"""Histogram PDF, mean and quantiles, with bootstrap-free standard errors, of Monte Carlo maxima.

    **Arguments:**

    - `maxima`: per-trial maxima [rad] (e.g. `maxima_of_first(amplitudes, n0)`), shape (trials,); non-finite
      entries are left out and counted in `n_excluded`.
    - `bins`: number of equal bins on [0, max], or bin edges [rad] covering every finite maximum.
    - `levels`: quantile levels in (0, 1).
    - `confidence`: level of the quantile intervals.

    **Returns:** an `EmpiricalMaxima`.
    """
    x = jnp.asarray(maxima, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"`maxima` must be 1-D (one maximum per trial); got shape {x.shape}.")
    levels_arr = np.asarray(levels, dtype=float)
    if levels_arr.ndim != 1 or not np.all((levels_arr > 0) & (levels_arr < 1)):
        raise ValueError(f"`levels` must be quantile levels strictly between 0 and 1; got {levels!r}.")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"`confidence` must lie strictly between 0 and 1; got {confidence!r}.")
    finite = jnp.isfinite(x)
    n = int(np.sum(np.asarray(finite)))
    if n < 2:
        raise ValueError(f"`maxima` has {n} finite value(s); at least 2 are needed for statistics.")
    xs = jnp.sort(x[finite])
    if float(xs[0]) < 0:
        raise ValueError(
            f"Maxima of amplitudes are non-negative; got {float(xs[0])!r}. Pass absolute values."
        )
    if isinstance(bins, int | np.integer) and not isinstance(bins, bool):
        if bins < 1:
            raise ValueError(f"`bins` must be a positive number of bins or an array of edges; got {bins}.")
        edges = jnp.linspace(0.0, xs[-1], bins + 1)
    else:
        edges = jnp.asarray(bins, dtype=float)
        if edges.ndim != 1 or edges.shape[0] < 2 or bool(jnp.any(jnp.diff(edges) <= 0)):
            raise ValueError("`bins` as edges must be 1-D, strictly increasing, with at least 2 values.")
        if float(xs[0]) < float(edges[0]) or float(xs[-1]) > float(edges[-1]):
            raise ValueError(
                f"The maxima [{float(xs[0])!r}, {float(xs[-1])!r}] reach outside the bin edges "
                f"[{float(edges[0])!r}, {float(edges[-1])!r}]; widen the edges."
            )
    return _empirical_maxima(xs, edges, jnp.asarray(levels_arr), jnp.asarray(x.shape[0] - n), confidence)


@eqx.filter_jit
def _empirical_maxima(xs, edges, levels, n_excluded, confidence):
    n = xs.shape[0]
    mean = jnp.mean(xs)
    std = jnp.std(xs, ddof=1)
    quantiles = jnp.quantile(xs, levels)
    z = jsp.ndtri(1.0 - 0.5 * (1.0 - confidence))
    spread = z * jnp.sqrt(n * levels * (1.0 - levels))
    j = jnp.clip(jnp.floor(n * levels - spread).astype(int), 1, n) - 1
    k = jnp.clip(jnp.ceil(n * levels + spread).astype(int), 1, n) - 1
    q_lo, q_hi = xs[j], xs[k]
    counts, _ = jnp.histogram(xs, bins=edges)
    width = jnp.diff(edges)
    return EmpiricalMaxima(
        n_trials=jnp.asarray(n),
        n_excluded=n_excluded,
        mean=mean,
        mean_se=std / jnp.sqrt(n),
        std=std,
        levels=levels,
        quantiles=quantiles,
        quantile_lower=q_lo,
        quantile_upper=q_hi,
        quantile_se=(q_hi - q_lo) / (2.0 * z),
        edges=edges,
        pdf=counts / (n * width),
        pdf_se=jnp.sqrt(counts * (1.0 - counts / n)) / (n * width),
        confidence=confidence,
    )
