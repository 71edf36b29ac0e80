r"""The wetted hull as panels for a BEM solver (capytaine): the same hull jaxroll reads, and the checks a BEM mesh
needs. NumPy only: nothing here imports capytaine (`jaxroll.ship._bem` runs it).

**Which surface.** A hull read from a mesh (`Hull.surface`, an STL or GDF) gives its own triangles; a hull of
offsets (a TOML hull file, `c11`) is panelled on its offsets' surface — each station's section polygon
(`jaxroll.ship._hull._section_polygons`), straight between stations — with every station and every waterline of the
table kept as panel edges and each interval divided so that no panel edge exceeds `panel_size`: the panels' vertices
lie on the hull whose hydrostatics and Froude–Krylov moment jaxroll computes, and the panels converge to it at
second order. The hull is symmetric port and starboard (the readers check it): its starboard half is panelled and
the solver mirrors it (a reflection-symmetric mesh, half the unknowns).

**BEM frame** (capytaine's): origin at amidships on the centre plane in the calm waterline, x_b forward, y_b to
port, z_b up — right-handed, so a positive rotation about x_b heels the ship to starboard, jaxroll's φ > 0. The hull
frame (x from the AP, y to starboard, z from the baseline) maps to it by a rigid motion: a reflection of y, and the
trim angle θ = atan(t/L) (t = d_FP − d_AP) turned out, so that the waterline of the loading (sinkage and trim,
`jaxroll.equilibrium`) is z_b = 0. The roll axis is the ship's x axis through G.

**Checks** (`MeshNotFitError`, one line each; docs/errors.md): the wetted surface must be closed up to the
waterline — every open edge of the immersed half lies on the centre plane (mirrored) or in the free surface — and
the hull must pierce the free surface (a waterline exists); no panel may be longer than λ/6 of the shortest wave
asked, λ = 2πg/ω².
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ._hull import Hull
from ._hydrostatics import GRAVITY, Loading

PANELS_PER_WAVELENGTH = 6.0
"""A BEM panel's longest edge must be at most λ/6 of the shortest wave solved (the usual rule for constant panels)."""


class MeshNotFitError(ValueError):
    """The hull's mesh cannot be given to the BEM solver: open below the waterline, not piercing the free surface,
    or too coarse for the shortest wave asked."""


@dataclasses.dataclass(frozen=True)
class BemMesh:
    """The wetted starboard half of a hull as panels in the BEM frame (module docstring) [m]; the solver mirrors it.

    `vertices` (n, 3); `faces` (m, 4) vertex indices, a triangle repeating its last vertex; `centre_of_gravity` G
    and `roll_axis` (unit vector, the ship's x axis) in the BEM frame; `trim_angle` θ [rad]."""

    vertices: np.ndarray
    faces: np.ndarray
    centre_of_gravity: np.ndarray
    roll_axis: np.ndarray
    trim_angle: float

    @property
    def n_panels(self) -> int:
        """Panels of the whole wetted hull (both halves)."""
        return 2 * int(self.faces.shape[0])

    @property
    def panel_size(self) -> float:
        """The longest panel edge [m]."""
        return float(np.max(_edge_lengths(self.vertices, self.faces)))

    def polygons(self) -> list[np.ndarray]:
        """The half's panels as vertex arrays (3 or 4, 3) [m]."""
        return [self.vertices[_distinct(f)] for f in self.faces]

    def mirrored(self) -> tuple[np.ndarray, np.ndarray]:
        """The whole wetted hull: (vertices, faces) with the port half appended (its faces reversed: outward)."""
        n = self.vertices.shape[0]
        port = self.vertices * np.array([1.0, -1.0, 1.0])
        faces = np.concatenate([self.faces, self.faces[:, ::-1] + n])
        return np.concatenate([self.vertices, port]), faces


def _distinct(face: np.ndarray) -> np.ndarray:
    return face[:3] if face[2] == face[3] else face


def _edge_lengths(vertices, faces):
    p = vertices[faces]  # (m, 4, 3)
    return np.linalg.norm(np.roll(p, -1, axis=1) - p, axis=2)


def wavelength(omega: float) -> float:
    """Deep-water wave length λ = 2πg/ω² [m] of frequency ω [rad/s]."""
    return 2 * math.pi * GRAVITY / omega**2


# --------------------------------------------------------------------------------------------------------------
# Panels of an offsets hull (hull frame, starboard half)
# --------------------------------------------------------------------------------------------------------------


def _subdivide(points: np.ndarray, pieces: np.ndarray) -> np.ndarray:
    """Each interval of increasing `points` cut into `pieces[i]` equal parts (the points themselves kept)."""
    out = [np.linspace(a, b, int(n) + 1)[:-1] for a, b, n in zip(points[:-1], points[1:], pieces)]
    return np.concatenate([*out, points[-1:]])


def offsets_panels(hull: Hull, panel_size: float, extra_levels=()) -> np.ndarray:
    """Quadrilateral panels (m, 4, 3) [m, hull frame] of the starboard half of an offsets hull's closed surface:
    bottom, side, deck and end sections, every station and waterline of the table kept and each interval divided so
    that no panel edge exceeds `panel_size` [m]. `extra_levels`: heights z [m] also made panel edges (the waterline,
    so that it cuts no panel at even keel)."""
    x0 = np.asarray(hull.stations, float)
    z0 = np.asarray(hull.waterlines, float)
    hb = np.asarray(hull.half_breadths, float)
    depth = float(hull.depth)
    levels = np.unique(np.concatenate([z0, [depth], [z for z in extra_levels if z0[0] < z < depth]]))
    side = np.stack([np.interp(levels, z0, row) for row in hb])  # Y(x_i, z_k): vertical above the top offset
    # along z: each interval's longest step (dz, dy at any station) within panel_size
    dz = np.hypot(np.diff(levels)[None, :], np.diff(side, axis=1))
    levels = _subdivide(levels, np.ceil(dz.max(axis=0) / panel_size))
    side = np.stack([np.interp(levels, z0, row) for row in hb])
    # along x: each interval's longest edge (dx, dy) within panel_size; half-breadths linear between stations
    dx = np.hypot(np.diff(x0)[:, None], np.diff(side, axis=0))
    x = _subdivide(x0, np.ceil(dx.max(axis=1) / panel_size))
    side = np.stack([np.interp(x, x0, side[:, k]) for k in range(levels.size)], axis=1)
    # across the bottom and the deck: fractions of the half-breadth, the same for both (conforming end sections)
    nu = int(max(1, math.ceil(max(side[:, 0].max(), side[:, -1].max()) / panel_size)))
    u = np.linspace(0.0, 1.0, nu + 1)
    # girth of each station: keel centre → bottom → side → deck → deck centre, (stations, girth, 3)
    ys = np.concatenate([u[None, :-1] * side[:, :1], side, u[None, ::-1][:, 1:] * side[:, -1:]], axis=1)
    zs = np.concatenate([np.full(nu, levels[0]), levels, np.full(nu, levels[-1])])
    g = np.stack([np.broadcast_to(x[:, None], ys.shape), ys, np.broadcast_to(zs, ys.shape)], axis=-1)
    a, b = g[:-1, :-1], g[1:, :-1]
    c, d = g[1:, 1:], g[:-1, 1:]
    quads = [
        np.stack([a, d, c, b], axis=2).reshape(-1, 4, 3)
    ]  # outward: normal +y at the side, −z at the bottom
    for end, sign in ((0, -1.0), (-1, 1.0)):  # the end sections, where they have breadth
        y = u[:, None] * side[end][None, :]  # (u, level)
        p = np.stack([np.full(y.shape, x[end]), y, np.broadcast_to(levels, y.shape)], axis=-1)
        q = np.stack([p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]], axis=2).reshape(-1, 4, 3)
        quads.append(q[:, ::-1] if sign < 0 else q)  # normal −x aft, +x forward
    quads = np.concatenate(quads)
    return quads[_area(quads) > 1e-12 * panel_size**2]


def _area(polys: np.ndarray) -> np.ndarray:
    """Areas of quadrilaterals (m, 4, 3) (vector area of the two triangles)."""
    n = np.cross(polys[:, 2] - polys[:, 0], polys[:, 3] - polys[:, 1]) / 2
    return np.linalg.norm(n, axis=1)


# --------------------------------------------------------------------------------------------------------------
# Clipping, frames, welding
# --------------------------------------------------------------------------------------------------------------


def _clip(polys: list[np.ndarray], axis: int, keep_below: bool) -> list[np.ndarray]:
    """Sutherland–Hodgman: the part of each polygon with coordinate `axis` ≤ 0 (`keep_below`) or ≥ 0."""
    out = []
    for p in polys:
        s = p[:, axis] if keep_below else -p[:, axis]
        if np.all(s <= 0):
            out.append(p)
            continue
        if np.all(s >= 0):
            continue
        kept = []
        for i in range(len(p)):
            a, b, sa, sb = p[i], p[(i + 1) % len(p)], s[i], s[(i + 1) % len(p)]
            if sa <= 0:
                kept.append(a)
            if (sa < 0 < sb) or (sb < 0 < sa):
                q = a + (sa / (sa - sb)) * (b - a)
                q[axis] = 0.0
                kept.append(q)
        if len(kept) >= 3:
            out.append(np.asarray(kept))
    return out


def _weld(polys: list[np.ndarray], size: float) -> tuple[np.ndarray, np.ndarray]:
    """Shared vertices (welded within 1e-9 of the size) and faces (m, 4) of polygons of 3–5 distinct vertices (a
    pentagon becomes a quadrilateral and a triangle); polygons of under 3 distinct vertices are dropped."""
    pts = np.concatenate(polys)
    key = np.round(pts / (1e-9 * size)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    vertices = pts[first]
    faces, start = [], 0
    for p in polys:
        idx = inverse.ravel()[start : start + len(p)]
        start += len(p)
        keep = [int(i) for j, i in enumerate(idx) if i != idx[j - 1]]
        if len(keep) < 3:
            continue
        for part in [keep] if len(keep) <= 4 else [keep[:4], [keep[0], *keep[3:]]]:
            if len(set(part)) < 3:
                continue
            faces.append(part if len(part) == 4 else [*part, part[-1]])
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 4)
    return vertices, faces[_polygon_area(vertices, faces) > 1e-14 * size**2]


WARP = 0.02
"""A quadrilateral whose fourth vertex lies off the plane of the other three by more than this fraction of its
diagonal is split into two triangles (a constant-panel BEM takes each panel as plane)."""


def _split_warped(vertices, faces):
    p = vertices[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    warp = np.abs(np.sum((p[:, 3] - p[:, 0]) * normal, axis=1)) / np.linalg.norm(p[:, 2] - p[:, 0], axis=1)
    split = (faces[:, 2] != faces[:, 3]) & (warp > WARP)
    s = faces[split]
    halves = [s[:, [0, 1, 2, 2]], s[:, [0, 2, 3, 3]]]
    return vertices, np.concatenate([faces[~split], *halves])


def _polygon_area(vertices, faces):
    p = vertices[faces]
    return np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1) / 2


def _to_bem_frame(points, hull, sinkage, trim):
    """Hull frame (x from the AP, y starboard, z from the baseline) → BEM frame (module docstring)."""
    theta = math.atan2(float(trim), float(hull.lpp))
    xi = points[..., 0] - float(hull.lpp) / 2
    zeta = points[..., 2] - float(sinkage)
    c, s = math.cos(theta), math.sin(theta)
    return np.stack([xi * c + zeta * s, -points[..., 1], -xi * s + zeta * c], axis=-1), theta


def bem_mesh(
    hull: Hull, loading: Loading, *, sinkage: float, trim: float, panel_size: float | None = None
) -> BemMesh:
    """The wetted starboard half of `hull` in `loading` as BEM panels ([`BemMesh`][]), in the BEM frame of the
    waterline given by `sinkage` [m] (draught amidships) and `trim` [m] (d_FP − d_AP).

    `panel_size` [m]: the longest panel edge of an offsets hull (required for it); a mesh hull keeps its own
    triangles (`panel_size` must then be None).

    **Raises:** `MeshNotFitError` for a wetted surface open below the waterline or a hull that does not pierce the
    free surface; `ValueError` for a `panel_size` that is not a length > 0, or one given with a mesh hull."""
    size = float(max(float(hull.lpp), float(hull.depth)))
    if hull.surface is not None:
        if panel_size is not None:
            raise ValueError(
                "`panel_size` is for a hull of offsets: a hull read from a mesh keeps its own panels (mesh the "
                "file finer instead)."
            )
        tri = np.asarray(hull.surface.triangles, float)[: hull.surface.n_triangles or None]
        tri = tri[_tri_area(tri) > 0]
        polys = list(tri)
    else:
        if panel_size is None or not (math.isfinite(panel_size) and panel_size > 0):
            raise ValueError(f"`panel_size` must be a finite length > 0 [m]; got {panel_size!r}.")
        flat = (float(sinkage),) if float(trim) == 0 else ()
        polys = list(offsets_panels(hull, panel_size, extra_levels=flat))
    # starboard half (y ≥ 0 in the hull frame), turned to the BEM frame: the reflection of y reverses the faces
    polys = _clip(polys, 1, keep_below=False)
    moved = [_to_bem_frame(p, hull, sinkage, trim)[0][::-1] for p in polys]
    for p in moved:  # a waterline within 1e-6 of the size of a panel edge (a trim of round-off) is that edge
        p[np.abs(p[:, 2]) < 1e-6 * size, 2] = 0.0
    wet = _clip(moved, 2, keep_below=True)
    if not wet:
        raise MeshNotFitError(
            f"{hull.name}: no panel lies below the waterline (sinkage {float(sinkage):.4g} m): nothing to solve."
        )
    vertices, faces = _split_warped(*_weld(wet, size))
    # panels in the centre plane (a stem or keel of no breadth, where the offsets are zero at two stations) are no
    # surface: the two halves' copies would coincide
    faces = faces[~np.all(np.abs(vertices[faces][..., 1]) < 1e-9 * size, axis=1)]
    theta = _to_bem_frame(np.zeros(3), hull, sinkage, trim)[1]
    g = _to_bem_frame(np.array([float(loading.lcg), 0.0, float(loading.kg)]), hull, sinkage, trim)[0]
    mesh = BemMesh(
        vertices=vertices,
        faces=faces,
        centre_of_gravity=g * np.array([1.0, 0.0, 1.0]),
        roll_axis=np.array([math.cos(theta), 0.0, -math.sin(theta)]),
        trim_angle=theta,
    )
    check_closed(mesh, what=hull.name)
    return mesh


def _tri_area(tri):
    return np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) / 2


# --------------------------------------------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------------------------------------------


def check_closed(mesh: BemMesh, *, what: str = "hull") -> None:
    """Refuse a wetted half whose open edges are not all on the centre plane (y = 0, mirrored) or in the free
    surface (z = 0): a hole below the waterline, or a mesh that ends below it. Refuse a hull with no waterline.

    **Raises:** `MeshNotFitError` naming where the mesh is open [m, BEM frame: x forward of amidships, depth]."""
    v, f = mesh.vertices, mesh.faces
    edges = np.concatenate([np.stack([f[:, i], f[:, (i + 1) % 4]], axis=1) for i in range(4)])
    edges = np.sort(edges[edges[:, 0] != edges[:, 1]], axis=1)
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    open_edges = uniq[counts == 1]
    tol = 1e-7 * float(np.ptp(v, axis=0).max())
    p, q = v[open_edges[:, 0]], v[open_edges[:, 1]]
    on_plane = (np.abs(p[:, 1]) < tol) & (np.abs(q[:, 1]) < tol)
    in_surface = (np.abs(p[:, 2]) < tol) & (np.abs(q[:, 2]) < tol)
    bad = ~(on_plane | in_surface)
    if bad.any():
        i = int(np.argmin(np.minimum(p[bad, 2], q[bad, 2])))
        mid = (p[bad][i] + q[bad][i]) / 2
        raise MeshNotFitError(
            f"{what}: the wetted surface is open below the waterline ({int(bad.sum())} free panel edges, e.g. at "
            f"{mid[0]:.4g} m from amidships, {-mid[2]:.4g} m deep): a BEM mesh must be closed up to the waterline. "
            "Close the hole in the mesh, or give the whole hull (not a wetted surface cut at another draught)."
        )
    if not in_surface.any():
        raise MeshNotFitError(
            f"{what}: the hull does not pierce the free surface (no waterline: the deck is under water); BEM needs "
            "a floating hull. Check the draught and the depth."
        )


def check_panel_size(mesh: BemMesh, omega_max: float, *, what: str = "hull") -> None:
    """Refuse panels longer than λ/6 of the shortest wave asked (frequency `omega_max` [rad/s]).

    **Raises:** `MeshNotFitError` saying the panel size, λ/6, and the highest frequency the mesh allows."""
    size = mesh.panel_size
    limit = wavelength(omega_max) / PANELS_PER_WAVELENGTH
    if size > limit * (1 + 1e-9):
        allowed = math.sqrt(2 * math.pi * GRAVITY / (PANELS_PER_WAVELENGTH * size))
        raise MeshNotFitError(
            f"{what}: panels up to {size:.3g} m long are too coarse for the shortest wave asked (ω = "
            f"{omega_max:.4g} rad/s, λ = {wavelength(omega_max):.4g} m): a panel must be at most λ/6 = {limit:.3g} m. "
            f"Mesh the hull finer (panels ≤ {limit:.3g} m) or solve up to ω ≤ {allowed:.4g} rad/s."
        )
