"""`jaxroll sensitivity`: derivatives of Monte Carlo roll statistics with respect to ship and sea parameters,
beside the theories' (Roberts, ESAM, moment method), as sensitivity.json and a bar chart."""

from __future__ import annotations

import math
import time
from pathlib import Path

from ..theory import SENSITIVITY_THEORIES
from ._common import CLIError, OutputFolder, Progress, load_ship_arg, save_figure, write_json, write_netcdf
from ._sea import (
    add_sea_options,
    check_positive,
    check_sea_options,
    check_steps,
    heading_for_api,
    moment_filter_order,
    parse_heading,
    resolved_method,
    sea_config,
)

THEORIES = SENSITIVITY_THEORIES  # roberts, esam, moment, envelope_fpk
DEFAULT_WRT = "gm_correction,b1,b2,gm0,hs"
# per statistic kind: JSON key suffix and the factor from radians
_DEG = 180 / math.pi


def register(sub) -> None:
    p = sub.add_parser(
        "sensitivity",
        help="d(roll statistic)/d(ship or sea parameter) by Monte Carlo (windowed pathwise AD) and by theory",
        description="Derivatives of E[φ²], the mean envelope and zero-crossing amplitudes and smoothed exceedance "
        "probabilities with respect to ship and sea parameters (docs/sensitivity.md); writes sensitivity.json, "
        "sensitivity.nc and sensitivity.png into --out.",
    )
    add_sea_options(p, spreading=False)  # the sensitivity problem is long-crested
    m = p.add_argument_group("sensitivities")
    m.add_argument(
        "--wrt",
        default=DEFAULT_WRT,
        help=f"comma-separated parameters (default {DEFAULT_WRT}); any of gm0, b1, b2, b3, gm_correction, "
        "c0…c6 (ΔGM), hs, t01, speed",
    )
    m.add_argument(
        "--statistics",
        default="E_phi2,mean_envelope,mean_zero_crossing,P_exceed_20deg",
        help="comma-separated statistics: E_phi2, mean_envelope, mean_zero_crossing, P_exceed_<a>deg (envelope), "
        "P_exceed_zc_<a>deg (zero-crossing amplitudes)",
    )
    m.add_argument("--realizations", type=int, default=1000, help="number of realizations (default 1000)")
    m.add_argument("--duration", type=float, default=3600.0, help="simulated time per realization [s] (3600)")
    m.add_argument("--discard", type=float, default=0.0, help="initial transient left out [s] (0)")
    m.add_argument("--phi0-deg", type=float, default=5.0, help="initial roll angle [deg] (5)")
    m.add_argument("--window", type=float, default=300.0, help="scored window of the estimator [s] (300)")
    m.add_argument(
        "--burn-in", type=float, default=300.0, help="tangent burn-in before each window [s] (300)"
    )
    m.add_argument("--no-extrapolate", action="store_true", help="do not extrapolate the burn-in bias away")
    m.add_argument(
        "--smoothing-deg", type=float, default=1.0, help="exceedance smoothing bandwidth [deg] (1)"
    )
    m.add_argument(
        "--chunk-size", type=int, default=250, help="realizations per compiled batch (memory bound)"
    )
    m.add_argument(
        "--theory",
        default=",".join(THEORIES),
        help=f"comma-separated theories to differentiate: {','.join(THEORIES)} (default all; '' for none)",
    )
    p.add_argument(
        "--out", default="jaxroll-out/sensitivity", help="output folder (default ./jaxroll-out/sensitivity)"
    )
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def _names(text: str, allowed, what: str) -> list[str]:
    names = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [n for n in names if n not in allowed]
    if unknown:
        raise CLIError(f"{what}: unknown {unknown}; choose from {', '.join(allowed)}.")
    if len(set(names)) != len(names):
        raise CLIError(f"{what}: a name is given twice: {names}.")
    return names


def json_key(stat: str) -> tuple[str, float]:
    """The JSON key of a statistic and the factor from its radian value: E_phi2 → E_phi2_deg2, amplitudes →
    *_deg, probabilities unchanged."""
    if stat == "E_phi2":
        return "E_phi2_deg2", _DEG**2
    if stat.startswith("mean_"):
        return f"{stat}_deg", _DEG
    return stat, 1.0


def run(args) -> int:
    import jax

    from .. import SENSITIVITY_PARAMETERS, monte_carlo_sensitivity, sensitivity_problem
    from ..plotting import sensitivity_bar_chart
    from ..theory import theory_sensitivities

    wrt = _names(args.wrt, tuple(SENSITIVITY_PARAMETERS), "--wrt")
    if not wrt:
        raise CLIError("--wrt names no parameter.")
    stats = [t.strip() for t in args.statistics.split(",") if t.strip()]
    theories = _names(args.theory, THEORIES, "--theory")
    check_sea_options(args)
    check_positive(args, "duration", "window", "smoothing_deg")
    if args.realizations < 2:
        raise CLIError(f"--realizations must be >= 2; got {args.realizations}.")
    if args.chunk_size < 1:
        raise CLIError(f"--chunk-size must be >= 1; got {args.chunk_size}.")
    if not (math.isfinite(args.discard) and 0 <= args.discard < args.duration):
        raise CLIError(
            f"--discard must be in [0, --duration) = [0, {args.duration:g}) s; got {args.discard:g}."
        )
    check_steps(args.dt, {"--duration": args.duration})
    if args.method == "superposition" and any(p in ("hs", "t01", "speed") for p in wrt):
        raise CLIError("sea-parameter derivatives need the filter excitation (--method filter).")
    out = Path(args.out)
    ship = load_ship_arg(args.ship)
    problem_fn, params = sensitivity_problem(
        ship, hs=args.hs, t01=args.t01, speed=args.speed, heading=heading_for_api(parse_heading(args.heading)), excitation=resolved_method(args, ship),
        dt=args.dt, filter_order=args.filter_order, phi0=math.radians(args.phi0_deg),
    )  # fmt: skip
    print(
        f"Sensitivities: {args.realizations} realizations × {args.duration:g} s (window {args.window:g} s, "
        f"burn-in {args.burn_in:g} s), H1/3 {args.hs} m, T01 {args.t01} s, U {args.speed} m/s; "
        f"d/d({', '.join(wrt)})"
    )
    progress = Progress(args.realizations, "realizations", enabled=None if not args.quiet else False)
    t0 = time.time()
    res = monte_carlo_sensitivity(
        problem_fn, params, jax.random.key(args.seed), wrt=wrt, statistics=stats,
        num_realizations=args.realizations, duration=args.duration, discard=args.discard, window=args.window,
        burn_in=args.burn_in, extrapolate=not args.no_extrapolate, smoothing_deg=args.smoothing_deg,
        chunk_size=args.chunk_size, progress=progress,
    )  # fmt: skip
    elapsed = time.time() - t0
    t1 = time.time()
    theory = theory_sensitivities(
        problem_fn,
        params,
        wrt=wrt,
        statistics=res.statistics,
        theories=theories,
        filter_order=moment_filter_order(args),
    )
    theory_time = time.time() - t1

    parameters = {
        p: {"value": params[p], "unit": SENSITIVITY_PARAMETERS[p],
            "step": 0.1 * abs(params[p]) if params[p] != 0 else 1.0}
        for p in wrt
    }  # fmt: skip
    values, gradients = {}, {}
    for i, s in enumerate(res.statistics):
        key, f = json_key(s)
        values[key] = {
            "monte_carlo": {"value": f * res.value[s], "std_error": f * res.value_std_error[s]},
            "theory": {n: (f * t["values"][i] if "values" in t else None) for n, t in theory.items()},
        }
        if s.startswith("P_exceed"):
            values[key]["monte_carlo_unsmoothed"] = res.unsmoothed[s]
        gradients[key] = {
            p: {
                "monte_carlo": {"value": f * res.gradient[s][p], "std_error": f * res.std_error[s][p]},
                "theory": {
                    n: (f * t["gradients"][i][j] if "gradients" in t else None) for n, t in theory.items()
                },
            }
            for j, p in enumerate(wrt)
        }
    config = {
        **sea_config(args, ship),
        "realizations": args.realizations,
        "duration_s": args.duration,
        "discard_s": args.discard,
        "phi0_deg": args.phi0_deg,
        "statistics": list(res.statistics),
        "theory": theories,
    }
    payload = {
        "config": config,
        "parameters": parameters,
        "values": values,
        "gradients": gradients,
        "estimator": {**res.config, "n_capsized": res.n_capsized, "n_realizations": res.n_realizations},
        "theory_details": {n: t.get("details", {"error": t.get("error")}) for n, t in theory.items()},
        "units": "gradients are per unit of the parameter (parameters[p].unit), in the statistic's units "
        "(deg, deg², probability); the chart shows derivative × step",
        "run_time_s": elapsed,
        "theory_time_s": theory_time,
    }
    title = f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s, U = {args.speed:g} m/s, N = {args.realizations}"
    with OutputFolder(out) as tmp:
        save_figure(sensitivity_bar_chart(payload, title=title), tmp / "sensitivity.png")
        write_json(tmp / "sensitivity.json", payload)
        nc = write_netcdf(tmp / "sensitivity.nc", "sensitivity", payload, {"monte_carlo": res.to_xarray()})

    print(f"Monte Carlo done in {elapsed:.1f} s (capsized {res.n_capsized}); theories in {theory_time:.1f} s")
    for n, t in theory.items():
        if "error" in t:
            print(f"  {n}: not available ({t['error']})")
    for key, per in gradients.items():
        print(f"{key}  (Monte Carlo {values[key]['monte_carlo']['value']:.4g} ± "
              f"{values[key]['monte_carlo']['std_error']:.2g})")  # fmt: skip
        for p, e in per.items():
            mc = e["monte_carlo"]
            th = "  ".join(f"{n} {v:+.4g}" for n, v in e["theory"].items() if v is not None)
            print(
                f"  d/d{p:<14s} {mc['value']:+.4g} ± {mc['std_error']:.2g} per {parameters[p]['unit']}   {th}"
            )
    print(
        f"wrote {out / 'sensitivity.json'}, "
        + (f"{out / 'sensitivity.nc'}, " if nc else "")
        + f"{out / 'sensitivity.png'}"
    )
    return 0
