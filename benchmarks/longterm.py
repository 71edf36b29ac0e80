"""Long-term risk by theory (issue 34): `jaxroll.longterm` over IACS Rec. 34 × headings × speeds, default ship,
beside the baseline of looping today's per-cell risk in the same run.

Target (issue 34): Rec. 34 × 12 headings × 4 speeds, default ship, theory, ≤ 60 s after compilation and ≤ 2 min
cold on a 2-core machine.

- cold: `jaxroll.longterm(...)` in a fresh process with an empty compilation cache (compilation included);
- warm: the same call again in that process (after compilation);
- baseline: today's per-cell risk looped over the same computation cells — `jaxroll.theory.passage_risk(ship,
  wave, angles, [exposure])` per cell (what `jaxroll risk --theory first_passage` runs), in a warm process (each
  kind of wave compiled before the timing),
  skipping nothing but the beam-sea class — timed on `--sample` cells drawn at random and extrapolated to all of
  them (`--full-baseline` loops over every cell).

`jaxroll.longterm` saves on the baseline by (1) the Lyapunov screen: cells with λ <= 0 are 0 exactly, one small
vmapped solve each, and (2) at zero speed computing χ and 180° − χ once (one problem). Both are exact. (3) The
two passes (`--refine-delta` δ): one grid everywhere, the Richardson step only on the cells carrying 1 − δ of
the one-grid Σ w P per heading class and speed (docs/longterm.md, "Cost").

Usage: python benchmarks/longterm.py [--headings 12] [--speeds 0,4,8,12] [--sample 24] [--full-baseline]
                                     [--skip-cold] [--refine-delta 0.01]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

CHILD = r"""
import json, math, sys, time
t0 = time.time()
import jaxroll
jaxroll.configure()
jaxroll.enable_compilation_cache()
args = json.loads(sys.argv[1])
kw = dict(headings=[math.radians(h) for h in args["headings"]], speeds=args["speeds"],
          angles=[math.radians(a) for a in args["angles"]], exposure=args["hours"] * 3600.0, method="theory",
          refine_delta=args["refine_delta"])
t1 = time.time()
ds = jaxroll.longterm("rec34", **kw)
t2 = time.time()
ds = jaxroll.longterm("rec34", **kw)
t3 = time.time()
m = ds.method.values
print(json.dumps({"import_s": t1 - t0, "cold_s": t2 - t1, "warm_s": t3 - t2,
                  "p_lt": ds.longterm_probability.values.tolist(),
                  "theory_cells": int((m == 4).sum()),  # METHODS.index("theory")
                  "live": int((ds.lyapunov_exponent.values > 0).sum()),
                  "refined": int(ds.theory_refined.values.sum())}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--headings", type=int, default=12, help="headings over 0 … 360° (default 12: every 30°)")
    ap.add_argument("--speeds", default="0,4,8,12", help="speeds [m/s] (default 0,4,8,12)")
    ap.add_argument("--angles", default="25,30,40", help="angles [deg]")
    ap.add_argument("--hours", type=float, default=3.0)
    ap.add_argument("--sample", type=int, default=24, help="baseline cells timed (extrapolated)")
    ap.add_argument("--full-baseline", action="store_true")
    ap.add_argument("--skip-cold", action="store_true")
    ap.add_argument(
        "--refine-delta", type=float, default=0.01, help="the theory's two-pass δ (0: every cell refined)"
    )
    a = ap.parse_args()
    headings = [360.0 * i / a.headings for i in range(a.headings)]
    speeds = [float(x) for x in a.speeds.split(",")]
    angles = [float(x) for x in a.angles.split(",")]
    print(f"load_average={os.getloadavg()[0]:.2f}")
    print(
        f"problem=rec34 x {len(headings)} headings x {len(speeds)} speeds, angles {angles} deg, {a.hours:g} h"
    )

    # ---- jaxroll.longterm, cold and warm, in a fresh process with an empty cache -------------------------------
    if not a.skip_cold:
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "JAXROLL_CACHE_DIR": cache}
            t = time.time()
            out = subprocess.run(
                [
                    sys.executable,
                    "-c",
                    CHILD,
                    json.dumps(
                        {
                            "headings": headings,
                            "speeds": speeds,
                            "angles": angles,
                            "hours": a.hours,
                            "refine_delta": a.refine_delta,
                        }
                    ),
                ],
                env=env,
                capture_output=True,
                text=True,
                check=True,
            )
            wall = time.time() - t
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"longterm_cold_s={r['cold_s']:.1f} (import {r['import_s']:.1f} s; process {wall:.1f} s)")
        print(f"longterm_warm_s={r['warm_s']:.1f}")
        print(
            f"theory_cells={r['theory_cells']} (dataset cells), lambda_positive_cells={r['live']}, "
            f"refined_cells={r['refined']} (refine_delta {a.refine_delta:g})"
        )
        print(f"p_lt={r['p_lt']}")

    # ---- baseline: today's per-cell route, looped -------------------------------------------------------------
    import jax
    import numpy as np

    import jaxroll
    from jaxroll.longterm._cells import make_grid

    jaxroll.configure()
    jaxroll.enable_compilation_cache()
    ship = jaxroll.c11_representative()
    scatter = jaxroll.rec34_scatter()
    grid = make_grid(scatter, [ship], ["c11"], None, [math.radians(h) for h in headings], None, speeds, None)
    needed = (grid.comp_weight > 0) & ~grid.beam[None, :, None, None, None]
    cells = np.argwhere(needed)
    print(
        f"computation_cells={len(cells)} (distinct problems: port/starboard once, beam seas and empty sea states "
        "left out)"
    )
    rng = np.random.default_rng(0)
    take = (
        cells if a.full_baseline else cells[rng.choice(len(cells), min(a.sample, len(cells)), replace=False)]
    )
    rad = np.radians(angles)

    def wave_of(c):
        _, k, u, i, j = c
        sea = jaxroll.ITTC(
            jax.numpy.asarray(scatter.hs[i]), jax.numpy.asarray(scatter.t01[j])
        )  # arrays: one program
        return jaxroll.EffectiveWave(
            sea, ship.lpp, float(grid.speeds[u]), math.radians(float(grid.classes_deg[k]))
        )

    def per_cell(c):
        return np.asarray(jaxroll.theory.passage_risk(ship, wave_of(c), rad, [a.hours * 3600.0]).probability)

    kinds = {}  # one cell of each kind of wave (head/following/oblique compile to different programs)
    for c in take:
        w = wave_of(c)
        kinds.setdefault((w.following, w.projected), c)
    for c in kinds.values():  # compile
        per_cell(c)
    t = time.time()
    for c in take:
        per_cell(c)
    base = time.time() - t
    scale = len(cells) / len(take)
    print(
        f"baseline_s={base * scale:.1f} ({'all cells' if a.full_baseline else f'{len(take)} cells timed, x{scale:.1f}'}"
        f"; {base / len(take):.3f} s per cell)"
    )

    print(f"load_average_end={os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
