r"""From hull hydrostatics to the roll model: the GZ(ζ_mid, φ) table, its polynomial fits, and a `Ship`.

The paper (Katsumura et al., arXiv 2407.02728, appendix A) obtains the non-memory relation ΔGM(ζ_mid) by
computing the GM of the hull in a wave of length L with its crest or trough amidships, for several wave
amplitudes, and fitting a 6th-order polynomial. [`hull_hydrostatics`][] computes that table (and the
calm-water GZ curve) with the balances of `jaxroll.ship._hydrostatics`, fits GZ ≈ GM0 φ + g3 φ³ + … + g9 φ⁹ and
ΔGM ≈ C1 ζ + … + C6 ζ⁶, and [`ship_from_hydrostatics`][] turns the fits into a roll-model `Ship`
(a_n = ω0² g_n / GM0, `[delta_gm]` C0..C6). Method and validation: `docs/hydrostatics.md`; signs:
`docs/conventions.md` (ζ_mid > 0 puts a trough amidships).
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Bool, Float

from .._compiled import as_float, cached_program
from .._config import require_float64
from ._equilibrium import Particulars, _check_result, _equilibrium_batch, _gm_at, _particulars
from ._hull import Hull, _bare, _concrete, c11_hull
from ._hydrostatics import GRAVITY, HYDROSTATICS_PROGRAM, Loading, c11_hull_loading
from ._ship import Ship, c11_representative, restoring_fields_from_gz, validate_ship

_DEFAULT_ZETA_MAX = 6.0
_DEFAULT_N_ZETA = 13
_DEFAULT_HEEL_MAX = math.radians(70.0)
_DEFAULT_N_HEEL = 15


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
    curve_heels: Float[Array, " curve"] | None = None
    curve_zeta_mid: Float[Array, " 3"] | None = None
    gz_curves: Float[Array, "3 curve"] | None = None
    curves_converged: Bool[Array, "3 curve"] | None = None

    @property
    def gm0(self) -> Float[Array, ""]:
        """Calm-water upright GM [m]."""
        return self.particulars.gm

    @property
    def delta_gz(self) -> Float[Array, "zeta heels"]:
        """GZ(ζ, φ) − GZ(calm, φ) [m]."""
        return self.gz - self.gz_calm[None, :]

    def to_xarray(self):
        """The tables and fits as an `xarray.Dataset` named as in hydrostatics.json: `tables_gz_m`,
        `tables_sinkage_m`, `tables_trim_m`, `tables_converged` on (`zeta_mid_m`, `heel_deg`), `tables_gz_calm_m`,
        `tables_gm_m`, `tables_delta_gm_m`, the calm-water particulars (`calm_water_*`), the polynomial fits
        (`fits_*`), the balance check and `wavelength_m`."""
        from .._labels import Layout, tree_to_dataset
        from .._labels._layouts import HYDROSTATICS

        h = lambda x: np.asarray(x)  # noqa: E731
        tree = {
            "wavelength_m": float(self.wavelength),
            "calm_water": self.particulars.as_dict(),
            "tables": {
                "zeta_mid_m": h(self.zeta_mid),
                "heel_deg": np.degrees(h(self.heels)),
                "gz_m": h(self.gz),
                "sinkage_m": h(self.sinkage),
                "trim_m": h(self.trim),
                "gz_calm_m": h(self.gz_calm),
                "gm_m": h(self.gm),
                "delta_gm_m": h(self.delta_gm),
                "converged": h(self.converged),
            },
            "fits": {
                "gm0_m": float(self.particulars.gm),
                "gz_coefficients_m": dict(zip(("g3", "g5", "g7", "g9"), h(self.gz_coefficients).tolist())),
                "gz_fit_rms_m": float(self.gz_fit_rms),
                "delta_gm_coefficients": {
                    f"c{k}": float(c) for k, c in enumerate(h(self.delta_gm_coefficients))
                },
                "delta_gm_fit_rms_m": float(self.delta_gm_fit_rms),
            },
            "balance_check": {
                "max_relative_volume_error": float(self.max_volume_error),
                "max_lcb_minus_lcg_m": float(self.max_lcb_error),
                "all_converged": bool(np.all(h(self.converged))),
            },
        }
        extra = Layout(
            arrays={"tables/converged": ("zeta_mid_m", "heel_deg")},
            long_names={"tables_converged": "whether the sinkage-and-trim balance converged"},
        )
        return tree_to_dataset(tree, HYDROSTATICS + extra)


HydrostaticsSolution.__init__.__doc__ = """Fields: `particulars` (calm water, [`Particulars`][]); the grids
`zeta_mid` [m] (> 0 trough amidships) and `heels` [rad]; `wavelength` λ [m]; tables `gz`, `sinkage`, `trim`
[m] of shape (zeta, heels) at free trim; `gz_calm` [m]; `gm`, `delta_gm` = GM(ζ) − GM(calm) [m] (upright); the
fits `gz_coefficients` (g3, g5, g7, g9) [m] of the calm GZ with GM0 held and `delta_gm_coefficients` C0..C6
[m^(1−k)], with their RMS residuals [m]; `max_volume_error` (largest |∇/∇0 − 1| over all balances) and
`max_lcb_error` [m]; `converged` and `result`. With `curve_heels` [rad] (else None): `gz_curves` [m] at those heels
in calm water and in the waves of the smallest and the largest amplitude (`curve_zeta_mid` = (0, min ζ, max ζ)),
free trim, and `curves_converged` (not part of `result`).
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


@functools.partial(cached_program, compiler_options=HYDROSTATICS_PROGRAM)
def _hydrostatics_core(hull, loading, zeta, heels, wavelength, curve_heels):
    """The table as one stored program (no host callback: `hull_hydrostatics` checks `result` after it).

    Every balance — the table, the upright ones, calm water, the curves — is one vmapped Newton solve: it costs
    its slowest case's steps whatever the batch, and a second batch would be a second compiled clip (a cold run's
    compilation is most of its time). Calm water is integrated on a surface's strip-cut triangles too (exact: the
    wave is zero)."""
    lam = hull.lpp if wavelength is None else jnp.asarray(wavelength, dtype=float)
    nz, nh = zeta.shape[0], heels.shape[0]
    nc = 0 if curve_heels is None else curve_heels.shape[0]
    zz, pp = jnp.meshgrid(zeta, heels, indexing="ij")
    curve_zeta = jnp.stack([jnp.zeros(()), jnp.min(zeta), jnp.max(zeta)])
    parts = [
        (pp.ravel(), zz.ravel()),
        (jnp.zeros(nz), zeta),
        (heels, jnp.zeros(nh)),
        (jnp.zeros(1), jnp.zeros(1)),
    ]
    if nc:
        parts.append((jnp.tile(curve_heels, 3), jnp.repeat(curve_zeta, nc)))
    eqs = _equilibrium_batch(hull, loading, *(jnp.concatenate(a) for a in zip(*parts)), lam)
    ends = np.cumsum([0] + [p[0].shape[0] for p in parts])
    pick = lambda k: jax.tree_util.tree_map(lambda a: a[ends[k] : ends[k + 1]], eqs)
    table = jax.tree_util.tree_map(lambda a: a.reshape(nz, nh), pick(0))
    upright_waves, calm = pick(1), pick(2)
    calm_upright = jax.tree_util.tree_map(lambda a: a[0], pick(3))
    table_eqs = jax.tree_util.tree_map(lambda a: a[: ends[4]], eqs)
    upright = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b[None]]), upright_waves, calm_upright)
    gms = jax.vmap(lambda s, t, z: _gm_at(hull, loading, s, t, z, lam))(upright.sinkage, upright.trim,
                                                                        upright.zeta_mid)  # fmt: skip
    gm, gm0 = gms[:nz], gms[nz]
    zero = jnp.zeros(())
    particulars = _particulars(hull, loading, calm_upright, gm0, zero, lam)
    delta_gm = gm - gm0
    g, g_rms = fit_gz_polynomial(heels, calm.gz, gm0)
    c, c_rms = fit_delta_gm_polynomial(zeta, delta_gm)
    converged = table.converged & calm.converged[None, :] & jnp.all(upright.converged)
    result = optx.RESULTS.where(
        jnp.all(converged), optx.RESULTS.successful, optx.RESULTS.nonlinear_divergence
    )
    curves = jax.tree_util.tree_map(lambda a: a.reshape(3, nc), pick(4)) if nc else None
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
        max_volume_error=jnp.max(jnp.abs(table_eqs.volume / loading.volume - 1)),
        max_lcb_error=jnp.max(jnp.abs(table_eqs.lcb - loading.lcg)),
        converged=converged,
        result=result,
        curve_heels=curve_heels,
        curve_zeta_mid=curve_zeta if nc else None,
        gz_curves=None if curves is None else curves.gz,
        curves_converged=None if curves is None else curves.converged,
    )


def hull_hydrostatics(
    hull: Hull,
    loading: Loading,
    *,
    zeta_mid: ArrayLike | None = None,
    heels: ArrayLike | None = None,
    wavelength: ArrayLike | None = None,
    curve_heels: ArrayLike | None = None,
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
    - `curve_heels`: heels [rad] of GZ curves for figures, in calm water and in the waves of the smallest and the
        largest amplitude (computed in the same batch as the table: no second program); default none.
    - `throw`: raise `EquinoxRuntimeError` if any balance of the table fails (otherwise, and for the curves,
        see `converged`/`result`, `curves_converged`).

    **Returns:** a [`HydrostaticsSolution`][].
    """
    require_float64("jaxroll.hull_hydrostatics")
    zeta = as_float(default_zeta_grid() if zeta_mid is None else zeta_mid)
    phi = as_float(default_heel_grid() if heels is None else heels)
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
    lam = None if wavelength is None else as_float(wavelength)
    curves = None if curve_heels is None else as_float(curve_heels).ravel()
    sol = _hydrostatics_core(_bare(hull), loading, zeta, phi, lam, curves)
    _check_result(sol.result, throw, "at least one (ζ_mid, φ) of the table")
    return sol


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
            f"λ = {float(solution.wavelength):.4g} m, ζ_mid in [{np.min(np.asarray(solution.zeta_mid)):.3g}, "
            f"{np.max(np.asarray(solution.zeta_mid)):.3g}] m); roll period and damping are inputs, not hydrostatics."
            + (f" {hull.provenance}" if hull.provenance else "")
        ),
    )

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
