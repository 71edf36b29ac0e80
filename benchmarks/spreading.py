"""Benchmark: the effect of directional spreading on P(roll > angle) of the default ship (issue 44, item 2).

The default ship, C11 (representative), in ITTC seas of T01 10 s and H1/3 `--hs` [m], head seas at zero speed,
long-crested and short-crested (`--spreadings`): per sea state and spreading, σ_G (Grim's effective wave, summed over
directions), S_G(2ω0) (what drives the parametric roll) against the long-crested sea's, and the Monte Carlo's
P(max |φ| > 25°, or capsize) and P(... > 30°) per trial with standard errors √(p(1 − p)/N), and P(capsize):
`monte_carlo_max_roll` (the shaping filter fitted to the spread S_G, `--method auto`; the same trial keys for
every spreading: common random numbers). Prints `name=value` lines.

Run: `python benchmarks/spreading.py [--hs 5,7] [--spreadings none,cos2s:75,cos2s:10,cos2s:2] [--trials 1000]
[--duration 1800] [--discard 300]`.
"""

from __future__ import annotations

import argparse
import math
import time

import jax.random as jr

import jaxroll
from jaxroll import ITTC, RollProblem, c11_representative, monte_carlo_max_roll
from jaxroll.sea import parse_spreading


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hs", default="5,7", help="H1/3 [m], comma-separated")
    ap.add_argument("--spreadings", default="none,cos2s:75,cos2s:10,cos2s:2")
    ap.add_argument("--trials", type=int, default=1000)
    ap.add_argument("--duration", type=float, default=1800.0)
    ap.add_argument("--discard", type=float, default=300.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    jaxroll.configure()
    ship = c11_representative()
    w2 = 2 * float(ship.omega0)
    print(
        f"ship=C11 (representative) head seas U=0 T01=10 s trials={args.trials} duration={args.duration:g} s"
    )
    for hs in (float(h) for h in args.hs.split(",")):
        base = None
        for text in args.spreadings.split(","):
            spreading = parse_spreading(text)
            t0 = time.perf_counter()
            problem = RollProblem.from_sea(ship, ITTC(hs, 10.0), spreading=spreading)
            wave = problem.wave
            sigma = math.sqrt(float(wave.variance()))
            s2 = float(wave.spectrum(w2))
            base = s2 if base is None else base
            line = [
                f"hs={hs:g}",
                f"spreading={text}",
                f"sigma_G_m={sigma:.4f}",
                f"S_G(2w0)_rel={s2 / base:.4f}",
                f"filter_order={problem.filter_fit.filter.order}",
            ]
            stats = monte_carlo_max_roll(
                problem,
                jr.key(args.seed),
                angle_deg=25.0,
                num_realizations=args.trials,
                duration=args.duration,
                discard=args.discard,
            )
            for angle in (25.0, 30.0):
                p = stats.exceedances(angle) / args.trials
                line.append(f"P(>{angle:g})={p:.4f}±{math.sqrt(p * (1 - p) / args.trials):.4f}")
            pc = float(stats.capsized.mean())
            line.append(f"P(capsize)={pc:.4f}±{math.sqrt(pc * (1 - pc) / args.trials):.4f}")
            line.append(f"seconds={time.perf_counter() - t0:.0f}")
            print(" ".join(line), flush=True)


if __name__ == "__main__":
    main()
