"""Rare cells of a long-term assessment by multilevel splitting (issue 34 items 3 and 4): `jaxroll.longterm(...,
method="auto")` with its Monte Carlo cells all by brute force (`estimator="brute_force"`, the baseline) and with the
rare ones by splitting (`estimator="splitting"`, `rare_below`), side by side in one process: the long-term value,
its 95 % interval (width and sampling part) per angle, and the wall time of the Monte Carlo.

The problem: a reduced scatter (IACS Rec. 34 rows H_s 3.5–6.5 m × T_z 8.5–10.5 s, their counts), the default ship,
head and bow seas (180°, 150°), zero speed, angles 30/40/50°, exposure 1 h after a 500 s discard, `auto` on the cells
carrying `--auto-share` (0.99) of the theory's value at some angle, `--realizations` per Monte Carlo cell on average
(Neyman-allocated): 13 Monte Carlo cells, 7 of them with a theory P(50°) below 10⁻³ (10⁻⁶–7·10⁻⁴). The theory is computed once (`method="theory"`, into a
checkpoint folder) and every run below loads it from a copy of that folder, so the times are the Monte Carlo's
alone. Each configuration runs twice: cold (its programs compiled) and warm. `--bf-factor K` adds brute force with
K × the trials, to compare the interval at a larger effort.

Usage: python benchmarks/longterm_splitting.py [--realizations 1000] [--rare-below 1e-3] [--bf-factor 0]
                                               [--hours 1] [--headings 180,150] [--angles 30,40,50]
                                               [--auto-share 0.99] [--rows 3.5,4.5,5.5,6.5]
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import tempfile
import time

import numpy as np

import jaxroll
from jaxroll.longterm import METHODS

ROWS = (3.5, 4.5, 5.5, 6.5)
COLUMNS = (8.5, 9.5, 10.5)


def reduced_scatter(path: str) -> None:
    """The Rec. 34 counts of `ROWS` × `COLUMNS` as a scatter file."""
    rec = jaxroll.rec34_scatter()
    i = [int(np.flatnonzero(rec.hs == h)[0]) for h in ROWS]
    j = [int(np.flatnonzero(rec.tz == t)[0]) for t in COLUMNS]
    lines = ["hs_m," + ",".join(f"{t:g}" for t in COLUMNS)]
    lines += [f"{ROWS[a]:g}," + ",".join(f"{rec.counts[ii, jj]:g}" for jj in j) for a, ii in enumerate(i)]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def summarise(label: str, ds, seconds: float) -> dict:
    mc = ds.method.values == METHODS.index("monte_carlo")
    split = mc & (ds.estimator.values == 2)
    return {
        "label": label,
        "seconds": seconds,
        "mc_cells": int(mc.sum()),
        "splitting_cells": int(split.sum()),
        "cost_trials": float(np.nansum(np.where(mc, ds.cost_trials.values, 0.0))),
        "p": ds.longterm_probability.values,
        "ci": ds.longterm_probability_ci95.values,
        "sd": ds.longterm_sampling_sd.values,
        "below": ds.longterm_model_below.values,
        "above": ds.longterm_model_above.values,
        "ds": ds,
    }


def part_sd(ds, cells) -> np.ndarray:
    """(Σ w² Var P)^1/2 over `cells` (a mask over the cells), per angle: those cells' part of the sampling sd."""
    w = ds.weight.values[..., None]
    var = np.where(cells[..., None], ds.probability_variance.values, 0.0)
    return np.sqrt((w**2 * var).sum(axis=tuple(range(w.ndim - 1))))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--realizations", type=int, default=1000)
    ap.add_argument("--rare-below", type=float, default=1e-3)
    ap.add_argument("--bf-factor", type=int, default=0, help="also brute force with K × the trials (0: not)")
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--headings", default="180,150")
    ap.add_argument("--angles", default="30,40,50")
    ap.add_argument("--auto-share", type=float, default=0.99)
    ap.add_argument("--rows", default="3.5,4.5,5.5,6.5", help="H_s rows of Rec. 34 [m]")
    a = ap.parse_args()
    global ROWS
    ROWS = tuple(float(x) for x in a.rows.split(","))
    jaxroll.configure()
    angles = [float(x) for x in a.angles.split(",")]
    kw = dict(
        headings=[math.radians(float(h)) for h in a.headings.split(",")],
        angles=[math.radians(x) for x in angles],
        exposure=a.hours * 3600.0,
        discard=500.0,
        seed=1,
        auto_share=a.auto_share,
    )
    print(f"load_average={os.getloadavg()[0]:.2f}")
    tmp = tempfile.mkdtemp()
    csv = os.path.join(tmp, "reduced.csv")
    reduced_scatter(csv)
    print(
        f"problem: Rec. 34 H_s {ROWS} m × T_z {COLUMNS} s, headings {a.headings}°, 0 m/s, angles {angles}°, "
        f"{a.hours:g} h after 500 s, method auto (share {a.auto_share:g}), {a.realizations} trials per Monte Carlo "
        "cell on average"
    )
    t0 = time.perf_counter()
    theory = jaxroll.longterm(csv, method="theory", checkpoint=os.path.join(tmp, "theory"), **kw)
    print(
        f"theory (once, checkpointed): {time.perf_counter() - t0:.1f} s, "
        f"{int((theory.lyapunov_exponent.values > 0).sum())} cells with λ > 0"
    )

    def auto(label, run, **extra):
        results = []
        for attempt in ("cold", "warm"):
            ck = os.path.join(tmp, f"ck-{run}-{attempt}")
            shutil.copytree(os.path.join(tmp, "theory"), ck)
            t = time.perf_counter()
            ds = jaxroll.longterm(csv, method="auto", checkpoint=ck, **kw, **extra)
            results.append(summarise(f"{label} ({attempt})", ds, time.perf_counter() - t))
            print(f"{results[-1]['label']}: {results[-1]['seconds']:.1f} s", flush=True)
        return results

    runs = auto("brute force", "bf", realizations=a.realizations)
    runs += auto(
        f"splitting below {a.rare_below:g}",
        "split",
        realizations=a.realizations,
        estimator="splitting",
        rare_below=a.rare_below,
    )
    if a.bf_factor:
        runs += auto(f"brute force ×{a.bf_factor}", "bfk", realizations=a.realizations * a.bf_factor)
    rare = runs[3]["ds"].estimator.values == 2  # the cells the splitting run found rare
    for r in runs:
        r["rare_sd"] = part_sd(r["ds"], rare)
        r["rare_cost"] = float(np.where(rare, r["ds"].cost_trials.values, 0.0).sum())
    print()
    print(f"{'run':<32} {'MC s':>7} {'MC cells':>8} {'split':>5} {'cost [trials]':>13}")
    for r in runs:
        print(
            f"{r['label']:<32} {r['seconds']:7.1f} {r['mc_cells']:8d} {r['splitting_cells']:5d} "
            f"{r['cost_trials']:13.0f}"
        )
    for k, angle in enumerate(angles):
        print(
            f"\nangle {angle:g}°: P_LT, 95 % interval (width), sampling ±1.96σ (of which the rare cells), "
            "model allowance"
        )
        for r in runs[1::2]:  # the warm runs (the same numbers as the cold ones)
            lo, hi = r["ci"][k]
            print(
                f"  {r['label'].removesuffix(' (warm)'):<28} {r['p'][k]:.4g}  [{lo:.4g}, {hi:.4g}] "
                f"({hi - lo:.3g})  ±{1.96 * r['sd'][k]:.3g} (±{1.96 * r['rare_sd'][k]:.3g})  "
                f"-{r['below'][k]:.3g}/+{r['above'][k]:.3g}"
            )
    print(
        "\nthe rare cells alone: their cost in trials, and the work at equal sampling width of their part against "
        "brute force, (σ_bf² cost_bf)/(σ² cost), per angle (brute force: Agresti–Coull variances, as the interval)"
    )
    base = runs[1]
    for r in runs[1::2]:
        ratio = (base["rare_sd"] ** 2 * base["rare_cost"]) / np.maximum(
            r["rare_sd"] ** 2 * r["rare_cost"], 1e-300
        )
        print(
            f"  {r['label'].removesuffix(' (warm)'):<28} cost {r['rare_cost']:9.0f}  work ratio "
            + ", ".join(f"{angle:g}°: {x:.3g}" for angle, x in zip(angles, ratio))
        )
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
