"""`jaxroll hydrostatics HULL`: GZ and ΔGM(ζ_mid) of a hull from its offsets, and a ship file using them."""

from __future__ import annotations

import concurrent.futures
import math
from pathlib import Path

from ._common import (
    CLIError,
    OutputFolder,
    atomic_write_text,
    import_output_libraries,
    save_figure,
    write_json,
    write_netcdf,
)
from ._sea import check_positive
from .sgisc import (
    MESH_SUFFIXES,
    add_hull_options,
    check_hull_options,
    check_plausible,
    datum_lines,
    datum_record,
    heights_above_baseline,
    read_hull_arg,
)

DEFAULT_OUT = Path("jaxroll-out") / "hydrostatics"


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "hydrostatics",
        help="GZ(φ) and ΔGM(ζ_mid) from hull offsets (Froude–Krylov, quasi-static balance) → ship.toml",
        description=(
            "Compute calm-water particulars, GZ curves and the GM variation ΔGM(ζ_mid) of a hull in a "
            "wave of length L with its crest or trough amidships (sinkage and trim balanced), fit the roll "
            "model's polynomials and write a ship file for `jaxroll pdf --ship FILE`. HULL is a hull "
            "file (TOML, docs/hydrostatics.md), a closed STL surface (ascii or binary), a WAMIT low-order GDF "
            "of the whole hull (not only the wetted surface) or an offsets CSV "
            "(docs/sgisc.md; sliced into stations, with --lpp, --units, --scale, --forward, --up), or the word "
            "`c11` for the shipped REPRESENTATIVE C11-like hull."
        ),
    )
    add = p.add_argument
    add("hull", metavar="HULL", help="hull file (TOML, STL, WAMIT GDF, offsets CSV) or `c11`")
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--kg", type=float, metavar="M", help="KG [m] above the baseline (default: the file's [loading])"
    )
    g.add_argument("--gm", type=float, metavar="M", help="choose KG so that the calm-water GM is M [m]")
    m = p.add_mutually_exclusive_group()
    m.add_argument("--displacement", type=float, metavar="KG", help="displacement mass [kg]")
    m.add_argument("--draught", type=float, metavar="M", help="even-keel draught [m]")
    add("--lcg", type=float, metavar="M", help="LCG [m] from the AP (default: floats at even keel)")
    add("--water-density", type=float, metavar="RHO", help="water density [kg/m³] (default: 1025)")
    r = p.add_mutually_exclusive_group()
    r.add_argument("--roll-period", type=float, metavar="S", help="natural roll period Tφ [s] (c11: 24.4)")
    r.add_argument("--roll-gyradius", type=float, metavar="M", help="roll radius of gyration k_xx [m]")
    add("--added-inertia", type=float, default=0.0, metavar="A", help="added / dry roll inertia (default: 0)")
    add(
        "--damping",
        type=float,
        nargs=3,
        metavar=("B1", "B2", "B3"),
        help="roll damping b1 [1/s], b2 [1/rad], b3 [s/rad²] (default: the default ship's)",
    )
    add("--zeta-max", type=float, default=6.0, metavar="M", help="largest amplitude ζ_mid [m] (default: 6)")
    add("--n-zeta", type=int, default=13, metavar="N", help="amplitudes in [−ζmax, ζmax] (default: 13)")
    add(
        "--heel-max-deg",
        type=float,
        default=70.0,
        metavar="DEG",
        help="largest heel of the GZ table and fit [deg] (default: 70)",
    )
    add("--n-heel", type=int, default=15, metavar="N", help="heels in [0, heel-max] (default: 15)")
    add("--wavelength", type=float, metavar="M", help="wave length λ [m] (default: Lpp)")
    add("--name", help="name of the ship in ship.toml")
    add(
        "--wave-moment",
        choices=("froude-krylov", "bem", "none"),
        default="none",
        help="write the hull's direct wave roll moment into ship.toml: froude-krylov (the incident wave's "
        "pressure on the hull, every 15° of heading; pdf, maxima, risk, sweep then add it at oblique and beam "
        "headings, docs/wave_moment.md), bem (Froude–Krylov + diffraction, with the added inertia A44(ω) and "
        'radiation damping B44(ω), from capytaine: pip install "jaxroll[bem]") or none (default: the paper\'s '
        "parametric-only model)",
    )
    add(
        "--bem-frequencies",
        type=int,
        default=40,
        metavar="N",
        help="--wave-moment bem: frequencies (default: 40)",
    )
    add(
        "--bem-omega-max",
        type=float,
        metavar="W",
        help="--wave-moment bem: highest wave frequency [rad/s] (default: where the incident pressure at the keel "
        "is 5 %%, 1.6 rad/s for c11)",
    )
    add(
        "--bem-headings",
        type=int,
        default=7,
        metavar="N",
        help="--wave-moment bem: headings 0–180° (default: 7)",
    )
    add(
        "--bem-panel-size",
        type=float,
        metavar="M",
        help="--wave-moment bem: longest panel edge [m] of an offsets hull (default: 0.95 λ/6 of the highest "
        "frequency; a mesh file keeps its own panels)",
    )
    add(
        "--bem-lid",
        action="store_true",
        help="--wave-moment bem: a lid in the waterplane (no irregular frequencies)",
    )
    add(
        "--gz-surface",
        action="store_true",
        help="write the hull's GZ(φ, ζ_mid) surface in waves into ship.toml ([restoring_surface], fitted to the "
        "table: 0–heel-max, ±zeta-max): the roll equation then restores with it instead of GZ_calm(φ) + ΔGM(ζ)·φ, "
        "and a run that leaves its range ends there, counted (docs/hydrostatics.md)",
    )
    add_hull_options(p)
    add(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        metavar="DIR",
        help="output folder (default: jaxroll-out/hydrostatics)",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress display (it shows none; accepted like the other commands')",
    )
    p.set_defaults(func=run)


def _check_options(args) -> None:
    """Every numeric option, before any hydrostatics is computed."""
    check_positive(
        args, "kg", "displacement", "draught", "water_density", "roll_period", "roll_gyradius", "wavelength"
    )
    for flag, value in (("--gm", args.gm), ("--lcg", args.lcg)):
        if value is not None and not math.isfinite(value):
            raise CLIError(f"{flag} must be a finite number; got {value}.")
    if not (math.isfinite(args.added_inertia) and args.added_inertia >= 0):
        raise CLIError(f"--added-inertia must be a finite number >= 0; got {args.added_inertia}.")
    if args.damping is not None and not all(math.isfinite(b) for b in args.damping):
        raise CLIError(f"--damping: B1 B2 B3 must be finite numbers; got {args.damping}.")
    for flag, value, least in (("--n-zeta", args.n_zeta, 7), ("--n-heel", args.n_heel, 5)):
        if value < least:
            raise CLIError(f"{flag} must be at least {least} (the polynomial fits need them); got {value}.")
    if args.wave_moment == "bem":
        _check_bem_options(args)
    else:
        given = [
            flag
            for flag, value, default in (
                ("--bem-frequencies", args.bem_frequencies, 40),
                ("--bem-omega-max", args.bem_omega_max, None),
                ("--bem-headings", args.bem_headings, 7),
                ("--bem-panel-size", args.bem_panel_size, None),
                ("--bem-lid", args.bem_lid, False),
            )
            if value != default
        ]
        if given:
            raise CLIError(f"{', '.join(given)} set(s) the BEM: give --wave-moment bem, or leave it out.")
    if args.out.exists() and not args.out.is_dir():
        raise CLIError(f"--out {str(args.out)!r} exists and is not a folder.")
    check_hull_options(args)


def _check_bem_options(args) -> None:
    """`--wave-moment bem`: capytaine installed, and the BEM options."""
    from ..ship import BEM_EXTRA, capytaine_missing

    if capytaine_missing():
        raise CLIError(f"--wave-moment bem needs capytaine, which is not installed: {BEM_EXTRA}.")
    for flag, value, least in (
        ("--bem-frequencies", args.bem_frequencies, 2),
        ("--bem-headings", args.bem_headings, 2),
    ):
        if value < least:
            raise CLIError(f"{flag} must be at least {least}; got {value}.")
    check_positive(args, "bem_omega_max", "bem_panel_size")
    if args.roll_gyradius is not None and args.added_inertia != 0:
        raise CLIError(
            "--added-inertia and --wave-moment bem: the BEM gives the added inertia A44(ω0); give --roll-gyradius "
            "alone (the dry k_xx), or --roll-period."
        )


def _bem(args, hull, loading, gm0):
    """capytaine's coefficients, and the roll period: Tφ given, or from the dry gyradius and A44(ω0)."""
    import numpy as np

    from ..ship import (
        BemNotInstalledError,
        MeshNotFitError,
        bem_frequencies,
        bem_roll_coefficients,
        bem_roll_period,
    )

    omega = bem_frequencies(float(loading.draught), args.bem_frequencies, args.bem_omega_max)
    headings = np.linspace(0.0, math.pi, args.bem_headings)
    try:
        c = bem_roll_coefficients(hull, loading, omega=omega, headings=headings, panel_size=args.bem_panel_size,
                                  lid=args.bem_lid)  # fmt: skip
    except (MeshNotFitError, BemNotInstalledError, ValueError, RuntimeError) as e:
        raise CLIError(str(e)) from None
    period = args.roll_period
    if period is None and args.roll_gyradius is not None:
        period = bem_roll_period(c, float(loading.displacement), gm0, args.roll_gyradius)
    return c, period


def _bem_roll_record(c, ship, loading) -> dict:
    """A44 and B44 at the roll frequency beside the inertia and damping of the roll equation (docs/wave_moment.md)."""
    import numpy as np

    from ..ship import roll_inertia

    w0 = float(ship.omega0)
    a44 = float(np.interp(w0, c.omega, c.added_inertia))
    b44 = float(np.interp(w0, c.omega, c.radiation_damping))
    i44 = float(roll_inertia(ship))
    dry = i44 - a44
    mass = float(loading.displacement)
    return {  # the arrays are in the ship's [wave_moment] (payload["ship"])
        "n_panels": c.n_panels,
        "panel_size_m": c.panel_size,
        "lid": c.lid,
        "irregular_frequency_rad_s": c.irregular_frequency if math.isfinite(c.irregular_frequency) else None,
        "n_frequencies": int(c.omega.size - 1),
        "n_headings": int(c.headings.size),
        "capytaine_s": c.solver_seconds,
        "total_s": c.seconds,
        "roll_frequency_rad_s": w0,
        "roll_inertia_kg_m2": i44,
        "added_inertia_at_roll_frequency_kg_m2": a44,
        "added_inertia_fraction": a44 / i44,
        "dry_inertia_kg_m2": dry,
        "dry_gyradius_m": math.sqrt(dry / mass) if dry > 0 else None,
        "radiation_damping_at_roll_frequency_N_m_s": b44,
        "radiation_b1_per_s": b44 / i44,
        "ship_b1_per_s": float(ship.damping[0]),
    }


def run(args) -> int:
    import equinox as eqx
    import numpy as np

    from ..io import hull_to_toml, loading_from_dict, ship_to_dict, ship_to_toml
    from ..plotting import plot_body_plan, plot_delta_gm, plot_gz_curves
    from ..ship import (
        C11_HULL_NOTE,
        c11_representative,
        default_heel_grid,
        default_zeta_grid,
        fit_restoring_surface,
        gz_in_waves,
        hull_hydrostatics,
        metacentric_height,
        restoring_fields_from_gz,
        ship_file_frequencies,
        ship_from_hydrostatics,
        wave_moment,
    )

    _check_options(args)
    is_mesh = Path(args.hull).suffix.lower() in MESH_SUFFIXES
    hull, file_loading, is_c11 = read_hull_arg(args)

    for flag, value in (("--zeta-max", args.zeta_max), ("--heel-max-deg", args.heel_max_deg)):
        if not (math.isfinite(value) and value > 0):
            raise CLIError(f"{flag} must be a finite number > 0; got {value}.")
    if args.heel_max_deg > 90:
        raise CLIError(f"--heel-max-deg must be at most 90; got {args.heel_max_deg}.")
    zeta = default_zeta_grid(args.zeta_max, args.n_zeta)
    heels = default_heel_grid(math.radians(args.heel_max_deg), args.n_heel)

    # the draught and KG given from --draught-datum / --kg-datum, measured from the baseline
    (draught,), kg_above = heights_above_baseline(
        hull, args, draughts=[("--draught", args.draught)], kg=args.kg
    )
    overrides = dict(
        draught=draught, displacement=args.displacement, lcg=args.lcg, water_density=args.water_density
    )
    if args.gm is not None:
        probe = loading_from_dict(hull, file_loading, kg=0.0, **overrides)
        kg = float(metacentric_height(hull, probe)) - args.gm
    else:
        kg = kg_above
    loading = loading_from_dict(hull, file_loading, kg=kg, **overrides)

    roll_period, gyradius = args.roll_period, args.roll_gyradius
    if roll_period is None and gyradius is None:
        if not is_c11:
            raise CLIError(
                "the roll period is not a hydrostatic quantity: give --roll-period S, or --roll-gyradius M "
                "(with --added-inertia)."
            )
        roll_period = 24.4

    check_plausible(hull, loading)
    # The figure's GZ curves (calm, crest and trough of the largest amplitude) to 90°: the table's heels, and beyond
    # them every 5°, computed with the table (one program, one batch)
    beyond = np.radians(np.arange(args.heel_max_deg + 5.0, 90.0 + 1e-9, 5.0))
    # The table's program is loaded (compiled, on a cold run) and dispatched in a worker thread, and computed in
    # XLA's threads, while this one imports what the figures and the netCDF file need (≈ 0.5 s that would otherwise
    # follow): the worker imports no module (tests/test_hydrostatics.py checks it), so the two never wait on each
    # other's imports
    with concurrent.futures.ThreadPoolExecutor(1) as worker:
        pending = worker.submit(hull_hydrostatics, hull, loading, zeta_mid=zeta, heels=heels,
                                wavelength=args.wavelength, curve_heels=beyond if beyond.size else None,
                                throw=False)  # fmt: skip
        import_output_libraries()
        sol = pending.result()
    converged = np.asarray(sol.converged)
    if not converged.all():
        iz, ih = np.nonzero(~converged)
        raise CLIError(
            f"the quasi-static balance (sinkage and trim) did not converge for {iz.size} of the {converged.size} "
            f"(ζ_mid, φ) cases (e.g. ζ_mid = {zeta[iz[0]]:g} m at {math.degrees(heels[ih[0]]):g}°): the hull "
            "cannot float there (deck or keel far out of the water) or the loading is inconsistent. Reduce "
            "--zeta-max or --heel-max-deg, or check the loading (--draught/--displacement, --kg, --lcg)."
        )
    bem = None
    if args.wave_moment == "bem":
        bem, bem_period = _bem(args, hull, loading, float(sol.particulars.gm))
        if gyradius is not None:  # the roll period of the dry inertia and the BEM's A44 at it
            roll_period, gyradius = bem_period, None
    ship = ship_from_hydrostatics(
        sol,
        hull,
        roll_period=roll_period,
        roll_gyradius=gyradius,
        added_inertia=args.added_inertia,
        damping=args.damping,
        name=args.name,
    )
    if args.wave_moment == "froude-krylov":
        table = wave_moment(hull, loading, ship, omega=ship_file_frequencies(float(sol.particulars.draught)))
        ship = eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)
    elif bem is not None:
        from ..ship import bem_wave_moment

        ship = eqx.tree_at(
            lambda s: s.wave_moment, ship, bem_wave_moment(bem, ship), is_leaf=lambda x: x is None
        )
    polynomial_rms = None
    if args.gz_surface:
        zz, pp = np.meshgrid(np.asarray(sol.zeta_mid), np.asarray(sol.heels), indexing="ij")
        polynomial_rms = float(
            np.sqrt(np.mean((np.asarray(gz_in_waves(ship, pp, zz)) - np.asarray(sol.gz)) ** 2))
        )
        surface = fit_restoring_surface(
            sol, ship, source=f"jaxroll hydrostatics {'c11' if is_c11 else Path(args.hull).name}"
        )
        ship = eqx.tree_at(lambda s: s.restoring_surface, ship, surface, is_leaf=lambda x: x is None)
    table_ok = np.asarray(sol.converged)
    rows = [np.asarray(sol.gz_calm), *(np.asarray(sol.gz)[i] for i in (np.argmin(zeta), np.argmax(zeta)))]
    rows = [
        np.where(ok, r, np.nan)
        for r, ok in zip(rows, (table_ok.all(axis=0), *table_ok[[np.argmin(zeta), np.argmax(zeta)]]))
    ]
    fine, curves_gz = heels, np.stack(rows)
    if beyond.size:
        fine = np.concatenate([heels, beyond])
        more = np.where(np.asarray(sol.curves_converged), np.asarray(sol.gz_curves), np.nan)
        curves_gz = np.concatenate([curves_gz, more], axis=1)

    final: Path = args.out
    with OutputFolder(final) as out:
        p = sol.particulars
        gz_labels = [
            "calm water",
            f"crest amidships, ζ_mid = −{args.zeta_max:g} m",
            f"trough amidships, ζ_mid = +{args.zeta_max:g} m",
        ]
        ax = plot_gz_curves(
            fine,
            {lab: curves_gz[i] for i, lab in enumerate(gz_labels)},
            fit=(float(p.gm), np.asarray(sol.gz_coefficients)),
            fit_heel_max=float(heels[-1]),
        )
        ax.set_title(
            f"{hull.name}: GZ, free sinkage and trim, λ = {float(sol.wavelength):g} m", fontsize="medium"
        )
        save_figure(ax.figure, out / "gz_curves.png")
        default = c11_representative()
        ax = plot_delta_gm(
            np.asarray(sol.zeta_mid),
            np.asarray(sol.delta_gm),
            np.asarray(sol.delta_gm_coefficients),
            reference=np.asarray(default.delta_gm),
        )
        ax.set_title(f"{hull.name}: ΔGM(ζ_mid), GM0 = {float(p.gm):.4f} m", fontsize="medium")
        save_figure(ax.figure, out / "delta_gm.png")
        ax = plot_body_plan(hull, draught=float(p.draught))
        save_figure(ax.figure, out / "body_plan.png")

        notes = [C11_HULL_NOTE] if is_c11 else []
        notes.append(
            "Roll period and damping are inputs, not hydrostatics; damping defaults to the default ship's."
        )
        payload = {
            "command": "hydrostatics",
            "notes": notes,
            "config": {
                "hull": "c11" if is_c11 else str(args.hull),
                "kg_m": float(loading.kg),
                "kg_given_m": args.kg,
                "draught_given_m": args.draught,
                "gm_requested_m": args.gm,
                "displacement_kg": float(loading.displacement),
                "lcg_m": float(loading.lcg),
                "water_density_kg_m3": float(loading.water_density),
                "roll_period_s": float(ship.roll_period),
                "roll_gyradius_m": gyradius,
                "added_inertia": args.added_inertia,
                "wavelength_m": float(sol.wavelength),
                "zeta_max_m": args.zeta_max,
                "n_zeta": args.n_zeta,
                "heel_max_deg": args.heel_max_deg,
                "n_heel": args.n_heel,
                "wave_moment": args.wave_moment,
                "gz_surface": bool(args.gz_surface),
                "method": (
                    "exact for the mesh: its triangles clipped by the water surface (divergence theorem, no "
                    f"waterplane cap), waves L2-projected on linear functions in {hull.surface.strips} strips along x"
                    if hull.surface is not None
                    else "sectional polygon clipping (exact for the offsets polygons), trapezoid rule along x"
                )
                + "; sinkage and trim balanced by optimistix Newton at every heel and wave (Froude–Krylov)",
                "datum": datum_record(hull, args),
                "wave_profile": "eta(x) = -zeta_mid cos(2 pi (x - Lpp/2) / wavelength); zeta_mid > 0: trough "
                "amidships",
            },
            "hull": {
                "name": hull.name,
                "provenance": hull.provenance,
                "lpp_m": float(hull.lpp),
                "depth_m": float(hull.depth),
                "n_stations": int(hull.stations.shape[0]),
                "n_waterlines": int(hull.waterlines.shape[0]),
                "n_triangles": None if hull.surface is None else hull.surface.n_triangles,
            },
            "calm_water": p.as_dict(),
            "tables": {
                "zeta_mid_m": sol.zeta_mid,
                "heel_deg": np.degrees(np.asarray(sol.heels)),
                "gz_m": sol.gz,
                "sinkage_m": sol.sinkage,
                "trim_m": sol.trim,
                "gz_calm_m": sol.gz_calm,
                "gm_m": sol.gm,
                "delta_gm_m": sol.delta_gm,
            },
            "gz_curves_figure": {
                "heel_deg": np.degrees(fine),
                "zeta_mid_m": np.array([0.0, np.min(zeta), np.max(zeta)]),
                "gz_m": curves_gz,
            },
            "fits": {
                "gm0_m": float(p.gm),
                "gz_coefficients_m": dict(
                    zip(("g3", "g5", "g7", "g9"), np.asarray(sol.gz_coefficients).tolist())
                ),
                "restoring": dict(
                    zip(
                        ("a3", "a5", "a7", "a9"),
                        restoring_fields_from_gz(
                            np.asarray(sol.gz_coefficients), float(p.gm), float(ship.roll_period)
                        ).tolist(),
                    )
                ),
                "gz_fit_rms_m": float(sol.gz_fit_rms),
                "gz_fit_heel_max_deg": args.heel_max_deg,
                "delta_gm_coefficients": {
                    f"c{k}": float(c) for k, c in enumerate(np.asarray(sol.delta_gm_coefficients))
                },
                "delta_gm_fit_rms_m": float(sol.delta_gm_fit_rms),
                **(
                    {
                        "gz_surface_fit_rms_m": float(ship.restoring_surface.fit_rms),
                        "gz_surface_fit_max_error_m": float(ship.restoring_surface.fit_max_error),
                        "polynomial_model_rms_m": polynomial_rms,
                    }
                    if polynomial_rms is not None
                    else {}
                ),
            },
            "balance_check": {
                "max_relative_volume_error": float(sol.max_volume_error),
                "max_lcb_minus_lcg_m": float(sol.max_lcb_error),
                "all_converged": bool(np.all(np.asarray(sol.converged))),
            },
            "ship": ship_to_dict(ship),
        }
        if bem is not None:
            payload["bem"] = _bem_roll_record(bem, ship, loading)
        write_json(out / "hydrostatics.json", payload)
        nc = write_netcdf(out / "hydrostatics.nc", "hydrostatics", payload, sol.to_xarray())
        atomic_write_text(out / "ship.toml", ship_to_toml(ship))
        if is_mesh:  # the sliced offsets, to inspect and reuse as a TOML hull file
            atomic_write_text(out / "hull.toml", hull_to_toml(hull, header=f"sliced from {args.hull}"))

    c = np.asarray(sol.delta_gm_coefficients)
    print(
        f"{hull.name}: Δ = {float(p.displacement):.6g} kg, d = {float(p.draught):.4g} m, "
        f"Cb = {float(p.block_coefficient):.4f}, KB = {float(p.kb):.4f} m, BM = {float(p.bm):.4f} m, "
        f"KG = {float(p.kg):.4f} m, GM0 = {float(p.gm):.4f} m"
    )
    print(
        f"ΔGM(ζ_mid) fit: C1..C6 = {', '.join(f'{v:.4g}' for v in c[1:])} (rms "
        f"{float(sol.delta_gm_fit_rms):.2g} m)"
    )
    print(
        f"GZ fit (0–{args.heel_max_deg:g}°): g3..g9 = "
        f"{', '.join(f'{v:.4g}' for v in np.asarray(sol.gz_coefficients))} (rms {float(sol.gz_fit_rms):.2g} "
        "m)"
    )
    for line in datum_lines(hull, args):
        print(line)
    if bem is not None:
        r = payload["bem"]
        print(
            f"BEM (capytaine, {r['n_panels']} panels ≤ {r['panel_size_m']:.3g} m, {r['n_frequencies']} frequencies × "
            f"{bem.headings.size} headings): {r['capytaine_s']:.1f} s in capytaine, {r['total_s']:.1f} s in all"
        )
        dry = "" if r["dry_gyradius_m"] is None else f", dry k_xx = {r['dry_gyradius_m']:.4g} m"
        print(
            f"at ω0 = {r['roll_frequency_rad_s']:.4g} rad/s: A44 = {r['added_inertia_at_roll_frequency_kg_m2']:.4g} "
            f"kg m² = {100 * r['added_inertia_fraction']:.1f} % of I44 = Δ g GM0/ω0² (Tφ = {float(ship.roll_period):.4g} s)"
            f"{dry}; B44/I44 = {r['radiation_b1_per_s']:.3g} 1/s beside the ship's b1 = {r['ship_b1_per_s']:.3g} 1/s "
            "(Tφ and b1 of the roll equation include them: not added again)"
        )
        if bem.irregular_frequency < bem.omega[-1]:
            print(
                f"Note: irregular frequencies from ≈ {bem.irregular_frequency:.3g} rad/s (capytaine's estimate) lie "
                "in the range solved: --bem-lid removes them."
            )
        if r["dry_gyradius_m"] is None:
            print(
                "Warning: A44(ω0) exceeds the roll inertia Δ g GM0/ω0² that the roll period implies: the roll period "
                "is too short for this hull (check --roll-period)."
            )
    elif ship.wave_moment is not None:
        print(
            f"wave moment (Froude–Krylov) tabulated for {ship.wave_moment.headings.size} headings × "
            f"{ship.wave_moment.omega.size} frequencies (0–{float(ship.wave_moment.omega[-1]):.3g} rad/s), in ship.toml"
        )
    if ship.restoring_surface is not None:
        rs = ship.restoring_surface
        print(
            f"GZ(φ, ζ_mid) surface (|φ| <= {args.heel_max_deg:g}°, ζ_mid in [{float(rs.zeta_min):g}, "
            f"{float(rs.zeta_max):g}] m; {rs.coefficients.shape[0]} × {rs.coefficients.shape[1]} terms beyond the "
            f"polynomial model) against the table: rms {float(rs.fit_rms):.2g} m, max {float(rs.fit_max_error):.2g} m "
            f"(GZ_calm + ΔGM·φ: rms {polynomial_rms:.2g} m), in ship.toml"
        )
    if is_c11:
        print("Note: the c11 hull is REPRESENTATIVE (parametric), not the real C11 lines.")
    print(
        f"wrote {final / 'hydrostatics.json'}, {'hydrostatics.nc, ' if nc else ''}{final / 'ship.toml'}, gz_curves.png, delta_gm.png, "
        "body_plan.png"
    )
    return 0
