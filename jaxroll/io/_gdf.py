r"""Hulls from WAMIT low-order geometric data files (`.gdf`): panels → the STL reader's triangles → the same path.

**Format** (WAMIT's low-order GDF; the higher-order B-spline form, IGDEF ≠ 0, is refused):

```
title line (ignored)
ULEN GRAV         reference length (WAMIT's non-dimensional outputs only) and the acceleration of gravity
ISX ISY           1 where x = 0 (ISX) or y = 0 (ISY) is a plane of symmetry and only one side is given
NPAN              number of panels (a second integer, IGDEF, must be 0 if present)
x1 y1 z1 x2 y2 z2 x3 y3 z3 x4 y4 z4     one quadrilateral panel: 12 numbers, on one line or spread over several
...                                      (a triangle repeats a vertex)
```

Text after the numbers of lines 2–4 is a comment (files often say `1.0 9.80665   ULEN GRAV`); numbers may be
separated by blanks or commas and may use Fortran's `D` exponent.

**Units.** The coordinates are dimensional, in the length unit GRAV is given in: GRAV = 9.80665 (±3 %) is metres,
32.174 feet, 386.09 inches, 9806.65 millimetres, … ULEN is WAMIT's reference length for non-dimensional outputs:
it scales nothing and is only checked (> 0). `units=` overrides GRAV's unit with a warning (a file whose GRAV
disagrees with its coordinates); a GRAV that is no known unit's g reads as metres, with a warning.

**Axes.** WAMIT's body frame has z up with z = 0 the free surface (the still waterplane of a floating body), x
and y as the user chose them; ship files usually put x forward, y to port, the origin amidships on the waterline.
The triangles go through [`hull_from_triangles`][] exactly as an STL's do (`forward`, `up`, `x_ap`, `scale`,
`lpp`: jaxroll's frame, x from the AP, z from the baseline), so the checks are the same (closed, 2-manifold,
symmetric, plausible length). ISX/ISY are expanded first: the given part is mirrored about x = 0 and/or y = 0
(it must lie on one side of each such plane, with no panel in it), so the symmetry plane is closed by the mirror.

**Wetted surface only.** A GDF for a floating body usually describes only the surface below z = 0, open at the
waterplane. jaxroll's hydrostatics in waves and at heel need the hull above the still waterline (a crest
amidships, a heeled deck edge), so such a file is refused: a mesh with nothing above z = 0 (open there, or closed
by a lid on it) raises `MeshError` ("only the WETTED surface"). A closed GDF of the whole hull (deck included) is
read; its z = 0 is then the file's waterline, and [`read_hull`][] returns that draught (metres above the keel)
as the loading's default `draught_m`.
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np

from ..ship._hull import Hull
from ._mesh import UNITS, MeshError, hull_from_triangles, to_body_frame

GRAVITY = 9.80665
"""Standard gravity [m/s²]; GRAV / GRAVITY is the number of file length units per metre."""

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][+-]?\d+)?")


def _float(token: str) -> float:
    return float(token.replace("D", "E").replace("d", "e"))


def _leading_numbers(line: str) -> list[float]:
    """The numbers at the start of a header line; the rest of the line is a comment."""
    out = []
    for tok in re.split(r"[\s,]+", line.strip()):
        if not _NUMBER.fullmatch(tok):
            break
        out.append(_float(tok))
    return out


def _parse(path: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    """(header, panels (n, 4, 3) as given, the line of each panel's first number) of a low-order GDF."""
    if not path.is_file():
        raise FileNotFoundError(f"GDF file {str(path)!r} does not exist.")
    lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    if len(lines) < 4:
        raise MeshError(
            f"{path}: a WAMIT GDF starts with 4 header lines (title; ULEN GRAV; ISX ISY; NPAN); the file has "
            f"{len(lines)} line(s)."
        )
    ulen_grav = _leading_numbers(lines[1])
    if len(ulen_grav) < 2 or not all(math.isfinite(v) and v > 0 for v in ulen_grav[:2]):
        raise MeshError(
            f"{path}:2: expected `ULEN GRAV` (two numbers > 0: WAMIT's reference length and the acceleration of "
            f"gravity in the file's length unit); got {lines[1].strip()!r}."
        )
    sym = _leading_numbers(lines[2])
    if len(sym) < 2 or any(v not in (0.0, 1.0) for v in sym[:2]):
        raise MeshError(
            f"{path}:3: expected `ISX ISY` (each 0, or 1 for a plane of symmetry x = 0 or y = 0); got "
            f"{lines[2].strip()!r}."
        )
    counts = _leading_numbers(lines[3])
    if not counts or not math.isfinite(counts[0]) or counts[0] != int(counts[0]) or counts[0] < 1:
        raise MeshError(
            f"{path}:4: expected `NPAN` (the number of panels, an integer >= 1); got {lines[3].strip()!r}."
        )
    if len(counts) > 1 and counts[1] != 0:
        raise MeshError(
            f"{path}:4: IGDEF = {counts[1]:g} after the panel count: a higher-order WAMIT geometry (B-splines or "
            "a subroutine), which jaxroll does not read. Export a low-order GDF (flat panels, IGDEF = 0) or an STL."
        )
    npan = int(counts[0])
    values, where = [], []
    for i, line in enumerate(lines[4:], 5):
        for tok in re.split(r"[\s,]+", line.strip()):
            if not tok:
                continue
            if not _NUMBER.fullmatch(tok):
                k = len(values)
                raise MeshError(
                    f"{path}:{i}: {tok!r} is not a number (panel {k // 12 + 1} of NPAN = {npan}, vertex "
                    f"{k % 12 // 3 + 1}): a panel is 4 vertices x y z, 12 numbers."
                )
            values.append(_float(tok))
            where.append(i)
    need = 12 * npan
    if len(values) < need:
        last = where[-1] if where else 4
        raise MeshError(
            f"{path}:{last}: the file ends after {len(values)} numbers of panel data, but NPAN = {npan} (line 4) "
            f"needs 12 x {npan} = {need} (4 vertices x y z per panel): it is TRUNCATED in panel "
            f"{len(values) // 12 + 1}, or NPAN is wrong."
        )
    if len(values) > need:
        extra = len(values) - need
        held = f"it holds {len(values) // 12} panels: set NPAN = {len(values) // 12}" if len(values) % 12 == 0 else (
            f"{len(values)} numbers are not a whole number of panels")  # fmt: skip
        raise MeshError(
            f"{path}:{where[need]}: {extra} number(s) after the NPAN = {npan} panels of line 4: the panel count is "
            f"wrong ({held})."
        )
    panels = np.asarray(values, dtype=float).reshape(npan, 4, 3)
    if not np.all(np.isfinite(panels)):
        k = int(np.argmax(~np.all(np.isfinite(panels), axis=(1, 2))))
        raise MeshError(f"{path}:{where[12 * k]}: panel {k + 1} has a non-finite coordinate (NaN or inf).")
    header = dict(
        title=lines[0].strip(),
        ulen=ulen_grav[0],
        grav=ulen_grav[1],
        isx=int(sym[0]),
        isy=int(sym[1]),
        npan=npan,
    )
    return header, panels, np.asarray(where[::12])


def _expand_symmetry(panels: np.ndarray, lines: np.ndarray, header: dict, path) -> np.ndarray:
    """Mirror the panels about x = 0 (ISX = 1) and/or y = 0 (ISY = 1); the given part must lie on one side."""
    size = float(np.max(np.ptp(panels.reshape(-1, 3), axis=0)))
    tol = 1e-9 * max(size, 1e-300)
    for axis, flag, name in ((0, header["isx"], "ISX"), (1, header["isy"], "ISY")):
        if not flag:
            continue
        c = panels[..., axis]
        ax = "xy"[axis]
        if c.min() < -tol and c.max() > tol:
            raise MeshError(
                f"{path}:3: {name} = 1 says {ax} = 0 is a plane of symmetry and the file gives one side of it, but "
                f"the panels lie on both sides ({ax} from {c.min():.6g} to {c.max():.6g}). Set {name} = 0 for a "
                "file that describes the whole body."
            )
        in_plane = np.all(np.abs(c) <= tol, axis=1)
        if np.any(in_plane):
            k = int(np.argmax(in_plane))
            raise MeshError(
                f"{path}:{lines[k]}: panel {k + 1} lies in the plane of symmetry {ax} = 0 ({name} = 1): the "
                "mirror would double it. A half-body file is open along its plane of symmetry; remove the panel."
            )
        panels = panels.copy()
        panels[..., axis] = np.where(np.abs(c) <= tol, 0.0, c)  # on the plane exactly, so the halves weld
        mirror = panels[:, ::-1].copy()  # reversed vertex order: the mirror keeps the normals outward
        mirror[..., axis] *= -1.0
        panels = np.concatenate([panels, mirror])
        lines = np.concatenate([lines, lines])
    return panels


def panels_to_triangles(panels: np.ndarray) -> np.ndarray:
    """Quadrilaterals (n, 4, 3) → triangles (m, 3, 3): (1, 2, 3) and (1, 3, 4), without those that a repeated
    vertex (a triangular panel) makes degenerate."""
    p = np.asarray(panels, dtype=float)
    tri = np.concatenate([p[:, [0, 1, 2]], p[:, [0, 2, 3]]])
    same = lambda a, b: np.all(tri[:, a] == tri[:, b], axis=1)
    return tri[~(same(0, 1) | same(1, 2) | same(0, 2))]


def read_gdf(path: str | Path) -> np.ndarray:
    """Triangles (n, 3, 3) [file units] of a WAMIT low-order GDF, with ISX/ISY symmetry expanded.

    The same array [`read_stl`][] returns for an STL: each panel is split along its 1–3 diagonal, a triangular
    panel (a repeated vertex) gives one triangle. Raises `MeshError` (a `ValueError`) naming the line for a
    malformed file: a header line that is not `ULEN GRAV` / `ISX ISY` / `NPAN`, a non-numeric value, fewer or more
    numbers than 12 NPAN, a half-body file that crosses its plane of symmetry.
    """
    return _read(Path(path))[1]


def _read(path: Path) -> tuple[dict, np.ndarray]:
    header, panels, lines = _parse(path)
    tri = panels_to_triangles(_expand_symmetry(panels, lines, header, path))
    if tri.shape[0] == 0:
        raise MeshError(f"{path}: every panel is degenerate (no area).")
    return header, tri


def gdf_unit(grav: float) -> str | None:
    """The length unit in which GRAV is the standard gravity (within 3 %), or None."""
    for name, metres in UNITS.items():
        if abs(grav * metres / GRAVITY - 1.0) <= 0.03:
            return name
    return None


def read_gdf_hull(path: str | Path, *, units: str | None = None, **kwargs) -> Hull:
    """A jaxroll `Hull` from a WAMIT low-order GDF: [`read_gdf`][] then [`hull_from_triangles`][].

    `units`: None (default) takes the unit GRAV is given in (9.80665 → m, 32.174 → ft, …; metres with a warning
    when GRAV is no unit's g); a unit name overrides it (with a warning where they differ). The other keywords are
    [`hull_from_triangles`][]'s (`lpp`, `x_ap` in the file's x origin, `scale`, `forward`, `up`, `stations`, …).
    Raises `MeshError` for a file that describes nothing above its waterplane z = 0 (the wetted surface only).
    """
    return _read_gdf_hull(Path(path), units=units, **kwargs)[0]


def _read_gdf_hull(path: Path, *, units: str | None = None, **kwargs) -> tuple[Hull, float | None]:
    """(hull, the draught [m above the baseline] of the file's waterplane z = 0, or None when z = 0 is not inside)."""
    header, tri = _read(path)
    grav_unit = gdf_unit(header["grav"])
    if units is None:
        units = grav_unit or "m"
        if grav_unit is None:
            warnings.warn(
                f"{path}: GRAV = {header['grav']:g} on line 2 is not the acceleration of gravity in a known unit "
                f"(9.80665 m/s², 32.174 ft/s², …); reading the coordinates as metres. Give units= (CLI --units) "
                "if they are not.",
                stacklevel=3,
            )
    elif grav_unit is not None and units != grav_unit:
        warnings.warn(
            f"{path}: units={units!r} overrides the unit of GRAV = {header['grav']:g} on line 2 ({grav_unit}); "
            "WAMIT would read the file in the unit of GRAV.",
            stacklevel=3,
        )
    if units not in UNITS:
        raise ValueError(f"units must be one of {sorted(UNITS)}; got {units!r}.")
    scale = kwargs.get("scale", 1.0)
    body = to_body_frame(
        tri * UNITS[units] * (scale if math.isfinite(scale) and scale > 0 else 1.0),
        forward=kwargs.get("forward", "+x"),
        up=kwargs.get("up", "+z"),
    )
    z = body[..., 2]
    size = float(np.max(np.ptp(body.reshape(-1, 3), axis=0)))
    if z.max() <= 1e-6 * size:
        raise MeshError(
            f"{path}: nothing of the body is above the waterplane z = 0 (highest point z = {z.max():.4g} m): the "
            "file describes only the WETTED surface, as a GDF for WAMIT does (open at the waterline, or closed by "
            "a lid on it). jaxroll's hydrostatics at heel and in waves (a crest amidships) need the hull above "
            "the waterline: export the whole hull, sides up to a closed deck, as a GDF or an STL."
        )
    kwargs.setdefault("name", path.stem)
    hull = hull_from_triangles(tri, units=units, source=str(path), zero_is_waterline=True, **kwargs)
    zb = hull.datum.baseline_file_z
    draught = float(-zb) if zb < -1e-6 * size else None
    note = (
        f"; WAMIT GDF '{header['title']}', ULEN {header['ulen']:g}, GRAV {header['grav']:g} (unit {units}), "
        f"ISX {header['isx']}, ISY {header['isy']}, {header['npan']} panels"
        + (f", waterplane z = 0 at draught {draught:.6g} m" if draught is not None else "")
    )
    hull = Hull(
        stations=hull.stations, waterlines=hull.waterlines, half_breadths=hull.half_breadths, lpp=hull.lpp,
        depth=hull.depth, surface=hull.surface, name=hull.name, provenance=hull.provenance + note, datum=hull.datum,
    )  # fmt: skip
    return hull, draught


def write_gdf(
    path: str | Path,
    panels: np.ndarray,
    *,
    ulen: float = 1.0,
    grav: float = GRAVITY,
    isx: int = 0,
    isy: int = 0,
    title: str = "written by jaxroll",
) -> Path:
    """Write a low-order GDF: `panels` (n, 4, 3) quadrilaterals or (n, 3, 3) triangles (the third vertex repeated),
    one panel per line."""
    p = np.asarray(panels, dtype=float)
    if p.shape[1:] == (3, 3):
        p = p[:, [0, 1, 2, 2]]
    lines = [
        title,
        f"{ulen!r} {grav!r}   ULEN GRAV",
        f"{int(isx)} {int(isy)}   ISX ISY",
        f"{p.shape[0]}   NPAN",
    ]
    lines += [" ".join(f"{v:.12g}" for v in q.ravel()) for q in p]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)
