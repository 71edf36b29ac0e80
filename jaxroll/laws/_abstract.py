"""The amplitude-law abstraction every law in jaxroll implements."""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._compiled import filter_jit
from .._config import require_float64
from ._checks import (
    _BISECTION_STEPS,
    _DOUBLING_STEPS,
    _LOG_HALF,
    _UPPER_TAIL,
    _gauss_legendre,
    _log1mexp,
    _probability_levels,
)


@filter_jit
def _evaluate(kernel: str, dist, a, exp: bool = False):
    """`dist.<kernel>(a)`, or its exponential (in the same program: no eager XLA program per shape)."""
    out = getattr(dist, kernel)(a)
    return jnp.exp(out) if exp else out


ESTIMATORS = ("zero_crossing", "envelope")
SAMPLING = {"zero_crossing": "per half cycle", "envelope": "per time sample"}
QUANTILE_LEVELS = (0.5, 0.9, 0.99)


def check_estimator(estimator: str) -> str:
    """`estimator` if it is "zero_crossing" or "envelope", else a `ValueError` that says so."""
    if estimator not in ESTIMATORS:
        raise ValueError(
            f"`estimator` must be 'zero_crossing' (amplitudes per half cycle) or 'envelope' (Hilbert envelope, "
            f"per time sample); got {estimator!r}."
        )
    return estimator


class AbstractAmplitudeLaw(eqx.Module):
    r"""The law of a roll amplitude $A \ge 0$ [rad]: every amplitude distribution in jaxroll implements it.

    Monte Carlo histograms (`AmplitudeStatistics.law`), the theories (Roberts, ESAM, the moment method),
    the closed forms (`RayleighLaw`, `RobertsLaw`) and tables (`TabulatedAmplitudeLaw`) all answer the same
    calls, in radians: `pdf`, `cdf`, `sf`, their logs, `quantile`, `isf`, `mean`, and `summary` (the JSON
    fields, in degrees).

    Each law says what it is a law **of** (`estimator`):

    - `"zero_crossing"`: one amplitude per half roll cycle (the zero-crossing method). This is the law the
      maximum-value and risk formulas (`max_pdf`, `exposure_risk`, ...) need, and they refuse any other.
    - `"envelope"`: the Hilbert envelope sampled uniformly in time (a time-weighted law: slow, large swings
      weigh more). The stationary laws of stochastic averaging and of the moment method are of this kind.

    Subclasses provide the kernels of `logpdf`, `logsf` ($\log \bar F$) and `logcdf` ($\log(1 - \bar F)$),
    each accurate in its own tail, plus `support`, `scale` and the `estimator` field.
    """

    estimator: eqx.AbstractVar[str]

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

    @property
    def sampling(self) -> str:
        """ "per half cycle" (zero-crossing amplitudes) or "per time sample" (envelope)."""
        return SAMPLING[self.estimator]

    def _repr_html_(self) -> str | None:
        """Jupyter's view: what the law is of, its mean, quantiles and exceedance probabilities [deg]; None (the
        plain repr) for a batch of laws (arrays of parameters)."""
        from .._display import html_table

        try:
            s = self.summary()
            exceed = np.asarray(self.sf(np.deg2rad(np.array([10.0, 20.0, 30.0]))))
        except Exception:  # a batch of laws has no single mean: IPython then shows the plain repr
            return None
        rows = [
            ("estimator", f"{self.estimator} ({self.sampling})", ""),
            ("mean amplitude", s["mean_amplitude_deg"], "deg"),
        ]
        rows += [(f"{k} % quantile", v, "deg") for k, v in s["quantiles_deg"].items()]
        rows += [(f"P(A > {a:g}°)", p, "-") for a, p in zip((10, 20, 30), exceed, strict=True)]
        return html_table(
            f"{type(self).__name__}: law of the roll amplitude A", rows, header=("", "value", "unit")
        )

    def logpdf(self, a: ArrayLike) -> Float[Array, "..."]:
        """log P(a), P in [1/rad]; −inf outside the support. `a` [rad], any shape."""
        _require_float64(self, "logpdf")
        return _evaluate("_logpdf", self, jnp.asarray(a, dtype=float))

    def logsf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$\log \bar F(a) = \log \int_a^\infty P\,dA$ [-], accurate far into the upper tail."""
        _require_float64(self, "logsf")
        return _evaluate("_logsf", self, jnp.asarray(a, dtype=float))

    def logcdf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$\log(1 - \bar F(a))$ [-], accurate where $\bar F \to 0$ (as `log1p(−F̄)`) and where
        $\bar F \to 1$."""
        _require_float64(self, "logcdf")
        return _evaluate("_logcdf", self, jnp.asarray(a, dtype=float))

    def pdf(self, a: ArrayLike) -> Float[Array, "..."]:
        """P(a) [1/rad] at amplitudes `a` [rad]."""
        _require_float64(self, "pdf")
        return _evaluate("_logpdf", self, jnp.asarray(a, dtype=float), True)

    def sf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""Survival $\bar F(a) = \Pr(A > a)$ [-] at amplitudes `a` [rad]."""
        _require_float64(self, "sf")
        return _evaluate("_logsf", self, jnp.asarray(a, dtype=float), True)

    def cdf(self, a: ArrayLike) -> Float[Array, "..."]:
        r"""$1 - \bar F(a) = \Pr(A \le a)$ [-] at amplitudes `a` [rad]."""
        _require_float64(self, "cdf")
        return _evaluate("_logcdf", self, jnp.asarray(a, dtype=float), True)

    def quantile(self, q: ArrayLike) -> Float[Array, "..."]:
        """The amplitude [rad] with `cdf(a) = q`, 0 < q < 1, any shape. Differentiable (implicit function)."""
        _require_float64(self, "quantile")
        q = _probability_levels(q)
        return _solve_levels_jit(self, jnp.log(q), jnp.log1p(-q))

    def isf(self, s: ArrayLike) -> Float[Array, "..."]:
        r"""Inverse survival: the amplitude [rad] with $\bar F(a) = s$, accurate for tiny `s` (e.g. 1e-12)."""
        _require_float64(self, "isf")
        s = _probability_levels(s, "s")
        return _solve_levels_jit(self, jnp.log1p(-s), jnp.log(s))

    def mean(self) -> Float[Array, ""]:
        r"""Mean amplitude [rad], $\int_0^\infty \bar F\,da$ (Gauss–Legendre; the $N_0 = 1$ case of
        `expected_maximum`)."""
        _require_float64(self, "mean")
        return _expected_maximum(self, jnp.asarray(1.0), 256)

    def pdf_per_degree(self, bins_deg: ArrayLike) -> np.ndarray:
        """Mean density per degree over each bin of the edges `bins_deg` [deg] (probability of the bin / width),
        the form in which every PDF is written to JSON and drawn."""
        edges = np.deg2rad(np.asarray(bins_deg, dtype=float))
        cdf = np.asarray(self.cdf(edges))
        return np.diff(cdf) / np.diff(np.asarray(bins_deg, dtype=float))

    def summary(self, bins_deg: ArrayLike | None = None, levels=QUANTILE_LEVELS) -> dict:
        """The law as plain numbers for JSON and figures (angles in **degrees**, the I/O edge):
        `estimator`, `amplitude_sampling`, `mean_amplitude_deg`, `quantiles_deg` ({"50": …, "90": …, "99": …}),
        `mass_beyond_grid` and, with `bins_deg`, `bins_deg` and `pdf_per_degree`."""
        out = {
            "estimator": self.estimator,
            "amplitude_sampling": self.sampling,
            "mean_amplitude_deg": float(np.rad2deg(self.mean())),
            "quantiles_deg": {
                f"{round(q * 100):d}": float(np.rad2deg(v))
                for q, v in zip(levels, np.asarray(self.quantile(jnp.asarray(levels))), strict=True)
            },
        }
        if bins_deg is not None:
            bins = np.asarray(bins_deg, dtype=float)
            out["bins_deg"] = bins
            out["pdf_per_degree"] = self.pdf_per_degree(bins)
            out["mass_beyond_grid"] = float(self.sf(np.deg2rad(bins[-1])))
        return out

    def to_xarray(self, amplitude_deg: ArrayLike | None = None):
        """The law as an `xarray.Dataset` on the amplitude grid `amplitude_deg` [deg] (default: 0.1° steps from 0 to
        the end of the support, or to the amplitude exceeded with probability 1e-12 where the support is
        unbounded): `pdf_per_degree` [1/deg], `sf` and `cdf` [-], the `summary()` numbers (`mean_amplitude_deg`,
        `quantiles_deg` on `percentile`), and as attributes the law's type, `estimator` and `amplitude_sampling`.
        `amplitude_rad` is a second coordinate (the law's own unit)."""
        from .._labels import Layout, labelled_values, merge, tree_to_dataset

        if amplitude_deg is None:
            lo, hi = (float(v) for v in self.support())
            top = hi if np.isfinite(hi) else float(self.isf(1e-12))
            amplitude_deg = np.arange(0.0, np.rad2deg(top) + 0.1, 0.1)
        grid = np.asarray(amplitude_deg, dtype=float)
        rad = np.deg2rad(grid)
        summary = self.summary()
        text = {k: summary.pop(k) for k in ("estimator", "amplitude_sampling")}
        ds = tree_to_dataset(
            summary,
            Layout(
                labels={"quantiles_deg": "percentile"}, coords={"percentile": ("percent", "quantile level")}
            ),
        )
        a = ("amplitude_deg",)
        return merge(
            ds,
            labelled_values(
                {
                    "pdf_per_degree": (
                        a,
                        np.asarray(self.pdf(rad)) * np.pi / 180,
                        "degree-1",
                        "PDF of the amplitude per degree",
                    ),
                    "sf": (a, np.asarray(self.sf(rad)), "1", "P(A > amplitude)"),
                    "cdf": (a, np.asarray(self.cdf(rad)), "1", "P(A <= amplitude)"),
                },
                coords={
                    "amplitude_deg": (a, grid, "degree", "roll amplitude A"),
                    "amplitude_rad": (a, rad, "rad", "roll amplitude A"),
                },
                attrs={"law": type(self).__name__, **text},
            ),
        )


def _require_float64(law: AbstractAmplitudeLaw, method: str) -> None:
    """`require_float64`, naming the law's method (e.g. "RobertsLaw.sf"); the laws' public methods call it."""
    if not jax.config.jax_enable_x64:
        require_float64(f"{type(law).__name__}.{method}")


def require_zero_crossing(law: AbstractAmplitudeLaw, what: str) -> None:
    """Refuse a law of envelope amplitudes where the per-half-cycle law is needed (maxima, risk)."""
    if not isinstance(law, AbstractAmplitudeLaw):
        raise TypeError(f"{what} needs an amplitude law (an AbstractAmplitudeLaw); got {type(law).__name__}.")
    if law.estimator != "zero_crossing":
        raise ValueError(
            f"{what} needs the law of zero-crossing amplitudes (one per half cycle), but this "
            f"{type(law).__name__} is a law of {law.estimator} amplitudes ({law.sampling}). Counting maxima "
            "over time samples is not counting them over cycles (docs/maxima.md). Ask the source for "
            "estimator='zero_crossing' (Monte Carlo: stats.law('zero_crossing'); theories: "
            "estimator='zero_crossing')."
        )


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


_solve_levels_jit = filter_jit(_solve_levels)


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


@filter_jit
def _expected_maximum(dist, n0, num_panels):
    log_c, log_s = _bracket_targets(n0)
    ends = _solve_levels(jax.lax.stop_gradient(dist), log_c[2:], log_s[2:])
    return _expected_in(dist, n0, ends[0], ends[1], num_panels)
