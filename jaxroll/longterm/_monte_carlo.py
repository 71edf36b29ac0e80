"""Short-term exceedance probabilities by Monte Carlo, one cell at a time.

A cell's estimate comes from trials of `discard + exposure` seconds (`jaxroll.monte_carlo_max_roll`): per trial the
largest |φ| after the discard and whether it capsized, so every angle is read from the same trials afterwards;
a capsized trial counts as an exceedance of every angle (and is counted apart). Its key is `jax.random.key(s_c)`
with the cell's seed s_c, recorded in the dataset, so `jaxroll risk … --seed s_c − 1` reproduces the cell trial
for trial (its direct estimate uses `jax.random.key(seed + 1)`).

Estimators are looked up by name in `CELL_ESTIMATORS`; each takes `(problem, key, *, angles_deg, exposure,
discard, num_realizations, **run_options)` and returns a `CellEstimate`. The rare-cell estimator of issue 34
item 4 (`jaxroll.monte_carlo_splitting`) plugs in here at merge as `"splitting"`: its `probability`,
`standard_error` and `probability_ci95` per angle fill a `CellEstimate` (variance = standard_error²).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..extremes import wilson_interval
from ..roll import RollProblem, monte_carlo_max_roll
from ..sea import ITTC

#: z of the 95 % intervals.
Z95 = 1.959963984540054
#: Fractions of a cell's trials at which the exceedances are also counted (the first n·f trials): the long-term
#: interval against effort (`longterm_ci.png`) is read from them.
EFFORT_FRACTIONS = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0)


@dataclasses.dataclass
class CellEstimate:
    """A cell's Monte Carlo estimate. Per angle: `probability` [-], its 95 % interval (`lower`, `upper`) and the
    `variance` of the estimate (for the long-term interval); the same for the capsize probability; the trial counts
    (`n_exceeded` per angle, `n_capsized`; −1 where an estimator has no counts) and `n_exceeded_effort` (efforts,
    angles) at `EFFORT_FRACTIONS` of the trials."""

    probability: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    variance: np.ndarray
    capsize_probability: float
    capsize_lower: float
    capsize_upper: float
    capsize_variance: float
    n_realizations: int
    n_exceeded: np.ndarray
    n_capsized: int
    n_exceeded_effort: np.ndarray


def binomial_variance(k, n) -> np.ndarray:
    """Variance [-] of a binomial proportion k/n for the long-term interval: Agresti–Coull, p̃(1 − p̃)/(n + z²) with
    p̃ = (k + z²/2)/(n + z²) — never zero, so a cell with no exceedance still carries its uncertainty."""
    k, n = np.asarray(k, float), np.asarray(n, float)
    p = (k + Z95**2 / 2) / (n + Z95**2)
    return p * (1 - p) / (n + Z95**2)


def _interval(k, n):
    lo, hi = wilson_interval(np.asarray(k, float), float(n), 0.95)
    return np.asarray(lo, float), np.asarray(hi, float)


def brute_force_cell(
    problem: RollProblem,
    key,
    *,
    angles_deg,
    exposure: float,
    discard: float,
    num_realizations: int,
    **run_options,
) -> CellEstimate:
    """Direct Monte Carlo of a cell: `num_realizations` trials of `discard + exposure` [s]; exceedance of each angle
    [deg] = max |φ| after the discard above it, or a capsize. Intervals: Wilson (95 %)."""
    angles_deg = np.asarray(angles_deg, float)
    stats = monte_carlo_max_roll(
        problem,
        key,
        angle_deg=float(angles_deg.min()),
        num_realizations=num_realizations,
        duration=discard + exposure,
        discard=discard,
        **run_options,
    )
    n = stats.n_realizations
    k = np.array([stats.exceedances(float(a)) for a in angles_deg], np.int64)
    lo, hi = _interval(k, n)
    kc = int(stats.n_capsized)
    clo, chi = _interval(kc, n)
    effort = []
    for f in EFFORT_FRACTIONS:
        m = max(1, int(round(f * n)))
        beyond = stats.capsized[:m, None] | (stats.max_abs_phi_deg[:m, None] > angles_deg[None, :])
        effort.append(beyond.sum(axis=0))
    return CellEstimate(
        probability=k / n,
        lower=lo,
        upper=hi,
        variance=binomial_variance(k, n),
        capsize_probability=kc / n,
        capsize_lower=float(clo),
        capsize_upper=float(chi),
        capsize_variance=float(binomial_variance(kc, n)),
        n_realizations=n,
        n_exceeded=k,
        n_capsized=kc,
        n_exceeded_effort=np.array(effort, np.int64),
    )


#: The per-cell Monte Carlo estimators by name (`longterm(..., estimator=NAME)`, `--estimator`).
CELL_ESTIMATORS = {"brute_force": brute_force_cell}


def cell_problem(
    ship,
    hs: float,
    t01: float,
    speed: float,
    heading_deg: float,
    *,
    excitation: str,
    dt: float,
    filter_order: int,
    phi0: float,
) -> RollProblem:
    """The cell's `RollProblem`, built as `jaxroll risk` builds it (the same floats: H_s [m], T01 [s], U [m/s],
    χ = radians(heading_deg))."""
    return RollProblem.from_sea(
        ship,
        ITTC(hs, t01),
        speed=speed,
        heading=math.radians(heading_deg),
        excitation=excitation,
        dt=dt,
        filter_order=filter_order,
        phi0=phi0,
    )


def neyman_allocation(weight, p_design, total: int, minimum: int) -> np.ndarray:
    """Trials per Monte Carlo cell: n_c ∝ w_c √(p̃_c(1 − p̃_c)) / √cost_c (Neyman allocation, which minimises the
    long-term variance Σ w_c² p_c(1 − p_c)/n_c for Σ n_c = `total`), with the cost per trial the same in every
    cell (same `dt`, discard and exposure), p̃ = p_design clipped to [0.01, 0.5] (a theory's 0 or 1 is no reason to
    run no trial), and at least `minimum` trials per cell. **Returns:** integers, shape of `weight`."""
    w = np.asarray(weight, float)
    if w.size == 0:
        return np.zeros(0, np.int64)
    p = np.clip(np.asarray(p_design, float), 0.01, 0.5)
    a = w * np.sqrt(p * (1 - p))
    share = a / a.sum() if a.sum() > 0 else np.full(w.size, 1.0 / w.size)
    return np.maximum(int(minimum), np.round(share * total)).astype(np.int64)
