"""Benchmark: the cost of the direct wave moment in the Monte Carlo (issue 44, target ≤ 1.3×).

The superposition Monte Carlo (`monte_carlo_amplitudes`, float32, the same trials and duration) of the C11-like
hull's ship (ITTC H1/3 4 m, T01 10 s, U 5 m/s, dt 0.25 s) at each heading of `--headings` [deg]: without a wave
moment (Method 1, the paper's parametric-only model) and with the ship's Froude–Krylov moment (the joint synthesis
of ζ_G and M_w, `RollProblem.from_sea`'s default for such a ship). Compile time (first call) apart; run time the
best of `--repeat` calls, alternated. Prints `name=value` lines, per heading the ratio last.

Following-type headings (χ < 90° at speed) have up to three wave frequencies per encounter frequency: the joint
synthesis draws each one's amplitude (three times the components of Method 1's aggregated spectrum).

Run: `python benchmarks/wave_moment.py [--trials 2000] [--duration 1800] [--repeat 3] [--headings 90,120,60]`.
"""

from __future__ import annotations

import argparse
import math
import time

import equinox as eqx
import jax.random as jr

import jaxroll
from jaxroll import ITTC, RollProblem, monte_carlo_amplitudes
from jaxroll.ship import c11_hull, c11_hull_loading, c11_hull_ship, wave_moment


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=2000)
    ap.add_argument("--duration", type=float, default=1800.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--headings", default="90,120,60", help="headings χ [deg], comma-separated")
    args = ap.parse_args()
    for heading in (float(h) for h in args.headings.split(",")):
        compare(args, heading)


def compare(args, heading_deg: float) -> None:
    jaxroll.configure()
    plain = c11_hull_ship()
    table = wave_moment(c11_hull(), c11_hull_loading(), plain)
    carrying = eqx.tree_at(lambda s: s.wave_moment, plain, table, is_leaf=lambda x: x is None)
    sea, options = ITTC(4.0, 10.0), dict(speed=5.0, heading=math.radians(heading_deg), dt=0.25)
    problems = {
        "without": RollProblem.from_sea(plain, sea, excitation="superposition", **options),
        "with": RollProblem.from_sea(carrying, sea, **options),
    }
    assert problems["with"].moment_excitation is not None and problems["without"].moment_excitation is None

    def run(problem):
        t = time.perf_counter()
        stats = monte_carlo_amplitudes(
            problem, jr.key(0), num_realizations=args.trials, duration=args.duration, discard=300.0
        )
        return time.perf_counter() - t, stats

    best = {}
    for name, problem in problems.items():
        first, stats = run(problem)
        print(f"heading_deg={heading_deg:g} {name}_first_call_s={first:.3f}")
        print(f"{name}_mean_envelope_deg={math.degrees(stats.mean('envelope')):.4g}")
        best[name] = math.inf
    for _ in range(args.repeat):
        for name, problem in problems.items():
            best[name] = min(best[name], run(problem)[0])
    for name in problems:
        print(f"heading_deg={heading_deg:g} {name}_run_s={best[name]:.3f}")
    print(
        f"trials={args.trials} duration_s={args.duration:g} realization_steps={args.trials * args.duration / 0.25:.3g}"
    )
    print(f"heading_deg={heading_deg:g} cost_ratio_with_moment={best['with'] / best['without']:.3f}")


if __name__ == "__main__":
    main()
