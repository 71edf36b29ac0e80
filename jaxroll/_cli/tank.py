"""`jaxroll tank`: a virtual towing tank that writes synthetic records (decay, captive, free-running roll)
with
known truth, at model scale, following the paper's protocols (format: docs/records.md)."""

from __future__ import annotations

import gzip
import math
import time
from pathlib import Path

from ._common import CLIError, OutputFolder, atomic_write_bytes, atomic_write_text, load_ship_arg, write_json

TESTS = ("decay", "captive", "roll")


def _sea(text: str) -> tuple[float, float]:
    try:
        hs, t01 = (float(v) for v in text.split(","))
    except ValueError:
        raise CLIError(
            f"a sea state is 'H1/3,T01' in metres and seconds (full scale); got {text!r}."
        ) from None
    if not (math.isfinite(hs) and math.isfinite(t01) and hs > 0 and t01 > 0):
        raise CLIError(f"sea state {text!r}: H1/3 and T01 must be > 0.")
    return hs, t01


def register(sub) -> None:
    p = sub.add_parser(
        "tank",
        help="virtual tank: synthetic decay, captive and free-running records with known truth",
        description="Writes model-scale tank records (CSV, docs/records.md) from a ship and seas with known "
        "truth, with sensor noise, following the paper's protocols: free decay from 20°; captive tests at "
        "heel 0/5/10/15°, 10 realizations of (5, 10), (5, 12.37), (7, 10); free-running roll, 24 "
        "realizations of (5, 10) and (7, 10), 360 s model (analysed 70–340 s). The truth goes to "
        "truth.json and truth_ship.toml.",
    )
    p.add_argument(
        "--ship", metavar="FILE", default=None, help="ship file (TOML); default C11 (representative)"
    )
    p.add_argument("--out", default="jaxroll-out/tank", help="output folder (default ./jaxroll-out/tank)")
    p.add_argument("--tests", default="decay,captive,roll", help="comma-separated: decay,captive,roll (all)")
    p.add_argument("--scale", type=float, default=100.0, help="model scale λ (default 100)")
    p.add_argument(
        "--sampling-hz", type=float, default=20.0, help="sampling rate [Hz, model scale] (default 20)"
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--gzip", action="store_true", help="write .csv.gz (the loaders read both)")
    p.add_argument(
        "--compact",
        action="store_true",
        help="fewer digits (roll 0.001°, wave 0.01 mm, ΔGM 0.001 mm): smaller files, for examples",
    )
    t = p.add_argument_group("truth (overrides the ship's values)")
    t.add_argument(
        "--gm-ratio", type=float, default=None, help="σ_obs/σ_thr of the virtual model (ship's value)"
    )
    t.add_argument(
        "--damping",
        type=float,
        nargs=3,
        metavar=("B1", "B2", "B3"),
        default=None,
        help="b1 [1/s], b2 [1/rad], b3 [s/rad²] at full scale (ship's values)",
    )
    d = p.add_argument_group("free decay")
    d.add_argument("--decay-from-deg", type=float, default=20.0, help="release angle [deg] (default 20)")
    d.add_argument("--decay-duration", type=float, default=60.0, help="record length [s, model scale] (60)")
    d.add_argument("--decay-realizations", type=int, default=1, help="number of decay records (1)")
    c = p.add_argument_group("captive tests")
    c.add_argument(
        "--captive-seas",
        nargs="+",
        default=["5,10", "5,12.37", "7,10"],
        metavar="H,T",
        help="sea states H1/3,T01 [m, s full scale] (default 5,10 5,12.37 7,10)",
    )
    c.add_argument("--captive-heels", default="0,5,10,15", help="fixed heels [deg] (default 0,5,10,15)")
    c.add_argument("--captive-realizations", type=int, default=10, help="realizations per sea and heel (10)")
    c.add_argument(
        "--probe-x",
        type=float,
        default=2.0,
        help="wave probe position relative to amidships, + forward [m, model scale] (default 2.0)",
    )
    r = p.add_argument_group("free-running roll")
    r.add_argument(
        "--roll-seas",
        nargs="+",
        default=["5,10", "7,10"],
        metavar="H,T",
        help="sea states H1/3,T01 [m, s full scale] (default 5,10 7,10)",
    )
    r.add_argument("--roll-realizations", type=int, default=24, help="realizations per sea state (24)")
    r.add_argument("--duration", type=float, default=360.0, help="record length [s, model scale] (360)")
    r.add_argument(
        "--phi0-deg", type=float, default=5.0, help="initial roll [deg] (5, the paper's MCS start)"
    )
    n = p.add_argument_group("sensor noise (Gaussian, white)")
    n.add_argument("--roll-noise-deg", type=float, default=0.05, help="roll sensor std [deg] (0.05)")
    n.add_argument("--wave-noise-mm", type=float, default=0.3, help="wave probe std [mm, model scale] (0.3)")
    n.add_argument("--gm-noise-mm", type=float, default=0.2, help="ΔGM std [mm, model scale] (0.2)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=run)


_COMPACT = {"time": 3, "roll": 3, "wave": 2, "delta_gm": 3}


def _write(record, path: Path, compress: bool, compact: bool = False) -> Path:
    from ..io import record_to_text

    text = record_to_text(record, decimals=_COMPACT if compact else None)
    if compress:
        path = path.with_name(path.name + ".gz")
        atomic_write_bytes(path, gzip.compress(text.encode(), mtime=0))
    else:
        atomic_write_text(path, text)
    return path


def run(args) -> int:
    import equinox as eqx
    import jax.numpy as jnp

    from .. import ITTC, ship_to_dict, ship_to_toml
    from ..calibration import virtual_captive_record, virtual_decay_record, virtual_roll_record
    from ..ship import validate_ship

    tests = [t.strip() for t in args.tests.split(",") if t.strip()]
    unknown = sorted(set(tests) - set(TESTS))
    if unknown or not tests:
        raise CLIError(f"--tests: unknown or empty {unknown or tests}; choose from {', '.join(TESTS)}.")
    for name in ("scale", "sampling_hz", "decay_from_deg", "decay_duration", "duration"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise CLIError(f"--{name.replace('_', '-')} must be > 0; got {v}.")
    for name in ("roll_noise_deg", "wave_noise_mm", "gm_noise_mm"):
        if not (math.isfinite(getattr(args, name)) and getattr(args, name) >= 0):
            raise CLIError(f"--{name.replace('_', '-')} must be >= 0.")
    if not math.isfinite(args.probe_x):
        raise CLIError(f"--probe-x must be a finite number [m]; got {args.probe_x}.")
    if not math.isfinite(args.phi0_deg):
        raise CLIError(f"--phi0-deg must be finite; got {args.phi0_deg}.")
    if args.gm_ratio is not None and not (math.isfinite(args.gm_ratio) and args.gm_ratio > 0):
        raise CLIError(f"--gm-ratio must be a finite number > 0; got {args.gm_ratio}.")
    if args.damping is not None and not all(math.isfinite(b) for b in args.damping):
        raise CLIError(f"--damping: B1 B2 B3 must be finite numbers; got {args.damping}.")
    for name in ("decay_realizations", "captive_realizations", "roll_realizations"):
        if getattr(args, name) < 1:
            raise CLIError(f"--{name.replace('_', '-')} must be >= 1.")
    try:
        heels = [float(h) for h in args.captive_heels.split(",")]
    except ValueError:
        raise CLIError(
            f"--captive-heels: comma-separated angles in degrees; got {args.captive_heels!r}."
        ) from None
    if not all(math.isfinite(h) and abs(h) < 90 for h in heels):
        raise CLIError(f"--captive-heels: angles must be finite and within ±90°; got {args.captive_heels!r}.")
    captive_seas = [_sea(s) for s in args.captive_seas]
    roll_seas = [_sea(s) for s in args.roll_seas]

    ship = load_ship_arg(args.ship)
    if args.gm_ratio is not None:
        ship = eqx.tree_at(lambda s: s.gm_correction, ship, jnp.asarray(float(args.gm_ratio)))
    if args.damping is not None:
        ship = eqx.tree_at(lambda s: s.damping, ship, jnp.asarray(args.damping, dtype=float))
    validate_ship(ship)
    final = Path(args.out)
    if final.exists() and not final.is_dir():
        raise CLIError(f"--out {str(final)!r} exists and is not a folder.")
    with OutputFolder(final) as out:
        lam, hz = args.scale, args.sampling_hz
        say = (lambda *a: None) if args.quiet else print
        if args.ship is None:
            say("Ship: C11 (representative) — representative coefficients (see `jaxroll ship show`).")
        files: dict[str, list[str]] = {t: [] for t in tests}
        capsized_attempts: dict[str, int] = {}
        t0 = time.time()
        if "decay" in tests:
            for k in range(args.decay_realizations):
                rec = virtual_decay_record(
                    ship,
                    initial_roll_deg=args.decay_from_deg,
                    duration_model_s=args.decay_duration,
                    scale=lam,
                    sampling_hz=hz,
                    roll_noise_deg=args.roll_noise_deg,
                    seed=args.seed * 1000 + k,
                    realization=k + 1,
                )
                path = _write(
                    rec,
                    out / "decay" / f"decay_{args.decay_from_deg:g}deg_r{k + 1:02d}.csv",
                    args.gzip,
                    args.compact,
                )
                files["decay"].append(str(final / path.relative_to(out)))
            say(f"decay: {args.decay_realizations} record(s) in {final / 'decay'}")
        if "captive" in tests:
            for i, (hs, t01) in enumerate(captive_seas):
                for heel in heels:
                    for k in range(args.captive_realizations):
                        seed = args.seed * 1_000_000 + 10_000 * i + 100 * int(round(heel)) + k
                        rec = virtual_captive_record(
                            ship,
                            ITTC(hs, t01),
                            heel_deg=heel,
                            seed=seed,
                            duration_model_s=args.duration,
                            scale=lam,
                            sampling_hz=hz,
                            probe_x_model_m=args.probe_x,
                            wave_noise_mm=args.wave_noise_mm,
                            gm_noise_mm=args.gm_noise_mm,
                            realization=k + 1,
                        )
                        name = f"captive_H{hs:g}_T{t01:g}_heel{heel:02g}_r{k + 1:02d}.csv"
                        files["captive"].append(
                            str(
                                final
                                / _write(rec, out / "captive" / name, args.gzip, args.compact).relative_to(
                                    out
                                )
                            )
                        )
                say(
                    f"captive: H1/3 {hs:g} m, T01 {t01:g} s: {len(heels)} heels × {args.captive_realizations}"
                )
        if "roll" in tests:
            for i, (hs, t01) in enumerate(roll_seas):
                lost = 0
                for k in range(args.roll_realizations):
                    seed = args.seed * 1_000_000 + 500_000 + 10_000 * i + k
                    rec, n_cap = virtual_roll_record(
                        ship,
                        ITTC(hs, t01),
                        seed=seed,
                        duration_model_s=args.duration,
                        scale=lam,
                        sampling_hz=hz,
                        initial_roll_deg=args.phi0_deg,
                        roll_noise_deg=args.roll_noise_deg,
                        wave_noise_mm=args.wave_noise_mm,
                        realization=k + 1,
                    )
                    lost += n_cap
                    name = f"roll_H{hs:g}_T{t01:g}_r{k + 1:02d}.csv"
                    files["roll"].append(
                        str(
                            final / _write(rec, out / "roll" / name, args.gzip, args.compact).relative_to(out)
                        )
                    )
                capsized_attempts[f"{hs:g},{t01:g}"] = lost
                say(
                    f"roll: H1/3 {hs:g} m, T01 {t01:g} s: {args.roll_realizations} records"
                    + (f" ({lost} capsized realization(s) discarded and redrawn)" if lost else "")
                )
        atomic_write_text(out / "truth_ship.toml", ship_to_toml(ship))
        b = [float(v) for v in ship.damping]
        write_json(
            out / "truth.json",
            {
                "truth": {
                    "damping": {"b1_1_s": b[0], "b2_1_rad": b[1], "b3_s_rad2": b[2]},
                    "gm_correction": float(ship.gm_correction),
                    "roll_period_s": float(ship.roll_period),
                    "ship": ship_to_dict(ship),
                },
                "config": {
                    "tests": tests,
                    "scale": lam,
                    "sampling_hz_model": hz,
                    "seed": args.seed,
                    "decay": {
                        "from_deg": args.decay_from_deg,
                        "duration_model_s": args.decay_duration,
                        "realizations": args.decay_realizations,
                    },
                    "captive": {
                        "seas": captive_seas,
                        "heels_deg": heels,
                        "realizations": args.captive_realizations,
                        "probe_x_model_m": args.probe_x,
                        "duration_model_s": args.duration,
                    },
                    "roll": {
                        "seas": roll_seas,
                        "realizations": args.roll_realizations,
                        "duration_model_s": args.duration,
                        "phi0_deg": args.phi0_deg,
                        "probe_x_model_m": 0.0,
                        "analysis_window_model_s": [70.0, 340.0],
                    },
                    "noise": {
                        "roll_deg": args.roll_noise_deg,
                        "wave_mm_model": args.wave_noise_mm,
                        "delta_gm_mm_model": args.gm_noise_mm,
                    },
                },
                "capsized_attempts_discarded": capsized_attempts,
                "model": "roll: the project's RK4 integrator (roll_time_series) driven by Grim's effective wave "
                "of the "
                "same realization as the wave column (superposition, exact dispersion); captive: ΔGM = "
                "gm_correction × Σ C_k ζ_mid^k, independent of heel; decay: P = 0",
                "files": files,
                "run_time_s": time.time() - t0,
            },
        )
        say(
            f"wrote {sum(len(v) for v in files.values())} records, {final / 'truth.json'}, "
            f"{final / 'truth_ship.toml'}"
        )
    return 0
