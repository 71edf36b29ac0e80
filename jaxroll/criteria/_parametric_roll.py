r"""IMO second generation intact stability criteria: vulnerability to PARAMETRIC ROLLING, Level 1 and Level 2 C1.

Interim Guidelines on the second generation intact stability criteria, MSC.1/Circ.1627 (2020), section 2.5,
and their Explanatory Notes, MSC.1/Circ.1652 (2023). Head and following long-crested seas.

- **Level 1**: ΔGM1/GM ≤ R_PR. ΔGM1 from the waterplane inertias at d_H = d + δd_H and d_L = d − δd_L (wave
  λ = L, steepness S_W = 0.0167) or, alternatively, half the range of GM on a wave λ = L, H = L S_W with its
  crest at the LCG and every 0.1 L fore and aft (sinkage and trim balanced). R_PR from the bilge keels and the
  midship coefficient.
- **Level 2, first check C1**: 16 wave cases with weights W_i; C_i = 0 when the Mathieu stability condition
  (GM in waves > 0 and ΔGM/GM < R_PR) or the speed condition (the principal-resonance speed V_PR exceeds the
  service speed) holds. C1 = Σ W_i C_i ≤ R_PR1.

The second check C2 is in `_c2.py`, the combined assessment and the KGmax curve in `_assessment.py`.
Every table and constant carries its source and verification status (docs/sgisc.md): the primary texts were
not retrievable here; values marked UNVERIFIED were transcribed from the guidelines as known to the author and
must be checked against Circ.1627 before any statutory use.

GM in waves is KG-independent in its KM part (the balance of sinkage and trim does not depend on KG), so every
function here computes KM in waves once per hull and draught; GM = KM − KG.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._compiled import filter_jit
from ..sea._spectra import GRAVITY
from ..ship._equilibrium import _equilibrium_single, _gm_at, hydrostatic_particulars
from ..ship._hull import Hull, _bare, translate_hull
from ..ship._hydrostatics import Loading, _integrals, buoyancy

# ==============================================================================================================
# Constants and tables (sources and status in docs/sgisc.md)
# ==============================================================================================================

WAVE_STEEPNESS_LEVEL1 = 0.0167
"""S_W: steepness H/λ of the Level-1 wave, λ = L (Circ.1627 2.5, Level 1). CORROBORATED."""

R_PR_SHARP_BILGE = 1.87
"""R_PR for a ship with a sharp bilge (Circ.1627 2.5, Level 1). CORROBORATED."""

R_PR_BASE = 0.17
"""Constant term of R_PR for ships without a sharp bilge. CORROBORATED."""

R_PR_SLOPE_FULL = 0.425
"""R_PR slope on 100 A_k/(L B) for C_m > 0.96. CORROBORATED."""

R_PR_SLOPE_FINE = 0.2125
"""R_PR slope on 100 A_k/(L B) for C_m < 0.94. CORROBORATED."""

R_PR_CM_LINEAR = (10.625, 9.775)
"""R_PR slope = 10.625 C_m − 9.775 for 0.94 ≤ C_m ≤ 0.96 (continuous: 0.2125 at 0.94, 0.425 at 0.96). CORROBORATED."""

BILGE_KEEL_RATIO_MAX = 4.0
"""100 A_k/(L B) is not taken greater than 4. CORROBORATED."""

RESERVE_RATIO_MIN = 1.0
"""The waterplane method of Level 1 applies only if (V_D − V)/(A_W (D − d)) ≥ 1.0. CORROBORATED."""

DRAUGHT_LOW_FRACTION = 0.25
"""δd_L = min(d − 0.25 d_full, L S_W/2): the trough draught is not below 25 % of the full-load draught.
CORROBORATED."""

R_PR1 = 0.06
"""Standard of the Level-2 first check: C1 ≤ R_PR1. UNVERIFIED (transcribed from memory)."""

R_PR2 = 0.025
"""Standard of the Level-2 second check: C2 ≤ R_PR2. UNVERIFIED (transcribed from memory)."""

POSITIONS_PER_WAVE = 10
"""GM in waves at the crest at the LCG and every 0.1 λ fore and aft (10 positions over one wavelength)."""

# Level-2 C1 wave cases: (weight W_i, wave length λ_i [m], wave height h_i [m]), Circ.1627 2.5 Level 2
# ("Table 2.10.3.2.1" in the SDC drafts). Transcribed (UNVERIFIED against the primary text), CORROBORATED
# internally: every W_i is the T_z column total of REC34_SCATTER / 1e5, λ_i = g T01²/(2π) with T01 = 1.086435 T_z,
# h_i = 1.4 × the column's mean H_s (tests/test_sgisc.py).
C1_WAVE_CASES = np.array(
    [
        [1.3e-05, 22.574, 0.700],
        [0.001654, 37.316, 0.990],
        [0.020912, 55.743, 1.715],
        [0.092799, 77.857, 2.589],
        [0.199218, 103.655, 3.464],
        [0.248788, 133.139, 4.410],
        [0.208699, 166.309, 5.393],
        [0.128984, 203.164, 6.351],
        [0.062446, 243.705, 7.250],
        [0.024790, 287.931, 8.080],
        [0.008367, 335.843, 8.841],
        [0.002473, 387.440, 9.539],
        [0.000658, 442.723, 10.194],
        [0.000158, 501.691, 10.739],
        [0.000034, 564.345, 11.241],
        [0.000007, 630.684, 11.900],
    ]
)
"""The 16 wave cases of C1: columns W_i [-], λ_i [m], h_i [m] (wave height, crest to trough)."""

REC34_HS = np.arange(0.5, 17.0, 1.0)
"""Significant wave heights H_s [m] (class centres) of the scatter table."""
REC34_TZ = np.arange(1.5, 19.0, 1.0)
"""Zero-crossing periods T_z [s] (class centres) of the scatter table."""
# fmt: off
REC34_SCATTER = np.array(
    [
        # Tz: 1.5 2.5 3.5 4.5 5.5 6.5 7.5 8.5 9.5 10.5 11.5 12.5 13.5 14.5 15.5 16.5 17.5 18.5
        [0, 0, 1.3, 133.7, 865.6, 1186.0, 634.2, 186.3, 36.9, 5.6, 0.7, 0.1, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 29.3, 986.0, 4976.0, 7738.0, 5569.7, 2375.7, 703.5, 160.7, 30.5, 5.1, 0.8, 0.1, 0, 0, 0],
        [0, 0, 0, 2.2, 197.5, 2158.8, 6230.0, 7449.5, 4860.4, 2066.0, 644.5, 160.2, 33.7, 6.3, 1.1, 0.2, 0, 0],
        [0, 0, 0, 0.2, 34.9, 695.5, 3226.5, 5675.0, 5099.1, 2838.0, 1114.1, 337.7, 84.3, 18.2, 3.5, 0.6, 0.1, 0],
        [0, 0, 0, 0, 6.0, 196.1, 1354.3, 3288.5, 3857.5, 2685.5, 1275.2, 455.1, 130.9, 31.9, 6.9, 1.3, 0.2, 0],
        [0, 0, 0, 0, 1.0, 51.0, 498.4, 1602.9, 2372.7, 2008.3, 1126.0, 463.6, 150.9, 41.0, 9.7, 2.1, 0.4, 0.1],
        [0, 0, 0, 0, 0.2, 12.6, 167.0, 690.3, 1257.9, 1268.6, 825.9, 386.8, 140.8, 42.2, 10.9, 2.5, 0.5, 0.1],
        [0, 0, 0, 0, 0, 3.0, 52.1, 270.1, 594.4, 703.2, 524.9, 276.7, 111.7, 36.7, 10.2, 2.5, 0.6, 0.1],
        [0, 0, 0, 0, 0, 0.7, 15.4, 97.9, 255.9, 350.6, 296.9, 174.6, 77.6, 27.7, 8.4, 2.2, 0.5, 0.1],
        [0, 0, 0, 0, 0, 0.2, 4.3, 33.2, 101.9, 159.9, 152.2, 99.2, 48.3, 18.7, 6.1, 1.7, 0.4, 0.1],
        [0, 0, 0, 0, 0, 0, 1.2, 10.7, 37.9, 67.5, 71.7, 51.5, 27.3, 11.4, 4.0, 1.2, 0.3, 0.1],
        [0, 0, 0, 0, 0, 0, 0.3, 3.3, 13.3, 26.6, 31.4, 24.7, 14.2, 6.4, 2.4, 0.7, 0.2, 0.1],
        [0, 0, 0, 0, 0, 0, 0.1, 1.0, 4.4, 9.9, 12.8, 11.0, 6.8, 3.3, 1.3, 0.4, 0.1, 0],
        [0, 0, 0, 0, 0, 0, 0, 0.3, 1.4, 3.5, 5.0, 4.6, 3.1, 1.6, 0.7, 0.2, 0.1, 0],
        [0, 0, 0, 0, 0, 0, 0, 0.1, 0.4, 1.2, 1.8, 1.8, 1.3, 0.7, 0.3, 0.1, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0.1, 0.4, 0.6, 0.7, 0.5, 0.3, 0.1, 0.1, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 0.1, 0.2, 0.2, 0.2, 0.1, 0.1, 0, 0, 0],
    ]
)
# fmt: on
"""North-Atlantic wave scatter table, IACS Recommendation No. 34 (Rev.1, 2001), occurrences per 100 000
observations, rows H_s = 0.5..16.5 m, columns T_z = 1.5..18.5 s, as used by Circ.1627 Level 2 (C1 via its T_z
marginal, C2 cell by cell). Transcribed; CORROBORATED internally by the C1 weights and its total 100 000."""

T01_OVER_TZ = math.pi**0.25 / math.gamma(0.75)
"""T01/T_z = π^{1/4}/Γ(3/4) = 1.086435 for the ITTC (Bretschneider) spectrum ω⁻⁵ exp(−B ω⁻⁴)."""


# ==============================================================================================================
# R_PR and GM in waves
# ==============================================================================================================


def r_pr(
    *,
    lpp: float,
    breadth: float,
    midship_coefficient: float,
    bilge_keel_area: float = 0.0,
    sharp_bilge: bool = False,
) -> float:
    """R_PR [-]: the Level-1 (and C1) standard for ΔGM/GM.

    **Arguments:** `lpp` L [m]; `breadth` B [m] (moulded, at the waterline); `midship_coefficient` C_m at the
    draught considered; `bilge_keel_area` A_k [m²], total projected area of the bilge keels (both sides);
    `sharp_bilge`: the ship has a sharp (square) bilge, then R_PR = 1.87.
    """
    if not (math.isfinite(bilge_keel_area) and bilge_keel_area >= 0):
        raise ValueError(f"`bilge_keel_area` must be a finite area >= 0 [m²]; got {bilge_keel_area}.")
    if sharp_bilge:
        return R_PR_SHARP_BILGE
    ak = min(100.0 * bilge_keel_area / (lpp * breadth), BILGE_KEEL_RATIO_MAX)
    cm = midship_coefficient
    if cm > 0.96:
        slope = R_PR_SLOPE_FULL
    elif cm >= 0.94:
        slope = R_PR_CM_LINEAR[0] * cm - R_PR_CM_LINEAR[1]
    else:
        slope = R_PR_SLOPE_FINE
    return R_PR_BASE + slope * ak


def _crest_offsets(n: int) -> tuple[np.ndarray, np.ndarray]:
    """For crest positions k λ/n (k = 0..n−1) from the LCG: the hull shift in wavelengths (|·| ≤ 1/4) and the
    sign of ζ_mid (−1: crest amidships of the shifted hull, +1: a trough, the same wave half a length away)."""
    frac = (np.arange(n) / n + 0.5) % 1.0 - 0.5
    trough = np.abs(frac) > 0.25
    frac = np.where(trough, frac - np.copysign(0.5, frac), frac)
    return frac, np.where(trough, 1.0, -1.0)


@filter_jit
def _gm_positions(hull: Hull, loading: Loading, shift, zeta, wavelength):
    """GM [m] (free trim) and convergence of the hull translated by −shift on waves (zeta, wavelength), vmapped."""

    def one(s, z, lam):
        h = translate_hull(hull, -s)
        ld = eqx.tree_at(lambda m: m.lcg, loading, loading.lcg - s)
        # Starting sinkage by bisection at zero trim (the Newton balance started at the calm draught diverges
        # when a high, long wave lifts or drops the whole hull by more than its freeboard).
        zero = jnp.zeros(())

        def bisect(_, bounds):
            lo, hi = bounds
            mid = (lo + hi) / 2
            low = buoyancy(h, mid, trim=zero, zeta_mid=z, wavelength=lam).volume < ld.volume
            return jnp.where(low, mid, lo), jnp.where(low, hi, mid)

        bounds = (hull.waterlines[0] - jnp.abs(z), hull.depth + jnp.abs(z))
        lo, hi = jax.lax.fori_loop(0, 60, bisect, bounds)
        guess = jnp.stack([(lo + hi) / 2, zero])
        eq = _equilibrium_single(h, ld, zero, z, lam, guess)
        return _gm_at(h, ld, eq.sinkage, eq.trim, z, lam), eq.converged

    return jax.vmap(one)(shift, zeta, wavelength)


N_WAVES_BATCH = 16
"""GM in waves is evaluated for 16 waves at a time (Level 1 pads its one wave), so Level 1 and C1 share one
compilation per hull shape."""


def gm_in_waves(
    hull: Hull,
    loading: Loading,
    *,
    wavelengths,
    heights,
    n_positions: int = POSITIONS_PER_WAVE,
) -> np.ndarray:
    """GM [m] on waves of length λ and height H with the crest at the LCG + k λ/n, k = 0..n−1 (free trim).

    **Arguments:** `hull`, `loading`; `wavelengths` λ [m] and `heights` H [m] (crest to trough), 1-D, same
    length; `n_positions`: crest positions per wave (the guidelines: 10).

    **Returns:** GM [m], shape (waves, n_positions).

    **Raises:** `ValueError` if a balance fails (the hull cannot float on that wave).

    Positions beyond ±λ/4 are taken as a trough at the opposite quarter (the same wave), so the hull is moved by
    at most λ/4 and the small-trim balance stays referred to amidships.
    """
    lam = np.atleast_1d(np.asarray(wavelengths, dtype=float))
    h = np.atleast_1d(np.asarray(heights, dtype=float))
    if lam.shape != h.shape or lam.ndim != 1:
        raise ValueError(
            f"`wavelengths` and `heights` must be 1-D of one length; got {lam.shape}, {h.shape}."
        )
    if not (np.all(np.isfinite(lam)) and np.all(lam > 0) and np.all(np.isfinite(h)) and np.all(h >= 0)):
        raise ValueError("wave lengths must be finite and > 0, heights finite and >= 0 [m].")
    frac, sign = _crest_offsets(n_positions)
    out, ok = [], []
    for start in range(0, lam.size, N_WAVES_BATCH):
        lb, hb = lam[start : start + N_WAVES_BATCH], h[start : start + N_WAVES_BATCH]
        n = lb.size
        lb = np.concatenate([lb, np.full(N_WAVES_BATCH - n, lb[-1])])
        hb = np.concatenate([hb, np.full(N_WAVES_BATCH - n, hb[-1])])
        shift = float(loading.lcg) - float(hull.amidships) + frac[None, :] * lb[:, None]
        zeta = sign[None, :] * hb[:, None] / 2
        lam_b = np.broadcast_to(lb[:, None], shift.shape)
        gm, conv = _gm_positions(
            _bare(hull),
            loading,
            jnp.asarray(shift.ravel()),
            jnp.asarray(zeta.ravel()),
            jnp.asarray(lam_b.ravel()),
        )
        out.append(np.asarray(gm).reshape(N_WAVES_BATCH, n_positions)[:n])
        ok.append(np.asarray(conv).reshape(N_WAVES_BATCH, n_positions)[:n])
    gm, ok = np.concatenate(out), np.concatenate(ok)
    if not np.all(ok):
        i = int(np.argmax(~np.all(ok, axis=1)))
        raise ValueError(
            f"the hull cannot be balanced on the wave λ = {lam[i]:.4g} m, H = {h[i]:.4g} m (sinkage and trim "
            "did not converge): the wave is too high for the hull's depth or the loading is inconsistent."
        )
    return gm


# ==============================================================================================================
# Even-keel waterplane quantities (exact for the polygonal hull, NumPy: no compilation)
# ==============================================================================================================


@filter_jit
def _surface_waterplane(hull: Hull, draught):
    """(∇ [m³], A_W [m²], I_T [m⁴]) of a hull surface at an even-keel draught [m], exact: A_W = ∂∇/∂d and
    I_T = ∂(∫u dV)/∂φ − ∫z dV at φ = 0 (KM ∇ = KB ∇ + I_T)."""
    zero = jnp.zeros(())

    def ints(d, phi):
        return _integrals(hull, phi, d, zero, zero, None, calm=True)

    vol, area = jax.jvp(lambda d: ints(d, zero).volume, (draught,), (jnp.ones(()),))
    base, dmu = jax.jvp(lambda p: ints(draught, p).moment_u, (zero,), (jnp.ones(()),))
    return vol, area, dmu - ints(draught, zero).moment_vertical


def _waterplane(hull: Hull, draught: float) -> tuple[float, float, float]:
    v = _surface_waterplane(_bare(hull), jnp.asarray(float(draught)))
    return tuple(float(a) for a in v)


def _breadths_at(hull: Hull, draught: float) -> np.ndarray:
    """Half-breadths y(x_i, z = draught) [m] of the section polygons (linear between offsets, vertical above)."""
    z = np.asarray(hull.waterlines)
    hb = np.asarray(hull.half_breadths)
    return np.array([np.interp(draught, z, row, left=0.0, right=row[-1]) for row in hb])


def _trapezoid(x: np.ndarray) -> np.ndarray:
    dx = np.diff(x)
    return np.concatenate([dx[:1], dx[:-1] + dx[1:], dx[-1:]]) / 2


def waterplane_inertia(hull: Hull, draught: float) -> float:
    """Transverse inertia I_T [m⁴] of the even-keel waterplane at `draught` [m]: ∫ (2/3) y³ dx (trapezoid in x,
    as the hydrostatics integrates; exact for a hull surface)."""
    if hull.surface is not None:
        return _waterplane(hull, draught)[2]
    y = _breadths_at(hull, draught)
    return float(np.sum(_trapezoid(np.asarray(hull.stations)) * 2.0 / 3.0 * y**3))


def waterplane_area(hull: Hull, draught: float) -> float:
    """Area A_W [m²] of the even-keel waterplane at `draught` [m]."""
    if hull.surface is not None:
        return _waterplane(hull, draught)[1]
    return float(np.sum(_trapezoid(np.asarray(hull.stations)) * 2.0 * _breadths_at(hull, draught)))


def volume_to(hull: Hull, draught: float) -> float:
    """Even-keel displaced volume [m³] up to `draught` [m] (exact for the section polygons, or the surface)."""
    if hull.surface is not None:
        return _waterplane(hull, draught)[0]
    z = np.asarray(hull.waterlines)
    zz = np.unique(np.concatenate([z[z < draught], [draught]]))
    zz = zz[zz >= z[0]]
    hb = np.asarray(hull.half_breadths)
    areas = []
    for row in hb:
        y = np.interp(zz, z, row, left=0.0, right=row[-1])
        areas.append(float(np.sum(np.diff(zz) * (y[1:] + y[:-1]))))  # 2 ∫ y dz, trapezoid exact for linear y
    return float(np.sum(_trapezoid(np.asarray(hull.stations)) * np.asarray(areas)))


# ==============================================================================================================
# Level 1
# ==============================================================================================================


@dataclass
class Level1Result:
    """Parametric-roll Level 1 (lengths [m], GM [m], ratios [-])."""

    gm: float
    r_pr: float
    draught: float
    draught_high: float
    draught_low: float
    reserve_ratio: float
    delta_gm1_waterplane: float
    delta_gm1_waves: float
    gm_waves: list
    method: str
    delta_gm1: float
    ratio: float
    vulnerable: bool
    notes: list = field(default_factory=list)


def _calm(hull: Hull, loading: Loading):
    p = hydrostatic_particulars(hull, loading)
    gm = float(p.gm)
    if not gm > 0:
        raise ValueError(
            f"the calm-water GM is {gm:.4g} m (KG = {float(loading.kg):.4g} m): the ship is not initially "
            "stable, and the parametric-roll criteria divide by GM. Lower KG."
        )
    return p


def level1(
    hull: Hull,
    loading: Loading,
    *,
    bilge_keel_area: float = 0.0,
    sharp_bilge: bool = False,
    full_load_draught: float | None = None,
    method: str = "auto",
) -> Level1Result:
    """Level-1 vulnerability to parametric rolling (Circ.1627 2.5, Level 1).

    **Arguments:**

    - `hull`, `loading`: the hull and the loading condition (draught d, KG); GM is the calm GM.
    - `bilge_keel_area`: A_k [m²] (both sides); `sharp_bilge`: R_PR = 1.87.
    - `full_load_draught`: d_full [m] for δd_L (default: the loading's draught).
    - `method`: `"waterplane"` (ΔGM1 = (I_H − I_L)/(2V)), `"waves"` (half the GM range on the L S_W wave over
      10 crest positions) or `"auto"`: waterplane when (V_D − V)/(A_W (D − d)) ≥ 1, else waves.

    **Returns:** a [`Level1Result`][]; `vulnerable` is True when ΔGM1/GM > R_PR.

    **Raises:** `ValueError` when the calm GM is not positive, or for an unknown method.
    """
    if method not in ("auto", "waterplane", "waves"):
        raise ValueError(f"method must be 'auto', 'waterplane' or 'waves'; got {method!r}.")
    L, D = float(hull.lpp), float(hull.depth)
    calm = _calm(hull, loading)
    d, gm, V = float(calm.draught), float(calm.gm), float(calm.volume)
    dfull = d if full_load_draught is None else float(full_load_draught)
    dd_h = min(D - d, L * WAVE_STEEPNESS_LEVEL1 / 2)
    dd_l = min(d - DRAUGHT_LOW_FRACTION * dfull, L * WAVE_STEEPNESS_LEVEL1 / 2)
    d_h, d_l = d + dd_h, d - dd_l
    dgm_wp = (waterplane_inertia(hull, d_h) - waterplane_inertia(hull, d_l)) / (2 * V)
    reserve = (volume_to(hull, D) - V) / (waterplane_area(hull, d) * (D - d))
    gms = gm_in_waves(hull, loading, wavelengths=[L], heights=[L * WAVE_STEEPNESS_LEVEL1])[0]
    dgm_w = float((gms.max() - gms.min()) / 2)
    notes = []
    if method == "auto":
        method = "waterplane" if reserve >= RESERVE_RATIO_MIN else "waves"
        if method == "waves":
            notes.append(
                f"(V_D − V)/(A_W (D − d)) = {reserve:.3f} < {RESERVE_RATIO_MIN}: the waterplane method does not "
                "apply; ΔGM1 from GM in waves."
            )
    dgm1 = dgm_wp if method == "waterplane" else dgm_w
    rpr = r_pr(
        lpp=L,
        breadth=float(calm.waterline_breadth),
        midship_coefficient=float(calm.midship_coefficient),
        bilge_keel_area=bilge_keel_area,
        sharp_bilge=sharp_bilge,
    )
    ratio = dgm1 / gm
    return Level1Result(
        gm=gm,
        r_pr=rpr,
        draught=d,
        draught_high=d_h,
        draught_low=d_l,
        reserve_ratio=float(reserve),
        delta_gm1_waterplane=float(dgm_wp),
        delta_gm1_waves=dgm_w,
        gm_waves=gms.tolist(),
        method=method,
        delta_gm1=float(dgm1),
        ratio=float(ratio),
        vulnerable=bool(ratio > rpr),
        notes=notes,
    )


# ==============================================================================================================
# Level 2, first check C1
# ==============================================================================================================


def is_code_roll_period(*, breadth: float, draught: float, waterline_length: float, gm: float) -> float:
    """Natural roll period T_φ = 2 C B/√GM [s], C = 0.373 + 0.023 B/d − 0.043 L_WL/100 (IS Code 2008, Part A
    2.3.4, weather criterion): the default when no roll period is given."""
    c = 0.373 + 0.023 * breadth / draught - 0.043 * waterline_length / 100
    return 2 * c * breadth / math.sqrt(gm)


@dataclass
class C1Result:
    """Level-2 first check: C1 [-] against its standard, and every wave case's values."""

    c1: float
    standard: float
    vulnerable: bool
    r_pr: float
    roll_period: float
    service_speed: float
    cases: list  # per wave case: dict(weight, wavelength_m, height_m, gm_mean_m, delta_gm_m, ratio, v_pr_m_s, ...)


def c1_from_gm(
    gm_waves: np.ndarray,
    gm: float,
    *,
    r_pr_value: float,
    roll_period: float,
    service_speed: float,
    cases: np.ndarray = C1_WAVE_CASES,
) -> C1Result:
    """C1 from the GM at the crest positions of each wave case (`gm_waves`, shape (16, 10) [m]) and the calm GM.

    C_i = 0 if (GM_i > 0 and ΔGM_i/GM_i < R_PR) or V_PR,i > V_S, with GM_i the mean and ΔGM_i half the range of
    the 10 values and V_PR,i = |(2 λ_i/T_φ) √(GM_i/GM) − √(g λ_i/(2π))| the speed of principal parametric
    resonance (encounter period T_φ'/2, head or following seas); C_i = 1 otherwise.
    """
    rows = []
    for (w, lam, h), gms in zip(np.asarray(cases), np.asarray(gm_waves)):
        gmi, dgm = float(gms.mean()), float((gms.max() - gms.min()) / 2)
        stable = gmi > 0 and dgm / gmi < r_pr_value
        v_pr = abs(
            2 * lam / roll_period * math.sqrt(max(gmi, 0.0) / gm) - math.sqrt(GRAVITY * lam / (2 * math.pi))
        )
        fast = v_pr > service_speed
        rows.append(
            dict(
                weight=float(w),
                wavelength_m=float(lam),
                height_m=float(h),
                gm_mean_m=gmi,
                delta_gm_m=dgm,
                ratio=dgm / gmi if gmi > 0 else math.inf,
                v_pr_m_s=v_pr,
                stable=bool(stable),
                resonance_above_service_speed=bool(fast),
                c=0 if (stable or fast) else 1,
            )
        )
    c1 = float(sum(r["weight"] * r["c"] for r in rows))
    return C1Result(c1, R_PR1, c1 > R_PR1, float(r_pr_value), float(roll_period), float(service_speed), rows)


def level2_c1(
    hull: Hull,
    loading: Loading,
    *,
    service_speed: float,
    roll_period: float | None = None,
    bilge_keel_area: float = 0.0,
    sharp_bilge: bool = False,
) -> C1Result:
    """Level-2 first check C1 = Σ W_i C_i (Circ.1627 2.5, Level 2, first check); see [`c1_from_gm`][].

    **Arguments:** `hull`, `loading`; `service_speed` V_S [m/s]; `roll_period` T_φ [s] (default: the IS Code
    formula, [`is_code_roll_period`][]); `bilge_keel_area` A_k [m²], `sharp_bilge` as for [`r_pr`][].
    """
    if not (math.isfinite(service_speed) and service_speed >= 0):
        raise ValueError(f"`service_speed` must be a finite speed >= 0 [m/s]; got {service_speed}.")
    calm = _calm(hull, loading)
    gm = float(calm.gm)
    if roll_period is None:
        roll_period = is_code_roll_period(
            breadth=float(calm.waterline_breadth),
            draught=float(calm.draught),
            waterline_length=float(hull.lpp),
            gm=gm,
        )
    rpr = r_pr(
        lpp=float(hull.lpp),
        breadth=float(calm.waterline_breadth),
        midship_coefficient=float(calm.midship_coefficient),
        bilge_keel_area=bilge_keel_area,
        sharp_bilge=sharp_bilge,
    )
    lam, h = C1_WAVE_CASES[:, 1], C1_WAVE_CASES[:, 2]
    gms = gm_in_waves(hull, loading, wavelengths=lam, heights=h)
    return c1_from_gm(gms, gm, r_pr_value=rpr, roll_period=roll_period, service_speed=service_speed)
