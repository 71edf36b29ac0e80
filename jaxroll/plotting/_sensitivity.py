"""Figure of design sensitivities: Monte Carlo derivatives (± 2 standard errors) beside the theories'."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

__all__ = ["sensitivity_bar_chart"]

_THEORY_STYLE = {"roberts": "C1", "esam": "C2", "moment": "C3"}
_THEORY_NAMES = {
    "roberts": "Roberts (SAM)",
    "esam": "ESAM",
    "moment": "moment method",
    "envelope_fpk": "envelope FPK",
}
_STATISTIC_LABELS = {
    "E_phi2_deg2": "E[φ²] [deg²]",
    "mean_envelope_deg": "mean envelope amplitude [deg]",
    "mean_zero_crossing_deg": "mean zero-crossing amplitude [deg]",
}
_PARAMETER_LABELS = {
    "gm0": ("GM0", "m"),
    "b1": ("b1", "1/s"),
    "b2": ("b2", "1/rad"),
    "b3": ("b3", "s/rad²"),
    "gm_correction": ("r = σ_obs/σ_thr", ""),
    "hs": ("H1/3", "m"),
    "t01": ("T01", "s"),
    "speed": ("U", "m/s"),
    **{f"c{k}": (f"C{k} of ΔGM", f"m^{1 - k}") for k in range(7)},
}


def statistic_label(key: str) -> str:
    """The words for a `sensitivity.json` statistic key: 'E_phi2_deg2' → 'E[φ²] [deg²]', 'P_exceed_20deg' →
    'P(envelope > 20°)' (the fraction of time), 'P_exceed_zc_20deg' → 'P(zero-crossing amplitude > 20°)'."""
    import re

    if key in _STATISTIC_LABELS:
        return _STATISTIC_LABELS[key]
    m = re.fullmatch(r"P_exceed(_zc)?_([0-9.]+)deg", key)
    if m:
        return f"P({'zero-crossing amplitude' if m.group(1) else 'envelope'} > {float(m.group(2)):g}°)"
    return key


def parameter_label(name: str, step: float) -> str:
    """The tick label of a parameter and its step, e.g. 'H1/3 +0.7 m'."""
    words, unit = _PARAMETER_LABELS.get(name, (name, ""))
    return f"{words}\n+{step:.3g}{f' {unit}' if unit else ''}"


def sensitivity_bar_chart(
    payload: Mapping, *, statistics: Sequence[str] | None = None, title: str | None = None
):
    """Grouped bars of the change of each statistic for a step of each parameter: the Monte Carlo derivative
    (error bar: ± 2 standard errors) and, where present, Roberts', ESAM's and the moment method's.

    `payload` is what `jaxroll sensitivity` writes (`sensitivity.json`): `payload["gradients"][stat][param]` =
    `{"monte_carlo": {"value", "std_error"}, "theory": {name: value or None}}` per unit of the parameter, and
    `payload["parameters"][param]["step"]`, the step Δθ the bars show (derivative × Δθ, so that parameters of
    different units share one axis: 10 % of the nominal value, or 1 unit when it is 0). One panel per statistic.

    **Returns:** the matplotlib `Figure`.
    """
    import matplotlib.pyplot as plt

    grads = payload["gradients"]
    names = list(statistics) if statistics is not None else list(grads)
    params = list(payload["parameters"])
    steps = {p: float(payload["parameters"][p]["step"]) for p in params}
    theories = sorted({t for s in names for p in params for t in (grads[s][p].get("theory") or {})})
    series = ["monte_carlo", *theories]
    ncol = min(2, len(names))
    nrow = math.ceil(len(names) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(6.0 * ncol, 3.4 * nrow), squeeze=False)
    width = 0.8 / len(series)
    x = np.arange(len(params))
    for ax, stat in zip(axes.ravel(), names, strict=False):
        for i, name in enumerate(series):
            vals, errs = [], []
            for p in params:
                entry = grads[stat][p]
                if name == "monte_carlo":
                    v, e = entry["monte_carlo"]["value"], entry["monte_carlo"]["std_error"]
                else:
                    v, e = (entry.get("theory") or {}).get(name), None
                vals.append(np.nan if v is None else v * steps[p])
                errs.append(np.nan if e is None else 2 * e * abs(steps[p]))
            pos = x - 0.4 + width * (i + 0.5)
            color = "C0" if name == "monte_carlo" else _THEORY_STYLE.get(name, f"C{4 + i}")
            label = "Monte Carlo (± 2 SE)" if name == "monte_carlo" else _THEORY_NAMES.get(name, name)
            ax.bar(pos, vals, width, color=color, label=label,
                   yerr=errs if name == "monte_carlo" else None, capsize=2)  # fmt: skip
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xticks(x, [parameter_label(p, steps[p]) for p in params], fontsize=8)
        ax.set_ylabel(f"Δ {statistic_label(stat)}", fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes.ravel()[len(names) :]:
        ax.set_visible(False)
    axes.ravel()[0].legend(fontsize=8)
    note = "bars: the change for the step under each parameter (10 % of its value; 1 unit where it is 0)"
    fig.suptitle(f"{title}\n{note}" if title else note, fontsize=10)
    fig.tight_layout()
    return fig
