"""Time of each theoretical amplitude PDF (after compilation) next to the Monte Carlo of the same case.

Default ship, ITTC H1/3 = 7 m, T01 = 10 s. Targets on a 2-core CPU: < 1 s for Roberts and ESAM, < 5 s for the
moment method. The Monte Carlo line is the paper's 10⁴ × 3600 s protocol (`--quick`: 10³ × 1800 s).

Usage: python benchmarks/theory.py [--quick]
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

import jaxroll
from jaxroll import theory


def timed(fn, repeat: int = 3):
    t0 = time.perf_counter()
    out = jax.block_until_ready(fn())
    first = time.perf_counter() - t0
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        runs.append(time.perf_counter() - t0)
    return out, first, min(runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    wave = jaxroll.EffectiveWave(sea, ship.lpp)
    print(f"device={jax.devices()[0].device_kind}, case: default ship, H1/3 = 7 m, T01 = 10 s")
    cases = {
        "roberts": lambda: theory.roberts_pdf(ship, wave, restoring="nonlinear").log_density,
        "esam": lambda: theory.esam_pdf(ship, wave).log_density,
        "moment": lambda: theory.moment_pdf(ship, wave, closure_order=6).e_phi2,
    }
    for name, fn in cases.items():
        _, first, run = timed(fn, repeat=1 if name == "moment" else 3)
        print(f"{name}_first_call_s={first:.2f} {name}_run_s={run:.3f}")
    n, duration = (1000, 1800.0) if args.quick else (10_000, 3600.0)
    problem = jaxroll.RollProblem.from_sea(ship, sea, dt=0.5)
    jaxroll.monte_carlo_amplitudes(problem, jax.random.key(0), num_realizations=min(n, 1000), duration=duration)
    t0 = time.perf_counter()
    stats = jaxroll.monte_carlo_amplitudes(problem, jax.random.key(0), num_realizations=n, duration=duration)
    mc = time.perf_counter() - t0
    print(f"monte_carlo_run_s={mc:.2f} ({n} x {duration:g} s), mean envelope amplitude "
          f"{np.rad2deg(stats.mean('envelope')):.2f} deg, E[phi^2] {stats.phi_moments()['E_phi2']:.4f} rad^2")


if __name__ == "__main__":
    main()
