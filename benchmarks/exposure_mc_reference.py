"""Monte Carlo reference of the exposure risk (issue 34 item 2): P(max |φ| > angle within T, capsize included).

Default ship, ITTC T01 = 10 s, head seas, U = 0, Method-2 filter of order 4, dt 0.5 s, φ0 = 5°; each trial runs a
discard of 1000 s (the roll reaches its quasi-stationary state) and then the exposure T; its largest |φ| over the
exposure (a capsize counts as beyond every angle) against 25°, 30°, 40°. H1/3 ∈ {5, 6, 7, 8} m, T ∈ {1 h, 3 h}.
`jaxroll.monte_carlo_max_roll`, key(100 · case + 7) per (H1/3, T), N trials.

Usage: python benchmarks/exposure_mc_reference.py [--realizations N] [--out PATH]
(writes benchmarks/data/exposure_mc_reference.json; about 5 min on a quiet 2-core CPU for N = 20000)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

OUT = Path(__file__).parent / "data" / "exposure_mc_reference.json"
HS = (5.0, 6.0, 7.0, 8.0)
HOURS = (1.0, 3.0)
ANGLES = (25.0, 30.0, 40.0)
DISCARD = 1000.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realizations", type=int, default=20000)
    parser.add_argument("--out", default=str(OUT))
    args = parser.parse_args()
    import jax

    import jaxroll

    if hasattr(jaxroll, "configure"):
        jaxroll.configure()
    ship = jaxroll.c11_representative()
    cases = []
    for i, hs in enumerate(HS):
        problem = jaxroll.RollProblem.from_sea(ship, jaxroll.ITTC(hs, 10.0))
        for j, hours in enumerate(HOURS):
            t0 = time.time()
            stats = jaxroll.monte_carlo_max_roll(
                problem,
                jax.random.key(100 * (len(HOURS) * i + j) + 7),
                angle_deg=ANGLES[0],
                num_realizations=args.realizations,
                duration=DISCARD + 3600.0 * hours,
                discard=DISCARD,
            )
            row = {
                "hs": hs,
                "hours": hours,
                "n_realizations": stats.n_realizations,
                "n_capsized": stats.n_capsized,
                "run_time_s": time.time() - t0,
                "angles_deg": list(ANGLES),
                "probability": [stats.exceedance_probability(a) for a in ANGLES],
                "probability_ci95": [list(stats.exceedance_interval(a)) for a in ANGLES],
                "n_exceeded": [stats.exceedances(a) for a in ANGLES],
            }
            print(json.dumps(row), flush=True)
            cases.append(row)
    payload = {
        "protocol": f"default ship, ITTC T01 = 10 s, head seas, U = 0, filter order 4, dt 0.5 s, phi0 5 deg, discard "
        f"{DISCARD:g} s then the exposure; capsizes count as exceedances; key(100*(2*i_hs + i_hours) + 7)",
        "command": f"python benchmarks/exposure_mc_reference.py --realizations {args.realizations}",
        "jaxroll_version": jaxroll.__version__,
        "cases": cases,
    }
    Path(args.out).write_text(json.dumps(payload, indent=1) + "\n")


if __name__ == "__main__":
    main()
