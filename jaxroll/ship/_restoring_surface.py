r"""Restoring in waves at large heel: a GZ(φ, ζ_mid) surface from the hull's hydrostatics in waves.

The paper's model restores with GZ_calm(φ) + ΔGM(ζ_mid)·φ: the wave changes the slope of GZ at the upright and
nothing else. A hull in a wave of length L with a trough amidships gains far more at large heel than ΔGM·φ (its
flared bow and wide transom immerse; the default C11-like table: the polynomial model is 0.9 m RMS off the hull's
GZ over 0–70°, ±6 m), and loses more with a crest. [`fit_restoring_surface`][] fits the hull's table GZ(ζ_i, φ_j)
(`jaxroll.ship.hull_hydrostatics`: free sinkage and trim, the paper's non-memory assumption) by

$$GZ(φ, ζ) = \underbrace{GM_0 φ + g_3 φ^3 + … + g_9 φ^9}_{\text{the ship's calm GZ}} + ΔGM(ζ)\,φ
  + \sum_{j=1}^{J} \sum_{k=1}^{K} c_{jk}\, φ^{2j+1} ζ^k,$$

the ship's own polynomial model (its `[restoring]` and `[delta_gm]`) plus a correction odd in φ, of order φ³ at
small heel and zero in calm water. So the surface reduces to the polynomial model exactly: ∂GZ/∂φ at φ = 0 is
GM0 + ΔGM(ζ), GZ(φ, 0) the ship's calm GZ; it is a polynomial (smooth, every derivative continuous), and in the
roll equation its ζ-part is formed once per excitation value, so an RK4 stage adds J multiply-adds in φ².
The surface holds only on the table's range, |φ| ≤ `heel_max`, `zeta_min` ≤ ζ_mid ≤ `zeta_max`: the Monte Carlo
ends a realization that leaves it (counted with the capsizes, never extrapolated: `jaxroll.roll`).
With σ_obs/σ_thr = r ≠ 1 the whole wave part ΔGM(ζ)φ + Σ c φ ζ is multiplied by r, as P(t) is.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._compiled import as_float
from ._restoring import _floating, delta_gm, parametric_excitation, restoring_moment, righting_lever
from ._ship import Ship

HEEL_TERMS = 5
"""Default J: heel powers φ³, φ⁵, …, φ¹¹ of the correction."""

ZETA_TERMS = 6
"""Default K: wave powers ζ¹ … ζ⁶ of the correction (ΔGM's degree)."""


class RestoringSurface(eqx.Module):
    """The correction of a ship's GZ in waves beyond its polynomial model, Σ c_jk φ^(2j+1) ζ_midᵏ [m]
    (j = 1..J, k = 1..K), and the range of heel and wave where it was fitted (module docstring)."""

    coefficients: Float[Array, "J K"]
    heel_max: Float[Array, ""]
    zeta_min: Float[Array, ""]
    zeta_max: Float[Array, ""]
    fit_rms: Float[Array, ""]
    fit_max_error: Float[Array, ""]
    source: str = eqx.field(static=True, default="")

    def __init__(self, coefficients, heel_max, zeta_min, zeta_max, fit_rms=0.0, fit_max_error=0.0, source=""):
        """`coefficients` c[j−1][k−1] of φ^(2j+1) ζ_midᵏ [m/(rad^(2j+1) mᵏ)]; the range `heel_max` [rad] (|φ| up to
        it), `zeta_min`, `zeta_max` [m] (ζ_mid > 0: trough amidships); `fit_rms`, `fit_max_error` [m]: the surface
        against the hydrostatics it came from; `source`: text (where it came from).

        **Raises:** `ValueError` for a malformed surface (`check_surface`)."""
        self.coefficients = as_float(coefficients)
        self.heel_max = as_float(heel_max)
        self.zeta_min = as_float(zeta_min)
        self.zeta_max = as_float(zeta_max)
        self.fit_rms = as_float(fit_rms)
        self.fit_max_error = as_float(fit_max_error)
        self.source = str(source)
        check_surface(self)


def check_surface(surface: RestoringSurface) -> None:
    """Raise `ValueError` (one line, naming the value and the fix) when the surface is malformed: coefficients not a
    non-empty 2-D table of finite numbers, `heel_max` outside (0, π/2], or a wave range that is empty, not finite or
    does not contain calm water (concrete values only)."""
    c = np.asarray(surface.coefficients)
    if c.ndim != 2 or 0 in c.shape:
        raise ValueError(
            f"the GZ surface's coefficients must be a table of rows (one per heel power φ³, φ⁵, …) of the wave "
            f"powers ζ¹, ζ², …; got shape {c.shape}."
        )
    if not np.all(np.isfinite(c)):
        raise ValueError("the GZ surface's coefficients must be finite numbers; got NaN or inf.")
    h, lo, hi = (float(np.asarray(v)) for v in (surface.heel_max, surface.zeta_min, surface.zeta_max))
    if not (math.isfinite(h) and 0 < h <= math.pi / 2):
        raise ValueError(f"the GZ surface's heel_max must be in (0, π/2] rad (0–90°); got {h} rad.")
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= 0 <= hi and lo < hi):
        raise ValueError(
            f"the GZ surface's wave range [zeta_min, zeta_max] = [{lo}, {hi}] m must be finite and contain calm "
            "water (zeta_min <= 0 <= zeta_max, zeta_min < zeta_max)."
        )


def surface_correction(surface: RestoringSurface, phi, zeta_mid) -> Float[Array, "..."]:
    """The surface's correction Σ c_jk φ^(2j+1) ζ_midᵏ [m] at heel φ [rad] and ζ_mid [m] (no range check)."""
    phi, zeta = _floating(phi), _floating(zeta_mid)
    d = _zeta_coefficients(surface.coefficients.astype(zeta.dtype), zeta)
    return _heel_series(d, phi)


def _zeta_coefficients(c, zeta):
    """d_j(ζ) = Σ_k c_jk ζᵏ for every j: an array (J, *ζ.shape) (Horner in ζ)."""
    out = jnp.zeros((c.shape[0], *jnp.shape(zeta)), zeta.dtype)
    for k in range(c.shape[1] - 1, -1, -1):
        out = (out + c[:, k].reshape((-1,) + (1,) * jnp.ndim(zeta))) * zeta
    return out


def _heel_series(d, phi):
    """Σ_j d_j φ^(2j+1), j = 1..J (Horner in φ²)."""
    phi2 = phi * phi
    acc = jnp.zeros_like(phi2 * d[-1])
    for j in range(d.shape[0] - 1, -1, -1):
        acc = (acc + d[j]) * phi2
    return acc * phi


def gz_in_waves(ship: Ship, phi, zeta_mid) -> Float[Array, "..."]:
    """GZ [m] of `ship` at heel φ [rad] with ζ_mid [m] amidships (> 0: trough): GZ_calm(φ) + r·(ΔGM(ζ)φ + the
    surface's correction) when the ship carries a surface (`ship.restoring_surface`), else the paper's
    GZ_calm(φ) + r·ΔGM(ζ)φ (r = σ_obs/σ_thr). No range check (`in_surface_range`)."""
    phi, zeta = _floating(phi), _floating(zeta_mid)
    wave = delta_gm(ship, zeta) * phi
    if ship.restoring_surface is not None:
        wave = wave + surface_correction(ship.restoring_surface, phi, zeta)
    return righting_lever(ship, phi) + ship.gm_correction * wave


def in_surface_range(surface: RestoringSurface, phi, zeta_mid) -> Array:
    """Whether (φ [rad], ζ_mid [m]) lies on the surface's range: |φ| ≤ heel_max and zeta_min ≤ ζ_mid ≤ zeta_max."""
    dtype = jnp.result_type(_floating(phi), _floating(zeta_mid))
    lo, hi, h = (jnp.asarray(v, dtype) for v in (surface.zeta_min, surface.zeta_max, surface.heel_max))
    return (jnp.abs(phi) <= h) & (zeta_mid >= lo) & (zeta_mid <= hi)


def wave_restoring_terms(ship: Ship, zeta_g):
    """What the roll equation needs of the wave at one instant, from Grim's effective wave ζ_G [m] (ζ_mid = −ζ_G):
    P = r (ω0²/GM0) ΔGM(ζ_mid) [1/s²] for a ship without a surface; with one, (P, d) with
    d_j = r (ω0²/GM0) Σ_k c_jk ζ_midᵏ [1/(s² rad^(2j))], so that `restoring_in_waves` costs J multiply-adds."""
    p = parametric_excitation(ship, zeta_g)
    surface = ship.restoring_surface
    if surface is None:
        return p
    zeta = -_floating(zeta_g)
    scale = (ship.gm_correction * ship.omega0**2 / ship.gm0).astype(zeta.dtype)
    return p, scale * _zeta_coefficients(surface.coefficients.astype(zeta.dtype), zeta)


def restoring_in_waves(ship: Ship, phi, terms) -> Float[Array, "..."]:
    """Restoring per unit roll inertia [1/s²·rad] at roll φ [rad] in the wave `terms` (`wave_restoring_terms`):
    a1φ + … + a9φ⁹ + Pφ, plus Σ d_j φ^(2j+1) with a surface."""
    if isinstance(terms, tuple):
        p, d = terms
        return restoring_moment(ship, phi) + p * phi + _heel_series(d, phi)
    return restoring_moment(ship, phi) + terms * phi


def restoring_surface_refusal(what: str) -> str:
    """The one-line reason `what` (a theory, a path) gives for a ship with a GZ surface it would ignore."""
    return (
        f"{what}: the ship carries a GZ(φ, ζ_mid) surface (ship.restoring_surface), which this computation would "
        "ignore (it knows only GZ_calm(φ) + ΔGM(ζ)·φ, the surface's small-heel reduction): use the Monte Carlo, or "
        "drop the surface (the ship file without [restoring_surface]; in Python eqx.tree_at(lambda s: "
        "s.restoring_surface, ship, None)) for the polynomial model."
    )


def refuse_restoring_surface(ship: Ship, what: str) -> None:
    """Raise `ValueError` (`restoring_surface_refusal`) when `ship` carries a GZ surface (`ship.restoring_surface`)
    that `what` would ignore. Static check (works when traced)."""
    if getattr(ship, "restoring_surface", None) is not None:
        raise ValueError(restoring_surface_refusal(what))


def fit_restoring_surface(
    solution,
    ship: Ship,
    *,
    heel_terms: int = HEEL_TERMS,
    zeta_terms: int = ZETA_TERMS,
    source: str = "jaxroll hydrostatics",
) -> RestoringSurface:
    """The [`RestoringSurface`][] of `ship` from the hull's hydrostatics table `solution`
    (`jaxroll.ship.hull_hydrostatics`, the ship made from it by `ship_from_hydrostatics`): least squares of the
    table's GZ(ζ_i, φ_j) minus the ship's polynomial model over φ^(2j+1) ζᵏ, j = 1..`heel_terms`,
    k = 1..`zeta_terms`, in scaled variables (host side, NumPy). Its range is the table's: |φ| up to its largest
    heel, ζ_mid over its amplitudes. `fit_rms` and `fit_max_error` [m] compare the whole surface with the table
    (at ζ = 0 the error is the calm polynomial's own).

    **Raises:** `ValueError` when the table has too few heels or amplitudes for the terms asked."""
    for name, v, lo in (("heel_terms", heel_terms, 1), ("zeta_terms", zeta_terms, 1)):
        if not (isinstance(v, int) and v >= lo):
            raise ValueError(f"`{name}` must be an integer >= {lo}; got {v!r}.")
    phi = np.asarray(solution.heels, float)
    zeta = np.asarray(solution.zeta_mid, float)
    gz = np.asarray(solution.gz, float)
    n_phi, n_zeta = np.count_nonzero(np.unique(np.abs(phi))), np.count_nonzero(np.unique(zeta))
    if n_phi < heel_terms + 1 or n_zeta < zeta_terms:
        raise ValueError(
            f"a GZ surface of {heel_terms} heel × {zeta_terms} wave terms needs at least {heel_terms + 1} non-zero "
            f"heels and {zeta_terms} non-zero amplitudes; the table has {n_phi} and {n_zeta} (raise --n-heel or "
            "--n-zeta)."
        )
    # the ship's polynomial model, without the correction r and without a surface
    model = eqx.tree_at(
        lambda s: (s.gm_correction, s.restoring_surface),
        ship,
        (as_float(1.0), None),
        is_leaf=lambda x: x is None,
    )
    zz, pp = np.meshgrid(zeta, phi, indexing="ij")
    base = np.asarray(gz_in_waves(model, pp, zz))
    residual = (gz - base).ravel()
    ps, zs = float(np.max(np.abs(phi))), float(np.max(np.abs(zeta)))
    powers = [(2 * j + 1, k) for j in range(1, heel_terms + 1) for k in range(1, zeta_terms + 1)]
    design = np.stack([((pp / ps) ** a * (zz / zs) ** b).ravel() for a, b in powers], axis=1)
    coef, *_ = np.linalg.lstsq(design, residual, rcond=None)
    error = residual - design @ coef
    c = np.array([v / (ps**a * zs**b) for v, (a, b) in zip(coef, powers, strict=True)])
    return RestoringSurface(
        c.reshape(heel_terms, zeta_terms),
        heel_max=ps,
        zeta_min=float(np.min(zeta)),
        zeta_max=float(np.max(zeta)),
        fit_rms=float(np.sqrt(np.mean(error**2))),
        fit_max_error=float(np.max(np.abs(error))),
        source=source,
    )
