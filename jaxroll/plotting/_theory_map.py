"""The accuracy map of the theories (issue 14): theory / Monte Carlo of the mean amplitude and of P(A > 20°)
over (H1/3, r), one column per method, with the target bands (mean ±10 %, P(A > 20°) within a factor 1.5)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ._pdf import THEORY_COLOURS, THEORY_LABELS

__all__ = ["theory_map_figure"]

_QUANTITIES = {
    "mean": ("mean_deg", "mean amplitude: theory / MC", 1.10),
    "p20": ("p20", "P(A > 20°): theory / MC", 1.5),
    "q99": ("q99_deg", "99 % point: theory / MC", 1.10),
}
_R_MARKERS = ("o", "s", "^", "D", "v")


def _method_style(name: str) -> tuple[str, str]:
    base = name.split(",")[0].strip()
    colour = THEORY_COLOURS.get(base, "grey")
    label = THEORY_LABELS.get(base, base) + (name[len(base) :] if name != base else "")
    return colour, label


def theory_map_figure(
    rows: Sequence[Mapping] | Mapping,
    *,
    methods: Sequence[str] | None = None,
    quantities: Sequence[str] = ("mean", "p20"),
    p_floor: float = 1e-3,
    title: str | None = None,
    panel_size: tuple[float, float] = (2.9, 2.6),
):
    """Theory / Monte Carlo ratios over the sea states of an accuracy map, one column per method.

    **Arguments:**

    - `rows`: the rows `benchmarks/theory_map.py` prints and writes with `--json` (a list of
      `{"hs": m, "r": -, "mc": {...}, "rows": {method: {"mean_deg", "p20", "q99_deg", ...} or {"error"}}}`),
      or that JSON's top-level dict (its `"envelope"` list is used).
    - `methods`: the methods to draw, in order (default: every method found, in order of appearance).
    - `quantities`: rows of panels, from "mean", "p20" (P(A > 20°)), "q99" (the 99 % point).
    - `p_floor`: P(A > 20°) ratios where the Monte Carlo value is below this are not targets: drawn open.
    - `title`: figure title.

    The x axis is H1/3 [m]; one line per r (marker shape); log y axis; the shaded bands are the targets (±10 %
    for the mean and the 99 % point, a factor 1.5 for P(A > 20°)). The moment method's closure order is written
    beside each of its points; a method with no result at a sea state is marked × at the bottom of the panel.

    **Returns:** the matplotlib `Figure`.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, NullFormatter

    if isinstance(rows, Mapping):
        rows = rows["envelope"]
    rows = list(rows)
    if not rows:
        raise ValueError("theory_map_figure: no rows to draw.")
    for q in quantities:
        if q not in _QUANTITIES:
            raise ValueError(f"theory_map_figure: unknown quantity {q!r}; choose from {sorted(_QUANTITIES)}.")
    found = list(dict.fromkeys(name for res in rows for name in res["rows"]))
    if methods is None:
        methods = [m for m in found if "," not in m]  # variants ("envelope_fpk, MC protocol") join their base
    variants = {m: [v for v in found if v != m and v.split(",")[0].strip() == m] for m in methods}
    rs = sorted({float(res["r"]) for res in rows})

    ncol, nrow = len(methods), len(quantities)
    fig, axes = plt.subplots(
        nrow,
        ncol,
        figsize=(panel_size[0] * ncol + 0.6, panel_size[1] * nrow + 0.8),
        sharex=True,
        sharey="row",
        squeeze=False,
    )
    for i, q in enumerate(quantities):
        key, ylabel, band = _QUANTITIES[q]
        ratios_all = []
        for j, method in enumerate(methods):
            ax = axes[i, j]
            colour, label = _method_style(method)
            ax.axhspan(1 / band, band, color="tab:green", alpha=0.13, lw=0)
            ax.axhline(1.0, color="k", lw=0.7)
            for (k, r), variant in [((k, r), None) for k, r in enumerate(rs)] + [
                ((k, r), v) for v in variants.get(method, []) for k, r in enumerate(rs)
            ]:
                pts, missing = [], []
                for res in sorted((x for x in rows if float(x["r"]) == r), key=lambda x: x["hs"]):
                    row = res["rows"].get(variant or method)
                    if row is None:
                        continue
                    mc = res["mc"]
                    if "error" in row or not (mc[key] > 0):
                        missing.append(res["hs"])
                        continue
                    target = q != "p20" or mc[key] > p_floor
                    pts.append((res["hs"], row[key] / mc[key], target, row.get("closure_order")))
                marker = "*" if variant else _R_MARKERS[k % len(_R_MARKERS)]
                if pts:
                    x = np.array([p[0] for p in pts])
                    y = np.array([p[1] for p in pts])
                    ratios_all.extend(y[np.isfinite(y) & (y > 0)])
                    ax.plot(x, y, ":" if variant else "-", color=colour, lw=1.0, alpha=0.6 if k else 1.0)
                    for xi, yi, target, order in pts:
                        ax.plot(
                            xi,
                            yi,
                            marker,
                            ms=5.5,
                            color=colour,
                            mfc=colour if target else "white",
                            label=None,
                        )
                        if order is not None:
                            ax.annotate(
                                str(order),
                                (xi, yi),
                                xytext=(3, 3),
                                textcoords="offset points",
                                fontsize=6,
                                color=colour,
                            )
                for xi in missing:
                    ax.plot(xi, 0.0, "x", color=colour, transform=ax.get_xaxis_transform(), clip_on=False)
                if variant is None:
                    ax.plot([], [], marker, ls="-", color="0.3", ms=5, label=f"r = {r:g}")
                elif pts and k == 0:
                    ax.plot([], [], "*", ls=":", color=colour, ms=7, label=variant.split(",", 1)[1].strip())
            ax.set_yscale("log")
            ax.grid(True, which="both", alpha=0.25)
            if i == 0:
                ax.set_title(label, fontsize=9, color=colour)
            if j == 0:
                ax.set_ylabel(ylabel, fontsize=8)
            if i == nrow - 1:
                ax.set_xlabel("H1/3 [m]")
            ax.tick_params(which="both", labelsize=7)
        if ratios_all:
            lo = min(min(ratios_all), 1 / band) / 1.25
            hi = max(max(ratios_all), band) * 1.25
            axes[i, 0].set_ylim(lo, hi)
            label = FuncFormatter(lambda v, _: f"{v:g}")
            for ax in axes[i]:
                ax.yaxis.set_major_formatter(label)
                # Within a decade or two the minor ticks (0.8, 2, 3, ...) carry the reading: label them too.
                ax.yaxis.set_minor_formatter(label if hi / lo < 30 else NullFormatter())
    for j, method in enumerate(methods):
        if j == ncol - 1 or variants.get(method):
            axes[0, j].legend(fontsize=7, loc="best")
    note = (
        "shaded: target band (mean and 99 % ±10 %, P(A > 20°) ×1.5); open markers: P(A > 20°) below "
        f"{p_floor:g} in the Monte Carlo (no target); digits: moment-method closure order; ×: no result"
    )
    fig.text(0.5, 0.005, note, ha="center", va="bottom", fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    return fig
