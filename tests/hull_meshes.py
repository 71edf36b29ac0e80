"""Closed triangulated test hulls generated here (no file copied from anywhere): structured meshes of analytic
forms — a frigate-like hull with an optional sonar dome, skeg and flare, a Wigley hull, prisms — for the mesh
reader's checks, the exact-surface hydrostatics and the benchmarks.

`ring_mesh(x, Y, Z)` closes a hull from its sections: station i's starboard contour (Y[i, j], Z[i, j]), j from
the keel (Y = 0) up to the deck edge, is mirrored to port; consecutive sections are joined by quadrilaterals (two
triangles), the deck and the end sections by fans. Vertex orders make every normal point outward.
"""

from __future__ import annotations

import numpy as np


def ring_mesh(x, Y, Z) -> np.ndarray:
    """Closed outward-oriented triangles (m, 3, 3) through the sections (see the module docstring)."""
    x, Y, Z = np.asarray(x, float), np.asarray(Y, float), np.asarray(Z, float)
    ns, nr = Y.shape
    # ring: starboard keel → deck edge, across the deck, port deck edge → keel (the keel point once)
    ring_y = np.concatenate([Y, -Y[:, ::-1][:, :-1]], axis=1)
    ring_z = np.concatenate([Z, Z[:, ::-1][:, :-1]], axis=1)
    P = np.stack([np.broadcast_to(x[:, None], ring_y.shape), ring_y, ring_z], axis=-1)  # (ns, 2nr-1, 3)
    m = P.shape[1]
    tris = []
    for i in range(ns - 1):
        for j in range(m):
            a, b = P[i, j], P[i, (j + 1) % m]
            c, d = P[i + 1, j], P[i + 1, (j + 1) % m]
            tris += [(a, c, b), (b, c, d)]
    for i, aft in ((0, True), (ns - 1, False)):
        ctr = P[i].mean(axis=0)
        for j in range(m):
            a, b = P[i, j], P[i, (j + 1) % m]
            tris.append((ctr, a, b) if aft else (ctr, b, a))
    tri = np.asarray(tris, float)[:, ::-1]  # outward normals
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return tri[area > 1e-12 * max(1.0, float(np.max(area)))]


def frigate(
    length=142.0,
    breadth=19.0,
    draught=6.15,
    depth=12.5,
    *,
    ns=61,
    nr=15,
    dome=0.0,
    skeg=0.0,
    flare=1.0,
    z0=0.0,
) -> np.ndarray:
    """A frigate-like hull (L, B, T, D [m]) with fine ends, a transom, flare above the waterline (`flare` × B/2 ×
    0.1 at the deck), an optional sonar dome of depth `dome` [m] below the keel near 0.93 L and an optional skeg
    of depth `skeg` [m] aft; z of the keel line = `z0` in the file. About 4 ns nr triangles."""
    xi = np.linspace(0.0, 1.0, ns)
    x = xi * length
    s = np.linspace(0.0, 1.0, nr)
    fwd = np.clip((xi - 0.45) / 0.55, 0, 1)
    aft = np.clip((0.3 - xi) / 0.3, 0, 1)
    plan = np.clip(1 - fwd**1.8, 0.003, 1) * (1 - 0.45 * aft**1.5)
    keel = np.zeros(ns)
    bump = np.clip(1 - ((xi - 0.93) / 0.05) ** 2, 0, None)
    keel -= dome * np.sqrt(bump)
    skeg_b = np.clip(1 - ((xi - 0.12) / 0.1) ** 2, 0, None)
    keel -= skeg * np.sqrt(skeg_b)
    Y = np.zeros((ns, nr))
    Z = np.zeros((ns, nr))
    for i in range(ns):
        z = keel[i] + (depth - keel[i]) * s**1.3
        zt = np.clip(z / draught, 0, None)
        sec = np.where(z < 0, 0.0, 1 - (1 - np.clip(zt, 0, 1)) ** 3)  # bilge: full near the waterline
        appendage = np.where(
            z < 0, 0.6 * np.sqrt(np.clip(1 - z / keel[i], 0, 1)) if keel[i] < 0 else 0.0, 0.0
        )
        above = np.clip((z - draught) / (depth - draught), 0, 1)
        y = breadth / 2 * plan[i] * sec * (1 + 0.1 * flare * above) + appendage
        y[0] = 0.0
        y[1:] = np.maximum(y[1:], 0.01)
        Y[i], Z[i] = y, z + z0
    return ring_mesh(x, Y, Z)


def box(length=100.0, breadth=20.0, depth=10.0, *, ns=11, nr=3) -> np.ndarray:
    """A box barge L × B × D as a ring mesh (flat bottom: the keel point at the centre of the bottom)."""
    x = np.linspace(0.0, length, ns)
    yb = np.linspace(0.0, breadth / 2, 3)
    Y = np.concatenate([yb, np.full(nr - 1, breadth / 2)])
    Z = np.concatenate([np.zeros(3), np.linspace(0.0, depth, nr)[1:]])
    return ring_mesh(x, np.tile(Y, (ns, 1)), np.tile(Z, (ns, 1)))


def cad_box(length=120.0, breadth=20.0, depth=12.0) -> np.ndarray:
    """A box L × B × D as the simplest CAD export writes it: 12 triangles, each face split by one diagonal (the
    same corner on every face), outward normals. Its diagonals pass through station × waterline points of a regular
    sampling grid wherever L/D is a ratio of small integers (issue 45)."""
    corner = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    v = corner * [length, breadth, depth] - [0.0, breadth / 2, 0.0]
    at = lambda i, j, k: 4 * i + 2 * j + k  # noqa: E731
    quads = [
        (at(0, 0, 0), at(0, 1, 0), at(0, 1, 1), at(0, 0, 1)),
        (at(1, 0, 0), at(1, 0, 1), at(1, 1, 1), at(1, 1, 0)),
        (at(0, 0, 0), at(0, 0, 1), at(1, 0, 1), at(1, 0, 0)),
        (at(0, 1, 0), at(1, 1, 0), at(1, 1, 1), at(0, 1, 1)),
        (at(0, 0, 0), at(1, 0, 0), at(1, 1, 0), at(0, 1, 0)),
        (at(0, 0, 1), at(0, 1, 1), at(1, 1, 1), at(1, 0, 1)),
    ]
    tri = v[np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    inward = np.einsum("ij,ij->i", tri.mean(axis=1) - v.mean(axis=0), normal) < 0
    tri[inward] = tri[inward][:, ::-1]
    return tri


def wigley(length=100.0, breadth=10.0, draught=6.25, depth=10.0, *, ns=81, nr=33) -> np.ndarray:
    """The Wigley hull y = (B/2)(1 − (2x'/L)²)(1 − (z'/T)²) (x' from amidships, z' below the waterline), wall-sided
    from the waterline to the deck, closed at the ends by a 5 mm wide stem (the ring mesh's minimum breadth)."""
    x = np.linspace(0.0, length, ns)
    z = draught * np.concatenate([np.linspace(0, 1, nr), [depth / draught]])
    xi = 2 * (x - length / 2) / length
    y = (
        breadth
        / 2
        * (1 - xi[:, None] ** 2)
        * (1 - ((draught - np.minimum(z, draught)) / draught)[None, :] ** 2)
    )
    y = np.maximum(y, 0.005)
    y[:, 0] = 0.0
    return ring_mesh(x, y, np.tile(z, (ns, 1)))


def asymmetric_prism(length=100.0, depth=10.0, port=8.0, starboard=(8.0, 10.0), ns=11) -> np.ndarray:
    """A prism whose port side is vertical at y = −port and whose starboard side flares from starboard[0] at the
    keel to starboard[1] at the deck (issue 37's hull)."""
    x = np.linspace(0.0, length, ns)
    P = []
    for xx in x:
        P.append(
            [
                [xx, 0.0, 0.0],
                [xx, starboard[0], 0.0],
                [xx, starboard[1], depth],
                [xx, -port, depth],
                [xx, -port, 0.0],
            ]
        )
    P = np.asarray(P)
    tris = []
    m = P.shape[1]
    for i in range(ns - 1):
        for j in range(m):
            a, b = P[i, j], P[i, (j + 1) % m]
            c, d = P[i + 1, j], P[i + 1, (j + 1) % m]
            tris += [(a, c, b), (b, c, d)]
    for i, aft in ((0, True), (ns - 1, False)):
        ctr = P[i].mean(axis=0)
        for j in range(m):
            a, b = P[i, j], P[i, (j + 1) % m]
            tris.append((ctr, a, b) if aft else (ctr, b, a))
    return np.asarray(tris, float)[:, ::-1]


def volume(tri) -> float:
    """Signed enclosed volume [m³] (> 0 for outward normals)."""
    tri = np.asarray(tri, float)
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


def modified_wigley(length=150.0, breadth=15.0, draught=9.375, depth=15.0, *, ns=121, nr=49) -> np.ndarray:
    """The modified Wigley hull of Journée (1992, Delft report 909; `tests/test_published_hulls.py`): with
    ξ = 2x'/L (x' from amidships) and ζ = z'/T (z' down from the waterline),
    y = (B/2) [(1 − ζ²)(1 − ξ²)(1 + 0.2 ξ²) + ζ²(1 − ζ⁸)(1 − ξ²)⁴], wall-sided from the waterline to the deck.
    Stations and waterlines are cosine-spaced (fine at the ends and at the keel, where the form turns fastest);
    the ends are closed by a 5 mm wide stem (the ring mesh's minimum breadth)."""
    x = length / 2 * (1 - np.cos(np.linspace(0.0, np.pi, ns)))
    zeta = np.cos(np.linspace(0.0, np.pi / 2, nr))  # 1 at the keel → 0 at the waterline
    z = np.concatenate([draught * (1 - zeta), [depth]])
    xi = (2 * (x - length / 2) / length)[:, None]
    zz = np.concatenate([zeta, [0.0]])[None, :]
    y = breadth / 2 * ((1 - zz**2) * (1 - xi**2) * (1 + 0.2 * xi**2) + zz**2 * (1 - zz**8) * (1 - xi**2) ** 4)
    y = np.maximum(y, 0.005)
    y[:, 0] = 0.0
    return ring_mesh(x, y, np.tile(z, (ns, 1)))
