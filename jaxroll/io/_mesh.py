r"""Hulls from a closed triangulated surface (STL, ascii or binary) or a plain offsets table (CSV).

Both readers return a [`Hull`][] (station offsets, full scale, SI), so the hydrostatics of `jaxroll.ship` (GM,
GZ, ΔGM in waves) and the IMO criteria of `jaxroll.criteria` apply to the user's own hull. The STL reader is
our own (about 30 lines of NumPy, binary and ascii): the format is trivial, and the checks that matter for a
hull (closed, 2-manifold, symmetric, plausible ship length) are ours either way, so an optional dependency
(numpy-stl, trimesh) would add an install step without removing any code (docs/sgisc.md); the tests read the
same files with numpy-stl (a dev extra) and check the triangles agree. WAMIT GDF panel files (`_gdf.py`) become
the same triangle array and take the same path ([`hull_from_triangles`][]).

**Axes and units** (stated and checked). The result is in jaxroll's body frame (`docs/hydrostatics.md`): x [m]
forward from the aft perpendicular (AP), y [m] across (the file's y: the hull is symmetric), z [m] up from the
baseline. Input files may use another length unit (`units="mm"` etc.), another forward/up axis (`forward="+x"`,
`up="+z"`, or e.g. `"-y"`), and may be model scale (`scale=100` multiplies every length).

- x origin: the AP (`x_ap`, in metres after the unit/scale conversion, in the file's x origin) — default: the
  aftmost point of the mesh;
- z origin: the baseline (`baseline_z`), by default the keel line where the lowest point is a local protrusion
  (sonar dome, skeg, bulb), else the lowest point, with a warning naming both whenever they differ or the file's
  z = 0 lies inside the hull (`jaxroll.io._mesh_geometry`);
- y origin: the centre plane, the middle of the y extent; a hull whose sections' centroids lie off it (more than
  0.2 % of the breadth) is refused with the measured asymmetry.

**Hydrostatics.** The returned `Hull` keeps the closed, outward-oriented triangles (`Hull.surface`): its
hydrostatics are those of the polyhedron itself (`jaxroll.ship._surface`). It also carries offsets sliced at
stations × waterlines (each station plane cuts the triangles exactly; the half-breadth at a waterline is the
largest |y| where the section crosses it) for the body plan and the exported hull file; `exact=False` uses them for
the hydrostatics (jaxroll 0.1's method, O(Δx², Δz²) errors at large heel).

**Checks.** The mesh must be closed and 2-manifold (every edge shared by exactly two triangles, after welding
vertices closer than 1e-9 of the size) and consistently oriented (`fix_normals=True` repairs it; all-inward normals
are turned outward). A half-hull (open only along a flat side) is mirrored with `half_hull=True` and refused
without it. Lengths under 24 m (the smallest ship the IS Code's criteria apply to) or over 500 m raise
`ModelScaleError` — the classic unit error is a 1:100 model file (L = 2.62 instead of 262 m) or millimetres read
as metres.
"""

from __future__ import annotations

import csv
import math
import re
import warnings
from pathlib import Path

import numpy as np

from ..ship._hull import Hull
from ..ship._surface import DEFAULT_WAVE_STRIPS, hull_surface
from ._mesh_geometry import (
    ASYMMETRY_TOLERANCE,
    MeshError,
    _datum,
    _inconsistent_edges,
    _welded_faces,
    mirror_half_hull,
    orient_consistently,
    slice_offsets,
    symmetry_defect,
)

UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "dm": 0.1, "hm": 100.0, "in": 0.0254, "ft": 0.3048}
"""Length units accepted by the readers, in metres."""

SHIP_LENGTH_RANGE_M = (24.0, 500.0)
"""Plausible full-scale L [m]: the IMO stability criteria (IS Code 2008 scope) apply to ships of 24 m and over; nothing afloat is
over 500 m. Outside this range a file is almost surely model scale or in the wrong unit."""


class ModelScaleError(ValueError):
    """The hull's length is implausible for a full-scale ship: a model-scale file or a unit error."""


# --------------------------------------------------------------------------------------------------------------
# STL reading
# --------------------------------------------------------------------------------------------------------------


def read_stl(path: str | Path) -> np.ndarray:
    """Triangles of an STL file (binary or ascii), shape (n, 3, 3) [file units].

    Binary is recognised by its exact size 84 + 50 n; anything else must be ascii (`solid … facet … vertex …`).
    Normals in the file are ignored (orientation is not used).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"STL file {str(path)!r} does not exist.")
    data = path.read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if len(data) == 84 + 50 * n:
            rec = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            tri = np.frombuffer(data, dtype=rec, count=n, offset=84)["v"].astype(float)
            return _checked_triangles(tri, path)
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().lower().startswith("solid"):
        raise MeshError(
            f"{path}: neither a binary STL (size {len(data)} is not 84 + 50 n for the triangle count in its "
            "header) nor an ascii STL (it does not start with 'solid')."
        )
    nums = re.findall(r"^\s*vertex\s+(\S+)\s+(\S+)\s+(\S+)", text, flags=re.MULTILINE | re.IGNORECASE)
    if len(nums) % 3:
        raise MeshError(f"{path}: {len(nums)} vertices is not a multiple of 3 (a facet without 3 vertices).")
    try:
        tri = np.asarray(nums, dtype=float).reshape(-1, 3, 3)
    except ValueError as e:
        raise MeshError(f"{path}: a vertex coordinate is not a number ({e}).") from None
    return _checked_triangles(tri, path)


def _checked_triangles(tri: np.ndarray, path) -> np.ndarray:
    if tri.shape[0] == 0:
        raise MeshError(f"{path}: the STL holds no triangles.")
    if not np.all(np.isfinite(tri)):
        raise MeshError(f"{path}: the STL holds non-finite coordinates (NaN or inf).")
    return tri


def write_stl(path: str | Path, triangles: np.ndarray, *, binary: bool = True, name: str = "hull") -> Path:
    """Write triangles (n, 3, 3) as an STL file (binary or ascii); normals from the vertex order."""
    path = Path(path)
    tri = np.asarray(triangles, dtype=float)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    if binary:
        rec = np.zeros(tri.shape[0], dtype=[("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
        rec["normal"], rec["v"] = nrm, tri
        path.write_bytes(name.encode()[:80].ljust(80, b" ") + np.uint32(len(rec)).tobytes() + rec.tobytes())
    else:
        lines = [f"solid {name}"]
        for t, n in zip(tri, nrm):
            lines += [f"  facet normal {n[0]:.9g} {n[1]:.9g} {n[2]:.9g}", "    outer loop"]
            lines += [f"      vertex {v[0]:.12g} {v[1]:.12g} {v[2]:.12g}" for v in t]
            lines += ["    endloop", "  endfacet"]
        lines.append(f"endsolid {name}")
        path.write_text("\n".join(lines) + "\n")
    return path


# --------------------------------------------------------------------------------------------------------------
# Topology
# --------------------------------------------------------------------------------------------------------------


def mesh_topology(triangles: np.ndarray, *, tol: float = 1e-9) -> dict:
    """Weld vertices and count edge uses: returns boundary edges, non-manifold edges and the signed volume.

    `tol` is relative to the bounding-box size. An edge used once is a boundary (hole); more than twice,
    non-manifold.
    """
    tri = np.asarray(triangles, dtype=float)
    size = float(np.max(np.ptp(tri.reshape(-1, 3), axis=0)))
    if size <= 0:
        raise MeshError("the mesh has zero extent.")
    key = np.round(tri.reshape(-1, 3) / (tol * size)).astype(np.int64)
    _, idx = np.unique(key, axis=0, return_inverse=True)
    faces = idx.reshape(-1, 3)
    degenerate = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    faces = faces[~degenerate]
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    und = np.sort(edges, axis=1)
    uniq, counts = np.unique(und, axis=0, return_counts=True)
    verts = tri.reshape(-1, 3)[np.unique(idx, return_index=True)[1]]
    v = tri
    volume = float(np.sum(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2]))) / 6)
    return dict(
        vertices=verts,
        boundary_edges=uniq[counts == 1],
        nonmanifold_edges=uniq[counts > 2],
        n_degenerate=int(degenerate.sum()),
        volume=volume,
    )


# --------------------------------------------------------------------------------------------------------------
# Frames and scale
# --------------------------------------------------------------------------------------------------------------


def _axis(spec: str) -> tuple[int, float]:
    m = re.fullmatch(r"([+-]?)([xyz])", spec.strip().lower())
    if not m:
        raise ValueError(f"axis must be one of '+x', '-x', '+y', …, '-z'; got {spec!r}.")
    return "xyz".index(m.group(2)), -1.0 if m.group(1) == "-" else 1.0


def to_body_frame(points: np.ndarray, *, forward: str = "+x", up: str = "+z") -> np.ndarray:
    """Points (..., 3) in file axes → (x forward, y starboard-or-port, z up); a proper rotation of the file axes."""
    (fi, fs), (ui, us) = _axis(forward), _axis(up)
    if fi == ui:
        raise ValueError(f"forward ({forward}) and up ({up}) must be different axes.")
    p = np.asarray(points, dtype=float)
    ex = np.zeros(3)
    ex[fi] = fs
    ez = np.zeros(3)
    ez[ui] = us
    ey = np.cross(ez, ex)  # right-handed: with x forward and z up, y points to port; the hull is symmetric
    return np.stack([p @ ex, p @ ey, p @ ez], axis=-1)


def check_ship_scale(length: float, *, what: str = "hull") -> None:
    """Raise `ModelScaleError` if `length` [m] is not a plausible full-scale ship length (24–500 m)."""
    lo, hi = SHIP_LENGTH_RANGE_M
    if lo <= length <= hi:
        return
    if length < lo:
        hint = (
            f"Is this a MODEL-SCALE file in metres (at 1:100 the ship is {length * 100:.4g} m), or a file in "
            f"hectometres? Give the model scale (scale=100, CLI --scale 100) or the file's unit (units='hm', "
            "CLI --units hm); the IMO stability criteria apply to ships of 24 m and over."
        )
    else:
        hint = (
            f"No ship is {length:.4g} m long: the file is probably in millimetres or centimetres read as "
            f"metres (in mm it would be {length / 1000:.4g} m). Give units='mm' (CLI --units mm; or cm, in, "
            "ft)."
        )
    raise ModelScaleError(f"{what}: length {length:.6g} m is outside {lo:g}–{hi:g} m. {hint}")


# --------------------------------------------------------------------------------------------------------------
# Public readers
# --------------------------------------------------------------------------------------------------------------


def hull_from_triangles(
    triangles: np.ndarray,
    *,
    lpp: float | None = None,
    x_ap: float | None = None,
    baseline_z: float | None = None,
    units: str = "m",
    scale: float = 1.0,
    forward: str = "+x",
    up: str = "+z",
    half_hull: bool = False,
    fix_normals: bool = False,
    exact: bool = True,
    strips: int = DEFAULT_WAVE_STRIPS,
    stations: np.ndarray | int = 61,
    waterlines: np.ndarray | int = 41,
    check_scale: bool = True,
    zero_is_waterline: bool = False,
    name: str = "mesh hull",
    source: str = "<triangles>",
) -> Hull:
    """A jaxroll `Hull` from a closed triangulated hull surface.

    **Arguments:**

    - `triangles`: (n, 3, 3) vertices in file units and axes.
    - `lpp`: L [m] (full scale). Default: the mesh's length overall, with a warning (SGISC use L = Lpp or the
      IS Code's L; give it).
    - `x_ap`: x of the aft perpendicular [m, full scale, file x origin]; default: the aftmost point.
    - `baseline_z`: z of the baseline [m, full scale, file z origin: the file's up axis, scaled to metres], from
      which draughts and KG are measured. Default: the keel line when the lowest point is a local protrusion
      (a sonar dome, skeg or bulb: less than 25 % of the length below the keel line), else the lowest point —
      with a warning naming both candidates whenever the lowest point is a protrusion or the file's z = 0 lies
      inside the hull. Refused above the keel line or far below the hull.
    - `units`: length unit of the file (`m`, `mm`, `cm`, `in`, `ft`); `scale`: model scale factor (100 for a
      1:100 model file), applied after `units`.
    - `forward`, `up`: file axes pointing forward and up (`"+x"`, `"-y"`, …).
    - `half_hull`: the file holds one side only, open along the centre plane: mirror it. A mesh open along a flat
      side is refused without it, and `half_hull=True` on a closed mesh is an error.
    - `fix_normals`: make inconsistent triangle orientations consistent (otherwise an error); a mesh whose
      triangles are all inward is always turned outward.
    - `exact`: keep the surface (`Hull.surface`): hydrostatics of the polyhedron itself (default). False: the
      sliced offsets only (the method before jaxroll 0.2: O(Δx², Δz²) errors at large heel).
    - `strips`: strips along x in which a wave surface is taken linear (`jaxroll.ship._surface`).
    - `stations`: x [m from the AP] of the sliced stations, or a count (uniform over the mesh's x extent).
    - `waterlines`: z [m above the baseline], or a count (uniform from the lowest point to the top).
    - `check_scale`: raise `ModelScaleError` for an implausible ship length (see `check_ship_scale`).
    - `zero_is_waterline`: the file's z = 0 is its waterline by convention (a WAMIT GDF): no warning for it.

    **Raises:** `MeshError` for an open (except a half-hull with `half_hull=True`), non-manifold, inconsistently
    oriented or asymmetric mesh, or a baseline contradicting the geometry; `ModelScaleError`; `ValueError` for bad
    axes or units.
    """
    if units not in UNITS:
        raise ValueError(f"units must be one of {sorted(UNITS)}; got {units!r}.")
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a finite factor > 0 (model scale, e.g. 100); got {scale}.")
    tri = to_body_frame(np.asarray(triangles, dtype=float) * UNITS[units] * scale, forward=forward, up=up)
    faces = _welded_faces(tri)
    tri = tri[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])]
    if tri.shape[0] < 4:
        raise MeshError(f"{source}: fewer than 4 triangles with an area: not a closed surface.")
    topo = mesh_topology(tri)
    pts = tri.reshape(-1, 3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float(np.max(hi - lo))
    if topo["nonmanifold_edges"].shape[0]:
        e = topo["vertices"][topo["nonmanifold_edges"][0]]
        raise MeshError(
            f"{source}: the mesh is not 2-manifold: {topo['nonmanifold_edges'].shape[0]} edge(s) are shared by "
            f"more than two triangles (first between {e[0].round(4).tolist()} and {e[1].round(4).tolist()} "
            "[m, body frame]). Export the hull as a single closed shell (no internal faces, no duplicates)."
        )
    half = False
    if topo["boundary_edges"].shape[0]:
        bverts = topo["vertices"][topo["boundary_edges"].ravel()]
        on_plane = np.abs(bverts[:, 1] - lo[1]) <= 1e-7 * size, np.abs(bverts[:, 1] - hi[1]) <= 1e-7 * size
        span = np.ptp(bverts, axis=0)
        covers = span[0] >= 0.9 * (hi[0] - lo[0]) and span[2] >= 0.5 * (hi[2] - lo[2])
        if (np.all(on_plane[0]) or np.all(on_plane[1])) and covers:
            half = True  # one side, open along its flat centre plane (the whole profile)
            side_y = lo[1] if np.all(on_plane[0]) else hi[1]
            if not half_hull:
                raise MeshError(
                    f"{source}: the mesh is OPEN along the whole of its flat side y = {side_y:.6g} m [body frame] "
                    f"({topo['boundary_edges'].shape[0]} boundary edges, all on that plane): it is a HALF hull (one "
                    "side, open on the centre plane). Give half_hull=True (CLI --half-hull) to mirror it into the "
                    "whole hull, or export the whole hull."
                )
        else:
            off = bverts[~(on_plane[0] | on_plane[1])]
            bad = off[0] if off.shape[0] else bverts[0]
            top = np.abs(bverts[:, 2] - hi[2]) <= 1e-7 * size
            wetted = top.any() and np.all(top | on_plane[0] | on_plane[1])
            if wetted and np.ptp(bverts[top, 0]) >= 0.9 * (hi[0] - lo[0]):
                raise MeshError(
                    f"{source}: the mesh is OPEN at its top: its {topo['boundary_edges'].shape[0]} boundary "
                    f"edge(s) lie on z = {hi[2]:.6g} m [body frame], so it describes only a WETTED surface (as a "
                    "panel-code mesh does). jaxroll's hydrostatics at heel and in waves need the hull above the "
                    "waterline: export the whole hull, sides up to a closed deck."
                )
            raise MeshError(
                f"{source}: the mesh is OPEN: {topo['boundary_edges'].shape[0]} boundary edge(s) (used by one "
                f"triangle only), e.g. at {bad.round(4).tolist()} [m, body frame]. A hull must be a closed "
                "surface (deck and transom included) so that it has a volume; close the holes in your CAD tool "
                "(or export a half-hull open only along the centre plane and give --half-hull)."
            )
    elif half_hull:
        raise MeshError(
            f"{source}: half_hull=True (--half-hull) but the mesh is closed (no boundary edge): it is a whole hull, "
            "or a half hull closed by a face on the centre plane, which the mirror would put inside the hull. Leave "
            "--half-hull out for a whole hull; export a half hull open on its centre plane."
        )
    if half:
        tri = mirror_half_hull(tri, side_y)
    bad_edges = _inconsistent_edges(tri)
    if bad_edges and not fix_normals:
        _, n_flipped = orient_consistently(tri)
        raise MeshError(
            f"{source}: the triangles' orientations (normals) are inconsistent: {bad_edges} edge(s) are traversed "
            f"in the same direction by both of their triangles, and {n_flipped} of {tri.shape[0]} triangles face "
            "the other way from their neighbours. Exact hydrostatics need every normal outward: fix the export, or "
            "give fix_normals=True (CLI --fix-normals) to orient them consistently."
        )
    tri, n_reversed = orient_consistently(tri)
    pts = tri.reshape(-1, 3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = 0.0 if half else (lo[1] + hi[1]) / 2
    if half:
        centre = side_y
    tri = tri.copy()
    tri[:, :, 1] -= centre
    ext = hi - lo
    if not (ext[0] > ext[1] and ext[0] > ext[2]):
        raise MeshError(
            f"{source}: after the axes forward={forward}, up={up} the hull is {ext[0]:.4g} m long, "
            f"{ext[1]:.4g} m wide and {ext[2]:.4g} m high: a ship is longest along x. Check the file's axes "
            "(forward=, up=; CLI --forward, --up), e.g. forward='+y' or up='+y'."
        )
    sym = symmetry_defect(tri)
    if sym["section_offset"] > ASYMMETRY_TOLERANCE * sym["breadth"]:
        raise MeshError(
            f"{source}: the hull is not port–starboard symmetric: about its centre plane (the middle of its y "
            f"extent, file y = {centre:.6g} m) the centroid of the section at x = {sym['section_x'] - lo[0]:.4g} m "
            f"from the aft end lies {sym['section_offset']:.4g} m to one side (of the largest section's area), and "
            f"the half-breadths differ by up to {sym['max_difference']:.4g} m (starboard {sym['starboard']:.4g} m, "
            f"port {sym['port']:.4g} m at x = {sym['x'] - lo[0]:.4g} m, {sym['z'] - lo[2]:.4g} m above the lowest "
            f"point); the enclosed volume's centre is {sym['tcb']:.4g} m off the centre plane. jaxroll's GZ, GM and "
            f"roll model assume a symmetric hull (accepted: {ASYMMETRY_TOLERANCE * sym['breadth']:.3g} m, "
            f"{100 * ASYMMETRY_TOLERANCE:g} % of the breadth): check that the file holds the whole hull in one "
            "piece and its axes (--forward, --up)."
        )
    x0 = lo[0] if x_ap is None else float(x_ap)
    zb, datum, note = _datum(tri, baseline_z, source=source, zero_is_waterline=zero_is_waterline)
    if note:
        warnings.warn(note, stacklevel=2)
    tri[:, :, 0] -= x0
    tri[:, :, 2] -= zb
    loa = float(hi[0] - lo[0])
    if check_scale:
        check_ship_scale(loa, what=f"{source} (length overall)")
    if lpp is None:
        lpp = loa
        warnings.warn(
            f"{source}: no `lpp` given; using the length overall {loa:.4g} m with the AP at the aft end. The "
            "IMO criteria use L (and waves of length λ = L): give lpp= and x_ap= (CLI --lpp, --x-ap).",
            stacklevel=2,
        )
    if check_scale:
        check_ship_scale(float(lpp), what=source)
    plo, phi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
    st = np.linspace(plo[0], phi[0], stations) if np.ndim(stations) == 0 else np.asarray(stations, float)
    wl = (
        np.linspace(plo[2], phi[2], waterlines) if np.ndim(waterlines) == 0 else np.asarray(waterlines, float)
    )
    hb = slice_offsets(tri, st, wl)
    surface = hull_surface(tri, strips=strips) if exact else None
    method = (
        f"exact surface ({tri.shape[0]} triangles, {strips} wave strips)"
        if exact
        else f"sliced into {len(st)} stations x {len(wl)} waterlines"
    )
    return Hull(
        stations=st,
        waterlines=wl,
        half_breadths=hb,
        lpp=float(lpp),
        depth=float(max(phi[2], wl[-1])),
        surface=surface,
        name=name,
        datum=datum,
        provenance=(
            f"read from {source}: {tri.shape[0]} triangles{' (half-hull, mirrored)' if half else ''}"
            f"{f', {n_reversed} reversed to orient them outward' if n_reversed else ''}, units {units}, scale "
            f"{scale:g}, forward {forward}, up {up}, AP at file x = {x0:.6g} m, baseline at file z = {zb:.6g} m "
            f"({datum.source}), {method}"
        ),
    )


def read_stl_hull(path: str | Path, **kwargs) -> Hull:
    """`hull_from_triangles(read_stl(path), …)`: a jaxroll `Hull` from an STL file (see that function)."""
    path = Path(path)
    kwargs.setdefault("name", path.stem)
    return hull_from_triangles(read_stl(path), source=str(path), **kwargs)


def read_offsets_csv(
    path: str | Path,
    *,
    lpp: float | None = None,
    depth: float | None = None,
    units: str = "m",
    scale: float = 1.0,
    waterlines: np.ndarray | int | None = None,
    check_scale: bool = True,
    name: str | None = None,
) -> Hull:
    """A jaxroll `Hull` from an offsets CSV: one row per station, `x, y1, z1, y2, z2, …`.

    x from the AP, positive forward; (y, z) the starboard half-breadth and height above the baseline of the
    section's points, listed from the keel up (z non-decreasing). Rows may have different numbers of points.
    Lines starting with `#` are comments; `# lpp = 262` and `# depth = 24.45` set L and D in the file's units
    and scale like every other number (the keyword arguments `lpp`, `depth` are full-scale metres and win). A first row that is not numeric is a header. Each section is sampled at the common
    waterlines (default: the union of every z in the file) by linear interpolation along its points; below its
    lowest point the breadth is 0, above its highest the last breadth is held (vertical side to the deck).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"Offsets file {str(path)!r} does not exist.")
    if units not in UNITS:
        raise ValueError(f"units must be one of {sorted(UNITS)}; got {units!r}.")
    f = UNITS[units] * scale
    meta, rows = {}, []
    for i, line in enumerate(path.read_text().splitlines(), 1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = re.match(r"#\s*(lpp|depth)(?:_m)?\s*[=:]\s*(\S+)", s)
            if m:
                meta[m.group(1)] = float(m.group(2))
            continue
        cells = [c.strip() for c in next(csv.reader([s])) if c.strip()]
        try:
            vals = [float(c) for c in cells]
        except ValueError:
            if not rows:
                continue  # header
            raise ValueError(f"{path}:{i}: not a number in {cells!r}.") from None
        if len(vals) < 5 or len(vals) % 2 == 0:
            raise ValueError(
                f"{path}:{i}: a row is `x, y1, z1, y2, z2, …` (x then at least two (y, z) pairs); got "
                f"{len(vals)} values."
            )
        rows.append((i, vals))
    if len(rows) < 2:
        raise ValueError(f"{path}: need at least two stations; got {len(rows)}.")
    xs = np.array([v[0] for _, v in rows]) * f
    sections = []
    for i, v in rows:
        yz = np.asarray(v[1:], dtype=float).reshape(-1, 2) * f
        if np.any(np.diff(yz[:, 1]) < 0):
            raise ValueError(
                f"{path}:{i}: the section's z must not decrease (list the points from the keel up)."
            )
        if np.any(yz[:, 0] < 0):
            raise ValueError(
                f"{path}:{i}: half-breadths y must be >= 0 (starboard half, from the centre plane)."
            )
        sections.append(yz)
    order = np.argsort(xs)
    xs = xs[order]
    sections = [sections[k] for k in order]
    if np.any(np.diff(xs) <= 0):
        raise ValueError(f"{path}: two rows have the same station x.")
    zall = np.unique(np.concatenate([s[:, 1] for s in sections]))
    if waterlines is None:
        wl = zall
    elif np.ndim(waterlines) == 0:
        wl = np.linspace(zall[0], zall[-1], int(waterlines))
    else:
        wl = np.asarray(waterlines, float)
    hb = np.zeros((len(xs), len(wl)))
    for k, s in enumerate(sections):
        y, z = s[:, 0], s[:, 1]
        # np.interp needs strictly increasing z: a horizontal run (flat bottom, deck) keeps its outer breadth
        zu = np.unique(z)
        yu = np.array([np.max(y[z == zz]) for zz in zu])
        hb[k] = np.where(wl < zu[0] - 1e-12, 0.0, np.interp(wl, zu, yu))
    if lpp is None and "lpp" in meta:
        lpp = meta["lpp"] * f
    if lpp is None:
        lpp = float(xs[-1] - xs[0])
        warnings.warn(
            f"{path}: no L given (lpp= or '# lpp = …'); using the station span {lpp:.4g} m. The IMO criteria use L.",
            stacklevel=2,
        )
    depth = depth if depth is not None else (meta["depth"] * f if "depth" in meta else float(wl[-1]))
    if check_scale:
        check_ship_scale(float(lpp), what=str(path))
    return Hull(
        stations=xs,
        waterlines=wl,
        half_breadths=hb,
        lpp=float(lpp),
        depth=float(depth),
        name=name or path.stem,
        provenance=f"offsets CSV {path} (units {units}, scale {scale:g}), {len(xs)} stations x {len(wl)} waterlines",
    )


def write_offsets_csv(
    path: str | Path, stations, sections, *, lpp: float | None = None, depth: float | None = None
):
    """Write an offsets CSV (`x, y1, z1, …` per row) from stations and a list of (k, 2) arrays of (y, z)."""
    lines = []
    if lpp is not None:
        lines.append(f"# lpp = {lpp!r}")
    if depth is not None:
        lines.append(f"# depth = {depth!r}")
    lines.append("# x_m, then (y_m, z_m) pairs from the keel up")
    for x, s in zip(stations, sections):
        lines.append(", ".join([repr(float(x))] + [repr(float(v)) for v in np.asarray(s).ravel()]))
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


# --------------------------------------------------------------------------------------------------------------
# Test geometry: closed surfaces from offsets (used by the tests and the examples)
# --------------------------------------------------------------------------------------------------------------


def triangulate_offsets(stations, waterlines, half_breadths, *, depth: float | None = None) -> np.ndarray:
    """A closed triangulated surface (m, 3, 3) through station offsets: both sides, bottom, deck, end caps.

    Vertex columns lie on the stations and rows on the waterlines, so `slice_offsets` at the same stations and
    waterlines returns the same half-breadths. A zero half-breadth is allowed at the lowest waterline (a keel
    point); zero breadths over several waterlines of two neighbouring stations (a stem line) make the starboard
    and port faces coincide, which is not a 2-manifold surface: give such offsets a small breadth (e.g. 5 mm).
    """
    x = np.asarray(stations, float)
    z = np.asarray(waterlines, float)
    y = np.asarray(half_breadths, float)
    if depth is not None and depth > z[-1]:
        z = np.append(z, depth)
        y = np.concatenate([y, y[:, -1:]], axis=1)
    ns, nw = y.shape
    # section ring, counter-clockwise seen from ahead: starboard keel→deck, deck to port, port deck→keel
    ring_y = np.concatenate([y, -y[:, ::-1]], axis=1)  # (ns, 2 nw)
    ring_z = np.concatenate([z, z[::-1]])
    P = np.stack(
        [np.broadcast_to(x[:, None], ring_y.shape), ring_y, np.broadcast_to(ring_z, ring_y.shape)], -1
    )
    nr = P.shape[1]
    tris = []
    for i in range(ns - 1):
        for j in range(nr):
            a, b = P[i, j], P[i, (j + 1) % nr]
            c, d = P[i + 1, j], P[i + 1, (j + 1) % nr]
            tris += [(a, b, c), (b, d, c)]
    for i, flip in ((0, True), (ns - 1, False)):  # end caps: fan around the ring's centroid
        if not np.any(y[i] > 0):
            continue  # the section is a line (a stem): starboard and port meet, no cap
        ctr = P[i].mean(axis=0)
        for j in range(nr):
            a, b = P[i, j], P[i, (j + 1) % nr]
            tris.append((ctr, b, a) if flip else (ctr, a, b))
    return np.asarray(tris, dtype=float)


MESHIO_SUFFIXES = (".obj", ".ply", ".off", ".vtk", ".vtu", ".msh", ".mesh", ".medit", ".xdmf", ".nas", ".bdf")
"""Surface-mesh suffixes read through meshio (the optional extra `mesh`: `pip install "jaxroll[mesh]"`)."""

MESH_SUFFIXES = (".stl", ".gdf", ".csv", *MESHIO_SUFFIXES)
"""File suffixes read by [`read_hull`][] as a mesh (STL, WAMIT GDF, meshio's formats) or an offsets table (CSV);
anything else is a TOML hull file."""


def read_mesh(path: str | Path) -> np.ndarray:
    """Triangles (n, 3, 3) [file units] of a surface mesh in any format meshio reads (OBJ, PLY, OFF, VTK, VTU,
    Gmsh, Medit, …): its triangle cells, and its quadrilaterals split along a diagonal.

    **Raises:** `ImportError` (with the install command) without meshio; `MeshError` for a file with no surface
    cells or with volume cells only (a tetrahedral mesh: export its boundary surface), or non-finite coordinates.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"mesh file {str(path)!r} does not exist.")
    try:
        import meshio
    except ImportError:
        raise ImportError(
            f"{path}: reading {path.suffix} files needs meshio, an optional dependency: pip install "
            '"jaxroll[mesh]" (or pip install meshio); STL and WAMIT GDF files need nothing more.'
        ) from None
    try:
        mesh = meshio.read(str(path))
    except Exception as e:  # meshio raises many types for a malformed file
        raise MeshError(f"{path}: meshio could not read it ({type(e).__name__}: {e}).") from None
    pts = np.asarray(mesh.points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] < 2:
        raise MeshError(f"{path}: the points have shape {pts.shape}; a hull needs 3-D points.")
    if pts.shape[1] == 2:
        raise MeshError(f"{path}: the mesh is 2-D (points (x, y) only); a hull surface is 3-D.")
    parts, kinds = [], []
    for block in mesh.cells:
        kinds.append(block.type)
        data = np.asarray(block.data)
        if block.type == "triangle":
            parts.append(pts[data])
        elif block.type == "quad":
            parts += [pts[data[:, [0, 1, 2]]], pts[data[:, [0, 2, 3]]]]
    if not parts:
        raise MeshError(
            f"{path}: no triangle or quad cells (cells: {sorted(set(kinds)) or 'none'}). A hull file is the closed "
            "surface of the hull; export the surface (a tetrahedral volume mesh's boundary), not its volume cells."
        )
    return _checked_triangles(np.concatenate(parts).astype(float), path)


def read_hull(
    path: str | Path,
    *,
    lpp: float | None = None,
    x_ap: float | None = None,
    baseline_z: float | None = None,
    units: str = "m",
    scale: float = 1.0,
    forward: str = "+x",
    up: str = "+z",
    half_hull: bool = False,
    fix_normals: bool = False,
    exact: bool = True,
    stations: np.ndarray | int = 61,
    waterlines: np.ndarray | int = 41,
) -> tuple[Hull, dict[str, float]]:
    """Any hull file, chosen by its suffix: `.stl` ([`read_stl_hull`][]), `.gdf` (`read_gdf_hull`, WAMIT
    low-order), OBJ/PLY/OFF/VTK/VTU/Gmsh/… through meshio ([`read_mesh`][], optional extra `mesh`), `.csv`
    ([`read_offsets_csv`][]), else a TOML hull file (`read_hull_file`, whose `[loading]` table comes back too).

    **Arguments:** `path`; for meshes the reader options (`lpp` [m], `x_ap` [m], `baseline_z` [m], `units`,
    `scale`, `forward`, `up`, `half_hull`, `fix_normals`, `exact`, `stations`, `waterlines`: see
    [`hull_from_triangles`][]); a CSV takes `lpp`, `units`, `scale`, `waterlines`. For a GDF, `units="m"` (the
    default) means the unit its GRAV is given in (9.80665: m, 32.174: ft, …); another unit overrides GRAV's, with
    a warning. A TOML hull file is full scale in metres, so the options must keep their defaults there.

    **Returns:** `(hull, loading)`; `loading` is `{}` for STL and CSV (they carry no loading condition), and for
    a GDF `{"draught_m": T}` when its waterplane z = 0 lies inside the hull (WAMIT's frame: T above the
    baseline), the default draught of the loading.
    """
    from ._hull_file import read_hull_file

    path = Path(path)
    suffix = path.suffix.lower()
    mesh_kw = dict(
        lpp=lpp, x_ap=x_ap, baseline_z=baseline_z, scale=scale, forward=forward, up=up, half_hull=half_hull,
        fix_normals=fix_normals, exact=exact, stations=stations, waterlines=waterlines,
    )  # fmt: skip
    if suffix == ".stl":
        return read_stl_hull(path, units=units, **mesh_kw), {}
    if suffix in MESHIO_SUFFIXES:
        return hull_from_triangles(
            read_mesh(path), units=units, source=str(path), name=path.stem, **mesh_kw
        ), {}
    if suffix == ".gdf":
        from ._gdf import _read_gdf_hull

        hull, draught = _read_gdf_hull(path, units=None if units == "m" else units, **mesh_kw)
        return hull, ({} if draught is None else {"draught_m": draught})
    if suffix == ".csv":
        n_wl = None if np.ndim(waterlines) == 0 and waterlines == 41 else waterlines
        return read_offsets_csv(path, lpp=lpp, units=units, scale=scale, waterlines=n_wl), {}
    given = dict(x_ap=x_ap, baseline_z=baseline_z, forward=forward, up=up)
    changed = (
        [k for k, v in given.items() if v not in (None, "+x", "+z")]
        + (["lpp"] if lpp is not None else [])
        + [k for k, v in (("half_hull", half_hull), ("fix_normals", fix_normals)) if v]
    )
    if units != "m" or scale != 1.0 or changed:
        raise ValueError(
            f"{path}: a TOML hull file is full scale, SI, in jaxroll's axes; the mesh options (units, scale, "
            f"lpp, x_ap, baseline_z, forward, up, half_hull, fix_normals) apply to mesh and .csv files only; got {changed + ['units'] * (units != 'm') + ['scale'] * (scale != 1.0)}."
        )
    return read_hull_file(path)
