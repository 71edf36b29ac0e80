r"""Hull hydrostatics: GZ(φ) and ΔGM(ζ_mid) from station offsets (Froude–Krylov, quasi-static balance).

The paper (Katsumura et al., arXiv 2407.02728, appendix A) obtains the non-memory relation ΔGM(ζ_mid) by
computing the GM of the hull in a wave of length L with its crest or trough amidships, sinkage and trim
balanced quasi-statically, for several wave amplitudes, and fitting a 6th-order polynomial. This module does
the same from a hull description, exactly for the polygonal hull the offsets define, and differentiably in
JAX.

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
  ζ_mid < 0 a **crest** (CONVENTIONS.md);
- water surface at station x (earth-vertical height above the baseline point on the centreline):
  h(x) = sinkage + trim · (x − L/2)/L + η(x), so `sinkage` is the draught amidships and
  `trim` = d_FP − d_AP [m] is positive by the head (bow down). Trim enters as a small angle (sections stay
  vertical), which is the usual hydrostatic approximation for trims of a few metres over a ship's length.
"""

from __future__ import annotations

import functools
import inspect
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from ._ship import Ship, c11_representative, restoring_fields_from_gz

GRAVITY = 9.80665
"""Standard gravity g [m/s²]."""

SEAWATER_DENSITY = 1025.0
"""Default sea-water density ρ [kg/m³]."""

C11_HULL_NOTE = (
    "C11-like hull (REPRESENTATIVE): a parametric post-Panamax container-ship hull with the paper's Table 1 "
    "proportions (Lpp 262 m, B 40 m, D 24.45 m, d 11.5 m), bow flare and a wide transom stern. It is NOT the "
    "real C11 lines, which are unpublished; its GZ and ΔGM are what such a hull gives, not the C11's."
)

_DEFAULT_ZETA_MAX = 6.0
_DEFAULT_N_ZETA = 13
_DEFAULT_HEEL_MAX = math.radians(70.0)
_DEFAULT_N_HEEL = 15

# Equilibrium tolerances: the balance residuals are in metres (volume error / (L B), LCB − LCG).
_NEWTON = optx.Newton(rtol=1e-10, atol=1e-9)
_MAX_STEPS = 64


# ------------------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------------------


def _concrete(x) -> np.ndarray | None:
    """`x` as a float64 NumPy array, or None when it is a JAX tracer (validation is then skipped)."""
    try:
        return np.asarray(x, dtype=float)
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError, TypeError):
        return None


def _entry_point(fn):
    """`eqx.filter_jit` with Python numbers and lists turned into float arrays first.

    `filter_jit` treats Python scalars as static, so `gz_curve(..., zeta_mid=3.0)` would compile again for
    every new amplitude; as arrays they are traced and one compilation serves all values.
    """
    jitted = eqx.filter_jit(fn)

    def convert(v):
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
# The hull
# ------------------------------------------------------------------------------------------------------------


def _validate_offsets(stations, waterlines, half_breadths, lpp, depth, source: str) -> None:
    """Raise ValueError naming what is wrong with concrete hull offsets and how to fix it."""
    pre = f"{source}: " if source else ""
    if stations.ndim != 1 or stations.size < 2:
        raise ValueError(
            f"{pre}`stations` must be a 1-D list of at least 2 positions x [m]; got shape {stations.shape}."
        )
    if waterlines.ndim != 1 or waterlines.size < 2:
        raise ValueError(
            f"{pre}`waterlines` must be a 1-D list of at least 2 heights z [m]; got shape {waterlines.shape}."
        )
    expected = (stations.size, waterlines.size)
    if half_breadths.shape != expected:
        raise ValueError(
            f"{pre}`half_breadths` must have one row per station and one column per waterline, shape "
            f"{expected}; "
            f"got {half_breadths.shape}."
        )
    for label, arr in (("stations", stations), ("waterlines", waterlines), ("half_breadths", half_breadths)):
        bad = np.argwhere(~np.isfinite(arr))
        if bad.size:
            raise ValueError(
                f"{pre}`{label}` contains a non-finite value ({arr[tuple(bad[0])]}) at index "
                f"{tuple(bad[0].tolist())}; "
                "every offset must be a finite number in metres (write 0.0 where the hull has no breadth)."
            )
    for label, arr in (("lpp", lpp), ("depth", depth)):
        if arr.shape != ():
            raise ValueError(f"{pre}`{label}` must be a scalar [m]; got shape {arr.shape}.")
        if not np.isfinite(arr) or arr <= 0:
            raise ValueError(f"{pre}`{label}` must be a finite length > 0 [m]; got {float(arr)}.")
    for label, arr in (("stations", stations), ("waterlines", waterlines)):
        steps = np.diff(arr)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0)) + 1
            raise ValueError(
                f"{pre}`{label}` must be strictly increasing; got {label}[{i}] = {arr[i]} after "
                f"{label}[{i - 1}] = {arr[i - 1]}. Sort the {label} (and the rows/columns of `half_breadths` "
                "with them) and remove duplicates."
            )
    neg = np.argwhere(half_breadths < 0)
    if neg.size:
        i, j = neg[0]
        raise ValueError(
            f"{pre}half-breadths must be >= 0 [m] (the offsets of the starboard half, measured from the "
            "centre "
            f"plane); got {half_breadths[i, j]} at station {i} (x = {stations[i]} m), waterline {j} "
            f"(z = {waterlines[j]} m)."
        )
    if not np.any(half_breadths > 0):
        raise ValueError(f"{pre}every half-breadth is zero: the hull has no volume. Check the offsets table.")
    if waterlines[-1] > depth:
        raise ValueError(
            f"{pre}the highest waterline z = {waterlines[-1]} m is above the depth D = {float(depth)} m. The "
            "deck "
            "closes the hull at z = D: raise `depth` to the deck at side, or drop the waterlines above the "
            "deck."
        )
    if not stations[0] < lpp / 2 < stations[-1]:
        raise ValueError(
            f"{pre}the stations span x = {stations[0]} .. {stations[-1]} m, which does not contain amidships "
            f"x = Lpp/2 = {float(lpp) / 2} m. Stations are measured from the aft perpendicular (AP), "
            "positive "
            'forward; if yours are measured from amidships, set station_origin = "amidships" in the hull '
            "file (or add Lpp/2 to every station)."
        )


class Hull(eqx.Module):
    """A ship hull described by station offsets (full scale, SI units).

    The section at station `i` is the polygon through the starboard offsets `(half_breadths[i, j],
    waterlines[j])`, continued vertically to the deck at `depth` with the last half-breadth, closed across the
    deck, mirrored to port and closed across the bottom at the lowest waterline. Between offsets the hull is
    linear; along x the section properties are integrated with the trapezoid rule.
    """

    stations: Float[Array, " stations"]
    waterlines: Float[Array, " waterlines"]
    half_breadths: Float[Array, "stations waterlines"]
    lpp: Float[Array, ""]
    depth: Float[Array, ""]
    name: str = eqx.field(static=True, default="unnamed hull")
    provenance: str = eqx.field(static=True, default="")

    def __init__(
        self,
        *,
        stations: ArrayLike,
        waterlines: ArrayLike,
        half_breadths: ArrayLike,
        lpp: ArrayLike,
        depth: ArrayLike,
        name: str = "unnamed hull",
        provenance: str = "",
    ):
        values = [_concrete(v) for v in (stations, waterlines, half_breadths, lpp, depth)]
        if all(v is not None for v in values):
            _validate_offsets(*values, source="")
        self.stations = jnp.asarray(stations, dtype=float)
        self.waterlines = jnp.asarray(waterlines, dtype=float)
        self.half_breadths = jnp.asarray(half_breadths, dtype=float)
        self.lpp = jnp.asarray(lpp, dtype=float)
        self.depth = jnp.asarray(depth, dtype=float)
        self.name = name
        self.provenance = provenance

    @property
    def amidships(self) -> Float[Array, ""]:
        """x of amidships, Lpp/2 [m] from the AP."""
        return self.lpp / 2

    @property
    def max_breadth(self) -> Float[Array, ""]:
        """Largest moulded breadth in the offsets, 2 max(y) [m]."""
        return 2 * jnp.max(self.half_breadths)


Hull.__init__.__doc__ = """**Arguments:**

- `stations`: x of each station [m], measured from the aft perpendicular (AP), positive forward, strictly
    increasing, shape `(stations,)`. Stations may lie aft of the AP (a transom) or forward of the FP (x =
    Lpp).
- `waterlines`: heights z of the offsets above the baseline [m], strictly increasing, shape `(waterlines,)`.
- `half_breadths`: starboard half-breadths y [m] >= 0, shape `(stations, waterlines)`.
- `lpp`: length between perpendiculars L [m] > 0; amidships is at x = L/2.
- `depth`: moulded depth D [m] (deck at side), >= the highest waterline. The hull is closed at z = D.
- `name`, `provenance`: free text carried into outputs.

**Raises:** `ValueError` (for concrete inputs) naming the offending entry: wrong shapes, non-finite values,
non-increasing stations or waterlines, negative half-breadths, a waterline above the deck, or stations that do
not contain amidships.
"""


def scale_hull(
    hull: Hull, *, length: ArrayLike = 1.0, breadth: ArrayLike = 1.0, height: ArrayLike = 1.0
) -> Hull:
    """The hull stretched by factors along x, y and z (differentiable in the factors).

    **Arguments:**

    - `hull`: the hull to scale.
    - `length`: factor on stations and Lpp [-].
    - `breadth`: factor on the half-breadths [-].
    - `height`: factor on waterlines and depth [-].

    **Returns:** a new `Hull` (no re-validation, so the factors may be JAX tracers, e.g. under `jax.grad`).
    """
    return eqx.tree_at(
        lambda h: (h.stations, h.lpp, h.half_breadths, h.waterlines, h.depth),
        hull,
        (
            hull.stations * length,
            hull.lpp * length,
            hull.half_breadths * breadth,
            hull.waterlines * height,
            hull.depth * height,
        ),
    )


# ------------------------------------------------------------------------------------------------------------
# Section integrals (the hot path)
# ------------------------------------------------------------------------------------------------------------


def _section_polygons(
    hull: Hull,
) -> tuple[Float[Array, "stations vertices"], Float[Array, "stations vertices"]]:
    """Vertices (y, z) of each section polygon, counter-clockwise in (y, z): starboard up, deck, port down."""
    y = jnp.concatenate([hull.half_breadths, hull.half_breadths[:, -1:]], axis=1)
    z = jnp.concatenate([hull.waterlines, hull.depth[None]])
    ys = jnp.concatenate([y, -y[:, ::-1]], axis=1)
    zs = jnp.broadcast_to(jnp.concatenate([z, z[::-1]]), ys.shape)
    return ys, zs


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
    - `zeta_mid`: wave amplitude ζ_mid [m]; > 0 puts a trough amidships, < 0 a crest (CONVENTIONS.md).
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


def _integrals(hull: Hull, heel, sinkage, trim, zeta_mid, wavelength) -> _Integrals:
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
    v = _integrals(hull, zero, draught, zero, zero, None).volume
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


@eqx.filter_jit
def _loading_arrays(hull, kg, draught, displacement, lcg, rho, from_draught: bool):
    zero = jnp.zeros(())
    if from_draught:
        vol = _integrals(hull, zero, draught, zero, zero, None).volume
        d = draught
        ok = jnp.array(True)
    else:
        vol = displacement / rho
        d, ok = _even_keel_draught(hull, vol)
    ints = _integrals(hull, zero, d, zero, zero, None)
    lcb = ints.moment_x / ints.volume
    lcg_out = lcb if lcg is None else lcg
    return vol * rho, kg, lcg_out, rho, d, ok


@eqx.filter_jit
def _max_displaced_volume(hull):
    zero = jnp.zeros(())
    return _integrals(hull, zero, hull.depth, zero, zero, None).volume


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
    f = lambda v: None if v is None else jnp.asarray(v, dtype=float)
    if displacement is not None:
        cd, cr = _concrete(displacement), _concrete(water_density)
        if cd is not None and cr is not None:
            max_mass = _max_displaced_volume(hull)
            cm = _concrete(max_mass)
            if cm is not None and cd >= cm * cr:
                raise ValueError(
                    f"displacement {float(cd):.6g} kg is more than the hull can float: with its deck at the "
                    "water "
                    f"it displaces {float(cm * cr):.6g} kg (ρ = {float(cr)} kg/m³). Check the units (kg, not "
                    "tonnes) and the offsets, or give a smaller displacement."
                )
    disp, kg_, lcg_, rho, d, ok = _loading_arrays(
        hull, f(kg), f(draught), f(displacement), f(lcg), f(water_density), draught is not None
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
    hull, loading, heel, zeta_mid, wavelength = args
    ints = _integrals(hull, heel, y[0], y[1], zeta_mid, wavelength)
    scale = hull.lpp * hull.max_breadth
    return jnp.stack(
        [(ints.volume - loading.volume) / scale, (ints.moment_x - loading.lcg * ints.volume) / loading.volume]
    )


def _equilibrium_single(hull, loading, heel, zeta_mid, wavelength, guess):
    sol = optx.root_find(
        _balance_residual,
        _NEWTON,
        guess,
        (hull, loading, heel, zeta_mid, wavelength),
        max_steps=_MAX_STEPS,
        throw=False,
    )
    sinkage, trim = sol.value[0], sol.value[1]
    ints = _integrals(hull, heel, sinkage, trim, zeta_mid, wavelength)
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


def _equilibrium_batch(hull, loading, heel, zeta_mid, wavelength) -> Equilibrium:
    """Balances at 1-D arrays of heels and amplitudes, one vmapped Newton solve (no throwing)."""
    guess = jnp.stack([loading.draught, jnp.zeros_like(loading.draught)])
    fn = lambda p, z: _equilibrium_single(hull, loading, p, z, wavelength, guess)
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


def _gm_at(hull, loading, sinkage, trim, zeta_mid, wavelength):
    """GM [m] = ∂GZ/∂φ at φ = 0 with sinkage and trim held (they are stationary in φ at φ = 0 by symmetry)."""

    def lever(phi):
        ints = _integrals(hull, phi, sinkage, trim, zeta_mid, wavelength)
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


def _particulars(hull, loading, eq: Equilibrium, gm, zeta, wavelength) -> Particulars:
    zero = jnp.zeros(())
    s, t = eq.sinkage, eq.trim
    km = gm + loading.kg

    def vol_mx(y):
        ints = _integrals(hull, zero, y[0], y[1], zeta, wavelength)
        return jnp.stack([ints.volume, ints.moment_x])

    jac = jax.jacfwd(vol_mx)(jnp.stack([s, t]))
    awp = jac[0, 0]
    lcf = jac[1, 0] / awp
    xm, lpp = hull.amidships, hull.lpp
    # ∂∫xA/∂trim = ∫ b x (x − xm) dx / L and ∂∇/∂trim = ∫ b (x − xm) dx / L, b the waterline breadth.
    i_xm = lpp * (jac[1, 1] - xm * jac[0, 1])  # ∫ b (x − xm)² dx
    i_l = i_xm - awp * (lcf - xm) ** 2
    bm_l = i_l / eq.volume

    ys, zs = _section_polygons(hull)
    h = s + t * (hull.stations - xm) / lpp + wave_elevation(hull, zeta, wavelength)
    area, breadth = jax.jvp(
        lambda hh: _immersed_section_moments(ys, zs, zero, hh)[0], (h,), (jnp.ones_like(h),)
    )
    b_wl = jnp.max(breadth)
    a_mid = jnp.interp(xm, hull.stations, area)
    cb = eq.volume / (lpp * b_wl * s)
    cm = a_mid / (b_wl * s)
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


# ------------------------------------------------------------------------------------------------------------
# Polynomial fits
# ------------------------------------------------------------------------------------------------------------


def fit_gz_polynomial(
    heels: Float[ArrayLike, " heels"], gz: Float[ArrayLike, " heels"], gm0: ArrayLike
) -> tuple[Float[Array, " 4"], Float[Array, ""]]:
    r"""Least-squares fit GZ(φ) ≈ GM0 φ + g3 φ³ + g5 φ⁵ + g7 φ⁷ + g9 φ⁹ with GM0 held.

    **Arguments:**

    - `heels`: φ [rad] (at least 4 distinct non-zero values); `gz`: GZ [m] at those heels.
    - `gm0`: the initial slope GM0 [m], held fixed so the fitted curve has the computed GM.

    **Returns:** `(g, rms)`: g = (g3, g5, g7, g9) [m] and the root-mean-square residual [m]. Convert to the
    ship file's a3..a9 with `jaxroll.ship._ship.restoring_fields_from_gz(g, gm0, roll_period)`.
    """
    phi = jnp.asarray(heels, dtype=float)
    gz = jnp.asarray(gz, dtype=float)
    scale = jnp.max(jnp.abs(phi))
    p = phi / scale
    design = jnp.stack([p**3, p**5, p**7, p**9], axis=-1)
    rhs = gz - gm0 * phi
    coef, *_ = jnp.linalg.lstsq(design, rhs)
    g = coef / scale ** jnp.array([3.0, 5.0, 7.0, 9.0])
    rms = jnp.sqrt(jnp.mean((design @ coef - rhs) ** 2))
    return g, rms


def fit_delta_gm_polynomial(
    zeta_mid: Float[ArrayLike, " zeta"], delta_gm: Float[ArrayLike, " zeta"], *, degree: int = 6
) -> tuple[Float[Array, " 7"], Float[Array, ""]]:
    r"""Least-squares fit ΔGM(ζ_mid) ≈ Σ_{k=1}^{degree} C_k ζ_midᵏ with C0 = 0 (ΔGM vanishes in calm water).

    **Arguments:**

    - `zeta_mid`: wave amplitudes at amidships [m] (> 0 trough); at least `degree` distinct non-zero values.
    - `delta_gm`: ΔGM = GM(ζ) − GM(calm) [m] at those amplitudes.
    - `degree`: polynomial degree, 1..6 (the paper uses 6).

    **Returns:** `(C, rms)`: C = (C0, …, C6) [m^(1−k)] padded with zeros, and the RMS residual [m].
    """
    if not 1 <= degree <= 6:
        raise ValueError(f"`degree` must be between 1 and 6 (the ship file holds C0..C6); got {degree}.")
    z = jnp.asarray(zeta_mid, dtype=float)
    dgm = jnp.asarray(delta_gm, dtype=float)
    scale = jnp.max(jnp.abs(z))
    powers = jnp.arange(1, degree + 1, dtype=float)
    design = (z / scale)[:, None] ** powers
    coef, *_ = jnp.linalg.lstsq(design, dgm)
    c = jnp.zeros(7).at[1 : degree + 1].set(coef / scale**powers)
    rms = jnp.sqrt(jnp.mean((design @ coef - dgm) ** 2))
    return c, rms


# ------------------------------------------------------------------------------------------------------------
# The full table: GZ(ζ_mid, φ), GM(ζ_mid), fits
# ------------------------------------------------------------------------------------------------------------


class HydrostaticsSolution(eqx.Module):
    """GZ and GM of a hull in calm water and in waves of length λ, with the roll model's polynomial fits."""

    particulars: Particulars
    zeta_mid: Float[Array, " zeta"]
    heels: Float[Array, " heels"]
    wavelength: Float[Array, ""]
    gz: Float[Array, "zeta heels"]
    sinkage: Float[Array, "zeta heels"]
    trim: Float[Array, "zeta heels"]
    gz_calm: Float[Array, " heels"]
    gm: Float[Array, " zeta"]
    delta_gm: Float[Array, " zeta"]
    gz_coefficients: Float[Array, " 4"]
    gz_fit_rms: Float[Array, ""]
    delta_gm_coefficients: Float[Array, " 7"]
    delta_gm_fit_rms: Float[Array, ""]
    max_volume_error: Float[Array, ""]
    max_lcb_error: Float[Array, ""]
    converged: Bool[Array, "zeta heels"]
    result: optx.RESULTS

    @property
    def gm0(self) -> Float[Array, ""]:
        """Calm-water upright GM [m]."""
        return self.particulars.gm

    @property
    def delta_gz(self) -> Float[Array, "zeta heels"]:
        """GZ(ζ, φ) − GZ(calm, φ) [m]."""
        return self.gz - self.gz_calm[None, :]


HydrostaticsSolution.__init__.__doc__ = """Fields: `particulars` (calm water, [`Particulars`][]); the grids
`zeta_mid` [m] (> 0 trough amidships) and `heels` [rad]; `wavelength` λ [m]; tables `gz`, `sinkage`, `trim`
[m] of shape (zeta, heels) at free trim; `gz_calm` [m]; `gm`, `delta_gm` = GM(ζ) − GM(calm) [m] (upright); the
fits `gz_coefficients` (g3, g5, g7, g9) [m] of the calm GZ with GM0 held and `delta_gm_coefficients` C0..C6
[m^(1−k)], with their RMS residuals [m]; `max_volume_error` (largest |∇/∇0 − 1| over all balances) and
`max_lcb_error` [m]; `converged` and `result`.
"""


def default_zeta_grid(zeta_max: float = _DEFAULT_ZETA_MAX, n: int = _DEFAULT_N_ZETA) -> np.ndarray:
    """Wave amplitudes ζ_mid = linspace(−ζmax, ζmax, n) [m] (crest amidships to trough amidships)."""
    if not (math.isfinite(zeta_max) and zeta_max > 0):
        raise ValueError(f"`zeta_max` must be a finite amplitude > 0 [m]; got {zeta_max}.")
    if n < 7:
        raise ValueError(f"the ΔGM fit has 6 coefficients: give at least 7 amplitudes; got n_zeta = {n}.")
    return np.linspace(-zeta_max, zeta_max, n)


def default_heel_grid(heel_max: float = _DEFAULT_HEEL_MAX, n: int = _DEFAULT_N_HEEL) -> np.ndarray:
    """Heels φ = linspace(0, φmax, n) [rad] for the GZ table and fit."""
    if not (math.isfinite(heel_max) and 0 < heel_max <= math.pi / 2):
        raise ValueError(f"`heel_max` must be in (0, π/2] rad (0–90°); got {heel_max} rad.")
    if n < 5:
        raise ValueError(f"the GZ fit has 4 free coefficients: give at least 5 heels; got n_heel = {n}.")
    return np.linspace(0.0, heel_max, n)


@eqx.filter_jit
def _hydrostatics_core(hull, loading, zeta, heels, wavelength, throw):
    lam = hull.lpp if wavelength is None else jnp.asarray(wavelength, dtype=float)
    nz, nh = zeta.shape[0], heels.shape[0]
    zz, pp = jnp.meshgrid(zeta, heels, indexing="ij")
    # One batch of balances: the table, the calm GZ curve, the upright wave conditions, and calm upright.
    all_heel = jnp.concatenate([pp.ravel(), heels, jnp.zeros(nz + 1)])
    all_zeta = jnp.concatenate([zz.ravel(), jnp.zeros(nh), zeta, jnp.zeros(1)])
    eqs = _equilibrium_batch(hull, loading, all_heel, all_zeta, lam)
    pick = lambda lo, hi: jax.tree_util.tree_map(lambda a: a[lo:hi], eqs)
    table = jax.tree_util.tree_map(lambda a: a.reshape(nz, nh), pick(0, nz * nh))
    calm = pick(nz * nh, nz * nh + nh)
    upright = pick(nz * nh + nh, nz * nh + nh + nz + 1)
    gms = jax.vmap(lambda s, t, z: _gm_at(hull, loading, s, t, z, lam))(
        upright.sinkage, upright.trim, upright.zeta_mid
    )
    gm, gm0 = gms[:nz], gms[nz]
    calm_upright = jax.tree_util.tree_map(lambda a: a[nz], upright)
    particulars = _particulars(hull, loading, calm_upright, gm0, jnp.zeros(()), lam)
    delta_gm = gm - gm0
    g, g_rms = fit_gz_polynomial(heels, calm.gz, gm0)
    c, c_rms = fit_delta_gm_polynomial(zeta, delta_gm)
    converged = table.converged & calm.converged[None, :] & jnp.all(upright.converged)
    result = optx.RESULTS.where(
        jnp.all(converged), optx.RESULTS.successful, optx.RESULTS.nonlinear_divergence
    )
    result = _check_result(result, throw, "at least one (ζ_mid, φ) of the table")
    vol_err = jnp.max(jnp.abs(eqs.volume / loading.volume - 1))
    lcb_err = jnp.max(jnp.abs(eqs.lcb - loading.lcg))
    return HydrostaticsSolution(
        particulars=particulars,
        zeta_mid=zeta,
        heels=heels,
        wavelength=lam,
        gz=table.gz,
        sinkage=table.sinkage,
        trim=table.trim,
        gz_calm=calm.gz,
        gm=gm,
        delta_gm=delta_gm,
        gz_coefficients=g,
        gz_fit_rms=g_rms,
        delta_gm_coefficients=c,
        delta_gm_fit_rms=c_rms,
        max_volume_error=vol_err,
        max_lcb_error=lcb_err,
        converged=converged,
        result=result,
    )


def hull_hydrostatics(
    hull: Hull,
    loading: Loading,
    *,
    zeta_mid: ArrayLike | None = None,
    heels: ArrayLike | None = None,
    wavelength: ArrayLike | None = None,
    throw: bool = True,
) -> HydrostaticsSolution:
    r"""GZ(ζ_mid, φ), GM(ζ_mid) and ΔGM(ζ_mid) of a hull, with the polynomial fits of the roll model.

    For each wave amplitude ζ_mid (a wave of length λ with its trough, ζ_mid > 0, or crest, ζ_mid < 0,
    amidships) and heel φ, sinkage and trim are balanced quasi-statically (Froude–Krylov: hydrostatic pressure
    under the wave profile) and the righting lever GZ is computed; GM(ζ_mid) is the upright slope. The calm GZ
    is fitted by GM0 φ + g3 φ³ + … + g9 φ⁹ and ΔGM by C1 ζ + … + C6 ζ⁶ (Katsumura et al., appendix A).

    **Arguments:**

    - `hull`, `loading`: the hull and its loading condition ([`loading_condition`][]).
    - `zeta_mid`: amplitudes [m]; default 13 values in [−6, 6] m.
    - `heels`: heels [rad] for the GZ table and fit; default 15 values in [0, 70°].
    - `wavelength`: λ [m]; default Lpp (the paper's condition).
    - `throw`: raise `EquinoxRuntimeError` if any balance fails; otherwise see `converged`/`result`.

    **Returns:** a [`HydrostaticsSolution`][].
    """
    zeta = jnp.asarray(default_zeta_grid() if zeta_mid is None else zeta_mid, dtype=float)
    phi = jnp.asarray(default_heel_grid() if heels is None else heels, dtype=float)
    if zeta.ndim != 1 or phi.ndim != 1:
        raise ValueError(
            f"`zeta_mid` and `heels` must be 1-D grids; got shapes {zeta.shape} and {phi.shape}."
        )
    cz = _concrete(zeta)
    if cz is not None and np.count_nonzero(np.unique(cz)) < 6:
        raise ValueError(
            "the ΔGM fit has 6 coefficients: give at least 6 distinct non-zero amplitudes; got zeta_mid = "
            f"{cz}."
        )
    cp = _concrete(phi)
    if cp is not None and np.count_nonzero(np.unique(cp)) < 4:
        raise ValueError(
            f"the GZ fit has 4 free coefficients: give at least 4 distinct non-zero heels; got {cp}."
        )
    if cp is not None and not np.all(np.abs(cp) <= math.pi / 2):
        raise ValueError(
            f"`heels` must be in radians within [−π/2, π/2]; got max |φ| = {np.max(np.abs(cp))}."
        )
    lam = None if wavelength is None else jnp.asarray(wavelength, dtype=float)
    return _hydrostatics_core(hull, loading, zeta, phi, lam, throw)


# ------------------------------------------------------------------------------------------------------------
# From hydrostatics to a Ship
# ------------------------------------------------------------------------------------------------------------


def roll_period_from_gyradius(
    gm: ArrayLike, gyradius: ArrayLike, *, added_inertia: ArrayLike = 0.0, gravity: float = GRAVITY
) -> Float[Array, ""]:
    r"""Natural roll period Tφ = 2π k √(1 + a) / √(g GM) [s].

    **Arguments:**

    - `gm`: GM [m] > 0. `gyradius`: dry roll radius of gyration k_xx [m] (often 0.35–0.40 B).
    - `added_inertia`: added roll inertia as a fraction a of the dry inertia [-] (often 0.1–0.25).
    """
    gm = jnp.asarray(gm, dtype=float)
    return (
        2
        * jnp.pi
        * jnp.asarray(gyradius, dtype=float)
        * jnp.sqrt(1 + jnp.asarray(added_inertia))
        / jnp.sqrt(gravity * gm)
    )


def ship_from_hydrostatics(
    solution: HydrostaticsSolution,
    hull: Hull,
    *,
    roll_period: float | None = None,
    roll_gyradius: float | None = None,
    added_inertia: float = 0.0,
    damping: ArrayLike | None = None,
    gm_correction: float = 1.0,
    name: str | None = None,
    provenance: str | None = None,
) -> Ship:
    """A roll-model `Ship` whose restoring (a3..a9) and ΔGM (C0..C6) come from hull hydrostatics.

    **Arguments:**

    - `solution`: from [`hull_hydrostatics`][]; `hull`: the same hull (for Lpp, breadth, depth).
    - `roll_period`: natural roll period Tφ [s] (not a hydrostatic quantity); or
    - `roll_gyradius`: k_xx [m], with `added_inertia` a [-], giving Tφ by [`roll_period_from_gyradius`][].
    - `damping`: (b1 [1/s], b2 [1/rad], b3 [s/rad²]); default: the default ship's values.
    - `gm_correction`: σ_obs/σ_thr (1: uncorrected). `name`, `provenance`: carried into the ship file.

    **Returns:** a `Ship` (validated) that `ship_to_toml` writes and `jaxroll pdf --ship FILE` reads.
    """
    if (roll_period is None) == (roll_gyradius is None):
        raise ValueError(
            "The roll period is not hydrostatic: give exactly one of `roll_period` [s] and `roll_gyradius` "
            "[m] "
            f"(with `added_inertia`); got roll_period={roll_period!r}, roll_gyradius={roll_gyradius!r}."
        )
    p = solution.particulars
    gm0 = float(p.gm)
    if not gm0 > 0:
        raise ValueError(
            f"the calm-water GM is {gm0:.4g} m: the ship is not initially stable, so it has no roll period. "
            "Lower KG."
        )
    if roll_period is None:
        roll_period = float(roll_period_from_gyradius(gm0, roll_gyradius, added_inertia=added_inertia))
    if not (math.isfinite(roll_period) and roll_period > 0):
        raise ValueError(f"`roll_period` must be a finite period > 0 [s]; got {roll_period}.")
    if damping is None:
        damping = np.asarray(c11_representative().damping)
    restoring = restoring_fields_from_gz(np.asarray(solution.gz_coefficients), gm0, roll_period)
    ship = Ship(
        lpp=float(hull.lpp),
        breadth=float(p.waterline_breadth),
        depth=float(hull.depth),
        draught=float(p.draught),
        displacement=float(p.displacement),
        block_coefficient=float(p.block_coefficient),
        gm0=gm0,
        roll_period=roll_period,
        restoring=restoring,
        damping=np.asarray(damping, dtype=float),
        delta_gm=np.asarray(solution.delta_gm_coefficients),
        gm_correction=gm_correction,
        name=name if name is not None else f"{hull.name}, hull-derived",
        provenance=provenance
        if provenance is not None
        else (
            f"jaxroll hydrostatics of hull {hull.name!r} (KG {float(p.kg):.4f} m, Δ "
            f"{float(p.displacement):.6g} kg, "
            f"λ = {float(solution.wavelength):.4g} m, ζ_mid in [{float(solution.zeta_mid.min()):.3g}, "
            f"{float(solution.zeta_mid.max()):.3g}] m); roll period and damping are inputs, not hydrostatics."
            + (f" {hull.provenance}" if hull.provenance else "")
        ),
    )
    from ._ship import validate_ship

    validate_ship(ship)
    return ship


def ship_from_hull(
    hull: Hull,
    loading: Loading,
    *,
    roll_period: float | None = None,
    roll_gyradius: float | None = None,
    added_inertia: float = 0.0,
    damping: ArrayLike | None = None,
    zeta_mid: ArrayLike | None = None,
    heels: ArrayLike | None = None,
    wavelength: ArrayLike | None = None,
    name: str | None = None,
) -> Ship:
    """[`hull_hydrostatics`][] followed by [`ship_from_hydrostatics`][]: a `Ship` from hull offsets.

    Arguments as for those two functions.
    """
    sol = hull_hydrostatics(hull, loading, zeta_mid=zeta_mid, heels=heels, wavelength=wavelength)
    return ship_from_hydrostatics(
        sol,
        hull,
        roll_period=roll_period,
        roll_gyradius=roll_gyradius,
        added_inertia=added_inertia,
        damping=damping,
        name=name,
    )


# ------------------------------------------------------------------------------------------------------------
# Hull files (TOML)
# ------------------------------------------------------------------------------------------------------------

_HULL_KEYS = {"lpp_m", "depth_m", "stations_m", "waterlines_m", "half_breadths_m", "station_origin"}
_LOADING_KEYS = {"kg_m", "draught_m", "displacement_kg", "lcg_m", "water_density_kg_m3"}


def _number_list(value, label: str, source: str) -> np.ndarray:
    if not isinstance(value, list) or not value:
        raise ValueError(f"{source}: [hull] {label} must be a non-empty list of numbers [m]; got {value!r}.")
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [hull] {label}[{i}] must be a number [m]; got {v!r}.")
    return np.asarray(value, dtype=float)


def hull_from_dict(data: Mapping[str, Any], *, source: str = "<dict>") -> tuple[Hull, dict[str, float]]:
    """Build a `Hull` (and the optional `[loading]` table) from the dictionary of a hull file.

    **Returns:** `(hull, loading)` where `loading` holds the `[loading]` keys present (`kg_m`, `draught_m` or
    `displacement_kg`, `lcg_m`, `water_density_kg_m3`), checked to be numbers.

    **Raises:** `ValueError` naming the missing/unknown/malformed field and how to fix it. The format is in
    `docs/hydrostatics.md`.
    """
    if not isinstance(data, Mapping):
        raise ValueError(f"{source}: a hull file must be a TOML table; got {type(data).__name__}.")
    unknown = sorted(set(data) - {"name", "provenance", "hull", "loading"})
    if unknown:
        raise ValueError(
            f"{source}: unknown top-level field(s) {unknown}; allowed: name, provenance, [hull], [loading]. "
            "See docs/hydrostatics.md."
        )
    table = data.get("hull")
    if not isinstance(table, Mapping):
        raise ValueError(
            f"{source}: missing [hull] table (lpp_m, depth_m, stations_m, waterlines_m, half_breadths_m)."
        )
    extra = sorted(set(table) - _HULL_KEYS)
    if extra:
        raise ValueError(f"{source}: unknown field(s) {extra} in [hull]; allowed: {sorted(_HULL_KEYS)}.")
    missing = sorted(_HULL_KEYS - {"station_origin"} - set(table))
    if missing:
        raise ValueError(f"{source}: missing field(s) {missing} in [hull]. See docs/hydrostatics.md.")
    for key in ("lpp_m", "depth_m"):
        v = table[key]
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [hull] {key} must be a number [m]; got {v!r}.")
    stations = _number_list(table["stations_m"], "stations_m", source)
    waterlines = _number_list(table["waterlines_m"], "waterlines_m", source)
    rows = table["half_breadths_m"]
    if not isinstance(rows, list) or not all(isinstance(r, list) for r in rows):
        raise ValueError(
            f"{source}: [hull] half_breadths_m must be a list of rows (one per station), each a list of "
            "half-breadths [m] (one per waterline)."
        )
    if len(rows) != stations.size:
        raise ValueError(
            f"{source}: [hull] half_breadths_m has {len(rows)} rows but there are {stations.size} stations; "
            "give one row per station."
        )
    for i, row in enumerate(rows):
        if len(row) != waterlines.size:
            raise ValueError(
                f"{source}: [hull] half_breadths_m is ragged: row {i} (station x = {stations[i]} m) has "
                f"{len(row)} "
                f"values but there are {waterlines.size} waterlines; give one half-breadth per waterline "
                "(0.0 where the hull has no breadth)."
            )
        _number_list(row, f"half_breadths_m[{i}]", source)
    half_breadths = np.asarray(rows, dtype=float)
    lpp = float(table["lpp_m"])
    origin = table.get("station_origin", "ap")
    if origin not in ("ap", "amidships"):
        raise ValueError(
            f'{source}: [hull] station_origin must be "ap" (x from the aft perpendicular, the default) or '
            f'"amidships"; got {origin!r}.'
        )
    if origin == "amidships":
        stations = stations + lpp / 2
    _validate_offsets(
        stations, waterlines, half_breadths, np.asarray(lpp), np.asarray(float(table["depth_m"])), source
    )
    hull = Hull(
        stations=stations,
        waterlines=waterlines,
        half_breadths=half_breadths,
        lpp=lpp,
        depth=float(table["depth_m"]),
        name=str(data.get("name", Path(source).stem)),
        provenance=str(data.get("provenance", f"hull file {source}")),
    )
    loading = data.get("loading", {})
    if not isinstance(loading, Mapping):
        raise ValueError(f"{source}: [loading] must be a table; got {type(loading).__name__}.")
    extra = sorted(set(loading) - _LOADING_KEYS)
    if extra:
        raise ValueError(
            f"{source}: unknown field(s) {extra} in [loading]; allowed: {sorted(_LOADING_KEYS)}."
        )
    for key, v in loading.items():
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [loading] {key} must be a number (SI units); got {v!r}.")
    if "draught_m" in loading and "displacement_kg" in loading:
        raise ValueError(f"{source}: [loading] gives both draught_m and displacement_kg; keep one.")
    return hull, {k: float(v) for k, v in loading.items()}


def read_hull_file(path: str | Path) -> tuple[Hull, dict[str, float]]:
    """Read a hull file (TOML, format in `docs/hydrostatics.md`): the hull and its `[loading]` table."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"Hull file {str(path)!r} does not exist.")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML ({e}).") from None
    return hull_from_dict(data, source=str(path))


def load_hull(path: str | Path) -> Hull:
    """Read the `Hull` of a hull file (TOML, full scale, SI; format in `docs/hydrostatics.md`)."""
    return read_hull_file(path)[0]


def loading_from_dict(hull: Hull, loading: Mapping[str, float], **overrides) -> Loading:
    """A [`Loading`][] from a hull file's `[loading]` keys, with keyword overrides (`kg`, `draught`, ...).

    Overrides given as not-None replace the file's values; a `draught` override drops the file's displacement
    and vice versa.
    """
    keys = dict(
        kg="kg_m",
        draught="draught_m",
        displacement="displacement_kg",
        lcg="lcg_m",
        water_density="water_density_kg_m3",
    )
    values = {arg: loading[key] for arg, key in keys.items() if key in loading}
    overrides = {k: v for k, v in overrides.items() if v is not None}
    if "draught" in overrides:
        values.pop("displacement", None)
    if "displacement" in overrides:
        values.pop("draught", None)
    values.update(overrides)
    if "kg" not in values:
        raise ValueError("KG is required: give `kg` [m] (CLI: --kg) or set [loading] kg_m in the hull file.")
    if "draught" not in values and "displacement" not in values:
        values["draught"] = None  # loading_condition names the problem
    return loading_condition(hull, **values)


def _fmt(v: float, digits: int) -> str:
    r = round(float(v), digits)
    return repr(r + 0.0)  # + 0.0 turns -0.0 into 0.0


def hull_to_toml(
    hull: Hull, loading: Mapping[str, float] | None = None, *, header: str = "", digits: int = 4
) -> str:
    """The hull file text (TOML) of `hull`: one offsets row per line, with an optional `[loading]` table.

    **Arguments:**

    - `hull`: the hull. `loading`: `[loading]` keys (`kg_m`, `draught_m` or `displacement_kg`, `lcg_m`,
        `water_density_kg_m3`) to store with it, or None.
    - `header`: comment lines put at the top of the file.
    - `digits`: decimals of a metre kept in the offsets (4: 0.1 mm).
    """
    import tomli_w

    lines = [f"# {line}".rstrip() for line in header.splitlines()] if header else []
    lines.append("# jaxroll hull file: full scale, SI units. Format: docs/hydrostatics.md")
    meta = {"name": hull.name, **({"provenance": hull.provenance} if hull.provenance else {})}
    lines.append(tomli_w.dumps(meta).rstrip())
    f = lambda v: _fmt(v, digits)
    stations, waterlines = np.asarray(hull.stations), np.asarray(hull.waterlines)

    def wrapped(values, per_line=10):
        chunks = [", ".join(f(v) for v in values[i : i + per_line]) for i in range(0, len(values), per_line)]
        return "[\n" + "".join(f"    {c},\n" for c in chunks) + "]"

    lines += [
        "",
        "[hull]",
        f"lpp_m = {f(hull.lpp)}",
        f"depth_m = {f(hull.depth)}",
        'station_origin = "ap"  # stations are x [m] from the aft perpendicular, positive forward',
        f"stations_m = {wrapped(stations)}",
        f"waterlines_m = {wrapped(waterlines)}  # z [m] above the baseline",
        "# half-breadths y [m]: one row per station, one column per waterline",
        "half_breadths_m = [",
    ]
    for x, row in zip(stations, np.asarray(hull.half_breadths)):
        lines.append(f"    [{', '.join(f(v) for v in row)}],  # x = {f(x)} m")
    lines.append("]")
    if loading:
        lines += ["", "[loading]", tomli_w.dumps({k: float(v) for k, v in loading.items()}).rstrip()]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------------------------
# Analytic test hulls and the representative C11-like hull
# ------------------------------------------------------------------------------------------------------------


def box_hull(
    length: float,
    breadth: float,
    depth: float,
    *,
    n_stations: int = 11,
    n_waterlines: int = 3,
    name: str = "box",
) -> Hull:
    """A rectangular barge L × B × D (stations from 0 to L, so Lpp = L).

    **Arguments:** `length` L, `breadth` B, `depth` D [m]; `n_stations`, `n_waterlines` (>= 2) offsets.
    """
    return Hull(
        stations=np.linspace(0.0, length, n_stations),
        waterlines=np.linspace(0.0, depth, n_waterlines),
        half_breadths=np.full((n_stations, n_waterlines), breadth / 2),
        lpp=length,
        depth=depth,
        name=name,
        provenance=f"box barge {length} x {breadth} x {depth} m",
    )


def wigley_hull(
    length: float,
    breadth: float,
    draught: float,
    depth: float,
    *,
    n_stations: int = 21,
    n_waterlines: int = 11,
    name: str = "Wigley",
) -> Hull:
    r"""The Wigley hull y = (B/2)(1 − (2x'/L)²)(1 − (z'/T)²), x' from amidships, z' depth below the design
    waterline, continued wall-sided from the design waterline z = T up to the deck z = D.

    Closed forms at the design draught T: ∇ = (4/9) L B T, KB = 5T/8, BM = (3/35) B²/T.

    **Arguments:** `length` L, `breadth` B, `draught` T, `depth` D > T [m]; `n_stations` (uniform over [0,
    L]), `n_waterlines` (uniform over [0, T]; the deck is added at D).
    """
    x = np.linspace(0.0, length, n_stations)
    z = np.linspace(0.0, draught, n_waterlines)
    xi = 2 * (x - length / 2) / length
    zz = (draught - z) / draught
    y = breadth / 2 * (1 - xi[:, None] ** 2) * (1 - zz[None, :] ** 2)
    return Hull(
        stations=x,
        waterlines=z,
        half_breadths=np.clip(y, 0.0, None),
        lpp=length,
        depth=depth,
        name=name,
        provenance=f"Wigley hull L={length}, B={breadth}, T={draught}, D={depth} m",
    )


# Parameters of the representative C11-like hull (see `c11_like_offsets`).
C11_PARTICULARS = dict(lpp=262.0, breadth=40.0, depth=24.45, draught=11.5)


def _c11_half_breadth(xi: np.ndarray, z: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """Half-breadth y(ξ, z) [m] of the C11-like hull; ξ = x/Lpp from the AP, z [m] above the baseline."""
    b2, d, depth = p["breadth"] / 2, p["draught"], p["depth"]
    xi = xi[:, None]
    z = z[None, :]
    tz = np.clip(z / d, 0.0, None)
    above = np.clip((z - d) / (depth - d), 0.0, 1.0)  # 0 at the design waterline, 1 at the deck
    # Midship section: flat bottom, round bilge of radius R, vertical side.
    r = p["bilge_radius"]
    bilge = np.where(z < r, b2 - r + np.sqrt(np.clip(r**2 - (r - z) ** 2, 0.0, None)), b2)
    # Forebody waterlines: y/b2 = 1 − ((ξ − ξf)/(ξstem − ξf))^pf, fuller (flared) higher up; raked stem.
    xi_f = p["xi_fwd"]
    stem = 1.0 + p["stem_rake"] * above
    rise = np.clip(tz, 0.0, 1.0) ** p["section_power"]
    pf = p["pf_keel"] + (p["pf_wl"] - p["pf_keel"]) * rise + (p["pf_deck"] - p["pf_wl"]) * above
    sf = np.clip((xi - xi_f) / (stem - xi_f), 0.0, 1.0)
    fwd = 1.0 - sf**pf
    # Afterbody waterlines end at the transom (ξ = ξT) above its lower edge zT with breadth ratio τ(z); below
    # zT they close further forward (the run), at ξe(z).
    xi_a, xi_t, z_t = p["xi_aft"], p["xi_transom"], p["z_transom"]
    s_t = np.clip((z - z_t) / (depth - z_t), 0.0, 1.0)
    tau = p["transom_ratio"] * np.sqrt(s_t)
    low = np.clip(z / z_t, 0.0, 1.0)
    xi_end = np.where(z >= z_t, xi_t, p["xi_run_keel"] + (xi_t - p["xi_run_keel"]) * low ** p["run_shape"])
    pa = p["pa_keel"] + (p["pa_wl"] - p["pa_keel"]) * rise + (p["pa_deck"] - p["pa_wl"]) * above
    sa = np.clip((xi_a - xi) / (xi_a - xi_end), 0.0, None)
    aft = np.where(sa <= 1.0, tau + (1 - tau) * (1 - np.clip(sa, 0.0, 1.0) ** pa), 0.0)
    shape = np.where(xi > xi_f, fwd, np.where(xi < xi_a, aft, 1.0))
    shape = np.where(xi > stem, 0.0, shape)
    return np.clip(np.minimum(bilge, b2 * shape), 0.0, None)


C11_SHAPE = dict(
    bilge_radius=5.0,
    xi_fwd=0.50,
    stem_rake=0.03,
    pf_keel=0.4,
    pf_wl=1.8,
    pf_deck=6.0,
    xi_aft=0.38,
    xi_transom=-0.02,
    z_transom=12.0,
    transom_ratio=0.9,
    xi_run_keel=0.12,
    run_shape=1.5,
    pa_keel=0.6,
    pa_wl=2.3,
    pa_deck=3.5,
    section_power=1.0,
)
"""Shape parameters of the representative C11-like hull (see `c11_like_offsets`)."""


def c11_like_offsets(**shape: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Station offsets of the representative C11-like hull (the formula behind `jaxroll/data/c11_hull.toml`).

    With ξ = x/Lpp from the AP and z above the baseline, the half-breadth is
    y(ξ, z) = min(y_mid(z), (B/2) S(ξ, z)), where

    - y_mid is the midship section: flat bottom, round bilge of radius R, vertical sides;
    - forward of ξ_f, S = 1 − ((ξ − ξ_f)/(ξ_stem(z) − ξ_f))^{p_f(z)}, with p_f rising from the keel to the
      waterline and again to the deck (bow flare) and a stem raked forward above the waterline;
    - aft of ξ_a, S = τ(z) + (1 − τ(z))(1 − ((ξ_a − ξ)/(ξ_a − ξ_e(z)))^{p_a(z)}): above the transom's lower
        edge z_T
      the waterlines end at the transom ξ_T < 0 with breadth ratio τ(z) = τ_max √((z − z_T)/(D − z_T)) (a wide
      transom), below it they close at ξ_e(z), moving aft from ξ_run at the keel.

    The parameters (`C11_SHAPE`, overridable by keyword) were tuned so that at d = 11.5 m, ρ = 1025 kg/m³ the
    hull displaces about 6.82e7 kg (Table 1: 6.7247e7) with C_B ≈ 0.55 (Table 1: 0.56), which are not
    consistent with each other at ρ = 1025 kg/m³ (see docs/hydrostatics.md); both are met within 2 %.

    **Returns:** `(stations, waterlines, half_breadths)` [m].
    """
    p = {**C11_PARTICULARS, **C11_SHAPE, **shape}
    lpp, d, depth = p["lpp"], p["draught"], p["depth"]
    xi = np.concatenate(
        [[p["xi_transom"], -0.01], np.linspace(0.0, 1.0, 41), [1.01, 1.02, p["stem_rake"] + 1.0]]
    )
    z = np.concatenate([[0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 2.5], np.arange(3.0, 24.0, 1.0), [d], [24.0, depth]])
    z = np.unique(z)
    y = _c11_half_breadth(xi, z, p)
    return xi * lpp, z, y


def c11_like_hull(**shape: float) -> Hull:
    """The representative C11-like hull straight from the formula of [`c11_like_offsets`][] (not rounded)."""
    x, z, y = c11_like_offsets(**shape)
    return Hull(
        stations=x,
        waterlines=z,
        half_breadths=y,
        lpp=C11_PARTICULARS["lpp"],
        depth=C11_PARTICULARS["depth"],
        name="C11-like hull (representative)",
        provenance=C11_HULL_NOTE,
    )


C11_GM0 = 1.9299
"""GM0 [m] of the default ship (Table 1); the shipped hull's KG is chosen to give it at d = 11.5 m."""


def write_c11_hull_file(path: str | Path | None = None) -> Path:
    """(Re)generate `jaxroll/data/c11_hull.toml` from [`c11_like_offsets`][], with KG giving GM0 = 1.9299 m.

    **Returns:** the path written.
    """
    path = _c11_hull_path() if path is None else Path(path)
    draft = c11_like_hull()
    # Round-trip through the file format first, so that KG is computed for the offsets actually stored.
    text = hull_to_toml(draft)
    hull, _ = hull_from_dict(tomllib.loads(text), source=str(path))
    kg = round(float(kg_for_gm(hull, C11_GM0, draught=C11_PARTICULARS["draught"])), 4)
    loading = {"draught_m": C11_PARTICULARS["draught"], "kg_m": kg, "water_density_kg_m3": SEAWATER_DENSITY}
    header = (
        "REPRESENTATIVE C11-like hull, NOT the real C11 lines (which are unpublished).\n"
        "Generated by jaxroll.ship._hydrostatics.write_c11_hull_file() from the parametric formula of\n"
        "jaxroll.ship._hydrostatics.c11_like_offsets (see docs/hydrostatics.md): Lpp 262 m, B 40 m, D 24.45 m,\n"
        "d 11.5 m (paper's Table 1), flat bottom with 5 m bilge radius, flared bow with raked stem, wide "
        "transom\n"
        "aft of the AP. At d = 11.5 m, rho = 1025 kg/m3: displacement ~6.82e7 kg, Cb ~0.552 (Table 1: "
        "6.7247e7 kg,\n"
        "0.56, which are mutually consistent only at rho = 1000). KG below gives GM0 = 1.9299 m."
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(hull_to_toml(hull, loading, header=header))
    return path


def c11_hull() -> Hull:
    """The C11-like hull shipped as `jaxroll/data/c11_hull.toml` (REPRESENTATIVE, not the real C11 lines)."""
    return load_hull(_c11_hull_path())


def _c11_hull_path() -> Path:
    return Path(__file__).parent / "data" / "c11_hull.toml"


def c11_hull_loading() -> Loading:
    """Loading of the shipped C11-like hull (its file's [loading]): d = 11.5 m, KG giving GM0 ≈ 1.93 m."""
    hull, loading = read_hull_file(_c11_hull_path())
    return loading_from_dict(hull, loading)


def c11_hull_ship(*, roll_period: float = 24.4, zeta_mid: ArrayLike | None = None) -> Ship:
    """A default ship whose GZ and ΔGM come from the shipped C11-like hull (REPRESENTATIVE), Tφ = 24.4 s.

    Particulars are the hull's (d = 11.5 m, GM0 ≈ 1.93 m); damping and σ_obs/σ_thr are the default ship's.
    """
    hull = c11_hull()
    return ship_from_hull(
        hull,
        c11_hull_loading(),
        roll_period=roll_period,
        zeta_mid=zeta_mid,
        name="C11-like hull (representative, hull-derived)",
    )
