r"""Exact hydrostatics of a closed triangulated hull surface: the polyhedron clipped by the water surface.

A hull read from a mesh (STL, GDF, meshio formats) keeps its triangles (`HullSurface`, in `Hull.surface`), and
every immersed integral is computed from them, exactly for the polyhedron the user gave — no stations, no
waterlines, no quadrature error.

**Method (no cap, no triangulation of the waterplane).** With w(x, y, z) = h(x) − (z cos φ − y sin φ) the depth
below the water surface (h(x): the surface's earth-vertical height at station x; φ: heel) and
n_v = (0, −sin φ, cos φ) the earth-vertical unit vector in the body frame, every vector field F = −w g n_v with
n_v·∇g = 0 has div F = g and vanishes on the water surface w = 0. By the divergence theorem the integrals over
the immersed volume are integrals over the wetted part of the hull surface alone:

$$\int_V g\,dV = -\int_{S,\,w\ge 0} w\,g\,(n_v\cdot n)\,dS, \quad g \in \{1, x, u, h(x)\}, \qquad
\int_V w\,dV = -\int_{S,\,w\ge 0} \tfrac12 w^2\,(n_v\cdot n)\,dS,$$

with u = y cos φ + z sin φ (horizontal, to starboard). The water surface cap contributes nothing, so each
triangle is clipped to w ≥ 0 on its own (a polygon of at most 4 vertices, fanned from a point on the waterline,
where the fan's closing triangle has no area) and the integrands — products of two functions linear on the
triangle — are integrated exactly by the 3-point edge-midpoint rule. Vectorised over triangles with `jnp.where`,
differentiable (the clip points move smoothly with sinkage, trim, heel and the wave).

**Waves.** In calm water h(x) = s + t (x − L/2)/L is linear and the result is exact. In a wave the surface
h(x) + η(x) is curved; the surface is split once (`split_at_planes`) at `strips` equally spaced planes x = x_k, and
in each strip η is replaced by its L²-projection on linear functions (the same mean and first moment over the strip).
F has no x-component, so the strip planes carry no flux and the per-strip surfaces need not join: the clip is exact
for them, and the only error is the projection's, O((kΔx)⁴) in the integrals (k = 2π/λ): ΔGM of a box in a 3 m
wave, λ = L, is off by 1.5 mm with 5 strips, 0.1 mm with 10, 6 µm with 20 (24 by default).

**Trim** is the small-angle shear of `jaxroll.ship._hydrostatics` (the water surface h(x) in the body frame;
the immersed body is exact for that surface, the GZ lever is measured transversely).
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

TRIANGLE_BUCKETS = tuple(int(512 * 2 ** (k / 4)) // 64 * 64 for k in range(0, 41))
"""Padded triangle counts (512 · 2^(k/4), multiples of 64: at most 19 % padding): every hull of a size class runs
the same compiled programs (padding triangles have no area and add nothing)."""

DEFAULT_WAVE_STRIPS = 24
"""Strips along x for waves (Δx = length/24); the error of the L²-projected wave is O((kΔx)⁴) (module docstring)."""


def bucket_size(n: int) -> int:
    """The padded size for `n` triangles: the smallest bucket ≥ n (beyond the table, the next multiple of 8192)."""
    for b in TRIANGLE_BUCKETS:
        if b >= n:
            return b
    return -(-n // 8192) * 8192


class HullSurface(eqx.Module):
    """A closed, outward-oriented triangulated hull surface in jaxroll's body frame (x from the AP, y to
    starboard, z up from the baseline) [m], with its copy split into strips along x for waves.

    Build it with [`hull_surface`][]. Vertices are stored coordinate-major, `vertices[c, v, i]` = coordinate c of
    vertex v of triangle i, so that the integrals run over contiguous arrays. Padding triangles (all vertices at the
    origin) have no area.
    """

    vertices: Float[Array, "3 3 n"]
    wave_vertices: Float[Array, "3 3 m"]
    wave_strips: Float[Array, "2 m"]
    n_triangles: int = eqx.field(static=True)
    strips: int = eqx.field(static=True)

    @property
    def triangles(self) -> Float[Array, "n 3 3"]:
        """The triangles (n, 3, 3) [m] (vertex, coordinate), padding included."""
        return jnp.transpose(self.vertices, (2, 1, 0))

    @property
    def wave_triangles(self) -> Float[Array, "m 3 3"]:
        """The triangles split into strips (m, 3, 3) [m], padding included."""
        return jnp.transpose(self.wave_vertices, (2, 1, 0))


def split_at_planes(triangles: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """The triangles (n, 3, 3) cut by the planes x = planes[k] so that none crosses a plane: each cut triangle
    becomes a triangle and a quadrilateral (two triangles), in the same orientation. The cut points of an edge are
    the same for both triangles that share it, so the result is a conforming mesh of the same surface."""
    tri = np.asarray(triangles, float)
    for xk in np.asarray(planes, float):
        x = tri[:, :, 0]
        cut = (x.min(axis=1) < xk) & (x.max(axis=1) > xk)
        if not cut.any():
            continue
        keep, t = tri[~cut], tri[cut]
        side = t[:, :, 0] > xk  # (m, 3)
        # rotate each triangle so that vertex 0 is the one alone on its side (order, so orientation, kept)
        lone = np.where(side.sum(axis=1) == 1, np.argmax(side, axis=1), np.argmax(~side, axis=1))
        idx = (lone[:, None] + np.arange(3)[None, :]) % 3
        t = np.take_along_axis(t, idx[:, :, None], axis=1)
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        pab = a + ((xk - a[:, 0]) / (b[:, 0] - a[:, 0]))[:, None] * (b - a)
        pac = a + ((xk - a[:, 0]) / (c[:, 0] - a[:, 0]))[:, None] * (c - a)
        pab[:, 0] = xk
        pac[:, 0] = xk
        new = np.concatenate(
            [np.stack([a, pab, pac], 1), np.stack([pab, b, c], 1), np.stack([pab, c, pac], 1)], axis=0
        )
        tri = np.concatenate([keep, new], axis=0)
    return tri


def _pad(tri: np.ndarray, n: int) -> np.ndarray:
    return np.concatenate([tri, np.zeros((n - tri.shape[0], 3, 3))], axis=0)


def hull_surface(triangles: np.ndarray, *, strips: int = DEFAULT_WAVE_STRIPS) -> HullSurface:
    """A [`HullSurface`][] from closed, outward-oriented triangles (n, 3, 3) in the body frame [m].

    `strips`: equally spaced strips over the surface's x extent in which a wave surface is taken linear (see the
    module's docstring for its error). Both triangle sets are padded to [`bucket_size`][]."""
    tri = np.asarray(triangles, float)
    x0, x1 = float(tri[..., 0].min()), float(tri[..., 0].max())
    edges = np.linspace(x0, x1, strips + 1)
    wave = split_at_planes(tri, edges[1:-1])
    centre = wave[..., 0].mean(axis=1)
    k = np.clip(np.searchsorted(edges, centre) - 1, 0, strips - 1)
    bounds = np.stack([edges[k], edges[k + 1]], axis=1)
    n, m = bucket_size(tri.shape[0]), bucket_size(wave.shape[0])
    pad_bounds = np.concatenate([bounds, np.tile([[0.0, 1.0]], (m - bounds.shape[0], 1))])
    soa = lambda t: jax.device_put(
        np.ascontiguousarray(np.transpose(t, (2, 1, 0)))
    )  # placed, nothing compiled
    return HullSurface(
        vertices=soa(_pad(tri, n)),
        wave_vertices=soa(_pad(wave, m)),
        wave_strips=jax.device_put(np.ascontiguousarray(pad_bounds.T)),
        n_triangles=int(tri.shape[0]),
        strips=int(strips),
    )


def translate_surface(surface: HullSurface, dx) -> HullSurface:
    """The surface moved by `dx` [m] along x (padding included: it has no area wherever it is)."""
    shift = jnp.stack([dx, jnp.zeros_like(dx), jnp.zeros_like(dx)])[:, None, None]
    return eqx.tree_at(
        lambda s: (s.vertices, s.wave_vertices, s.wave_strips),
        surface,
        (surface.vertices + shift, surface.wave_vertices + shift, surface.wave_strips + dx),
    )


def scale_surface(surface: HullSurface, length, breadth, height) -> HullSurface:
    """The surface stretched by factors along x, y, z (differentiable in the factors)."""
    f = jnp.stack([jnp.asarray(length, float), jnp.asarray(breadth, float), jnp.asarray(height, float)])
    return eqx.tree_at(
        lambda s: (s.vertices, s.wave_vertices, s.wave_strips),
        surface,
        (
            surface.vertices * f[:, None, None],
            surface.wave_vertices * f[:, None, None],
            surface.wave_strips * f[0],
        ),
    )


# ------------------------------------------------------------------------------------------------------------
# The clip and the integrals
# ------------------------------------------------------------------------------------------------------------


def _tri_integrals(fields, pairs):
    """Closed-form integrals over triangles of products of fields linear on each triangle, against the
    earth-vertical area element dS_ζ: `fields` maps a name to the three vertices' values (arrays), `pairs` lists
    (f, g) names (g None: ∫f). ∫f = A Σf/3, ∫f g = A (Σ f g + Σf Σg)/12, A = the (x, u) area of the triangle."""
    (x0, x1, x2), (u0, u1, u2) = fields["x"], fields["u"]
    area = 0.5 * ((x1 - x0) * (u2 - u0) - (u1 - u0) * (x2 - x0))
    sums = {k: v[0] + v[1] + v[2] for k, v in fields.items()}
    out = []
    for f, g in pairs:
        if g is None:
            out.append(area * sums[f] / 3)
        else:
            F, G = fields[f], fields[g]
            out.append(area * (F[0] * G[0] + F[1] * G[1] + F[2] * G[2] + sums[f] * sums[g]) / 12)
    return out


# ∫dV, ∫x dV, ∫u dV, 2∫w dV, ∫h dV as surface integrals of −(w, w x, w u, w², w h) dS_ζ
_MOMENTS = (("w", None), ("w", "x"), ("w", "u"), ("w", "w"), ("w", "h"))
# their derivatives with respect to the sinkage s and the trim t (∂h/∂s = 1, ∂h/∂t = τ = (x − L/2)/L; the
# boundary terms vanish because w = 0 on the waterline): −∫(1, x, u, h) dS_ζ and −∫(1, x, u, h) τ dS_ζ
_SLOPES = (("one", None), ("x", None), ("u", None), ("h", None), ("one", "tau"), ("x", "tau"), ("u", "tau"),
           ("h", "tau"))  # fmt: skip
# and their heel derivatives' waterplane terms (∂w/∂φ = u): −∫(u, x u, u², h u) dS_ζ (`_moments_jvp`)
_HEEL_SLOPES = (("u", None), ("x", "u"), ("u", "u"), ("h", "u"))


_BALANCE = (("w", None), ("w", "x"))  # ∇ and ∫x dV: what the sinkage–trim balance needs
_BALANCE_SLOPES = (("one", None), ("x", None), ("one", "tau"), ("x", "tau"))


def _clipped(verts, h, tau, heel, pairs):
    """Integrals −∫_{wet} f g dS_ζ (`pairs` as for `_tri_integrals`) over the part of the triangles below the
    surface: `verts` (3 coordinates, 3 vertices, n), `h` and `tau` (3, n) linear fields at the vertices.

    Each triangle's wet part is the whole triangle (all three vertices wet), the corner at its lone vertex (the one
    on the other side of the waterline from the two others) when that vertex alone is wet, or the whole minus that
    corner when it alone is dry: two closed-form triangle integrals per triangle, no gather."""
    c, s = jnp.cos(heel), jnp.sin(heel)
    x, y, z = verts[0], verts[1], verts[2]
    u = y * c + z * s
    w = h - (z * c - y * s)
    wet = w >= 0
    one = jnp.ones_like(x)
    f3 = lambda q: (q[0], q[1], q[2])
    needed = {"x", "u", "w"} | {k for pair in pairs for k in pair if k is not None}
    fields = {k: f3(v) for k, v in dict(x=x, u=u, w=w, h=h, tau=tau, one=one).items() if k in needed}
    full = _tri_integrals(fields, pairs)
    lone0 = wet[1] == wet[2]
    lone1 = (wet[0] == wet[2]) & ~lone0
    pick = lambda q, k: jnp.where(lone0, q[(0 + k) % 3], jnp.where(lone1, q[(1 + k) % 3], q[(2 + k) % 3]))
    all_wet = wet[0] & wet[1] & wet[2]
    partial = ~all_wet & (wet[0] | wet[1] | wet[2])
    wl, wn, wp = pick(fields["w"], 0), pick(fields["w"], 1), pick(fields["w"], 2)
    tn = jnp.where(partial, wl / jnp.where(partial, wl - wn, 1.0), 0.0)
    tp = jnp.where(partial, wl / jnp.where(partial, wl - wp, 1.0), 0.0)
    corner_fields = {}
    for k, q in fields.items():
        a, b, cc = pick(q, 0), pick(q, 1), pick(q, 2)
        corner_fields[k] = (a, a + tn * (b - a), a + tp * (cc - a))
    corner = _tri_integrals(corner_fields, pairs)
    lone_wet = partial & pick(f3(wet), 0)
    lone_dry = partial & ~lone_wet
    # wet = full (all wet or lone dry) ± corner; one reduction for all the integrals (XLA would otherwise recompute
    # the clip in each of them: 2× slower)
    keep_full, sign = all_wet | lone_dry, jnp.where(lone_wet, 1.0, jnp.where(lone_dry, -1.0, 0.0))
    parts = [jnp.where(keep_full, f, 0.0) + sign * k for f, k in zip(full, corner)]
    return list(-jnp.sum(jnp.stack(parts), axis=-1))


def _strip_wave(surface: HullSurface, x, zeta_mid, wavelength, amidships):
    """η at the points x (3, n) of the wave triangles: in each strip [m − a, m + a] the L²-projection of
    η = −ζ cos(k (x − L/2)) on linear functions, c0 + c1 (x − m) (exact mean and first moment over the strip)."""
    lo, hi = surface.wave_strips[0], surface.wave_strips[1]
    m, a = (lo + hi) / 2, (hi - lo) / 2
    k = 2 * jnp.pi / wavelength
    ka = k * a
    theta = k * (m - amidships)
    small = ka < 1e-3
    ka_s = jnp.where(small, 1.0, ka)
    sinc = jnp.where(small, 1 - ka**2 / 6, jnp.sin(ka_s) / ka_s)  # sin(ka)/(ka)
    # 3 (sin(ka) − ka cos(ka)) / (ka)³, → 1 as ka → 0
    g = jnp.where(small, 1 - ka**2 / 10, 3 * (jnp.sin(ka_s) - ka_s * jnp.cos(ka_s)) / ka_s**3)
    c0 = -zeta_mid * jnp.cos(theta) * sinc
    c1 = zeta_mid * k * jnp.sin(theta) * g
    return c0 + c1 * (x - m)


def _heights(surface, sinkage, trim, zeta_mid, wavelength, amidships, lpp, calm):
    """(vertices, h, τ): the triangles used and the water surface's height h and ∂h/∂trim = τ at their vertices."""
    verts = surface.vertices if calm else surface.wave_vertices
    tau = (verts[0] - amidships) / lpp
    h = sinkage + trim * tau
    if not calm:
        h = h + _strip_wave(surface, verts[0], zeta_mid, wavelength, amidships)
    return verts, h, tau


@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def _moments(calm, surface, heel, sinkage, trim, zeta_mid, wavelength, amidships, lpp):
    verts, h, tau = _heights(surface, sinkage, trim, zeta_mid, wavelength, amidships, lpp, calm)
    vol, mx, mu, ww, mh = _clipped(verts, h, tau, heel, _MOMENTS)
    return jnp.stack([vol, mx, mu, mh - ww / 2])


def _moments_jvp(calm, primals, tangents):
    """Where only the heel, sinkage and trim carry tangents (the balance's Newton Jacobian, GM = ∂GZ/∂φ), closed-form
    slopes: more integrands of the same clip, for the arguments that have tangents; otherwise forward-mode through
    the clip.

    With ∂w/∂s = 1, ∂w/∂t = τ, ∂w/∂φ = u and w = 0 on the water surface, d/dq ∫_V g dV = ∫_V ∂g/∂q dV +
    ∫_WP g ∂w/∂q dA′ (dA′ = dA/|∇w|, so ∫_WP f dA′ = −∫_wet f dS_ζ for f independent of the surface); of the moments
    only Z = h − w (∂Z/∂s = ∂Z/∂t = 0, ∂Z/∂φ = −u) and u (∂u/∂φ = Z) depend on q:
    d(∇, ∫x, ∫u, ∫Z)/dφ = (∫_WP u, ∫_WP x u, ∫Z dV + ∫_WP u², −∫u dV + ∫_WP h u)."""
    surface, heel, sinkage, trim, zeta_mid, wavelength, amidships, lpp = primals
    t_other = jax.tree.leaves((tangents[0], *tangents[4:]))
    if all(_known_zero(t) for t in t_other):
        verts, h, tau = _heights(surface, sinkage, trim, zeta_mid, wavelength, amidships, lpp, calm)
        groups = [
            (t, g)
            for t, g in zip(tangents[1:4], (_HEEL_SLOPES, _SLOPES[:4], _SLOPES[4:]))
            if not _known_zero(t)
        ]
        out = _clipped(verts, h, tau, heel, _MOMENTS + sum((g for _, g in groups), ()))
        vol, mx, mu, ww, mh = out[:5]
        mz = mh - ww / 2
        tangent, k = jnp.zeros(4), 5
        for t, g in groups:
            d = out[k : k + 4]
            d = [d[0], d[1], mz + d[2], -mu + d[3]] if g is _HEEL_SLOPES else d
            tangent, k = tangent + jnp.stack(d) * t, k + 4
        return jnp.stack([vol, mx, mu, mz]), tangent
    plain = lambda *p: _moments.fun(calm, *p)
    return jax.jvp(plain, primals, tuple(_instantiate(t, p) for t, p in zip(tangents, primals)))


def _known_zero(t) -> bool:
    """A symbolic-zero tangent, or one known to be zero without looking at traced values."""
    return isinstance(t, jax.custom_derivatives.SymbolicZero) or _is_zero(t)


_moments.defjvp(_moments_jvp, symbolic_zeros=True)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def _balance(calm, surface, heel, sinkage, trim, zeta_mid, wavelength, amidships, lpp):
    verts, h, tau = _heights(surface, sinkage, trim, zeta_mid, wavelength, amidships, lpp, calm)
    return jnp.stack(_clipped(verts, h, tau, heel, _BALANCE))


def _balance_jvp(calm, primals, tangents):
    surface, heel, sinkage, trim, zeta_mid, wavelength, amidships, lpp = primals
    t_other = jax.tree.leaves((tangents[0], tangents[1], *tangents[4:]))
    if all(isinstance(t, jax.custom_derivatives.SymbolicZero) or _is_zero(t) for t in t_other):
        verts, h, tau = _heights(surface, sinkage, trim, zeta_mid, wavelength, amidships, lpp, calm)
        out = _clipped(verts, h, tau, heel, _BALANCE + _BALANCE_SLOPES)
        zero = lambda t: 0.0 if isinstance(t, jax.custom_derivatives.SymbolicZero) else t
        ds, dt = jnp.stack(out[2:4]), jnp.stack(out[4:6])
        return jnp.stack(out[:2]), ds * zero(tangents[2]) + dt * zero(tangents[3])
    plain = lambda *p: _balance.fun(calm, *p)
    return jax.jvp(plain, primals, tuple(_instantiate(t, p) for t, p in zip(tangents, primals)))


_balance.defjvp(_balance_jvp, symbolic_zeros=True)


def balance_integrals(
    surface: HullSurface, heel, sinkage, trim, zeta_mid, wavelength, amidships, lpp, *, calm: bool = False
):
    """(volume [m³], ∫x dV [m⁴]) as [`surface_integrals`][] gives them, computing only these two (the balance's
    residual; its sinkage and trim derivatives are closed-form)."""
    f = lambda v: jnp.asarray(v, dtype=float)
    out = _balance(
        calm, surface, f(heel), f(sinkage), f(trim), f(zeta_mid), f(wavelength), f(amidships), f(lpp)
    )
    return out[0], out[1]


def _is_zero(t) -> bool:
    """A tangent known to be zero without looking at traced values (float0, or a concrete all-zero array)."""
    if getattr(t, "dtype", None) == jax.dtypes.float0:
        return True
    try:
        return not np.any(np.asarray(t))
    except Exception:  # traced
        return False


def _instantiate(t, p):
    sz = jax.custom_derivatives.SymbolicZero
    return jax.tree.map(
        lambda a, b: jnp.zeros_like(b) if isinstance(a, sz) else a, t, p, is_leaf=lambda v: isinstance(v, sz)
    )


def surface_integrals(
    surface: HullSurface, heel, sinkage, trim, zeta_mid, wavelength, amidships, lpp, *, calm: bool = False
):
    """(volume, ∫x dV, ∫u dV, ∫Z dV) [m³, m⁴] of the hull below the water surface h(x) = s + t (x − L/2)/L + η(x),
    η = −ζ_mid cos(2π (x − L/2)/λ) (L²-projected on linear functions in each strip), at heel φ; Z = h − w is the
    earth-vertical height above the baseline point on the centre plane. `calm=True` uses the unsplit triangles
    (η ignored: only where ζ_mid is 0). Differentiable in every argument; the sinkage and trim derivatives are
    closed-form integrals (cheap Newton Jacobians)."""
    f = lambda v: jnp.asarray(v, dtype=float)
    out = _moments(
        calm, surface, f(heel), f(sinkage), f(trim), f(zeta_mid), f(wavelength), f(amidships), f(lpp)
    )
    return out[0], out[1], out[2], out[3]


def waterline_breadth(surface: HullSurface, sinkage, trim, zeta_mid, wavelength, amidships, lpp):
    """Largest breadth [m] of the upright waterline: max y − min y over the points where the surface crosses the
    water surface."""
    tri = surface.wave_triangles
    eta = _strip_wave(surface, surface.wave_vertices[0], zeta_mid, wavelength, amidships).T
    h = sinkage + trim * (tri[..., 0] - amidships) / lpp + eta
    w = h - tri[..., 2]
    wb = jnp.roll(w, -1, axis=1)
    cross = (w >= 0) != (wb >= 0)
    t = jnp.where(cross, w / jnp.where(cross, w - wb, 1.0), 0.0)
    y = tri[..., 1] + t * (jnp.roll(tri[..., 1], -1, axis=1) - tri[..., 1])
    big = jnp.asarray(1e300)
    return jnp.max(jnp.where(cross, y, -big)) - jnp.min(jnp.where(cross, y, big))


def section_area(surface: HullSurface, x, h):
    """Area [m²] of the upright section x = const of the body below the level z = h (the midship area)."""
    tri = surface.triangles
    side = tri[..., 0] >= x
    cut = jnp.any(side, axis=1) & ~jnp.all(side, axis=1)
    nxt = lambda a: jnp.roll(a, -1, axis=1)
    crosses = (side != nxt(side)) & cut[:, None]
    pa, pb = tri, nxt(tri)
    t = jnp.where(crosses, (x - pa[..., 0]) / jnp.where(crosses, pb[..., 0] - pa[..., 0], 1.0), 0.0)
    p = pa + t[..., None] * (pb - pa)  # (n, 3, 3)
    order = jnp.argsort(~crosses, axis=1, stable=True)[:, :2]
    q = jnp.take_along_axis(p, order[:, :, None], axis=1)  # the two cut points
    y0, z0, y1, z1 = q[:, 0, 1], q[:, 0, 2], q[:, 1, 1], q[:, 1, 2]
    normal = jnp.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    # orient each segment counter-clockwise in (y, z): the outward normal on its right
    flip = (z1 - z0) * normal[:, 1] - (y1 - y0) * normal[:, 2] < 0
    y0, y1 = jnp.where(flip, y1, y0), jnp.where(flip, y0, y1)
    z0, z1 = jnp.where(flip, z1, z0), jnp.where(flip, z0, z1)
    w0, w1 = h - z0, h - z1
    in0, in1 = w0 >= 0, w1 >= 0
    crossing = in0 != in1
    tc = jnp.where(crossing, w0 / jnp.where(crossing, w0 - w1, 1.0), 0.0)
    ya = jnp.where(in0, y0, y0 + tc * (y1 - y0))
    yb = jnp.where(in1, y1, y0 + tc * (y1 - y0))
    wa, wb = jnp.where(in0, w0, 0.0), jnp.where(in1, w1, 0.0)
    keep = cut & (in0 | in1)
    return jnp.sum(jnp.where(keep, (yb - ya) * (wa + wb) / 2, 0.0))
