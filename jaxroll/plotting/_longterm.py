"""Figures of a long-term assessment (`jaxroll.longterm`): the scatter table coloured by contribution, the polar
guidance chart of risk over heading × speed, and the long-term interval against the Monte Carlo effort."""

from __future__ import annotations

import numpy as np

from ._polar import polar_risk_chart

__all__ = ["longterm_ci_figure", "longterm_polar_figure", "longterm_scatter_figure"]


def _angle_label(ds, a: int) -> str:
    return f"P(max |φ| > {float(ds.angle_deg[a]):g}° within {_hours(ds):g} h)"


def _hours(ds) -> float:
    import json

    return json.loads(ds.attrs["config_json"])["exposure_s"] / 3600.0


def _edges(x):
    x = np.asarray(x, float)
    if x.size == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5])
    mid = (x[1:] + x[:-1]) / 2
    return np.concatenate([[2 * x[0] - mid[0]], mid, [2 * x[-1] - mid[-1]]])


def _angles(ds, angle_index) -> list[int]:
    """The angles' indices a figure draws: every `--angle` (None), or the one given."""
    return list(range(ds.angle_deg.size)) if angle_index is None else [int(angle_index)]


def _grid(n: int):
    """(rows, columns) of `n` panels, at most three a row."""
    cols = min(3, n)
    return -(-n // cols), cols


def _percent(v: float) -> str:
    """A share or probability in % with two significant digits and no exponent (cells are narrow)."""
    x = 100.0 * v
    return f"{x:.2g}" if x >= 0.01 else "<0.01"


def longterm_scatter_figure(ds, angle_index: int | None = None):
    """The scatter diagram (H_s × T_z): the occurrence probabilities, and each sea state's share of the long-term
    probability at every angle (summed over headings, speeds and ships; `angle_index`: one angle only), coloured
    on log scales and written in the cells in % (where they carry 1 % of the panel's largest, or every cell of a
    small table).

    **Returns:** the matplotlib `Figure`."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    w = ds["weight"].values
    occ = w.sum(axis=(2, 3, 4))
    tz, hs = ds.tz.values, ds.hs.values
    panels = [(occ, "occurrence of the sea states", "occurrence [%]", "viridis")]
    for a in _angles(ds, angle_index):
        contrib = np.nan_to_num(w * ds["probability"].values[..., a]).sum(axis=(2, 3, 4))
        total = contrib.sum()
        panels.append(
            (
                contrib / total if total > 0 else contrib,
                f"long-term {_angle_label(ds, a)} = {float(ds.longterm_probability[a]):.3g}:\neach sea state's share",
                f"share of P_LT at {float(ds.angle_deg[a]):g}° [%]",
                "magma_r",
            )
        )
    rows, cols = _grid(len(panels))
    cell_w = min(0.6, max(0.34, 5.5 / tz.size))  # [in]: room for "0.074" at the cells' font size
    cell_h = min(0.45, max(0.24, 4.5 / hs.size))
    width, height = cell_w * tz.size + 1.6, cell_h * hs.size + 1.3
    fontsize = 6.5 if cell_w < 0.45 else 8
    fig, axes = plt.subplots(
        rows, cols, figsize=(width * cols, height * rows + 0.5), layout="constrained", squeeze=False
    )
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax, (values, title, bar_label, cmap) in zip(axes.flat, panels, strict=False):
        shown = np.ma.masked_less_equal(100.0 * values, 0)  # in %, as the cells' text
        vmax = float(shown.max()) if shown.count() else 1.0
        norm = LogNorm(vmin=max(vmax * 1e-5, 1e-12), vmax=vmax) if shown.count() else None
        mesh = ax.pcolormesh(_edges(tz), _edges(hs), shown, cmap=cmap, norm=norm, shading="flat")
        fig.colorbar(mesh, ax=ax, shrink=0.85, label=bar_label)
        big = 100.0 * values >= 0.01 * vmax
        for i, h in enumerate(hs):
            for j, t in enumerate(tz):
                if values[i, j] > 0 and (big[i, j] or values.size <= 80):
                    dark = (100.0 * values[i, j] >= 0.05 * vmax) == (
                        cmap == "magma_r"
                    )  # magma_r is dark at the top
                    ax.text(t, h, _percent(values[i, j]), ha="center", va="center", fontsize=fontsize,
                            color="w" if dark else "k")  # fmt: skip
        ax.set_xlabel("T_z [s] (T01 = 1.0864 T_z)")
        ax.set_ylabel("H_s [m]")
        ax.set_title(title, fontsize=9)
    ships = ", ".join(str(s) for s in ds.ship.values)
    fig.suptitle(
        f"{ships}: the sea states and their shares of the long-term probability per exposure (95 % intervals: "
        "longterm.json)",
        fontsize=10,
    )
    return fig


def longterm_polar_figure(ds, angle_index: int | None = None):
    """Operational guidance: the long-term probability of exceeding each angle (`angle_index`: one only) and of
    capsize per exposure, given the heading and speed (the sea states and loadings weighted as in the assessment),
    as polar charts over the heading class χ' ∈ [0°, 180°] (port and starboard alike) × speed; each panel says
    what it shows under its colour bar. For a ship carrying a direct wave moment each angle has two panels: the
    total, and the parametric-only probability (`parametric_probability`: the moment off).

    **Returns:** the matplotlib `Figure`."""
    import matplotlib.pyplot as plt

    w = ds["weight"].values  # (hs, tz, heading, speed, ship)
    classes = np.unique(ds.heading_class_deg.values)
    speeds = ds.speed.values
    member = ds.heading_class_deg.values

    def given_heading_and_speed(p):
        out = np.zeros((classes.size, speeds.size))
        for a, chi in enumerate(classes):
            sel = member == chi
            ww = w[:, :, sel].sum(axis=2)  # weights within the class
            norm = ww.sum(axis=(0, 1, 3))
            out[a] = np.where(
                norm > 0, (ww * p[:, :, sel][:, :, 0]).sum(axis=(0, 1, 3)) / np.where(norm > 0, norm, 1), 0
            )
        return out

    # a ship carrying a direct wave moment: each angle's total beside its parametric-only share (docs/longterm.md)
    moment = "direct_moment" in ds and bool(ds["direct_moment"].values.any())
    panels = []
    for a in _angles(ds, angle_index):
        label = _angle_label(ds, a)
        total = given_heading_and_speed(np.nan_to_num(ds["probability"].values[..., a]))
        panels.append((total, label + ("\nwith the direct wave moment" if moment else ""), None))
        if moment:  # on the total's colour scale, so that the two compare at a glance
            p = given_heading_and_speed(np.nan_to_num(ds["parametric_probability"].values[..., a]))
            top = max(float(total.max()), float(p.max()))
            panels[-1] = (*panels[-1][:2], top)
            panels.append((p, label + "\nparametric only (the moment off)", top))
    panels.append(
        (
            given_heading_and_speed(np.nan_to_num(ds["capsize_probability"].values)),
            f"P(capsize within {_hours(ds):g} h)",
            None,
        )
    )
    rows, cols = _grid(len(panels))
    fig, axes = plt.subplots(
        rows, cols, subplot_kw={"projection": "polar"}, figsize=(4.6 * cols, 4.9 * rows + 0.4),
        layout="constrained", squeeze=False,
    )  # fmt: skip
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    for ax, (values, what, top) in zip(axes.flat, panels, strict=False):
        vmax = max(float(values.max()) if top is None else top, 1e-12)
        mesh = polar_risk_chart(ax, classes, speeds, values, label="", vmax=vmax, fmt="{:.2g}")
        bar = fig.colorbar(mesh, ax=ax, shrink=0.8, location="bottom", pad=0.02, format="%.2g",
                           label=f"{what}\nper exposure, given heading and speed")  # fmt: skip
        bar.ax.tick_params(labelsize=7)
    fig.suptitle(
        "long-term risk given heading χ (180° head seas at the top; port and starboard alike) and speed U [m/s] "
        "(radius)",
        fontsize=9,
    )
    return fig


def longterm_ci_figure(ds, summary: dict | None = None, angle_index: int | None = None):
    """The long-term probability's 95 % interval at every angle (`angle_index`: one only). With Monte Carlo cells:
    its half-width against the Monte Carlo effort, the sampling part read from the first 1/16 … all of every
    brute-force cell's trials (points; splitting cells enter each point with their whole run, dotted) with its
    1/√N continuation (dashed), beside the model allowance of the theory cells (which no Monte Carlo effort
    shrinks), one colour per angle. With no Monte Carlo cell: the long-term probability and its interval (the
    allowance alone) against the angle.

    **Returns:** the matplotlib `Figure`."""
    import matplotlib.pyplot as plt

    from ..longterm import longterm_summary

    summary = longterm_summary(ds) if summary is None else summary
    angles = _angles(ds, angle_index)
    effort = summary.get("ci_against_effort") or {}
    fig, ax = plt.subplots(figsize=(9.5 if effort else 7.5, 4.6), layout="constrained")
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    if effort:
        n = np.asarray(effort["trials"], float)
        split = effort.get("splitting_half_width")
        from matplotlib.lines import Line2D

        handles = []
        for k, a in enumerate(angles):
            colour = colours[k % len(colours)]
            handles.append(Line2D([], [], color=colour, lw=3, label=f"{float(ds.angle_deg[a]):g}°"))
            half = np.asarray(effort["sampling_half_width"], float)[:, a]
            ax.plot(n, half, "o-", color=colour)
            more = np.geomspace(n[-1], 100 * n[-1], 20)
            ax.plot(more, half[-1] * np.sqrt(n[-1] / more), "--", color=colour)
            allowance = max(float(ds.longterm_model_below[a]), float(ds.longterm_model_above[a]))
            if allowance > 0:
                ax.axhline(allowance, color=colour, ls="-.", lw=1.0)
            if split is not None and split[a] > 0:  # splitting cells enter every point with their whole run
                ax.axhline(split[a], color=colour, ls=":")
        handles += [
            Line2D(
                [], [], color="k", marker="o", label="sampling ±1.96 σ (first fraction of each cell's trials)"
            ),
            Line2D([], [], color="k", ls="--", label="∝ 1/√N beyond"),
            Line2D([], [], color="k", ls="-.", label="model allowance of the theory cells (max side)"),
        ]
        if split is not None and any(v > 0 for v in split):
            handles.append(
                Line2D([], [], color="k", ls=":", label="of which the splitting cells (whole runs)")
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(
            "Monte Carlo trials in all cells" + (" (splitting cells: their cost in trials)" if split else "")
        )
        ax.set_ylabel("half-width of the long-term 95 % interval")
        ax.set_title(f"the long-term interval against the Monte Carlo effort (per exposure of {_hours(ds):g} h)",
                     fontsize=9)  # fmt: skip
    else:
        x = np.array([float(ds.angle_deg[a]) for a in angles])
        p = np.array([float(ds.longterm_probability[a]) for a in angles])
        lo = np.array([float(ds.longterm_probability_ci95[a, 0]) for a in angles])
        hi = np.array([float(ds.longterm_probability_ci95[a, 1]) for a in angles])
        ax.errorbar(x, p, yerr=[p - lo, hi - p], fmt="ko", capsize=6, elinewidth=6, ecolor=(0.84, 0.15, 0.16, 0.4),
                    label="long-term probability, 95 % interval (model allowance of the theory cells)")  # fmt: skip
        for xi, pi in zip(x, p, strict=True):
            ax.annotate(
                f"{pi:.3g}", (xi, pi), xytext=(8, 0), textcoords="offset points", va="center", fontsize=8
            )
        if x.size > 1:
            ax.plot(x, p, "k-", lw=0.8, alpha=0.5)
        if np.all(lo > 0):
            ax.set_yscale("log")
            ax.set_ylim(lo.min() / 2, min(hi.max() * 2, 1.5))
        else:
            ax.set_ylim(0, min(1.05, 1.3 * hi.max()) if hi.max() > 0 else 1)
        pad = max(2.0, 0.1 * float(np.ptp(x)))
        ax.set_xlim(x.min() - pad, x.max() + pad)
        ax.set_xticks(x)
        ax.set_xticklabels([f"{v:g}°" for v in x])
        ax.set_xlabel("roll angle [deg]")
        ax.set_ylabel(f"P(max |φ| > angle within {_hours(ds):g} h)")
        ax.set_title("long-term probability per exposure (no Monte Carlo cell: the interval is the theory's "
                     "model allowance)", fontsize=9)  # fmt: skip
    ax.grid(alpha=0.3, which="both")
    if effort:  # the angles by colour, the parts by line style
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    else:
        ax.legend(fontsize=7, loc="lower left")
    return fig
