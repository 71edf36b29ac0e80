"""The exposure-risk figure of `jaxroll risk`: P(roll exceeds x within the exposure) against x."""

from __future__ import annotations

import numpy as np

from ._pdf import THEORY_COLOURS, THEORY_LABELS


def risk_figure(
    angles_deg,
    direct,
    curves: dict,
    *,
    angle_deg: float,
    hours: float,
    capsize_probability: float,
    title: str | None = None,
    splitting: dict | None = None,
):
    """P(max |φ| > x within the exposure) [-] against the angle x [deg], linear and log panels.

    - `direct`: the Monte Carlo trials of the exposure's length, P(x) = fraction of trials whose largest roll
      exceeds x or that capsized (black steps; it levels off at `capsize_probability`, drawn dotted).
    - `curves`: name → P(x) on `angles_deg`: from independent per-cycle amplitudes ("monte_carlo": the Monte Carlo
      amplitude law; theory names: their laws), or "first_passage": the envelope FPK model's first passage
      (no independence assumed; NaN where not computed).
    - `angle_deg`: the threshold asked for (vertical line); `hours`: the exposure [h].
    - `splitting`: the multilevel-splitting estimate at `angle_deg` (`probability`, `probability_ci95`), drawn as a
      point with its 95 % interval (None: not computed).

    **Returns:** the figure.
    """
    import matplotlib.pyplot as plt  # imported where used: `import jaxroll.plotting` loads no pyplot

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    x = np.asarray(angles_deg, float)
    for ax, log in zip(axes, (False, True), strict=True):
        d = np.asarray(direct, float)
        ax.step(
            x,
            np.where(d > 0, d, np.nan) if log else d,
            "k-",
            where="post",
            lw=1.4,
            label="Monte Carlo, trials of the exposure's length",
        )
        for name, p in curves.items():
            p = np.asarray(p, float)
            label = (
                "Monte Carlo amplitudes (independent)"
                if name == "monte_carlo"
                else THEORY_LABELS.get(name, name)
            )
            ax.plot(
                x,
                np.where(p > 0, p, np.nan) if log else p,
                "--" if name == "monte_carlo" else "-",
                color="tab:green" if name == "monte_carlo" else THEORY_COLOURS.get(name, "c"),
                lw=1.3,
                label=label,
            )
        if capsize_probability > 0:
            ax.axhline(
                capsize_probability,
                color="tab:red",
                ls=":",
                lw=1.0,
                label=f"P(capsize) = {capsize_probability:.3g}",
            )
        if splitting is not None:
            p, (lo, hi) = float(splitting["probability"]), (float(v) for v in splitting["probability_ci95"])
            ax.errorbar(
                [angle_deg],
                [p],
                yerr=[[max(p - lo, 0.0)], [max(hi - p, 0.0)]],
                fmt="D",
                color="tab:purple",
                ms=5,
                capsize=3,
                label=f"multilevel splitting at {angle_deg:g}°: {p:.3g} (95 % {lo:.2g}–{hi:.2g})",
            )
        ax.axvline(angle_deg, color="0.5", ls="-.", lw=0.8)
        ax.set_xlabel("roll angle x [deg]")
        ax.set_ylabel(f"P(max |φ| > x within {hours:g} h)")
        if log:
            ax.set_yscale("log")
            extra = [] if splitting is None else [np.asarray([splitting["probability_ci95"][0]], float)]
            finite = [
                np.nanmin(np.where(np.asarray(c) > 0, c, np.nan))
                for c in [direct, *curves.values(), *extra]
                if np.any(np.asarray(c) > 0)
            ]
            ax.set_ylim(max(min(finite, default=1e-6), 1e-8) / 2, 1.5)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    return fig


__all__ = ["risk_figure"]
