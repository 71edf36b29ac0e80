"""`explore()`: sliders for the sea state, heading, speed and GM correction that redraw the theories' amplitude
PDFs, and on request a small Monte Carlo beside them (Jupyter, ipywidgets).

The numbers come from the library's public functions only: `explore_curves` is `jaxroll.theory.theory_summary`
for each theory in the sea state of the sliders, and `explore_monte_carlo` is `jaxroll.monte_carlo_amplitudes`;
the widget draws what they return. A redraw after the first compilation takes one theory program per curve
(envelope FPK ≈ 0.2 s on a 2-core CPU: `benchmarks/explore.py`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax
import numpy as np

#: The theories the explorer offers, in drawing order; the first is on by default.
EXPLORE_THEORIES = ("envelope_fpk", "roberts", "esam", "moment")
_LABELS = {"envelope_fpk": "envelope FPK", "roberts": "Roberts", "esam": "ESAM", "moment": "moment method"}
_COLOURS = {"envelope_fpk": "tab:blue", "roberts": "tab:orange", "esam": "tab:green", "moment": "tab:purple"}
#: Amplitude bins of the figure [deg].
EXPLORE_BINS_DEG = np.arange(0.0, 60.5, 0.5)


def _heading(heading_deg: float) -> str | float:
    """What `EffectiveWave`/`RollProblem.from_sea` take for χ [deg] (as the command line passes it): "head" (180°),
    "following" (0°), else χ [rad]."""
    if not 0.0 <= heading_deg <= 180.0:
        raise ValueError(
            f"`heading_deg` must be in [0, 180] (0 following, 90 beam, 180 head); got {heading_deg!r}."
        )
    return (
        "head" if heading_deg == 180.0 else "following" if heading_deg == 0.0 else math.radians(heading_deg)
    )


def _with_correction(ship, gm_correction: float | None):
    import jax.numpy as jnp

    if gm_correction is None:
        return ship
    if not (math.isfinite(gm_correction) and gm_correction > 0):
        raise ValueError(f"`gm_correction` (σ_obs/σ_thr) must be a finite number > 0; got {gm_correction!r}.")
    # the ship's own dtype, not a weak type: the theories' stored programs are then the ones already compiled
    return eqx.tree_at(
        lambda s: s.gm_correction,
        ship,
        jnp.asarray(float(gm_correction), dtype=jnp.asarray(ship.gm_correction).dtype),
    )


def explore_curves(
    ship=None,
    *,
    hs: float = 7.0,
    t01: float = 10.0,
    heading_deg: float = 180.0,
    speed: float = 0.0,
    gm_correction: float | None = None,
    theories: Sequence[str] = ("envelope_fpk",),
    bins_deg=EXPLORE_BINS_DEG,
) -> dict[str, dict[str, Any] | str]:
    """What `explore()` draws for one set of slider values: each theory's envelope-amplitude law in the ITTC sea
    (H1/3 `hs` [m], T01 `t01` [s]) met at `speed` [m/s] and heading `heading_deg` [deg] (180 head, 0 following),
    with the ship's GM correction σ_obs/σ_thr set to `gm_correction` (None: the ship's).

    **Returns:** theory name → `jaxroll.theory.theory_summary(name, ship, wave, bins_deg)`'s summary (angles in
    degrees: `pdf_per_degree` on `bins_deg`, `mean_amplitude_deg`, `quantiles_deg`, …), or the reason it has no
    law in this sea state (a string: the `ValueError` the theory raises, e.g. the roll dies out)."""
    from .. import ITTC, EffectiveWave, c11_representative
    from ..theory import theory_summary

    ship = _with_correction(c11_representative() if ship is None else ship, gm_correction)
    wave = EffectiveWave(ITTC(hs, t01), ship.lpp, speed, _heading(heading_deg))
    out: dict[str, dict[str, Any] | str] = {}
    for name in theories:
        try:
            out[name] = theory_summary(name, ship, wave, bins_deg)[1]
        except (ValueError, eqx.EquinoxRuntimeError) as e:
            out[name] = str(e).strip().splitlines()[0]
    return out


def explore_monte_carlo(
    ship=None,
    *,
    hs: float = 7.0,
    t01: float = 10.0,
    heading_deg: float = 180.0,
    speed: float = 0.0,
    gm_correction: float | None = None,
    num_realizations: int = 200,
    duration: float = 1800.0,
    discard: float = 300.0,
    seed: int = 0,
    dt: float = 0.5,
    progress=None,
):
    """The small Monte Carlo of `explore()`'s button for the same slider values: `jaxroll.monte_carlo_amplitudes`
    of `RollProblem.from_sea(ship, ITTC(hs, t01), speed=…, heading=…, dt=dt)` (the shaping filter, φ0 = 5°) with
    `num_realizations` trials of `duration` [s], the first `discard` [s] left out, key `seed`.

    **Returns:** `AmplitudeStatistics` (its envelope law is what the theories predict)."""
    from .. import ITTC, RollProblem, c11_representative, monte_carlo_amplitudes

    ship = _with_correction(c11_representative() if ship is None else ship, gm_correction)
    problem = RollProblem.from_sea(ship, ITTC(hs, t01), speed=speed, heading=_heading(heading_deg), dt=dt)
    return monte_carlo_amplitudes(
        problem,
        jax.random.key(seed),
        num_realizations=num_realizations,
        duration=duration,
        discard=discard,
        progress=progress,
    )


def _widgets():
    try:
        import ipywidgets
    except ImportError:
        raise ImportError(
            "jaxroll.explore() draws ipywidgets sliders, and ipywidgets is not installed: install jaxroll's notebook "
            "extra, pip install 'jaxroll[notebook]' (or pip install ipywidgets)."
        ) from None
    return ipywidgets


class Explorer:
    """The widget `explore()` returns: sliders, theory check boxes, a Monte Carlo button, a figure and a status
    line. Shown by Jupyter as its `widget` (an `ipywidgets.VBox`).

    - `values()`: the sliders' values, as the keyword arguments of `explore_curves`/`explore_monte_carlo`.
    - `redraw()`: recompute and redraw the theory curves (what moving a slider does); returns the seconds it took.
    - `run_monte_carlo()`: the button: a small Monte Carlo for the same values, drawn beside the theories.
    - `curves`: the last `explore_curves` result; `monte_carlo`: the last `AmplitudeStatistics` (or None).
    """

    def __init__(
        self,
        ship=None,
        *,
        hs=7.0,
        t01=10.0,
        heading_deg=180.0,
        speed=0.0,
        gm_correction=None,
        theories=("envelope_fpk",),
        num_realizations=200,
        duration=1800.0,
        discard=300.0,
        seed=0,
    ):
        w = _widgets()
        import matplotlib.pyplot as plt

        from .. import c11_representative
        from .._display import in_notebook

        self.ship = c11_representative() if ship is None else ship
        unknown = [t for t in theories if t not in EXPLORE_THEORIES]
        if unknown:
            raise ValueError(f"unknown theory {unknown[0]!r}; choose from {', '.join(EXPLORE_THEORIES)}.")
        r0 = float(self.ship.gm_correction) if gm_correction is None else float(gm_correction)
        style = {"description_width": "150px"}
        layout = w.Layout(width="460px")

        def slider(description, value, lo, hi, step, fmt):
            return w.FloatSlider(
                value=value,
                min=lo,
                max=hi,
                step=step,
                description=description,
                continuous_update=False,
                readout_format=fmt,
                style=style,
                layout=layout,
            )

        self.sliders = {
            "hs": slider("H1/3 [m]", hs, 0.5, 14.0, 0.25, ".2f"),
            "t01": slider("T01 [s]", t01, 5.0, 18.0, 0.25, ".2f"),
            "heading_deg": slider("heading χ [deg] (180 head)", heading_deg, 0.0, 180.0, 5.0, ".0f"),
            "speed": slider("speed [m/s]", speed, 0.0, 12.0, 0.5, ".1f"),
            "gm_correction": slider("GM correction σobs/σthr", r0, 0.2, 2.0, 0.05, ".2f"),
        }
        self.checks = {
            name: w.Checkbox(
                value=name in theories,
                description=_LABELS[name],
                indent=False,
                layout=w.Layout(width="130px"),
            )
            for name in EXPLORE_THEORIES
        }
        self.log_scale = w.Checkbox(
            value=False, description="log scale", indent=False, layout=w.Layout(width="110px")
        )
        self.realizations = w.BoundedIntText(
            value=num_realizations, min=2, max=10**6, description="trials", layout=w.Layout(width="170px")
        )
        self.button = w.Button(
            description="Monte Carlo", tooltip="a small Monte Carlo for these values", icon="play"
        )
        self.status = w.HTML()
        self.output = w.Output()
        self.mc_options = {"duration": float(duration), "discard": float(discard), "seed": int(seed)}
        self.curves: dict[str, dict[str, Any] | str] = {}
        self.monte_carlo = None
        self._mc_values = None
        self._show = in_notebook()
        with plt.ioff():
            self.figure, self.ax = plt.subplots(figsize=(7.0, 3.8))
        self.widget = w.VBox(
            [
                w.HBox(
                    [
                        w.VBox(list(self.sliders.values())),
                        w.VBox(
                            [
                                w.HBox(list(self.checks.values())[:2]),
                                w.HBox(list(self.checks.values())[2:]),
                                self.log_scale,
                                w.HBox([self.realizations, self.button]),
                            ]
                        ),
                    ]
                ),
                self.status,
                self.output,
            ]
        )
        for control in (*self.sliders.values(), *self.checks.values()):
            control.observe(lambda change: self.redraw(), names="value")
        self.log_scale.observe(lambda change: self._draw(), names="value")
        self.button.on_click(lambda button: self.run_monte_carlo())
        self.redraw()

    def values(self) -> dict[str, float]:
        """The sliders' values: `hs` [m], `t01` [s], `heading_deg` [deg], `speed` [m/s], `gm_correction` [-]."""
        return {name: float(s.value) for name, s in self.sliders.items()}

    def theories(self) -> tuple[str, ...]:
        """The theories ticked."""
        return tuple(name for name, c in self.checks.items() if c.value)

    def redraw(self) -> float:
        """Recompute the ticked theories for the sliders' values and redraw (what moving a slider does); returns the
        seconds it took (the theories and the figure)."""
        start = time.perf_counter()
        self.curves = explore_curves(self.ship, theories=self.theories(), **self.values())
        self._draw()
        elapsed = time.perf_counter() - start
        parts = [
            f"{_LABELS[n]}: {'no law here — ' + c if isinstance(c, str) else 'mean ' + format(c['mean_amplitude_deg'], '.2f') + '°'}"
            for n, c in self.curves.items()
        ]
        self.status.value = f"<small>{'; '.join(parts) or 'no theory ticked'} ({elapsed:.2f} s)</small>"
        return elapsed

    def run_monte_carlo(self):
        """A small Monte Carlo for the sliders' values (trials from the box; the envelope PDF, drawn with the
        theories). Returns its `AmplitudeStatistics`."""
        values = self.values()
        self.status.value = f"<small>Monte Carlo: {self.realizations.value} trials …</small>"
        start = time.perf_counter()
        try:
            self.monte_carlo = explore_monte_carlo(
                self.ship,
                num_realizations=int(self.realizations.value),
                progress=True if self._show else None,
                **self.mc_options,
                **values,
            )
        except ValueError as e:
            self.monte_carlo, self._mc_values = None, None
            self.status.value = f"<small>Monte Carlo: {e}</small>"
            self._draw()
            return None
        self._mc_values = values
        self._draw()
        stats = self.monte_carlo
        self.status.value = (
            f"<small>Monte Carlo: {stats.n_realizations} trials, {stats.n_capsized} capsized, mean envelope "
            f"amplitude {math.degrees(stats.mean('envelope')):.2f}° ({time.perf_counter() - start:.1f} s)</small>"
        )
        return stats

    def _draw(self) -> None:
        ax = self.ax
        ax.clear()
        centres = 0.5 * (EXPLORE_BINS_DEG[1:] + EXPLORE_BINS_DEG[:-1])
        if self.monte_carlo is not None and self._mc_values == self.values():
            pdf = self.monte_carlo.pdf_per_degree("envelope", EXPLORE_BINS_DEG)
            ax.step(
                centres,
                pdf,
                where="mid",
                color="0.3",
                lw=1.0,
                label=f"Monte Carlo ({self.monte_carlo.n_realizations} trials)",
            )
        for name, c in self.curves.items():
            if not isinstance(c, str):
                ax.plot(
                    centres,
                    c["pdf_per_degree"],
                    color=_COLOURS[name],
                    lw=1.6,
                    label=f"{_LABELS[name]} (mean {c['mean_amplitude_deg']:.1f}°)",
                )
        v = self.values()
        ax.set_title(
            f"ITTC H1/3 = {v['hs']:g} m, T01 = {v['t01']:g} s, χ = {v['heading_deg']:g}°, "
            f"U = {v['speed']:g} m/s, r = {v['gm_correction']:g}",
            fontsize=9,
        )
        ax.set_xlabel("envelope amplitude [deg]")
        ax.set_ylabel("PDF [1/deg]")
        ax.set_yscale("log" if self.log_scale.value else "linear")
        if self.log_scale.value:
            ax.set_ylim(1e-6, None)
        ax.set_xlim(0, EXPLORE_BINS_DEG[-1])
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        if self._show:
            from IPython.display import clear_output, display

            with self.output:
                clear_output(wait=True)
                display(self.figure)

    def _repr_mimebundle_(self, **kwargs):
        return self.widget._repr_mimebundle_(**kwargs)


def explore(ship=None, **kwargs) -> Explorer:
    """Explore a ship's parametric roll in a notebook: sliders for H1/3, T01, heading, speed and the GM correction
    σ_obs/σ_thr redraw the theories' envelope-amplitude PDFs (envelope FPK by default; Roberts, ESAM and the moment
    method by their boxes), and the Monte Carlo button runs a small Monte Carlo for the same values beside them.

    **Arguments:** `ship` (default C11 (representative)); keyword arguments: the sliders' start values `hs` [m],
    `t01` [s], `heading_deg` [deg] (180 head), `speed` [m/s], `gm_correction` [-]; `theories` ticked at the start
    (names of `EXPLORE_THEORIES`); the Monte Carlo's `num_realizations`, `duration` [s], `discard` [s], `seed`.

    **Returns:** an `Explorer` (Jupyter shows it as its widget).

    **Raises:** `ImportError` naming the `notebook` extra when ipywidgets is not installed.
    """
    return Explorer(ship, **kwargs)
