"""Benchmark: the cost of the GZ(φ, ζ_mid) surface in the Monte Carlo (issue 44, item 3).

The paper's Monte Carlo (`monte_carlo_amplitudes`, shaping filter, float32, dt 0.5 s, the same trials and duration)
of the C11-like hull's ship (`c11_hull_ship`) in ITTC H1/3 `--hs` m, T01 10 s, head seas: with the polynomial model
(GZ_calm + ΔGM·φ) and with the surface fitted to the hull's table (`fit_restoring_surface`, 5 × 6 terms beyond the
polynomial; its range checked at every step). Compile time (first call) apart; run time the best of `--repeat`
calls, alternated. Prints `name=value` lines, the ratio last, and the two runs' mean envelope amplitude and capsizes.

Run: `python benchmarks/gz_surface.py [--trials 10000] [--duration 3600] [--repeat 3] [--hs 7]`.
"""

from __future__ import annotations

import argparse
import math
import time

import equinox as eqx
import jax.random as jr

import jaxroll
from jaxroll import ITTC, RollProblem, monte_carlo_amplitudes
from jaxroll.ship import (
    c11_hull,
    c11_hull_loading,
    fit_restoring_surface,
    hull_hydrostatics,
    ship_from_hydrostatics,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=10_000)
    ap.add_argument("--duration", type=float, default=3600.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--hs", type=float, default=7.0)
    args = ap.parse_args()
    jaxroll.configure()
    hull = c11_hull()
    sol = hull_hydrostatics(hull, c11_hull_loading())
    plain = ship_from_hydrostatics(sol, hull, roll_period=24.4)
    surface = fit_restoring_surface(sol, plain)
    carrying = eqx.tree_at(lambda s: s.restoring_surface, plain, surface, is_leaf=lambda x: x is None)
    sea = ITTC(args.hs, 10.0)
    problems = {
        "polynomial": RollProblem.from_sea(plain, sea),
        "surface": RollProblem.from_sea(carrying, sea),
    }

    def run(problem):
        t = time.perf_counter()
        stats = monte_carlo_amplitudes(
            problem, jr.key(0), num_realizations=args.trials, duration=args.duration, discard=500.0
        )
        return time.perf_counter() - t, stats

    best, stats = {}, {}
    for name, problem in problems.items():
        first, stats[name] = run(problem)
        print(f"{name}_first_call_s={first:.2f}")
        best[name] = math.inf
    for _ in range(args.repeat):
        for name, problem in problems.items():
            best[name] = min(best[name], run(problem)[0])
    for name in problems:
        s = stats[name]
        print(
            f"{name}_run_s={best[name]:.3f} {name}_mean_envelope_deg={math.degrees(s.mean('envelope')):.4f} "
            f"{name}_capsized={s.n_capsized} {name}_left_surface={s.config.get('n_left_gz_surface_range', 0)}"
        )
    print(f"surface_over_polynomial={best['surface'] / best['polynomial']:.3f}")


if __name__ == "__main__":
    main()
