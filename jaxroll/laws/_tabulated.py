"""Tabulated amplitude laws: a PDF on a grid, from a theory, a histogram or samples."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._compiled import require
from ._abstract import AbstractAmplitudeLaw, check_estimator
from ._checks import _NEG_PDF_HINT, _check_table, _first_bad_message, _is_traced


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


class TabulatedAmplitudeLaw(AbstractAmplitudeLaw):
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

    Build it with `TabulatedAmplitudeLaw.from_pdf`, `.from_logpdf` or `.from_samples`.
    """

    grid: Float[Array, " n"]
    pdf_values: Float[Array, " n"]
    log_pdf: Float[Array, " n"]
    log_mass: Float[Array, " n-1"]
    log_sf_nodes: Float[Array, " n"]
    log_cdf_nodes: Float[Array, " n"]
    estimator: str = eqx.field(static=True)
    n_samples: int | None = eqx.field(static=True, default=None)

    def __init__(
        self,
        grid: Float[ArrayLike, " n"],
        log_pdf: Float[ArrayLike, " n"],
        log_mass: Float[ArrayLike, " n-1"],
        n_samples: int | None = None,
        *,
        estimator: str = "zero_crossing",
    ):
        grid = jnp.asarray(grid, dtype=float)
        log_pdf = jnp.asarray(log_pdf, dtype=float)
        log_mass = jnp.asarray(log_mass, dtype=float)
        if grid.ndim != 1 or log_pdf.shape != grid.shape or log_mass.shape != (grid.shape[0] - 1,):
            raise ValueError(
                "`grid` and `log_pdf` must be 1-D of the same length n and `log_mass` of length n − 1; got "
                f"shapes {grid.shape}, {log_pdf.shape}, {log_mass.shape}. "
                "Use TabulatedAmplitudeLaw.from_pdf(grid, pdf)."
            )
        self.grid = grid
        self.log_pdf, self.pdf_values, self.log_mass, self.log_sf_nodes, self.log_cdf_nodes = _tabulate(
            log_pdf, log_mass
        )
        self.n_samples = n_samples
        self.estimator = check_estimator(estimator)

    # -- constructors ----------------------------------------------------------------------------------------

    @classmethod
    def from_pdf(
        cls, grid: Float[ArrayLike, " n"], pdf: Float[ArrayLike, " n"], *, estimator: str = "zero_crossing"
    ) -> "TabulatedAmplitudeLaw":
        """A distribution from PDF values on a grid (normalised here with the trapezoidal rule).

        **Arguments:**

        - `grid`: amplitudes [rad], 1-D, strictly increasing, >= 0, at least 3 points. Extend it far
          enough into the tail: there is no mass beyond `grid[-1]`.
        - `pdf`: PDF values [1/rad] at `grid`, finite and >= 0 (any normalisation).

        **Raises:** `ValueError` naming the offending index and value for a bad grid or PDF.
        """
        grid, pdf = _check_table(grid, pdf, "pdf")
        pdf = require(pdf, pdf < 0, _first_bad_message(pdf, pdf < 0, "pdf", "must be >= 0", _NEG_PDF_HINT))
        log_pdf = jnp.log(pdf)
        return cls._from_log_nodes(grid, log_pdf, estimator)

    @classmethod
    def from_logpdf(
        cls,
        grid: Float[ArrayLike, " n"],
        log_pdf: Float[ArrayLike, " n"],
        *,
        estimator: str = "zero_crossing",
    ) -> "TabulatedAmplitudeLaw":
        """A distribution from log-PDF values on a grid, for tails below the float64 range (`log p = −900`).

        **Arguments:**

        - `grid`: amplitudes [rad], as in `from_pdf`.
        - `log_pdf`: log of the PDF [log(1/rad)] at `grid`, any additive constant; `-inf` marks zero density,
          NaN and `+inf` are rejected.
        """
        grid, log_pdf = _check_table(grid, log_pdf, "log_pdf", allow_neg_inf=True)
        return cls._from_log_nodes(grid, log_pdf, estimator)

    @classmethod
    def _from_log_nodes(cls, grid, log_pdf, estimator):
        h = jnp.diff(grid)
        log_mass = jnp.log(0.5 * h) + jnp.logaddexp(log_pdf[:-1], log_pdf[1:])
        total = jax.scipy.special.logsumexp(log_mass)
        shown = "" if _is_traced(total) else " (every value is 0 or −inf)"
        log_mass = require(
            log_mass,
            ~jnp.isfinite(total),
            f"The PDF integrates to 0 on the grid{shown}; tabulate it where the amplitudes actually lie.",
        )
        return cls(grid, log_pdf, log_mass, estimator=estimator)

    @classmethod
    def from_samples(
        cls,
        amplitudes: Float[ArrayLike, "..."],
        bins: int | Float[ArrayLike, " m+1"] = 100,
        *,
        estimator: str = "zero_crossing",
    ) -> "TabulatedAmplitudeLaw":
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
        x = require(
            x,
            bad,
            f"`amplitudes` contains {count} non-finite value(s) (capsized or failed trials?). Drop them "
            "first, e.g. `a[jnp.isfinite(a)]`, and count them separately as capsizes.",
        )
        x = require(
            x, x < 0, _first_bad_message(x, x < 0, "amplitudes", "must be >= 0", " Pass absolute values |φ|.")
        )
        xs = jax.jit(jnp.sort)(x)
        if isinstance(bins, int | np.integer) and not isinstance(bins, bool):
            if bins < 1:
                raise ValueError(
                    f"`bins` must be a positive number of bins or an array of edges; got {bins}."
                )
            top = require(xs[-1], xs[-1] <= 0, "All amplitudes are 0; there is no distribution to tabulate.")
            edges = jnp.linspace(0.0, top, bins + 1)
        else:
            edges = jnp.asarray(bins, dtype=float)
            if edges.ndim != 1 or edges.shape[0] < 2:
                raise ValueError(
                    f"`bins` as edges must be 1-D with at least 2 values; got shape {edges.shape}."
                )
            d = jnp.diff(edges)
            edges = require(
                edges,
                d <= 0,
                _first_bad_message(
                    d, d <= 0, "diff(bins)", "must be > 0", " Bin edges must be strictly increasing."
                ),
            )
            outside = (xs[0] < edges[0]) | (xs[-1] > edges[-1])
            shown = "" if _is_traced(outside) else f" [{float(xs[0])!r}, {float(xs[-1])!r}]"
            edges = require(
                edges,
                outside,
                f"The samples{shown} reach outside the bin edges [edges[0], edges[-1]]; widen the edges: "
                "samples beyond the last edge would be dropped from the tail, which is exactly what maxima "
                "depend on.",
            )
        grid, log_pdf, log_mass = _histogram_table(xs, edges)
        return cls(grid, log_pdf, log_mass, n_samples=n, estimator=estimator)

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


TabulatedAmplitudeLaw.__init__.__doc__ = """Low-level constructor; most users call `from_pdf`, `from_logpdf`
or `from_samples`.

**Arguments:**

- `grid`: increasing amplitudes [rad], shape (n,).
- `log_pdf`: log PDF at the nodes (any additive constant), shape (n,).
- `log_mass`: log probability mass of each segment (same constant), shape (n − 1,).
- `n_samples`: the sample size when the table comes from samples, else `None`.
"""


def law_from_histogram(
    counts, edges, *, estimator: str, n_samples: int | None = None
) -> TabulatedAmplitudeLaw:
    """The law of a histogram: `counts` in bins with `edges` [rad], PDF at the bin centres (repeated at the two
    outer edges, like `from_samples`), segment masses exact. Counts beyond the last edge must be folded into the
    last bin by the caller (and reported: there is no mass beyond `edges[-1]`).

    **Raises:** `ValueError` when the histogram is empty (no amplitude to make a law of).
    """
    counts = np.asarray(counts, dtype=float)
    edges = np.asarray(edges, dtype=float)
    total = counts.sum()
    if not total > 0:
        raise ValueError("The histogram is empty: there are no amplitudes to make a law of.")
    density = counts / total / np.diff(edges)
    centres = 0.5 * (edges[1:] + edges[:-1])
    grid = np.concatenate([edges[:1], centres, edges[-1:]])
    with np.errstate(divide="ignore"):
        log_pdf = np.log(np.concatenate([density[:1], density, density[-1:]]))
        half = np.concatenate([[0.0], counts / 2, [0.0]])
        mass = (half[:-1] + half[1:]) / total
        log_mass = np.log(mass)
    return TabulatedAmplitudeLaw(grid, log_pdf, log_mass, n_samples=n_samples, estimator=estimator)
