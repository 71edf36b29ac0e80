"""Where the theories hold (issue 37 item 6): the validity numbers beside the Monte Carlo and the averaging theories.

Default ship, ITTC T01 = 10 s, head seas, zero speed; Monte Carlo with Method 1 (superposition), 400 trials × 3600 s,
500 s discarded (envelope means). For each H1/3: ε = σ[rΔGM]/(GM0 + E[rΔGM]), the mean GM in waves over GM0,
3σ_G / min(draught, freeboard) (`jaxroll.ship.excitation_validity`), the significant steepness against the breaking limit
(`jaxroll.sea_steepness`), the Monte Carlo's mean and capsize probability, and Roberts', ESAM's and the envelope
FPK's means. Prints a markdown table (docs/theory.md, "Where the theories hold").

Usage: python benchmarks/theory_validity.py [--realizations N] [--hs 5,7,9,12,20,30]
"""

from __future__ import annotations

import argparse
import warnings

import jax
import numpy as np

import jaxroll
from jaxroll import theory
from jaxroll.ship import excitation_validity


def main() -> None:
    jaxroll.configure()
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--realizations", type=int, default=400)
    parser.add_argument("--hs", default="5,7,9,12,20,30")
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # the warnings are what the table shows
    ship = jaxroll.c11_representative()
    print(
        "| H1/3 [m] | S_p / limit | ε | mean GM / GM0 | 3σ_G / min(d, D − d) | MC mean [deg] | P(capsize) | Roberts | ESAM | "
        "envelope FPK |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for hs in (float(h) for h in args.hs.split(",")):
        sea = jaxroll.ITTC(hs, 10.0)
        problem = jaxroll.RollProblem.from_sea(ship, sea, dt=0.5, excitation="superposition")
        stats = jaxroll.monte_carlo_amplitudes(
            problem, jax.random.key(0), num_realizations=args.realizations, duration=3600.0, discard=500.0
        )
        v = excitation_validity(ship, problem.wave)
        s = jaxroll.sea_steepness(sea)
        means = []
        for fn in (
            lambda: theory.roberts_pdf(ship, problem.wave, restoring="nonlinear"),
            lambda: theory.esam_pdf(ship, problem.wave),
            lambda: theory.envelope_fpk_pdf(ship, problem.wave),
        ):
            try:
                means.append(f"{np.rad2deg(fn().mean()):.2f}")
            except Exception:  # no law in this sea state
                means.append("—")
        mc = np.rad2deg(stats.mean("envelope"))
        print(
            f"| {hs:g} | {s['steepness'] / s['limit']:.2f} | {v['stiffness_variation']:.2f} | "
            f"{1 + v['mean_gm_shift']:.2f} | {v['zeta_range']:.2f} | "
            f"{'—' if np.isnan(mc) else f'{mc:.2f}'} | {stats.capsize_probability:.3f} | {' | '.join(means)} |"
        )


if __name__ == "__main__":
    main()
