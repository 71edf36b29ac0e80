"""Paper-style figures (the only module of the numerical package that imports matplotlib).

Colours follow the paper: Monte Carlo / experiment zero-crossing amplitudes black dots, envelope red dots;
theories as lines — Roberts blue, ESAM yellow, moment method purple. When an experiment is shown, the Monte
Carlo dots turn green (filled: zero-crossing, open: envelope).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

THEORY_COLOURS = {
    "roberts": "tab:blue",
    "esam": "gold",
    "moment": "purple",
    "envelope_fpk": "teal",
    "first_passage": "tab:orange",
}
THEORY_LABELS = {
    "roberts": "Roberts (SAM)",
    "esam": "ESAM",
    "moment": "moment method",
    "envelope_fpk": "envelope FPK (coloured averaging)",
    "first_passage": "envelope FPK, first passage (large rolls in groups)",
}


@dataclass
class Curve:
    """One curve of an amplitude-PDF figure: density per degree on bin centres or a grid."""

    x_deg: np.ndarray
    density: np.ndarray
    label: str
    style: str = "dots"  # "dots", "open" or "line"
    color: str = "k"


def amplitude_curves(summary: dict, *, experiment: dict | None = None) -> list[Curve]:
    """Curves of a `pdf.json`-like summary: Monte Carlo, optional experiment, and every theory present."""
    edges = np.asarray(summary["bins_deg"], dtype=float)
    centres = (edges[1:] + edges[:-1]) / 2
    curves = []
    mc_colours = ("tab:green", "tab:green") if experiment else ("k", "tab:red")
    styles = ("dots", "open") if experiment else ("dots", "dots")
    for (key, name), colour, style in zip(
        (("pdf_zero_crossing", "zero-crossing"), ("pdf_envelope", "envelope")),
        mc_colours,
        styles,
        strict=True,
    ):
        if summary.get(key) is not None:
            label = f"MCS {name}"
            if summary.get("n_capsized"):
                label += f" (given no capsize: {summary['n_realizations'] - summary['n_capsized']} survivors)"
            curves.append(Curve(centres, np.asarray(summary[key], float), label, style, colour))
    if experiment:
        for key, name, colour in (
            ("pdf_zero_crossing", "zero-crossing", "k"),
            ("pdf_envelope", "envelope", "tab:red"),
        ):
            if experiment.get(key) is not None:
                curves.append(
                    Curve(centres, np.asarray(experiment[key], float), f"experiment {name}", "dots", colour)
                )
    for method, result in (summary.get("theory") or {}).items():
        label = THEORY_LABELS.get(method, method)
        if result.get("estimator"):
            label += f" ({result['estimator'].replace('_', '-')})"
        curves.append(
            Curve(centres, np.asarray(result["pdf"], float), label, "line", THEORY_COLOURS.get(method, "c"))
        )
    return curves


def plot_amplitude_pdf(curves: Sequence[Curve], *, log: bool = False, ax=None, title: str | None = None):
    """Draw amplitude PDFs [1/deg] against amplitude [deg]; `log=True` gives the paper's semi-log tail view.

    **Returns:** the matplotlib `Axes`.
    """
    if ax is None:
        import matplotlib.pyplot as plt  # imported where used: `import jaxroll.plotting` loads no pyplot

        _, ax = plt.subplots(figsize=(6.0, 4.2))
    ymax = 0.0
    for c in curves:
        y = np.where(c.density > 0, c.density, np.nan) if log else c.density
        if c.style == "line":
            ax.plot(c.x_deg, y, "-", color=c.color, lw=1.8, label=c.label)
        else:
            face = "none" if c.style == "open" else c.color
            ax.plot(c.x_deg, y, "o", ms=3.5, mfc=face, mec=c.color, label=c.label)
        if np.any(np.isfinite(c.density)):
            ymax = max(ymax, float(np.nanmax(c.density)))
    ax.set_xlabel("roll amplitude [deg]")
    ax.set_ylabel("probability density [1/deg]")
    if log:
        ax.set_yscale("log")
        positive = [
            np.nanmin(np.where(c.density > 0, c.density, np.nan)) for c in curves if np.any(c.density > 0)
        ]
        if positive and ymax > 0:
            ax.set_ylim(max(min(positive) / 2, ymax * 1e-7), ymax * 2)
    else:
        ax.set_ylim(0, ymax * 1.1 if ymax > 0 else 1)
    ax.set_xlim(left=0)
    ax.grid(True, alpha=0.3, which="both" if log else "major")
    if curves:
        ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=9)
    return ax


def amplitude_pdf_figures(summary: dict, *, experiment: dict | None = None, title: str | None = None):
    """Linear and log figures of a `pdf.json`-like summary. **Returns:** `(fig_linear, fig_log)`."""
    curves = amplitude_curves(summary, experiment=experiment)
    import matplotlib.pyplot as plt

    figs = []
    for log in (False, True):
        fig, ax = plt.subplots(figsize=(6.0, 4.2))
        plot_amplitude_pdf(curves, log=log, ax=ax, title=title)
        if summary.get("reason"):
            ax.text(
                0.5,
                0.5,
                "Monte Carlo: " + summary["reason"],
                transform=ax.transAxes,
                ha="center",
                va="center",
                wrap=True,
                fontsize=8,
                color="tab:red",
            )
        st = summary.get("stationarity") or {}
        if (
            st.get("stationary") is False
        ):  # the Monte Carlo's law depends on the initial roll and the duration
            ax.text(
                0.99,
                0.91,
                f"Monte Carlo not stationary: mean envelope {st['mean_envelope_first_half_deg']:.3g}° "
                f"→ {st['mean_envelope_second_half_deg']:.3g}°\nbetween the halves of the run (see the JSON)",
                transform=ax.transAxes,
                ha="right",
                va="top",
                fontsize=7,
                color="tab:red",
            )
        if summary.get(
            "theory_left_out"
        ):  # a theory with no law in this sea state: said, not silently missing
            names = ", ".join(THEORY_LABELS.get(n, n) for n in summary["theory_left_out"])
            ax.text(
                0.99,
                0.99,
                f"no law in this sea state: {names} (see the JSON)",
                transform=ax.transAxes,
                ha="right",
                va="top",
                fontsize=7,
                color="0.35",
            )
        figs.append(fig)
    return figs[0], figs[1]


def maxima_figures(
    centres_deg, histograms: dict, *, title: str | None = None, capsize_probability: dict | None = None
):
    """The paper's Figs. 12-13 analogue: Monte Carlo PDFs [1/deg] of the maximum amplitude, one curve per N0.

    `capsize_probability` maps N0 to P(capsize before the N0-th amplitude) [-]: the histograms are then defective
    (they integrate to 1 - P) and the legend says so.
    **Returns:** `(fig_linear, fig_log)`.
    """
    capsize_probability = capsize_probability or {}
    import matplotlib.pyplot as plt

    figs = []
    for log in (False, True):
        fig, ax = plt.subplots(figsize=(7.6, 4.2))
        for n0, h in sorted(histograms.items()):
            h = np.asarray(h, float)
            p = capsize_probability.get(n0, 0.0)
            label = f"N0 = {n0}" + (f"\nP(capsize) = {p:.3g}" if p else "")
            ax.plot(centres_deg, np.where(h > 0, h, np.nan) if log else h, "o-", ms=3, lw=0.8, label=label)
        ax.set_xlabel("maximum roll amplitude [deg]")
        ax.set_ylabel("probability density [1/deg]")
        if log:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
        # beside the axes, not over them: the large-N0 peaks sit at the top right, where a legend inside went
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
        if capsize_probability and any(capsize_probability.values()):
            ax.text(
                1.01,
                0.0,
                "P(capsize): trials that\ncapsized before N0, maxima\nbeyond the vanishing angle\n"
                "(not in the curves)",
                transform=ax.transAxes,
                fontsize=7,
                va="bottom",
                ha="left",
                color="0.3",
            )
        if title:
            ax.set_title(title, fontsize=9)
        figs.append(fig)
    return figs[0], figs[1]


def maxima_comparison_figure(
    centres_deg,
    histogram,
    grid_deg,
    curves: dict,
    n0: int,
    *,
    title: str | None = None,
    capsize_probability: float = 0.0,
    n_trials: int | None = None,
):
    """The paper's Figs. 14-19 analogue: MCS maxima PDF (dots) vs P*(A_M), exact (solid) and asymptotic (dashed).

    `curves` maps a source ("mcs_amplitudes", "moment", "roberts", …) to {"exact": …, "asymptotic": …} [1/deg].
    `title` names the ship and sea state; `capsize_probability` [-] (trials that capsized before N0, the
    histogram's missing mass) and `n_trials` are stated on the figure.
    **Returns:** the figure (linear and log panels).
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    colours = {"mcs_amplitudes": "tab:green", **THEORY_COLOURS}
    labels = {"mcs_amplitudes": "P from MCS amplitudes", **THEORY_LABELS}
    for ax, log in zip(axes, (False, True), strict=True):
        h = np.asarray(histogram, float)
        ax.plot(centres_deg, np.where(h > 0, h, np.nan) if log else h, "ko", ms=3.5, label="MCS maxima")
        for name, c in curves.items():
            col = colours.get(name, "c")
            exact, asymptotic = np.asarray(c["exact"], float), np.asarray(c["asymptotic"], float)
            label = labels.get(name, name)
            ax.plot(grid_deg, exact, "-", color=col, lw=2.4, alpha=0.55, label=f"{label}: exact")
            # dashes over the wide, light exact curve: at large N0 the two coincide, and a dashed line drawn under a
            # solid one of the same colour was invisible
            close = (
                np.nanmax(np.abs(asymptotic - exact)) <= 0.01 * np.nanmax(exact)
                if np.any(exact > 0)
                else False
            )
            ax.plot(
                grid_deg,
                asymptotic,
                "--",
                color=col,
                lw=1.0,
                zorder=3,
                label=f"{label}: asymptotic" + (" (= exact within 1 %)" if close else ""),
            )
        ax.set_xlabel("maximum roll amplitude [deg]")
        ax.set_ylabel("probability density [1/deg]")
        if log:
            ax.set_yscale("log")
            peak = np.nanmax(h) if np.any(h > 0) else 1.0
            ax.set_ylim(peak * 1e-5, peak * 5)
        ax.grid(True, alpha=0.3)
        head = f"N0 = {n0}" + (f", {n_trials} trials" if n_trials is not None else "")
        if capsize_probability:
            head += f"; P(capsize before N0) = {capsize_probability:.3g} (not in the dots)"
        ax.set_title(head, fontsize=8)
    axes[0].legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    return fig
