"""Long-term risk by theory (issue 34): `jaxroll.longterm` over IACS Rec. 34 × headings × speeds, default ship,
beside the baseline of looping today's per-cell risk in the same run.

Target (issue 34): Rec. 34 × 12 headings × 4 speeds, default ship, theory, ≤ 60 s after compilation and ≤ 2 min
cold on a 2-core machine.

- cold: `jaxroll.longterm(...)` in a fresh process with an empty compilation cache (compilation included);
- warm: the same call again in that process (after compilation);
- baseline: today's per-cell route looped over the same computation cells — `theory.envelope_fpk_pdf(ship, wave,
  estimator="zero_crossing")` and `exceedance_probability(law, angle, rate, duration)` per cell, in a warm
  process, skipping nothing but the beam-sea class — timed on `--sample` cells drawn at random and extrapolated to
  all of them (`--full-baseline` loops over every cell);
- batching: the same cells through the theory's per-cell program spread over the CPU devices (the library's way)
  and through a vmapped batch of 8 (`_theory_batch`), side by side.

The interim theory is the independent-amplitude adapter (`jaxroll.longterm._theory._theory_probability`); at
merge `jaxroll.theory.passage_risk` replaces it and the lead re-measures.

Usage: python benchmarks/longterm.py [--headings 12] [--speeds 0,4,8,12] [--sample 24] [--full-baseline]
                                     [--skip-cold] [--compare-batching N]
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
jaxroll.enable_compilation_cache()
args = json.loads(sys.argv[1])
kw = dict(headings=[math.radians(h) for h in args["headings"]], speeds=args["speeds"],
          angles=[math.radians(a) for a in args["angles"]], exposure=args["hours"] * 3600.0, method="theory")
t1 = time.time()
ds = jaxroll.longterm("rec34", **kw)
t2 = time.time()
ds = jaxroll.longterm("rec34", **kw)
t3 = time.time()
m = ds.method.values
print(json.dumps({"import_s": t1 - t0, "cold_s": t2 - t1, "warm_s": t3 - t2,
                  "p_lt": ds.longterm_probability.values.tolist(),
                  "theory_cells": int((m == 4).sum()), "live": int((ds.lyapunov_exponent.values > 0).sum())}))
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
    ap.add_argument("--compare-batching", type=int, default=16, help="cells for the batching comparison (0: skip)")
    a = ap.parse_args()
    headings = [360.0 * i / a.headings for i in range(a.headings)]
    speeds = [float(x) for x in a.speeds.split(",")]
    angles = [float(x) for x in a.angles.split(",")]
    print(f"load_average={os.getloadavg()[0]:.2f}")
    print(f"problem=rec34 x {len(headings)} headings x {len(speeds)} speeds, angles {angles} deg, {a.hours:g} h")

    # ---- jaxroll.longterm, cold and warm, in a fresh process with an empty cache -------------------------------
    if not a.skip_cold:
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "JAXROLL_CACHE_DIR": cache}
            t = time.time()
            out = subprocess.run([sys.executable, "-c", CHILD, json.dumps({"headings": headings, "speeds": speeds,
                                                                           "angles": angles, "hours": a.hours})],
                                 env=env, capture_output=True, text=True, check=True)
            wall = time.time() - t
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"longterm_cold_s={r['cold_s']:.1f} (import {r['import_s']:.1f} s; process {wall:.1f} s)")
        print(f"longterm_warm_s={r['warm_s']:.1f}")
        print(f"theory_cells={r['theory_cells']} (dataset cells), lambda_positive_cells={r['live']}")
        print(f"p_lt={r['p_lt']}")

    # ---- baseline: today's per-cell route, looped -------------------------------------------------------------
    import jax
    import numpy as np

    import jaxroll
    from jaxroll.longterm._cells import make_grid

    jaxroll.enable_compilation_cache()
    ship = jaxroll.c11_representative()
    scatter = jaxroll.rec34_scatter()
    grid = make_grid(scatter, [ship], ["c11"], None, [math.radians(h) for h in headings], None, speeds, None)
    needed = (grid.comp_weight > 0) & ~grid.beam[None, :, None, None, None]
    cells = np.argwhere(needed)
    print(f"computation_cells={len(cells)} (distinct problems: port/starboard once, beam seas and empty sea states "
          "left out)")
    rng = np.random.default_rng(0)
    take = cells if a.full_baseline else cells[rng.choice(len(cells), min(a.sample, len(cells)), replace=False)]
    rad = np.radians(angles)

    def per_cell(c):
        _, k, u, i, j = c
        wave = jaxroll.EffectiveWave(jaxroll.ITTC(float(scatter.hs[i]), float(scatter.t01[j])), ship.lpp,
                                     float(grid.speeds[u]), math.radians(float(grid.classes_deg[k])))
        law = jaxroll.theory.envelope_fpk_pdf(ship, wave, estimator="zero_crossing", throw=False)
        if not bool(law.exists):
            return np.zeros(rad.size)
        rate = float(law.excitation.omega) / math.pi
        return np.asarray(jaxroll.exceedance_probability(law, rad, rate=rate, duration=a.hours * 3600.0))

    per_cell(take[0])  # compile
    t = time.time()
    for c in take:
        per_cell(c)
    base = time.time() - t
    scale = len(cells) / len(take)
    print(f"baseline_s={base * scale:.1f} ({'all cells' if a.full_baseline else f'{len(take)} cells timed, x{scale:.1f}'}"
          f"; {base / len(take):.3f} s per cell)")

    # ---- batching: per-cell programs over the devices vs a vmapped batch --------------------------------------
    if a.compare_batching:
        from jaxroll.longterm import _theory

        template = _theory.class_template(ship, 0.0, 180.0)
        n = a.compare_batching
        hs = np.linspace(4.0, 9.0, n)
        t01 = np.full(n, 10.0)
        _theory.class_theory(ship, template, hs[:2], t01[:2], rad, a.hours * 3600.0)  # compile
        t = time.time()
        _theory.class_theory(ship, template, hs, t01, rad, a.hours * 3600.0)
        per = time.time() - t
        ang, dur = jax.numpy.asarray(rad), jax.numpy.asarray([a.hours * 3600.0])
        jax.block_until_ready(_theory._theory_batch(ship, _theory._seas(hs[:8], t01[:8]), template, ang, dur))
        t = time.time()
        for s in range(0, n, 8):
            jax.block_until_ready(_theory._theory_batch(ship, _theory._seas(hs[s:s + 8], t01[s:s + 8]), template,
                                                        ang, dur))
        vm = time.time() - t
        print(f"batching_{n}_cells: per-cell programs over {jax.local_device_count()} devices {per:.2f} s "
              f"(incl. the lambda screen), vmapped batches of 8 {vm:.2f} s")
    print(f"load_average_end={os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
