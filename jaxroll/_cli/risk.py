"""`jaxroll risk`: probability that the roll exceeds an angle within an exposure time, and the largest roll."""

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
from ._sea import add_sea_options, build_problem, check_positive, heading_phrase, parse_heading, sea_config


def register(sub) -> None:
    p = sub.add_parser(
        "risk",
        help="P(roll > ANGLE within HOURS), most probable and expected largest roll, capsize probability",
        description="Monte Carlo per-cycle (zero-crossing) amplitudes → exceedance within the exposure, with 95 % "
        "Wilson intervals; optionally the same from theoretical amplitude PDFs (--theory).",
    )
    add_sea_options(p)
    p.add_argument("--angle", type=float, default=30.0, help="threshold roll angle [deg] (30)")
    p.add_argument("--hours", type=float, default=3.0, help="exposure time [h] (3)")
    p.add_argument("--realizations", type=int, default=2000, help="Monte Carlo trials (2000)")
    p.add_argument("--duration", type=float, default=3600.0, help="simulated time per trial [s] (3600)")
    p.add_argument("--discard", type=float, default=500.0, help="initial transient left out [s] (500)")
    add_chunk_option(p, streaming=True, what="trials")
    add_memory_option(p)
    p.add_argument("--theory", default="", help="also from theory: roberts,esam,moment,envelope_fpk")
    p.add_argument("--out", default="jaxroll-out/risk", help="output folder for risk.json, risk.nc and risk.png")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def _deg(value) -> str:
    """An angle for the terminal; None (a quantile beyond the vanishing angle) prints as 'capsize'."""
    return "capsize" if value is None else f"{value:.1f}°"


def _risk_dict(r) -> dict:
    return {
        "n_cycles": float(r.n_cycles),
        "exceedance_per_cycle": float(r.exceedance_per_cycle),
        "exceedance_per_cycle_ci95": [float(r.exceedance_per_cycle_lower), float(r.exceedance_per_cycle_upper)],
        "probability": float(r.probability),
        "probability_poisson": float(r.probability_poisson),
        "probability_ci95": [float(r.probability_lower), float(r.probability_upper)],
        "most_probable_largest_deg": float(r.most_probable_largest_deg),
        "characteristic_largest_deg": float(r.characteristic_largest_deg),
        "characteristic_largest_ci95_deg": [float(r.characteristic_largest_lower_deg),
                                            float(r.characteristic_largest_upper_deg)],
        "expected_largest_deg": float(r.expected_largest_deg),
    }


def run(args) -> int:
    import jax
    import jax.numpy as jnp
    import numpy as np

    from .. import (
        exceedance_probability,
        exposure_risk,
        monte_carlo_amplitudes,
        monte_carlo_max_roll,
        vanishing_angle,
    )
    from ..plotting import risk_figure
    from .pdf import check_out, parse_theories

    theories = parse_theories(args.theory)
    check_positive(args, "hours", "duration")
    if not (math.isfinite(args.angle) and 0 < args.angle < 90):
        raise CLIError(f"--angle must be in (0, 90) degrees; got {args.angle}.")
    if args.realizations < 1:
        raise CLIError(f"--realizations must be >= 1; got {args.realizations}.")
    check_chunk_size(args)
    if not (math.isfinite(args.discard) and 0 <= args.discard < args.duration):
        raise CLIError(f"--discard must be in [0, --duration) = [0, {args.duration:g}) s; got {args.discard:g}.")
    budget = memory_budget(args)
    out = Path(args.out)
    check_out(out)
    ship = load_ship_arg(args.ship)
    vanishing_deg = math.degrees(float(vanishing_angle(ship)))
    if args.angle >= vanishing_deg:
        raise CLIError(
            f"--angle {args.angle:g}° is not below the angle of vanishing stability of {ship.name} "
            f"({vanishing_deg:.1f}°): beyond it the ship capsizes (capsizes are counted separately); choose a "
            "smaller angle."
        )
    problem, _, sea = build_problem(args, ship)
    exposure = args.hours * 3600.0
    t0 = time.time()
    progress = Progress(args.realizations, "realizations", enabled=None if not args.quiet else False)
    stats = monte_carlo_amplitudes(problem, jax.random.key(args.seed), num_realizations=args.realizations,
                                   duration=args.duration, discard=args.discard, chunk_size=args.chunk_size, memory_budget=budget,
                                   progress=progress)
    counts = stats.counts_zero_crossing
    stationarity = stats.stationarity()
    edges = stats.edges_deg
    n_amp = int(counts.sum())
    if n_amp == 0:
        raise CLIError("no amplitudes were recorded (every trial capsized?); reduce H1/3 or check the ship.")
    k = int(round(args.angle / (edges[1] - edges[0])))
    n_exceed = int(counts[k:].sum())
    angle_used = float(edges[k])
    survivors = stats.n_realizations - stats.n_capsized
    rate = n_amp / (survivors * (args.duration - args.discard))
    mc = exposure_risk(stats.law("zero_crossing"), jnp.deg2rad(angle_used), rate=rate, duration=exposure,
                       n_amplitudes=n_amp,
                       n_exceed=n_exceed)
    # Direct estimate: trials as long as the exposure, no independence assumption between amplitudes.
    direct_stats = monte_carlo_max_roll(problem, jax.random.key(args.seed + 1), angle_deg=angle_used,
                                        num_realizations=args.realizations, duration=args.discard + exposure,
                                        discard=args.discard, chunk_size=args.chunk_size, memory_budget=budget)
    # A capsized trial's largest roll is beyond the vanishing angle: counted in the order statistics, never dropped.
    largest_q = direct_stats.largest_roll_quantiles_deg()
    direct = {
        "probability": direct_stats.exceedance_probability(),
        "probability_ci95": list(direct_stats.exceedance_interval()),
        "capsize_probability": direct_stats.capsize_probability,
        "capsize_probability_ci95": list(direct_stats.capsize_interval()),
        "n_capsized": direct_stats.n_capsized,
        "largest_roll_quantiles_deg": largest_q,
        "n_realizations": direct_stats.n_realizations,
        "method": "trials of the exposure's length after the discard; exceedance = max |φ| > angle or capsize; "
                  "a capsized trial's largest roll counts as beyond the angle of vanishing stability",
    }
    if None in largest_q.values():
        direct["largest_roll_quantiles_reason"] = (
            f"null: beyond the angle of vanishing stability ({direct_stats.n_capsized} of "
            f"{direct_stats.n_realizations} trials capsized)")
    result = {"direct": direct,
              "monte_carlo": {"angle_deg": angle_used, "rate_per_s": rate, "n_amplitudes": n_amp,
                              "n_exceed": n_exceed, **_risk_dict(mc),
                              "n_capsized": stats.n_capsized, "n_realizations": stats.n_realizations,
                              "stationarity": stationarity,
                              "method": "per-cycle amplitude distribution, amplitudes assumed independent; "
                                        "the amplitudes of the trials that did not capsize (conditional on "
                                        "survival: see direct.capsize_probability)"}}
    # The risk curve P(max |φ| > x within the exposure) over x, for the figure and the JSON.
    curve_deg = np.arange(0.0, math.floor(vanishing_deg) + 1e-9, 0.5)
    curve_rad = jnp.deg2rad(curve_deg)
    curves = {"monte_carlo": np.asarray(exceedance_probability(stats.law("zero_crossing"), curve_rad, rate=rate,
                                                               duration=exposure))}
    if theories:
        from ._theory import closure_note, theory_laws

        for name, tdist in theory_laws(problem, args, theories).items():
            result[name] = _risk_dict(exposure_risk(tdist, jnp.deg2rad(angle_used), rate=rate, duration=exposure))
            result[name]["theory_details"] = tdist.details()
            curves[name] = np.asarray(exceedance_probability(tdist, curve_rad, rate=rate, duration=exposure))
    direct_curve = np.array([direct_stats.exceedance_probability(x) for x in curve_deg])
    result["curve"] = {"angle_deg": curve_deg, "direct": direct_curve, **curves}
    payload = {"config": {**sea_config(args, ship), "angle_deg": args.angle, "hours": args.hours,
                          "realizations": args.realizations, "duration_s": args.duration,
                          "discard_s": args.discard, "theory": theories,
                          "amplitudes": "zero-crossing, per half cycle; amplitudes assumed independent"},
               **result, "run_time_s": time.time() - t0}
    title = (f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s, U = {args.speed:g} m/s, "
             f"{heading_phrase(parse_heading(args.heading))}; {args.realizations} trials")
    with OutputFolder(out) as tmp:
        fig = risk_figure(curve_deg, direct_curve, curves, angle_deg=angle_used, hours=args.hours,
                          capsize_probability=direct_stats.capsize_probability, title=title)
        save_figure(fig, tmp / "risk.png")
        write_json(tmp / "risk.json", payload)
        write_netcdf(tmp / "risk.nc", "risk", payload, {"direct": direct_stats.to_xarray(),
                                                        "monte_carlo": stats.to_xarray()})
    m, d = result["monte_carlo"], result["direct"]
    print(f"Sea: H1/3 {args.hs} m, T01 {args.t01} s, {heading_phrase(parse_heading(args.heading))}, U {args.speed} m/s; ship {ship.name}")
    print(f"Direct ({args.realizations} trials of {args.hours:g} h after {args.discard:g} s): "
          f"P(roll > {angle_used:g}° within {args.hours:g} h) = {d['probability']:.4f} "
          f"(95 % CI {d['probability_ci95'][0]:.4f}–{d['probability_ci95'][1]:.4f}); "
          f"median largest roll {_deg(d['largest_roll_quantiles_deg']['50'])}, "
          f"90 % {_deg(d['largest_roll_quantiles_deg']['90'])}; "
          f"P(capsize) = {d['capsize_probability']:.4f} "
          f"(95 % CI {d['capsize_probability_ci95'][0]:.4f}–{d['capsize_probability_ci95'][1]:.4f})")
    print(f"Independent amplitudes ({n_amp} amplitudes, {rate * 3600:.0f} per hour): "
          f"P = {m['probability']:.4f} (95 % CI {m['probability_ci95'][0]:.4f}–{m['probability_ci95'][1]:.4f}); "
          f"characteristic largest {m['characteristic_largest_deg']:.1f}°, expected largest "
          f"{m['expected_largest_deg']:.1f}° (assumes independent amplitudes)")
    if stationarity["note"]:
        print(f"warning: the amplitudes behind the independent-amplitude estimate: {stationarity['note']}")
    for name in theories:
        t = result[name]
        print(f"{name}: P = {t['probability']:.4f}, most probable largest {t['most_probable_largest_deg']:.1f}°"
              f"{closure_note(t['theory_details'])}")
    print(f"wrote {out}/risk.json, risk.nc, risk.png")
    return 0
