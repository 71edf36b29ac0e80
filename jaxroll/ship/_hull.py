r"""The hull: station offsets, section polygons, analytic test hulls and the representative C11-like hull.

A [`Hull`][] is a table of offsets (full scale, SI): each station's section is the polygon of its starboard
half-breadths, mirrored to port and closed by the deck at `depth`. This module holds the hull type and its
geometry; the hydrostatics of a hull (immersed sections, balance, GZ, GM) are in `jaxroll.ship._hydrostatics`,
the hull file format (TOML) in `jaxroll.io._hull_file` (the model reads no file).

**Frames** (see `docs/hydrostatics.md`): x [m] forward from the aft perpendicular (AP), y [m] to starboard,
z [m] up from the baseline.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._compiled import as_float
from ._surface import HullSurface, scale_surface, translate_surface

C11_HULL_NOTE = (
    "C11-like hull (REPRESENTATIVE): a parametric post-Panamax container-ship hull with the paper's Table 1 "
    "proportions (Lpp 262 m, B 40 m, D 24.45 m, d 11.5 m), bow flare and a wide transom stern. It is NOT the "
    "real C11 lines, which are unpublished; its GZ and ΔGM are what such a hull gives, not the C11's."
)


# ------------------------------------------------------------------------------------------------------------
# Small helpers
# ------------------------------------------------------------------------------------------------------------


def _concrete(x) -> np.ndarray | None:
    """`x` as a float64 NumPy array, or None when it is a JAX tracer (validation is then skipped)."""
    try:
        return np.asarray(x, dtype=float)
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError, TypeError):
        return None


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


@dataclasses.dataclass(frozen=True)
class Datum:
    """The vertical datum of a hull read from a file: z = 0 of jaxroll's frame (the baseline, from which draughts
    and KG are measured) in the file's z [m, full scale], how it was chosen, and the candidates."""

    baseline_file_z: float
    source: str
    lowest_point_file_z: float
    keel_line_file_z: float | None = None

    def as_dict(self) -> dict:
        """Plain values for JSON, lengths in metres (`*_m`)."""
        return dict(
            baseline_file_z_m=self.baseline_file_z,
            source=self.source,
            lowest_point_file_z_m=self.lowest_point_file_z,
            keel_line_file_z_m=self.keel_line_file_z,
        )

    def file_z(self, reference: str | float) -> float:
        """File z [m, full scale] of a reference for heights: `"baseline"`, `"keel"` (the keel line), `"lowest"` (the
        hull's lowest point), or a file z [m] itself.

        **Raises:** `ValueError` for another name, a z that is not finite, or `"keel"` where no keel line is known."""
        if isinstance(reference, str):
            named = dict(
                baseline=self.baseline_file_z, keel=self.keel_line_file_z, lowest=self.lowest_point_file_z
            )
            if reference not in named:
                raise ValueError(
                    f"a height reference is baseline, keel, lowest or a file z [m]; got {reference!r}."
                )
            if named[reference] is None:
                raise ValueError(
                    "this hull has no keel line (its file gives none): give the reference's file z [m]."
                )
            return float(named[reference])
        if not math.isfinite(reference):
            raise ValueError(f"a height reference's file z must be a finite number [m]; got {reference}.")
        return float(reference)

    def above_baseline(self, height: float, reference: str | float) -> float:
        """A height [m] measured from `reference` (see `file_z`: a draught from the keel line, a KG from the lowest
        point, …) as jaxroll measures every height: above the baseline."""
        return float(height) + self.file_z(reference) - self.baseline_file_z


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
    surface: HullSurface | None = None
    name: str = eqx.field(static=True, default="unnamed hull")
    provenance: str = eqx.field(static=True, default="")
    datum: Datum | None = eqx.field(static=True, default=None)

    def __init__(
        self,
        *,
        stations: ArrayLike,
        waterlines: ArrayLike,
        half_breadths: ArrayLike,
        lpp: ArrayLike,
        depth: ArrayLike,
        surface: HullSurface | None = None,
        name: str = "unnamed hull",
        provenance: str = "",
        datum: Datum | None = None,
    ):
        values = [_concrete(v) for v in (stations, waterlines, half_breadths, lpp, depth)]
        if all(v is not None for v in values):
            _validate_offsets(*values, source="")
        self.stations = as_float(stations)
        self.waterlines = as_float(waterlines)
        self.half_breadths = as_float(half_breadths)
        self.lpp = as_float(lpp)
        self.depth = as_float(depth)
        self.surface = surface
        self.name = name
        self.provenance = provenance
        self.datum = datum

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
- `surface`: the closed triangulated surface the offsets were sliced from ([`jaxroll.ship.HullSurface`][], from a
    mesh file), or None. When given, every immersed volume, centre, waterplane and GM is computed from the surface
    itself, exactly for the polyhedron (`jaxroll.ship._surface`); the offsets then serve the body plan and the
    exported hull file only.
- `name`, `provenance`: free text carried into outputs. `datum`: where the baseline z = 0 lies in the file it was
    read from ([`Datum`][]), or None.

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
    if hull.surface is not None:
        hull = eqx.tree_at(lambda h: h.surface, hull, scale_surface(hull.surface, length, breadth, height))
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


def translate_hull(hull: Hull, dx: ArrayLike) -> Hull:
    """The hull moved by `dx` [m] along x (stations and surface; Lpp and the AP stay), differentiable in `dx`."""
    dx = jnp.asarray(dx, dtype=float)
    if hull.surface is not None:
        hull = eqx.tree_at(lambda h: h.surface, hull, translate_surface(hull.surface, dx))
    return eqx.tree_at(lambda h: h.stations, hull, hull.stations + dx)


def _bare(hull: Hull) -> Hull:
    """The hull without its name, provenance, datum and its surface's triangle count (static data the integrals do
    not use): what compiled programs take, so that every hull of one size class shares them."""
    surface = hull.surface
    if surface is not None and surface.n_triangles != 0:
        surface = dataclasses.replace(surface, n_triangles=0)
    if hull.name == "" and hull.provenance == "" and hull.datum is None and surface is hull.surface:
        return hull
    new = object.__new__(Hull)
    for f in dataclasses.fields(Hull):
        object.__setattr__(new, f.name, getattr(hull, f.name))
    for key, value in (("name", ""), ("provenance", ""), ("datum", None), ("surface", surface)):
        object.__setattr__(new, key, value)
    return new


# ------------------------------------------------------------------------------------------------------------
# Section geometry
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
    return _c11_hull(*c11_like_offsets(**shape))


def _c11_hull(x, z, y) -> Hull:
    """The C11-like hull of offsets x [m], z [m], y [m] (`c11_like_offsets`, rounded or not)."""
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


C11_KG = 15.5289
"""KG [m] of the shipped C11-like hull's loading (its file's `[loading] kg_m`): GM0 = 1.9299 m at d = 11.5 m in
sea water (`jaxroll.io._hull_file.write_c11_hull_file` computes it and writes the file)."""


def c11_hull() -> Hull:
    """The C11-like hull shipped as `jaxroll/data/c11_hull.toml` (REPRESENTATIVE, not the real C11 lines).

    The offsets of `c11_like_offsets` rounded to 0.1 mm, as the file stores them (the model reads no file:
    tests/test_hydrostatics.py checks that the file holds these numbers)."""
    return _c11_hull(*(_rounded(a, 4) for a in c11_like_offsets()))


def _rounded(values: np.ndarray, digits: int) -> np.ndarray:
    """`values` rounded as a hull file writes them (Python's correctly rounded `round`, −0 as 0)."""
    flat = [round(float(v), digits) + 0.0 for v in np.ravel(values)]
    return np.asarray(flat, dtype=float).reshape(np.shape(values))


def _c11_hull_path() -> Path:
    """Path of the packaged hull file `jaxroll/data/c11_hull.toml`."""
    return Path(__file__).parents[1] / "data" / "c11_hull.toml"


c11_hull_path = _c11_hull_path
