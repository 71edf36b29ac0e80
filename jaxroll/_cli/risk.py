"""`jaxroll risk`: probability that the roll exceeds an angle within an exposure time, and the largest roll."""

from __future__ import annotations

import math
import sys
import time
import warnings
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
    add_sea_options,
    add_yaw_options,
    build_problem,
    check_positive,
    check_sea_options,
    check_steps,
    refuse_theories_under_yaw,
    resolved_method,
    sea_config,
    sea_heading_phrase,
    yaw_from_args,
)


def register(sub) -> None:
    p = sub.add_parser(
        "risk",
        help="P(roll > ANGLE within HOURS), most probable and expected largest roll, capsize probability",
        description="Monte Carlo per-cycle (zero-crossing) amplitudes → exceedance within the exposure, with 95 % "
        "Wilson intervals; optionally the same from theoretical amplitude PDFs (--theory).",
    )
    add_sea_options(p)
    add_yaw_options(p)
    p.add_argument("--angle", type=float, default=30.0, help="threshold roll angle [deg] (30)")
    p.add_argument("--hours", type=float, default=3.0, help="exposure time [h] (3)")
    p.add_argument("--realizations", type=int, default=2000, help="Monte Carlo trials (2000)")
    p.add_argument("--duration", type=float, default=3600.0, help="simulated time per trial [s] (3600)")
    p.add_argument("--discard", type=float, default=500.0, help="initial transient left out [s] (500)")
    add_chunk_option(p, streaming=True, what="trials")
    add_memory_option(p)
    p.add_argument(
        "--theory",
        default="",
        help="also from theory: first_passage (the envelope FPK model followed through the exposure: large "
        "rolls come in groups) and/or the amplitude laws roberts,esam,moment,envelope_fpk (amplitudes "
        "taken as independent); all: every one",
    )
    p.add_argument(
        "--estimator",
        choices=("brute-force", "splitting", "direct"),
        default="brute-force",
        metavar="brute-force|splitting",
        help="brute-force (default): trials of the exposure's length (always run; risk.json 'direct'); splitting: "
        "also multilevel splitting for the same probability, for rare exceedances (risk.json 'splitting'; "
        "docs/rare_events.md). The names of `jaxroll longterm --estimator`; 'direct', the old name of "
        "brute-force, is still accepted (deprecated)",
    )
    p.add_argument("--splitting-trials", type=int, default=1000, help="splitting: runs a stage (1000)")
    p.add_argument(
        "--out", default="jaxroll-out/risk", help="output folder for risk.json, risk.nc and risk.png"
    )
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def _deg(value) -> str:
    """An angle for the terminal; None (a quantile beyond the vanishing angle) prints as 'capsize'."""
    return "capsize" if value is None else f"{value:.1f}°"


def _no_exceedance(q: float, n: float) -> float:
    """1 − P = (1 − q)ⁿ, the probability of no exceedance in n independent cycles, computed as exp(n log1p(−q)) so
    that it keeps its digits where P rounds to 1 (P = 1 − 2e-12 is not 1.0000)."""
    if not (math.isfinite(q) and math.isfinite(n)):
        return math.nan
    return 0.0 if q >= 1 else math.exp(n * math.log1p(-q))


def probability_text(p: float, complement: float) -> str:
    """A probability for the terminal: 4 decimals, or 1 − x where it rounds to 1 (a CI "1.0000–1.0000" said
    nothing), or 1 exactly."""
    if not math.isfinite(p):
        return "n/a"
    if p >= 0.99995:
        return "1" if not complement > 0 else f"1 − {complement:.2g}"
    return f"{p:.4f}"


def _risk_dict(r) -> dict:
    q, lo, hi, n = (
        float(r.exceedance_per_cycle),
        float(r.exceedance_per_cycle_lower),
        float(r.exceedance_per_cycle_upper),
        float(r.n_cycles),
    )
    return {
        "n_cycles": n,
        "exceedance_per_cycle": q,
        "exceedance_per_cycle_ci95": [lo, hi],
        "probability": float(r.probability),
        # 1 − P with its digits (P itself rounds to 1 in float64 below 1e-16): (1 − q)^n and its interval
        "probability_complement": _no_exceedance(q, n),
        "probability_complement_ci95": [_no_exceedance(hi, n), _no_exceedance(lo, n)],
        "probability_poisson": float(r.probability_poisson),
        "probability_ci95": [float(r.probability_lower), float(r.probability_upper)],
        "most_probable_largest_deg": float(r.most_probable_largest_deg),
        "characteristic_largest_deg": float(r.characteristic_largest_deg),
        "characteristic_largest_ci95_deg": [
            float(r.characteristic_largest_lower_deg),
            float(r.characteristic_largest_upper_deg),
        ],
        "expected_largest_deg": float(r.expected_largest_deg),
    }


def parse_risk_theories(text: str) -> tuple[list[str], bool]:
    """--theory of `jaxroll risk`: (the amplitude-law theories, whether the first passage is asked for); `all`:
    every theory."""
    from ..theory import THEORIES
    from .pdf import parse_theories

    names = [t.strip().lower() for t in text.split(",") if t.strip()]
    if names == ["all"]:
        return list(THEORIES), True
    first_passage = "first_passage" in names
    return parse_theories(",".join(n for n in names if n != "first_passage") or "none"), first_passage


def _first_passage(problem, angle_deg: float, exposure: float, curve_deg, vanishing_deg: float):
    """risk.json's `first_passage` entry and its risk curve on `curve_deg` (NaN outside the levels computed):
    `jaxroll.theory.passage_risk` at the threshold, and at levels 1.2 apart in amplitude for the curve, the curve
    interpolated in ln(−ln(1 − P)) against ln x, as the model varies smoothly there."""
    import math

    import numpy as np

    from ..longterm import measured_allowance
    from ..theory import passage_risk
    from ._theory import first_line

    try:
        risk = passage_risk(problem.ship, problem.wave, [math.radians(angle_deg)], [exposure])
        levels = 2.0 * 1.2 ** np.arange(int(math.log(0.93 * vanishing_deg / 2.0) / math.log(1.2)) + 1)
        curve = passage_risk(problem.ship, problem.wave, np.deg2rad(levels), [exposure])
    except ValueError as e:
        raise CLIError(f"first_passage: {first_line(e)}") from None
    p = np.asarray(curve.probability[:, 0])
    loglog = np.log(-np.log(np.clip(1 - p, 1e-300, 1 - 1e-16)))
    x = np.asarray(curve_deg, float)
    inside = (x >= levels[0]) & (x <= levels[-1])
    on_curve = np.where(
        inside, -np.expm1(-np.exp(np.interp(np.log(np.maximum(x, 1e-9)), np.log(levels), loglog))), np.nan
    )
    theta = float(risk.extremal_index[0])
    entry = {
        "probability": float(risk.probability[0, 0]),
        "capsize_probability": float(risk.capsize_probability[0]),
        "clusters_per_hour": 3600.0 * float(risk.cluster_rate[0]),
        "amplitudes_per_cluster": 1.0 / theta if theta > 0 else None,
        "extremal_index": theta,
        "mean_passage_time_s": float(risk.mean_passage_time[0]),
        "start_exceedance": float(risk.start_exceedance[0]),
        "exceedance_per_cycle": float(risk.exceedance_per_cycle[0]),
        "independent_probability": float(risk.independent_probability[0, 0]),
        "lyapunov_exponent_per_s": float(risk.lyapunov_exponent),
        "exists": bool(risk.exists),
        "method": "envelope FPK model followed through the exposure: the roll is seen at its peaks (a Poisson "
        "stream at the model's half-cycle rate), the exposure starts in the stationary law; P = 1 − "
        "survival (docs/theory.md, 'Exposure risk')",
        "grid": dict(risk.grid),
    }
    # The allowance measured against an exact-spectrum sea in this sea state's region (docs/validation.md): the
    # theory is low nearly everywhere, by up to ×16 at speed.
    below, above, outside, _ = (
        float(x) for x in measured_allowance(problem.wave.sea.hs, problem.wave.sea.t01, problem.wave.speed)
    )
    p = entry["probability"]
    entry["model_allowance"] = {
        "probability_range": [p / below, min(1.0, p * above)],
        "f_below": below,
        "f_above": above,
        "outside_validated_map": bool(outside),
    }
    if outside:
        print(
            "first_passage: this sea state is outside the map the exposure theory was validated on (H1/3 4-8 m, "
            f"T01 8-12 s, 0-5 m/s): its allowance is the widest measured, x{above:.3g} (docs/validation.md)."
        )
    return entry, on_curve


def _splitting_line(text: str) -> None:
    """The splitting phase's progress (its pilot, then each stage): one line each on stderr."""
    print(f"splitting: {text}", file=sys.stderr, flush=True)


def run(args) -> int:
    import jax
    import jax.numpy as jnp
    import numpy as np

    from .. import (
        exceedance_probability,
        exposure_risk,
        monte_carlo_amplitudes,
        monte_carlo_max_roll,
        monte_carlo_splitting,
        vanishing_angle,
    )
    from ..plotting import risk_figure
    from ..roll import SPLITTING_EXCITATIONS

    theories, first_passage = parse_risk_theories(args.theory)
    refuse_theories_under_yaw(args, theories + ["first_passage"] * first_passage)
    if args.estimator == "direct":  # one vocabulary with `jaxroll longterm --estimator` (issue 45)
        warnings.warn(
            "--estimator direct is now called brute-force (the same trials of the exposure's length; longterm's "
            "name); 'direct' is accepted until jaxroll 0.3.",
            FutureWarning,
            stacklevel=2,
        )
        args.estimator = "brute-force"
    check_positive(args, "hours", "duration")
    if not (math.isfinite(args.angle) and 0 < args.angle < 90):
        raise CLIError(f"--angle must be in (0, 90) degrees; got {args.angle}.")
    if args.realizations < 1:
        raise CLIError(f"--realizations must be >= 1; got {args.realizations}.")
    if args.estimator == "splitting" and args.splitting_trials < 10:
        raise CLIError(f"--splitting-trials must be >= 10; got {args.splitting_trials}.")
    if args.estimator == "splitting" and args.method not in (
        *SPLITTING_EXCITATIONS,
        "auto",
    ):  # (was after the direct trials)
        raise CLIError(
            f"--estimator splitting needs --method {' or '.join(SPLITTING_EXCITATIONS)} (splitting restarts runs "
            f"from the shaping filter's state); got --method {args.method}."
        )
    check_chunk_size(args)
    if not (math.isfinite(args.discard) and 0 <= args.discard < args.duration):
        raise CLIError(
            f"--discard must be in [0, --duration) = [0, {args.duration:g}) s; got {args.discard:g}."
        )
    check_sea_options(args)
    check_steps(
        args.dt, {"--duration": args.duration, "--discard + --hours": args.discard + args.hours * 3600.0}
    )
    budget = memory_budget(args)
    out = Path(args.out)
    ship = load_ship_arg(args.ship)
    if args.estimator == "splitting" and yaw_from_args(args) is not None:
        raise CLIError(
            "--estimator splitting needs the shaping filter, which cannot make the yawing heading's effective wave "
            "(--yaw-std, docs/yaw.md): use --estimator brute-force."
        )
    if args.estimator == "splitting" and resolved_method(args, ship) not in SPLITTING_EXCITATIONS:
        raise CLIError(
            "--estimator splitting needs the shaping filter, which cannot make the direct wave moment this ship "
            "carries at this heading (docs/wave_moment.md): use --estimator brute-force."
        )
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
    stats = monte_carlo_amplitudes(
        problem,
        jax.random.key(args.seed),
        num_realizations=args.realizations,
        duration=args.duration,
        discard=args.discard,
        chunk_size=args.chunk_size,
        memory_budget=budget,
        progress=progress,
    )
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
    mc = exposure_risk(
        stats.law("zero_crossing"),
        jnp.deg2rad(angle_used),
        rate=rate,
        duration=exposure,
        n_amplitudes=n_amp,
        n_exceed=n_exceed,
    )
    # Direct estimate: trials as long as the exposure, no independence assumption between amplitudes.
    direct_stats = monte_carlo_max_roll(
        problem,
        jax.random.key(args.seed + 1),
        angle_deg=angle_used,
        num_realizations=args.realizations,
        duration=args.discard + exposure,
        discard=args.discard,
        chunk_size=args.chunk_size,
        memory_budget=budget,
    )
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
            f"{direct_stats.n_realizations} trials capsized)"
        )
    if args.estimator == "splitting":
        # The same probability by multilevel splitting on the roll energy (unbiased; for rare exceedances).
        if not args.quiet:
            _splitting_line(f"a pilot run, then stages of {args.splitting_trials} runs")
        split = monte_carlo_splitting(
            problem,
            jax.random.key(args.seed + 2),
            angle_deg=angle_used,
            exposure=exposure,
            discard=args.discard,
            num_trials=args.splitting_trials,
            progress=None if args.quiet else _splitting_line,
        )
        direct_splitting = {
            **split.to_dict(),
            "method": "fixed-effort multilevel splitting on the roll energy and "
            "wave envelope; the same event as direct (docs/rare_events.md)",
        }
    result = {
        "direct": direct,
        "monte_carlo": {
            "angle_deg": angle_used,
            "rate_per_s": rate,
            "n_amplitudes": n_amp,
            "n_exceed": n_exceed,
            **_risk_dict(mc),
            "n_capsized": stats.n_capsized,
            "n_realizations": stats.n_realizations,
            "stationarity": stationarity,
            "method": "per-cycle amplitude distribution, amplitudes assumed independent; "
            "the amplitudes of the trials that did not capsize (conditional on "
            "survival: see direct.capsize_probability)",
        },
    }
    if args.estimator == "splitting":
        result["splitting"] = direct_splitting
    # The risk curve P(max |φ| > x within the exposure) over x, for the figure and the JSON.
    curve_deg = np.arange(0.0, math.floor(vanishing_deg) + 1e-9, 0.5)
    curve_rad = jnp.deg2rad(curve_deg)
    curves = {
        "monte_carlo": np.asarray(
            exceedance_probability(stats.law("zero_crossing"), curve_rad, rate=rate, duration=exposure)
        )
    }
    if theories:
        from ._theory import closure_note, theory_laws

        for name, tdist in theory_laws(problem, args, theories).items():
            result[name] = _risk_dict(
                exposure_risk(tdist, jnp.deg2rad(angle_used), rate=rate, duration=exposure)
            )
            result[name]["theory_details"] = tdist.details()
            curves[name] = np.asarray(exceedance_probability(tdist, curve_rad, rate=rate, duration=exposure))
    if first_passage:
        result["first_passage"], curves["first_passage"] = _first_passage(
            problem, angle_used, exposure, curve_deg, vanishing_deg
        )
    direct_curve = np.array([direct_stats.exceedance_probability(x) for x in curve_deg])
    result["curve"] = {"angle_deg": curve_deg, "direct": direct_curve, **curves}
    payload = {
        "config": {
            **sea_config(args, ship),
            "angle_deg": args.angle,
            "hours": args.hours,
            "realizations": args.realizations,
            "duration_s": args.duration,
            "discard_s": args.discard,
            "theory": theories + (["first_passage"] if first_passage else []),
            "estimator": args.estimator,
            "amplitudes": "zero-crossing, per half cycle; amplitudes assumed independent",
        },
        **result,
        "run_time_s": time.time() - t0,
    }
    title = (
        f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s, U = {args.speed:g} m/s, "
        f"{sea_heading_phrase(args)}; {args.realizations} trials"
    )
    with OutputFolder(out) as tmp:
        fig = risk_figure(
            curve_deg,
            direct_curve,
            curves,
            angle_deg=angle_used,
            hours=args.hours,
            capsize_probability=direct_stats.capsize_probability,
            title=title,
            splitting=result.get("splitting"),
        )
        save_figure(fig, tmp / "risk.png")
        write_json(tmp / "risk.json", payload)
        nc = write_netcdf(
            tmp / "risk.nc",
            "risk",
            payload,
            {"direct": direct_stats.to_xarray(), "monte_carlo": stats.to_xarray()},
        )
    m, d = result["monte_carlo"], result["direct"]
    print(
        f"Sea: H1/3 {args.hs} m, T01 {args.t01} s, {sea_heading_phrase(args)}, U {args.speed} m/s; ship {ship.name}"
    )
    print(
        f"Direct ({args.realizations} trials of {args.hours:g} h after {args.discard:g} s): "
        f"P(roll > {angle_used:g}° within {args.hours:g} h) = {probability_text(d['probability'], 1 - d['probability'])} "
        f"(95 % CI {probability_text(d['probability_ci95'][0], 1 - d['probability_ci95'][0])}–"
        f"{probability_text(d['probability_ci95'][1], 1 - d['probability_ci95'][1])}); "
        f"median largest roll {_deg(d['largest_roll_quantiles_deg']['50'])}, "
        f"90 % {_deg(d['largest_roll_quantiles_deg']['90'])}; "
        f"P(capsize) = {d['capsize_probability']:.4f} "
        f"(95 % CI {d['capsize_probability_ci95'][0]:.4f}–{d['capsize_probability_ci95'][1]:.4f})"
    )
    print(
        f"Independent amplitudes ({n_amp} amplitudes, {rate * 3600:.0f} per hour): "
        f"P = {probability_text(m['probability'], m['probability_complement'])} (95 % CI "
        f"{probability_text(m['probability_ci95'][0], m['probability_complement_ci95'][1])} … "
        f"{probability_text(m['probability_ci95'][1], m['probability_complement_ci95'][0])}); "
        f"characteristic largest {m['characteristic_largest_deg']:.1f}°, expected largest "
        f"{m['expected_largest_deg']:.1f}° (assumes independent amplitudes)"
    )
    if args.estimator == "splitting":
        s = result["splitting"]
        print(
            f"Splitting ({args.splitting_trials} runs a stage, {len(s['levels_deg'])} stages): "
            f"P = {s['probability']:.3g} (95 % CI {s['probability_ci95'][0]:.3g}–{s['probability_ci95'][1]:.3g}); "
            f"{s['total_simulated_seconds'] / 3600:.0f} realization-hours"
        )
    if stationarity["note"]:
        print(f"warning: the amplitudes behind the independent-amplitude estimate: {stationarity['note']}")
    if first_passage:
        f = result["first_passage"]
        print(
            f"first_passage (envelope FPK followed through the exposure): P = {f['probability']:.4f}, "
            f"P(capsize) = {f['capsize_probability']:.2g}; {f['clusters_per_hour']:.3g} groups of large rolls per "
            f"hour, {f['amplitudes_per_cluster']:.2f} amplitudes above {angle_used:g}° per group"
        )
    for name in theories:
        t = result[name]
        print(
            f"{name} (independent amplitudes): P = {probability_text(t['probability'], t['probability_complement'])}, "
            f"most probable largest {t['most_probable_largest_deg']:.1f}°{closure_note(t['theory_details'])}"
        )
    print(f"wrote {out}/risk.json, {'risk.nc, ' if nc else ''}risk.png")
    return 0
