"""`jaxroll maxima`: the paper's maxima protocol by Monte Carlo, compared with P*(A_M) from amplitude PDFs."""

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
    add_sea_options,
    add_yaw_options,
    build_problem,
    check_sea_options,
    check_steps,
    refuse_theories_under_yaw,
    sea_config,
    sea_heading_phrase,
)


def register(sub) -> None:
    p = sub.add_parser(
        "maxima",
        help="PDF of the maximum of the first N0 roll amplitudes (paper's Figs. 12-19 analogue)",
        description="Per trial: φ(0)=5°, discard the first 500 s, the maximum of the first N0 zero-crossing "
        "amplitudes. N0 below 10⁴ share --realizations trials (10⁴); N0 ≥ 10⁴ use --realizations-large (5·10³).",
    )
    add_sea_options(p)
    add_yaw_options(p)
    m = p.add_argument_group("maxima protocol")
    m.add_argument("--n0", default="20,50,100,1000,10000", help="comma-separated N0 values (default paper's)")
    m.add_argument("--realizations", type=int, default=10_000, help="trials for N0 < 10⁴ (default 10000)")
    m.add_argument("--realizations-large", type=int, default=5000, help="trials for N0 ≥ 10⁴ (default 5000)")
    m.add_argument("--discard", type=float, default=500.0, help="initial time left out [s] (500)")
    m.add_argument(
        "--duration", type=float, default=None, help="simulated time per trial [s] (default: enough)"
    )
    add_chunk_option(m, streaming=True, what="trials")
    add_memory_option(m)
    m.add_argument(
        "--theory", default="", help="comma-separated amplitude PDFs for P*: roberts,esam,moment,envelope_fpk"
    )
    m.add_argument(
        "--checkpoint",
        metavar="DIR",
        default=None,
        help="save progress in DIR (one subfolder per trial group); a rerun resumes from it",
    )
    p.add_argument("--out", default="jaxroll-out/maxima", help="output folder (default ./jaxroll-out/maxima)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


P_EXCEED_DEG = (20.0, 30.0, 40.0)  # the angles [deg] of `p_exceed` (Monte Carlo maxima and every P*)


def p_star_numbers(grid_deg, density_per_deg, sf_at_angles) -> dict:
    """Summary of one P*(A_M) curve for maxima.json and the terminal: `mode_deg` (the grid point of the largest
    density: ±0.05° on the 0.1° grid), `mean_deg` (trapezoid rule over the grid, None where less than 0.999 of the
    mass lies on it), `mass_on_grid`, and `p_exceed` = P(max > x) at `P_EXCEED_DEG` (exact: `max_sf`)."""
    import numpy as np

    def integral(y):  # trapezoid rule on the grid
        return float(np.sum(np.diff(grid_deg) * (y[1:] + y[:-1]) / 2))

    mass = integral(density_per_deg)
    mean = integral(grid_deg * density_per_deg) / mass if mass >= 0.999 else None
    return {
        "mode_deg": float(grid_deg[int(np.argmax(density_per_deg))]),
        "mean_deg": mean,
        "mass_on_grid": mass,
        "p_exceed": {f"{x:g}": float(p) for x, p in zip(P_EXCEED_DEG, sf_at_angles, strict=True)},
    }


#: The Monte Carlo amplitude law behind P*: 1° bins, and in the tail bins merged to hold this many amplitudes.
MIN_TAIL_COUNT = 10


def parse_n0(text: str) -> list[int]:
    try:
        values = sorted({int(v) for v in text.split(",") if v.strip()})
    except ValueError:
        raise CLIError(f"--n0 must be comma-separated integers; got {text!r}.") from None
    if not values or values[0] < 1:
        raise CLIError(f"--n0 values must be integers >= 1; got {text!r}.")
    return values


def maxima_line(v: dict) -> str:
    """The terminal's line for one N0 (`per_n0` entry): the mean and 99 % point of the maxima, or, where trials
    capsized before N0 (maxima beyond the vanishing angle: no finite mean), the mean of the survivors' maxima."""
    q99 = v["quantiles_deg"]["99"]
    q99 = f"{q99:.2f}°" if q99 is not None else "beyond the vanishing angle (capsizes)"
    trials = f"{v['n_known']} trials"
    if not v["n_capsized"]:
        return f"mean max {v['mean_deg']:.2f}°, 99 % {q99} ({trials}, none capsized)"
    survivors = v.get("mean_deg_given_no_capsize")
    mean = (
        f"{survivors:.2f}° for the trials that did not capsize"
        if survivors is not None
        else "none (all capsized)"
    )
    return (
        f"mean max {mean}, 99 % {q99} ({trials}, {v['n_capsized']} capsized before N0: P = "
        f"{v['capsize_probability']:.3g}, counted as maxima beyond the vanishing angle, so the mean of all "
        "maxima is not finite)"
    )


def run(args) -> int:
    import jax
    import numpy as np

    from .. import max_pdf, max_pdf_asymptotic, max_sf, monte_carlo_amplitudes, monte_carlo_maxima
    from ..plotting import maxima_comparison_figure, maxima_figures
    from .pdf import parse_theories

    n0_all = parse_n0(args.n0)
    theories = parse_theories(args.theory)
    refuse_theories_under_yaw(args, theories)
    check_chunk_size(args)
    for name in ("realizations", "realizations_large"):
        if getattr(args, name) < 1:
            raise CLIError(f"--{name.replace('_', '-')} must be >= 1; got {getattr(args, name)}.")
    if not (math.isfinite(args.discard) and args.discard >= 0):
        raise CLIError(f"--discard must be >= 0 [s]; got {args.discard:g}.")
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > args.discard):
        raise CLIError(f"--duration must exceed --discard ({args.discard:g} s); got {args.duration:g}.")
    budget = memory_budget(args)
    out = Path(args.out)
    ship = load_ship_arg(args.ship)
    check_sea_options(args)
    longest = (
        args.duration
        if args.duration is not None
        # as jaxroll.roll.default_duration
        else (args.discard + (1.6 * max(n0_all) + 4) * float(ship.roll_period) / 2)
    )
    check_steps(
        args.dt,
        {
            "--duration" if args.duration is not None else "the duration max(--n0) needs (--duration)": max(
                longest, 3600.0
            )
        },
    )  # the trials of the maxima, and of the amplitude law (3600 s)
    problem, fit, sea = build_problem(args, ship)
    groups = [
        (g, n)
        for g, n in (
            ([v for v in n0_all if v < 10_000], args.realizations),
            ([v for v in n0_all if v >= 10_000], args.realizations_large),
        )
        if g
    ]
    bins = np.arange(0.0, 90.0 + 1e-9, 1.0)
    centres = (bins[1:] + bins[:-1]) / 2
    grid_deg = np.linspace(0.0, 89.0, 891)
    per_n0: dict[str, dict] = {}
    amplitude_summaries, per_trial = [], []
    t0 = time.time()
    resumed = False
    # The per-cycle amplitude PDF of the same sea (zero-crossing, after the discard), for P*(A_M).
    amp = monte_carlo_amplitudes(
        problem,
        jax.random.key(args.seed),
        num_realizations=min(args.realizations, 2000),
        duration=3600.0,
        discard=min(args.discard, 3000.0),
        chunk_size=args.chunk_size,
        memory_budget=budget,
    )
    # 1° bins, merged in the sparse tail to 10 amplitudes or more: P* amplifies histogram noise, and an empty bin
    # in the tail made it drop to zero there (jagged, with zeros near 65-70°, at N0 = 10⁴)
    mc_dist = amp.law("zero_crossing", pool=20, min_count=MIN_TAIL_COUNT)
    stationarity = amp.stationarity()
    if stationarity["note"]:
        print(f"warning: the amplitude run behind P* from the MC amplitudes: {stationarity['note']}")
    laws = {}
    if theories:
        from ._theory import closure_note, theory_laws

        laws = theory_laws(problem, args, theories)  # per-half-cycle laws: what P* needs
    for n0s, n_trials in groups:
        print(f"maxima: N0 = {n0s}, {n_trials} trials, discard {args.discard} s")
        group_checkpoint = (
            None if args.checkpoint is None else Path(args.checkpoint) / f"n0_{'_'.join(map(str, n0s))}"
        )
        resuming = group_checkpoint is not None and (group_checkpoint / "checkpoint.npz").exists()
        resumed = resumed or resuming
        progress = Progress(n_trials, f"trials (N0 ≤ {max(n0s)})", enabled=None if not args.quiet else False,
                            resuming=f"resuming N0 = {n0s} from the checkpoint in {group_checkpoint}" if resuming
                            else None)  # fmt: skip
        stats = monte_carlo_maxima(
            problem,
            jax.random.key(args.seed),
            n0=n0s,
            num_realizations=n_trials,
            discard=args.discard,
            duration=args.duration,
            chunk_size=args.chunk_size,
            memory_budget=budget,
            progress=progress,
            checkpoint=group_checkpoint,
        )
        amplitude_summaries.append({"n0": n0s, "n_trials": n_trials})
        per_trial.append(stats.to_xarray(bins))
        for j, n0 in enumerate(stats.n0):
            a = np.deg2rad(grid_deg)
            curves, p_star = {}, {}
            for name, dist in {"mcs_amplitudes": mc_dist, **laws}.items():
                exact = np.asarray(max_pdf(dist, a, n0)) * np.pi / 180
                curves[name] = {
                    "exact": exact,
                    "asymptotic": np.asarray(max_pdf_asymptotic(dist, a, n0)) * np.pi / 180,
                }
                p_star[name] = p_star_numbers(
                    grid_deg, exact, np.asarray(max_sf(dist, np.deg2rad(P_EXCEED_DEG), n0))
                )
            summary = stats.summary(j, bins)
            summary["p_exceed"] = {f"{x:g}": stats.exceedance_probability(j, x) for x in P_EXCEED_DEG}
            per_n0[str(n0)] = {**summary, "curves": curves, "p_star": p_star}
            if stats.n_incomplete(j):
                print(
                    f"warning: {stats.n_incomplete(j)} trials did not reach N0 = {n0} amplitudes; "
                    "increase --duration"
                )
    elapsed = time.time() - t0
    payload = {
        "config": {
            **sea_config(args, ship),
            "n0": n0_all,
            "realizations": args.realizations,
            "realizations_large": args.realizations_large,
            "discard_s": args.discard,
            "duration_s": args.duration,
            "theory": theories,
            "amplitudes": "zero-crossing (per half cycle), the first N0 after the discard",
            "capsizes": "a trial that capsized before its N0-th amplitude counts as a maximum beyond the "
            "angle of vanishing stability: histogram_pdf_per_deg integrates to "
            "1 - capsize_probability (a defective distribution); quantiles above that mass "
            "are null",
        },
        "bins_deg": bins,
        "grid_deg": grid_deg,
        "per_n0": per_n0,
        "runs": amplitude_summaries,
        "amplitude_pdf_source": "zero-crossing amplitudes of a separate run of the same sea "
        f"({min(args.realizations, 2000)} × 3600 s, discard {min(args.discard, 3000.0)} s)",
        "amplitude_pdf_stationarity": stationarity,
        "theory_details": {name: law.details() for name, law in laws.items()},
        "theory_amplitude_laws": {
            name: f"{law.estimator} ({law.sampling}): the theory's time-sampled envelope law weighted by the rate of "
            + (
                "half cycles (ω + dψ/dt)/π of the averaged (amplitude, phase, wave-envelope) system"
                if name == "envelope_fpk"
                else "half cycles Ω(A)/π at each amplitude"
            )
            for name, law in laws.items()
        },
        "run_time_s": elapsed,
        "resumed_from_checkpoint": resumed,
    }
    title = f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s, U = {args.speed:g} m/s, {sea_heading_phrase(args)}"
    capsized = {int(k): v["capsize_probability"] for k, v in per_n0.items()}
    with OutputFolder(out) as tmp:
        fig_lin, fig_log = maxima_figures(
            centres,
            {int(k): v["histogram_pdf_per_deg"] for k, v in per_n0.items()},
            title=title,
            capsize_probability=capsized,
        )
        save_figure(fig_lin, tmp / "maxima_linear.png")
        save_figure(fig_log, tmp / "maxima_log.png")
        for k, v in per_n0.items():
            fig = maxima_comparison_figure(
                centres,
                v["histogram_pdf_per_deg"],
                grid_deg,
                v["curves"],
                int(k),
                title=title,
                capsize_probability=v["capsize_probability"],
                n_trials=v["n_known"],
            )
            save_figure(fig, tmp / f"maxima_N0_{k}.png")
        write_json(tmp / "maxima.json", payload)
        nc = write_netcdf(
            tmp / "maxima.nc", "maxima", payload, {"": per_trial, "amplitude_pdf": amp.to_xarray(bins)}
        )
    for k, v in per_n0.items():
        print(f"N0 = {k:>6}: {maxima_line(v)}")
        for name, p in v["p_star"].items():
            label = "P* from the MC amplitudes" if name == "mcs_amplitudes" else f"P* {name}"
            note = closure_note(payload["theory_details"][name]) if name in laws else ""
            mean = "beyond the grid" if p["mean_deg"] is None else f"{p['mean_deg']:.2f}°"
            print(
                f"  {label}: mode {p['mode_deg']:.2f}°, mean {mean}, P(max > 30°) = "
                f"{p['p_exceed']['30']:.3g} (Monte Carlo maxima: {v['p_exceed']['30']:.3g}){note}"
            )
    print(
        f"done in {elapsed:.1f} s{' (resumed from the checkpoint; this run only)' if resumed else ''}; wrote {out}/maxima_linear.png, maxima_log.png, maxima_N0_*.png, maxima.json{', maxima.nc' if nc else ''}"
    )
    return 0
