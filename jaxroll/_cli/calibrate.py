"""`jaxroll calibrate decay|captive|roll RECORDS...`: fit the ship's coefficients to tank records; writes
ship.toml (feeds straight back into `jaxroll pdf --ship`), calibration.json and figures."""

from __future__ import annotations

import time
from pathlib import Path

from ._common import CLIError, atomic_write_text, load_ship_arg, save_figure, write_json


def _common(p) -> None:
    p.add_argument(
        "records", nargs="+", metavar="RECORD", help="record files (.csv, .csv.gz) or folders of them"
    )
    p.add_argument(
        "--ship",
        metavar="FILE",
        default=None,
        help="ship file (TOML) whose other coefficients are kept; default C11 (representative)",
    )
    p.add_argument("--out", default=None, help="output folder (default ./jaxroll-out/calibrate-KIND)")
    p.add_argument(
        "--resample",
        action="store_true",
        help="interpolate irregularly sampled records onto their nominal rate (gaps are still refused)",
    )
    p.add_argument(
        "--name", default=None, help="name of the calibrated ship (default: '<ship> (calibrated)')"
    )


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="fit damping (decay), the GM correction (captive) or the model to roll PDFs (roll) from tank "
        "records",
        description="Calibrates a ship from tank records (docs/records.md, docs/calibration.md) and writes "
        "ship.toml, calibration.json and figures into --out.",
    )
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)
    d = kinds.add_parser(
        "decay", help="b1, b2, b3 from free-roll decay records (extinction curve and ODE fit)"
    )
    _common(d)
    d.add_argument(
        "--method",
        choices=("ode", "extinction"),
        default="ode",
        help="which fit goes into ship.toml (both are reported; default ode)",
    )
    d.add_argument(
        "--fixed-period",
        action="store_true",
        help="keep the ship's roll period in the ODE fit (default: fit it)",
    )
    d.add_argument(
        "--no-bias-correction",
        action="store_true",
        help="extinction method: plain first-order conversion of a, b, c (docs/calibration.md)",
    )
    d.set_defaults(func=run_decay)
    c = kinds.add_parser(
        "captive", help="σ_obs/σ_thr from captive tests (ΔGM at fixed heel with a wave probe)"
    )
    _common(c)
    c.add_argument(
        "--estimator",
        choices=("std_ratio", "ls"),
        default="std_ratio",
        help="correction written to ship.toml: the paper's σ_obs/σ_thr (default) or the LS scale",
    )
    c.add_argument("--fit-polynomial", action="store_true", help="also fit the ΔGM polynomial C0..Cn")
    c.add_argument(
        "--window",
        type=float,
        nargs=2,
        default=(70.0, 340.0),
        metavar=("START", "STOP"),
        help="analysis window [s, model scale] (default 70 340)",
    )
    c.add_argument(
        "--block",
        type=float,
        default=10.0,
        help="cluster length for the standard errors [s, model scale] (default 10)",
    )
    c.set_defaults(func=run_captive)
    r = kinds.add_parser("roll", help="fit damping and/or the GM correction to free-running amplitude PDFs")
    _common(r)
    r.add_argument(
        "--params",
        default="gm_correction",
        help="comma-separated parameters to fit: gm_correction, b1, b2, b3 (default gm_correction)",
    )
    r.add_argument("--realizations", type=int, default=96, help="Monte Carlo realizations per sea state (96)")
    r.add_argument(
        "--method",
        choices=("superposition", "filter"),
        default="superposition",
        help="effective wave of the Monte Carlo (default superposition)",
    )
    r.add_argument(
        "--derivative",
        choices=("fd", "pathwise"),
        default="fd",
        help="derivatives: central differences with common random numbers (default) or pathwise AD",
    )
    r.add_argument(
        "--window",
        type=float,
        nargs=2,
        default=(70.0, 340.0),
        metavar=("START", "STOP"),
        help="analysis window [s, model scale] (default 70 340)",
    )
    r.add_argument("--seed", type=int, default=0, help="random seed of the Monte Carlo (default 0)")
    r.set_defaults(func=run_roll)


def _load(args, kind):
    from ..io import load_records

    return load_records(args.records, kind=kind, resample=args.resample)


def _finish(args, kind, ship, fitted, payload, figures) -> int:
    from .. import ship_to_toml
    from ..io import load_ship

    out = Path(args.out or f"jaxroll-out/calibrate-{kind}")
    atomic_write_text(out / "ship.toml", ship_to_toml(fitted))
    load_ship(out / "ship.toml")  # the file must feed straight back into `jaxroll pdf --ship`
    for name, fig in figures.items():
        save_figure(fig, out / name)
    write_json(out / "calibration.json", payload)
    print(
        f"wrote {out / 'ship.toml'}, {out / 'calibration.json'}, " + ", ".join(str(out / n) for n in figures)
    )
    return 0


def _base_config(args, ship, records):
    from .. import ship_to_dict

    return {
        "kind": args.kind,
        "records": [r.source for r in records],
        "ship_file": args.ship,
        "ship": ship_to_dict(ship),
        "resample": args.resample,
    }


def _fmt(e) -> str:
    return f"{e.value:.5g} ± {e.std_error:.2g}"


def run_decay(args) -> int:
    import matplotlib.pyplot as plt

    from ..calibration import calibrated_ship, decay_agreement, fit_decay_ode, fit_extinction
    from ..plotting import plot_decay_fit, plot_extinction

    ship = load_ship_arg(args.ship)
    records = _load(args, "decay")
    t0 = time.time()
    ext = fit_extinction(records, ship, correct_bias=not args.no_bias_correction)
    ode = fit_decay_ode(records, ship, fit_period=not args.fixed_period)
    chosen = ode if args.method == "ode" else ext
    fitted = calibrated_ship(ship, decay=chosen, name=args.name)
    agree = decay_agreement(ext, ode)
    for f in (ext, ode):
        print(
            f"{f.method:>10}: b1 = {_fmt(f.damping['b1'])} 1/s, b2 = {_fmt(f.damping['b2'])} 1/rad, "
            f"b3 = {_fmt(f.damping['b3'])} s/rad²"
            + (f", Tφ = {_fmt(f.roll_period)} s" if f.method == "ode" else "")
        )
    print("agreement (difference / combined SE): " + ", ".join(f"{k} {v:+.2f}" for k, v in agree.items()))
    fig1, ax1 = plt.subplots(figsize=(6, 4))
    plot_extinction([ext, ode], ax=ax1)
    fig2, ax2 = plt.subplots(figsize=(8, 4))
    plot_decay_fit(ode, ax=ax2)
    payload = {
        "config": {
            **_base_config(args, ship, records),
            "method_written": args.method,
            "fit_period": not args.fixed_period,
            "bias_correction": not args.no_bias_correction,
        },
        "estimates": {"extinction": ext.to_dict(), "ode": ode.to_dict()},
        "written": {"damping": chosen.to_dict()["damping"], "roll_period_s": float(fitted.roll_period)},
        "agreement_z": agree,
        "run_time_s": time.time() - t0,
    }
    return _finish(args, "decay", ship, fitted, payload, {"extinction.png": fig1, "decay_fit.png": fig2})


def run_captive(args) -> int:
    import matplotlib.pyplot as plt

    from ..calibration import calibrated_ship, fit_captive
    from ..plotting import plot_captive, plot_captive_series

    if not args.block > 0:
        raise CLIError(f"--block must be > 0; got {args.block}.")
    ship = load_ship_arg(args.ship)
    records = _load(args, "captive")
    t0 = time.time()
    fit = fit_captive(
        records,
        ship,
        window_model_s=tuple(args.window),
        fit_polynomial=args.fit_polynomial,
        block_model_s=args.block,
    )
    fitted = calibrated_ship(ship, captive=fit, estimator=args.estimator, name=args.name)
    print(
        f"σ_obs/σ_thr = {_fmt(fit.std_ratio)}, LS scale = {_fmt(fit.ls_scale)} ({len(records)} records, "
        f"{len(fit.groups)} sea-state/heel groups); written: {args.estimator}"
    )
    fig1, ax1 = plt.subplots(figsize=(7, 4))
    plot_captive(fit, ax=ax1)
    fig2, ax2 = plt.subplots(figsize=(8, 3.5))
    plot_captive_series(fit, ax=ax2)
    payload = {
        "config": {
            **_base_config(args, ship, records),
            "estimator_written": args.estimator,
            "window_model_s": list(args.window),
            "block_model_s": args.block,
        },
        "estimates": fit.to_dict(),
        "written": {"gm_correction": float(fitted.gm_correction)},
        "run_time_s": time.time() - t0,
    }
    return _finish(
        args, "captive", ship, fitted, payload, {"captive_ratio.png": fig1, "captive_series.png": fig2}
    )


def run_roll(args) -> int:
    import jax

    from ..calibration import calibrated_ship, fit_roll_pdf
    from ..plotting import plot_roll_calibration

    params = [p.strip() for p in args.params.split(",") if p.strip()]
    if args.realizations < 2:
        raise CLIError(f"--realizations must be >= 2; got {args.realizations}.")
    ship = load_ship_arg(args.ship)
    records = _load(args, "roll")
    t0 = time.time()
    fit = fit_roll_pdf(
        records,
        ship,
        params=params,
        key=jax.random.key(args.seed),
        num_realizations=args.realizations,
        method=args.method,
        derivative=args.derivative,
        window_model_s=tuple(args.window),
        seed=args.seed,
    )
    fitted = calibrated_ship(ship, roll=fit, name=args.name)
    print(
        "fitted "
        + ", ".join(f"{k} = {_fmt(v)} (from {fit.initial[k]:.5g})" for k, v in fit.estimates.items())
        + f"; {fit.info.num_steps} solver steps, {time.time() - t0:.0f} s"
    )
    payload = {
        "config": {**_base_config(args, ship, records), "params": params},
        "estimates": fit.to_dict(),
        "run_time_s": time.time() - t0,
    }
    return _finish(args, "roll", ship, fitted, payload, {"roll_pdfs.png": plot_roll_calibration(fit)})
