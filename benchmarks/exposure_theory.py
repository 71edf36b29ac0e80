"""Exposure risk by theory against the direct Monte Carlo (issue 34 item 2): P(max |φ| > angle within T).

Default ship, ITTC T01 = 10 s, head seas, U = 0; H1/3 5–8 m, angles 25°/30°/40°, T = 1 h and 3 h. Methods:
- first passage (`jaxroll.theory.passage_risk`): the envelope FPK model followed through the exposure, the roll seen
  at its peaks (the default);
- the same with the envelope watched continuously (`observe="continuous"`): every excursion counts, also those
  between two peaks;
- the same model's zero-crossing amplitudes taken as independent (what `jaxroll risk --theory envelope_fpk` gave:
  `independent_probability`).
The Monte Carlo reference (40 000 trials of 1000 s + T per (H1/3, T)) is read from
benchmarks/data/exposure_mc_reference.json (`python benchmarks/exposure_mc_reference.py` remakes it). Target:
theory / MC within [1/1.25, 1.25] wherever the MC value lies in [1e-3, 0.95].

Usage: python benchmarks/exposure_theory.py [--grid default|coarse] [--skip-continuous]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

REFERENCE = Path(__file__).parent / "data" / "exposure_mc_reference.json"
GRIDS = {
    "default": {},
    "coarse": dict(num_rho=8, num_theta=12),
    "coarse-40": dict(num_rho=8, num_theta=12, num_s=40),
    "single": dict(extrapolate=False),
    "single-fine": dict(extrapolate=False, num_s=120),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", choices=sorted(GRIDS), default="default")
    parser.add_argument("--skip-continuous", action="store_true")
    args = parser.parse_args()
    import jax

    import jaxroll
    from jaxroll import theory

    if hasattr(jaxroll, "configure"):
        jaxroll.configure()
    ref = json.loads(REFERENCE.read_text())
    ship = jaxroll.c11_representative()
    angles = np.deg2rad([25.0, 30.0, 40.0])
    durations = np.array([3600.0, 10800.0])
    risks, times = {}, []
    for observe in ("peaks",) + (() if args.skip_continuous else ("continuous",)):
        for hs in (5.0, 6.0, 7.0, 8.0):
            wave = jaxroll.EffectiveWave(jaxroll.ITTC(hs, 10.0), ship.lpp)
            t0 = time.perf_counter()
            r = theory.passage_risk(ship, wave, angles, durations, observe=observe, **GRIDS[args.grid])
            jax.block_until_ready(r.probability)
            times.append((observe, hs, time.perf_counter() - t0))
            risks[observe, hs] = r
    print(f"grid: {args.grid} {GRIDS[args.grid] or '(12 rho x 20 theta x 70 ln A cells)'}")
    print(
        "| H1/3 | T | angle | Monte Carlo (95 % CI) | first passage (ratio) | continuous (ratio) | independent (ratio) |"
    )
    print("|---|---|---|---|---|---|---|")
    worst = 1.0
    for case in ref["cases"]:
        j = list(durations).index(3600.0 * case["hours"])
        for i, a in enumerate(case["angles_deg"]):
            p_mc, (lo, hi) = case["probability"][i], case["probability_ci95"][i]
            cells = []
            for observe, field in (
                ("peaks", "probability"),
                ("continuous", "probability"),
                ("peaks", "independent_probability"),
            ):
                if (observe, case["hs"]) not in risks:
                    cells.append("—")
                    continue
                p = float(getattr(risks[observe, case["hs"]], field)[i, j])
                cells.append(f"{p:.4g} (×{p / p_mc:.2f})" if p_mc > 0 else f"{p:.4g}")
            target = 1e-3 <= p_mc <= 0.95
            if target:
                ratio = float(risks["peaks", case["hs"]].probability[i, j]) / p_mc
                worst = max(worst, ratio, 1 / ratio)
            mark = "" if target else " †"
            print(
                f"| {case['hs']:g} m | {case['hours']:g} h | {a:g}° | {p_mc:.4g} ({lo:.4g}–{hi:.4g}){mark} | "
                + " | ".join(cells)
                + " |"
            )
    print("\n| H1/3 | T | Monte Carlo P(capsize) (95 % CI) | first passage P(capsize) (ratio) |")
    print("|---|---|---|---|")
    for case in ref["cases"]:
        j = list(durations).index(3600.0 * case["hours"])
        k, n = case["n_capsized"], case["n_realizations"]
        p = float(risks["peaks", case["hs"]].capsize_probability[j])
        from jaxroll import wilson_interval

        lo, hi = (float(x) for x in wilson_interval(k, n))
        ratio = f" (×{p / (k / n):.2f})" if k else ""
        print(
            f"| {case['hs']:g} m | {case['hours']:g} h | {k / n:.3g} ({lo:.2g}–{hi:.2g}) | {p:.3g}{ratio} |"
        )
    print(
        f"\nworst first-passage ratio where 1e-3 <= P_MC <= 0.95: ×{worst:.3f} (target 1.25); † outside the target range"
    )
    for observe, hs, t in times:
        print(f"time {observe:10s} H1/3 {hs:g} m: {t:.2f} s{' (with compilation)' if hs == 5.0 else ''}")


if __name__ == "__main__":
    main()
