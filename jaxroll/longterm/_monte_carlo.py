"""Short-term exceedance probabilities by Monte Carlo, one cell at a time.

A cell's estimate comes from trials of `discard + exposure` seconds (`jaxroll.monte_carlo_max_roll`): per trial the
largest |φ| after the discard and whether it capsized, so every angle is read from the same trials afterwards;
a capsized trial counts as an exceedance of every angle (and is counted apart). Its key is `jax.random.key(s_c)`
with the cell's seed s_c, recorded in the dataset, so `jaxroll risk … --seed s_c − 1` reproduces the cell trial
for trial (its direct estimate uses `jax.random.key(seed + 1)`).

Estimators are looked up by name in `CELL_ESTIMATORS`; each takes `(problem, key, *, angles_deg, exposure,
discard, num_realizations, **run_options)` and returns a `CellEstimate`: `"brute_force"` (above) and `"splitting"`
(`splitting_cell`: `jaxroll.monte_carlo_splitting_angles`, every angle of the cell from one multilevel splitting run
keyed `jax.random.key(s_c)` too; for the rare cells, `longterm(..., estimator="splitting", rare_below=…)`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..extremes import wilson_interval
from ..roll import RollProblem, monte_carlo_max_roll, monte_carlo_splitting_angles, splitting_pilot
from ..sea import ITTC

#: z of the 95 % intervals.
Z95 = 1.959963984540054
#: Fractions of a cell's trials at which the exceedances are also counted (the first n·f trials): the long-term
#: interval against effort (`longterm_ci.png`) is read from them.
EFFORT_FRACTIONS = (1 / 16, 1 / 8, 1 / 4, 1 / 2, 1.0)
#: `estimator` flag values of the dataset: the estimator of each Monte Carlo cell ("none": not a Monte Carlo cell).
ESTIMATORS = ("none", "brute_force", "splitting")
#: `estimator="splitting"`: a Monte Carlo cell is rare — estimated by splitting — where its design probability at its
#: largest angle is below this (docs/longterm.md, "Rare cells").
RARE_BELOW = 1e-3


@dataclasses.dataclass
class CellEstimate:
    """A cell's Monte Carlo estimate. Per angle: `probability` [-], its 95 % interval (`lower`, `upper`) and the
    `variance` of the estimate (for the long-term interval); the same for the capsize probability; the trial counts
    (`n_exceeded` per angle, `n_capsized`; −1 where an estimator has no counts) and `n_exceeded_effort` (efforts,
    angles) at `EFFORT_FRACTIONS` of the trials; `estimator`, the estimator that made it (a name of `ESTIMATORS`);
    `cost_trials`, its cost in trials of `discard` + `exposure` (brute force: its trials; splitting: the
    realization-seconds it simulated, pilot included, over a trial's)."""

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
    estimator: str = "brute_force"
    cost_trials: float = math.nan


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
        cost_trials=float(n),
    )


def _lognormal(estimate: float, se: float, upper_if_zero: float):
    """`monte_carlo_splitting`'s 95 % interval of an estimate and its standard error: P·exp(±z σ), σ² = log(1 +
    (se/P)²); [0, upper_if_zero] for an estimate of 0."""
    if estimate <= 0:
        return 0.0, upper_if_zero
    sigma = math.sqrt(math.log1p((se / estimate) ** 2))
    return estimate * math.exp(-Z95 * sigma), estimate * math.exp(Z95 * sigma)


def splitting_cell(
    problem: RollProblem,
    key,
    *,
    angles_deg,
    exposure: float,
    discard: float,
    num_realizations: int,
    brute_force_above: float | None = None,
    progress=None,
    checkpoint=None,
    devices=None,
    **brute_force_options,
) -> CellEstimate:
    """A cell by multilevel splitting: `jaxroll.monte_carlo_splitting_angles(problem, key, …)` with every angle
    [deg] from one run of `num_realizations` runs a stage (its pilot, `splitting_pilot`, of max(100, N/10)). Per
    angle P̂, its log-normal 95 % interval (t on the effective ancestors), and the variance SE² (genealogy); an estimate of 0 gets (upper/z)², its
    one-sided bound read as z σ (never zero, as the brute force's Agresti–Coull). The capsize probability from the
    run's continued runs, likewise; at 0 of S such runs its upper end is P̂(largest angle)·(1 − 0.05^{1/S}). No
    trial counts (−1).

    `brute_force_above`: the pilot screens first — where it puts P at the largest angle at or above this, the cell
    is `brute_force_cell(...)` instead (`checkpoint`, `progress` and `brute_force_options` go to it), its cost
    counting the pilot's."""
    angles_deg = np.asarray(angles_deg, float)
    order = np.argsort(angles_deg)
    up = [float(a) for a in angles_deg[order]]  # the run takes increasing angles
    pilot = splitting_pilot(
        problem,
        key,
        angles_deg=up,
        exposure=exposure,
        discard=discard,
        pilot_trials=max(100, num_realizations // 10),
        devices=devices,
    )
    trial = discard + exposure
    if brute_force_above is not None and pilot.probability[-1] >= brute_force_above:
        est = brute_force_cell(
            problem,
            key,
            angles_deg=angles_deg,
            exposure=exposure,
            discard=discard,
            num_realizations=num_realizations,
            progress=progress,
            checkpoint=checkpoint,
            devices=devices,
            **brute_force_options,
        )
        est.cost_trials += pilot.simulated_seconds / trial
        return est
    runs = monte_carlo_splitting_angles(
        problem,
        key,
        angles_deg=up,
        exposure=exposure,
        discard=discard,
        num_trials=num_realizations,
        levels=pilot,
        devices=devices,
    )
    res = [runs[i] for i in np.argsort(order)]  # back in the cell's order of angles
    p = np.array([r.probability for r in res])
    lo = np.array([r.probability_ci95[0] for r in res])
    hi = np.array([r.probability_ci95[1] for r in res])
    var = np.where(p > 0, np.array([r.standard_error for r in res]) ** 2, (hi / Z95) ** 2)
    top = runs[-1]
    c, cse = top.capsize_probability, top.capsize_standard_error
    c_zero = (
        top.probability * (1 - 0.05 ** (1 / top.n_exceeded)) if top.n_exceeded else top.probability_ci95[1]
    )
    clo, chi = _lognormal(c, cse, c_zero)
    if progress is not None:
        progress(num_realizations)
    return CellEstimate(
        probability=p,
        lower=lo,
        upper=hi,
        variance=var,
        capsize_probability=c,
        capsize_lower=clo,
        capsize_upper=chi,
        capsize_variance=cse**2 if c > 0 else (chi / Z95) ** 2,
        n_realizations=num_realizations,
        n_exceeded=np.full(angles_deg.size, -1, np.int64),
        n_capsized=-1,
        n_exceeded_effort=np.full((len(EFFORT_FRACTIONS), angles_deg.size), -1, np.int64),
        estimator="splitting",
        cost_trials=(top.simulated_seconds + top.pilot_simulated_seconds) / trial,
    )


#: The per-cell Monte Carlo estimators by name (`longterm(..., estimator=NAME)`, `--estimator`).
CELL_ESTIMATORS = {"brute_force": brute_force_cell, "splitting": splitting_cell}


def cell_problem(
    ship,
    hs: float,
    t01: float,
    speed: float,
    heading_deg: float,
    *,
    excitation: str,
    dt: float,
    filter_order: int | str,
    phi0: float,
    spreading=None,
) -> RollProblem:
    """The cell's `RollProblem`, built as `jaxroll risk` builds it (the same floats: H_s [m], T01 [s], U [m/s],
    χ = radians(heading_deg); `spreading`: a `jaxroll.sea.Spreading` or None)."""
    return RollProblem.from_sea(
        ship,
        ITTC(hs, t01),
        speed=speed,
        heading=math.radians(heading_deg),
        excitation=excitation,
        dt=dt,
        filter_order=filter_order,
        phi0=phi0,
        spreading=spreading,
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
