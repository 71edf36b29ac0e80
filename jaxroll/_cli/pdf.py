"""`jaxroll pdf`: the paper's Monte Carlo amplitude PDFs with the theoretical PDFs overlaid (the paper's figure)."""

from __future__ import annotations

import math
import time
from pathlib import Path

from ._common import (
    CLIError,
    Progress,
    add_chunk_option,
    add_memory_option,
    atomic_write_text,
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
    has_yaw,
    resolved_method,
    sea_config,
    sea_heading_phrase,
)

THEORIES = ("roberts", "esam", "moment", "envelope_fpk")
#: Above this capsize probability the Monte Carlo's PDF (of the survivors) and the theories' stationary laws are not
#: comparable: `jaxroll pdf` warns.
CAPSIZE_LIMIT_FOR_THEORIES = 0.1
# the theories `jaxroll pdf` overlays unless --theory says otherwise (docs/theory.md, "Speed": what they cost)
DEFAULT_OVERLAY = ("roberts", "esam", "moment")


def register(sub) -> None:
    p = sub.add_parser(
        "pdf",
        help="Monte Carlo roll-amplitude PDFs, paper style (default: C11 representative, H1/3 7 m, T01 10 s)",
        description="Runs the paper's MCS protocol (φ(0)=5°, 3600 s, 10⁴ realizations) and writes pdf_linear.png, "
        "pdf_log.png, pdf.json and pdf.nc (docs/outputs.md) into --out.",
    )
    add_sea_options(p)
    add_yaw_options(p)
    m = p.add_argument_group("Monte Carlo")
    m.add_argument("--realizations", type=int, default=10_000, help="number of realizations (default 10000)")
    m.add_argument("--duration", type=float, default=3600.0, help="simulated time per realization [s] (3600)")
    m.add_argument(
        "--discard", type=float, default=0.0, help="initial transient left out of the PDFs [s] (0)"
    )
    m.add_argument("--phi0-deg", type=float, default=5.0, help="initial roll angle [deg] (5)")
    add_chunk_option(m, streaming=False)
    add_memory_option(m)
    m.add_argument("--bin-width-deg", type=float, default=1.0, help="PDF bin width [deg] (1)")
    m.add_argument(
        "--theory",
        default=None,
        help=f"comma-separated theories to overlay: {','.join(THEORIES)}, or none (default: "
        f"{','.join(DEFAULT_OVERLAY)}, the paper's figure; a default theory that has no law here is left out)",
    )
    m.add_argument("--checkpoint", metavar="DIR", default=None, help="save progress in DIR; a rerun resumes")
    p.add_argument("--out", default="jaxroll-out/pdf", help="output folder (default ./jaxroll-out/pdf)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def parse_theories(text: str) -> list[str]:
    """The theory names of a --theory option (comma-separated; `none` or empty: none)."""
    if text.strip().lower() == "none":
        return []
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


def check_run_length(duration: float, discard: float, ship) -> None:
    """Refuse a run that cannot produce an amplitude: (duration − discard) shorter than two roll periods."""
    if not (math.isfinite(discard) and 0 <= discard < duration):
        raise CLIError(f"--discard must be in [0, --duration) = [0, {duration:g}) s; got {discard:g}.")
    t_roll = float(ship.roll_period)
    if duration - discard < 2 * t_roll:
        raise CLIError(
            f"--duration − --discard = {duration - discard:g} s is shorter than two roll periods "
            f"(2 × {t_roll:.3g} s): no roll amplitude could be measured. Use --duration >= "
            f"{discard + 2 * t_roll:.0f} s (the paper: 3600 s)."
        )


def check_phi0(phi0_deg: float, ship, direct: bool = False) -> None:
    """Refuse φ0 = 0 (the parametric roll equation has no direct excitation: φ ≡ 0 forever) unless `direct` (the
    ship's wave moment joins the roll), and angles at or beyond the vanishing angle."""
    import jax.numpy as jnp

    from ..ship import vanishing_angle

    if not math.isfinite(phi0_deg):
        raise CLIError(f"--phi0-deg must be finite; got {phi0_deg}.")
    if phi0_deg == 0 and not direct:
        raise CLIError(
            "--phi0-deg 0: the roll equation has parametric excitation only, so a ship started upright stays "
            "upright (φ ≡ 0) and there is no amplitude to estimate. Use the paper's --phi0-deg 5."
        )
    vanish = float(jnp.rad2deg(vanishing_angle(ship)))
    if abs(phi0_deg) >= vanish:
        raise CLIError(
            f"--phi0-deg {phi0_deg:g} is at or beyond the angle of vanishing stability ({vanish:.1f}°)."
        )


def capsize_caption(n_realizations: int, n_capsized: int) -> str:
    """'N = 10000' or 'N = 10000, 9143 capsized; PDF of the 857 survivors'."""
    if not n_capsized:
        return f"N = {n_realizations}"
    return f"N = {n_realizations}, {n_capsized} capsized; PDF of the {n_realizations - n_capsized} survivors"


_TIME_FILE = "jaxroll_pdf_run_time.json"


def run(args) -> int:
    import json

    import jax
    import jax.numpy as jnp

    from .. import monte_carlo_amplitudes
    from ..plotting import amplitude_pdf_figures
    from ._common import OutputFolder

    # Check everything first: no filter fit, compilation or simulation before every option is known good.
    theories = parse_theories(",".join(DEFAULT_OVERLAY) if args.theory is None else args.theory)
    check_sea_options(args)
    check_positive(args, "duration", "bin_width_deg")
    check_steps(args.dt, {"--duration": args.duration})
    if args.realizations < 1:
        raise CLIError(f"--realizations must be >= 1; got {args.realizations}.")
    check_chunk_size(args)
    from ..roll import default_chunk_size

    chunk = args.chunk_size if args.chunk_size is not None else default_chunk_size(True)
    budget = memory_budget(args)
    out = Path(args.out)
    checkpoint_file = None
    if args.checkpoint is not None:
        if Path(args.checkpoint).exists() and not Path(args.checkpoint).is_dir():
            raise CLIError(f"--checkpoint {args.checkpoint!r} exists and is not a folder.")
        checkpoint_file = Path(args.checkpoint) / "checkpoint.npz"
    ship = load_ship_arg(args.ship)
    check_run_length(args.duration, args.discard, ship)
    check_phi0(
        args.phi0_deg,
        ship,
        direct=resolved_method(args, ship) == "superposition" and ship.wave_moment is not None,
    )
    bins_check = pdf_bins(args.bin_width_deg, 89.0)  # the width is valid (the grid's top comes later)
    del bins_check
    problem, fit, sea = build_problem(args, ship, phi0_deg=args.phi0_deg)
    capsize_deg = float(jnp.rad2deg(problem.capsize_angle))
    bins = pdf_bins(args.bin_width_deg, capsize_deg)
    if args.ship is None:
        print(
            "Ship: C11 (representative) — Table-1 particulars, representative coefficients (see `jaxroll ship show`)."
        )
    print(
        f"Monte Carlo: {args.realizations} realizations × {args.duration:g} s, dt {args.dt} s, "
        f"H1/3 {args.hs} m, T01 {args.t01} s, {sea_heading_phrase(args)}, U {args.speed} m/s, method {resolved_method(args, ship)}"
        + (f", yaw σ_ψ {args.yaw_std:g}° τ {args.yaw_time:g} s" if has_yaw(problem) else "")
    )
    earlier = 0.0
    resumed = checkpoint_file is not None and checkpoint_file.exists()
    if resumed:
        try:
            earlier = float(json.loads((Path(args.checkpoint) / _TIME_FILE).read_text())["run_time_s"])
        except (OSError, ValueError, KeyError, TypeError):
            earlier = 0.0
    finish_theories = None
    if (
        theories
    ):  # loaded and dispatched before the Monte Carlo (not in its run time): they compute while it runs
        from ._theory import start_theory_summaries

        default = args.theory is None  # the default overlay: a theory without a law, or a fallback, is noted
        finish_theories = start_theory_summaries(problem, args, theories, bins, skip_failed=default,
                                                 warn=not default)  # fmt: skip
    shown = Progress(args.realizations, "realizations", enabled=None if not args.quiet else False,
                     resuming=f"resuming from the checkpoint in {args.checkpoint} ({earlier:.1f} s of earlier run "
                     "time)" if resumed else None)  # fmt: skip
    t0 = time.time()

    def progress(done: int) -> None:
        shown(done)
        if args.checkpoint is not None:
            atomic_write_text(
                Path(args.checkpoint) / _TIME_FILE,
                json.dumps({"run_time_s": earlier + time.time() - t0}) + "\n",
            )

    with OutputFolder(out) as tmp:
        stats = monte_carlo_amplitudes(
            problem,
            jax.random.key(args.seed),
            num_realizations=args.realizations,
            duration=args.duration,
            discard=args.discard,
            chunk_size=chunk,
            memory_budget=budget,
            progress=progress,
            checkpoint=args.checkpoint,
        )
        elapsed = time.time() - t0
        summary = stats.summary(bins)
        theories_failed = {}
        if finish_theories is not None:
            summary["theory"] = finish_theories()
            if args.theory is None:  # the default overlay: a theory that has no law here is left out
                summary["theory"], theories_failed = summary["theory"]
                if theories_failed:
                    summary["theory_left_out"] = theories_failed
        config = {
            **sea_config(args, ship),
            "realizations": args.realizations,
            "duration_s": args.duration,
            "discard_s": args.discard,
            "phi0_deg": args.phi0_deg,
            "chunk_size": chunk,
            "bin_width_deg": args.bin_width_deg,
            "theory": theories,
            "capsize_angle_deg": capsize_deg,
        }
        left = stats.config.get("n_left_gz_surface_range")  # a ship with a GZ surface: ended by leaving it
        if left is not None:
            config["n_left_gz_surface_range"] = left
        payload = {"config": config, **summary, "run_time_s": elapsed}
        if resumed:
            payload["resumed_from_checkpoint"] = True
            payload["total_run_time_s"] = earlier + elapsed
        if fit is not None:
            payload["filter_fit"] = fit.summary()
        if problem.moment_excitation is not None and not has_yaw(
            problem
        ):  # the direct wave moment's exact linear roll, beside the MC's
            from ..theory import linear_roll_variance

            payload["wave_moment"] = {
                "source": ship.wave_moment.source,
                "linear_roll_variance_rad2": float(linear_roll_variance(problem)),
                "note": "E[φ²] of the linear roll (b1, ω0) driven by the direct wave moment alone: the Monte "
                "Carlo's roll_moments.E_phi2 in a small sea (docs/wave_moment.md)",
            }
        if summary.get("theory") and stats.capsize_probability > CAPSIZE_LIMIT_FOR_THEORIES:
            import warnings

            warnings.warn(
                f"{stats.n_capsized} of {stats.n_realizations} realizations capsized (P = "
                f"{stats.capsize_probability:.3g}): the theories overlaid ({', '.join(summary['theory'])}) are "
                "stationary laws of a roll that never capsizes, so they do not describe this sea state, and the "
                f"Monte Carlo's PDF is that of the {stats.n_realizations - stats.n_capsized} survivors only. This "
                f"warning appears because more than {CAPSIZE_LIMIT_FOR_THEORIES:.0%} of the realizations capsized.",
                stacklevel=2,
            )
        caption = capsize_caption(stats.n_realizations, stats.n_capsized)
        title = (
            f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s, U = {args.speed:g} m/s, "
            f"{sea_heading_phrase(args)}, {caption}"
        )
        fig_lin, fig_log = amplitude_pdf_figures(payload, title=title)
        save_figure(fig_lin, tmp / "pdf_linear.png")
        save_figure(fig_log, tmp / "pdf_log.png")
        write_json(tmp / "pdf.json", payload)
        nc = write_netcdf(tmp / "pdf.nc", "pdf", payload, stats.to_xarray(bins))
    took = f"done in {elapsed:.1f} s" + (f" (resumed; {earlier + elapsed:.1f} s in total)" if resumed else "")
    capsized = f"capsized {stats.n_capsized}/{stats.n_realizations} (P = {stats.capsize_probability:.4f})"
    if left:
        capsized += f", of which {left} left the ship's GZ surface (not extrapolated)"
    print(f"{took}; {capsized}")
    if stats.n_capsized:
        print(f"the statistics below are conditional on no capsize: {caption}")
    for est, name in (("zero_crossing", "zero-crossing"), ("envelope", "envelope")):
        if summary[f"pdf_{est}"] is None:
            continue
        q = summary["quantiles_deg"][est]
        beyond = summary["mass_beyond_grid"][est]
        print(
            f"{name:>13}: mean amplitude {summary['mean_amplitude_deg'][est]:.2f}°, 99 % quantile {q['99']:.1f}°"
            + (f", {beyond:.2g} of the amplitudes beyond {bins[-1]:g}°" if beyond else "")
        )
    if "wave_moment" in payload:
        e_mc, e_lin = summary["roll_moments"]["E_phi2"], payload["wave_moment"]["linear_roll_variance_rad2"]
        print(
            f"direct wave moment ({payload['wave_moment']['source']}) in the roll: E[φ²] {e_mc:.4g} rad² (Monte "
            f"Carlo) against {e_lin:.4g} rad² for the linear roll it alone drives (ratio {e_mc / e_lin:.4f})"
        )
    if summary["reason"]:
        print(f"no statistics: {summary['reason']}")
    if summary["stationarity"]["note"]:
        print(f"warning: {summary['stationarity']['note']}")
    if summary.get("theory"):
        from ._theory import closure_note

        print("theory overlay: " + ", ".join(
            f"{name} (mean {t['mean_amplitude_deg']:.2f}°{closure_note(t)})" for name, t in summary["theory"].items())
            + ("" if args.theory is not None else "; --theory none leaves them out"))  # fmt: skip
    for name, reason in theories_failed.items():
        print(f"theory overlay: {name} left out: {reason}")
    print(
        f"wrote {out / 'pdf_linear.png'}, {out / 'pdf_log.png'}, {out / 'pdf.json'}"
        + (f", {out / 'pdf.nc'}" if nc else "")
    )
    return 0
