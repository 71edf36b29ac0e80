"""The polar risk chart: probability of exceeding a roll angle (and of capsize) over speed × heading."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

__all__ = ["polar_risk_chart", "sweep_polar_figure"]

_HEADING_TICKS_DEG = (0, 30, 60, 90, 120, 150, 180)
_HEADING_NAMES = {0: "following", 90: "beam", 180: "head"}


def _edges(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Cell edges around sorted centres `x`, clipped to [lo, hi]."""
    if x.size == 1:  # a lone value: a cell a twelfth of the range wide (of [0, max(2x, 6)] for an open range)
        span = hi - lo if np.isfinite(hi - lo) else max(2 * abs(float(x[0])), 6.0)
        half = 0.5 * max(span, 1.0) / 6
        return np.clip(np.array([x[0] - half, x[0] + half]), lo, hi)
    mid = (x[1:] + x[:-1]) / 2
    return np.clip(np.concatenate([[2 * x[0] - mid[0]], mid, [2 * x[-1] - mid[-1]]]), lo, hi)


def _setup_polar(ax, r_max: float, speeds=()) -> None:
    """Head seas (χ = 180°) at the top, beam seas to the right, following seas at the bottom; radius = speed."""
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    ax.set_thetamin(0)
    ax.set_thetamax(180)
    ax.set_xticks(np.radians([180 - c for c in _HEADING_TICKS_DEG]))
    ax.set_xticklabels(
        [f"{c}°" + (f"\n{_HEADING_NAMES[c]}" if c in _HEADING_NAMES else "") for c in _HEADING_TICKS_DEG]
    )
    ax.set_ylim(0, r_max)
    ax.set_rorigin(-0.3 * r_max)  # a hole in the middle: zero speed is a ring of cells, not a crowded point
    ax.set_rlabel_position(180)
    # the grid's speeds as labels, short of the rim (a label at r_max sat on the "180° head" heading label), the
    # unit on the last
    ticks = [float(t) for t in speeds if 0 <= t <= 0.85 * r_max]
    ticks = ticks[:: -(-len(ticks) // 5)] if ticks else [0.0]
    ax.set_yticks(ticks)
    ax.set_yticklabels([f"{t:g}" + (" m/s" if k == len(ticks) - 1 else "") for k, t in enumerate(ticks)])
    ax.tick_params(labelsize=7)


def polar_risk_chart(
    ax,
    heading_deg,
    speed_m_s,
    probability,
    *,
    label: str = "probability",
    cmap: str = "magma_r",
    annotate: bool = True,
    vmax: float = 1.0,
    fmt: str = "{:.2f}",
):
    """Draw one polar risk chart on the polar axes `ax`: `probability` [-], shaped (heading, speed), as cells over
    heading χ [deg] (angle; 180° head seas at the top, 0° following at the bottom) × speed U [m/s] (radius).

    **Arguments:** `ax` (made with `projection="polar"`); `heading_deg` in [0, 180] and `speed_m_s` ≥ 0, the
    grid's values in any order; `probability`; `label`: the panel's title; `annotate`: write each cell's value
    (with `fmt`); `vmax`: the top of the colour scale (1; smaller for rare events, e.g. long-term risks).

    **Returns:** the `QuadMesh` (for a colour bar; values in [0, `vmax`]).
    """
    chi = np.asarray(heading_deg, float)
    speed = np.asarray(speed_m_s, float)
    p = np.asarray(probability, float).reshape(chi.size, speed.size)
    i, j = np.argsort(chi), np.argsort(speed)
    chi, speed, p = chi[i], speed[j], p[np.ix_(i, j)]
    r_edges = _edges(speed, 0.0, np.inf)
    r_max = float(r_edges[-1]) if r_edges[-1] > 0 else 1.0
    theta_edges = np.radians(180.0 - _edges(chi, 0.0, 180.0))
    _setup_polar(ax, r_max, speed)
    mesh = ax.pcolormesh(theta_edges, r_edges, p.T, cmap=cmap, vmin=0.0, vmax=vmax, shading="flat")
    ax.plot(*np.meshgrid(np.radians(180.0 - chi), speed, indexing="ij"), "k.", ms=2, alpha=0.4)
    if annotate:  # at the cells' centres (a speed-0 cell is a wedge from the centre), where the text fits
        r_mid = (r_edges[1:] + r_edges[:-1]) / 2
        theta_mid = (theta_edges[1:] + theta_edges[:-1]) / 2
        fig = ax.figure
        box = ax.get_position()
        radius_in = min(box.width * fig.get_figwidth(), box.height * fig.get_figheight() / 2)  # the half disc
        origin = ax.get_rorigin()
        scale = radius_in / (r_max - origin)  # [in] per unit of speed
        for a in range(chi.size):
            for b in range(speed.size):
                text = fmt.format(p[a, b])
                arc = (r_mid[b] - origin) * scale * abs(theta_edges[a] - theta_edges[a + 1])
                depth = (r_edges[b + 1] - r_edges[b]) * scale
                if arc < len(text) * 0.55 * 6 / 72 or depth < 1.3 * 6 / 72:
                    continue  # it would spill out of its wedge (the colour says the value)
                ax.text(
                    theta_mid[a],
                    r_mid[b],
                    text,
                    ha="center",
                    va="center",
                    fontsize=6,
                    color="w" if p[a, b] > 0.5 * vmax else "k",
                )
    if label:
        ax.set_title(label, fontsize=9, pad=26)  # above the two-line "180° head" tick label
    ax.grid(True, alpha=0.4)
    return mesh


def sweep_polar_figure(payload: Mapping):
    """Polar risk charts of a `jaxroll sweep` result: one row per sea state (H1/3, T01), P(max |φ| > angle) and
    P(capsize) over speed (radius) × heading (angle).

    `payload` is what `jaxroll sweep` writes (`sweep.json`): `grid` (axes heading, speed_m_s, hs_m, t01_s),
    `heading_deg` (one angle per heading of the grid), `exceedance_probability` and `capsize_probability` shaped
    like the grid, `config` with `angle_deg`, `realizations`, `duration_s` and the ship's name.

    **Returns:** the matplotlib `Figure`.
    """
    import matplotlib.pyplot as plt

    grid = payload["grid"]
    chi = np.asarray(payload["heading_deg"], float)
    speed = np.asarray(grid["speed_m_s"], float)
    hs, t01 = grid["hs_m"], grid["t01_s"]
    cfg = payload["config"]
    angle = float(cfg["angle_deg"])
    states = [(a, b) for a in range(len(hs)) for b in range(len(t01))]
    fig, axes = plt.subplots(
        len(states),
        2,
        subplot_kw={"projection": "polar"},
        figsize=(8.6, 3.9 * len(states) + 0.6),
        squeeze=False,
        layout="constrained",
    )
    mesh = None
    for row, (a, b) in enumerate(states):
        sea = f"H1/3 = {hs[a]:g} m, T01 = {t01[b]:g} s"
        for col, (name, what) in enumerate(
            (("exceedance_probability", f"P(max |φ| > {angle:g}°)"), ("capsize_probability", "P(capsize)"))
        ):
            values = np.asarray(payload[name], float)[:, :, a, b]
            mesh = polar_risk_chart(axes[row, col], chi, speed, values, label=f"{what}\n{sea}")
    fig.colorbar(mesh, ax=axes, label="probability per trial", shrink=0.6)
    fig.suptitle(
        f"{cfg['ship']['name']}: N = {cfg['realizations']} trials × {cfg['duration_s']:g} s per point\n"
        "heading χ (angle): 180° head seas at the top, 0° following at the bottom; radius: speed U [m/s]",
        fontsize=9,
    )
    return fig
