"""Figures of the IMO parametric-roll criteria: C1 and C2 contributions per wave case, roll amplitude against
speed, KGmax curves. Functions take `ax=None` and return the `Axes` (or the figure); angles in degrees."""

from __future__ import annotations

import numpy as np

__all__ = ["plot_c1_cases", "plot_c2_cases", "plot_roll_versus_speed", "plot_kg_max", "sgisc_figures"]


def _axes(ax, figsize=(6.4, 4.2)):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def plot_c1_cases(c1, *, ax=None):
    """Level-2 C1 per wave case: the weight W_i (bar, hatched where C_i = 1, i.e. the case counts) and
    ΔGM_i/GM_i against R_PR (right axis).

    **Arguments:** `c1`: a `jaxroll.criteria.C1Result`; `ax`. **Returns:** the `Axes`.
    """
    ax = _axes(ax, figsize=(7.2, 4.2))
    cases = c1.cases
    i = np.arange(1, len(cases) + 1)
    w = np.array([c["weight"] for c in cases])
    counts = np.array([c["c"] for c in cases], bool)
    ax.bar(i[~counts], w[~counts], color="tab:green", alpha=0.6, label="W_i, C_i = 0")
    ax.bar(i[counts], w[counts], color="tab:red", alpha=0.8, hatch="//", label="W_i, C_i = 1 (counts in C1)")
    ax.set_xlabel("wave case i (λ_i in m)")
    ax.set_xticks(i, [f"{i_}\n{c['wavelength_m']:.0f}" for i_, c in zip(i, cases)], fontsize="x-small")
    ax.set_ylabel("weight W_i")
    ax2 = ax.twinx()
    ratio = np.array([c["ratio"] if np.isfinite(c["ratio"]) else np.nan for c in cases])
    ax2.plot(i, ratio, "ko-", ms=3, lw=1, label="ΔGM_i/GM_i")
    ax2.axhline(c1.r_pr, color="k", ls="--", lw=0.8, label=f"R_PR = {c1.r_pr:.3g}")
    ax2.set_ylabel("ΔGM_i / GM_i")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize="small", loc="upper right")
    ax.set_title(
        f"Level 2, first check: C1 = {c1.c1:.4f} vs R_PR1 = {c1.standard:g} "
        f"({'fails' if c1.vulnerable else 'passes'})",
        fontsize="medium",
    )
    return ax


def plot_c2_cases(c2, *, ax=None):
    """Level-2 C2 per speed/heading case: Σ W C of each of the 7 cases, their mean C2 and the standard R_PR2.

    **Arguments:** `c2`: a `jaxroll.criteria.C2Result`; `ax`. **Returns:** the `Axes`.
    """
    ax = _axes(ax, figsize=(6.8, 4.0))
    labels = [
        "V = 0" if o["speed_factor"] == 0 else f"{o['heading']}\n{o['speed_factor']:g} V_S"
        for o in c2.per_case
    ]
    values = np.array([o["c"] for o in c2.per_case])
    colors = ["tab:blue" if o["heading"] == "head" else "tab:orange" for o in c2.per_case]
    ax.bar(np.arange(len(values)), values, color=colors)
    ax.set_xticks(np.arange(len(values)), labels, fontsize="x-small")
    ax.axhline(c2.c2, color="k", lw=1, label=f"C2 = mean = {c2.c2:.4f}")
    ax.axhline(c2.standard, color="tab:red", ls="--", lw=1, label=f"R_PR2 = {c2.standard:g}")
    ax.set_ylabel("Σ W_j C_j over the scatter table")
    ax.legend(fontsize="small")
    ax.set_title(
        f"Level 2, second check: C2 = {c2.c2:.4f} ({'fails' if c2.vulnerable else 'passes'})",
        fontsize="medium",
    )
    return ax


def plot_roll_versus_speed(curve, *, limit_deg: float = 25.0, service_speed: float | None = None, ax=None):
    """Maximum roll [deg] in a regular wave λ = L against speed [kn], head and following seas.

    **Arguments:** `curve`: `jaxroll.criteria.roll_versus_speed`'s dict (radians, m/s); `limit_deg`: C2's
    angle; `service_speed` V_S [m/s] to mark; `ax`. **Returns:** the `Axes`.
    """
    ax = _axes(ax)
    kn = np.asarray(curve["speed_m_s"]) / (1852.0 / 3600.0)
    for key, color in (("head", "tab:blue"), ("following", "tab:orange")):
        deg = np.degrees(np.asarray(curve[key]))
        deg = np.where(deg >= 179.0, np.nan, deg)  # capsized
        ax.plot(kn, deg, "o-", ms=3, color=color, label=f"{key} seas")
    ax.axhline(limit_deg, color="tab:red", ls="--", lw=0.8, label=f"{limit_deg:g}°")
    if service_speed is not None:
        ax.axvline(service_speed / (1852.0 / 3600.0), color="k", ls=":", lw=0.8, label="V_S")
    ax.set_xlabel("ship speed [kn]")
    ax.set_ylabel("maximum roll angle [deg]")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="small")
    return ax


def plot_kg_max(curve, *, kg: float | None = None, draught: float | None = None, ax=None):
    """KGmax [m] against draught [m]: Level 1, Level 2 C1 and KM; the loading condition as a point.

    **Arguments:** `curve`: a `jaxroll.criteria.KGMaxCurve`; `kg`, `draught` of the loading to mark; `ax`.
    **Returns:** the `Axes`.
    """
    ax = _axes(ax)
    ax.plot(curve.draught, curve.km, "k-", lw=0.8, label="KM (GM = 0)")
    ax.plot(curve.draught, curve.kg_max_level1, "o-", ms=3, label="KGmax, Level 1")
    ax.plot(curve.draught, curve.kg_max_c1, "s-", ms=3, label="KGmax, Level 2 C1")
    if kg is not None and draught is not None:
        ax.plot([draught], [kg], "r*", ms=10, label="loading condition")
    ax.set_xlabel("draught d [m]")
    ax.set_ylabel("KG [m]")
    ax.legend(fontsize="small")
    ax.set_title("KGmax for parametric rolling (below the curve: not vulnerable)", fontsize="medium")
    return ax


def sgisc_figures(assessment):
    """The C1 and (if computed) C2 figures of a `jaxroll.criteria.ParametricRollAssessment`, side by side.

    **Returns:** the matplotlib `Figure`.
    """
    import matplotlib.pyplot as plt

    n = 2 if assessment.c2 is not None else 1
    fig, axes = plt.subplots(1, n, figsize=(7.0 * n, 4.2), layout="constrained", squeeze=False)
    plot_c1_cases(assessment.c1, ax=axes[0, 0])
    if assessment.c2 is not None:
        plot_c2_cases(assessment.c2, ax=axes[0, 1])
    return fig
