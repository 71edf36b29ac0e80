"""Rare exceedances: multilevel splitting (`jaxroll.monte_carlo_splitting`) against brute force, side by side.

The cell: default ship ("C11 (representative)"), ITTC H1/3 = 4.5 m, T01 = 10 s, head seas, zero speed, dt 0.5 s,
discard 500 s, exposure 1 h, angle 40° — P ≈ 1e-4 per hour (a 2·10⁷-trial brute-force reference on a GPU,
benchmarks/README.md). Three modes, each printing `name=value` lines:

- default: brute force (`monte_carlo_max_roll`, `--bf-trials` trials) and `--repeat` splitting runs (`--trials`
  runs a stage, levels by each run's own pilot) in the same process, after compiling both; the estimates, their
  95 % intervals, wall times and simulated realization-seconds, and the speed-up at equal CI width: work ratio =
  brute-force cost × (its CI width / one splitting run's)² / the splitting run's mean cost, in wall time and in
  realization-seconds — the brute force's width from its binomial variance (1 − P)/(P N) at P = the splitting's
  mean, the brute force's own estimate or `--reference-p`, the splitting's from its mean estimated relative
  variance or `--empirical-relvar` (measured over independent runs by `--coverage`). The splitting's cost
  includes its pilot.
- `--reference`: brute force only, `--bf-trials` trials, P(max |φ| > a) for a = 20…50° from the per-trial largest
  roll (a GPU job: 2·10⁷ × 4100 s in seconds there).
- `--coverage R [--reference-p P]`: R independent splitting runs (seeds S … S + R − 1, `--first-seed S`, default
  1000, each with its own pilot): their mean against P (without P — a probability no brute force here reaches — each run's interval
  against the mean of the other R − 1 runs, independent of it), the empirical relative variance against the mean of the estimated one, the coverage of the 95 %
  intervals with its binomial standard error, the mean cost, and the work-normalised speed-up
  (1 − P)/P × (brute-force cost per trial) / (empirical relative variance × mean cost).

Usage: python benchmarks/splitting.py [--trials 1000] [--bf-trials 400000] [--repeat 5] [--reference-p 9.79e-5]
       [--empirical-relvar 0.080] [--hs 4.5] [--angle 40] [--hours 1]
       python benchmarks/splitting.py --reference --bf-trials 20000000 [--hs 4.5]
       python benchmarks/splitting.py --coverage 100 --reference-p 1.1e-4 [--trials 1000]
       [--wave-weight 6] [--json OUT] [--quick]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import jax
import numpy as np

import jaxroll


def wilson(k: int, n: int) -> tuple[float, float]:
    lo, hi = jaxroll.wilson_interval(k, n)
    return float(lo), float(hi)


def brute_force(problem, args, key):
    t0 = time.perf_counter()
    stats = jaxroll.monte_carlo_max_roll(
        problem,
        key,
        angle_deg=args.angle,
        num_realizations=args.bf_trials,
        duration=args.discard + args.hours * 3600,
        discard=args.discard,
    )
    return stats, time.perf_counter() - t0


def splitting(problem, args, seed):
    return jaxroll.monte_carlo_splitting(
        problem,
        jax.random.key(seed),
        angle_deg=args.angle,
        exposure=args.hours * 3600,
        discard=args.discard,
        num_trials=args.trials,
        wave_weight=args.wave_weight,
    )


def side_by_side(problem, args, out):
    trial_s = args.discard + args.hours * 3600
    # Compile both first (a small brute-force run, a whole splitting run of the same size), so that the timed runs
    # below are the programs' run time.
    t0 = time.perf_counter()
    jaxroll.monte_carlo_max_roll(
        problem,
        jax.random.key(99),
        angle_deg=args.angle,
        num_realizations=1000,
        duration=trial_s,
        discard=args.discard,
    )
    splitting(problem, args, 99)
    print(f"compile_and_warmup_s={time.perf_counter() - t0:.1f}", flush=True)
    bf, bf_wall = brute_force(problem, args, jax.random.key(1))
    p_bf = bf.exceedance_probability()
    lo, hi = bf.exceedance_interval()
    bf_sim = args.bf_trials * trial_s
    print(
        f"brute_force_trials={args.bf_trials} brute_force_P={p_bf:.4g} brute_force_ci95=[{lo:.3g}, {hi:.3g}] "
        f"brute_force_exceedances={bf.n_exceeded} brute_force_capsized={bf.n_capsized} "
        f"brute_force_wall_s={bf_wall:.2f} brute_force_realization_s={bf_sim:.4g}",
        flush=True,
    )
    runs = []
    for seed in range(args.repeat):
        sp = splitting(problem, args, 2 + seed)
        runs.append(sp)
        print(
            f"splitting_seed={2 + seed} splitting_trials={args.trials} splitting_P={sp.probability:.4g} "
            f"splitting_se={sp.standard_error:.3g} "
            f"splitting_ci95=[{sp.probability_ci95[0]:.3g}, {sp.probability_ci95[1]:.3g}] "
            f"levels_deg={np.round(sp.levels_deg, 2).tolist()} "
            f"conditional={np.round(sp.conditional_probabilities, 3).tolist()} ancestors={sp.n_ancestors} "
            f"splitting_wall_s={sp.wall_time_s:.2f} (pilot {sp.pilot_wall_time_s:.2f}) "
            f"splitting_realization_s={sp.total_simulated_seconds:.4g} (pilot {sp.pilot_simulated_seconds:.3g}; "
            f"lanes ran {sp.lane_seconds:.4g})",
            flush=True,
        )
        print(
            "  stage_realization_s="
            + ",".join(f"{x:.3g}" for x in sp.stage_simulated_seconds)
            + " stage_wall_s="
            + ",".join(f"{x:.2f}" for x in sp.stage_wall_time_s)
        )
    p_sp = float(np.mean([r.probability for r in runs]))
    relvar = float(np.mean([r.relative_error**2 for r in runs if r.probability > 0]))
    wall = float(np.mean([r.wall_time_s for r in runs]))
    cost = float(np.mean([r.total_simulated_seconds for r in runs]))
    se_bf = math.sqrt(p_bf * (1 - p_bf) / args.bf_trials)
    se_sp = p_sp * math.sqrt(relvar / len(runs))
    print(
        f"splitting_mean_P={p_sp:.4g} (of {len(runs)} runs) mean_estimated_relvar={relvar:.3g} "
        f"mean_wall_s={wall:.2f} mean_realization_s={cost:.4g}"
    )
    print(f"difference_in_combined_se={(p_sp - p_bf) / math.hypot(se_bf, se_sp):.2f}")
    result = {
        "brute_force": {
            "trials": args.bf_trials,
            "probability": p_bf,
            "ci95": [lo, hi],
            "wall_s": bf_wall,
            "realization_s": bf_sim,
        },
        "splitting": [r.to_dict() for r in runs],
    }
    # Work at equal CI width: the brute force's relative variance per trial (1 − P)/P against one splitting run's
    # (its mean estimated relative variance, or `--empirical-relvar` measured over independent runs).
    relvars = {"estimated": relvar}
    if math.isfinite(args.empirical_relvar):
        relvars["empirical"] = args.empirical_relvar
    for label, p in (("splitting_P", p_sp), ("brute_force_P", p_bf), ("reference_P", args.reference_p)):
        if not (p > 0 and math.isfinite(p)):
            continue
        for kind, rv in relvars.items():
            ratio = (1 - p) / p / args.bf_trials / rv  # (CI width of the brute force / of one splitting run)²
            w = bf_wall * ratio / wall
            sim = bf_sim * ratio / cost
            print(f"speedup_at_{label}_{kind}_relvar: wall={w:.1f} realization_s={sim:.1f}")
            result[f"speedup_at_{label}_{kind}_relvar"] = {"wall": w, "realization_s": sim}
    return result


def reference(problem, args, out):
    bf, wall = brute_force(problem, args, jax.random.key(2026))
    x = np.where(bf.capsized, np.inf, bf.max_abs_phi_deg)
    table = {}
    for a in range(20, 51):
        k = int(np.sum(x > a))
        table[a] = {"exceedances": k, "probability": k / args.bf_trials, "ci95": wilson(k, args.bf_trials)}
        print(
            f"angle={a} P={k / args.bf_trials:.4g} exceedances={k} ci95=[{table[a]['ci95'][0]:.3g}, "
            f"{table[a]['ci95'][1]:.3g}]"
        )
    print(
        f"reference_trials={args.bf_trials} capsized={bf.n_capsized} wall_s={wall:.1f} "
        f"realization_steps_per_s={args.bf_trials * (args.discard + args.hours * 3600) / problem.dt / wall:.3g}"
    )
    return {
        "trials": args.bf_trials,
        "hs": args.hs,
        "hours": args.hours,
        "discard": args.discard,
        "table": table,
        "capsized": bf.n_capsized,
        "wall_s": wall,
    }


def coverage(problem, args, out):
    trial_s = args.discard + args.hours * 3600
    runs = []
    t0 = time.perf_counter()
    for seed in range(args.coverage):
        r = splitting(problem, args, args.first_seed + seed)
        runs.append(r)
        if seed % 10 == 9:
            print(f"done={seed + 1} elapsed_s={time.perf_counter() - t0:.0f}", flush=True)
    est = np.array([r.probability for r in runs])
    n = est.size
    if math.isfinite(args.reference_p):
        p_refs = np.full(n, args.reference_p)
    else:  # no brute force can reach P: each run against the mean of the others (independent of it)
        p_refs = (est.sum() - est) / (n - 1)
    p_ref = float(np.mean(p_refs))
    relvar_hat = np.array([r.relative_error**2 if r.probability > 0 else np.nan for r in runs])
    covered = np.array([r.probability_ci95[0] <= q <= r.probability_ci95[1] for r, q in zip(runs, p_refs)])
    sym = np.array([abs(r.probability - q) <= 1.96 * r.standard_error for r, q in zip(runs, p_refs)])
    cost = np.array([r.total_simulated_seconds for r in runs])
    wall = np.array([r.wall_time_s for r in runs])
    mean, sd = est.mean(), est.std(ddof=1)
    relvar_emp = (sd / p_ref) ** 2
    cov, cov_se = covered.mean(), math.sqrt(covered.mean() * (1 - covered.mean()) / n)
    bf_relvar_per_trial = (1 - p_ref) / p_ref
    speedup = bf_relvar_per_trial * trial_s / (relvar_emp * cost.mean())
    print(
        f"runs={n} trials={args.trials} wave_weight={args.wave_weight} reference_P={p_ref:.4g} "
        f"mean_P={mean:.4g} (mean/reference − 1 = {mean / p_ref - 1:+.3f} ± {sd / math.sqrt(n) / p_ref:.3f}) "
        f"empirical_relvar={relvar_emp:.3g} mean_estimated_relvar={np.nanmean(relvar_hat):.3g} "
        f"median_estimated_relvar={np.nanmedian(relvar_hat):.3g} zeros={int(np.sum(est == 0))}"
    )
    print(
        f"coverage_lognormal={cov:.3f} ± {cov_se:.3f} coverage_symmetric={sym.mean():.3f} "
        f"mean_realization_s={cost.mean():.4g} mean_wall_s={wall.mean():.2f} "
        f"mean_levels={np.mean([r.levels_deg.size for r in runs]):.2f} "
        f"mean_ancestors={np.mean([r.n_ancestors for r in runs]):.1f}"
    )
    print(f"speedup_realization_s_at_equal_variance={speedup:.1f}")
    return {
        "runs": n,
        "trials": args.trials,
        "wave_weight": args.wave_weight,
        "reference_p": p_ref,
        "reference": "brute force (--reference-p)"
        if math.isfinite(args.reference_p)
        else "leave-one-out mean",
        "estimates": est.tolist(),
        "estimated_relvar": relvar_hat.tolist(),
        "covered": covered.tolist(),
        "covered_symmetric": sym.tolist(),
        "realization_s": cost.tolist(),
        "wall_s": wall.tolist(),
        "coverage": cov,
        "coverage_se": cov_se,
        "empirical_relvar": relvar_emp,
        "speedup_realization_s": speedup,
        "per_run": {  # what an interval rule needs, run by run
            "relative_error": [r.relative_error for r in runs],
            "effective_ancestors": [r.effective_ancestors for r in runs],
            "n_ancestors": [r.n_ancestors for r in runs],
            "stages": [int(r.levels_deg.size) for r in runs],
            "ci95": [list(r.probability_ci95) for r in runs],
        },
    }


def main() -> None:
    jaxroll.configure()
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--hs", type=float, default=4.5)
    p.add_argument("--t01", type=float, default=10.0)
    p.add_argument("--angle", type=float, default=40.0)
    p.add_argument("--hours", type=float, default=1.0)
    p.add_argument("--discard", type=float, default=500.0)
    p.add_argument("--trials", type=int, default=1000, help="splitting runs a stage")
    p.add_argument("--bf-trials", type=int, default=400_000, help="brute-force trials")
    p.add_argument("--wave-weight", type=float, default=jaxroll.roll.DEFAULT_WAVE_WEIGHT)
    p.add_argument("--reference", action="store_true")
    p.add_argument("--coverage", type=int, default=0)
    p.add_argument("--first-seed", type=int, default=1000, help="--coverage: the first run's seed")
    p.add_argument("--reference-p", type=float, default=math.nan)
    p.add_argument("--repeat", type=int, default=5, help="splitting runs in the side-by-side mode")
    p.add_argument(
        "--empirical-relvar",
        type=float,
        default=math.nan,
        help="a splitting run's relative variance measured over independent runs (--coverage)",
    )
    p.add_argument("--json", default="")
    p.add_argument("--quick", action="store_true", help="a smoke run (small counts)")
    args = p.parse_args()
    if args.quick:
        args.trials, args.bf_trials, args.hours = min(args.trials, 200), min(args.bf_trials, 2000), 0.25
        args.coverage, args.repeat = min(args.coverage, 3), min(args.repeat, 2)
    dev = jax.devices()[0]
    print(
        f"device={dev.device_kind} platform={dev.platform} devices={jax.device_count()} jax={jax.__version__} "
        f"load={os.getloadavg()[0]:.1f} hs={args.hs} t01={args.t01} angle={args.angle} hours={args.hours} "
        f"discard={args.discard}",
        flush=True,
    )
    problem = jaxroll.RollProblem.from_sea(
        jaxroll.c11_representative(), jaxroll.ITTC(args.hs, args.t01), dt=0.5
    )
    if args.reference:
        result = reference(problem, args, None)
    elif args.coverage:
        result = coverage(problem, args, None)
    else:
        result = side_by_side(problem, args, None)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"config": vars(args), "result": result}, f, indent=1, default=float)


if __name__ == "__main__":
    main()
