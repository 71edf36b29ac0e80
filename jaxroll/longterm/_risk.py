"""The long-term integral, its interval, the per-year conversion, and the rule of `method="auto"`.

P_LT = Σ_c w_c P_c over the cells c (weights summing to 1): the probability that the roll exceeds the angle within
one exposure taken at random from the cells' distribution (capsizes counted as exceedances).

Its 95 % interval adds two parts, stated apart:
- sampling: ±z σ with σ² = Σ_c w_c² Var P̂_c over the Monte Carlo cells (independent estimates: each cell has its
  own seed);
- model allowance on the theory's cells: a theory cell's probability is taken to lie in [P/f, min(1, f·P)] with
  f = `model_factor` (1.25, the accuracy target of issue 34's exposure-risk theory against the direct Monte Carlo);
  a cell whose theory fails a validity check and was not simulated, or that was left out (`skip_weight`), in
  [0, 1]. The allowances are added linearly (as if every theory cell erred the same way: conservative).

Per year: N_y = (hours at sea per year)/(exposure) exposures. The number of exposures a year spends in cell c is
random, Poisson with mean w_c N_y (independent cells, independent exposures): the exposures with an exceedance are
then Poisson with mean Λ = N_y Σ_c w_c P_c = N_y P_LT, and P_year = P(at least one) = 1 − exp(−Λ) ≤ Λ. (The
earlier 1 − Π_c (1 − P_c)^{w_c N_y} read w_c N_y as a fixed count; a storm cell met 0.01 times a year with P_c → 1
then gave P_year → 1 against an expected 0.01 exceedances: THEORY.md §9, corrected 2026-12-07.)
"""

from __future__ import annotations

import numpy as np

from ._monte_carlo import Z95

#: The factor of a valid theory cell's model allowance: [P/f, min(1, f·P)].
MODEL_FACTOR = 1.25
#: `auto`: the Monte Carlo cells include the smallest set of cells carrying this share of the theory's P_LT.
AUTO_SHARE = 0.9
#: `auto`: a cell failing a validity check is simulated where its worst case, w·max(P, 1 − P), exceeds this
#: fraction of the theory's P_LT (for some angle).
AUTO_TOLERANCE = 0.01
#: A theory cell is doubtful where the envelope's Lyapunov exponent is within this many 1/exposure of 0 (the roll's
#: growth time 1/|λ| is longer than the exposure: the stationary law the theory assumes is not what an exposure
#: sees, and near λ = 0 that law changes fast with λ) …
NEAR_THRESHOLD = 1.0
#: … or where the theory puts at least this probability per exposure in the capsize range (the envelope FPK's top
#: cell, a reflecting boundary at the vanishing angle) …
CAPSIZE_DOUBT = 0.01
# … or where the fitted envelope decay γ ≤ 0 (the envelope model does not fit the sea; λ is undefined).


def doubtful(lyapunov, gamma, capsize_probability, exposure: float) -> np.ndarray:
    """The theory's validity checks per cell (module constants): True where the theory is not to be trusted."""
    lam = np.asarray(lyapunov, float)
    return (
        (np.asarray(gamma, float) <= 0)
        | (np.abs(lam) * exposure < NEAR_THRESHOLD)
        | ((lam > 0) & (np.asarray(capsize_probability, float) >= CAPSIZE_DOUBT))
    )


def auto_cells(
    weight, p_theory, doubt, needed, share: float = AUTO_SHARE, tolerance: float = AUTO_TOLERANCE
) -> tuple[np.ndarray, np.ndarray]:
    """The Monte Carlo cells of `method="auto"`: (dominant, doubtful-and-material) masks over the cells.

    - dominant: for each angle, the smallest set of cells whose theory contributions w·P add up to at least
      `share` of the theory's P_LT (largest first);
    - doubtful-and-material: cells failing a validity check whose worst-case error w·max(P, 1 − P) exceeds
      `tolerance`·P_LT (theory) for some angle.

    `weight` (cells,), `p_theory` (cells, angles), `doubt`, `needed` (cells,): flat arrays.
    """
    w = np.asarray(weight, float)
    p = np.asarray(p_theory, float)
    needed = np.asarray(needed, bool)
    dominant = np.zeros(w.size, bool)
    material = np.zeros(w.size, bool)
    for a in range(p.shape[1]):
        contrib = np.where(needed, w * p[:, a], 0.0)
        total = contrib.sum()
        if total > 0:
            order = np.argsort(-contrib, kind="stable")
            cum = np.cumsum(contrib[order])
            count = int(np.searchsorted(cum, share * total * (1 - 1e-12))) + 1
            dominant[order[:count]] = True
        worst = w * np.maximum(p[:, a], 1 - p[:, a])
        material |= needed & np.asarray(doubt, bool) & (worst > tolerance * total)
    return dominant & needed, material


def rare_cells(trials, p_theory, rare_below: float) -> np.ndarray:
    """The rare Monte Carlo cells of `estimator="splitting"` with `method="auto"`: cells with trials (`trials` > 0)
    whose theory probability at the largest angle — the smallest over the angles (last axis of `p_theory`; NaN
    counts as 1) — is below `rare_below`. **Returns:** a mask, the shape of `trials`."""
    p = np.nan_to_num(np.asarray(p_theory, float), nan=1.0)
    return (np.asarray(trials) > 0) & (p.min(axis=-1) < rare_below)


def model_bounds(p, kind, lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """Per cell and angle the interval the long-term allowance assumes: `kind` 0 exact (Monte Carlo cells, whose
    uncertainty is sampling, and beam seas), 1 a valid theory cell: its own interval [`lower`, `upper`] (the model
    factor around the value), 2 unknown [0, 1] (a doubtful theory cell not
    simulated, or a cell left out)."""
    p = np.asarray(p, float)
    kind = np.asarray(kind)[..., None]
    lo = np.where(kind == 1, np.nan_to_num(lower), np.where(kind == 2, 0.0, p))
    hi = np.where(kind == 1, np.nan_to_num(upper), np.where(kind == 2, 1.0, p))
    return lo, hi


def longterm_probability(weight, p, variance, lo_model, hi_model) -> dict:
    """P_LT = Σ w P and its 95 % interval (module docstring). Arrays over cells (first axes) and angles (last);
    `weight` over cells. **Returns:** dict of arrays over angles: `probability`, `lower`, `upper`, `sampling_sd`,
    `model_below`, `model_above` (the allowance's reach below and above P_LT)."""
    w = np.asarray(weight, float)[..., None]
    axes = tuple(range(w.ndim - 1))
    est = (w * p).sum(axis=axes)
    sd = np.sqrt((w**2 * variance).sum(axis=axes))
    below = (w * (p - lo_model)).sum(axis=axes)
    above = (w * (hi_model - p)).sum(axis=axes)
    return {
        "probability": est,
        "lower": np.clip(est - Z95 * sd - below, 0.0, 1.0),
        "upper": np.clip(est + Z95 * sd + above, 0.0, 1.0),
        "sampling_sd": sd,
        "model_below": below,
        "model_above": above,
    }


def annual(weight, p, variance, lo_model, hi_model, exposures_per_year: float) -> dict:
    """P(at least one exceedance in a year) = 1 − exp(−N_y P_LT) (Poisson numbers of exposures per cell: module
    docstring) and its interval, the long-term interval's ends put through the same increasing map; and the rate
    Λ = N_y P_LT, the expected number of exposures with an exceedance per year (P_year ≤ Λ always). Arrays as
    `longterm_probability`."""
    ny = float(exposures_per_year)
    lt = longterm_probability(weight, p, variance, lo_model, hi_model)
    rate, rate_lo, rate_hi = (ny * lt[k] for k in ("probability", "lower", "upper"))
    return {
        "probability": -np.expm1(-rate),
        "lower": -np.expm1(-rate_lo),
        "upper": -np.expm1(-rate_hi),
        "sampling_sd": np.exp(-rate) * ny * lt["sampling_sd"],
        "rate": rate,
        "rate_lower": rate_lo,
        "rate_upper": rate_hi,
    }


def fill_cells(cells, shape, method, comp_w, beam, left_out, needed, is_mc, factor) -> None:
    """Method, value and interval of every computation cell (Monte Carlo cells are already filled); `factor`
    [2, *shape]: each theory cell's (f_below, f_above)."""
    from ._dataset import METHODS, UNCERTAINTY  # (the dataset's codes; _dataset imports this module)

    m = np.full(shape, METHODS.index("zero_weight"))
    unc = np.zeros(shape, np.int64)
    m[left_out] = METHODS.index("left_out")
    unc[left_out] = UNCERTAINTY.index("unknown")
    exact = (comp_w > 0) & beam
    m[exact] = METHODS.index("no_excitation")
    for k in ("probability", "probability_lower", "probability_upper"):
        cells[k][exact] = 0.0
    for k in ("capsize_probability", "capsize_lower", "capsize_upper"):
        cells[k][exact] = 0.0
    th = needed & ~is_mc
    if method in ("theory", "auto"):
        m[th] = METHODS.index("theory")
        p = cells["theory_probability"][th]
        c = cells["theory_capsize_probability"][th]
        doubt = cells["theory_doubtful"][th]
        f_below, f_above = factor[0][th][:, None], factor[1][th][:, None]
        cells["probability"][th] = p
        cells["capsize_probability"][th] = c
        cells["probability_lower"][th] = np.where(doubt[:, None], 0.0, p / f_below)
        cells["probability_upper"][th] = np.where(doubt[:, None], 1.0, np.minimum(1.0, p * f_above))
        cells["capsize_lower"][th] = np.where(doubt, 0.0, c / f_below[:, 0])
        cells["capsize_upper"][th] = np.where(doubt, 1.0, np.minimum(1.0, c * f_above[:, 0]))
        # cells left at pass 1 (two passes): [0, min(1, f·r·P1)], r the largest pass-2/pass-1 ratio of the refined
        # cells of the cell's unit (at least 1; pass 1 was measured above pass 2 wherever they differ):
        # docs/longterm.md, "Cost"
        rough = th & ~cells["theory_refined"] & (cells["lyapunov_exponent"] > 0)
        if rough.any():
            doubt_r = cells["theory_doubtful"][rough]
            cells["probability_lower"][rough] = 0.0
            cells["probability_upper"][rough] = np.where(
                doubt_r[:, None],
                1.0,
                np.minimum(
                    1.0,
                    factor[1][rough][:, None]
                    * cells["theory_pass_ratio"][rough][:, None]
                    * cells["theory_probability"][rough],
                ),
            )
            cells["capsize_lower"][rough] = 0.0
            cells["capsize_upper"][rough] = np.where(
                doubt_r,
                1.0,
                np.minimum(
                    1.0,
                    factor[1][rough]
                    * cells["theory_pass_capsize_ratio"][rough]
                    * cells["theory_capsize_probability"][rough],
                ),
            )
        unc[th] = np.where(doubt, UNCERTAINTY.index("unknown"), UNCERTAINTY.index("model_factor"))
    m[is_mc] = METHODS.index("monte_carlo")
    unc[is_mc] = UNCERTAINTY.index("sampling")
    cells["method"], cells["uncertainty"] = m, unc
