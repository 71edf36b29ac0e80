"""`jaxroll longterm`: long-term exceedance probability over a wave scatter diagram, headings, speeds and loading
conditions — per exposure and per year, with the cells that dominate it (docs/longterm.md).

Headings in degrees (0 following, 90 beam, 180 head; 0 … 345 with port/starboard symmetry), speeds in m/s, as
`jaxroll sweep`. Writes longterm.nc, longterm.json and three figures into --out as one set; with --part i/N only
the partial dataset `longterm.part-i-of-N.nc` (merge the parts with `jaxroll merge`).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from ._common import (
    CLIError,
    OutputFolder,
    Progress,
    add_chunk_option,
    add_memory_option,
    check_chunk_size,
    load_ship_arg,
    memory_budget,
    save_figure,
    write_json,
    write_netcdf,
)
from ._sea import (
    _filter_order,
    add_spreading_option,
    check_filter_order,
    spreading_from_args,
    word_or_number,
)

#: --model-factor: 'measured' or a number (checked by `check_options`).
_model_factor = word_or_number("measured", float)


_NAMED = {"head": 180.0, "beam": 90.0, "following": 0.0}
ALL_HEADINGS = [15.0 * i for i in range(24)]  # 0 … 345°


def register(sub) -> None:
    p = sub.add_parser(
        "longterm",
        help="long-term P(roll > angle) over a wave scatter diagram, headings, speeds and loadings (per exposure, "
        "per year, dominating cells)",
        description="Short-term P(max |roll| > angle within --hours) in every cell (H_s, T_z, heading, speed, "
        "loading) by theory, Monte Carlo or both (--method auto), weighted by the scatter diagram and the heading, "
        "speed and loading probabilities: the long-term probability per exposure and per year with a 95 % interval "
        "(sampling and model allowance), and the cells that dominate it. Writes longterm.nc (every cell), "
        "longterm.json and figures into --out.",
    )
    g = p.add_argument_group("cells (full scale)")
    g.add_argument(
        "--scatter",
        default="rec34",
        metavar="rec34|FILE.csv",
        help="wave scatter diagram: rec34 (IACS Rec. 34, North Atlantic, shipped) or a CSV file: first row "
        "hs_m,<Tz1>,<Tz2>,… [s], then one row per H_s [m] with its counts (default rec34); each sea is "
        "ITTC with T01 = 1.0864 T_z",
    )
    g.add_argument(
        "--heading",
        default="all",
        metavar="LIST|all",
        help="headings χ [deg] in [0, 360): 0 following, 90 beam, 180 head (or head/beam/following); all: "
        "0 … 345 every 15° (default); χ and 360 − χ are computed once (port/starboard)",
    )
    g.add_argument(
        "--heading-weights",
        default=None,
        metavar="LIST",
        help="probability of each heading (default uniform; normalised)",
    )
    add_spreading_option(g)
    g.add_argument("--speed", default="0", metavar="LIST", help="ship speeds U [m/s] (default 0)")
    g.add_argument(
        "--speed-weights", default=None, metavar="LIST", help="probability of each speed (default uniform)"
    )
    g.add_argument(
        "--ship",
        default=None,
        metavar="FILE[,FILE…]",
        help="ship files (TOML) of the loading conditions, or c11-hull; default: C11 (representative)",
    )
    g.add_argument(
        "--ship-weights",
        default=None,
        metavar="LIST",
        help="probability of each loading condition (default uniform)",
    )
    r = p.add_argument_group("risk")
    r.add_argument("--angle", default="30", metavar="LIST", help="roll angles [deg] (default 30)")
    r.add_argument("--hours", type=float, default=3.0, help="exposure per cell [h] (default 3)")
    r.add_argument(
        "--hours-per-year",
        type=float,
        default=8766.0,
        help="hours at sea per year, for the per-year values (default 8766: all year)",
    )
    r.add_argument(
        "--method",
        choices=("theory", "monte-carlo", "auto"),
        default="theory",
        help="theory in every cell (default); Monte Carlo in every cell; auto: theory everywhere and "
        "Monte Carlo where a cell dominates or the theory fails a validity check. A ship carrying a direct wave "
        "moment ([wave_moment]) has no theory off head and following seas: auto simulates those cells, theory "
        "refuses them",
    )
    r.add_argument(
        "--realizations",
        type=int,
        default=1000,
        help="Monte Carlo trials per cell (auto: on average per Monte Carlo cell, Neyman-allocated) "
        "(default 1000)",
    )
    r.add_argument("--discard", type=float, default=500.0, help="initial transient of each trial [s] (500)")
    r.add_argument(
        "--auto-share",
        type=float,
        default=0.9,
        help="auto: Monte Carlo on the smallest set of cells carrying this share of the theory's "
        "long-term value (0.9)",
    )
    r.add_argument(
        "--auto-tolerance",
        type=float,
        default=0.01,
        help="auto: and on doubtful theory cells whose worst case exceeds this fraction of it (0.01)",
    )
    r.add_argument(
        "--model-factor",
        type=_model_factor,
        default="measured",
        help="allowance on theory cells in the long-term interval, [P/f, f·P]: measured (default: f measured "
        "against an exact-spectrum sea in the cell's T01 band, the widest measured outside the validated map) or "
        "a number f >= 1 for every cell",
    )
    r.add_argument(
        "--skip-weight",
        type=float,
        default=0.0,
        help="leave out the lightest cells up to this total weight (a bound added to the interval; 0)",
    )
    r.add_argument(
        "--refine-delta",
        type=float,
        default=0.01,
        help="theory in two passes: the cells outside the smallest set carrying 1 - δ of the one-grid sum w·P per "
        "heading class and speed keep the one-grid value (0: every cell refined; 0.01)",
    )
    r.add_argument(
        "--estimator",
        default="brute-force",
        metavar="brute-force|splitting",
        help="per-cell Monte Carlo estimator: brute-force (default), or splitting: the rare Monte Carlo cells "
        "(P < --rare-below) by multilevel splitting, every angle from one run, the others by brute force "
        "(docs/longterm.md, Rare cells)",
    )
    r.add_argument(
        "--rare-below",
        type=float,
        default=1e-3,
        metavar="P",
        help="--estimator splitting: a Monte Carlo cell is rare where its probability at the largest angle is "
        "below P — the theory's with --method auto, its splitting pilot's with --method monte-carlo (1e-3)",
    )
    n = p.add_argument_group("numerics")
    n.add_argument("--dt", type=float, default=0.5, help="time step [s] (default 0.5)")
    n.add_argument(
        "--excitation",
        choices=("filter", "superposition"),
        default="filter",
        help="effective wave of the Monte Carlo: Method 2 shaping filter (default) or superposition; the cells "
        "where a ship's direct wave moment joins the roll run the superposition (both from the same waves)",
    )
    n.add_argument(
        "--filter-order",
        type=_filter_order,
        default="auto",
        help="order of the Method-2 filter, or auto (default): 4, or 8 where 4 does not follow the effective-wave "
        "spectrum within 5 %% where the roll is excited, per sea state (4 is the paper's)",
    )
    n.add_argument("--phi0-deg", type=float, default=5.0, help="initial roll of each trial [deg] (5)")
    n.add_argument(
        "--seed",
        type=int,
        default=0,
        help="random seed (default 0); cell c uses seed 1000000·SEED + c + 1, recorded per cell",
    )
    s = p.add_argument_group("scale-out")
    add_chunk_option(s, streaming=True, what="trials")
    add_memory_option(s)
    s.add_argument(
        "--checkpoint", metavar="DIR", default=None, help="save each finished cell in DIR; a rerun resumes"
    )
    s.add_argument(
        "--part",
        default=None,
        metavar="i/N",
        help="compute part i of N (1 <= i <= N, e.g. a SLURM array task) and write the partial dataset "
        "longterm.part-i-of-N.nc; merge the parts with `jaxroll merge`",
    )
    s.add_argument(
        "--distributed",
        action="store_true",
        help="call jax.distributed.initialize() first and share the cells among the processes "
        "(docs/scaling.md)",
    )
    p.add_argument(
        "--out", default="jaxroll-out/longterm", help="output folder (default jaxroll-out/longterm)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def _floats(text: str, option: str) -> list[float]:
    try:
        values = [float(v) for v in str(text).split(",") if v.strip()]
    except ValueError:
        raise CLIError(f"{option} must be a comma-separated list of numbers; got {text!r}.") from None
    if not values:
        raise CLIError(f"{option} must hold at least one number; got {text!r}.")
    return values


def parse_headings(text: str) -> list[float]:
    """Headings [deg] in [0, 360) from `all` or a list of degrees / head / beam / following. Raises CLIError."""
    if str(text).strip().lower() == "all":
        return list(ALL_HEADINGS)
    out = []
    for item in str(text).split(","):
        t = item.strip().lower()
        if t in _NAMED:
            value = _NAMED[t]
        else:
            try:
                value = float(t.removesuffix("deg").removesuffix("°"))
            except ValueError:
                value = math.nan
        if not (0.0 <= value < 360.0):
            raise CLIError(
                f"--heading must be all or a list of angles in degrees in [0, 360) (0 following, 90 beam, "
                f"180 head) or head/beam/following; got {item.strip()!r}."
            )
        out.append(value)
    if len(set(out)) != len(out):
        raise CLIError(f"--heading repeats a heading: {text!r}.")
    return out


def weights(text, n: int, option: str, what: str) -> list[float] | None:
    """The weights of an option (None: uniform), checked: one per value, finite, >= 0, not all zero."""
    if text is None:
        return None
    w = _floats(text, option)
    if len(w) != n:
        raise CLIError(
            f"{option} has {len(w)} weights for {n} {what}; give one weight per value (or leave it out "
            "for uniform weights)."
        )
    if not all(math.isfinite(x) and x >= 0 for x in w):
        raise CLIError(f"{option} must be finite numbers >= 0; got {text!r}.")
    if not max(w) > 0:
        raise CLIError(f"{option} sum to zero: give at least one {what[:-1]} a positive weight.")
    return w


def check_args(args):
    """Every option, before any computation. **Returns:** the keyword arguments of `jaxroll.longterm`, the ship
    files and the headings [deg]."""
    from .. import vanishing_angle
    from ..longterm import (
        CELL_ESTIMATORS,
        MAX_SEED,
        ScatterError,
        check_exposure,
        check_speeds,
        scatter_diagram,
    )
    from ..roll import SPLITTING_EXCITATIONS

    for name in ("hours", "hours_per_year", "dt"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            raise CLIError(f"--{name.replace('_', '-')} must be a finite number > 0; got {value}.")
    if not (math.isfinite(args.discard) and args.discard >= 0):
        raise CLIError(f"--discard must be a finite number >= 0 [s]; got {args.discard}.")
    if args.realizations < 1:
        raise CLIError(f"--realizations must be >= 1; got {args.realizations}.")
    if not 0 <= args.seed <= MAX_SEED:
        raise CLIError(f"--seed must be an integer in [0, {MAX_SEED}] (10^12 - 1); got {args.seed}.")
    try:
        check_exposure(args.hours * 3600.0, args.hours_per_year, ("--hours", "--hours-per-year"))
    except ValueError as e:
        raise CLIError(str(e)) from None
    if not 0 < args.auto_share <= 1:
        raise CLIError(f"--auto-share must be in (0, 1]; got {args.auto_share}.")
    if not (math.isfinite(args.auto_tolerance) and args.auto_tolerance >= 0):
        raise CLIError(f"--auto-tolerance must be >= 0; got {args.auto_tolerance}.")
    if args.model_factor != "measured" and not (
        isinstance(args.model_factor, float) and math.isfinite(args.model_factor) and args.model_factor >= 1
    ):
        raise CLIError(
            f"--model-factor must be measured or a number >= 1 (1: the theory taken as exact); got "
            f"{args.model_factor!r}."
        )
    if not 0 <= args.skip_weight < 1:
        raise CLIError(f"--skip-weight must be in [0, 1); got {args.skip_weight}.")
    if not (math.isfinite(args.refine_delta) and 0 <= args.refine_delta < 1):
        raise CLIError(f"--refine-delta must be in [0, 1); got {args.refine_delta}.")
    check_filter_order(args)
    spreading = spreading_from_args(args)
    if not math.isfinite(args.phi0_deg) or args.phi0_deg == 0:
        raise CLIError(
            f"--phi0-deg must be a finite non-zero angle (a ship started upright stays upright); got "
            f"{args.phi0_deg}."
        )
    estimator = args.estimator.replace("-", "_")
    if estimator not in CELL_ESTIMATORS:
        raise CLIError(
            f"--estimator must be one of {', '.join(e.replace('_', '-') for e in CELL_ESTIMATORS)}; got "
            f"{args.estimator!r}."
        )
    if not (math.isfinite(args.rare_below) and 0 < args.rare_below <= 1):
        raise CLIError(
            f"--rare-below must be a probability in (0, 1] (a Monte Carlo cell is rare, and estimated by "
            f"splitting, where its probability is below it); got {args.rare_below}."
        )
    if estimator == "splitting" and args.excitation not in SPLITTING_EXCITATIONS:
        raise CLIError(
            "--estimator splitting needs --excitation filter (splitting restarts runs from the shaping filter's "
            f"state); got --excitation {args.excitation}."
        )
    check_chunk_size(args)
    budget = memory_budget(args)
    part = None
    if args.part is not None:
        try:
            i, n = (int(x) for x in args.part.split("/"))
        except ValueError:
            i = n = 0
        if not 1 <= i <= n:
            raise CLIError(f"--part must be i/N with integers 1 <= i <= N (e.g. 2/8); got {args.part!r}.")
        part = (i, n)
    headings = parse_headings(args.heading)
    hw = weights(args.heading_weights, len(headings), "--heading-weights", "headings")
    speeds = _floats(args.speed, "--speed")
    if not all(math.isfinite(u) and u >= 0 for u in speeds) or len(set(speeds)) != len(speeds):
        raise CLIError(f"--speed must be distinct finite speeds >= 0 [m/s]; got {args.speed!r}.")
    sw = weights(args.speed_weights, len(speeds), "--speed-weights", "speeds")
    angles = _floats(args.angle, "--angle")
    if not all(math.isfinite(a) and 0 < a < 90 for a in angles) or len(set(angles)) != len(angles):
        raise CLIError(f"--angle must be distinct angles in (0, 90) degrees; got {args.angle!r}.")
    files = [f.strip() for f in args.ship.split(",")] if args.ship else [None]
    if any(f == "" for f in files) or len(set(files)) != len(files):
        raise CLIError(f"--ship must be distinct ship files separated by commas; got {args.ship!r}.")
    shw = weights(args.ship_weights, len(files), "--ship-weights", "ships")
    try:
        scatter = scatter_diagram(args.scatter)
    except ScatterError as e:
        raise CLIError(f"--scatter: {e}") from None
    except FileNotFoundError as e:
        raise CLIError(f"--scatter: {e} Give rec34 or a CSV file.") from None
    ships = [load_ship_arg(f) for f in files]
    try:
        check_speeds(speeds, ships, "--speed")
    except ValueError as e:
        raise CLIError(str(e)) from None
    names = [s.name if f in (None, "c11-hull") else Path(f).stem for s, f in zip(ships, files, strict=True)]
    if len(set(names)) != len(names):
        names = [f or s.name for s, f in zip(ships, files, strict=True)]
    for ship in ships:
        vanish = math.degrees(float(vanishing_angle(ship)))
        for a in angles:
            if a >= vanish:
                raise CLIError(
                    f"--angle {a:g}° is not below the angle of vanishing stability of {ship.name} "
                    f"({vanish:.1f}°): beyond it the ship capsizes (capsizes are counted separately); "
                    "choose a smaller angle."
                )
    kwargs = dict(
        scatter=scatter,
        ships=ships,
        ship_weights=shw,
        ship_names=names,
        ship_files=files,
        headings=[math.radians(h) for h in headings],
        heading_weights=hw,
        speeds=speeds,
        speed_weights=sw,
        angles=[math.radians(a) for a in angles],
        exposure=args.hours * 3600.0,
        method=args.method,
        realizations=args.realizations,
        discard=args.discard,
        dt=args.dt,
        excitation=args.excitation,
        filter_order=args.filter_order,
        phi0=math.radians(args.phi0_deg),
        seed=args.seed,
        hours_per_year=args.hours_per_year,
        auto_share=args.auto_share,
        auto_tolerance=args.auto_tolerance,
        model_factor=args.model_factor,
        skip_weight=args.skip_weight,
        refine_delta=args.refine_delta,
        estimator=estimator,
        rare_below=args.rare_below,
        spreading=spreading,
        part=part,
        checkpoint=args.checkpoint,
        chunk_size=args.chunk_size,
        memory_budget=budget,
    )
    return kwargs


class _Phases:
    """The progress of `jaxroll.longterm`'s phases (theory cells, Monte Carlo trials), one line each."""

    def __init__(self, enabled):
        self.enabled, self.bars = enabled, {}

    def __call__(self, done: int, total: int, phase: str) -> None:
        if phase not in self.bars:
            label = "theory cells" if phase == "theory" else "Monte Carlo trials"
            self.bars[phase] = Progress(max(total, 1), label, enabled=self.enabled)
        self.bars[phase](done)


def write_outputs(ds, out: Path, run_time: float | None = None) -> dict:
    """longterm.json, longterm.nc (the JSON's numbers and every cell of `ds`, one labelled dataset:
    `write_netcdf`) and the figures of a whole (not partial) dataset, as one set into `out`."""
    import json

    from .. import longterm_summary
    from ..plotting import longterm_ci_figure, longterm_polar_figure, longterm_scatter_figure

    summary = longterm_summary(ds)
    payload = {"config": json.loads(ds.attrs["config_json"]), **summary}
    if run_time is not None:
        payload["run_time_s"] = run_time
    with OutputFolder(out) as tmp:
        save_figure(longterm_scatter_figure(ds), tmp / "longterm_scatter.png")
        save_figure(longterm_polar_figure(ds), tmp / "longterm_polar.png")
        save_figure(longterm_ci_figure(ds, summary), tmp / "longterm_ci.png")
        write_json(tmp / "longterm.json", payload)
        written = write_netcdf(tmp / "longterm.nc", "longterm", payload, ds)
    return {**summary, "_netcdf_written": written}


def print_summary(summary: dict, out: Path) -> None:
    hours = summary["exposure_hours"]
    for angle, row in summary["longterm"].items():
        lo, hi = row["probability_ci95"]
        y = row["per_year"]
        print(
            f"P(roll > {angle}° within {hours:g} h) = {row['probability']:.4g} (95 % {lo:.4g}–{hi:.4g}); "
            f"per year: P = {y['probability']:.4g}, {y['rate']:.4g} exposures with an exceedance"
        )
        if "parametric_probability" in row:  # a ship carrying a direct wave moment: the parametric-only share
            plo, phi = row["parametric_probability_ci95"]
            print(
                f"  parametric only (direct wave moment off): P = {row['parametric_probability']:.4g} (95 % "
                f"{plo:.4g}–{phi:.4g}), {row['parametric_share']:.3g} of the total"
            )
        for cell in row["dominating_cells"][:3]:
            print(
                f"  {cell['share']:6.1%}  H_s {cell['hs_m']:g} m, T_z {cell['tz_s']:g} s, χ {cell['heading_deg']:g}°, "
                f"U {cell['speed_m_s']:g} m/s, {cell['ship']}: P = {cell['probability']:.3g} "
                f"({'splitting' if cell.get('estimator') == 'splitting' else cell['method']})"
            )
    c = summary["longterm_capsize"]
    print(
        f"P(capsize within {hours:g} h) = {c['probability']:.3g} (95 % {c['probability_ci95'][0]:.3g}–"
        f"{c['probability_ci95'][1]:.3g}); cells: "
        + ", ".join(f"{k} {v}" for k, v in summary["cells"].items() if v)
        + (
            f" (splitting {summary['monte_carlo_estimators']['splitting']})"
            if summary.get("monte_carlo_estimators", {}).get("splitting")
            else ""
        )
    )
    print(
        f"wrote {out}/longterm.json, {'longterm.nc, ' if summary.get('_netcdf_written', True) else ''}"
        "longterm_scatter.png, longterm_polar.png, "
        "longterm_ci.png"
    )


def run(args) -> int:
    import jax

    if args.distributed:
        from .sweep import initialize_distributed

        initialize_distributed()
    from .. import longterm
    from ..io import write_dataset

    out = Path(args.out)  # checked writable before the command ran (`prepare_out`)
    main = jax.process_index() == 0
    kwargs = check_args(args)
    if main and args.ship is None:
        print("Ship: C11 (representative) — Table-1 particulars, representative coefficients.")
    t0 = time.time()
    ds = longterm(**kwargs, progress=_Phases(False if args.quiet or not main else None))
    elapsed = time.time() - t0
    if not main:
        return 0
    if kwargs["part"] is not None:
        i, n = kwargs["part"]
        path = out / f"longterm.part-{i}-of-{n}.nc"
        ds.attrs["run_time_s"] = elapsed  # (not in the part's digest; `jaxroll merge` sums them)
        write_dataset(path, ds)
        print(f"part {i}/{n} done in {elapsed:.1f} s: wrote {path} (merge the parts with `jaxroll merge`)")
        return 0
    summary = write_outputs(ds, out, elapsed)
    print(f"done in {elapsed:.1f} s")
    print_summary(summary, out)
    return 0
