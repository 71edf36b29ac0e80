"""Empirical maxima from Monte Carlo amplitudes."""

from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import jax.scipy.special as jsp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._compiled import filter_jit

# ------------------------------------------------------------------------------------------------------------
# Empirical maxima from Monte Carlo
# ------------------------------------------------------------------------------------------------------------


def maxima_of_first(amplitudes: Float[ArrayLike, "trials m"], n0: int) -> Float[Array, " trials"]:
    r"""Per-trial maximum [rad] of the first `n0` amplitudes (the paper's maxima protocol, docs/maxima.md).

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


@filter_jit
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
