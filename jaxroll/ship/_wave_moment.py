r"""The direct roll moment of the incident wave on the hull (Froude–Krylov), any heading.

A long-crested regular wave of amplitude a, frequency ω and heading χ (docs/conventions.md: 0 following, π/2 beam,
π head) has, in deep water, the elevation η = Re[a e^{i(ωt − k(ξ cos χ + y sin χ))}] and the pressure

$$p = \rho g a\, e^{k\zeta}\, e^{i(\omega t - k(\xi\cos\chi + y\sin\chi))}, \qquad k = \omega^2/g,$$

ξ = x − L/2 [m] forward of amidships, y [m] to starboard, ζ = z − h(x) [m] up from the equilibrium waterline (≤ 0
on the wetted hull). So waves of χ ∈ (0, π) travel to starboard: they come from **port**. The Froude–Krylov roll
moment about the centre of gravity G (on the centre plane, KG above the baseline) is the pressure integrated over
the wetted hull at its equilibrium waterline (n outward):

$$M = \int_S p\,\big[n_z (y - y_G) - n_y (z - KG)\big]\,dS,$$

positive when it heels the ship to starboard (φ > 0: starboard down), so that a heel φ of the ship in calm water
gives the restoring −ρ g ∇ GM φ. It is written M(t) = Re[F(ω, χ) a e^{iωt}]: F [N m/m] is the transfer function,
complex, its phase relative to the wave elevation at amidships on the centre plane.

**Method (exact for the offsets' hull).** On the surface of stations x and section contours (y(x, s), z(x, s)),
the y and z components of the vector area element are those of the section contour, n_y dS = ∂z/∂s ds dx and
n_z dS = −∂y/∂s ds dx, whatever the hull's slope along x: so M = ∫ e^{−iκξ} m(x) dx with κ = k cos χ and m(x) the
contour integral of the section at x. Each section is the offsets' polygon (`jaxroll.ship._hull`), clipped at the
waterline; on each of its straight edges the integrand is a linear function times the exponential of a linear one,
integrated in closed form. Along x the section integrals are taken linear between stations — as the hydrostatics
take the section areas and moments (the trapezoid rule) — and integrated against e^{−iκξ} exactly (Filon's rule).
So F is exact for the hull whose hydrostatics jaxroll computes: as k → 0, F/(k a) → i ρ g ∇ GM sin χ, the moment of
the tilted free surface, with the ∇ and GM of `jaxroll.ship.hydrostatic_particulars` (to round-off; tested). A hull
read from a mesh is integrated over its sliced offsets. Ends of the hull (a transom) have n_y = n_z = 0 and add
nothing. Differentiable in the offsets, KG, the waterline, ω and χ.

Per unit roll inertia, as the roll equation needs it (φ̈ + … = M_w): M_w = M / I44 with
I44 = Δ g GM0 / ω0² [kg m²] — the inertia the roll period implies, added inertia included (`roll_inertia`).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Complex, Float

from ._equilibrium import equilibrium
from ._hull import Hull, _concrete, _section_polygons
from ._hydrostatics import GRAVITY, Loading, _entry_point
from ._ship import Ship


def _complex(x):
    """A real array as complex (the same precision): explicit, as JAX's strict type promotion asks."""
    x = jnp.asarray(x)
    return jax.lax.complex(x, jnp.zeros_like(x))


_SERIES = 1.0  # |c| below which the exponential moments are summed as series
_TERMS = 20  # series terms: |c|^20/20! < 5e-19 for |c| < 1


def _exp_moments(c0, c1):
    """(∫₀¹ e^{c0 + c1 s} ds, ∫₀¹ s e^{c0 + c1 s} ds) for complex c0, c1 (Re(c0), Re(c0 + c1) ≤ 0 where it matters).

    Closed forms (e^{c0+c1} − e^{c0})/c1 and ((c1 − 1) e^{c0+c1} + e^{c0})/c1², which never overflow, and for
    |c1| < 1 their Taylor series (no cancellation); the unused branch is fed a safe argument (finite gradients)."""
    small = jnp.abs(c1) < _SERIES
    e0 = jnp.exp(c0)
    big = jnp.where(small, jnp.ones_like(c1), c1)
    e1 = jnp.exp(c0 + big)
    closed0 = (e1 - e0) / big
    closed1 = ((big - 1) * e1 + e0) / (big * big)
    c = jnp.where(small, c1, jnp.zeros_like(c1))
    s0 = jnp.zeros_like(c1)
    s1 = jnp.zeros_like(c1)
    term = jnp.ones_like(c1)  # c^n / n!
    for n in range(_TERMS):
        s0 = s0 + term / (n + 1)
        s1 = s1 + term / (n + 2)
        term = term * c / (n + 1)
    return jnp.where(small, e0 * s0, closed0), jnp.where(small, e0 * s1, closed1)


def _section_integrals(ys, zs, h, kg, k, sin_chi):
    """m(x)/(ρ g a) [m²] for every section: ∮ e^{k(z − h) − i k y sin χ} [−(y dy + (z − KG) dz)] over the wetted
    edges of each section polygon (counter-clockwise in (y, z), so n_y dl = dz, n_z dl = −dy)."""
    y0, z0 = ys, zs
    y1, z1 = jnp.roll(ys, -1, axis=1), jnp.roll(zs, -1, axis=1)
    w0, w1 = h[:, None] - z0, h[:, None] - z1  # depth below the waterline
    in0, in1 = w0 >= 0, w1 >= 0
    crossing = in0 != in1
    t_cross = jnp.where(crossing, jnp.clip(w0 / jnp.where(crossing, w0 - w1, 1.0), 0.0, 1.0), 0.0)
    t_a = jnp.where(in0, 0.0, t_cross)
    t_b = jnp.where(in1, 1.0, t_cross)
    keep = in0 | in1
    ya, za = y0 + t_a * (y1 - y0), z0 + t_a * (z1 - z0)
    dy = jnp.where(keep, (t_b - t_a) * (y1 - y0), 0.0)
    dz = jnp.where(keep, (t_b - t_a) * (z1 - z0), 0.0)
    alpha = -(ya * dy + (za - kg) * dz)  # −(Y dY + Z dZ) = −(alpha' + beta' s) ds along the edge
    beta = -(dy * dy + dz * dz)
    c0 = jax.lax.complex(k * (za - h[:, None]), -k * sin_chi * ya)
    c1 = jax.lax.complex(k * dz, -k * sin_chi * dy)
    i0, i1 = _exp_moments(c0, c1)
    return jnp.sum(_complex(alpha) * i0 + _complex(beta) * i1, axis=1)


def _filon_weights(x, kappa):
    """Weights W with Σ W_j f_j = ∫ f(x) e^{−iκx} dx for f linear between the nodes x (Filon's trapezoid)."""
    dx = jnp.diff(x)
    zero = jnp.zeros_like(dx)
    c0 = jax.lax.complex(zero, -kappa * x[:-1])
    c1 = jax.lax.complex(zero, -kappa * dx)
    i0, i1 = _exp_moments(c0, c1)
    left, right = _complex(dx) * (i0 - i1), _complex(dx) * i1
    pad = jnp.zeros(1, dtype=left.dtype)
    return jnp.concatenate([left, pad]) + jnp.concatenate([pad, right])


def _moment_one(hull: Hull, kg, h, rho, omega, heading):
    """F(ω, χ) [N m/m] for one frequency and heading."""
    k = omega * omega / GRAVITY
    ys, zs = _section_polygons(hull)
    m = _section_integrals(ys, zs, h, kg, k, jnp.sin(heading))
    w = _filon_weights(hull.stations - hull.amidships, k * jnp.cos(heading))
    return _complex(rho * GRAVITY) * jnp.sum(w * m)


@_entry_point
def _moment_program(hull, kg, sinkage, trim, rho, omega, heading):
    h = sinkage + trim * (hull.stations - hull.amidships) / hull.lpp
    flat = jnp.broadcast_arrays(omega, heading)
    shape = flat[0].shape
    pairs = jnp.stack([f.ravel() for f in flat], axis=1)
    out = jax.lax.map(lambda p: _moment_one(hull, kg, h, rho, p[0], p[1]), pairs, batch_size=64)
    return out.reshape(shape)


def froude_krylov_roll_moment(
    hull: Hull,
    loading: Loading,
    omega: ArrayLike,
    heading: ArrayLike,
    *,
    sinkage: ArrayLike | None = None,
    trim: ArrayLike | None = None,
) -> Complex[Array, "..."]:
    r"""The Froude–Krylov roll moment F(ω, χ) [N m per m of wave amplitude] of a long-crested regular wave on the
    hull, about the centre of gravity (module docstring: M(t) = Re[F a e^{iωt}], phase relative to the wave
    elevation at amidships; positive heels the ship to starboard; deep water).

    **Arguments:**

    - `hull`: the hull (its offsets; a mesh hull's sliced offsets); `loading`: its loading condition (KG, ρ, the
        mass that sets the waterline).
    - `omega`: wave frequency ω [rad/s] ≥ 0 (absolute, not encounter); array.
    - `heading`: χ [rad], the angle between the ship's course and the direction the waves travel: 0 following,
        π/2 beam, π head; χ ∈ (0, π) are waves from port (M(−χ) = −M(χ) for a hull symmetric port and starboard:
        waves from starboard). Broadcast with `omega`.
    - `sinkage` [m] (draught amidships), `trim` [m] (d_FP − d_AP): the waterline; by default the calm-water
        equilibrium of the loading ([`equilibrium`][]).

    **Returns:** complex F with the broadcast shape of `omega` and `heading` [N m/m].

    **Raises:** `ValueError` for a negative or non-finite frequency or a non-finite heading (concrete inputs).
    """
    for name, value, lower in (("omega", omega, 0.0), ("heading", heading, -math.inf)):
        c = _concrete(value)
        if c is not None and not (np.all(np.isfinite(c)) and np.all(c >= lower)):
            unit = "a frequency >= 0 [rad/s]" if name == "omega" else "an angle [rad]"
            raise ValueError(f"`{name}` must be finite, {unit}; got {value!r}.")
    if (sinkage is None) != (trim is None):
        raise ValueError("give both `sinkage` and `trim` [m], or neither (the calm-water equilibrium).")
    if sinkage is None:
        eq = equilibrium(hull, loading)
        sinkage, trim = eq.sinkage, eq.trim
    return _moment_program(hull, loading.kg, sinkage, trim, loading.water_density, omega, heading)


def roll_inertia(ship: Ship) -> Float[Array, ""]:
    """I44 [kg m²], the roll inertia (added inertia included) that the ship's roll period implies:
    Δ g GM0 / ω0², ω0 = 2π/Tφ (the roll equation per unit inertia has a1 = ω0²)."""
    return ship.displacement * GRAVITY * ship.gm0 / ship.omega0**2


class WaveMoment(eqx.Module):
    """The direct wave roll moment per unit roll inertia and unit wave amplitude, F(ω, χ)/I44 [rad/s² per m],
    tabulated over wave frequency and heading: what the roll equation's M_w needs (`jaxroll.WaveMomentExcitation`).

    Build it with [`wave_moment`][]. Between grid points the real and imaginary parts are interpolated linearly
    (exact at the grid's headings); above the last frequency F is taken as 0.
    """

    omega: Float[Array, " n"]
    headings: Float[Array, " m"]
    values: Complex[Array, "m n"]
    inertia: Float[Array, ""]
    source: str = eqx.field(static=True, default="froude-krylov")
    added_inertia: Float[Array, " n"] | None = None
    radiation_damping: Float[Array, " n"] | None = None

    def radiation(self, omega: ArrayLike) -> tuple[Float[Array, "..."], Float[Array, "..."]]:
        """(A44, B44) at frequencies ω [rad/s]: the added inertia [kg m²] and radiation damping [N m s/rad] about G
        of a BEM table (`source = "bem"`), linear between the table's frequencies, the last value above them.

        **Raises:** `ValueError` when the table carries no A44, B44 (a Froude–Krylov table)."""
        if self.added_inertia is None or self.radiation_damping is None:
            raise ValueError(
                f"this wave-moment table ({self.source}) carries no added inertia or radiation damping: "
                "compute it with the BEM (`jaxroll hydrostatics ... --wave-moment bem`)."
            )
        omega = jnp.asarray(omega, dtype=float)
        return jnp.interp(omega, self.omega, self.added_inertia), jnp.interp(
            omega, self.omega, self.radiation_damping
        )

    def transfer(self, omega: ArrayLike, heading: ArrayLike) -> Complex[Array, "..."]:
        """F(ω, χ)/I44 [rad/s² per m] at wave frequencies ω [rad/s] and a heading χ [rad] in the grid's range
        (scalar), 0 above the last frequency."""
        omega = jnp.asarray(omega, dtype=float)
        row = self.at_heading(heading)
        inside = omega <= self.omega[-1]
        re = jnp.interp(omega, self.omega, row.real)
        im = jnp.interp(omega, self.omega, row.imag)
        return jnp.where(inside, jax.lax.complex(re, im), jnp.zeros((), dtype=row.dtype))

    def per_inertia(self, inertia: ArrayLike) -> "WaveMoment":
        """The same moment F per another roll inertia I44 [kg m²] (e.g. `roll_inertia` of a ship whose Tφ or GM0
        differs from the one the table was made for): values × (`inertia` of the table / `inertia`)."""
        inertia = jnp.asarray(inertia, dtype=float)
        return eqx.tree_at(
            lambda t: (t.values, t.inertia), self, (self.values * _complex(self.inertia / inertia), inertia)
        )

    def at_heading(self, heading: ArrayLike) -> Complex[Array, " n"]:
        """The table's row at heading χ [rad] (scalar), linear between the grid's headings [rad/s² per m].

        **Raises:** `ValueError` for a (concrete) heading outside the table's headings: never extrapolated."""
        chi = jnp.asarray(heading, dtype=float)
        c, grid = _concrete(chi), _concrete(self.headings)
        if c is not None and grid is not None and not grid[0] - 1e-12 <= c <= grid[-1] + 1e-12:
            raise ValueError(
                f"heading χ = {float(c):.6g} rad is outside the wave-moment table's headings "
                f"({grid[0]:.6g}–{grid[-1]:.6g} rad): tabulate the moment there (`wave_moment(..., headings=...)`)."
            )
        if self.headings.size == 1:
            return self.values[0]
        j = jnp.clip(jnp.searchsorted(self.headings, chi, side="right") - 1, 0, self.headings.size - 2)
        t = (chi - self.headings[j]) / (self.headings[j + 1] - self.headings[j])
        return self.values[j] * _complex(1 - t) + self.values[j + 1] * _complex(t)


WaveMoment.__init__.__doc__ = """Fields: `omega`: wave frequencies ω [rad/s], increasing from 0; `headings`: χ [rad], increasing, in
[0, π]; `values`: F(ω, χ)/I44 [rad/s² per m of wave amplitude], complex, shape (headings, frequencies), phase
relative to the wave elevation at amidships; `inertia`: I44 [kg m²] that divides F; `source`: how F was computed
(`"froude-krylov"`, or `"bem"`: Froude–Krylov + diffraction); `added_inertia` A44(ω) [kg m²] and
`radiation_damping` B44(ω) [N m s/rad] about G on the same frequencies (a BEM table), or None.
"""


DEFAULT_OMEGA = np.linspace(0.0, 6.0, 601)
"""Wave frequencies [rad/s] of `wave_moment`'s default table (0–6 rad/s, step 0.01)."""
DEFAULT_HEADINGS = np.linspace(0.0, math.pi, 13)
"""Headings [rad] of `wave_moment`'s default table (0–180°, step 15°)."""


def ship_file_frequencies(draught: float) -> np.ndarray:
    """The wave frequencies [rad/s] `jaxroll hydrostatics --wave-moment` tabulates for a hull of `draught` d [m]:
    301 from 0 to max(6, √(g ln 10⁴ / d)) rad/s, past where the pressure at the keel has fallen to e^{−kd} = 10⁻⁴
    (a ship file of ~100 kB with 13 headings)."""
    return np.linspace(0.0, max(6.0, math.sqrt(GRAVITY * math.log(1e4) / float(draught))), 301)


def wave_moment(
    hull: Hull,
    loading: Loading,
    ship: Ship,
    *,
    omega: ArrayLike | None = None,
    headings: ArrayLike | None = None,
) -> WaveMoment:
    """The Froude–Krylov roll moment of `hull` in `loading` per unit inertia of `ship` (I44 = Δ g GM0/ω0²,
    [`roll_inertia`][]), tabulated: a [`WaveMoment`][].

    **Arguments:** `hull`, `loading`: as [`froude_krylov_roll_moment`][]; `ship`: the roll model whose inertia
    divides the moment (Δ, GM0 and Tφ of the same loading); `omega`: wave frequencies [rad/s], increasing from 0
    (default `DEFAULT_OMEGA`, 0–6 rad/s); `headings`: χ [rad], increasing, in [0, π] (default every 15°).

    **Raises:** `ValueError` for a grid that is not increasing, not finite, or (frequencies) does not start at 0.
    """
    omega = DEFAULT_OMEGA if omega is None else np.asarray(omega, dtype=float)
    headings = DEFAULT_HEADINGS if headings is None else np.atleast_1d(np.asarray(headings, dtype=float))
    _check_grid(omega, headings)
    moment = froude_krylov_roll_moment(hull, loading, omega[None, :], headings[:, None])
    return moment_table(omega, headings, moment, ship)


def _check_grid(omega: np.ndarray, headings: np.ndarray) -> None:
    if omega.ndim != 1 or omega.size < 2 or omega[0] != 0 or not np.all(np.diff(omega) > 0):
        raise ValueError(
            "`omega` must be a 1-D grid of wave frequencies [rad/s] increasing from 0, at least 2 values; "
            f"got {omega!r}."
        )
    if (
        headings.ndim != 1
        or not np.all(np.diff(headings) > 0)
        or not np.all((headings >= 0) & (headings <= math.pi))
    ):
        raise ValueError(f"`headings` must be increasing angles χ in [0, π] rad; got {headings!r}.")


def moment_table(
    omega: ArrayLike,
    headings: ArrayLike,
    moment: ArrayLike,
    ship: Ship,
    source: str = "froude-krylov",
    *,
    added_inertia: ArrayLike | None = None,
    radiation_damping: ArrayLike | None = None,
) -> WaveMoment:
    """A [`WaveMoment`][] from the roll moment F(ω, χ) [N m per m of wave amplitude] on a grid (e.g. read from a
    ship file): F / I44 of `ship` ([`roll_inertia`][]).

    **Arguments:** `omega` [rad/s], increasing from 0; `headings` χ [rad], increasing, in [0, π]; `moment`:
    complex F, shape (headings, frequencies), finite; `ship`: whose inertia divides F; `source`: how F was made;
    `added_inertia` A44(ω) [kg m²] ≥ 0 and `radiation_damping` B44(ω) [N m s/rad] ≥ 0 on `omega` (a BEM's), both or
    neither.

    **Raises:** `ValueError` for a grid as `wave_moment` refuses it, a moment of another shape or not finite, or
    A44, B44 of another length, not finite or negative.
    """
    omega = np.asarray(omega, dtype=float)
    headings = np.atleast_1d(np.asarray(headings, dtype=float))
    _check_grid(omega, headings)
    moment = jnp.asarray(moment)
    if moment.shape != (headings.size, omega.size) or not np.all(np.isfinite(np.asarray(moment))):
        raise ValueError(
            f"the wave moment must be finite, one row of {omega.size} frequencies per heading "
            f"({headings.size}); got shape {moment.shape}."
        )
    if (added_inertia is None) != (radiation_damping is None):
        raise ValueError("give both the added inertia A44(ω) and the radiation damping B44(ω), or neither.")
    radiation = None
    if added_inertia is not None:
        radiation = [np.asarray(x, dtype=float) for x in (added_inertia, radiation_damping)]
        for name, x in zip(("added inertia A44 [kg m²]", "radiation damping B44 [N m s/rad]"), radiation):
            if x.shape != omega.shape or not np.all(np.isfinite(x)) or np.any(x < 0):
                raise ValueError(
                    f"the {name} must be one finite value >= 0 per frequency ({omega.size}); got shape {x.shape}."
                )
    inertia = roll_inertia(ship)
    return WaveMoment(
        omega=jnp.asarray(omega),
        headings=jnp.asarray(headings),
        values=moment.astype(complex) / _complex(inertia),
        inertia=inertia,
        source=source,
        added_inertia=None if radiation is None else jnp.asarray(radiation[0]),
        radiation_damping=None if radiation is None else jnp.asarray(radiation[1]),
    )
