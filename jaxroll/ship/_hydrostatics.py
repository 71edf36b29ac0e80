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
from jaxtyping import Array, ArrayLike, Float

from .._compiled import as_float, cached_program
from . import _surface
from ._hull import C11_KG, C11_PARTICULARS, Hull, _bare, _concrete, _section_polygons, c11_hull

GRAVITY = 9.80665
"""Standard gravity g [m/s²]."""

SEAWATER_DENSITY = 1025.0
"""Default sea-water density ρ [kg/m³]."""

HYDROSTATICS_PROGRAM = {"xla_backend_optimization_level": 1}
"""XLA options (CPU) of the hydrostatics' programs: LLVM's level 1 compiles ≈ 10 % faster than the default and runs
the surface clip as fast; XLA's older loop emitters (`SOLVER_PROGRAM`) would run it 1.5× slower (a vmapped Newton
step of 208 wave balances on a 6 848-triangle surface: 110 ms at level 1 or the default, 166 ms with them)."""


# ------------------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------------------


def _entry_point(fn):
    """`fn` as a stored program (`jaxroll._compiled.cached_program`, `HYDROSTATICS_PROGRAM` options), its arguments
    passed in signature order, Python numbers and lists turned into float arrays and hulls stripped of their names
    first (`_bare`).

    A concrete call runs the program stored by an earlier process (no tracing; JAX's persistent cache supplies the
    compiled code); under `jit`, `grad` or `vmap` it is traced as usual. `filter_jit` would treat Python scalars as
    static, so `buoyancy(..., zeta_mid=3.0)` would compile again for every new amplitude; as arrays they are traced
    and one program serves all values — and every hull of a size class (`_surface.bucket_size`). `fn` must hold
    no host callback (no `eqx.error_if`): such a program is not kept by JAX's persistent cache.
    """
    signature = inspect.signature(fn)
    names = tuple(signature.parameters)

    def positional(*values):
        return fn(**dict(zip(names, values)))

    # the program's key names `fn` (no `__wrapped__`: `eqx.filter_jit` would bind the arguments to `fn`'s signature)
    positional.__module__, positional.__qualname__ = fn.__module__, fn.__qualname__
    program = cached_program(positional, compiler_options=HYDROSTATICS_PROGRAM)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()  # defaults too: a Python-float default would be static as well
        return program(*(_as_input(bound.arguments[n]) for n in names))

    return wrapper


def _as_input(v):
    """An argument as a stored program takes it: a hull without its name and provenance, numbers as float arrays
    (placed without compiling anything), integer arrays as they are, anything else unchanged (static)."""
    if isinstance(v, Hull):
        return _bare(v)  # name and provenance are not part of the program: one compilation per hull size
    if isinstance(v, bool) or not isinstance(v, int | float | list | np.ndarray | np.generic):
        return v
    if isinstance(v, np.ndarray) and np.issubdtype(v.dtype, np.integer):
        return jax.device_put(v)
    return as_float(v)


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


@functools.partial(cached_program, compiler_options=HYDROSTATICS_PROGRAM)
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


@functools.partial(cached_program, compiler_options=HYDROSTATICS_PROGRAM)
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
            "baseline (the hull's datum; for a mesh, --baseline-z, or --kg-datum for a KG given from the keel line or "
            "the lowest point) and is in metres.",
            stacklevel=2,
        )
    f = lambda v: None if v is None else as_float(v)
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
    return loading_condition(
        c11_hull(), kg=C11_KG, draught=C11_PARTICULARS["draught"], water_density=SEAWATER_DENSITY
    )
