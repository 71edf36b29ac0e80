"""Exposure-time risk: the probability of exceeding an angle within an exposure, with confidence intervals."""

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.special as jsp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._compiled import filter_jit, require
from .._config import require_float64
from ..laws._abstract import (
    AbstractAmplitudeLaw,
    _bracket_targets,
    _expected_in,
    _solve_levels,
    require_zero_crossing,
)
from ..laws._checks import _is_traced, _positive, _scalar
from ..laws._tabulated import TabulatedAmplitudeLaw
from ._maxima import _mode_in

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
    return require(
        angle, ~(angle >= 0), f"`angle` must be >= 0 [rad]; got {shown}. Convert degrees with jnp.deg2rad."
    )


def exceedance_probability(
    dist: AbstractAmplitudeLaw,
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
    require_float64("jaxroll.exceedance_probability")
    require_zero_crossing(dist, "`exceedance_probability`")
    n = _exposure_cycles(rate, duration)
    angle = _check_angle(angle)
    return _exceedance(dist, angle, n, poisson)


@filter_jit
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
    k = require(
        k,
        (n < 1) | (k < 0) | (k > n),
        f"need 0 <= successes <= trials and trials >= 1; got {n_exceed!r} of {n_total!r}.",
    )
    return _wilson_bounds(k, n, confidence)


def _wilson_bounds(k, n, confidence: float):
    """`wilson_interval` of inputs already checked: no run-time check, so a compiled program that uses it has no
    host callback and JAX can keep it on disk between runs."""
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

    def _repr_html_(self) -> str | None:
        """Jupyter's view: the exposure, the exceedance probabilities with their intervals and the largest roll
        [deg]; None (the plain repr) for a batch of exposures."""
        from .._display import fmt_interval, html_table

        if any(jnp.ndim(leaf) for leaf in jax.tree_util.tree_leaves(self)):
            return None
        level = f"{self.confidence:.0%} interval"
        deg = lambda x: float(jnp.rad2deg(x))  # noqa: E731
        rows = [
            ("angle", deg(self.angle), "", "deg"),
            ("exposure", float(self.duration) / 3600, "", "h"),
            ("amplitudes in the exposure n", float(self.n_cycles), "", "-"),
            (
                "P(A > angle) per amplitude",
                float(self.exceedance_per_cycle),
                fmt_interval(self.exceedance_per_cycle_lower, self.exceedance_per_cycle_upper),
                "-",
            ),
            (
                "P(exceeded within the exposure)",
                float(self.probability),
                fmt_interval(self.probability_lower, self.probability_upper),
                "-",
            ),
            ("  the same, Poisson", float(self.probability_poisson), "", "-"),
            ("most probable largest roll", deg(self.most_probable_largest), "", "deg"),
            (
                "characteristic largest roll",
                deg(self.characteristic_largest),
                fmt_interval(deg(self.characteristic_largest_lower), deg(self.characteristic_largest_upper)),
                "deg",
            ),
            ("expected largest roll", deg(self.expected_largest), "", "deg"),
        ]
        note = (
            f"intervals from {float(self.n_amplitudes):.0f} amplitudes"
            if jnp.isfinite(self.n_amplitudes)
            else "no sample size given: no intervals"
        )
        return html_table("Exposure risk", rows, header=("", "value", level, "unit"), note=note)

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

    def to_xarray(self):
        """The risk measures as an `xarray.Dataset`, named as in risk.json (`probability`, `probability_ci95`,
        `characteristic_largest_deg`, …; intervals on `bound`, angles in degrees), with `angle_deg`, `duration_s`,
        `rate_per_s`, `n_amplitudes` and `confidence`. A batch of exposures (arrays of one dimension, e.g. from
        `jax.vmap` over angles) is laid out on the dimension `case`."""
        from .._labels import tree_to_dataset
        from .._labels._layouts import EXPOSURE

        def host(x, deg=False):
            x = np.asarray(x, dtype=float)
            if x.ndim > 1:
                raise ValueError(
                    f"`to_xarray` takes one exposure or a batch of one dimension; got shape {x.shape}."
                )
            return np.rad2deg(x) if deg else x

        def pair(lo, hi, deg=False):
            return np.stack([host(lo, deg), host(hi, deg)], -1)

        tree = {
            "angle_deg": host(self.angle, True),
            "duration_s": host(self.duration),
            "rate_per_s": host(self.rate),
            "n_amplitudes": host(self.n_amplitudes),
            "confidence": self.confidence,
            "n_cycles": host(self.n_cycles),
            "exceedance_per_cycle": host(self.exceedance_per_cycle),
            "exceedance_per_cycle_ci95": pair(
                self.exceedance_per_cycle_lower, self.exceedance_per_cycle_upper
            ),
            "probability": host(self.probability),
            "probability_poisson": host(self.probability_poisson),
            "probability_ci95": pair(self.probability_lower, self.probability_upper),
            "most_probable_largest_deg": host(self.most_probable_largest, True),
            "characteristic_largest_deg": host(self.characteristic_largest, True),
            "characteristic_largest_ci95_deg": pair(
                self.characteristic_largest_lower, self.characteristic_largest_upper, True
            ),
            "expected_largest_deg": host(self.expected_largest, True),
        }
        from .._labels import Layout

        batch = ("case",) if np.ndim(tree["angle_deg"]) == 1 else ()
        arrays = {
            k: (*batch, "bound") if k.endswith(("ci95", "ci95_deg")) else batch
            for k, v in tree.items()
            if np.ndim(v) > 0
        }
        return tree_to_dataset(tree, EXPOSURE + Layout(arrays=arrays, index={"bound": ("lower", "upper")}))


def exposure_risk(
    dist: AbstractAmplitudeLaw,
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

    - `dist`: per-cycle (zero-crossing) amplitude distribution, e.g. `TabulatedAmplitudeLaw.from_samples`
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
      $\hat F$ = `n_exceed / n_amplitudes` exactly, instead of `dist.sf(angle)`.

    **Returns:** an `ExposureRisk`.

    **Raises:** `ValueError` for a negative or non-scalar angle, non-positive rate/duration/n_amplitudes, a
    confidence outside (0, 1), `n_exceed` without `n_amplitudes`, or `n_exceed` outside [0, n_amplitudes].
    """
    require_float64("jaxroll.exposure_risk")
    require_zero_crossing(dist, "`exposure_risk`")
    n = _exposure_cycles(rate, duration)
    angle = _check_angle(angle)
    if angle.shape != ():
        raise ValueError(
            f"`angle` must be a scalar; got shape {angle.shape}. Call exposure_risk once per angle."
        )
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"`confidence` must lie strictly between 0 and 1; got {confidence!r}.")
    if n_amplitudes is None and isinstance(dist, TabulatedAmplitudeLaw) and dist.n_samples is not None:
        n_amplitudes = dist.n_samples
    if n_exceed is not None and n_amplitudes is None:
        raise ValueError("`n_exceed` needs `n_amplitudes` (the number of amplitudes it was counted among).")
    if n_amplitudes is None:
        n_amp = jnp.asarray(jnp.nan)
    else:
        n_amp = _positive(n_amplitudes, "n_amplitudes", "[-]", " It is the number of amplitudes counted.")
        n_amp = require(n_amp, n_amp < 1, "`n_amplitudes` must be >= 1 (the number of amplitudes counted).")
    if n_exceed is None:
        k = None
    else:
        k = _scalar(n_exceed, "n_exceed")
        shown = "a traced value" if _is_traced(k) else f"{float(k)!r}"
        k = require(k, ~((k >= 0) & (k <= n_amp)), f"`n_exceed` must lie in [0, n_amplitudes]; got {shown}.")
    rate = jnp.asarray(rate, dtype=float)
    duration = jnp.asarray(duration, dtype=float)
    return _exposure_risk(dist, angle, n, rate, duration, n_amp, k, confidence)


@filter_jit
def _exposure_risk(dist, angle, n, rate, duration, n_amp, k, confidence):
    if k is None:
        p = jnp.exp(dist._logsf(angle))
        log_c = dist._logcdf(angle)
    else:
        p = k / n_amp
        log_c = jnp.log1p(-p)
    p_lo, p_hi = _wilson_bounds(p * n_amp, n_amp, confidence)  # checked by exposure_risk
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
