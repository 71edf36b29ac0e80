"""`jaxroll pdf`: the paper's Monte Carlo amplitude PDFs (and, with --theory, the theoretical PDFs)."""

from __future__ import annotations

import math
import time
from pathlib import Path

from ._common import CLIError, Progress, load_ship_arg, save_figure, write_json
from ._sea import add_sea_options, build_problem, check_positive, sea_config

THEORIES = ("roberts", "esam", "moment")


def register(sub) -> None:
    p = sub.add_parser(
        "pdf",
        help="Monte Carlo roll-amplitude PDFs, paper style (default: C11 representative, H1/3 7 m, T01 10 s)",
        description="Runs the paper's MCS protocol (φ(0)=5°, 3600 s, 10⁴ realizations) and writes pdf_linear.png, "
        "pdf_log.png and pdf.json into --out.",
    )
    add_sea_options(p)
    m = p.add_argument_group("Monte Carlo")
    m.add_argument("--realizations", type=int, default=10_000, help="number of realizations (default 10000)")
    m.add_argument("--duration", type=float, default=3600.0, help="simulated time per realization [s] (3600)")
    m.add_argument("--discard", type=float, default=0.0, help="initial transient left out of the PDFs [s] (0)")
    m.add_argument("--phi0-deg", type=float, default=5.0, help="initial roll angle [deg] (5)")
    m.add_argument("--chunk-size", type=int, default=1000, help="realizations per compiled batch (memory bound)")
    m.add_argument("--bin-width-deg", type=float, default=1.0, help="PDF bin width [deg] (1)")
    m.add_argument(
        "--theory",
        default="",
        help=f"comma-separated theories to overlay: {','.join(THEORIES)} (default: none)",
    )
    m.add_argument("--checkpoint", metavar="DIR", default=None, help="save progress in DIR; a rerun resumes")
    p.add_argument("--out", default="jaxroll-out/pdf", help="output folder (default ./jaxroll-out/pdf)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def parse_theories(text: str) -> list[str]:
    names = [t.strip().lower() for t in text.split(",") if t.strip()]
    unknown = sorted(set(names) - set(THEORIES))
    if unknown:
        raise CLIError(f"--theory: unknown method(s) {unknown}; choose from {', '.join(THEORIES)}.")
    return names


def pdf_bins(bin_width_deg: float, capsize_angle_deg: float):
    """Bin edges [deg] from 0 to just past the angle of vanishing stability, on the 0.05° fine grid."""
    import numpy as np

    fine = 0.05
    steps = round(bin_width_deg / fine)
    if steps < 1 or abs(steps * fine - bin_width_deg) > 1e-9:
        raise CLIError(f"--bin-width-deg must be a multiple of {fine}; got {bin_width_deg}.")
    n = math.ceil(min(capsize_angle_deg, 89.0) / bin_width_deg)
    return np.arange(n + 1) * steps * fine


def run(args) -> int:
    import jax
    import jax.numpy as jnp

    from .. import monte_carlo_amplitudes
    from ..plotting import amplitude_pdf_figures

    theories = parse_theories(args.theory)
    check_positive(args, "duration", "bin_width_deg")
    if args.realizations < 1:
        raise CLIError(f"--realizations must be >= 1; got {args.realizations}.")
    if args.chunk_size < 1:
        raise CLIError(f"--chunk-size must be >= 1; got {args.chunk_size}.")
    ship = load_ship_arg(args.ship)
    problem, fit, sea = build_problem(args, ship, phi0_deg=args.phi0_deg)
    capsize_deg = float(jnp.rad2deg(problem.capsize_angle))
    bins = pdf_bins(args.bin_width_deg, capsize_deg)
    out = Path(args.out)
    if args.ship is None:
        print("Ship: C11 (representative) — Table-1 particulars, representative coefficients (see `jaxroll ship show`).")
    print(
        f"Monte Carlo: {args.realizations} realizations × {args.duration:g} s, dt {args.dt} s, "
        f"H1/3 {args.hs} m, T01 {args.t01} s, {args.heading} seas, U {args.speed} m/s, method {args.method}"
    )
    progress = Progress(args.realizations, "realizations", enabled=None if not args.quiet else False)
    t0 = time.time()
    stats = monte_carlo_amplitudes(
        problem,
        jax.random.key(args.seed),
        num_realizations=args.realizations,
        duration=args.duration,
        discard=args.discard,
        chunk_size=args.chunk_size,
        progress=progress,
        checkpoint=args.checkpoint,
    )
    elapsed = time.time() - t0
    summary = stats.summary(bins)
    if theories:
        from ._theory import theory_summaries

        summary["theory"] = theory_summaries(problem, args, theories, bins)
    config = {
        **sea_config(args, ship),
        "realizations": args.realizations,
        "duration_s": args.duration,
        "discard_s": args.discard,
        "phi0_deg": args.phi0_deg,
        "chunk_size": args.chunk_size,
        "bin_width_deg": args.bin_width_deg,
        "theory": theories,
        "capsize_angle_deg": capsize_deg,
    }
    payload = {"config": config, **summary, "run_time_s": elapsed}
    if fit is not None:
        payload["filter_fit"] = fit.summary()
    title = (
        f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s, U = {args.speed:g} m/s, "
        f"N = {args.realizations}"
    )
    fig_lin, fig_log = amplitude_pdf_figures(payload, title=title)
    save_figure(fig_lin, out / "pdf_linear.png")
    save_figure(fig_log, out / "pdf_log.png")
    write_json(out / "pdf.json", payload)
    zc, env = summary["mean_amplitude_deg"]["zero_crossing"], summary["mean_amplitude_deg"]["envelope"]
    print(
        f"done in {elapsed:.1f} s: mean amplitude {zc:.2f}° (zero-crossing), {env:.2f}° (envelope); "
        f"99 % quantile {summary['quantiles_deg']['zero_crossing']['99']:.1f}° / "
        f"{summary['quantiles_deg']['envelope']['99']:.1f}°; capsized {stats.n_capsized}/{stats.n_realizations} "
        f"(P = {stats.capsize_probability:.4f})"
    )
    print(f"wrote {out / 'pdf_linear.png'}, {out / 'pdf_log.png'}, {out / 'pdf.json'}")
    return 0
