"""The direct wave moment in a long-term assessment (issue 44, item 6), and the parametric share of the risk.

A ship carrying a wave moment (`ship.wave_moment`) rolls under it at every heading class but head and following
seas (|cos χ| < 1: the moment of a hull symmetric port and starboard vanishes only there). Those cells — the
*moment cells* — are simulated with the whole excitation (the direct moment and Grim's effective wave made of the
same waves: the superposition, `MOMENT_EXCITATION`; no theory covers the moment), beam seas included, which are no
longer 0. Beside each cell's probability P the dataset reports the **parametric-only** probability P_param: the
same cell with the moment off (the ship without its table, the same seed and trials, the run's `excitation`), 0
exactly in beam seas (Grim's effective wave vanishes there); a cell without the moment has P_param = P. The
long-term P_param,LT = Σ w P_param beside P_LT is the parametric-roll question the IMO criteria ask.
"""

from __future__ import annotations

import equinox as eqx
import numpy as np

#: The excitation of the moment cells: the only one that makes M_w and ζ_G of the same waves (docs/wave_moment.md).
MOMENT_EXCITATION = "superposition"
#: The dataset's parametric-only variables: the cells' name → the dataset's.
PARAMETRIC_KEYS = {
    "parametric_probability": "parametric_probability",
    "parametric_lower": "parametric_probability_lower",
    "parametric_upper": "parametric_probability_upper",
    "parametric_variance": "parametric_probability_variance",
}
#: The long-term parametric-only variables (recomputed from the cells by `add_longterm`).
LONGTERM_PARAMETRIC_VARS = (
    "longterm_parametric_probability",
    "longterm_parametric_probability_ci95",
    "longterm_parametric_share",
)


def parametric_only(ship):
    """`ship` without its direct wave moment (`ship.wave_moment` None): the paper's parametric-only roll model."""
    return eqx.tree_at(lambda s: s.wave_moment, ship, None, is_leaf=lambda x: x is None)


def moment_classes(grid, short_crested: bool = False) -> np.ndarray:
    """Per (ship, heading class) of `grid`: the direct wave moment joins the roll (the ship carries one and the
    class heading is neither head nor following seas; every class in a short-crested sea, whose directions meet the
    hull obliquely). Shape (ships, classes)."""
    has = np.array([s.wave_moment is not None for s in grid.ships])
    oblique = (grid.classes_deg != 0.0) & (grid.classes_deg != 180.0) | short_crested
    return has[:, None] & oblique[None, :]


def surface_ships(grid) -> np.ndarray:
    """Per ship of `grid`: it carries a GZ(φ, ζ_mid) surface (`ship.restoring_surface`), which no theory knows."""
    return np.array([getattr(s, "restoring_surface", None) is not None for s in grid.ships])


def refuse_theory(grid, moment_cells: np.ndarray) -> None:
    """`method="theory"` cannot give a moment cell: **Raises** `ValueError` naming the ship and headings."""
    if not moment_cells.any():
        return
    s, k = np.argwhere(moment_cells.any(axis=(2, 3, 4)))[0]
    classes = [
        f"{c:g}" for c, m in zip(grid.classes_deg, moment_cells[s].any(axis=(1, 2, 3)), strict=True) if m
    ]
    raise ValueError(
        f"`method='theory'`: {grid.ship_names[s]} carries a direct wave moment (ship.wave_moment), which joins the "
        f"roll at heading(s) {', '.join(classes)}°; the theory (passage_risk) covers the parametric excitation only. "
        "Use method='auto' (theory where it holds, the Monte Carlo at those headings) or 'monte-carlo'."
    )


def empty_parametric(shape, n_angles) -> dict:
    """The cells' parametric-only arrays before any computation (NaN; variance 0)."""
    out = {k: np.full(shape + (n_angles,), np.nan) for k in PARAMETRIC_KEYS}
    out["parametric_variance"] = np.zeros(shape + (n_angles,))
    out["direct_moment"] = np.zeros(shape, bool)
    return out


def fill_parametric(cells: dict, moment_cells: np.ndarray, beam: np.ndarray) -> None:
    """P_param of every computed cell, in place: a moment cell off beam seas keeps what its Monte Carlo of the
    parametric-only ship gave; a moment cell in beam seas (`beam`: the cell's class is beam seas) is 0 exactly;
    every other cell has its own P, interval and variance."""
    pairs = (("probability", "parametric_probability"), ("probability_lower", "parametric_lower"),
             ("probability_upper", "parametric_upper"), ("variance", "parametric_variance"))  # fmt: skip
    zero = moment_cells & beam & ~np.isnan(cells["probability"][..., 0])
    for own, par in pairs:
        cells[par] = np.where(moment_cells[..., None], cells[par], cells[own])
        cells[par][zero] = 0.0
    cells["direct_moment"] = np.array(moment_cells)


def dataset_variables(to_cells, angle_dims, cell_dims, cells: dict) -> dict:
    """The dataset's parametric-only variables (`build_dataset`), from the cells' arrays (`to_cells` reorders)."""
    if "parametric_probability" not in cells:
        return {}
    one = {"units": "1"}
    names = {
        "parametric_probability": "short-term P(max |roll| > angle within the exposure) with the direct wave moment "
        "off: the parametric-only roll (= probability where the cell has no direct moment; 0 in beam seas)",
        "parametric_lower": "95 % interval of the parametric-only probability, lower",
        "parametric_upper": "95 % interval of the parametric-only probability, upper",
        "parametric_variance": "sampling variance of the parametric-only estimate (0: theory)",
    }
    out = {
        PARAMETRIC_KEYS[k]: (angle_dims, to_cells(cells[k]), {**one, "long_name": names[k]}) for k in names
    }
    out["direct_moment"] = (
        cell_dims,
        to_cells(cells["direct_moment"]).astype(bool),
        {**one, "long_name": "the direct wave moment joins the cell's roll (its probability has it; "
         "parametric_probability has it off)"},
    )  # fmt: skip
    return out


def longterm_variables(ds, w, p0, var, lo, hi, longterm_probability) -> dict:
    """`longterm_parametric_probability` (Σ w P_param) with its 95 % interval (as the long-term probability's:
    sampling of the Monte Carlo cells, the theory cells' allowance) and `longterm_parametric_share` = P_param,LT /
    P_LT; {} for a dataset without the parametric-only variables. `w`, `p0`, `var`, `lo`, `hi`: the cells' weight,
    probability (NaN as 0), variance and model bounds, as `add_longterm` has them."""
    if "parametric_probability" not in ds:
        return {}
    moment = ds["direct_moment"].values[..., None]
    pp = ds["parametric_probability"].values
    pp0 = np.where(moment, np.nan_to_num(pp), p0)
    pvar = np.where(moment, np.nan_to_num(ds["parametric_probability_variance"].values), var)
    lt = longterm_probability(w, pp0, pvar, np.where(moment, pp0, lo), np.where(moment, pp0, hi))
    total = longterm_probability(w, p0, var, lo, hi)["probability"]
    share = np.where(total > 0, lt["probability"] / np.where(total > 0, total, 1.0), np.nan)
    one = {"units": "1"}
    return {
        "longterm_parametric_probability": (
            ("angle_deg",),
            lt["probability"],
            {**one, "long_name": "P(max |roll| > angle within one exposure) with the direct wave moment off: "
             "the parametric-only roll, the cells' weighted mean"},
        ),
        "longterm_parametric_probability_ci95": (
            ("angle_deg", "bound"),
            np.stack([lt["lower"], lt["upper"]], axis=-1),
            {**one, "long_name": "95 % interval of the parametric-only long-term probability"},
        ),
        "longterm_parametric_share": (
            ("angle_deg",),
            share,
            {**one, "long_name": "parametric-only over total long-term probability (NaN: total 0)"},
        ),
    }  # fmt: skip
