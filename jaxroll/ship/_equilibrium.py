r"""The quasi-static balance of a hull and what it gives: GZ(φ), GM, the upright particulars.

Sinkage and trim are balanced with `optimistix.Newton` so that the displaced mass equals the ship's mass and
LCB = LCG, in calm water, in a wave of length λ (default L) with its crest or trough amidships, and at every heel
(free trim); gradients pass through the balance by the implicit function theorem. The immersed integrals are those
of `jaxroll.ship._hydrostatics` (the offsets' sections, or a mesh's own surface, `jaxroll.ship._surface`).

**Batches and stored programs.** Each public function is one stored program (`jaxroll._compiled.cached_program`):
a later process loads it instead of tracing it, and JAX's persistent cache supplies its compiled code. The programs
hold no host callback — JAX's persistent cache does not keep a program that has one —: a failed balance is in
`result`, and `throw=True` raises on the host after the program has run (under `jit`/`grad`, by `eqx.error_if`).
Heel × wave cases are vmapped. Where the amplitudes are concrete, calm cases (ζ_mid = 0) are split off and
integrate a hull surface's unsplit triangles (the wave's strips are not needed). A vmapped Newton iteration runs
until its slowest case has converged, so every case starts at (d cos φ, 0) — the upright waterline turned about its
centre-line point, a wall-sided hull's exact sinkage, which also keeps a balance at 90° on the hull —: at most 5
steps for every case of the frigate's GZ tables in calm water and in ±6 m waves, to 90° (from the calm draught: up
to 7, and 46 with a failure at 90°). A first upright balance per amplitude to start the heeled ones from would save
one step more, and cost a second compiled balance.
"""

from __future__ import annotations

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._compiled import is_concrete
from . import _surface
from ._hull import Hull, _section_polygons
from ._hydrostatics import (
    Loading,
    _entry_point,
    _immersed_section_moments,
    _integrals,
    loading_condition,
    wave_elevation,
)

# Equilibrium tolerances: the balance residuals are in metres (volume error / (L B), LCB − LCG). Newton stops when
# its last step was below 1e-6 m; converging quadratically, the balance it returns is then exact to round-off
# (1e-14 m on the frigate's GZ table, as with 1e-9 m, one step fewer).
_NEWTON = optx.Newton(rtol=1e-8, atol=1e-6)
_MAX_STEPS = 32  # a vmapped batch runs its slowest case to the end: 5 steps from the start used here


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
        return _succeeded(self.result)


Equilibrium.__init__.__doc__ = """Fields (all [m] unless stated): `sinkage` (draught amidships,
earth-vertical), `trim` (d_FP − d_AP, positive by the head), `heel` [rad], `zeta_mid` (wave amplitude, > 0
trough amidships), `volume` [m³], `lcb` (from the AP), `gz` (righting lever about G, > 0 rights the ship),
`vertical_centre_of_buoyancy` (earth-vertical height of B above the baseline point on the centreline; KB when
upright), `result` (`optimistix.RESULTS`), `num_steps` (Newton steps).
"""


def _balance_residual(y, args):
    hull, loading, heel, zeta_mid, wavelength, calm = args
    if hull.surface is not None:  # only ∇ and ∫x dV, with closed-form Jacobians
        lam = hull.lpp if wavelength is None else wavelength
        args = (hull.surface, heel, y[0], y[1], zeta_mid, lam, hull.amidships, hull.lpp)
        volume, moment_x = _surface.balance_integrals(*args, calm=calm)
    else:
        ints = _integrals(hull, heel, y[0], y[1], zeta_mid, wavelength, calm)
        volume, moment_x = ints.volume, ints.moment_x
    scale = hull.lpp * hull.max_breadth
    return jnp.stack([(volume - loading.volume) / scale, (moment_x - loading.lcg * volume) / loading.volume])


def _equilibrium_single(hull, loading, heel, zeta_mid, wavelength, guess, calm: bool = False):
    sol = optx.root_find(
        _balance_residual,
        _NEWTON,
        guess,
        (hull, loading, heel, zeta_mid, wavelength, calm),
        max_steps=_MAX_STEPS,
        throw=False,
    )
    sinkage, trim = sol.value[0], sol.value[1]
    ints = _integrals(hull, heel, sinkage, trim, zeta_mid, wavelength, calm)
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
    """`result`; with `throw`, a failed balance raises `EquinoxRuntimeError` — on the host where `result` is
    concrete (the stored programs hold no host callback), by `eqx.error_if` under tracing."""
    if not throw:
        return result
    message = (
        f"The quasi-static balance (sinkage and trim) did not converge for {what}. This happens when the hull cannot "
        "float at that heel or wave (deck or keel far out of the water), or the offsets are inconsistent. Reduce the "
        "wave amplitude or heel range, check the loading condition, or pass throw=False and inspect "
        "`result`/`converged`."
    )
    if is_concrete(result):
        if not np.all(_succeeded(result)):
            raise eqx.EquinoxRuntimeError(message)
        return result
    return eqx.error_if(result, jnp.any(result != optx.RESULTS.successful), message)


def _succeeded(result):
    """Where `result` is `optx.RESULTS.successful`: compared on the host where it is concrete (a NumPy array; no
    program compiled for the comparison), in JAX under tracing."""
    if not is_concrete(result):
        return result == optx.RESULTS.successful
    (value,), (successful,) = jax.tree.leaves(result), jax.tree.leaves(optx.RESULTS.successful)
    return np.asarray(value) == np.asarray(successful)


def _calm_guess(loading, heel):
    """(sinkage, trim) (n, 2) [m] to start a balance at heels φ (n,): the upright waterline turned about its
    centre-line point, h = d cos φ (a wall-sided hull's exact sinkage), no trim."""
    return jnp.stack([loading.draught * jnp.cos(heel), jnp.zeros_like(heel)], axis=-1)


def _equilibrium_batch(
    hull, loading, heel, zeta_mid, wavelength, calm: bool = False, guess=None
) -> Equilibrium:
    """Balances at 1-D arrays of heels and amplitudes, one vmapped Newton solve (no throwing), started from `guess`
    (n, 2) (default: `_calm_guess`); `calm=True` where every amplitude is 0 (a hull surface then uses its unsplit
    triangles)."""
    if guess is None:
        guess = _calm_guess(loading, heel)
    fn = lambda p, z, g: _equilibrium_single(hull, loading, p, z, wavelength, g, calm)
    return jax.vmap(fn)(heel, zeta_mid, guess)


class _Cases(eqx.Module):
    """Concrete heel × wave cases, flattened, and the calm ones (ζ_mid = 0) and the wave ones by index."""

    heel: Array
    zeta_mid: Array
    calm: Array
    waves: Array


def _cases(heel, zeta_mid) -> tuple[tuple[int, ...], _Cases] | None:
    """(shape, cases) of broadcast heels and amplitudes, or None where the amplitudes are traced."""
    if not is_concrete(zeta_mid):
        return None
    z = np.asarray(zeta_mid, dtype=float)
    h = heel if not is_concrete(heel) else np.asarray(heel, dtype=float)
    shape = np.broadcast_shapes(np.shape(h), z.shape)
    z = np.broadcast_to(z, shape).ravel()
    h = (np if isinstance(h, np.ndarray) else jnp).broadcast_to(h, shape).ravel()
    put = lambda a: jax.device_put(np.ascontiguousarray(a))
    cases = _Cases(heel=put(h) if isinstance(h, np.ndarray) else h, zeta_mid=put(z), calm=put(np.flatnonzero(z == 0)),
                   waves=put(np.flatnonzero(z != 0)))  # fmt: skip
    return shape, cases


def _by_case(cases: _Cases, fn):
    """`fn(calm, index)` (a pytree of arrays with leading axis len(index)) for the calm and the wave cases,
    scattered back to the order of the cases."""
    n = cases.zeta_mid.shape[0]
    parts = [(idx, fn(flag, idx)) for flag, idx in ((True, cases.calm), (False, cases.waves)) if idx.shape[0]]
    scatter = lambda *leaves: functools.reduce(
        lambda acc, il: acc.at[il[0]].set(il[1]), zip([i for i, _ in parts], leaves),
        jnp.zeros((n, *leaves[0].shape[1:]), leaves[0].dtype),
    )  # fmt: skip
    return jax.tree.map(scatter, *[out for _, out in parts])


@_entry_point
def _equilibrium_cases(hull, loading, cases, wavelength, shape):
    solve = lambda calm, i: _equilibrium_batch(
        hull, loading, cases.heel[i], cases.zeta_mid[i], wavelength, calm
    )
    flat = _by_case(cases, solve)
    return jax.tree_util.tree_map(lambda a: a.reshape(shape + a.shape[1:]), flat)


@_entry_point
def _equilibrium_traced(hull, loading, heel, zeta_mid, wavelength):
    heel, zeta_mid = jnp.broadcast_arrays(jnp.asarray(heel, dtype=float), jnp.asarray(zeta_mid, dtype=float))
    flat = _equilibrium_batch(hull, loading, heel.ravel(), zeta_mid.ravel(), wavelength)
    return jax.tree_util.tree_map(lambda a: a.reshape(heel.shape + a.shape[1:]), flat)


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
    found = _cases(heel, zeta_mid)
    if found is None:
        out = _equilibrium_traced(hull, loading, heel, zeta_mid, wavelength)
    else:
        shape, cases = found
        out = _equilibrium_cases(hull, loading, cases, wavelength, shape)
    result = _check_result(out.result, throw, "this heel / wave")
    return eqx.tree_at(lambda e: e.result, out, result)


def _gm_at(hull, loading, sinkage, trim, zeta_mid, wavelength, calm: bool = False):
    """GM [m] = ∂GZ/∂φ at φ = 0 with sinkage and trim held (they are stationary in φ at φ = 0 by symmetry)."""

    def lever(phi):
        ints = _integrals(hull, phi, sinkage, trim, zeta_mid, wavelength, calm)
        return ints.moment_u / ints.volume

    _, dlever = jax.jvp(lever, (jnp.zeros(()),), (jnp.ones(()),))
    return dlever - loading.kg


@_entry_point
def _metacentric_cases(hull, loading, cases, wavelength, shape):
    def solve(calm, idx):
        zeta = cases.zeta_mid[idx]
        eq = _equilibrium_batch(hull, loading, jnp.zeros_like(zeta), zeta, wavelength, calm=calm)
        gm = jax.vmap(lambda s, t, z: _gm_at(hull, loading, s, t, z, wavelength, calm))(
            eq.sinkage, eq.trim, zeta
        )
        return gm, eq.result

    gm, result = _by_case(cases, solve)
    return gm.reshape(shape), result


@_entry_point
def _metacentric_traced(hull, loading, zeta_mid, wavelength):
    zeta = jnp.asarray(zeta_mid, dtype=float)
    eq = _equilibrium_batch(hull, loading, jnp.zeros(zeta.size), zeta.ravel(), wavelength)
    gm = jax.vmap(lambda s, t, z: _gm_at(hull, loading, s, t, z, wavelength))(
        eq.sinkage, eq.trim, zeta.ravel()
    )
    return gm.reshape(zeta.shape), eq.result


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
    found = _cases(0.0, zeta_mid)
    if found is None:
        gm, result = _metacentric_traced(hull, loading, zeta_mid, wavelength)
    else:
        gm, result = _metacentric_cases(hull, loading, found[1], wavelength, found[0])
    _check_result(result, throw, "this wave")
    return gm


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

    def to_xarray(self):
        """The particulars as an `xarray.Dataset` of scalars named as in `as_dict` (hydrostatics.json's
        `calm_water`), with units and long names."""
        from .._labels import tree_to_dataset
        from .._labels._layouts import PARTICULARS

        return tree_to_dataset(self.as_dict(), PARTICULARS)


Particulars.__init__.__doc__ = """Fields: `displacement` Δ [kg]; `volume` ∇ [m³]; `draught` amidships,
`draught_ap`, `draught_fp` [m]; `trim` = d_FP − d_AP [m]; `lcb`, `lcg`, `lcf` [m] from the AP; `kb`, `bm`,
`km`, `kg`, `gm` [m] (transverse); `bm_longitudinal`, `gm_longitudinal` [m] (trim moment of the waterplane
about the LCF); `waterplane_area` [m²]; `waterline_breadth` B_WL [m]; `block_coefficient` ∇/(Lpp B_WL d),
`midship_coefficient` A_M/(B_WL d), `prismatic_coefficient` C_B/C_M, `waterplane_coefficient` A_WP/(Lpp B_WL);
`result` of the balance.
"""


@_entry_point
def _particulars_program(hull, loading, zeta_mid, wavelength, calm):
    zeta = jnp.asarray(zeta_mid, dtype=float)
    heel = jnp.zeros((1,))
    eq = _equilibrium_batch(hull, loading, heel, zeta[None], wavelength, calm=calm)
    eq = jax.tree_util.tree_map(lambda a: a[0], eq)
    gm = _gm_at(hull, loading, eq.sinkage, eq.trim, zeta, wavelength, calm)
    return _particulars(hull, loading, eq, gm, zeta, wavelength, calm)


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
    calm = is_concrete(zeta_mid) and bool(np.all(np.asarray(zeta_mid) == 0))
    out = _particulars_program(hull, loading, zeta_mid, wavelength, calm)
    _check_result(out.result, throw, "the upright balance")
    return out


def _at_most_one(x, tol: float = 1e-9):
    """`x`, with values in (1, 1 + tol] (round-off of a form coefficient that is exactly 1) set to 1."""
    return jnp.where((x > 1) & (x <= 1 + tol), 1.0, x)


def _particulars(hull, loading, eq: Equilibrium, gm, zeta, wavelength, calm: bool = False) -> Particulars:
    zero = jnp.zeros(())
    s, t = eq.sinkage, eq.trim
    km = gm + loading.kg

    def vol_mx(y):
        ints = _integrals(hull, zero, y[0], y[1], zeta, wavelength, calm)
        return jnp.stack([ints.volume, ints.moment_x])

    jac = jax.jacfwd(vol_mx)(jnp.stack([s, t]))
    awp = jac[0, 0]
    lcf = jac[1, 0] / awp
    xm, lpp = hull.amidships, hull.lpp
    # ∂∫xA/∂trim = ∫ b x (x − xm) dx / L and ∂∇/∂trim = ∫ b (x − xm) dx / L, b the waterline breadth.
    i_xm = lpp * (jac[1, 1] - xm * jac[0, 1])  # ∫ b (x − xm)² dx
    i_l = i_xm - awp * (lcf - xm) ** 2
    bm_l = i_l / eq.volume

    if hull.surface is not None:
        lam = hull.lpp if wavelength is None else wavelength
        b_wl = _surface.waterline_breadth(hull.surface, s, t, zeta, lam, xm, lpp)
        a_mid = _surface.section_area(hull.surface, xm, s + zeta * (-1.0))  # η(L/2) = −ζ_mid
    else:
        ys, zs = _section_polygons(hull)
        h = s + t * (hull.stations - xm) / lpp + wave_elevation(hull, zeta, wavelength)
        area, breadth = jax.jvp(
            lambda hh: _immersed_section_moments(ys, zs, zero, hh)[0], (h,), (jnp.ones_like(h),)
        )
        b_wl = jnp.max(breadth)
        a_mid = jnp.interp(xm, hull.stations, area)
    # A box's coefficients are 1; round-off of the integrals must not push them past it (a ship file refuses > 1)
    cb = _at_most_one(eq.volume / (lpp * b_wl * s))
    cm = _at_most_one(a_mid / (b_wl * s))
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
