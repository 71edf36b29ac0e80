"""Geometry of closed triangulated hulls: slicing into sections, orientation, half hulls, the symmetry check and
the vertical datum (the keel line, local protrusions). Used by the mesh readers of `jaxroll.io._mesh`."""

from __future__ import annotations

import math

import numpy as np

from ..ship._hull import Datum


class MeshError(ValueError):
    """The surface cannot define a hull (open, non-manifold, degenerate, asymmetric, unreadable)."""


# --------------------------------------------------------------------------------------------------------------
# Slicing
# --------------------------------------------------------------------------------------------------------------


def _section_segments(tri: np.ndarray, x: float, strict: bool = False) -> np.ndarray:
    """Segments (s, 2, 2) of (y, z) where the plane x = const cuts the triangles.

    A vertex on the plane counts as ahead of it (`strict=False`) or abaft it (`strict=True`, used at the aft
    end, where every triangle is ahead of the plane)."""
    side = tri[:, :, 0] > x if strict else tri[:, :, 0] >= x  # (n, 3)
    cut = side.any(axis=1) & ~side.all(axis=1)
    t = tri[cut]
    s = side[cut]
    pts = []
    for a, b in ((0, 1), (1, 2), (2, 0)):
        crosses = s[:, a] != s[:, b]
        pa, pb = t[:, a], t[:, b]
        frac = np.where(crosses, (x - pa[:, 0]) / np.where(crosses, pb[:, 0] - pa[:, 0], 1.0), 0.0)
        pts.append((crosses, pa[:, 1:] + frac[:, None] * (pb[:, 1:] - pa[:, 1:])))
    # exactly two of the three edges cross; keep them in order
    flags = np.stack([c for c, _ in pts], axis=1)  # (m, 3)
    coords = np.stack([p for _, p in pts], axis=1)  # (m, 3, 2)
    order = np.argsort(~flags, axis=1, kind="stable")[:, :2]
    return np.take_along_axis(coords, order[:, :, None], axis=1)


def _half_breadths(seg: np.ndarray, z: np.ndarray, side: int = 0) -> np.ndarray:
    """Largest |y| (side 0), y (side +1, starboard) or −y (side −1, port) where the segments (s, 2, 2) cross each
    height z (0 where none does).

    A height on a segment's end counts within a rounding tolerance (1e-9 of the section's size): where a station
    and a waterline meet on a triangle's edge or vertex (a box's diagonal), the two triangles' cut points differ
    in the last bits, and an exact comparison left the height in the gap between them, counted by neither
    (issue 45: a 12-triangle box refused as asymmetric, "port 0 m")."""
    if seg.shape[0] == 0:
        return np.zeros_like(z)
    y0, z0, y1, z1 = seg[:, 0, 0], seg[:, 0, 1], seg[:, 1, 0], seg[:, 1, 1]
    size = max(float(np.max(np.abs(seg))), float(np.max(np.abs(z))) if z.size else 0.0, 1e-300)
    eps = 1e-9 * size
    zlo, zhi = np.minimum(z0, z1)[:, None], np.maximum(z0, z1)[:, None]
    zz = z[None, :]
    inside = (zz >= zlo - eps) & (zz <= zhi + eps)
    dz = (z1 - z0)[:, None]
    flat = np.abs(dz) <= 1e-15 * max(1.0, float(np.max(np.abs(z))))
    t = np.clip(np.where(flat, 0.0, (zz - z0[:, None]) / np.where(flat, 1.0, dz)), 0.0, 1.0)
    f = np.abs if side == 0 else (lambda v: side * v)
    y = f(y0[:, None] + t * (y1 - y0)[:, None])
    y = np.where(flat, np.maximum(f(y0), f(y1))[:, None], y)
    return np.max(np.where(inside, y, 0.0), axis=0)


def slice_offsets(
    triangles: np.ndarray, stations: np.ndarray, waterlines: np.ndarray, *, side: int = 0
) -> np.ndarray:
    """Half-breadths (stations, waterlines) [m] of a closed body-frame mesh (y centred, z from the keel).

    Exact for the triangulation, also at the ends (flat transoms, flat bottoms and decks): a vertex on a station
    plane counts as ahead of it, except at the aftmost point where it counts as abaft; horizontal segments on a
    waterline give their outer end. `side`: 0 the larger of |y| on both sides, +1 starboard (y), −1 port (−y).
    """
    tri = np.asarray(triangles, dtype=float)
    lo = tri.reshape(-1, 3).min(axis=0)
    xs = np.asarray(stations, dtype=float)
    zs = np.asarray(waterlines, dtype=float)
    return np.stack([_half_breadths(_section_segments(tri, x, strict=x <= lo[0]), zs, side) for x in xs])


def section_bottoms(triangles: np.ndarray, stations: np.ndarray) -> np.ndarray:
    """Lowest z [m] of each section x = stations[i] of a body-frame mesh (NaN where a plane misses the mesh).

    The cut points of `_section_segments` (the same arithmetic, so the same numbers), computed for the pairs of a
    station and a triangle that spans it only (a loop over 201 stations, each over every triangle, took 40 ms of a
    3 500-triangle STL's reading)."""
    tri = np.asarray(triangles, dtype=float)
    lo = tri.reshape(-1, 3).min(axis=0)
    xs = np.asarray(stations, dtype=float)
    x3, z3 = tri[:, :, 0], tri[:, :, 2]
    order = np.argsort(xs, kind="stable")
    first = np.searchsorted(
        xs[order], x3.min(axis=1), side="left"
    )  # the stations within each triangle's x span
    last = np.searchsorted(xs[order], x3.max(axis=1), side="right")
    count = last - first
    tri_of = np.repeat(np.arange(tri.shape[0]), count)
    station = order[
        np.repeat(first, count) + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ]
    x = xs[station][:, None]
    xt, zt = x3[tri_of], z3[tri_of]
    side = np.where(x <= lo[0], xt > x, xt >= x)  # as `_section_segments`: strict at the aft end
    cut = side.any(axis=1) & ~side.all(axis=1)
    lowest = np.full(cut.shape, np.inf)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        crosses = cut & (side[:, a] != side[:, b])
        frac = np.where(crosses, (x[:, 0] - xt[:, a]) / np.where(crosses, xt[:, b] - xt[:, a], 1.0), 0.0)
        lowest = np.where(crosses, np.minimum(lowest, zt[:, a] + frac * (zt[:, b] - zt[:, a])), lowest)
    out = np.full(xs.shape, np.inf)
    np.minimum.at(out, station, lowest)
    return np.where(np.isinf(out), math.nan, out)


# --------------------------------------------------------------------------------------------------------------
# Orientation, half hulls, symmetry
# --------------------------------------------------------------------------------------------------------------


def _welded_faces(tri: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Vertex indices (n, 3) of the triangles after welding vertices closer than `tol` of the mesh size."""
    size = float(np.max(np.ptp(tri.reshape(-1, 3), axis=0)))
    key = np.round(tri.reshape(-1, 3) / (tol * size)).astype(np.int64)
    return np.unique(key, axis=0, return_inverse=True)[1].reshape(-1, 3)


def orient_consistently(triangles: np.ndarray) -> tuple[np.ndarray, int]:
    """The triangles with their vertex orders made consistent (every shared edge traversed in opposite directions
    by its two triangles) and the enclosed volume positive (normals outward), and how many were reversed.

    Each connected part is oriented like its first triangle (breadth-first over shared edges), then reversed as a
    whole where its signed volume is negative. A closed surface whose orientations already agree (every edge
    traversed once each way, the usual export) skips the search: only its parts are found (`_consistent_parts`)."""
    tri = np.asarray(triangles, dtype=float).copy()
    faces = _welded_faces(tri)
    n = faces.shape[0]
    part = _consistent_parts(faces)
    if part is not None:
        flip = np.zeros(n, dtype=bool)
        vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6
        for p in np.unique(part):
            if vol[part == p].sum() < 0:
                tri[part == p] = tri[part == p][:, ::-1]
                flip[part == p] = ~flip[part == p]
        return tri, int(min(flip.sum(), n - flip.sum()))
    edge_faces: dict = {}
    for f in range(n):
        for k in range(3):
            a, b = faces[f, k], faces[f, (k + 1) % 3]
            edge_faces.setdefault((min(a, b), max(a, b)), []).append((f, a))
    flip = np.zeros(n, dtype=bool)
    seen = np.zeros(n, dtype=bool)
    part = np.full(n, -1)
    parts = 0
    for start in range(n):
        if seen[start]:
            continue
        seen[start], part[start], queue = True, parts, [start]
        while queue:
            f = queue.pop()
            for k in range(3):
                a, b = faces[f, k], faces[f, (k + 1) % 3]
                a_eff = b if flip[f] else a  # the edge's start as f is oriented now
                for g, start_g in edge_faces[(min(a, b), max(a, b))]:
                    if g == f or seen[g]:
                        continue
                    # g must traverse the edge the other way: from the other end
                    flip[g] = start_g == a_eff
                    seen[g], part[g] = True, parts
                    queue.append(g)
        parts += 1
    tri[flip] = tri[flip][:, ::-1]
    vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6
    for p in range(parts):
        if vol[part == p].sum() < 0:
            tri[part == p] = tri[part == p][:, ::-1]
            flip[part == p] = ~flip[part == p]
    return tri, int(min(flip.sum(), n - flip.sum()))


def _consistent_parts(faces: np.ndarray) -> np.ndarray | None:
    """For welded faces (n, 3) of a closed surface whose orientations agree — three distinct vertices a face, every
    directed edge once and its reverse once — the connected part of each face (a label per face); None otherwise
    (`orient_consistently` then searches)."""
    if np.any((faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])):
        return None
    n, big = faces.shape[0], int(faces.max()) + 1
    a = np.concatenate([faces[:, 0], faces[:, 1], faces[:, 2]]).astype(np.int64)
    b = np.concatenate([faces[:, 1], faces[:, 2], faces[:, 0]]).astype(np.int64)
    code, twin = a * big + b, b * big + a
    order = np.argsort(code, kind="stable")
    sorted_code = code[order]
    if np.any(sorted_code[1:] == sorted_code[:-1]):
        return None  # an edge traversed twice the same way
    at = np.minimum(np.searchsorted(sorted_code, twin), code.size - 1)
    if not np.array_equal(sorted_code[at], twin):
        return None  # an edge without its reverse: open or inconsistent
    f, g = np.arange(code.size) % n, order[at] % n  # the two faces of each edge
    parent = np.arange(n)
    while True:  # hook each edge's larger root under its smaller one, then point every face at its root
        pf, pg = parent[f], parent[g]
        if np.array_equal(pf, pg):
            return parent
        np.minimum.at(parent, np.maximum(pf, pg), np.minimum(pf, pg))
        while not np.array_equal(parent[parent], parent):
            parent = parent[parent]


def _inconsistent_edges(tri: np.ndarray) -> int:
    """Edges traversed in the same direction by both their triangles (inconsistent vertex orders)."""
    faces = _welded_faces(tri)
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    directed = directed[directed[:, 0] != directed[:, 1]]
    _, counts = np.unique(directed, axis=0, return_counts=True)
    return int(np.sum(counts > 1))


def mirror_half_hull(triangles: np.ndarray, centre_y: float) -> np.ndarray:
    """A half-hull (one side, open along the plane y = centre_y) and its mirror image: a closed hull, with the
    mirrored triangles in reversed vertex order so that both halves keep one orientation."""
    tri = np.asarray(triangles, dtype=float).copy()
    near = np.abs(tri[..., 1] - centre_y) <= 1e-9 * float(np.max(np.ptp(tri.reshape(-1, 3), axis=0)))
    tri[..., 1] = np.where(near, centre_y, tri[..., 1])  # on the plane exactly, so that both halves weld
    mirror = tri[:, ::-1].copy()
    mirror[..., 1] = 2 * centre_y - mirror[..., 1]
    return np.concatenate([tri, mirror])


ASYMMETRY_TOLERANCE = 2e-3
"""Largest sideways offset of a section's centroid accepted (its ∫y dA over the largest section's area), as a
fraction of the breadth (8 cm on a 40 m beam). Measured on integrals, not on single half-breadths: the two
diagonals of a quadrilateral triangulated differently on the two sides (every CAD export) move a half-breadth by
centimetres at a fine bow (5.6e-5 B on the test frigate), an asymmetric hull by metres (issue 37: 0.027 B)."""


def symmetry_defect(triangles: np.ndarray, *, n_stations: int = 41, n_waterlines: int = 41) -> dict:
    """Port–starboard asymmetry of a body-frame mesh (y from the centre plane): the largest difference [m] between
    the starboard and port half-breadths over a grid of stations × waterlines, where it is, both breadths there,
    and the transverse centre of the enclosed volume [m]."""
    tri = np.asarray(triangles, dtype=float)
    lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
    st = np.linspace(lo[0], hi[0], n_stations)
    wl = np.linspace(lo[2], hi[2], n_waterlines)
    stbd, port = slice_offsets(tri, st, wl, side=1), slice_offsets(tri, st, wl, side=-1)
    diff = np.abs(stbd - port)
    i, j = np.unravel_index(int(np.argmax(diff)), diff.shape)
    dz = np.gradient(wl)
    area = np.sum((stbd + port) * dz, axis=1)  # section areas
    moment = np.sum((stbd**2 - port**2) / 2 * dz, axis=1)  # ∫ y dA of each section
    k = int(np.argmax(np.abs(moment)))
    v = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6
    cy = (tri[:, 0, 1] + tri[:, 1, 1] + tri[:, 2, 1]) / 4  # centroid of the tetrahedron with the origin
    return dict(
        max_difference=float(diff[i, j]), x=float(st[i]), z=float(wl[j]), starboard=float(stbd[i, j]),
        port=float(port[i, j]), tcb=float(np.sum(v * cy) / np.sum(v)), breadth=float(hi[1] - lo[1]),
        section_offset=float(abs(moment[k]) / max(area.max(), 1e-300)), section_x=float(st[k]),
    )  # fmt: skip


# --------------------------------------------------------------------------------------------------------------
# The vertical datum
# --------------------------------------------------------------------------------------------------------------

PROTRUSION_LENGTH_FRACTION = 0.25
"""A lowest point is a local protrusion (sonar dome, skeg, bulb) when less than this fraction of the length lies
below the keel line (the median section bottom over the middle 60 % of the length)."""


def _datum(tri_body: np.ndarray, baseline_z: float | None, *, source: str, zero_is_waterline: bool) -> tuple:
    """(baseline z in the body-frame file coordinates, Datum, warning or None) — see `hull_from_triangles`."""
    lo, hi = tri_body.reshape(-1, 3).min(axis=0), tri_body.reshape(-1, 3).max(axis=0)
    height = float(hi[2] - lo[2])
    tol = max(0.01 * height, 1e-9)
    st = np.linspace(lo[0], hi[0], 201)
    bottoms = section_bottoms(tri_body, st)
    middle = (st >= lo[0] + 0.2 * (hi[0] - lo[0])) & (st <= lo[0] + 0.8 * (hi[0] - lo[0]))
    keel = float(np.nanmedian(bottoms[middle]))
    below = np.nan_to_num(bottoms, nan=np.inf) < keel - tol
    fraction = float(np.mean(below))
    protrusion = float(lo[2]) < keel - tol and fraction < PROTRUSION_LENGTH_FRACTION
    x_low = float(st[np.nanargmin(bottoms)])
    z_min = float(lo[2])
    if baseline_z is not None:
        zb = float(baseline_z)
        if zb > keel + tol:
            raise MeshError(
                f"{source}: the baseline z = {zb:.4g} m [file z, m] is {zb - keel:.4g} m ABOVE the keel line (the "
                f"bottom of the hull over its middle part, file z = {keel:.4g} m; lowest point {z_min:.4g} m): draughts "
                "and KG are measured from the baseline, which lies at or below the keel. Give --baseline-z "
                f"{keel:.4g} (the keel line) or {z_min:.4g} (the lowest point), in the file's z [m, full scale]."
            )
        if zb < z_min - 0.1 * height:
            raise MeshError(
                f"{source}: the baseline z = {zb:.4g} m [file z, m] is {z_min - zb:.4g} m BELOW the lowest point of "
                f"the hull (file z = {z_min:.4g} m; height {height:.4g} m): check its sign and unit (metres, full "
                f"scale, in the file's z). The keel line is at file z = {keel:.4g} m."
            )
        return zb, Datum(zb, "given (baseline_z)", z_min, keel), None
    if protrusion:
        zb, how = (0.0, "file z = 0, the keel line") if abs(keel) <= tol else (keel, "the keel line")
        note = (
            f"{source}: the lowest point (file z = {z_min:.4g} m, near x = {x_low:.4g} m [body frame]) is a local "
            f"protrusion below the keel line (a sonar dome, skeg or bulb: {100 * fraction:.0f} % of the length "
            f"lies below it). Draughts and KG are measured from the keel line at file z = {zb:.4g} m ({how}); if "
            f"they are measured from the lowest point, give --baseline-z {z_min:.6g} (Python: baseline_z="
            f"{z_min:.6g}), or where only the draught or KG is, --draught-datum lowest or --kg-datum lowest (Python: "
            f"hull.datum.above_baseline(value, 'lowest')). The lowest point is {zb - z_min:.4g} m below the baseline."
        )
        return zb, Datum(zb, f"{how} (the lowest point is a local protrusion)", z_min, keel), note
    datum = Datum(z_min, "the lowest point", z_min, keel)
    if not zero_is_waterline and z_min + tol < 0.0 < float(hi[2]) - tol:
        note = (
            f"{source}: the file's z = 0 lies inside the hull, {-z_min:.4g} m above its lowest point (file z = "
            f"{z_min:.4g} m) and {float(hi[2]):.4g} m below its top. Draughts and KG are measured from the lowest "
            f"point (the baseline at file z = {z_min:.4g} m). If the file's z = 0 is the baseline (with parts of "
            "the hull below it), give --baseline-z 0 (Python: baseline_z=0), or where only the draught or KG is "
            "measured from it, --draught-datum 0 or --kg-datum 0; if it is the design waterline, the draught is "
            f"{-z_min:.4g} m above the lowest point."
        )
        return z_min, datum, note
    return z_min, datum, None
