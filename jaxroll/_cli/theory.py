"""`jaxroll theory`: the theoretical amplitude PDFs alone (Roberts, ESAM, moment method, envelope FPK), no Monte
Carlo."""

from __future__ import annotations

import functools
import time
from pathlib import Path

from ._common import load_ship_arg, save_figure, write_json, write_netcdf
from ._sea import add_sea_options, check_positive, check_sea_options, sea_config


def register(sub) -> None:
    p = sub.add_parser(
        "theory", help="theoretical roll-amplitude PDFs (Roberts, ESAM, moment method, envelope FPK)"
    )
    add_sea_options(p)
    p.add_argument(
        "--theory",
        default=None,
        help="comma-separated: roberts,esam,moment,envelope_fpk (default: all four, and a theory that has no law in "
        "this sea state is left out with its reason; named ones must all have one)",
    )
    p.add_argument("--bin-width-deg", type=float, default=1.0, help="PDF bin width [deg] (1)")
    p.add_argument("--out", default="jaxroll-out/theory", help="output folder (default ./jaxroll-out/theory)")
    p.add_argument(
        "--quiet",
        action="store_true",
        help="no progress display (it shows none; accepted like the other commands')",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    import numpy as np

    from ..ship import vanishing_angle
    from ..theory import THEORIES
    from ._common import CLIError, OutputFolder
    from ._sea import build_theory_inputs
    from ._theory import closure_note, start_theory_summaries
    from .pdf import parse_theories, pdf_bins

    # Check every option before the filter fit and the theories' compilation.
    named = args.theory is not None  # named theories must all have a law; of the default set, those that have
    names = (
        parse_theories(args.theory) if named else list(THEORIES)
    )  # one here are shown, the others left out
    if not names:
        raise CLIError("--theory: give at least one of roberts,esam,moment,envelope_fpk.")
    check_sea_options(args)
    check_positive(args, "bin_width_deg")
    pdf_bins(args.bin_width_deg, 89.0)
    out = Path(args.out)
    ship = load_ship_arg(args.ship)
    t0 = time.time()
    inputs = build_theory_inputs(
        args, ship
    )  # no time stepping here: the Monte Carlo's dt check does not apply

    @functools.cache
    def bins():  # computed while the filter fit starts (a program to load or compile: the vanishing angle's)
        return pdf_bins(args.bin_width_deg, float(np.rad2deg(np.asarray(vanishing_angle(ship)))))

    finish = start_theory_summaries(inputs, args, names, bins, skip_failed=not named, warn=False)
    from ..plotting import amplitude_pdf_figures  # imported (matplotlib: ~0.4 s) while the theories compute

    theories, left_out = finish() if not named else (finish(), {})
    if not theories:
        raise CLIError(
            "no theory has a law in this sea state:\n"
            + "\n".join(f"  {name}: {reason}" for name, reason in left_out.items())
        )
    payload = {
        "config": {**sea_config(args, ship), "theory": names},
        "bins_deg": bins(),
        "theory": theories,
        "run_time_s": time.time() - t0,
    }
    if left_out:
        payload["theory_left_out"] = left_out
    with OutputFolder(out) as tmp:
        fig_lin, fig_log = amplitude_pdf_figures(
            payload, title=f"{ship.name}: H1/3 = {args.hs:g} m, T01 = {args.t01:g} s (theory)"
        )
        save_figure(fig_lin, tmp / "theory_linear.png")
        save_figure(fig_log, tmp / "theory_log.png")
        write_json(tmp / "theory.json", payload)
        nc = write_netcdf(tmp / "theory.nc", "theory", payload)
    for name, t in theories.items():
        print(
            f"{name:>12}: mean {t['mean_amplitude_deg']:.2f}°, 99 % {t['quantiles_deg']['99']:.2f}° "
            f"({t['time_s']:.2f} s{closure_note(t)})"
        )
    for name, reason in left_out.items():
        print(f"{name:>12}: left out, no law here: {reason}")
    print(f"wrote {out}/theory_linear.png, theory_log.png, theory.json" + (", theory.nc" if nc else ""))
    return 0
