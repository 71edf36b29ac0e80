r"""The exact linear answer for the roll driven by the direct wave moment (issue 44): E[φ²] = ∫ |H|² S_M dω_e.

For the linear roll φ̈ + b φ̇ + ω0² φ = M_w(t), M_w stationary Gaussian with the one-sided spectrum S_M(ω_e)
(`jaxroll.WaveMomentExcitation.spectrum`: Σ_b |F(ω_b, χ)/I44|² S(ω_b)/|dω_e/dω|), the stationary roll is Gaussian
with E[φ²] = ∫₀^∞ |H(ω_e)|² S_M(ω_e) dω_e and E[φ̇²] = ∫ ω_e² |H|² S_M dω_e, H(ω) = 1/(ω0² − ω² + i b ω),
b = 2ζω0. It is the check of the Monte Carlo in a small sea, where the restoring is linear and the parametric term
P(t)φ is negligible (beam seas: ζ_G ≡ 0, P ≡ 0).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..sea._spectra import GRAVITY
from ..ship._restoring_surface import refuse_restoring_surface

_COARSE = 20001  # points from 0 to the top encounter frequency
_FINE = 4001  # points within ±40 half-widths of the resonance


def _grid(problem, b: float) -> np.ndarray:
    moment = problem.moment_excitation
    top = float(moment.omega[-1])
    top = top * (1 + top * float(moment.speed) / GRAVITY)  # the encounter frequency of the table's last wave
    w0 = float(problem.ship.omega0)
    half = max(b / 2, 1e-4 * w0)
    fine = np.linspace(max(w0 - 40 * half, 0.0), w0 + 40 * half, _FINE)
    return np.union1d(np.linspace(0.0, top, _COARSE), fine)


def linear_roll_variance(problem, *, damping: str = "linear") -> Float[Array, ""]:
    r"""E[φ²] [rad²] of the stationary linear roll driven by the problem's direct wave moment:
    ∫₀^∞ |H(ω_e)|² S_M(ω_e) dω_e, H(ω) = 1/(ω0² − ω² + i b ω) [s²], S_M [rad²/s⁴ · s/rad] the moment's one-sided
    spectrum in encounter frequency (`WaveMomentExcitation.spectrum`); trapezoid rule on 20 001 frequencies up to the
    encounter frequency of the moment table's last, and 4 001 within ±40 half-widths b/2 of ω0 (relative error
    < 1e-4 for the default ship).

    **Arguments:**

    - `problem`: a `RollProblem` with a `WaveMomentExcitation` (`RollProblem.from_sea` of a ship carrying a wave
        moment at an oblique or beam heading).
    - `damping`: `"linear"` (default): b = b1, the ship's linear damping — the exact answer for b2 = b3 = 0 in a
        small sea; `"equivalent"`: b = b1 + √(8/π) b2 σ_φ̇ + 3 b3 σ_φ̇², the Gaussian stochastic linearisation
        of the ship's nonlinear damping, solved with σ_φ̇² = ∫ ω_e² |H|² S_M dω_e (an approximation, not exact).

    The parametric term P(t)φ and the nonlinear restoring are left out: exact in beam seas (ζ_G ≡ 0) for a small
    roll; elsewhere a check in a small sea only.

    **Raises:** `ValueError` for a problem without a `WaveMomentExcitation`, or an unknown `damping`.
    """
    moment = problem.moment_excitation
    if not hasattr(moment, "spectrum"):  # a `WaveMomentExcitation` (the theories sit below `jaxroll.roll`)
        raise ValueError(
            "linear_roll_variance needs a problem with a direct wave moment (a WaveMomentExcitation): build it with "
            "RollProblem.from_sea for a ship carrying one (ship.wave_moment) at an oblique or beam heading."
        )
    if getattr(moment, "yaw", None) is not None:
        raise ValueError(yaw_refusal("linear_roll_variance"))
    if damping not in ("linear", "equivalent"):
        raise ValueError(f"`damping` must be 'linear' or 'equivalent'; got {damping!r}.")
    ship = problem.ship
    b1, b2, b3 = (float(x) for x in ship.damping)
    w = _grid(problem, b1)
    s = np.asarray(moment.spectrum(w))
    w0sq = float(ship.omega0) ** 2

    def moments(b):
        h2 = s / ((w0sq - w**2) ** 2 + (b * w) ** 2)
        trap = lambda f: float(np.sum((f[1:] + f[:-1]) / 2 * np.diff(w)))  # noqa: E731
        return trap(h2), trap(w**2 * h2)

    b = b1
    var, var_rate = moments(b)
    if damping == "equivalent" and (b2 != 0 or b3 != 0):
        for _ in range(200):  # the fixed point b = b1 + √(8/π) b2 σ_v + 3 b3 σ_v²: a contraction here
            b_new = b1 + math.sqrt(8 / math.pi) * b2 * math.sqrt(var_rate) + 3 * b3 * var_rate
            if abs(b_new - b) <= 1e-12 * b_new:
                break
            b = 0.5 * (b + b_new)
            var, var_rate = moments(b)
    return jnp.asarray(var)


def wave_moment_refusal(theory: str) -> str:
    """The one-line reason theory `theory` gives for a ship whose direct wave moment joins the roll."""
    return (
        f"{theory}: the ship carries a direct wave moment (ship.wave_moment), which joins the roll at oblique and "
        f"beam headings; {theory} covers the parametric excitation only. Use the Monte Carlo (jaxroll pdf/risk, "
        "monte_carlo_amplitudes), or jaxroll.theory.linear_roll_variance for E[φ²] in a small sea."
    )


def yaw_refusal(theory: str) -> str:
    """The one-line reason theory `theory` gives for a run whose heading yaws (`jaxroll.Yaw`)."""
    return (
        f"{theory}: the heading yaws along the run (--yaw-std, jaxroll.Yaw); {theory} covers one heading, a "
        "stationary sea at a fixed χ. Use the Monte Carlo (jaxroll pdf/maxima/risk, monte_carlo_amplitudes)."
    )


def refuse_wave_moment(ship, wave, theory: str) -> None:
    """Raise `ValueError` (`wave_moment_refusal`) when `ship` carries a wave moment (`ship.wave_moment`) and `wave`
    (an `EffectiveWave`) is at an oblique or beam heading (|cos χ| < 1) or short-crested, where the moment joins
    the roll equation: the parametric-only theories would silently leave it out. Static checks only (works when
    traced). A ship with a GZ surface (`ship.restoring_surface`) is refused at every heading: the theories know
    only its small-heel reduction."""
    refuse_restoring_surface(ship, theory)
    if moment_joins(ship, wave):
        raise ValueError(wave_moment_refusal(theory))


def moment_joins(ship, wave) -> bool:
    """Whether `ship`'s direct wave moment joins its roll in `wave` (an `EffectiveWave`): the ship carries one and
    the heading is oblique or beam (|cos χ| < 1), or the sea short-crested (oblique directions at every heading)."""
    spread = getattr(wave, "spreading", None) is not None
    return getattr(ship, "wave_moment", None) is not None and (getattr(wave, "projected", False) or spread)
