"""`jaxroll sgisc HULL`: IMO parametric-roll vulnerability (MSC.1/Circ.1627 2.5) of a loading condition."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ._common import CLIError, OutputFolder, atomic_write_text, save_figure, write_json, write_netcdf
from ._sea import check_positive

DEFAULT_OUT = Path("jaxroll-out") / "sgisc"
MESH_UNITS = ("m", "mm", "cm", "dm", "hm", "in", "ft")
AXES = ("+x", "-x", "+y", "-y", "+z", "-z")
MESH_SUFFIXES = (
    ".stl",
    ".gdf",
    ".csv",
    ".obj",
    ".ply",
    ".off",
    ".vtk",
    ".vtu",
    ".msh",
    ".mesh",
    ".medit",
    ".xdmf",
    ".nas",
    ".bdf",
)  # hull files read with the mesh options (jaxroll.io.read_hull; jaxroll.io MESH_SUFFIXES)


#: Printed with every Level-2 result and written to sgisc.json: the Level-2 standards and rules could not be checked
#: against the text of MSC.1/Circ.1627 here (docs/sgisc.md marks each constant).
LEVEL2_CAUTION = (
    "the Level-2 standards and rules (R_PR1 = 0.06, R_PR2 = 0.025, the 25° roll limit, the C2 speeds and "
    "averaging) are transcribed, not verified against the guideline's text (docs/sgisc.md); check them before "
    "statutory use. Level 1 is corroborated by an independent implementation."
)


def add_hull_options(p) -> None:
    """The STL/GDF/CSV reading options shared with `jaxroll hydrostatics`."""
    g = p.add_argument_group("hull files in STL, WAMIT GDF or CSV (ignored for TOML hull files)")
    g.add_argument("--lpp", type=float, metavar="M", help="length between perpendiculars L [m, full scale]")
    g.add_argument("--x-ap", type=float, metavar="M", help="x of the AP [m, full scale] (default: aft end)")
    g.add_argument(
        "--units",
        choices=MESH_UNITS,
        default="m",
        help="length unit of the file (default: m; a GDF: the unit of its GRAV)",
    )
    g.add_argument(
        "--scale", type=float, default=1.0, metavar="S", help="model scale (100 for 1:100; default 1)"
    )
    g.add_argument("--forward", choices=AXES, default="+x", help="file axis pointing forward (default: +x)")
    g.add_argument("--up", choices=AXES, default="+z", help="file axis pointing up (default: +z)")
    g.add_argument(
        "--baseline-z", type=float, metavar="Z",
        help="z of the baseline in the file [m, full scale]: draughts and KG are measured from it (default: the "
        "keel line where the lowest point is a sonar dome, skeg or bulb, else the lowest point; a warning names both)",
    )  # fmt: skip
    g.add_argument(
        "--draught-datum", metavar="REF", type=_height_reference,
        help="what the draughts given (--draught, and sgisc's --full-load-draught, --kgmax) are measured from: baseline "
        "(default), keel (the keel line), lowest (the lowest point, e.g. a sonar dome), or a file z [m, full scale]",
    )  # fmt: skip
    g.add_argument(
        "--kg-datum", metavar="REF", type=_height_reference,
        help="what --kg is measured from: baseline (default), keel, lowest, or a file z [m, full scale] (the outputs "
        "give every height from the baseline)",
    )  # fmt: skip
    g.add_argument(
        "--half-hull",
        action="store_true",
        help="the file holds one side, open on the centre plane: mirror it",
    )
    g.add_argument("--fix-normals", action="store_true", help="orient inconsistent triangles consistently")
    g.add_argument(
        "--sliced", action="store_true",
        help="hydrostatics from the sliced stations × waterlines instead of the exact surface (the method of jaxroll "
        "0.1; for comparison)",
    )  # fmt: skip
    g.add_argument(
        "--stations", type=int, default=61, metavar="N", help="stations sliced from an STL/GDF (61)"
    )
    g.add_argument(
        "--waterlines", type=int, default=41, metavar="N", help="waterlines sliced from an STL/GDF (41)"
    )


def _height_reference(text: str):
    """`--draught-datum`/`--kg-datum`: baseline, keel, lowest, or a file z [m] (a finite number)."""
    if text in ("baseline", "keel", "lowest"):
        return text
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(
            f"give baseline, keel, lowest or a file z [m, full scale]; got {text!r}"
        )
    return value


def heights_above_baseline(hull, args, *, draughts=(), kg=None) -> tuple[list, float | None]:
    """The draughts (from `--draught-datum`) and KG (from `--kg-datum`) given on the command line, measured from the
    baseline as jaxroll measures every height (None stays None). A draught at or above the deck, or a KG at or below
    the baseline, is refused with both values."""
    d_ref, k_ref = (
        getattr(args, "draught_datum", None) or "baseline",
        getattr(args, "kg_datum", None) or "baseline",
    )
    ignored = [
        f"{flag} (it applies to {what}, and no {what} was given{also})"
        for flag, given, what, also in (
            ("--draught-datum", getattr(args, "draught_datum", None) is not None and all(v is None for _, v in draughts),
             " or ".join(f for f, _ in draughts), ": the loading comes from --displacement or the hull file"),
            ("--kg-datum", getattr(args, "kg_datum", None) is not None and kg is None, "--kg",
             ": KG comes from --gm or the hull file"),
        )
        if given
    ]  # fmt: skip
    if ignored:  # a datum the user believes applied, silently ignored (issue 45)
        raise CLIError(
            f"{'; '.join(ignored)} would be ignored: give the height it is the datum of, or leave it out (every "
            "height in the outputs is measured from the baseline)."
        )
    datum = hull.datum
    if datum is None:
        if (d_ref, k_ref) != ("baseline", "baseline"):
            raise CLIError(
                "--draught-datum and --kg-datum apply to hulls read from a mesh (STL, GDF, OBJ, …); the heights of an "
                "offsets table are measured from its own baseline already."
            )
        return [value for _, value in draughts], kg
    depth = float(hull.depth)
    out = []
    for flag, value in draughts:
        if value is None:
            out.append(None)
            continue
        above = datum.above_baseline(value, d_ref)
        if above >= depth and d_ref != "baseline":  # from the baseline: the loading's own check names it
            raise CLIError(
                f"{flag} {value:g} m from the {_ref_name(d_ref, datum)} is d = {above:.4g} m above the baseline: at or "
                f"above the depth D = {depth:.4g} m (the deck). Check --draught-datum and the draught."
            )
        out.append(above)
    kg_above = None
    if kg is not None:
        kg_above = datum.above_baseline(kg, k_ref)
        if kg_above <= 0:
            raise CLIError(
                f"--kg {kg:g} m from the {_ref_name(k_ref, datum)} is {kg_above:.4g} m above the baseline: the centre of "
                "gravity would be at or below the bottom of the hull. Check --kg-datum and KG."
            )
    return out, kg_above


def datum_lines(hull, args) -> list[str]:
    """What the command line's draughts and KG were measured from, for the printed summary (none where both are the
    baseline)."""
    refs = [
        (what, ref)
        for what, ref in (("draughts", args.draught_datum), ("KG", args.kg_datum))
        if ref not in (None, "baseline")
    ]
    if hull.datum is None or not refs:
        return []
    z0 = hull.datum.baseline_file_z
    parts = [f"{what} given from the {_ref_name(ref, hull.datum)}, {hull.datum.file_z(ref) - z0:+.4g} m from the baseline"
             for what, ref in refs]  # fmt: skip
    return [f"Heights above the baseline (file z = {z0:.4g} m) in this output; " + "; ".join(parts) + "."]


def _ref_name(ref, datum) -> str:
    """'keel line (file z = 0 m)' etc. for messages."""
    name = {"baseline": "baseline", "keel": "keel line", "lowest": "lowest point"}.get(ref, "given reference")
    return f"{name} (file z = {datum.file_z(ref):.4g} m)"


def check_hull_options(args) -> None:
    """Check the STL/GDF/CSV options and that the hull file exists (before any computation)."""
    for flag, value in (("--lpp", args.lpp), ("--scale", args.scale)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise CLIError(f"{flag} must be a finite number > 0; got {value}.")
    for flag, value in (("--x-ap", args.x_ap), ("--baseline-z", args.baseline_z)):
        if value is not None and not math.isfinite(value):
            raise CLIError(f"{flag} must be a finite number; got {value}.")
    if args.forward[1] == args.up[1]:
        raise CLIError(f"--forward {args.forward} and --up {args.up} must be different axes.")
    for flag, value, least in (("--stations", args.stations, 5), ("--waterlines", args.waterlines, 5)):
        if value < least:
            raise CLIError(f"{flag} must be at least {least}; got {value}.")
    if args.hull.lower() != "c11" and not Path(args.hull).is_file():
        raise CLIError(
            f"hull file {args.hull!r} does not exist (give a TOML hull file, an STL, a WAMIT GDF or an offsets CSV, or `c11`)."
        )
    mesh = Path(args.hull).suffix.lower() in MESH_SUFFIXES
    changed = [
        flag
        for flag, value, default in (
            ("--lpp", args.lpp, None), ("--x-ap", args.x_ap, None), ("--units", args.units, "m"),
            ("--scale", args.scale, 1.0), ("--forward", args.forward, "+x"), ("--up", args.up, "+z"),
            ("--baseline-z", args.baseline_z, None), ("--half-hull", args.half_hull, False),
            ("--draught-datum", args.draught_datum, None), ("--kg-datum", args.kg_datum, None),
            ("--fix-normals", args.fix_normals, False), ("--sliced", args.sliced, False),
        )
        if value != default
    ]  # fmt: skip
    if changed and not mesh:
        raise CLIError(
            f"{', '.join(changed)} apply to STL, GDF and CSV hull files only; a TOML hull file is full scale, in "
            "metres and jaxroll's axes."
        )


def read_hull_arg(args):
    """(hull, file loading, is_c11) of the HULL argument (TOML, STL, GDF, CSV or `c11`)."""
    from ..io import read_hull
    from ..ship import c11_hull_path

    if args.hull.lower() == "c11":
        return (*read_hull(c11_hull_path()), True)
    mesh = Path(args.hull).suffix.lower() in MESH_SUFFIXES and Path(args.hull).suffix.lower() != ".csv"
    extra = dict(baseline_z=args.baseline_z, half_hull=args.half_hull, fix_normals=args.fix_normals,
                 exact=not args.sliced) if mesh else {}  # fmt: skip
    hull, loading = read_hull(
        args.hull, lpp=args.lpp, x_ap=args.x_ap, units=args.units, scale=args.scale, forward=args.forward,
        up=args.up, stations=args.stations, waterlines=args.waterlines, **extra,
    )  # fmt: skip
    return hull, loading, False


def check_plausible(hull, loading) -> None:
    """Refuse a loading whose proportions betray a unit slip (a hull in feet or millimetres read as metres, a
    displacement in tonnes given as kg), before the tables are computed (from the loading's even-keel draught and
    the hull's largest breadth: nothing to compile)."""
    import numpy as np

    d, depth = float(loading.draught), float(hull.depth)
    b, lo = 2 * float(np.max(np.asarray(hull.half_breadths))), float(np.asarray(hull.waterlines)[0])
    if d - lo < 0.04 * (depth - lo):
        raise CLIError(
            f"the draught d = {d:.4g} m is only {100 * (d - lo) / (depth - lo):.2g} % of the hull's height "
            f"({depth - lo:.4g} m, L = {float(hull.lpp):.4g} m, B = {b:.4g} m, Δ = "
            f"{float(loading.displacement):.4g} kg): a unit slip? (a displacement in tonnes given as kg, or a hull "
            "file in feet or inches read as metres: --units ft). Check --displacement/--draught and --units."
        )
    if b / max(d, 1e-9) > 15:
        raise CLIError(
            f"B/d = {b / d:.3g} (B = {b:.4g} m, d = {d:.4g} m): no ship floats so shallow for its "
            "breadth; a unit slip? (--units, --scale, or a draught/displacement in the wrong unit)."
        )


def datum_record(hull, args) -> dict | None:
    """The vertical datum of a hull read from a mesh, for the JSON outputs (None for TOML/CSV hulls): the baseline,
    and the references the command line's draughts and KG were given from, with their heights above it."""
    if hull.datum is None:
        return None
    refs = {}
    for key, ref in (("draught_datum", args.draught_datum), ("kg_datum", args.kg_datum)):
        ref = ref or "baseline"
        z = hull.datum.file_z(ref)
        refs[key] = {"option": ref, "file_z_m": z, "above_baseline_m": z - hull.datum.baseline_file_z}
    return {
        **hull.datum.as_dict(),
        "baseline_z_option": args.baseline_z,
        **refs,
        "note": "draughts, KG and every height in the outputs are measured from the baseline (z = 0 of jaxroll's "
        "frame); the command line's draughts and KG were given from draught_datum and kg_datum (add "
        "above_baseline_m to measure them from the baseline)",
    }


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "sgisc",
        help="IMO parametric-roll vulnerability (Circ.1627 2.5): Level 1, Level 2 C1 and C2 of a hull",
        description=(
            "Check a loading condition against the IMO second generation intact stability criteria for "
            "parametric rolling (MSC.1/Circ.1627 section 2.5): Level 1 (ΔGM1/GM against R_PR), Level 2 first "
            "check C1 (16 wave cases) and second check C2 (roll in the scatter table's regular waves, jaxroll's "
            "roll equation with the simplified Ikeda damping). Prints the values with their standards and a "
            "verdict, writes sgisc.json (every intermediate), sgisc.nc and figures. HULL is a hull file (TOML), an STL "
            "(ascii or binary), a WAMIT low-order GDF (the whole hull, not only the wetted surface), an offsets CSV, or `c11` (the REPRESENTATIVE C11-like hull). The Level-2 "
            "standards are transcribed, not verified against the guideline's text: see docs/sgisc.md."
        ),
    )
    add = p.add_argument
    add("hull", metavar="HULL", help="hull file (TOML, STL, GDF, CSV) or `c11`")
    m = p.add_mutually_exclusive_group()
    m.add_argument("--draught", type=float, metavar="M", help="even-keel draught d [m]")
    m.add_argument("--displacement", type=float, metavar="KG", help="displacement mass [kg]")
    add(
        "--kg", type=float, metavar="M", help="KG [m] above the baseline (default: the hull file's [loading])"
    )
    add("--water-density", type=float, metavar="RHO", help="water density [kg/m³] (default: 1025)")
    add("--speed-kn", type=float, metavar="KN", help="service speed V_S [kn] (required)")
    r = p.add_mutually_exclusive_group()
    r.add_argument("--roll-period", type=float, metavar="S", help="natural roll period Tφ [s]")
    r.add_argument("--roll-gyradius", type=float, metavar="M", help="roll radius of gyration k_xx [m]")
    b = p.add_mutually_exclusive_group()
    b.add_argument(
        "--bilge-keel",
        type=float,
        nargs=2,
        metavar=("LENGTH_M", "BREADTH_M"),
        help="bilge keels, length and breadth of each [m] (R_PR with A_k = 2 l b, and the Ikeda damping)",
    )
    b.add_argument(
        "--bilge-keel-area",
        type=float,
        metavar="M2",
        help="total projected bilge-keel area A_k [m²] (R_PR only)",
    )
    add("--sharp-bilge", action="store_true", help="the ship has a sharp bilge (R_PR = 1.87)")
    add("--full-load-draught", type=float, metavar="M", help="d_full for Level 1's δd_L [m] (default: d)")
    add(
        "--damping",
        type=float,
        nargs=3,
        metavar=("B1", "B2", "B3"),
        help="roll damping for C2 instead of the Ikeda estimate: b1 [1/s], b2 [1/rad], b3 [s/rad²]",
    )
    add("--skip-c2", action="store_true", help="stop after C1 (no roll model, no simulation)")
    add(
        "--kgmax",
        type=float,
        nargs=3,
        metavar=("D_MIN", "D_MAX", "N"),
        help="also compute KGmax (Level 1 and C1) at N draughts in [D_MIN, D_MAX] m",
    )
    add_hull_options(p)
    add(
        "--out",
        type=Path,
        default=DEFAULT_OUT,
        metavar="DIR",
        help="output folder (default: jaxroll-out/sgisc)",
    )
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress display (it shows none; accepted like the other commands')",
    )
    p.set_defaults(func=run)


def _check_options(args) -> None:
    check_positive(
        args,
        "kg",
        "draught",
        "displacement",
        "water_density",
        "roll_period",
        "roll_gyradius",
        "full_load_draught",
    )
    if args.speed_kn is None:
        raise CLIError("--speed-kn is required: the service speed V_S [kn] enters C1 (V_PR) and C2 (K V_S).")
    if not (math.isfinite(args.speed_kn) and args.speed_kn >= 0):
        raise CLIError(f"--speed-kn must be a finite number >= 0; got {args.speed_kn}.")
    if args.bilge_keel is not None and not all(math.isfinite(v) and v >= 0 for v in args.bilge_keel):
        raise CLIError(
            f"--bilge-keel: LENGTH_M BREADTH_M must be finite numbers >= 0; got {args.bilge_keel}."
        )
    if args.bilge_keel_area is not None and not (
        math.isfinite(args.bilge_keel_area) and args.bilge_keel_area >= 0
    ):
        raise CLIError(f"--bilge-keel-area must be a finite number >= 0; got {args.bilge_keel_area}.")
    if args.damping is not None and not all(math.isfinite(v) and v >= 0 for v in args.damping):
        raise CLIError(f"--damping: B1 B2 B3 must be finite numbers >= 0; got {args.damping}.")
    if args.kgmax is not None:
        lo, hi, n = args.kgmax
        if not (
            math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi and n >= 1 and float(n).is_integer()
        ):
            raise CLIError(
                f"--kgmax D_MIN D_MAX N: need 0 < D_MIN <= D_MAX and an integer N >= 1; got {args.kgmax}."
            )
    if args.out.exists() and not args.out.is_dir():
        raise CLIError(f"--out {str(args.out)!r} exists and is not a folder.")
    check_hull_options(args)


def _summary(hull, calm, a, kn) -> list[str]:
    l1, c1, c2 = a.level1, a.c1, a.c2
    lines = [
        f"SGISC parametric rolling — {hull.name}  (MSC.1/Circ.1627 2.5; constants' status in docs/sgisc.md)",
        f"  L = {float(hull.lpp):.2f} m, d = {l1.draught:.3f} m, KG = {float(calm.kg):.3f} m, GM = {l1.gm:.4f} m, "
        f"C_m = {float(calm.midship_coefficient):.3f}, A_k = {a.bilge_keel_area:.1f} m², V_S = {kn:g} kn, "
        f"T_φ = {a.roll_period:.2f} s ({a.roll_period_source})",
        f"  Level 1: ΔGM1/GM = {l1.ratio:.3f} ({l1.method} method; waterplane ΔGM1 {l1.delta_gm1_waterplane:.3f} m, "
        f"GM-in-waves ΔGM1 {l1.delta_gm1_waves:.3f} m) vs R_PR = {l1.r_pr:.3f} -> "
        f"{'VULNERABLE' if l1.vulnerable else 'not vulnerable'}",
        f"  Level 2 C1 = {c1.c1:.4f} vs R_PR1 = {c1.standard:g} -> {'fails' if c1.vulnerable else 'passes'}",
    ]
    d = a.damping
    if c2 is not None:
        lines.append(
            f"  Level 2 C2 = {c2.c2:.4f} vs R_PR2 = {c2.standard:g} -> {'fails' if c2.vulnerable else 'passes'}"
            f"  (damping b1 = {d['b1']:.3g} 1/s, b2 = {d['b2']:.3g} 1/rad: {d['source']})"
        )
    else:
        lines.append("  Level 2 C2: not computed (--skip-c2)")
    lines.append(f"  Verdict: {a.verdict}")
    if c1 is not None or c2 is not None:
        lines.append(f"  Caution: {LEVEL2_CAUTION}")
    return lines + [f"  Note: {n}" for n in (a.level1.notes + a.notes)]


def run(args) -> int:
    import numpy as np

    from ..criteria import (
        ROLL_ANGLE_LIMIT_DEG,
        assess_parametric_roll,
        kg_max_curve,
        roll_versus_speed,
    )
    from ..io import hull_to_toml, loading_from_dict, ship_to_dict, ship_to_toml
    from ..plotting import plot_c1_cases, plot_c2_cases, plot_kg_max, plot_roll_versus_speed
    from ..ship import C11_HULL_NOTE, hydrostatic_particulars

    _check_options(args)
    kn = args.speed_kn
    vs = kn * 1852.0 / 3600.0
    hull, file_loading, is_c11 = read_hull_arg(args)
    # every draught given from --draught-datum and KG from --kg-datum, measured from the baseline
    kgmax = args.kgmax if args.kgmax is not None else (None, None, None)
    (draught, full_load, kgmax_lo, kgmax_hi), kg = heights_above_baseline(
        hull, args, kg=args.kg, draughts=[("--draught", args.draught), ("--full-load-draught", args.full_load_draught),
                                          ("--kgmax D_MIN", kgmax[0]), ("--kgmax D_MAX", kgmax[1])],
    )  # fmt: skip
    loading = loading_from_dict(
        hull, file_loading, kg=kg, draught=draught, displacement=args.displacement,
        water_density=args.water_density,
    )  # fmt: skip
    check_plausible(hull, loading)
    calm = hydrostatic_particulars(hull, loading)
    if not float(calm.gm) > 0:
        raise CLIError(
            f"KG = {float(loading.kg):.4g} m gives GM = {float(calm.gm):.4g} m <= 0 (KM = "
            f"{float(calm.km):.4g} m): the ship is not initially stable. Lower --kg."
        )
    if args.kgmax is not None and kgmax_hi >= float(hull.depth):
        raise CLIError(
            f"--kgmax: D_MAX = {kgmax_hi:g} m above the baseline must be below the depth {float(hull.depth):g} m."
        )
    lbk, bbk = args.bilge_keel if args.bilge_keel is not None else (0.0, 0.0)
    a = assess_parametric_roll(
        hull,
        loading,
        service_speed=vs,
        roll_period=args.roll_period,
        roll_gyradius=args.roll_gyradius,
        bilge_keel_length=lbk,
        bilge_keel_breadth=bbk,
        bilge_keel_area=args.bilge_keel_area,
        sharp_bilge=args.sharp_bilge,
        full_load_draught=full_load,
        damping=args.damping,
        damping_source="given on the command line (--damping)" if args.damping is not None else None,
        skip_c2=args.skip_c2,
    )
    lines = _summary(hull, calm, a, kn) + [f"  Note: {line}" for line in datum_lines(hull, args)]
    speed = None
    if a.c2 is not None:
        worst = np.unravel_index(np.argmax(np.max(a.c2.max_roll, axis=0)), a.c2.max_roll.shape[1:])
        h_worst = float(a.c2.effective_wave_height[worst])
        speed = roll_versus_speed(a.ship, wave_height=h_worst, speeds=np.linspace(0.0, vs, 25))
    curve = None
    if args.kgmax is not None:
        curve = kg_max_curve(
            hull,
            np.linspace(kgmax_lo, kgmax_hi, int(args.kgmax[2])),
            service_speed=vs,
            roll_gyradius=args.roll_gyradius,
            bilge_keel_area=a.bilge_keel_area,
            sharp_bilge=args.sharp_bilge,
        )

    final: Path = args.out
    with OutputFolder(final) as out:
        save_figure(plot_c1_cases(a.c1).figure, out / "c1_cases.png")
        files = ["sgisc.json", "c1_cases.png"]
        if a.c2 is not None:
            save_figure(plot_c2_cases(a.c2).figure, out / "c2_cases.png")
            ax = plot_roll_versus_speed(speed, limit_deg=ROLL_ANGLE_LIMIT_DEG, service_speed=vs)
            ax.set_title(
                f"regular wave λ = L, H = {h_worst:.2f} m (the worst C2 sea state)", fontsize="medium"
            )
            save_figure(ax.figure, out / "roll_vs_speed.png")
            atomic_write_text(out / "ship.toml", ship_to_toml(a.ship, damping_source=a.damping["source"]))
            files += ["c2_cases.png", "roll_vs_speed.png", "ship.toml"]
        if curve is not None:
            ax = plot_kg_max(curve, kg=float(loading.kg), draught=float(calm.draught))
            save_figure(ax.figure, out / "kgmax.png")
            files.append("kgmax.png")
        if not is_c11 and Path(args.hull).suffix.lower() in MESH_SUFFIXES:
            atomic_write_text(out / "hull.toml", hull_to_toml(hull, header=f"sliced from {args.hull}"))
            files.append("hull.toml")
        c2 = a.c2
        payload = {
            "command": "sgisc",
            "notes": ([C11_HULL_NOTE] if is_c11 else [])
            + [
                "Level-2 standards R_PR1, R_PR2, the 25° angle, the speed factors, h_eff and the 7-case average "
                "are transcribed, not verified against MSC.1/Circ.1627: see docs/sgisc.md.",
                "C2 rolls with jaxroll's model: GZ_calm(φ) + ΔGM(ζ_mid(t)) φ (non-memory ΔGM of the hull).",
            ]
            + a.level1.notes
            + a.notes,
            "config": {
                "hull": "c11" if is_c11 else str(args.hull),
                "service_speed_kn": kn,
                "service_speed_m_s": vs,
                "roll_period_s": a.roll_period,
                "roll_period_source": a.roll_period_source,
                "bilge_keel_length_m": lbk,
                "bilge_keel_breadth_m": bbk,
                "bilge_keel_area_m2": a.bilge_keel_area,
                "sharp_bilge": args.sharp_bilge,
                "full_load_draught_m": args.full_load_draught,
                "draught_given_m": args.draught,
                "kg_given_m": args.kg,
                "mesh_options": {
                    "lpp_m": args.lpp,
                    "x_ap_m": args.x_ap,
                    "units": args.units,
                    "scale": args.scale,
                    "forward": args.forward,
                    "up": args.up,
                    "stations": args.stations,
                    "waterlines": args.waterlines,
                    "baseline_z_m": args.baseline_z,
                    "half_hull": args.half_hull,
                    "fix_normals": args.fix_normals,
                    "sliced": args.sliced,
                },  # fmt: skip
                "datum": datum_record(hull, args),
            },
            "hull": {
                "name": hull.name,
                "provenance": hull.provenance,
                "lpp_m": float(hull.lpp),
                "depth_m": float(hull.depth),
            },  # fmt: skip
            "calm_water": calm.as_dict(),
            "level1": vars(a.level1),
            "level2_c1": {k: v for k, v in vars(a.c1).items()},
            "damping": a.damping,
            "level2_c2": None
            if c2 is None
            else {
                "c2": c2.c2,
                "standard": c2.standard,
                "vulnerable": c2.vulnerable,
                "per_case": c2.per_case,
                "hs_m": np.arange(0.5, 17.0, 1.0),
                "tz_s": np.arange(1.5, 19.0, 1.0),
                "effective_wave_height_m": c2.effective_wave_height,
                "max_roll_deg": np.degrees(c2.max_roll),
                "roll_versus_speed": {
                    "wave_height_m": h_worst,
                    "speed_m_s": speed["speed_m_s"],
                    "head_max_roll_deg": np.degrees(speed["head"]),
                    "following_max_roll_deg": np.degrees(speed["following"]),
                },
            },
            "ship": None if a.ship is None else ship_to_dict(a.ship, damping_source=a.damping["source"]),
            "kg_max": None
            if curve is None
            else {
                "draught_m": curve.draught,
                "km_m": curve.km,
                "kg_max_level1_m": curve.kg_max_level1,
                "kg_max_c1_m": curve.kg_max_c1,
                "heights": "above the baseline; from --draught-datum / --kg-datum: subtract config.datum's "
                "above_baseline_m",
                "delta_gm1_m": curve.delta_gm1,
                "r_pr": curve.r_pr,
                "roll_period_model": "2π k/√(g GM) with --roll-gyradius"
                if args.roll_gyradius is not None
                else "IS Code 2008 formula at each KG (a given --roll-period holds for one GM only)",
            },
            "verdict": a.verdict,
            "vulnerable": a.vulnerable,
            "level2_standards_verified": False,
            "level2_caution": LEVEL2_CAUTION,
            "summary": lines,
        }
        write_json(out / "sgisc.json", payload)
        nc = write_netcdf(out / "sgisc.nc", "sgisc", payload)
    print("\n".join(lines))
    if is_c11:
        print("Note: the c11 hull is REPRESENTATIVE (parametric), not the real C11 lines.")
    print(f"wrote {final / 'sgisc.json'}, {'sgisc.nc, ' if nc else ''}{', '.join(files[1:])}")
    return 0
