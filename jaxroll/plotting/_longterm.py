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


def longterm_scatter_figure(ds, angle_index: int = 0):
    """The scatter diagram (H_s × T_z) twice: the occurrence probabilities, and each sea state's share of the
    long-term probability at the angle of index `angle_index` (summed over headings, speeds and ships), both
    coloured on log scales and written in the cells (shares in %).

    **Returns:** the matplotlib `Figure`."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    w = ds["weight"].values
    occ = w.sum(axis=(2, 3, 4))
    contrib = np.nan_to_num(w * ds["probability"].values[..., angle_index]).sum(axis=(2, 3, 4))
    total = contrib.sum()
    share = contrib / total if total > 0 else contrib
    tz, hs = ds.tz.values, ds.hs.values
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2), layout="constrained", sharey=True)
    for ax, values, title, fmt in (
        (axes[0], occ, "occurrence probability of the sea state", "{:.2g}"),
        (axes[1], share, f"share of the long-term {_angle_label(ds, angle_index)}", "{:.1%}"),
    ):
        shown = np.ma.masked_less_equal(values, 0)
        vmax = float(shown.max()) if shown.count() else 1.0
        norm = LogNorm(vmin=max(vmax * 1e-5, 1e-12), vmax=vmax) if shown.count() else None
        mesh = ax.pcolormesh(
            _edges(tz),
            _edges(hs),
            shown,
            cmap="viridis" if ax is axes[0] else "magma_r",
            norm=norm,
            shading="flat",
        )
        fig.colorbar(mesh, ax=ax, shrink=0.8)
        big = values >= 0.01 * vmax
        for i, h in enumerate(hs):
            for j, t in enumerate(tz):
                if values[i, j] > 0 and (big[i, j] or values.size <= 80):
                    dark = (values[i, j] >= 0.05 * vmax) == (ax is axes[1])  # magma_r is dark at the top
                    ax.text(
                        t,
                        h,
                        fmt.format(values[i, j]),
                        ha="center",
                        va="center",
                        fontsize=5,
                        color="w" if dark else "k",
                    )
        ax.set_xlabel("T_z [s] (T01 = 1.0864 T_z)")
        ax.set_title(title, fontsize=9)
    axes[0].set_ylabel("H_s [m]")
    ships = ", ".join(str(s) for s in ds.ship.values)
    fig.suptitle(
        f"{ships}: long-term P = {float(ds.longterm_probability[angle_index]):.3g} per exposure "
        f"(95 % {float(ds.longterm_probability_ci95[angle_index, 0]):.3g}–"
        f"{float(ds.longterm_probability_ci95[angle_index, 1]):.3g})",
        fontsize=10,
    )
    return fig


def longterm_polar_figure(ds, angle_index: int = 0):
    """Operational guidance: the long-term probability of exceeding the angle (and of capsize) per exposure,
    given the heading and speed (the sea states and loadings weighted as in the assessment), as polar charts over
    the heading class χ' ∈ [0°, 180°] (port and starboard alike) × speed.

    **Returns:** the matplotlib `Figure`."""
    import matplotlib.pyplot as plt

    w = ds["weight"].values  # (hs, tz, heading, speed, ship)
    p = np.nan_to_num(ds["probability"].values[..., angle_index])
    c = np.nan_to_num(ds["capsize_probability"].values)
    classes = np.unique(ds.heading_class_deg.values)
    speeds = ds.speed.values
    member = ds.heading_class_deg.values
    risk = np.zeros((classes.size, speeds.size))
    cap = np.zeros_like(risk)
    for a, chi in enumerate(classes):
        sel = member == chi
        ww = w[:, :, sel].sum(axis=2)  # weights within the class
        norm = ww.sum(axis=(0, 1, 3))
        risk[a] = np.where(
            norm > 0, (ww * p[:, :, sel][:, :, 0]).sum(axis=(0, 1, 3)) / np.where(norm > 0, norm, 1), 0
        )
        cap[a] = np.where(
            norm > 0, (ww * c[:, :, sel][:, :, 0]).sum(axis=(0, 1, 3)) / np.where(norm > 0, norm, 1), 0
        )
    fig, axes = plt.subplots(
        1, 2, subplot_kw={"projection": "polar"}, figsize=(10, 4.8), layout="constrained"
    )
    for ax, values, what in ((axes[0], risk, _angle_label(ds, angle_index)), (axes[1], cap, "P(capsize)")):
        vmax = max(float(values.max()), 1e-12)
        mesh = polar_risk_chart(ax, classes, speeds, values, label=what, vmax=vmax, fmt="{:.2g}")
        fig.colorbar(mesh, ax=ax, shrink=0.6, label="per exposure, given heading and speed")
    fig.suptitle(
        "long-term risk given heading χ (angle; 180° head seas at the top, port and starboard alike) and "
        "speed U [m/s] (radius)",
        fontsize=9,
    )
    return fig


def longterm_ci_figure(ds, summary: dict | None = None, angle_index: int = 0):
    """The long-term probability's 95 % interval against the Monte Carlo effort: the sampling half-width read
    from the first 1/16 … all of every brute-force Monte Carlo cell's trials (points; splitting cells enter each
    point with their whole run, dotted) and its 1/√N continuation (dashed), on
    top of the model allowance of the theory cells (which no Monte Carlo effort shrinks). With no Monte Carlo cell,
    the interval is the allowance alone.

    **Returns:** the matplotlib `Figure`."""
    import matplotlib.pyplot as plt

    from ..longterm import longterm_summary

    summary = longterm_summary(ds) if summary is None else summary
    a = angle_index
    p = float(ds.longterm_probability[a])
    below, above = float(ds.longterm_model_below[a]), float(ds.longterm_model_above[a])
    fig, ax = plt.subplots(figsize=(7.5, 4.6), layout="constrained")
    effort = summary.get("ci_against_effort") or {}
    if effort:
        n = np.asarray(effort["trials"], float)
        half = np.asarray(effort["sampling_half_width"], float)[:, a]
        ax.plot(
            n, half, "o-", color="tab:blue", label="sampling ±1.96 σ (first fraction of each cell's trials)"
        )
        more = np.geomspace(n[-1], 100 * n[-1], 20)
        ax.plot(more, half[-1] * np.sqrt(n[-1] / more), "--", color="tab:blue", label="∝ 1/√N beyond")
        if below or above:
            ax.axhline(
                max(below, above), color="tab:red", label="model allowance of the theory cells (max side)"
            )
        split = effort.get("splitting_half_width")
        if split is not None and split[a] > 0:  # splitting cells enter every point with their whole run
            ax.axhline(split[a], color="tab:green", ls=":", label="of which the splitting cells (whole runs)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(
            "Monte Carlo trials in all cells" + (" (splitting cells: their cost in trials)" if split else "")
        )
        ax.set_ylabel("half-width of the long-term 95 % interval")
    else:
        ax.bar(
            [0],
            [below + above],
            bottom=[p - below],
            width=0.4,
            color="tab:red",
            alpha=0.4,
            label="model allowance (theory cells)",
        )
        ax.plot([0], [p], "ko", label="long-term probability")
        ax.set_xticks([])
        ax.set_ylabel(_angle_label(ds, a))
        ax.set_xlim(-1, 1)
    ax.set_title(f"{_angle_label(ds, a)} = {p:.3g}: the interval against effort", fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    return fig
