"""Monte Carlo design sensitivities on the paper's protocol: the windowed pathwise estimator against central finite
differences with common random numbers (docs/sensitivity.md, "Bias and variance, measured").

Default ship, ITTC H1/3 = 7 m, T01 = 10 s, 10⁴ realizations × 3600 s from φ0 = 5° (`--quick`: 10³ × 1200 s).
Prints per (statistic, parameter) both estimates with their standard errors, the relative difference and its size
in combined standard errors, and the times. ~10 min on a 2-core CPU for the full protocol.

Usage: python benchmarks/sensitivity.py [--quick] [--wrt gm_correction,b1,hs] [--seed 20251]
"""

from __future__ import annotations

import argparse
import math
import time

import jax

import jaxroll as jxr

STATS = ("E_phi2", "mean_envelope", "mean_zero_crossing")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--wrt", default="gm_correction,b1,hs")
    parser.add_argument("--seed", type=int, default=20251)
    args = parser.parse_args()
    n, duration = (1000, 1200.0) if args.quick else (10_000, 3600.0)
    wrt = tuple(args.wrt.split(","))
    problem_fn, params = jxr.sensitivity_problem(jxr.c11_representative(), hs=7.0, t01=10.0)
    kw = dict(wrt=wrt, statistics=STATS, num_realizations=n, duration=duration, chunk_size=500)
    key = jax.random.key(args.seed)
    t0 = time.perf_counter()
    windowed = jxr.monte_carlo_sensitivity(problem_fn, params, key, **kw)
    t1 = time.perf_counter()
    fd = jxr.monte_carlo_sensitivity(problem_fn, params, key, method="finite_difference", fd_step=0.02, **kw)
    t2 = time.perf_counter()
    print(
        f"protocol: {n} x {duration:g} s, seed {args.seed}; windowed {t1 - t0:.0f} s, finite differences "
        f"{t2 - t1:.0f} s; memory ratio rho = {windowed.config['memory_ratio']:.3f}"
    )
    print("statistic parameter windowed (SE) finite-difference (SE) rel_diff z")
    worst = 0.0
    for s in STATS:
        for p in wrt:
            g, e = windowed.gradient[s][p], windowed.std_error[s][p]
            h, f = fd.gradient[s][p], fd.std_error[s][p]
            z = (g - h) / math.hypot(e, f)
            worst = max(worst, abs(z))
            print(
                f"{s} {p} {g:.5g} ({e:.2g}, {abs(e / h):.1%}) {h:.5g} ({f:.2g}, {abs(f / h):.1%}) "
                f"{g / h - 1:+.1%} {z:+.2f}"
            )
    print(f"largest_z={worst:.2f}")


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
