"""`jaxroll calibrate decay|captive|roll RECORDS...`: fit the ship's coefficients to tank records; writes
ship.toml (feeds straight back into `jaxroll pdf --ship`), calibration.json and figures. `roll` fits the
amplitude PDFs (`--estimator pdf`) or the time series (`time-domain`: multiple shooting; `kalman`: EKF
likelihood)."""

from __future__ import annotations

import math
import time
from pathlib import Path

from ._common import (
    CLIError,
    OutputFolder,
    atomic_write_text,
    import_output_libraries,
    load_ship_arg,
    save_figure,
    write_json,
    write_netcdf,
)
from ._lab import add_lab_options, import_lab_files, lab_mode, lab_settings

DAMPING_MODEL_CHOICES = ("linear", "linear+quadratic", "linear+cubic", "linear+quadratic+cubic")


def _common(p, kind: str) -> None:
    p.add_argument(
        "records",
        nargs="+",
        metavar="RECORD",
        help="record files (.csv, .csv.gz) or folders of them; with the lab-file options below, a lab's files "
        "(CSV of any layout, HDF5 FILE.h5[:/group])",
    )
    p.add_argument(
        "--ship",
        metavar="FILE",
        default=None,
        help="ship file (TOML) whose other coefficients are kept; default C11 (representative); decay: without "
        "--ship, --gm or --roll-period no ship.toml is written (the damping needs only the records)",
    )
    p.add_argument(
        "--out",
        default=f"jaxroll-out/calibrate-{kind}",
        help=f"output folder (default ./jaxroll-out/calibrate-{kind})",
    )
    p.add_argument(
        "--start",
        type=float,
        default=None,
        metavar="S",
        help="analyse from this time [s, model scale: the record file's own time] (decay: default the release, "
        "found in each record)",
    )
    p.add_argument(
        "--stop",
        type=float,
        default=None,
        metavar="S",
        help="analyse up to this time [s, model scale: the record file's own time] (default: the end)",
    )
    p.add_argument(
        "--resample",
        action="store_true",
        help="interpolate irregularly sampled records onto their nominal rate (gaps are still refused)",
    )
    p.add_argument(
        "--name", default=None, help="name of the calibrated ship (default: '<ship> (calibrated)')"
    )
    add_lab_options(p, for_calibrate=True)


def register(sub) -> None:
    p = sub.add_parser(
        "calibrate",
        help="fit damping (decay), the GM correction (captive) or the model to free-running roll records (roll: "
        "amplitude PDFs, or the time series) from tank records",
        description="Calibrates a ship from tank records (docs/records.md, docs/calibration.md) and writes "
        "ship.toml, calibration.json, calibration.nc (docs/outputs.md) and figures into --out.",
    )
    kinds = p.add_subparsers(dest="kind", metavar="KIND", required=True)
    d = kinds.add_parser(
        "decay", help="b1, b2, b3 from free-roll decay records (extinction curve and ODE fit)"
    )
    _common(d, "decay")
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
        "--damping-model",
        choices=DAMPING_MODEL_CHOICES,
        default="linear+quadratic",
        help="damping terms fitted (the others 0; all kept >= 0): linear b1, linear+quadratic b1, b2 (default), "
        "linear+cubic b1, b3, or linear+quadratic+cubic; every model's information criterion is reported",
    )
    bias = d.add_mutually_exclusive_group()
    bias.add_argument(
        "--bias-correction",
        action="store_true",
        help="extinction method: remove the first-order conversion's bias by simulation (docs/calibration.md)",
    )
    bias.add_argument(
        "--no-bias-correction",
        action="store_true",
        help="extinction method: plain first-order conversion of a, b, c (the default)",
    )
    d.add_argument(
        "--gm",
        type=float,
        default=None,
        metavar="M",
        help="GM0 of the ship tested [m, full scale]: with it (or --roll-period, or --ship) a ship.toml is written",
    )
    d.add_argument(
        "--roll-period",
        type=float,
        default=None,
        metavar="S",
        help="natural roll period of the ship tested [s, full scale] (a warning when the records' differs by > 2 %%)",
    )
    d.set_defaults(func=run_decay)
    c = kinds.add_parser(
        "captive", help="σ_obs/σ_thr from captive tests (ΔGM at fixed heel with a wave probe)"
    )
    _common(c, "captive")
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
    r = kinds.add_parser(
        "roll",
        help="fit damping and/or the GM correction to free-running records (amplitude PDFs, or the time series)",
        description="Calibrates the roll model on free-running roll records. --estimator pdf (default) matches "
        "the model's amplitude PDFs (Monte Carlo); time-domain fits the roll time series by multiple shooting "
        "through the roll equation driven by the probe's effective wave; kalman maximises the extended-Kalman-"
        "filter likelihood with fitted process noise (use it when the model is not exact; "
        "docs/calibration.md, 'Time-domain calibration').",
    )
    _common(r, "roll")
    r.add_argument(
        "--estimator",
        choices=("pdf", "time-domain", "kalman"),
        default="pdf",
        help="pdf: amplitude-PDF band means (default); time-domain: multiple shooting; kalman: EKF likelihood",
    )
    r.add_argument(
        "--params",
        default=None,
        help="comma-separated parameters to fit. pdf: gm_correction, b1, b2, b3 (default gm_correction); "
        "time-domain, kalman: b1, b2, b3, gm_correction, roll_period, delta_gm_nonlinear "
        "(default b1,b2,gm_correction)",
    )
    r.add_argument(
        "--realizations", type=int, default=None, help="pdf: Monte Carlo realizations per sea state (96)"
    )
    r.add_argument(
        "--method",
        choices=("superposition", "filter"),
        default=None,
        help="pdf: effective wave of the Monte Carlo (default superposition)",
    )
    r.add_argument(
        "--derivative",
        choices=("fd", "pathwise"),
        default=None,
        help="pdf: derivatives by central differences with common random numbers (default) or pathwise AD",
    )
    r.add_argument(
        "--window",
        type=float,
        nargs=2,
        default=None,
        metavar=("START", "STOP"),
        help="analysis window [s, model scale]; pdf: default 70 340; time-domain, kalman: default 70 340 when "
        "the records cover it, else each record less 5·T01 at both ends",
    )
    r.add_argument(
        "--shooting-window",
        type=float,
        default=None,
        metavar="S",
        help="time-domain: length of each shooting window [s, full scale] (default four natural roll periods "
        "of the ship, 97.6 s for C11)",
    )
    r.add_argument("--seed", type=int, default=None, help="pdf: random seed of the Monte Carlo (default 0)")
    r.set_defaults(func=run_roll)


def _load(args, kind):
    """The records: jaxroll record files, or lab files read with the lab-file options (all checked first)."""
    from ..io import load_records

    if lab_mode(args):
        records = import_lab_files(
            args.records, kind or "roll", lab_settings(args, kind or "roll"), resample=args.resample
        )
    else:
        records = load_records(args.records, kind=kind, resample=args.resample)
    if kind != "decay" and (args.start is not None or args.stop is not None):  # decay: the fits take them
        records = [r.window(args.start, args.stop) for r in records]
    return records


def _finish(args, kind, ship, fitted, payload, figures, fit=None) -> int:
    """Write the set (ship.toml unless `fitted` is None) and say which files were written."""
    from .. import ship_to_toml
    from ..io import load_ship

    out = Path(args.out)
    layout = kind if kind != "roll" else f"roll-{'pdf' if args.estimator == 'pdf' else 'time-domain'}"
    with OutputFolder(out) as tmp:  # one set: never a new ship.toml beside an old calibration.json
        if fitted is not None:
            atomic_write_text(tmp / "ship.toml", ship_to_toml(fitted))
            load_ship(tmp / "ship.toml")  # the file must feed straight back into `jaxroll pdf --ship`
        for name, fig in figures.items():
            save_figure(fig, tmp / name)
        write_json(tmp / "calibration.json", payload)
        nc = write_netcdf(
            tmp / "calibration.nc", f"calibrate-{layout}", payload, None if fit is None else {"fit": fit}
        )
    names = [*(["ship.toml"] if fitted is not None else []), "calibration.json"]
    names += [*(["calibration.nc"] if nc else []), *figures]
    print("wrote " + ", ".join(str(out / n) for n in names))
    return 0


def _base_config(args, ship, records):
    from .. import ship_to_dict

    config = {
        "kind": args.kind,
        "records": [r.source for r in records],
        "ship_file": args.ship,
        "ship": None if ship is None else ship_to_dict(ship),
        "resample": args.resample,
    }
    if args.start is not None or args.stop is not None:
        config["start_model_s"], config["stop_model_s"] = args.start, args.stop
    if lab_mode(args):
        config["lab_import"] = [r.meta["imported_from"] for r in records]
    return config


def _fmt(e) -> str:
    return f"{e.value:.5g} ± {e.std_error:.2g}"


def _decay_ship_arg(args):
    """The ship of a decay calibration, or None: --ship, else the default ship with --gm/--roll-period, else none
    (the damping needs only the records; no ship.toml is written)."""
    import equinox as eqx
    import jax.numpy as jnp

    for name in ("gm", "roll_period"):
        v = getattr(args, name)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise CLIError(f"--{name.replace('_', '-')} must be > 0 (full scale); got {v:g}.")
    if args.ship is None and args.gm is None and args.roll_period is None:
        return None
    ship = load_ship_arg(args.ship)
    if args.gm is not None:
        ship = eqx.tree_at(lambda s: s.gm0, ship, jnp.asarray(args.gm))
    if args.roll_period is not None:
        ship = eqx.tree_at(lambda s: s.roll_period, ship, jnp.asarray(args.roll_period))
    return ship


def _zeta_line(fit) -> str:
    eq = fit.equivalent_damping_table()
    return ", ".join(
        f"{a:.2f}° {z:.5f} ± {s:.1g}"
        for a, z, s in list(zip(eq["amplitude_deg"], eq["zeta"], eq["zeta_std_error"]))[::3]
    )


def run_decay(args) -> int:
    import concurrent.futures

    from ..calibration import (
        calibrated_ship,
        decay_agreement,
        fit_decay_ode,
        fit_extinction,
    )

    ship = _decay_ship_arg(args)
    records = _load(args, "decay")
    t0 = time.time()
    window = {"start_model_s": args.start, "stop_model_s": args.stop}
    ext = fit_extinction(
        records, ship, damping_model=args.damping_model, correct_bias=args.bias_correction, **window
    )
    # The ODE fit (its program loaded after the extinction fit above loaded the same kind: the worker imports no
    # module on a warm run) runs in a worker thread, and computes in XLA's threads, while this one fits the other
    # damping models' extinction curves and imports what the figures and the netCDF file need (~0.5 s)
    with concurrent.futures.ThreadPoolExecutor(1) as worker:
        pending = worker.submit(
            fit_decay_ode,
            records,
            ship,
            damping_model=args.damping_model,
            fit_period=not args.fixed_period,
            **window,
        )
        # the models compared by the extinction curve: an ODE fit per model would add ~30 s of compilation each
        # (docs/calibration.md, "Damping models"); warnings are said once
        comparison = {
            model: (
                ext
                if model == args.damping_model
                else fit_extinction(records, ship, damping_model=model, **window)
            ).information_criteria()
            for model in DAMPING_MODEL_CHOICES
        }
        import_output_libraries()
        ode = pending.result()
    import matplotlib.pyplot as plt

    from ..plotting import plot_decay_fit, plot_equivalent_damping, plot_extinction

    chosen = ode if args.method == "ode" else ext
    fitted = None if ship is None else calibrated_ship(ship, decay=chosen, name=args.name)
    agree = decay_agreement(ext, ode)
    for r in ode.records:
        print(
            f"{r['source']}: analysed from {r['start_model_s']:.3f} s ("
            + ("release found" if r["start_from"] == "release found" else "--start")
            + f"; model scale) to {r['stop_model_s']:.3f} s; initial amplitude {r['initial_amplitude_deg']:.2f}°, "
            f"roll offset {r['roll_offset_deg']:+.3f}°, observed period {r['observed_period_s']:.4g} s full scale"
        )
    for f in (ext, ode):
        print(
            f"{f.method:>10} ({f.damping_model}): "
            + ", ".join(
                f"{k} = {_fmt(f.damping[k])} {f.damping[k].unit.replace('^2', '²')}"
                for k in f.fitted_parameters
            )
            + f", Tφ = {_fmt(f.roll_period)} s ({'fitted' if f.method == 'ode' else 'observed'})"
        )
        print(f"{'':>10} ζ_eq(A): {_zeta_line(f)}")
    best = min(comparison, key=lambda m: comparison[m]["bic"])
    print(
        "damping models (extinction curve, BIC; smaller is better): "
        + ", ".join(f"{m} {c['bic']:.1f}" for m, c in comparison.items())
        + f"; best {best}, written {args.damping_model}"
    )
    print("agreement (difference / combined SE): " + ", ".join(f"{k} {v:+.2f}" for k, v in agree.items()))
    fig1, ax1 = plt.subplots(figsize=(6, 4))
    plot_extinction([ext, ode], ax=ax1)
    fig2, ax2 = plt.subplots(figsize=(8, 4))
    plot_decay_fit(ode, ax=ax2)
    fig3, ax3 = plt.subplots(figsize=(6, 4))
    plot_equivalent_damping([ext, ode], ax=ax3)
    payload = {
        "config": {
            **_base_config(args, ship, records),
            "method_written": args.method,
            "fit_period": not args.fixed_period,
            "bias_correction": args.bias_correction,
            "damping_model": args.damping_model,
        },
        "estimates": {"extinction": ext.to_dict(), "ode": ode.to_dict()},
        "model_comparison": {
            m: {"aic": c["aic"], "bic": c["bic"], "method": "extinction"} for m, c in comparison.items()
        },
        # the damping of the chosen fit (ship.toml's, when one is written; b >= 0 by the fits' parametrisation)
        "written": {
            "damping": chosen.to_dict()["damping"],
            "roll_period_s": chosen.roll_period.value,
            "ship_written": fitted is not None,
            "constrained": {},
        },
        "agreement_z": agree,
        "run_time_s": time.time() - t0,
    }
    return _finish(
        args,
        "decay",
        ship,
        fitted,
        payload,
        {"extinction.png": fig1, "decay_fit.png": fig2, "equivalent_damping.png": fig3},
        chosen.to_xarray(),
    )


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
        args,
        "captive",
        ship,
        fitted,
        payload,
        {"captive_ratio.png": fig1, "captive_series.png": fig2},
        fit.to_xarray(),
    )


_PDF_ONLY = ("realizations", "method", "derivative", "seed")


def run_roll(args) -> int:
    if args.estimator != "pdf":
        return _run_roll_time_domain(args)
    import jax

    from ..calibration import calibrated_ship, fit_roll_pdf
    from ..plotting import plot_roll_calibration

    if args.shooting_window is not None:
        raise CLIError("--shooting-window belongs to --estimator time-domain.")
    params = [p.strip() for p in (args.params or "gm_correction").split(",") if p.strip()]
    allowed = ("gm_correction", "b1", "b2", "b3")
    for p in params:
        if p not in allowed:
            raise CLIError(
                f"--params: {p!r} is not a parameter of the roll model the pdf estimator fits; choose from "
                f"{', '.join(allowed)} (roll_period and delta_gm_nonlinear: --estimator time-domain or kalman)."
            )
    realizations = 96 if args.realizations is None else args.realizations
    seed = 0 if args.seed is None else args.seed
    window = (70.0, 340.0) if args.window is None else tuple(args.window)
    if realizations < 2:
        raise CLIError(f"--realizations must be >= 2; got {realizations}.")
    ship = load_ship_arg(args.ship)
    records = _load(args, "roll")
    t0 = time.time()
    fit = fit_roll_pdf(
        records,
        ship,
        params=params,
        key=jax.random.key(seed),
        num_realizations=realizations,
        method=args.method or "superposition",
        derivative=args.derivative or "fd",
        window_model_s=window,
        seed=seed,
    )
    fitted = calibrated_ship(ship, roll=fit, name=args.name)
    print(
        "fitted "
        + ", ".join(f"{k} = {_fmt(v)} (from {fit.initial[k]:.5g})" for k, v in fit.estimates.items())
        + f"; {fit.info.num_steps} solver steps, {time.time() - t0:.0f} s"
    )
    payload = {
        "config": {**_base_config(args, ship, records), "estimator": "pdf", "params": params},
        "estimates": fit.to_dict(),
        "run_time_s": time.time() - t0,
    }
    return _finish(
        args, "roll", ship, fitted, payload, {"roll_pdfs.png": plot_roll_calibration(fit)}, fit.to_xarray()
    )


def _run_roll_time_domain(args) -> int:
    """`--estimator time-domain|kalman`: every input is checked before anything is computed."""
    import sys

    from .. import ship_to_dict
    from ..calibration import (
        calibrated_ship,
        check_time_domain_inputs,
        check_time_domain_params,
        default_window,
        fit_roll_kalman,
        fit_roll_time_domain,
    )
    from ..plotting import plot_residual_spectrum, plot_time_domain_fit

    kalman = args.estimator == "kalman"
    given = [f"--{o}" for o in _PDF_ONLY if getattr(args, o) is not None]
    if given:
        raise CLIError(
            f"{', '.join(given)} belong(s) to --estimator pdf (the Monte Carlo); the time-domain estimators take "
            "the effective wave from the records' wave probe."
        )
    if kalman and args.shooting_window is not None:
        raise CLIError(
            "--shooting-window belongs to --estimator time-domain (the Kalman filter has no windows)."
        )
    try:
        params = check_time_domain_params(
            [p.strip() for p in (args.params or "b1,b2,gm_correction").split(",") if p.strip()]
        )
    except ValueError as e:
        raise CLIError(f"--params: {e}") from None
    if args.shooting_window is not None and not args.shooting_window > 0:
        raise CLIError(f"--shooting-window must be > 0 [s, full scale]; got {args.shooting_window:g}.")
    ship = load_ship_arg(args.ship)
    records = _load(args, None)
    span = None if args.window is None else tuple(args.window)
    checked = check_time_domain_inputs(
        ship,
        records,
        params=params,
        window=args.shooting_window,
        span_model_s=span,
        what="Kalman-filter calibration" if kalman else "time-domain calibration",
        check_window=not kalman,
    )
    # --- compute ---
    t0 = time.time()
    if kalman:
        fit = fit_roll_kalman(ship, records, params=params, span_model_s=span, warn=False)
    else:
        fit = fit_roll_time_domain(
            ship, records, params=params, window=args.shooting_window, span_model_s=span, warn=False
        )
    fitted = calibrated_ship(ship, roll=fit, name=args.name)
    for k, e in fit.estimates.items():
        lo, hi = e.ci95
        print(f"{k:>18} = {e.value:.6g} ± {e.std_error:.2g} {e.unit}  (95 % interval {lo:.6g} … {hi:.6g})")
    ratio = ", ".join(f"{d.residual_to_noise:.2f}" for d in fit.records)
    print(
        f"{fit.method}: {fit.n_windows} {'blocks' if kalman else 'windows'} of {fit.window_s:.4g} s, residual rms "
        f"{fit.residual_rms_deg:.4f}° (residual / sensor noise per record: {ratio}), condition number "
        f"{fit.condition_number:.3g}, {time.time() - t0:.0f} s"
    )
    for w in fit.warnings:
        print(f"jaxroll calibrate: warning: {w}", file=sys.stderr)
    result = fit.to_dict()
    payload = {
        "config": {
            **_base_config(args, ship, records),
            "estimator": args.estimator,
            "params": list(params),
            "window_model_s": None if span is None else list(span),
            "shooting_window_s": None if kalman else checked.window,
            "shooting_window_rule": None
            if kalman
            else (
                "given"
                if args.shooting_window is not None
                else f"four natural roll periods ({default_window(ship):.4g} s)"
            ),
            "fit": result.pop("config"),
        },
        **result,
        "written": {"ship": ship_to_dict(fitted)},
        "run_time_s": time.time() - t0,
    }
    figures = {
        "roll_fit.png": plot_time_domain_fit(fit),
        "residual_spectrum.png": plot_residual_spectrum(fit).figure,
    }
    return _finish(args, "roll", ship, fitted, payload, figures, fit.to_xarray())
