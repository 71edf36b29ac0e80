"""Figures of the calibration (matplotlib only here and in the CLI; never `plt.show()`).

Every function draws on `ax` (a new figure when None) and returns the `Axes` (or the `Figure` for multi-panel
figures). Angles are shown in degrees, times at full scale.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # imported where used: `import jaxroll.plotting` does not load the calibration
    from ..calibration import CaptiveFit, DecayFit, RollFit, SeaStateComparison, TimeDomainFit


def _axes(ax, figsize=(6.0, 4.0)):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize)
    return ax


def plot_extinction(fits: DecayFit | Sequence[DecayFit], *, ax=None):
    """Extinction curve: decrement per half swing Δφ against the mean amplitude φ_m [deg], the measured points
    (from the first fit that has them) and the curve aφ_m + bφ_m² + cφ_m³ of every fit."""
    from ..calibration import DecayFit

    fits = [fits] if isinstance(fits, DecayFit) else list(fits)
    ax = _axes(ax)
    x_max = 0.0
    for f in fits:
        if "mean_amplitude" in f.curves:
            pm, dec = np.degrees(f.curves["mean_amplitude"]), np.degrees(f.curves["decrement"])
            ax.plot(pm, dec, "ko", ms=4, mfc="none", label="measured half swings")
            x_max = max(x_max, pm.max())
            break
    x_max = x_max or 20.0
    phi = np.radians(np.linspace(0, x_max * 1.05, 200))
    styles = {"extinction": ("C0", "-"), "ode": ("C3", "--")}
    for f in fits:
        a, b, c = (f.extinction[k].value for k in ("a", "b", "c"))
        color, ls = styles.get(f.method, ("C2", ":"))
        label = {"extinction": "extinction-curve fit", "ode": "implied by the ODE fit"}.get(
            f.method, f.method
        )
        ax.plot(
            np.degrees(phi), np.degrees(a * phi + b * phi**2 + c * phi**3), color=color, ls=ls, label=label
        )
    ax.set_xlabel("mean amplitude φ_m [deg]")
    ax.set_ylabel("decrement per half swing Δφ [deg]")
    ax.set_xlim(0, None)
    ax.set_ylim(0, None)
    ax.legend()
    ax.set_title("Free-roll decay: extinction curve")
    return ax


def plot_decay_fit(fit: DecayFit, *, index: int = 0, ax=None):
    """Measured decay (dots) and the fitted roll equation (line) of record `index` of an ODE fit, with
    residuals, against the record's own time [s, model scale]; the part before the analysis (the rest before the
    release) in light grey and the release found (or the start given) as a vertical line."""
    if fit.method != "ode":
        raise ValueError("plot_decay_fit needs a fit from `fit_decay_ode` (it draws the fitted time series).")
    ax = _axes(ax, (8.0, 4.0))
    t = fit.curves.get("model_time", fit.curves["time"])[index]
    meas = np.degrees(fit.curves["measured"][index])
    model = np.degrees(fit.curves["fitted"][index])
    if "before" in fit.curves:
        tb, pb = fit.curves["before"][index]
        if len(tb):
            ax.plot(tb, np.degrees(pb), ".", color="0.8", ms=2, label="before the analysis")
        start = fit.curves["start_model_s"][index]
        released = fit.curves["released"][index]
        ax.axvline(
            start,
            color="C2",
            lw=1,
            ls="--",
            label=f"{'release found' if released else 'start'}: {start:.2f} s",
        )
    ax.plot(t, meas, ".", color="0.4", ms=2, label="measured")
    ax.plot(t, model, "C3-", lw=1, label="fitted roll equation (with offset)")
    ax.plot(t, meas - model, "C0-", lw=0.6, label="residual")
    ax.set_xlabel(
        "time [s, model scale: the record's own]" if "model_time" in fit.curves else "time [s, full scale]"
    )
    ax.set_ylabel("roll [deg]")
    b = fit.damping
    ax.set_title(
        f"{fit.damping_model}: "
        + ", ".join(f"{k} = {b[k].value:.4g} ± {b[k].std_error:.2g}" for k in fit.fitted_parameters)
        + f", Tφ = {fit.roll_period.value:.4g} s",
        fontsize=9,
    )
    ax.legend(loc="upper right", fontsize=7)
    return ax


def plot_equivalent_damping(fits: DecayFit | Sequence[DecayFit], *, ax=None):
    """The equivalent linear damping ratio ζ_eq(A) [-] of each fit with its 95 % band: solid over the amplitudes
    the records cover, dotted beyond (an extrapolation of the damping model)."""
    from ..calibration import DecayFit

    fits = [fits] if isinstance(fits, DecayFit) else list(fits)
    ax = _axes(ax)
    for i, f in enumerate(fits):
        lo, hi = np.degrees(f.amplitude_range)
        a = np.linspace(0.0, hi * 1.3, 120)
        eq = f.equivalent_damping(a, warn=False)
        z, se, out = eq["zeta"], eq["zeta_std_error"], eq["extrapolated"]
        color = f"C{[0, 3][i % 2]}"
        inside = ~out
        ax.plot(a[inside], z[inside], color=color, label=f"{f.method} ({f.damping_model})")
        ax.fill_between(a[inside], (z - 1.96 * se)[inside], (z + 1.96 * se)[inside], color=color, alpha=0.2)
        ax.plot(np.where(out, a, np.nan), np.where(out, z, np.nan), color=color, ls=":")
    ax.axvspan(*np.degrees(fits[0].amplitude_range), color="0.9", zorder=0, label="amplitudes in the records")
    ax.set_xlabel("roll amplitude A [deg]")
    ax.set_ylabel("equivalent damping ratio ζ_eq [-]")
    ax.set_xlim(0, None)
    ax.legend(fontsize=8)
    ax.set_title("ζ_eq(A) = B_e(A)/(2ω) with 95 % band (dotted: extrapolated)", fontsize=9)
    return ax


def plot_captive(fit: CaptiveFit, *, ax=None):
    """σ_obs/σ_thr and the least-squares scale per sea state and heel, with 95 % intervals and the pooled
    values."""
    ax = _axes(ax, (7.0, 4.0))
    x = np.arange(len(fit.groups))
    for off, attr, color, label in (
        (-0.12, "std_ratio", "k", "σ_obs/σ_thr"),
        (0.12, "ls_scale", "C3", "LS scale"),
    ):
        est = [getattr(g, attr) for g in fit.groups]
        ax.errorbar(
            x + off,
            [e.value for e in est],
            yerr=[1.96 * e.std_error for e in est],
            fmt="o",
            color=color,
            capsize=3,
            label=label,
        )
        pooled = getattr(fit, attr)
        ax.axhline(pooled.value, color=color, lw=0.8, ls="--")
    ax.set_xticks(
        x, [f"{g.wave_height:g} m, {g.wave_period:g} s\n{g.heel_deg:g}°" for g in fit.groups], fontsize=7
    )
    ax.set_ylabel("GM correction [-]")
    ax.set_title(
        "Captive tests: observed vs Grim + non-memory ΔGM (95 % intervals; dashed: pooled)", fontsize=9
    )
    ax.legend()
    return ax


def plot_captive_series(fit: CaptiveFit, *, index: int = 0, duration_s: float = 600.0, ax=None):
    """ΔGM measured and from theory (Grim + polynomial, uncorrected) over the first `duration_s` [s, full
    scale]
    of record `index`'s analysis window."""
    ax = _axes(ax, (8.0, 3.5))
    s = fit.series[index]
    t = s["time"] - s["time"][0]
    keep = t <= duration_s
    ax.plot(t[keep], s["observed"][keep], "k-", lw=1, label="measured ΔGM")
    ax.plot(t[keep], s["theory"][keep], "C0-", lw=1, label="Grim + polynomial (σ_thr)")
    ax.plot(
        t[keep],
        fit.std_ratio.value * (s["theory"][keep] - s["theory"].mean()) + s["observed"].mean(),
        "C3--",
        lw=1,
        label=f"× σ_obs/σ_thr = {fit.std_ratio.value:.3f}",
    )
    ax.set_xlabel("time in the analysis window [s, full scale]")
    ax.set_ylabel("ΔGM [m, full scale]")
    ax.legend(fontsize=8)
    return ax


def _density(samples, bins):
    x = np.concatenate([np.ravel(s) for s in samples]) if len(samples) else np.zeros(0)
    h, _ = np.histogram(np.degrees(x), bins=bins)
    return h / max(h.sum(), 1) / np.diff(bins)


def plot_roll_pdfs(
    comparison: SeaStateComparison,
    *,
    ax=None,
    log: bool = False,
    bin_width_deg: float = 1.0,
    max_deg: float | None = None,
):
    """The paper's Figs. 10–11 analogue for one sea state: experimental amplitude PDFs (zero-crossing: black
    dots;
    envelope: red dots) and the model's (lines; dashed before, solid after the calibration)."""
    ax = _axes(ax)
    exp = comparison.samples["experiment"]
    top = max(np.degrees(np.max(np.concatenate(exp["envelope"]))), 1.0)
    max_deg = max_deg or float(np.ceil(top * 1.1))
    bins = np.arange(0.0, max_deg + bin_width_deg, bin_width_deg)
    mid = (bins[1:] + bins[:-1]) / 2
    colors = {"zero_crossing": "k", "envelope": "r"}
    names = {"zero_crossing": "zero-crossing (per half cycle)", "envelope": "envelope (per sample)"}
    for est in ("zero_crossing", "envelope"):
        d = _density(exp[est], bins)
        shown = d > 0
        ax.plot(mid[shown], d[shown], "o", color=colors[est], ms=4, label=f"experiment, {names[est]}")
        for which, ls in (("before", "--"), ("after", "-")):
            model = comparison.samples.get(which)
            if model is None:
                continue
            dm = _density(model[est], bins)
            ax.plot(
                mid,
                np.where(dm > 0, dm, np.nan) if log else dm,
                ls=ls,
                color=colors[est],
                lw=1,
                label=f"model {which} calibration, {est.replace('_', '-')}",
            )
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("roll amplitude [deg]")
    ax.set_ylabel("PDF [1/deg]")
    ax.set_title(
        f"H1/3 = {comparison.wave_height:g} m, T01 = {comparison.wave_period:g} s "
        f"({comparison.n_records} records)",
        fontsize=9,
    )
    ax.legend(fontsize=6)
    return ax


def plot_roll_calibration(fit: RollFit):
    """All sea states of a roll-PDF fit: PDFs on linear (top) and log (bottom) axes. Returns the `Figure`."""
    import matplotlib.pyplot as plt

    n = len(fit.comparisons)
    fig, axes = plt.subplots(2, n, figsize=(5.5 * n, 7.5), squeeze=False)
    for k, comp in enumerate(fit.comparisons):
        plot_roll_pdfs(comp, ax=axes[0, k])
        plot_roll_pdfs(comp, ax=axes[1, k], log=True)
    est = ", ".join(f"{k} = {v.value:.4g} ± {v.std_error:.2g}" for k, v in fit.estimates.items())
    fig.suptitle(f"Free-running roll: model vs experiment; fitted {est}", fontsize=10)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------------------------------------------
# Time-domain calibration
# ------------------------------------------------------------------------------------------------------------


def _segments(fit: TimeDomainFit, record: int):
    """(time, measured, fitted) segments of one record: the shooting windows, or the Kalman filter's record cut
    into blocks of `fit.window_s`."""
    out = []
    for t, m, f, r in zip(
        fit.curves["time"], fit.curves["measured"], fit.curves["fitted"], fit.curves["record"]
    ):
        if r != record:
            continue
        t, m, f = np.asarray(t), np.asarray(m), np.asarray(f)
        if fit.method == "multiple shooting":
            out.append((t, m, f))
            continue
        n = max(8, int(round(fit.window_s / (t[1] - t[0]))) + 1)
        out.extend((t[a : a + n], m[a : a + n], f[a : a + n]) for a in range(0, t.size - n + 1, n - 1))
    return out


def plot_time_domain_fit(fit: TimeDomainFit, *, record: int = 0, windows: int = 3):
    """Measured roll (dots), the fitted model (line: the simulated roll of each shooting window, or the Kalman
    filter's one-step prediction) and the residual, over `windows` windows spread through record `record`.
    Returns the `Figure`."""
    import matplotlib.pyplot as plt

    segs = _segments(fit, record)
    if not segs:
        raise ValueError(f"the fit has no curves for record {record} (it has {len(fit.records)} record(s)).")
    pick = np.unique(np.linspace(0, len(segs) - 1, min(windows, len(segs))).round().astype(int))
    fig, axes = plt.subplots(1, pick.size, figsize=(4.2 * pick.size, 3.6), squeeze=False, sharey=True)
    label = "fitted (simulated)" if fit.method == "multiple shooting" else "fitted (one-step prediction)"
    for ax, i in zip(axes[0], pick):
        t, m, f = segs[i]
        ax.plot(t, np.degrees(m), ".", color="0.35", ms=2.5, label="measured")
        ax.plot(t, np.degrees(f), "C3-", lw=1, label=label)
        ax.plot(t, np.degrees(m - f), "C0-", lw=0.6, label="residual")
        ax.set_xlabel("time [s, full scale]")
    axes[0, 0].set_ylabel("roll [deg]")
    axes[0, 0].legend(fontsize=7, loc="upper left")
    est = ", ".join(f"{k} = {e.value:.4g} ± {e.std_error:.2g}" for k, e in fit.estimates.items())
    d = fit.records[record]
    fig.suptitle(
        f"{fit.method}, {d.source}: residual {d.residual_rms_deg:.3f}° rms (sensor noise {d.sensor_noise_deg:.3f}°)"
        f"\n{est}",
        fontsize=8,
    )
    fig.tight_layout()
    return fig


def plot_residual_spectrum(fit: TimeDomainFit, *, ax=None):
    """One-sided spectrum of the residual (measured − fitted roll) [deg²·s/rad], averaged over the windows of
    all records (Hann-windowed periodograms), against the white level of the sensor noise estimated from the
    records. A flat residual at that level: the model explains the record; a peak near ω0: model error (an
    unmodelled roll moment or a wrong damping law; use `fit_roll_kalman`)."""
    ax = _axes(ax, (6.0, 4.0))
    segs = [s for r in range(len(fit.records)) for s in _segments(fit, r)]
    n = min(s[0].size for s in segs)
    dt = float(segs[0][0][1] - segs[0][0][0])
    w = np.hanning(n)
    psd = np.zeros(n // 2 + 1)
    for _, m, f in segs:
        res = np.degrees(m[:n] - f[:n])
        res = res - res.mean()
        psd += np.abs(np.fft.rfft(res * w)) ** 2
    psd *= 2 * dt / (2 * np.pi * np.sum(w**2) * len(segs))  # ∫ S dω over [0, π/dt] = variance
    omega = 2 * np.pi * np.fft.rfftfreq(n, dt)
    ax.semilogy(omega[1:], psd[1:], "C0-", lw=1, label=f"residual ({len(segs)} windows)")
    noise = np.sqrt(np.mean([d.sensor_noise_deg**2 for d in fit.records]))
    ax.axhline(noise**2 * dt / np.pi, color="k", ls="--", lw=0.8, label=f"white sensor noise {noise:.3f}°")
    w0 = float(fit.ship.omega0)
    for k, txt in ((1, "ω0"), (2, "2ω0")):
        ax.axvline(k * w0, color="0.6", lw=0.6, ls=":")
        ax.text(k * w0, ax.get_ylim()[1], txt, fontsize=7, ha="center", va="top")
    ax.set_xlabel("encounter frequency ω [rad/s]")
    ax.set_ylabel("residual spectrum [deg²·s/rad]")
    ax.set_title(f"{fit.method}: residual spectrum", fontsize=9)
    ax.legend(fontsize=7)
    return ax
