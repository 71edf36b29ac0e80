"""Where the roll model and the averaging theories hold, for a concrete ship in a concrete effective wave.

The model's GM variation is the non-memory polynomial ΔGM(ζ_mid) (docs/hydrostatics.md): it means something only
for effective waves a hull can meet without its keel coming out of the water or its deck going under, so its
standard deviation σ_G is compared with min(draught, freeboard). The averaging theories (Roberts' SAM, ESAM, the
envelope Fokker–Planck method) are expansions in the strength of the parametric excitation: they treat the roll as
a harmonic oscillation of slowly varying amplitude, which holds while the GM in waves varies little about its mean
(ε = σ[rΔGM]/(GM0 + E[rΔGM]) small). Both numbers come from the Gaussian effective wave exactly (Gauss–Hermite
quadrature of the polynomial), on the host. docs/theory.md, "Where the theories hold".
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..sea._grim import EffectiveWave, effective_wave_std
from ._ship import Ship

#: ε above which the averaging theories are warned about: the GM in waves then varies by more than half its mean
#: (default ship, T01 = 10 s: ε = 0.25 at H1/3 5 m, 0.33 at 7 m, 0.51 at 12 m, 0.82 at 30 m).
AVERAGING_LIMIT = 0.5
#: The theories that are expansions in ε (stochastic averaging).
AVERAGING_THEORIES = ("roberts", "esam", "envelope_fpk")
#: How many σ_G of ζ_mid must stay within min(draught, freeboard) for the ΔGM polynomial to be used in its range.
ZETA_SIGMAS = 3.0


def excitation_validity(ship: Ship, wave: EffectiveWave) -> dict[str, float]:
    """The numbers that say whether the model and the averaging theories hold (concrete inputs, host arithmetic).

    **Returns:** `sigma_zeta_mid_m` σ_G [m]; `zeta_mid_limit_m` min(draught, depth − draught) [m]; `zeta_range`
    3σ_G / that limit (> 1: the ΔGM polynomial is used beyond the hull); `mean_gm_shift` E[rΔGM]/GM0 [-] (the mean
    GM in waves is GM0 times 1 + this); `stiffness_variation` ε = σ[rΔGM]/(GM0 + E[rΔGM]) [-] (inf when the mean GM
    in waves is not positive).
    """
    sigma = effective_wave_std(wave)
    x, w = np.polynomial.hermite_e.hermegauss(20)  # exact for the degree-6 polynomial and its square
    w = w / w.sum()
    r = float(np.asarray(ship.gm_correction))
    gm0 = float(np.asarray(ship.gm0))
    dgm = r * np.polynomial.polynomial.polyval(sigma * x, np.asarray(ship.delta_gm, dtype=float))
    mean = float(w @ dgm)
    std = float(np.sqrt(w @ (dgm - mean) ** 2))
    gm_waves = gm0 + mean
    draught, depth = float(np.asarray(ship.draught)), float(np.asarray(ship.depth))
    limit = min(draught, depth - draught)
    return {
        "sigma_zeta_mid_m": sigma,
        "zeta_mid_limit_m": limit,
        "zeta_range": ZETA_SIGMAS * sigma / limit,
        "mean_gm_shift": mean / gm0,
        "stiffness_variation": std / gm_waves if gm_waves > 0 else math.inf,
    }


def validity_warnings(validity: dict[str, float], theories=()) -> list[str]:
    """The warnings `excitation_validity`'s numbers call for: the ΔGM model beyond the hull (every method, the Monte
    Carlo too), and, for those of `theories` that are averaging methods, an excitation too strong for them."""
    out = []
    v = validity
    if v["zeta_range"] > 1:
        out.append(
            f"Grim's effective wave has σ = {v['sigma_zeta_mid_m']:.3g} m, so ζ_mid reaches {ZETA_SIGMAS:g}σ = "
            f"{ZETA_SIGMAS * v['sigma_zeta_mid_m']:.3g} m, beyond min(draught, freeboard) = "
            f"{v['zeta_mid_limit_m']:.3g} m: the ΔGM(ζ_mid) polynomial is used where a trough amidships uncovers the "
            "keel or a crest floods the deck. This warning appears because the non-memory ΔGM model, and with it "
            "the Monte Carlo and every theory, holds only for effective waves the hull can meet; lower H1/3."
        )
    averaging = [t for t in theories if t in AVERAGING_THEORIES]
    if averaging and v["stiffness_variation"] > AVERAGING_LIMIT:
        out.append(
            f"{', '.join(averaging)}: the GM in waves varies by ε = σ[rΔGM]/(GM0 + E[rΔGM]) = "
            f"{v['stiffness_variation']:.3g} of its mean (mean GM {1 + v['mean_gm_shift']:.3g} × GM0), above "
            f"{AVERAGING_LIMIT:g}. This warning appears because stochastic averaging treats the parametric "
            "excitation as a small perturbation of the restoring (first order in ε; ε = 0.33 in the paper's 7 m "
            'sea), so these laws are not reliable here: trust the Monte Carlo (docs/theory.md, "Where the '
            'theories hold").'
        )
    return out


def warn_outside_validity(
    ship: Ship, wave: EffectiveWave, theories=(), stacklevel: int = 2
) -> dict[str, float]:
    """`excitation_validity(ship, wave)`, with a `UserWarning` for each of its `validity_warnings`."""
    v = excitation_validity(ship, wave)
    for message in validity_warnings(v, theories):
        warnings.warn(message, stacklevel=stacklevel + 1)
    return v
