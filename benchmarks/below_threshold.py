"""The moment method below the parametric threshold: the closure's fixed point against the roll's decay.

For each (r, H1/3) of the default ship (ITTC, T01 = 10 s, head seas, zero speed): the Lyapunov exponent λ of the
linearised roll under the moment method's coloured excitation (`jaxroll.theory.sustained_roll_exponent`), the
paper's moment method (`moment_pdf`, closure order 4: order 6 has no stable point there) and the Monte Carlo's
mean envelope amplitude over 500–3600 s and 15 000–20 000 s, from φ0 = 5° and 15°. Where λ ≤ 0 the Monte Carlo
decays while the closure keeps a non-trivial law; `moment_pdf_first_stable` and `theory_law("moment")` refuse
there (docs/theory.md, "Below the threshold"). About 25 s on a 2-core CPU.

Usage: python benchmarks/below_threshold.py [--realizations 1000]
"""

from __future__ import annotations

import argparse
import math
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import jaxroll
from jaxroll import theory

CASES = ((1.0, 3.0), (0.8, 4.0), (0.6, 5.0), (0.5, 6.0), (1.0, 4.0))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--realizations", type=int, default=1000)
    args = p.parse_args()
    base = jaxroll.c11_representative()
    t0 = time.perf_counter()
    print("| r, H1/3 | λ [1/s] | moment method (order 4), mean | MC 500–3600 s | MC 15 000–20 000 s |")
    print("|---|---|---|---|---|")
    for r, hs in CASES:
        ship = eqx.tree_at(lambda s: s.gm_correction, base, jnp.asarray(r))
        wave = jaxroll.EffectiveWave(jaxroll.ITTC(hs, 10.0), ship.lpp)
        lam = float(theory.sustained_roll_exponent(ship, wave))
        paper = math.degrees(float(theory.moment_pdf(ship, wave, closure_order=4).mean()))
        mc = {}
        for phi0 in (5.0, 15.0):
            problem = jaxroll.RollProblem.from_sea(ship, jaxroll.ITTC(hs, 10.0), phi0=math.radians(phi0))
            for duration, discard in ((3600.0, 500.0), (20_000.0, 15_000.0)):
                st = jaxroll.monte_carlo_amplitudes(problem, jax.random.key(1), num_realizations=args.realizations,
                                                    duration=duration, discard=discard)  # fmt: skip
                mc[(phi0, discard)] = np.rad2deg(st.mean("envelope"))
        cols = [" / ".join(f"{mc[(phi0, d)]:.3f}°" for phi0 in (5.0, 15.0)) for d in (500.0, 15_000.0)]
        print(f"| {r:g}, {hs:g} m | {lam:+.5f} | {paper:.2f}° | {cols[0]} | {cols[1]} |", flush=True)
    print(
        f"(Monte Carlo from φ0 = 5° / 15°, {args.realizations} trials each; {time.perf_counter() - t0:.0f} s)"
    )


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
