r"""Hull hydrostatics: GZ(φ) and ΔGM(ζ_mid) from station offsets (Froude–Krylov, quasi-static balance).

The paper (Katsumura et al., arXiv 2407.02728, appendix A) obtains the non-memory relation ΔGM(ζ_mid) by
computing the GM of the hull in a wave of length L with its crest or trough amidships, sinkage and trim
balanced quasi-statically, for several wave amplitudes, and fitting a 6th-order polynomial. This module does
the hydrostatics of that computation from a hull description (`jaxroll.ship._hull`), exactly for the polygonal
hull the offsets define, and differentiably in JAX: immersed section properties, the loading condition, the
balance, GZ(φ), GM(ζ_mid) and the upright particulars. The table over (ζ_mid, φ) and its polynomial fits are
in `jaxroll.ship._fits`.

**Method.** Each station's section is the polygon of its offsets, mirrored to port and closed by the deck at
`depth`. At heel φ the water surface in the section plane is a straight line; the immersed part of the section
is the polygon clipped by that half-plane. Its area and first moments follow from Green's theorem written in
coordinates $(u, w)$ — $u$ horizontal (to starboard), $w$ depth below the surface — in which the clipping line
is $w = 0$, so that only the (clipped) hull edges contribute:

$$A = \oint w\,du, \qquad \iint u\,dA = \oint u w\,du, \qquad \iint w\,dA = \oint \tfrac12 w^2\,du .$$

Every edge integral is a closed-form polynomial of its clipped end points, so the result is exact for the
polygon and piecewise smooth in every input (vectorised over stations and edges with `jnp.where`; no Python
loops). The sections are integrated along the hull with the trapezoid rule. Sinkage and trim are balanced with
`optimistix.Newton` so that the displaced mass equals the ship's mass and LCB = LCG, in calm water, in a wave
of length λ (default L) with its crest or trough amidships, and at every heel (free trim). Gradients pass
through the balance by the implicit function theorem.

**Frames and signs** (see `docs/hydrostatics.md`):

- body frame: x [m] forward from the aft perpendicular (AP), y [m] to starboard, z [m] up from the baseline;
- heel φ [rad] positive to starboard (starboard side down); GZ > 0 rights the ship;
- wave profile along the hull: η(x) = −ζ_mid cos(2π (x − L/2)/λ); ζ_mid > 0 puts a **trough** amidships,
  ζ_mid < 0 a **crest** (docs/conventions.md);
- water surface at station x (earth-vertical height above the baseline point on the centreline):
  h(x) = sinkage + trim · (x − L/2)/L + η(x), so `sinkage` is the draught amidships and
  `trim` = d_FP − d_AP [m] is positive by the head (bow down). Trim enters as a small angle (sections stay
  vertical), which is the usual hydrostatic approximation for trims of a few metres over a ship's length.
"""

from __future__ import annotations

import functools
import inspect
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._compiled import filter_jit
from . import _surface
from ._hull import Hull, _bare, _c11_hull_path, _concrete, _section_polygons

GRAVITY = 9.80665
"""Standard gravity g [m/s²]."""

SEAWATER_DENSITY = 1025.0
"""Default sea-water density ρ [kg/m³]."""

# Equilibrium tolerances: the balance residuals are in metres (volume error / (L B), LCB − LCG).
_NEWTON = optx.Newton(rtol=1e-10, atol=1e-9)
_MAX_STEPS = 64


# ------------------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------------------


def _entry_point(fn):
    """`filter_jit` (`jaxroll._compiled`) with Python numbers and lists turned into float arrays first.

    `filter_jit` treats Python scalars as static, so `gz_curve(..., zeta_mid=3.0)` would compile again for
    every new amplitude; as arrays they are traced and one compilation serves all values.
    """
    jitted = filter_jit(fn)

    def convert(v):
        if isinstance(v, Hull):
            return _bare(v)  # name and provenance are not part of the program: one compilation per hull size
        if isinstance(v, bool) or not isinstance(v, int | float | list | np.ndarray | np.generic):
            return v
        return jnp.asarray(v, dtype=float)

    signature = inspect.signature(fn)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()  # defaults too: a Python-float default would be static as well
        return jitted(*map(convert, bound.args), **{k: convert(v) for k, v in bound.kwargs.items()})

    return wrapper


def _trapezoid_weights(x: Float[Array, " n"]) -> Float[Array, " n"]:
    """Weights w with Σ w f = ∫ f dx for f linear between the nodes x (the trapezoid rule)."""
    dx = jnp.diff(x)
    return jnp.concatenate([dx[:1], dx[:-1] + dx[1:], dx[-1:]]) / 2


def _first_moment_weights(x: Float[Array, " n"]) -> Float[Array, " n"]:
    """Weights w with Σ w f = ∫ x f dx exactly for f linear between the nodes x.

    Consistent with the trapezoid rule for ∫ f dx: the LCB is that of the piecewise-linear sectional-area
    curve, so it is exact for a trimmed box and trim moments are not polluted by an O(Δx²) error of x·A.
    """
    x0, x1 = x[:-1], x[1:]
    dx = x1 - x0
    left = dx * (2 * x0 + x1) / 6
    right = dx * (x0 + 2 * x1) / 6
    zero = jnp.zeros(1, dtype=x.dtype)
    return jnp.concatenate([left, zero]) + jnp.concatenate([zero, right])


# ------------------------------------------------------------------------------------------------------------
# Section integrals (the hot path)
# ------------------------------------------------------------------------------------------------------------


def _immersed_section_moments(ys, zs, heel, h):
    """Area, ∬u dA and ∬w dA of every section's immersed part (exact for the polygons).

    `ys`, `zs`: (stations, vertices); `heel` [rad] scalar; `h`: (stations,) level of the water surface.
    u = y cos φ + z sin φ (horizontal, to starboard), w = h − (z cos φ − y sin φ) (depth below the surface).
    """
    c, s = jnp.cos(heel), jnp.sin(heel)
    u0 = ys * c + zs * s
    w0 = h[:, None] - (zs * c - ys * s)
    u1 = jnp.roll(u0, -1, axis=1)
    w1 = jnp.roll(w0, -1, axis=1)
    in0 = w0 >= 0
    in1 = w1 >= 0
    denom = w0 - w1
    crossing = in0 != in1
    safe = jnp.where(crossing, denom, 1.0)
    t_cross = jnp.where(crossing, jnp.clip(w0 / safe, 0.0, 1.0), 0.0)
    t_a = jnp.where(in0, 0.0, t_cross)
    t_b = jnp.where(in1, 1.0, t_cross)
    du_edge = u1 - u0
    ua = u0 + t_a * du_edge
    ub = u0 + t_b * du_edge
    wa = jnp.where(in0, w0, 0.0)
    wb = jnp.where(in1, w1, 0.0)
    keep = in0 | in1
    du = jnp.where(keep, ub - ua, 0.0)
    dw = wb - wa
    area = du * (wa + wb) / 2
    mom_u = du * (ua * wa + (ua * dw + wa * du) / 2 + du * dw / 3)
    mom_w = du * (wa * wa + wa * wb + wb * wb) / 6
    return area.sum(axis=1), mom_u.sum(axis=1), mom_w.sum(axis=1)


def wave_elevation(
    hull: Hull, zeta_mid: ArrayLike, wavelength: ArrayLike | None = None
) -> Float[Array, " stations"]:
    r"""Wave elevation η(x) [m] at the hull's stations: η = −ζ_mid cos(2π (x − L/2)/λ).

    **Arguments:**

    - `hull`: the hull (its stations x [m] from the AP and Lpp).
    - `zeta_mid`: wave amplitude ζ_mid [m]; > 0 puts a trough amidships, < 0 a crest (docs/conventions.md).
    - `wavelength`: λ [m]; defaults to Lpp.
    """
    lam = hull.lpp if wavelength is None else jnp.asarray(wavelength, dtype=float)
    return -jnp.asarray(zeta_mid, dtype=float) * jnp.cos(2 * jnp.pi * (hull.stations - hull.amidships) / lam)


class _Integrals(eqx.Module):
    volume: Array  # ∇ [m³]
    moment_x: Array  # ∫ x A dx [m⁴]
    moment_u: Array  # ∫∬ u dA dx [m⁴]
    moment_vertical: (
        Array  # ∫∬ Z dA dx [m⁴], Z earth-vertical height above the baseline point on the centreline
    )


def _integrals(hull: Hull, heel, sinkage, trim, zeta_mid, wavelength, calm: bool = False) -> _Integrals:
    """The immersed integrals: of the hull's surface (exact) or offsets; `calm=True` where ζ_mid is 0."""
    if hull.surface is not None:
        lam = hull.lpp if wavelength is None else wavelength
        vol, mx, mu, mz = _surface.surface_integrals(
            hull.surface, heel, sinkage, trim, zeta_mid, lam, hull.amidships, hull.lpp, calm=calm
        )
        return _Integrals(volume=vol, moment_x=mx, moment_u=mu, moment_vertical=mz)
    ys, zs = _section_polygons(hull)
    x = hull.stations
    h = sinkage + trim * (x - hull.amidships) / hull.lpp + wave_elevation(hull, zeta_mid, wavelength)
    area, mom_u, mom_w = _immersed_section_moments(ys, zs, heel, h)
    wts = _trapezoid_weights(x)
    return _Integrals(
        volume=jnp.sum(wts * area),
        moment_x=jnp.sum(_first_moment_weights(x) * area),
        moment_u=jnp.sum(wts * mom_u),
        moment_vertical=jnp.sum(wts * (h * area - mom_w)),
    )


class Buoyancy(eqx.Module):
    """Volume and centre of buoyancy of the hull at a given waterline (no balance)."""

    volume: Float[Array, ""]
    lcb: Float[Array, ""]
    horizontal_centre: Float[Array, ""]
    vertical_centre: Float[Array, ""]


Buoyancy.__init__.__doc__ = """Fields: `volume` ∇ [m³]; `lcb` [m] from the AP; `horizontal_centre` [m]:
horizontal distance of B to starboard of the baseline point on the centre plane (= TCB upright, and GZ + KG
sin φ when heeled); `vertical_centre` [m]: earth-vertical height of B above that point (= KB upright).
"""


@_entry_point
def buoyancy(
    hull: Hull,
    sinkage: ArrayLike,
    *,
    trim: ArrayLike = 0.0,
    heel: ArrayLike = 0.0,
    zeta_mid: ArrayLike = 0.0,
    wavelength: ArrayLike | None = None,
) -> Buoyancy:
    """Immersed volume and centre of buoyancy at a prescribed waterline (sinkage, trim, heel held, no
    balance).

    **Arguments:**

    - `hull`: the hull.
    - `sinkage`: draught amidships [m] (earth-vertical, to the mean level of the wave).
    - `trim`: d_FP − d_AP [m], positive by the head.
    - `heel`: φ [rad], positive to starboard.
    - `zeta_mid`: wave amplitude at amidships [m] (> 0: trough); `wavelength`: λ [m], default Lpp.

    **Returns:** a [`Buoyancy`][] (scalars).
    """
    f = lambda a: jnp.asarray(a, dtype=float)
    ints = _integrals(hull, f(heel), f(sinkage), f(trim), f(zeta_mid), wavelength)
    return Buoyancy(
        volume=ints.volume,
        lcb=ints.moment_x / ints.volume,
        horizontal_centre=ints.moment_u / ints.volume,
        vertical_centre=ints.moment_vertical / ints.volume,
    )


# ------------------------------------------------------------------------------------------------------------
# Loading condition
# ------------------------------------------------------------------------------------------------------------


class Loading(eqx.Module):
    """A loading condition: the ship's mass, its centre of gravity, and the water it floats in.

    Build it with [`loading_condition`][], which checks the values against the hull and fills in LCG.
    """

    displacement: Float[Array, ""]
    kg: Float[Array, ""]
    lcg: Float[Array, ""]
    water_density: Float[Array, ""]
    draught: Float[Array, ""]

    @property
    def volume(self) -> Float[Array, ""]:
        """Displaced volume ∇ = Δ/ρ [m³]."""
        return self.displacement / self.water_density


Loading.__init__.__doc__ = """**Arguments:**

- `displacement`: displacement mass Δ [kg].
- `kg`: height of the centre of gravity above the baseline, KG [m].
- `lcg`: longitudinal centre of gravity [m] from the AP, positive forward.
- `water_density`: ρ [kg/m³].
- `draught`: even-keel draught [m] at this displacement: the starting guess of every balance (the ship trims
    away from it when LCG is not the even-keel LCB).
"""


def _even_keel_volume_residual(draught, args):
    hull, volume = args
    zero = jnp.zeros_like(draught)
    v = _integrals(hull, zero, draught, zero, zero, None, calm=True).volume
    return (v - volume) / (hull.lpp * hull.max_breadth)


def _even_keel_draught(hull: Hull, volume) -> tuple[Array, Array]:
    """Even-keel draught [m] displacing `volume` (bisection between the lowest waterline and the deck)."""
    lo, hi = hull.waterlines[0], hull.depth
    sol = optx.root_find(
        _even_keel_volume_residual,
        optx.Bisection(rtol=1e-12, atol=1e-10),
        (lo + hi) / 2,
        (hull, volume),
        options=dict(lower=lo, upper=hi),
        max_steps=200,
        throw=False,
    )
    return sol.value, sol.result == optx.RESULTS.successful


@filter_jit
def _loading_arrays(hull, kg, draught, displacement, lcg, rho, from_draught: bool):
    zero = jnp.zeros(())
    if from_draught:
        vol = _integrals(hull, zero, draught, zero, zero, None, calm=True).volume
        d = draught
        ok = jnp.array(True)
    else:
        vol = displacement / rho
        d, ok = _even_keel_draught(hull, vol)
    ints = _integrals(hull, zero, d, zero, zero, None, calm=True)
    lcb = ints.moment_x / ints.volume
    lcg_out = lcb if lcg is None else lcg
    return vol * rho, kg, lcg_out, rho, d, ok


@filter_jit
def _max_displaced_volume(hull):
    zero = jnp.zeros(())
    top = hull.waterlines[-1]  # a mesh's highest point may be above its depth amidships
    return _integrals(hull, zero, jnp.maximum(top, hull.depth), zero, zero, None, calm=True).volume


def loading_condition(
    hull: Hull,
    *,
    kg: ArrayLike,
    draught: ArrayLike | None = None,
    displacement: ArrayLike | None = None,
    lcg: ArrayLike | None = None,
    water_density: ArrayLike = SEAWATER_DENSITY,
) -> Loading:
    """The loading condition of `hull`, from KG and either the draught or the displacement.

    **Arguments:**

    - `hull`: the hull.
    - `kg`: KG [m] above the baseline.
    - `draught`: even-keel draught d [m] (the displacement is the even-keel volume at d times ρ); or
    - `displacement`: displacement mass Δ [kg] (the even-keel draught is solved for). Give exactly one.
    - `lcg`: LCG [m] from the AP; defaults to the even-keel LCB, so that the ship floats at even keel in calm
        water. With a different LCG the ship trims (see [`equilibrium`][]).
    - `water_density`: ρ [kg/m³], default 1025 (sea water).

    **Returns:** a [`Loading`][].

    **Raises:** `ValueError` when the values are not finite, when both or neither of `draught` and
    `displacement` are given, when the draught is not between the lowest waterline and the deck, or when the
    displacement is more than the hull displaces with its deck at the water (concrete inputs only: under
    `jax.grad` the checks are skipped).
    """
    if (draught is None) == (displacement is None):
        raise ValueError(
            "Give exactly one of `draught` [m] and `displacement` [kg] to define the loading condition; "
            f"got draught={draught!r}, displacement={displacement!r}."
        )
    checks = {
        "kg": kg,
        "water_density": water_density,
        "draught": draught,
        "displacement": displacement,
        "lcg": lcg,
    }
    for key, value in checks.items():
        if value is None:
            continue
        c = _concrete(value)
        if c is None:
            continue
        if c.shape != ():
            raise ValueError(f"`{key}` must be a scalar; got shape {c.shape}.")
        if not np.isfinite(c):
            raise ValueError(f"`{key}` must be a finite number; got {float(c)}. Give a value in SI units.")
        if key in ("water_density", "displacement") and c <= 0:
            raise ValueError(f"`{key}` must be > 0; got {float(c)} (SI units: kg/m³, kg).")
    hv = [_concrete(v) for v in (hull.waterlines, hull.depth)]
    if draught is not None and all(v is not None for v in hv) and _concrete(draught) is not None:
        d = float(_concrete(draught))
        if d >= float(hv[1]):
            raise ValueError(
                f"draught d = {d} m is at or above the depth D = {float(hv[1])} m: the deck would be under "
                "water. "
                "Give a draught below the deck (or check that the hull's depth is right)."
            )
        if d <= float(hv[0][0]):
            raise ValueError(
                f"draught d = {d} m is at or below the lowest waterline of the offsets, z = "
                f"{float(hv[0][0])} m: "
                "the hull would not float. Give a draught above the keel."
            )
    if (c_kg := _concrete(kg)) is not None and hv[1] is not None and c_kg.shape == () and c_kg > hv[1]:
        warnings.warn(
            f"KG = {float(c_kg):.4g} m is above the deck: the hull's depth is D = {float(hv[1]):.4g} m above the "
            "baseline. Possible only with tall superstructure or deck cargo: check that KG is measured from the "
            "baseline (the hull's datum; for a mesh, --baseline-z) and is in metres.",
            stacklevel=2,
        )
    f = lambda v: None if v is None else jnp.asarray(v, dtype=float)
    if displacement is not None:
        cd, cr = _concrete(displacement), _concrete(water_density)
        if cd is not None and cr is not None:
            max_mass = _max_displaced_volume(_bare(hull))
            cm = _concrete(max_mass)
            if cm is not None and cd >= cm * cr:
                raise ValueError(
                    f"displacement {float(cd):.6g} kg is more than the hull can float: with its deck at the "
                    "water "
                    f"it displaces {float(cm * cr):.6g} kg (ρ = {float(cr)} kg/m³). Check the units (kg, not "
                    "tonnes) and the offsets, or give a smaller displacement."
                )
    disp, kg_, lcg_, rho, d, ok = _loading_arrays(
        _bare(hull), f(kg), f(draught), f(displacement), f(lcg), f(water_density), draught is not None
    )
    c_ok = _concrete(ok)
    if c_ok is not None and not c_ok:
        raise ValueError(
            f"no even-keel draught between the keel and the deck displaces {float(_concrete(disp))} kg; "
            "check the "
            "displacement (kg) and the water density (kg/m³)."
        )
    c_lcg, c_st = _concrete(lcg_), _concrete(hull.stations)
    if lcg is not None and c_lcg is not None and c_st is not None and not c_st[0] <= c_lcg <= c_st[-1]:
        raise ValueError(
            f"LCG = {float(c_lcg)} m is outside the hull (stations span x = {c_st[0]} .. {c_st[-1]} m from "
            "the "
            "AP). LCG is measured from the aft perpendicular, positive forward."
        )
    return Loading(displacement=disp, kg=kg_, lcg=lcg_, water_density=rho, draught=d)


def c11_hull_loading() -> Loading:
    """Loading of the shipped C11-like hull (its file's [loading]): d = 11.5 m, KG giving GM0 ≈ 1.93 m."""
    # Function-level import: io/ imports ship/, so ship/ reads hull files only when called.
    from ..io._hull_file import loading_from_dict, read_hull_file

    hull, loading = read_hull_file(_c11_hull_path())
    return loading_from_dict(hull, loading)


# ------------------------------------------------------------------------------------------------------------
# Equilibrium
# ------------------------------------------------------------------------------------------------------------


class Equilibrium(eqx.Module):
    """Quasi-static balance of a hull (free sinkage and trim) at a given heel and wave position."""

    sinkage: Float[Array, "*batch"]
    trim: Float[Array, "*batch"]
    heel: Float[Array, "*batch"]
    zeta_mid: Float[Array, "*batch"]
    volume: Float[Array, "*batch"]
    lcb: Float[Array, "*batch"]
    gz: Float[Array, "*batch"]
    vertical_centre_of_buoyancy: Float[Array, "*batch"]
    result: optx.RESULTS
    num_steps: Int[Array, "*batch"]

    @property
    def converged(self) -> Bool[Array, "*batch"]:
        """True where the Newton balance converged."""
        return self.result == optx.RESULTS.successful


Equilibrium.__init__.__doc__ = """Fields (all [m] unless stated): `sinkage` (draught amidships,
earth-vertical), `trim` (d_FP − d_AP, positive by the head), `heel` [rad], `zeta_mid` (wave amplitude, > 0
trough amidships), `volume` [m³], `lcb` (from the AP), `gz` (righting lever about G, > 0 rights the ship),
`vertical_centre_of_buoyancy` (earth-vertical height of B above the baseline point on the centreline; KB when
upright), `result` (`optimistix.RESULTS`), `num_steps` (Newton steps).
"""


def _balance_residual(y, args):
    hull, loading, heel, zeta_mid, wavelength, calm = args
    if hull.surface is not None:  # only ∇ and ∫x dV, with closed-form Jacobians
        lam = hull.lpp if wavelength is None else wavelength
        args = (hull.surface, heel, y[0], y[1], zeta_mid, lam, hull.amidships, hull.lpp)
        volume, moment_x = _surface.balance_integrals(*args, calm=calm)
    else:
        ints = _integrals(hull, heel, y[0], y[1], zeta_mid, wavelength, calm)
        volume, moment_x = ints.volume, ints.moment_x
    scale = hull.lpp * hull.max_breadth
    return jnp.stack([(volume - loading.volume) / scale, (moment_x - loading.lcg * volume) / loading.volume])


def _equilibrium_single(hull, loading, heel, zeta_mid, wavelength, guess, calm: bool = False):
    sol = optx.root_find(
        _balance_residual,
        _NEWTON,
        guess,
        (hull, loading, heel, zeta_mid, wavelength, calm),
        max_steps=_MAX_STEPS,
        throw=False,
    )
    sinkage, trim = sol.value[0], sol.value[1]
    ints = _integrals(hull, heel, sinkage, trim, zeta_mid, wavelength, calm)
    gz = ints.moment_u / ints.volume - loading.kg * jnp.sin(heel)
    return Equilibrium(
        sinkage=sinkage,
        trim=trim,
        heel=heel,
        zeta_mid=zeta_mid,
        volume=ints.volume,
        lcb=ints.moment_x / ints.volume,
        gz=gz,
        vertical_centre_of_buoyancy=ints.moment_vertical / ints.volume,
        result=sol.result,
        num_steps=sol.stats["num_steps"],
    )


def _check_result(result, throw: bool, what: str):
    if not throw:
        return result
    failed = jnp.any(result != optx.RESULTS.successful)
    return eqx.error_if(
        result,
        failed,
        f"The quasi-static balance (sinkage and trim) did not converge for {what}. This happens when the "
        "hull "
        "cannot float at that heel or wave (deck or keel far out of the water), or the offsets are "
        "inconsistent. "
        "Reduce the wave amplitude or heel range, check the loading condition, or pass throw=False and "
        "inspect "
        "`result`/`converged`.",
    )


def _equilibrium_batch(hull, loading, heel, zeta_mid, wavelength, calm: bool = False) -> Equilibrium:
    """Balances at 1-D arrays of heels and amplitudes, one vmapped Newton solve (no throwing); `calm=True` where
    every amplitude is 0 (a hull surface then uses its unsplit triangles)."""
    guess = jnp.stack([loading.draught, jnp.zeros_like(loading.draught)])
    fn = lambda p, z: _equilibrium_single(hull, loading, p, z, wavelength, guess, calm)
    return jax.vmap(fn)(heel, zeta_mid)


@_entry_point
def equilibrium(
    hull: Hull,
    loading: Loading,
    *,
    heel: ArrayLike = 0.0,
    zeta_mid: ArrayLike = 0.0,
    wavelength: ArrayLike | None = None,
    throw: bool = True,
) -> Equilibrium:
    """Balance sinkage and trim so that displacement = mass and LCB = LCG, at a heel and in a wave.

    **Arguments:**

    - `hull`: the hull; `loading`: its [`Loading`][].
    - `heel`: heel φ [rad] (positive to starboard), held fixed; scalar or any array shape.
    - `zeta_mid`: amplitude of a wave of length λ at amidships [m] (> 0 trough, < 0 crest); broadcast with
        `heel`.
    - `wavelength`: λ [m]; defaults to Lpp.
    - `throw`: raise (`EquinoxRuntimeError`) if any balance fails; otherwise report it in `result`.

    **Returns:** an [`Equilibrium`][] with the broadcast shape of `heel` and `zeta_mid`.
    """
    heel, zeta_mid = jnp.broadcast_arrays(jnp.asarray(heel, dtype=float), jnp.asarray(zeta_mid, dtype=float))
    flat = _equilibrium_batch(hull, loading, heel.ravel(), zeta_mid.ravel(), wavelength)
    out = jax.tree_util.tree_map(lambda a: a.reshape(heel.shape + a.shape[1:]), flat)
    result = _check_result(out.result, throw, "this heel / wave")
    return eqx.tree_at(lambda e: e.result, out, result)


def _gm_at(hull, loading, sinkage, trim, zeta_mid, wavelength, calm: bool = False):
    """GM [m] = ∂GZ/∂φ at φ = 0 with sinkage and trim held (they are stationary in φ at φ = 0 by symmetry)."""

    def lever(phi):
        ints = _integrals(hull, phi, sinkage, trim, zeta_mid, wavelength, calm)
        return ints.moment_u / ints.volume

    _, dlever = jax.jvp(lever, (jnp.zeros(()),), (jnp.ones(()),))
    return dlever - loading.kg


@_entry_point
def metacentric_height(
    hull: Hull,
    loading: Loading,
    *,
    zeta_mid: ArrayLike = 0.0,
    wavelength: ArrayLike | None = None,
    throw: bool = True,
) -> Float[Array, "*zeta"]:
    r"""Transverse metacentric height GM [m] upright, in calm water or in a wave, with sinkage and trim
    balanced.

    GM is the initial slope dGZ/dφ at φ = 0 of the free-trim GZ curve; in a wave it includes the local
    waterline breadths and the shift of the centre of buoyancy (the paper's Froude–Krylov GM).

    **Arguments:**

    - `hull`, `loading`: the hull and its loading condition.
    - `zeta_mid`: wave amplitude(s) at amidships [m] (> 0 trough, < 0 crest); any shape.
    - `wavelength`: λ [m], default Lpp.
    - `throw`: raise if a balance fails (otherwise the GM of a failed balance is NaN-free but meaningless).

    **Returns:** GM [m] with the shape of `zeta_mid`. Differentiable in the hull, KG and ζ.
    """
    zeta = jnp.asarray(zeta_mid, dtype=float)
    eq = equilibrium(
        hull, loading, heel=jnp.zeros_like(zeta), zeta_mid=zeta, wavelength=wavelength, throw=throw
    )
    fn = lambda s, t, z: _gm_at(hull, loading, s, t, z, wavelength)
    return jax.vmap(fn)(eq.sinkage.ravel(), eq.trim.ravel(), zeta.ravel()).reshape(zeta.shape)


@_entry_point
def gz_curve(
    hull: Hull,
    loading: Loading,
    heels: ArrayLike,
    *,
    zeta_mid: ArrayLike = 0.0,
    wavelength: ArrayLike | None = None,
    throw: bool = True,
) -> Float[Array, " heels"]:
    """Righting lever GZ(φ) [m] with free sinkage and trim (displacement and LCB = LCG held at every heel).

    **Arguments:**

    - `hull`, `loading`: the hull and its loading condition.
    - `heels`: heel angles φ [rad] (positive to starboard).
    - `zeta_mid`: wave amplitude at amidships [m] (> 0 trough, < 0 crest), broadcast with `heels`.
    - `wavelength`: λ [m], default Lpp. `throw`: raise if a balance fails.

    **Returns:** GZ [m], > 0 righting, with the broadcast shape of `heels` and `zeta_mid`.
    """
    return equilibrium(hull, loading, heel=heels, zeta_mid=zeta_mid, wavelength=wavelength, throw=throw).gz


# ------------------------------------------------------------------------------------------------------------
# Calm-water particulars
# ------------------------------------------------------------------------------------------------------------


class Particulars(eqx.Module):
    """Upright hydrostatic particulars of a loading condition (calm water or a wave), all SI."""

    displacement: Float[Array, ""]
    volume: Float[Array, ""]
    draught: Float[Array, ""]
    draught_ap: Float[Array, ""]
    draught_fp: Float[Array, ""]
    trim: Float[Array, ""]
    lcb: Float[Array, ""]
    lcg: Float[Array, ""]
    kb: Float[Array, ""]
    bm: Float[Array, ""]
    km: Float[Array, ""]
    kg: Float[Array, ""]
    gm: Float[Array, ""]
    bm_longitudinal: Float[Array, ""]
    gm_longitudinal: Float[Array, ""]
    waterplane_area: Float[Array, ""]
    lcf: Float[Array, ""]
    waterline_breadth: Float[Array, ""]
    block_coefficient: Float[Array, ""]
    midship_coefficient: Float[Array, ""]
    prismatic_coefficient: Float[Array, ""]
    waterplane_coefficient: Float[Array, ""]
    result: optx.RESULTS

    def as_dict(self) -> dict[str, float]:
        """Plain floats keyed `<name>_<unit>` (for JSON)."""
        units = dict(
            displacement="kg",
            volume="m3",
            waterplane_area="m2",
            block_coefficient="",
            midship_coefficient="",
            prismatic_coefficient="",
            waterplane_coefficient="",
        )
        out = {}
        for k in self.__dataclass_fields__:
            if k == "result":
                continue
            unit = units.get(k, "m")
            out[f"{k}_{unit}" if unit else k] = float(getattr(self, k))
        return out

    def to_xarray(self):
        """The particulars as an `xarray.Dataset` of scalars named as in `as_dict` (hydrostatics.json's
        `calm_water`), with units and long names."""
        from .._labels import tree_to_dataset
        from .._labels._layouts import PARTICULARS

        return tree_to_dataset(self.as_dict(), PARTICULARS)


Particulars.__init__.__doc__ = """Fields: `displacement` Δ [kg]; `volume` ∇ [m³]; `draught` amidships,
`draught_ap`, `draught_fp` [m]; `trim` = d_FP − d_AP [m]; `lcb`, `lcg`, `lcf` [m] from the AP; `kb`, `bm`,
`km`, `kg`, `gm` [m] (transverse); `bm_longitudinal`, `gm_longitudinal` [m] (trim moment of the waterplane
about the LCF); `waterplane_area` [m²]; `waterline_breadth` B_WL [m]; `block_coefficient` ∇/(Lpp B_WL d),
`midship_coefficient` A_M/(B_WL d), `prismatic_coefficient` C_B/C_M, `waterplane_coefficient` A_WP/(Lpp B_WL);
`result` of the balance.
"""


@_entry_point
def hydrostatic_particulars(
    hull: Hull,
    loading: Loading,
    *,
    zeta_mid: ArrayLike = 0.0,
    wavelength: ArrayLike | None = None,
    throw: bool = True,
) -> Particulars:
    """Upright particulars (displacement, LCB, KB, BM, KM, GM, waterplane, form coefficients) at free trim.

    **Arguments:**

    - `hull`, `loading`: the hull and its loading condition.
    - `zeta_mid`: scalar wave amplitude at amidships [m] (0: calm water); `wavelength`: λ [m], default Lpp.
    - `throw`: raise if the balance fails.

    **Returns:** [`Particulars`][]. KB is the height of the centre of buoyancy above the baseline;
    BM = KM − KB with KM = KG + GM, GM from [`metacentric_height`][] (so in calm water BM = I_T/∇ exactly).
    """
    zeta = jnp.asarray(zeta_mid, dtype=float)
    eq = equilibrium(hull, loading, heel=jnp.zeros(()), zeta_mid=zeta, wavelength=wavelength, throw=throw)
    gm = _gm_at(hull, loading, eq.sinkage, eq.trim, zeta, wavelength)
    return _particulars(hull, loading, eq, gm, zeta, wavelength)


def _at_most_one(x, tol: float = 1e-9):
    """`x`, with values in (1, 1 + tol] (round-off of a form coefficient that is exactly 1) set to 1."""
    return jnp.where((x > 1) & (x <= 1 + tol), 1.0, x)


def _particulars(hull, loading, eq: Equilibrium, gm, zeta, wavelength, calm: bool = False) -> Particulars:
    zero = jnp.zeros(())
    s, t = eq.sinkage, eq.trim
    km = gm + loading.kg

    def vol_mx(y):
        ints = _integrals(hull, zero, y[0], y[1], zeta, wavelength, calm)
        return jnp.stack([ints.volume, ints.moment_x])

    jac = jax.jacfwd(vol_mx)(jnp.stack([s, t]))
    awp = jac[0, 0]
    lcf = jac[1, 0] / awp
    xm, lpp = hull.amidships, hull.lpp
    # ∂∫xA/∂trim = ∫ b x (x − xm) dx / L and ∂∇/∂trim = ∫ b (x − xm) dx / L, b the waterline breadth.
    i_xm = lpp * (jac[1, 1] - xm * jac[0, 1])  # ∫ b (x − xm)² dx
    i_l = i_xm - awp * (lcf - xm) ** 2
    bm_l = i_l / eq.volume

    if hull.surface is not None:
        lam = hull.lpp if wavelength is None else wavelength
        b_wl = _surface.waterline_breadth(hull.surface, s, t, zeta, lam, xm, lpp)
        a_mid = _surface.section_area(hull.surface, xm, s + zeta * (-1.0))  # η(L/2) = −ζ_mid
    else:
        ys, zs = _section_polygons(hull)
        h = s + t * (hull.stations - xm) / lpp + wave_elevation(hull, zeta, wavelength)
        area, breadth = jax.jvp(
            lambda hh: _immersed_section_moments(ys, zs, zero, hh)[0], (h,), (jnp.ones_like(h),)
        )
        b_wl = jnp.max(breadth)
        a_mid = jnp.interp(xm, hull.stations, area)
    # A box's coefficients are 1; round-off of the integrals must not push them past it (a ship file refuses > 1)
    cb = _at_most_one(eq.volume / (lpp * b_wl * s))
    cm = _at_most_one(a_mid / (b_wl * s))
    kb = eq.vertical_centre_of_buoyancy
    return Particulars(
        displacement=eq.volume * loading.water_density,
        volume=eq.volume,
        draught=s,
        draught_ap=s - t / 2,
        draught_fp=s + t / 2,
        trim=t,
        lcb=eq.lcb,
        lcg=loading.lcg,
        kb=kb,
        bm=km - kb,
        km=km,
        kg=loading.kg,
        gm=gm,
        bm_longitudinal=bm_l,
        gm_longitudinal=kb + bm_l - loading.kg,
        waterplane_area=awp,
        lcf=lcf,
        waterline_breadth=b_wl,
        block_coefficient=cb,
        midship_coefficient=cm,
        prismatic_coefficient=cb / cm,
        waterplane_coefficient=awp / (lpp * b_wl),
        result=eq.result,
    )


def kg_for_gm(hull: Hull, gm: ArrayLike, **loading_kwargs) -> Float[Array, ""]:
    """The KG [m] that gives the upright calm-water GM `gm` [m] (KG = KM − GM; KM does not depend on KG).

    **Arguments:**

    - `hull`: the hull. `gm`: the wanted GM [m].
    - `**loading_kwargs`: `draught` or `displacement`, and optionally `lcg`, `water_density`, as for
        [`loading_condition`][].
    """
    probe = loading_condition(hull, kg=0.0, **loading_kwargs)
    return metacentric_height(hull, probe) - jnp.asarray(gm, dtype=float)
