"""The comparison report of issue 3: the three theories against the Monte Carlo for the default ship.

Default ship, ITTC T01 = 10 s, H1/3 = 5 and 7 m, head seas, zero speed. Monte Carlo: Method-2 filter (order 4),
dt 0.5 s, φ(0) = 5°, 3600 s, the first 500 s left out; envelope (time-sampled) amplitudes, which is the law all
three theories predict. Prints a markdown table (mean, 99 % quantile, P(A > 20°), P(A > 30°)).

Usage: python benchmarks/comparison.py [--realizations N]
"""

from __future__ import annotations

import argparse

import jax
import numpy as np

import jaxroll
from jaxroll import theory


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--realizations", type=int, default=10_000)
    args = parser.parse_args()
    ship = jaxroll.c11_representative()
    print("| H1/3 | method | mean [deg] | 99 % [deg] | P(A > 20°) | P(A > 30°) |")
    print("|---|---|---|---|---|---|")
    for hs in (5.0, 7.0):
        sea = jaxroll.ITTC(hs, 10.0)
        problem = jaxroll.RollProblem.from_sea(ship, sea, dt=0.5)
        stats = jaxroll.monte_carlo_amplitudes(
            problem, jax.random.key(0), num_realizations=args.realizations, duration=3600.0, discard=500.0
        )
        c = stats.counts_envelope
        rows = [
            (
                "Monte Carlo (envelope)",
                float(np.rad2deg(stats.mean("envelope"))),
                float(np.rad2deg(stats.quantiles("envelope")[2])),
                c[400:].sum() / c.sum(),
                c[600:].sum() / c.sum(),
            )
        ]
        wave = problem.wave
        m = theory.moment_pdf_first_stable(ship, wave, shaping_filter=problem.filter_fit)
        for label, law in (
            ("Roberts (nonlinear restoring)", theory.roberts_pdf(ship, wave, restoring="nonlinear")),
            ("ESAM", theory.esam_pdf(ship, wave)),
            (f"moment method (closure {m.closure_order})", m),
            ("envelope FPK (coloured averaging)", theory.envelope_fpk_pdf(ship, wave)),
        ):
            q = law.summary()["quantiles_deg"]
            rows.append(
                (
                    label,
                    float(np.rad2deg(law.mean())),
                    q["99"],
                    float(law.sf(np.deg2rad(20.0))),
                    float(law.sf(np.deg2rad(30.0))),
                )
            )
        for label, mean, q99, p20, p30 in rows:
            print(f"| {hs:g} m | {label} | {mean:.2f} | {q99:.1f} | {p20:.4f} | {p30:.5f} |")
        print(f"<!-- H1/3 = {hs} m: {stats.n_realizations} realizations, {stats.n_capsized} capsized -->")


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
