"""`jaxroll sweep`: capsize and angle-exceedance probability maps over H1/3 × T01 × speed × heading.

Headings are degrees here (0° following, 90° beam, 180° head); with two or more headings and speeds the sweep
also draws the polar risk chart (`jaxroll.plotting.sweep_polar_figure`) of every sea state.
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
    check_chunk_size,
    load_ship_arg,
    save_figure,
    write_json,
    write_netcdf,
)
from ._sea import (
    _filter_order,
    add_spreading_option,
    check_filter_order,
    check_steps,
    heading_for_api,
    heading_number,
    heading_phrase,
    spreading_from_args,
    spreading_label,
)


def register(sub) -> None:
    p = sub.add_parser(
        "sweep",
        help="capsize / angle-exceedance probability maps over sea states (H1/3 × T01 × speed × heading)",
        description="For every sea state of the grid, runs a Monte Carlo of --realizations trials of "
        "--duration s "
        "and estimates P(capsize) and P(max |φ| > --angle within the duration), with Wilson confidence "
        "intervals. Writes sweep.png, sweep.json and sweep.nc into --out, and sweep_polar.png (the polar risk chart: "
        "probability over speed × heading for each sea state) when two or more headings and speeds are given.",
    )
    g = p.add_argument_group("grid (comma-separated lists; full scale)")
    g.add_argument("--hs", default="3,5,7", help="significant wave heights H1/3 [m] (default 3,5,7)")
    g.add_argument("--t01", default="8,10,12", help="mean wave periods T01 [s] (default 8,10,12)")
    g.add_argument("--speed", default="0", help="ship speeds [m/s] (default 0)")
    g.add_argument(
        "--heading",
        default="head",
        help="headings χ [deg] in [0, 180] (0 following, 90 beam, 180 head), or head / following; "
        "e.g. 0,45,90,135,180 (default head)",
    )
    add_spreading_option(g)
    g.add_argument(
        "--ship", metavar="FILE", default=None, help="ship file (TOML); default: C11 (representative)"
    )
    m = p.add_argument_group("Monte Carlo")
    m.add_argument(
        "--angle", type=float, default=30.0, help="roll angle whose exceedance is counted [deg] (30)"
    )
    m.add_argument("--confidence", type=float, default=0.95, help="level of the Wilson intervals (0.95)")
    m.add_argument("--realizations", type=int, default=200, help="trials per sea state (default 200)")
    m.add_argument("--duration", type=float, default=1800.0, help="simulated time per trial [s] (1800)")
    m.add_argument("--discard", type=float, default=0.0, help="initial time left out of the maximum [s] (0)")
    m.add_argument("--phi0-deg", type=float, default=5.0, help="initial roll angle [deg] (5)")
    m.add_argument("--dt", type=float, default=0.5, help="time step [s] (default 0.5)")
    m.add_argument(
        "--method",
        choices=("auto", "filter", "superposition"),
        default="auto",
        help="effective wave method: auto (default) is the filter, but superposition for a ship carrying a wave "
        "moment at oblique and beam headings (docs/wave_moment.md)",
    )
    m.add_argument(
        "--filter-order",
        type=_filter_order,
        default="auto",
        help="order of the Method-2 filter, or auto (default): 4, or 8 where 4 does not follow the effective-wave "
        "spectrum within 5 %% where the roll is excited, per sea state (4 is the paper's)",
    )
    m.add_argument(
        "--seed", type=int, default=0, help="random seed (default 0; the same trials at every point)"
    )
    s = p.add_argument_group("scale-out")
    add_chunk_option(s, streaming=True)
    s.add_argument("--devices", type=int, default=None, help="use the first N devices (default: all)")
    s.add_argument("--checkpoint", metavar="DIR", default=None, help="save progress in DIR; a rerun resumes")
    s.add_argument(
        "--distributed",
        action="store_true",
        help="call jax.distributed.initialize() first (one process per host; see docs/scaling.md)",
    )
    p.add_argument("--out", default="jaxroll-out/sweep", help="output folder (default ./jaxroll-out/sweep)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def parse_list(text: str, option: str, *, minimum: float, strict: bool = True) -> list[float]:
    """Sorted distinct floats from 'a,b,c'; each finite and > minimum (>= when not `strict`)."""
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise CLIError(f"{option} must be a comma-separated list of numbers; got {text!r}.") from None
    if not values:
        raise CLIError(f"{option} needs at least one value; got {text!r}.")
    for v in values:
        if not math.isfinite(v) or (v <= minimum if strict else v < minimum):
            raise CLIError(
                f"{option} values must be finite and {'>' if strict else '>='} {minimum:g}; got {v:g}."
            )
    return sorted(set(values))


def parse_headings(text: str) -> list[float]:
    """Distinct headings χ [deg] in [0, 180] from 'head,following' or '0,45,90' (in the order given)."""
    values = [heading_number(h) for h in text.split(",") if h.strip()]
    if not values or None in values:
        raise CLIError(
            "--heading must be head, following, beam or a list such as head,following, or angles in degrees in "
            "[0, 180] "
            f"(0 following, 90 beam, 180 head); got {text!r}."
        )
    return sorted(set(values), key=values.index)


def sweep_figure(payload: dict):
    """Maps of P(capsize) and P(max |φ| > angle) on (T01, H1/3), one column per (heading, speed); where H1/3 and T01
    do not both vary (a map would be a strip or a single cell), the two probabilities as curves with their 95 %
    intervals (`_sweep_curves`)."""
    import matplotlib.pyplot as plt
    import numpy as np

    grid = payload["grid"]
    hs, t01 = np.asarray(grid["hs_m"]), np.asarray(grid["t01_s"])
    if hs.size == 1 or t01.size == 1:
        return _sweep_curves(payload)
    cases = [(h, u) for h in grid["heading"] for u in grid["speed_m_s"]]
    phrase = dict(zip(grid["heading"], map(heading_phrase, payload["heading_deg"]), strict=True))
    angle = payload["config"]["angle_deg"]
    rows = (("capsize_probability", "P(capsize)"), ("exceedance_probability", f"P(max |φ| > {angle:g}°)"))
    ncol = min(len(cases), 6)  # many (heading, speed) cases wrap onto further pairs of rows
    blocks = -(-len(cases) // ncol)
    fig, axes = plt.subplots(
        2 * blocks, ncol, figsize=(3.6 * ncol + 1.2, 6.4 * blocks), squeeze=False, layout="constrained"
    )
    for c in range(len(cases), blocks * ncol):
        axes[2 * (c // ncol), c % ncol].set_visible(False)
        axes[2 * (c // ncol) + 1, c % ncol].set_visible(False)

    def edges(x):
        if x.size == 1:
            return np.array([x[0] - 0.5, x[0] + 0.5])
        mid = (x[1:] + x[:-1]) / 2
        return np.concatenate([[2 * x[0] - mid[0]], mid, [2 * x[-1] - mid[-1]]])

    mesh = None
    for r, (name, label) in enumerate(rows):
        values = np.asarray(payload[name], float)
        for c, (h, u) in enumerate(cases):
            ax = axes[2 * (c // ncol) + r, c % ncol]
            z = values[grid["heading"].index(h), grid["speed_m_s"].index(u)]
            mesh = ax.pcolormesh(edges(t01), edges(hs), z, cmap="magma_r", vmin=0, vmax=1, shading="flat")
            if hs.size > 1 and t01.size > 1 and np.ptp(z) > 0:
                cs = ax.contour(t01, hs, z, levels=[0.01, 0.1, 0.5], colors="tab:cyan", linewidths=1)
                ax.clabel(cs, fontsize=7, fmt="%g")
            for i, height in enumerate(hs):
                for j, period in enumerate(t01):
                    ax.text(
                        period,
                        height,
                        f"{z[i, j]:.2f}",
                        ha="center",
                        va="center",
                        fontsize=7,
                        color="w" if z[i, j] > 0.5 else "k",
                    )
            ax.set_title(f"{label}\n{phrase[h]}, U = {u:g} m/s", fontsize=9)
            ax.set_xlabel("T01 [s]")
            ax.set_ylabel("H1/3 [m]")
    fig.colorbar(mesh, ax=axes, label="probability per trial", shrink=0.8)
    cfg = payload["config"]
    fig.suptitle(
        f"{cfg['ship']['name']}: N = {cfg['realizations']} trials × {cfg['duration_s']:g} s per sea state",
        fontsize=10,
    )
    return fig


def _sweep_curves(payload: dict):
    """P(capsize) and P(max |φ| > angle) with their 95 % intervals against the first axis of the sweep that varies —
    H1/3, T01, speed, heading in that order — one curve per value of the others (for `sweep_figure`)."""
    import matplotlib.pyplot as plt
    import numpy as np

    grid = payload["grid"]
    names = ("heading", "speed_m_s", "hs_m", "t01_s")  # the axes of the probability arrays
    values = {name: list(grid[name]) for name in names}
    values["heading"] = list(payload["heading_deg"])  # χ [deg], in the order of grid["heading"]
    x_name = next((n for n in ("hs_m", "t01_s", "speed_m_s", "heading") if len(values[n]) > 1), "hs_m")
    x_axis = names.index(x_name)
    x_label = {"hs_m": "H1/3 [m]", "t01_s": "T01 [s]", "speed_m_s": "speed U [m/s]",
               "heading": "heading χ [deg] (0 following, 90 beam, 180 head)"}[x_name]  # fmt: skip
    x = np.asarray(values[x_name], float)
    order = np.argsort(x)
    others = [n for n in names if n != x_name]
    angle = payload["config"]["angle_deg"]

    def describe(n, v):
        return {"heading": heading_phrase(v), "speed_m_s": f"U {v:g} m/s", "hs_m": f"H1/3 {v:g} m",
                "t01_s": f"T01 {v:g} s"}[n]  # fmt: skip

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    rows = (("capsize", "P(capsize)"), ("exceedance", f"P(max |φ| > {angle:g}°)"))
    for ax, (name, title) in zip(axes, rows, strict=True):
        p = np.moveaxis(np.asarray(payload[f"{name}_probability"], float), x_axis, -1)
        ci = np.moveaxis(np.asarray(payload[f"{name}_ci"], float), x_axis, -2)
        for idx in np.ndindex(p.shape[:-1]):
            label = ", ".join(describe(n, values[n][i]) for n, i in zip(others, idx, strict=True)
                              if len(values[n]) > 1) or None  # fmt: skip
            y, lo, hi = p[idx][order], ci[idx][order, 0], ci[idx][order, 1]
            ax.errorbar(x[order], y, yerr=[y - lo, hi - y], marker="o", ms=4, capsize=3, label=label)
        ax.set_xlabel(x_label)
        ax.set_ylabel(f"{title} per trial")
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=8)
    fixed = ", ".join(describe(n, values[n][0]) for n in others if len(values[n]) == 1)
    cfg = payload["config"]
    fig.suptitle(
        f"{cfg['ship']['name']}: {fixed}; N = {cfg['realizations']} trials × {cfg['duration_s']:g} s per point "
        "(bars: 95 % Wilson intervals)",
        fontsize=10,
    )
    return fig


_BOOT = """import os, sys, jax
os.environ["JAXROLL_DISTRIBUTED_BOOT"] = "1"
kwargs = {}
for var, name in (("JAXROLL_NUM_PROCESSES", "num_processes"), ("JAXROLL_PROCESS_ID", "process_id")):
    if os.environ.get(var):
        kwargs[name] = int(os.environ[var])
jax.distributed.initialize(**kwargs)
from jaxroll._cli import main
sys.exit(main(sys.argv[1:]))
"""


def initialize_distributed() -> None:
    """`jax.distributed.initialize()`: SLURM, Open MPI and Kubernetes are detected by JAX; elsewhere set
    JAX_COORDINATOR_ADDRESS (host:port of process 0), JAXROLL_NUM_PROCESSES and JAXROLL_PROCESS_ID.

    It must run before JAX initialises its backend, which importing jaxroll already does (module-level
    arrays). So the command restarts itself (`os.execv`, same process id) as a Python that initialises the
    distributed runtime first, then imports jaxroll and runs the same command line.
    """
    import os
    import sys

    import jax

    if jax.distributed.is_initialized() or os.environ.get("JAXROLL_DISTRIBUTED_BOOT"):
        return
    for var in ("JAXROLL_NUM_PROCESSES", "JAXROLL_PROCESS_ID"):
        if os.environ.get(var) and not os.environ[var].isdigit():
            raise CLIError(f"{var} must be a non-negative integer; got {os.environ[var]!r}.")
    argv = sys.argv[1:]
    if not {"sweep", "longterm"} & set(argv) or "--distributed" not in argv:
        raise CLIError(
            "--distributed needs the command line (`jaxroll sweep --distributed ...` or `jaxroll longterm "
            "--distributed ...`); from Python, call jax.distributed.initialize() before importing jaxroll instead."
        )
    sys.stdout.flush()
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, "-c", _BOOT, *argv])


def run(args) -> int:
    import jax

    if args.distributed:
        initialize_distributed()

    import jax.numpy as jnp
    import numpy as np

    from .. import ITTC, EffectiveWave, check_time_step, ship_to_dict, sweep_sea_states, vanishing_angle
    from ..plotting import sweep_polar_figure

    hs = parse_list(args.hs, "--hs", minimum=0)
    t01 = parse_list(args.t01, "--t01", minimum=0)
    speed = parse_list(args.speed, "--speed", minimum=0, strict=False)
    heading_deg = parse_headings(args.heading)
    heading = [heading_for_api(d) for d in heading_deg]
    check_chunk_size(args)
    if args.realizations < 1:
        raise CLIError(f"--realizations must be >= 1; got {args.realizations}.")
    for name in ("duration", "angle", "dt"):
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            raise CLIError(f"--{name} must be a finite number > 0; got {value}.")
    if not 0 <= args.discard < args.duration:
        raise CLIError(
            f"--discard must be in [0, --duration) = [0, {args.duration:g}) s; got {args.discard}."
        )
    if not 0 < args.confidence < 1:
        raise CLIError(f"--confidence must be in (0, 1); got {args.confidence}.")
    check_filter_order(args)
    spreading = spreading_from_args(args)
    check_steps(args.dt, {"--duration": args.duration})
    if args.devices is not None and not 1 <= args.devices <= jax.device_count():
        raise CLIError(
            f"--devices must be between 1 and {jax.device_count()} (the devices JAX sees); "
            f"got {args.devices}."
        )
    from ..roll import default_chunk_size

    chunk = args.chunk_size if args.chunk_size is not None else default_chunk_size(False, args.devices)
    ship = load_ship_arg(args.ship)
    capsize_deg = float(jnp.rad2deg(vanishing_angle(ship)))
    if args.angle >= capsize_deg:
        raise CLIError(
            f"--angle must be below the angle of vanishing stability, {capsize_deg:.1f}°; got {args.angle}."
        )
    # The time step against every sea state of the grid, before any simulation (the filter fits come later).
    for h in heading:
        for u in speed:
            for height in hs:
                for period in t01:
                    wave = EffectiveWave(ITTC(height, period), ship.lpp, u, h, spreading=spreading)
                    check_time_step(args.dt, ship, wave)
    main = jax.process_index() == 0
    n_points = len(hs) * len(t01) * len(speed) * len(heading)
    total = n_points * args.realizations
    if main:
        if args.ship is None:
            print("Ship: C11 (representative) — Table-1 particulars, representative coefficients.")
        print(
            f"Sweep: {n_points} sea states × {args.realizations} trials × {args.duration:g} s on "
            f"{args.devices or jax.device_count()} device(s) ({jax.default_backend()}), "
            f"{jax.process_count()} process(es)"
        )
    progress = Progress(total, "realizations", enabled=False if args.quiet or not main else None)
    t0 = time.time()
    result = sweep_sea_states(
        ship,
        jax.random.key(args.seed),
        hs=hs,
        t01=t01,
        speed=speed,
        heading=heading,
        angle_deg=args.angle,
        confidence=args.confidence,
        num_realizations=args.realizations,
        duration=args.duration,
        discard=args.discard,
        excitation=args.method,
        dt=args.dt,
        filter_order=args.filter_order,
        phi0=math.radians(args.phi0_deg),
        spreading=spreading,
        chunk_size=chunk,
        devices=args.devices,
        checkpoint=args.checkpoint,
        progress=progress,
    )
    elapsed = time.time() - t0
    config = {
        "sea": {"spectrum": "ITTC"},
        "heading_convention": "χ between the course and the wave direction: 0° following, 90° beam, 180° head",
        "spreading": spreading_label(args),
        "ship": ship_to_dict(ship),
        "ship_file": args.ship,
        "angle_deg": args.angle,
        "confidence": args.confidence,
        "realizations": args.realizations,
        "duration_s": args.duration,
        "discard_s": args.discard,
        "phi0_deg": args.phi0_deg,
        "dt_s": args.dt,
        "method": args.method,
        "filter_order": args.filter_order,
        "seed": args.seed,
        "common_random_numbers": True,
        "chunk_size": chunk,
        "devices": args.devices or jax.device_count(),
        "processes": jax.process_count(),
        "capsize_angle_deg": capsize_deg,
    }
    if args.ship is None:
        from ..ship import DEFAULT_SHIP_NOTE

        config["ship_note"] = DEFAULT_SHIP_NOTE
    cap_ci, exc_ci = result.capsize_interval(), result.exceedance_interval()
    points = []
    for index in np.ndindex(*result.n_capsized.shape):
        h, u, height, period = (v[i] for v, i in zip(result.grid.values(), index, strict=True))
        points.append(
            {
                "heading": h,
                "heading_deg": heading_deg[index[0]],
                "speed_m_s": u,
                "hs_m": height,
                "t01_s": period,
                "n_capsized": int(result.n_capsized[index]),
                "n_exceeded": int(result.n_exceeded[index]),
                "capsize_probability": float(result.capsize_probability[index]),
                "capsize_ci": cap_ci[index].tolist(),
                "exceedance_probability": float(result.exceedance_probability[index]),
                "exceedance_ci": exc_ci[index].tolist(),
            }
        )
    payload = {
        "config": config,
        "grid": {"axes": list(result.grid), **result.grid},
        "heading_deg": heading_deg,
        "n_realizations": result.n_realizations,
        "n_capsized": result.n_capsized,
        "n_exceeded": result.n_exceeded,
        "capsize_probability": result.capsize_probability,
        "capsize_ci": cap_ci,
        "exceedance_probability": result.exceedance_probability,
        "exceedance_ci": exc_ci,
        "exceedance_definition": f"per trial: max |φ| > {args.angle:g}° after the discard within the "
        "duration, or a capsize",
        "points": points,
        "run_time_s": elapsed,
    }
    if not main:
        return 0
    out = Path(args.out)
    polar = len(heading_deg) > 1 and len(speed) > 1
    with OutputFolder(out) as tmp:
        save_figure(sweep_figure(payload), tmp / "sweep.png")
        if polar:
            save_figure(sweep_polar_figure(payload), tmp / "sweep_polar.png")
        write_json(tmp / "sweep.json", payload)
        nc = write_netcdf(tmp / "sweep.nc", "sweep", payload, result.to_xarray())

    def where(p):
        return f"{heading_phrase(p['heading_deg'])}, U {p['speed_m_s']:g} m/s, H1/3 {p['hs_m']:g} m, T01 {p['t01_s']:g} s"

    w = points[int(np.argmax(result.capsize_probability))]
    e = points[int(np.argmax(result.exceedance_probability))]
    if w["n_capsized"]:
        capsize = f"largest P(capsize) {w['capsize_probability']:.3f} in {where(w)}"
    else:  # no capsize anywhere: the bound the trials give, not the first grid point's zero
        capsize = (
            f"no capsize at any of the {len(points)} points (P(capsize) < {w['capsize_ci'][1]:.3g} at each, "
            "95 %)"
        )
    exceed = (
        f"largest P(max |φ| > {args.angle:g}°) {e['exceedance_probability']:.3f} in {where(e)}"
        if e["n_exceeded"]
        else f"no trial beyond {args.angle:g}° at any point"
    )
    print(f"done in {elapsed:.1f} s: {capsize}; {exceed}")
    polar_note = f", {out / 'sweep_polar.png'}" if polar else ""
    print(
        f"wrote {out / 'sweep.png'}{polar_note}, {out / 'sweep.json'}"
        + (f", {out / 'sweep.nc'}" if nc else "")
    )
    return 0
