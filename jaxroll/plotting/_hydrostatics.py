"""Figures of hull hydrostatics: body plan, GZ curves (calm, crest, trough), ΔGM(ζ_mid) and its polynomial
fit.

The only hydrostatics module that imports matplotlib. Functions take `ax=None` (a new figure is made with
`pyplot.subplots`) and return the `Axes`; they never call `plt.show()`. Angles are plotted in degrees.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np


def _axes(ax, figsize=(6.4, 4.2)):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def plot_body_plan(hull, *, draught: float | None = None, ax=None, **kwargs):
    """Body plan of `hull`: afterbody stations (x < Lpp/2) on the left, forebody on the right.

    **Arguments:** `hull` (a `Hull`); `draught` [m] to draw as a waterline (optional); `ax`; `kwargs` for
    `ax.plot`. **Returns:** the `Axes`.
    """
    ax = _axes(ax, figsize=(6.4, 4.6))
    x = np.asarray(hull.stations)
    z = np.append(np.asarray(hull.waterlines), float(hull.depth))
    xm = float(hull.lpp) / 2
    style = dict(color="k", lw=0.7) | kwargs
    hb = np.asarray(hull.half_breadths)  # indexed on the host: no program compiled per index
    for i, xi in enumerate(x):
        y = np.append(hb[i], hb[i, -1])
        sign = -1.0 if xi < xm else 1.0
        ax.plot(sign * y, z, **style)
    if draught is not None:
        ax.axhline(draught, color="tab:blue", lw=0.8, ls="--", label=f"d = {draught:g} m")
        ax.legend(loc="lower right", fontsize="small")
    ax.axvline(0.0, color="0.6", lw=0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("half-breadth y [m] (aft body left, fore body right)")
    ax.set_ylabel("z above baseline [m]")
    ax.set_title(f"Body plan: {hull.name}", fontsize="medium")
    return ax


def plot_gz_curves(
    heels,
    curves: Mapping[str, Sequence[float]],
    *,
    fit: tuple[float, Sequence[float]] | None = None,
    fit_heel_max: float | None = None,
    ax=None,
):
    """GZ(φ) curves, e.g. calm water, crest and trough amidships (paper Fig. A.2 analogue).

    **Arguments:**

    - `heels`: heel angles φ [rad] (shared by all curves).
    - `curves`: label → GZ [m] at `heels`.
    - `fit`: `(gm0, (g3, g5, g7, g9))` [m] of the polynomial GZ = GM0 φ + Σ g_n φⁿ to draw dashed.
    - `fit_heel_max`: largest heel of the fit [rad], marked with a dotted line.
    - `ax`: axes to draw on. **Returns:** the `Axes`.
    """
    ax = _axes(ax)
    deg = np.degrees(np.asarray(heels))
    colors = {"calm": "k", "crest": "tab:red", "trough": "tab:blue"}
    for label, gz in curves.items():
        color = next((c for key, c in colors.items() if key in label), None)
        ax.plot(deg, np.asarray(gz), label=label, color=color, lw=1.5)
    if fit is not None:
        gm0, g = fit
        phi = np.linspace(0.0, float(np.max(heels)), 200)
        poly = gm0 * phi + sum(c * phi**n for c, n in zip(g, (3, 5, 7, 9)))
        ax.plot(np.degrees(phi), poly, "k--", lw=1.0, label="fit GM0 φ + g3 φ³ + … + g9 φ⁹ (calm)")
    if fit_heel_max is not None:
        ax.axvline(np.degrees(fit_heel_max), color="0.5", lw=0.6, ls=":")
    ax.axhline(0.0, color="0.6", lw=0.5)
    ax.set_xlabel("heel φ [deg]")
    ax.set_ylabel("GZ [m]")
    ax.set_title("Righting lever, free sinkage and trim (Froude–Krylov, λ = L)", fontsize="medium")
    ax.legend(fontsize="small")
    return ax


def plot_delta_gm(
    zeta_mid,
    delta_gm,
    coefficients: Sequence[float],
    *,
    reference: Sequence[float] | None = None,
    reference_label: str = "default ship (representative)",
    ax=None,
):
    """ΔGM(ζ_mid) computed points and their polynomial fit (paper Fig. A.3 analogue).

    **Arguments:**

    - `zeta_mid`: amplitudes [m] (> 0: trough amidships); `delta_gm`: ΔGM [m] at them.
    - `coefficients`: C0..C6 [m^(1−k)] of the fit; `reference`: another C0..C6 to compare with (optional).
    - `ax`: axes. **Returns:** the `Axes`.
    """
    ax = _axes(ax)
    z = np.asarray(zeta_mid)
    zz = np.linspace(z.min(), z.max(), 200)
    poly = lambda c: sum(ck * zz**k for k, ck in enumerate(c))
    ax.plot(z, np.asarray(delta_gm), "o", color="tab:blue", label="hydrostatics (quasi-static balance)")
    ax.plot(zz, poly(coefficients), "-", color="tab:blue", lw=1.2, label="6th-order fit")
    if reference is not None:
        ax.plot(zz, poly(reference), ":", color="0.4", lw=1.2, label=reference_label)
    ax.axhline(0.0, color="0.6", lw=0.5)
    ax.axvline(0.0, color="0.6", lw=0.5)
    ax.set_xlabel("ζ_mid [m]  (< 0: crest amidships, > 0: trough amidships)")
    ax.set_ylabel("ΔGM [m]")
    ax.set_title("GM variation in a wave of length L", fontsize="medium")
    ax.legend(fontsize="small")
    return ax
