r"""Roll radiation and diffraction from capytaine (the optional extra `pip install "jaxroll[bem]"`) on the hull
jaxroll reads: the excitation moment F(ω, χ) = Froude–Krylov + diffraction, the added inertia A44(ω) and the
radiation damping B44(ω), about the centre of gravity (docs/wave_moment.md, "BEM").

The panels are `jaxroll.ship._bem_mesh.bem_mesh`'s (the same hull, its starboard half mirrored by the solver); the
BEM frame and capytaine's conventions are turned into jaxroll's here: capytaine's time factor is e^{−iωt}, jaxroll's
e^{iωt} (so F = conj F_capytaine), its wave direction β is measured from x_b towards y_b (port), so a jaxroll heading
χ (waves travelling towards starboard for χ ∈ (0, π)) is β = −χ; both phases are relative to the wave at amidships
on the centre plane. The roll degree of freedom is a rotation about the ship's x axis through G: A44 and B44 are
about G, and positive F heels the ship to starboard, as `froude_krylov_roll_moment`'s.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from jaxtyping import ArrayLike

from ._bem_mesh import PANELS_PER_WAVELENGTH, BemMesh, bem_mesh, check_panel_size, wavelength
from ._equilibrium import equilibrium
from ._hull import Hull
from ._hydrostatics import GRAVITY, Loading
from ._ship import Ship
from ._wave_moment import WaveMoment, froude_krylov_roll_moment, moment_table

DEFAULT_FREQUENCIES = 40
"""Wave frequencies of `bem_roll_coefficients`' default grid."""
DEFAULT_HEADINGS = np.linspace(0.0, math.pi, 7)
"""Headings χ [rad] of `bem_roll_coefficients`' default grid (0–180°, every 30°)."""
KEEL_PRESSURE = 0.05
"""The default grid ends where the incident wave's pressure at the keel has fallen to this fraction, e^{−kd}."""

BEM_EXTRA = 'pip install "jaxroll[bem]"'


class BemNotInstalledError(ImportError):
    """capytaine, the BEM solver of `--wave-moment bem`, is not installed."""


def _capytaine():
    try:
        import capytaine
    except ImportError:
        raise BemNotInstalledError(
            f"the BEM wave moment needs capytaine, which is not installed: {BEM_EXTRA} (or pip install capytaine)."
        ) from None
    return capytaine


def capytaine_missing() -> bool:
    """True when capytaine cannot be imported (found, not imported: the import takes ≈ 2 s)."""
    import importlib.util

    try:
        return importlib.util.find_spec("capytaine") is None
    except ValueError:  # sys.modules["capytaine"] is None: an import would fail
        return True


def bem_frequencies(
    draught: float, n: int = DEFAULT_FREQUENCIES, omega_max: float | None = None
) -> np.ndarray:
    """`n` wave frequencies [rad/s], ω_max/n to ω_max; by default ω_max = √(g ln(1/0.05)/d), where the incident
    pressure at the keel of a hull of `draught` d [m] has fallen to 5 % (1.60 rad/s for d = 11.5 m: panels of
    3.8 m, 3 400 on the C11-like hull)."""
    top = (
        math.sqrt(GRAVITY * math.log(1 / KEEL_PRESSURE) / float(draught)) if omega_max is None else omega_max
    )
    return top * np.arange(1, n + 1) / n


def bem_roll_period(
    coefficients: "BemRollCoefficients", displacement: float, gm0: float, gyradius: float
) -> float:
    """The natural roll period Tφ [s] of a ship of dry roll gyradius k_xx `gyradius` [m] with the BEM's added
    inertia at its own frequency: Tφ = 2π √((Δ k_xx² + A44(2π/Tφ)) / (Δ g GM0)) (fixed point; `displacement` Δ [kg],
    `gm0` [m]). The roll equation's I44 = Δ g GM0/ω0² is then Δ k_xx² + A44(ω0)."""
    c, dry = coefficients, displacement * gyradius**2
    added, period = 0.0, 0.0
    for _ in range(200):
        period = 2 * math.pi * math.sqrt((dry + added) / (displacement * GRAVITY * gm0))
        new = float(np.interp(2 * math.pi / period, c.omega, c.added_inertia))
        if abs(new - added) <= 1e-13 * dry:
            break
        added = new
    return period


def panel_size_for(omega_max: float) -> float:
    """The panel size [m] `bem_roll_coefficients` meshes an offsets hull with: 0.95 λ/6 of ω_max [rad/s]."""
    return 0.95 * wavelength(omega_max) / PANELS_PER_WAVELENGTH


@dataclasses.dataclass(frozen=True)
class BemRollCoefficients:
    """Roll coefficients of a hull from capytaine, about G, in jaxroll's conventions (module docstring).

    - `omega` [rad/s] (n,): 0 (F = 0, B44 = 0, A44 its zero-frequency limit), then the frequencies solved;
      `headings` χ [rad] (m,);
    - `excitation`: F = Froude–Krylov + diffraction [N m per m of wave amplitude], complex (m, n), M = Re[F a e^{iωt}];
    - `froude_krylov`: its Froude–Krylov part, [`froude_krylov_roll_moment`][] of the hull (exact for it; its long-wave
      limit is i ρ g ∇ GM k sin χ, the GM of the ship's restoring); `diffraction`: capytaine's diffraction moment;
    - `froude_krylov_panels`: capytaine's own Froude–Krylov moment over the panels (one point per panel: second-order
      in the panel size, checked against `froude_krylov`), not used;
    - `added_inertia`: A44(ω) [kg m²] (n,); `radiation_damping`: B44(ω) [N m s/rad] (n,);
    - `n_panels`, `panel_size` [m] (the longest edge), `lid` (an interior lid removed the irregular frequencies),
      `irregular_frequency` [rad/s] (capytaine's estimate of the lowest one, for a box of the hull's waterplane and
      draught; with the lid, that of the thin layer under it, far above): results above it may be spoiled without
      the lid,
      `solver_seconds` (wall time inside capytaine) and `seconds` (the whole call).
    """

    omega: np.ndarray
    headings: np.ndarray
    excitation: np.ndarray
    froude_krylov: np.ndarray
    diffraction: np.ndarray
    froude_krylov_panels: np.ndarray
    added_inertia: np.ndarray
    radiation_damping: np.ndarray
    n_panels: int
    panel_size: float
    lid: bool
    irregular_frequency: float
    solver_seconds: float
    seconds: float


def _body(cpt, mesh: BemMesh, lid: bool, name: str):
    from capytaine.bodies.dofs import RotationDof

    faces = [list(f[:3]) if f[2] == f[3] else list(f) for f in mesh.faces]
    # capytaine's own check flags every quadrilateral off plane by 1e-8 m: bem_mesh splits those warped by > 2 %
    half = cpt.Mesh(mesh.vertices, faces, name=f"{name} (starboard half)", auto_check=False)
    hull = cpt.ReflectionSymmetricMesh(half, plane="xOz", name=name)
    lid_mesh = None
    if lid:  # just below the free surface, as capytaine advises
        depth = -float(mesh.vertices[:, 2].min())
        lid_mesh = hull.generate_lid(z=-0.01 * depth)
    dofs = {"Roll": RotationDof(rotation_center=mesh.centre_of_gravity, direction=mesh.roll_axis)}
    return cpt.FloatingBody(
        mesh=hull, dofs=dofs, lid_mesh=lid_mesh, center_of_mass=mesh.centre_of_gravity, name=name
    )


def bem_roll_coefficients(
    hull: Hull,
    loading: Loading,
    *,
    omega: ArrayLike | None = None,
    headings: ArrayLike | None = None,
    panel_size: float | None = None,
    lid: bool = False,
    sinkage: float | None = None,
    trim: float | None = None,
) -> BemRollCoefficients:
    """Roll radiation and diffraction of `hull` in `loading` by capytaine: F(ω, χ), A44(ω), B44(ω) about G
    ([`BemRollCoefficients`][]; deep water, zero speed: encounter frequency = wave frequency).

    **Arguments:**

    - `hull`, `loading`: as [`froude_krylov_roll_moment`][] (the waterline: `sinkage` and `trim` [m], by default the
        calm-water [`equilibrium`][]).
    - `omega`: wave frequencies [rad/s] > 0, increasing (default: 40 up to where the incident pressure at the keel
        is 5 %, [`bem_frequencies`][]).
    - `headings`: χ [rad] in [0, π], increasing (default: every 30°).
    - `panel_size`: the longest panel edge [m] of an offsets hull (default: 0.95 λ/6 of the highest frequency); a
        mesh hull keeps its own panels.
    - `lid`: add capytaine's lid inside the waterplane, which removes the irregular frequencies (more panels).

    **Raises:** `BemNotInstalledError` (capytaine missing: the extra named), `MeshNotFitError` (a mesh open below
    the waterline, or panels longer than λ/6 of the shortest wave), `ValueError` for a bad grid, `RuntimeError`
    where capytaine fails on a problem (its exception named).
    """
    start = time.perf_counter()
    cpt = _capytaine()
    if (sinkage is None) != (trim is None):
        raise ValueError("give both `sinkage` and `trim` [m], or neither (the calm-water equilibrium).")
    if sinkage is None:
        eq = equilibrium(hull, loading)
        sinkage, trim = float(eq.sinkage), float(eq.trim)
    omega = bem_frequencies(sinkage) if omega is None else np.atleast_1d(np.asarray(omega, dtype=float))
    headings = DEFAULT_HEADINGS if headings is None else np.atleast_1d(np.asarray(headings, dtype=float))
    check_grid(omega, headings)
    if panel_size is None and hull.surface is None:
        panel_size = panel_size_for(float(omega[-1]))
    mesh = bem_mesh(hull, loading, sinkage=sinkage, trim=trim, panel_size=panel_size)
    check_panel_size(mesh, float(omega[-1]), what=hull.name)
    body = _body(cpt, mesh, lid, hull.name)
    rho = float(loading.water_density)
    problems = [
        cpt.RadiationProblem(body=body, radiating_dof="Roll", omega=w, rho=rho, g=GRAVITY)
        for w in [0.0, *omega]
    ]
    problems += [
        cpt.DiffractionProblem(body=body, wave_direction=-chi, omega=w, rho=rho, g=GRAVITY)
        for w in omega
        for chi in headings
    ]
    solver = cpt.BEMSolver()
    t0 = time.perf_counter()
    results = solver.solve_all(problems, keep_details=False, progress_bar=False, _check_wavelength=False)
    solver_seconds = time.perf_counter() - t0
    failed = [r for r in results if hasattr(r, "exception")]
    if failed:
        raise RuntimeError(
            f"capytaine failed on {len(failed)} of its {len(results)} problems (e.g. ω = {float(failed[0].problem.omega):.4g} "
            f"rad/s: {failed[0].exception!r}); please report it with the hull."
        )
    grid = np.concatenate([[0.0], omega])
    n, m = grid.size, headings.size
    added, damping = np.empty(n), np.zeros(n)
    diffraction, panels_fk = np.zeros((m, n), complex), np.zeros((m, n), complex)
    for r in results:
        pb = r.problem
        i = int(np.searchsorted(grid, float(pb.omega)))
        if isinstance(pb, cpt.RadiationProblem):
            added[i], damping[i] = float(r.added_mass["Roll"]), float(r.radiation_damping["Roll"])
        else:  # e^{−iωt} → e^{iωt}: the conjugate
            j = int(np.argmin(np.abs(headings + float(pb.wave_direction))))
            diffraction[j, i] = np.conj(complex(r.forces["Roll"]))
            panels_fk[j, i] = np.conj(complex(cpt.bem.airy_waves.froude_krylov_force(pb)["Roll"]))
    fk = np.asarray(froude_krylov_roll_moment(hull, loading, grid[None, :], headings[:, None], sinkage=sinkage,
                                              trim=trim))  # fmt: skip
    return BemRollCoefficients(
        omega=grid,
        headings=headings,
        excitation=fk + diffraction,
        froude_krylov=fk,
        diffraction=diffraction,
        froude_krylov_panels=panels_fk,
        added_inertia=added,
        radiation_damping=damping,
        n_panels=mesh.n_panels + (0 if body.lid_mesh is None else body.lid_mesh.nb_faces),
        panel_size=mesh.panel_size,
        lid=lid,
        irregular_frequency=float(body.first_irregular_frequency_estimate(g=GRAVITY)),
        solver_seconds=solver_seconds,
        seconds=time.perf_counter() - start,
    )


def bem_wave_moment(coefficients: BemRollCoefficients, ship: Ship) -> WaveMoment:
    """The [`WaveMoment`][] of `coefficients` per the roll inertia of `ship` (I44 = Δ g GM0/ω0², `roll_inertia`),
    `source = "bem"`, carrying A44(ω) and B44(ω) (`WaveMoment.radiation`)."""
    c = coefficients
    return moment_table(
        c.omega,
        c.headings,
        c.excitation,
        ship,
        source="bem",
        added_inertia=c.added_inertia,
        radiation_damping=c.radiation_damping,
    )


def check_grid(omega: np.ndarray, headings: np.ndarray) -> None:
    """Refuse frequencies that are not increasing, finite and > 0 [rad/s], or headings outside [0, π] [rad]."""
    if omega.ndim != 1 or not np.all(np.isfinite(omega)) or omega[0] <= 0 or not np.all(np.diff(omega) > 0):
        raise ValueError(f"BEM frequencies ω must be increasing, finite and > 0 [rad/s]; got {omega!r}.")
    if (
        headings.ndim != 1
        or not np.all(np.diff(headings) > 0)
        or not np.all((headings >= 0) & (headings <= math.pi))
    ):
        raise ValueError(f"BEM headings χ must be increasing angles in [0, π] rad; got {headings!r}.")
