"""Every tail-probability method of jaxroll against the exact-spectrum reference, over the whole map (issue 42).

The reference is `benchmarks/exact_reference.py` (an exactly Gaussian sea from the ITTC spectrum component by
component, Heun's method in numba: nothing of jaxroll's numerics), stored in `benchmarks/data/exact_reference.json`.
For each cell of the map (H1/3 × T01 × heading × speed) and each exposure (1 h, 3 h) and angle (25–45°) this
computes P(max |φ| > angle within the exposure, or capsize) by

- `mc-default`: `RollProblem.from_sea`'s default excitation, `monte_carlo_max_roll` (what `jaxroll risk` runs);
- `mc-filter4`, `mc-filter8`, `mc-superposition`: the same with the paper's order-4 filter, an order-8 filter and
  Method 1 (component superposition);
- `splitting`: `monte_carlo_splitting_angles` on the default excitation (cells where the reference P < `--split-below`);
- `passage`: `jaxroll.theory.passage_risk` (the envelope FPK model followed through the exposure);
- `pstar-<theory>`: 1 − (1 − F̄(a))^N of Roberts', ESAM's and the envelope FPK's zero-crossing laws (amplitudes
  taken as independent, N = the envelope model's amplitude rate × exposure).

Per entry: the ratio to the reference and z = (p − p_ref)/s.e. (the Monte Carlo's and the reference's binomial
errors pooled; a theory: the reference's alone), for entries with 1e-3 ≤ P_ref ≤ 0.95. Per method: the pooled
χ² = Σ z² against its 99 % quantile (entries of one cell share trials, so they are positively correlated and χ²
is conservative as a test), the worst |z|, the entries beyond 3σ + 3 %, and the ratio's range. Writes
`benchmarks/data/validation_map.json` and the ratio-map figure `docs/figures/validation_map.png`.

Usage:
    python benchmarks/validation_map.py                                  # every method, the stored reference
    python benchmarks/validation_map.py --methods mc-default,passage --trials 20000
    python benchmarks/validation_map.py --from-json benchmarks/data/validation_map.json   # redraw, summarise
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REFERENCE = os.path.join(HERE, "data", "exact_reference.json")
OUT_JSON = os.path.join(HERE, "data", "validation_map.json")
FIGURE = os.path.join(HERE, "..", "docs", "figures", "validation_map.png")
P_MIN, P_MAX = 1e-3, 0.95
MC_METHODS = {
    "mc-default": {},
    "mc-filter4": {"excitation": "filter", "filter_order": 4},
    "mc-filter8": {"excitation": "filter", "filter_order": 8},
    "mc-superposition": {"excitation": "superposition"},
}
THEORY_PSTAR = ("roberts", "esam", "envelope_fpk")
ALL_METHODS = (*MC_METHODS, "splitting", "passage", *(f"pstar-{t}" for t in THEORY_PSTAR))


def chi2_quantile(k, q=0.99):
    """χ²_k quantile by Wilson–Hilferty (within 0.5 % for k ≥ 5)."""
    from statistics import NormalDist

    z = NormalDist().inv_cdf(q)
    return k * (1 - 2 / (9 * k) + z * math.sqrt(2 / (9 * k))) ** 3


def problem_of(cell, **kw):
    import jaxroll as jxr

    ship = jxr.c11_representative()
    sea = jxr.ITTC(hs=cell["hs"], t01=cell["t01"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return jxr.RollProblem.from_sea(
            ship, sea, speed=cell["speed"], heading=math.radians(cell["heading_deg"]), **kw
        )


def mc_probabilities(cell, kw, trials, seed, exposures_h, angles):
    """{h: {angle: (count, trials)}} from two runs with one key (the 1 h run is the 3 h run's beginning)."""
    import jax

    import jaxroll as jxr

    problem = problem_of(cell, **kw)
    out = {}
    for h in exposures_h:
        s = jxr.monte_carlo_max_roll(problem, jax.random.key(seed), angle_deg=30.0, num_realizations=trials,
                                     duration=500.0 + 3600.0 * h, discard=500.0)  # fmt: skip
        peak = np.where(s.capsized, np.inf, s.max_abs_phi_deg)
        out[f"{h:g}"] = {f"{a:g}": (int(np.sum(peak > a)), trials) for a in angles}
    return out


def splitting_probabilities(cell, trials, seed, exposures_h, angles):
    """{h: {angle: (p, se)}} by multilevel splitting on the default excitation, every angle from one run."""
    import jax

    import jaxroll as jxr

    problem = problem_of(cell)
    out = {}
    for h in exposures_h:
        res = jxr.monte_carlo_splitting_angles(problem, jax.random.key(seed), angles_deg=[float(a) for a in angles],
                                               exposure=3600.0 * h, discard=500.0, num_trials=trials)  # fmt: skip
        out[f"{h:g}"] = {
            f"{a:g}": (float(r.probability), float(r.standard_error)) for a, r in zip(angles, res)
        }
    return out


def theory_probabilities(cell, exposures_h, angles):
    """passage_risk and the P* of each averaging theory: {method: {h: {angle: p}}}."""
    import jax.numpy as jnp

    import jaxroll as jxr

    problem = problem_of(cell, excitation="superposition")
    rad = np.radians(np.asarray(angles, float))
    secs = 3600.0 * np.asarray(exposures_h, float)
    pr = jxr.theory.passage_risk(problem.ship, problem.wave, rad, secs)
    table = {"passage": np.asarray(pr.probability)}
    rate = float(pr.amplitude_rate)
    for name in THEORY_PSTAR:
        try:
            law = jxr.theory.theory_law(
                name, problem.ship, problem.wave, estimator="zero_crossing", warn=False
            )
            table[f"pstar-{name}"] = np.stack(
                [
                    np.asarray(jxr.exceedance_probability(law, jnp.asarray(rad), rate=rate, duration=t))
                    for t in secs
                ],
                axis=-1,
            )
        except Exception as e:  # a theory with no law here (below its threshold): 0, said
            print(f"  {name}: no law ({type(e).__name__}: {str(e)[:80]})", file=sys.stderr)
            table[f"pstar-{name}"] = np.zeros((len(angles), len(exposures_h)))
    return {
        m: {
            f"{h:g}": {f"{a:g}": float(v[i, j]) for i, a in enumerate(angles)}
            for j, h in enumerate(exposures_h)
        }
        for m, v in table.items()
    }


def compare(reference, results):
    """Per method: entries (cell, h, angle, p, p_ref, ratio, z) and the pooled statistics."""
    summary = {}
    for method, cells in results.items():
        entries = []
        for key, per in cells.items():
            ref = reference[key]
            n_ref = ref["trials"]
            for h, angles in per.items():
                for a, val in angles.items():
                    x_ref = ref["exceedances"][h][a]
                    p_ref = x_ref / n_ref
                    if not (P_MIN <= p_ref <= P_MAX):
                        continue
                    if method.startswith("mc-"):
                        x, n = val
                        p = x / n
                        pooled = (x + x_ref) / (n + n_ref)
                        se = math.sqrt(pooled * (1 - pooled) * (1 / n + 1 / n_ref))
                    elif method == "splitting":
                        p, se_m = val
                        se = math.sqrt(se_m**2 + p_ref * (1 - p_ref) / n_ref)
                    else:
                        p = val
                        se = math.sqrt(p_ref * (1 - p_ref) / n_ref)
                    z = (p - p_ref) / se
                    beyond = abs(p - p_ref) > 3 * se + 0.03 * p_ref
                    entries.append({"cell": key, "exposure_h": float(h), "angle_deg": float(a), "p": p,
                                    "p_ref": p_ref, "ratio": p / p_ref, "z": z, "beyond_3se_3pct": beyond})  # fmt: skip
        if not entries:
            continue
        chi2 = sum(e["z"] ** 2 for e in entries)
        ratios = [e["ratio"] for e in entries]
        summary[method] = {
            "entries": entries,
            "n": len(entries),
            "chi2": chi2,
            "chi2_q99": chi2_quantile(len(entries)),
            "worst_abs_z": max(abs(e["z"]) for e in entries),
            "n_beyond_3se_3pct": sum(e["beyond_3se_3pct"] for e in entries),
            "ratio_min": min(ratios),
            "ratio_max": max(ratios),
            "ratio_geomean": float(np.exp(np.mean(np.log(np.maximum(ratios, 1e-300))))),
        }
    return summary


#: Regions of the theory's allowance (jaxroll/longterm/_allowance.py): speed classes [m/s] × T01 bands [s], and the
#: fewest reference exceedances an entry needs to count there (fewer: its ratio is mostly the reference's noise,
#: σ_log > 0.2).
SPEED_CLASSES = ((0.0, 0.5), (0.5, math.inf))
T01_BANDS = ((0.0, 9.0), (9.0, 11.0), (11.0, math.inf))
MIN_EVENTS = 25


def allowance(summary, reference, method="passage"):
    """Per region (speed class, T01 band) index pair: (f_below, f_above, entries), so that over the region's
    entries P_exact ∈ [P/f_below, P·f_above]: f_below = max(1, largest ratio r = P/P_exact), f_above = max(1,
    1/smallest r), over the entries with at least `MIN_EVENTS` reference exceedances (None where there are none)."""
    out = {}
    for si, (ulo, uhi) in enumerate(SPEED_CLASSES):
        for ti, (lo, hi) in enumerate(T01_BANDS):
            ratios = []
            for e in summary.get(method, {}).get("entries", []):
                ref = reference[e["cell"]]
                events = ref["exceedances"][f"{e['exposure_h']:g}"][f"{e['angle_deg']:g}"]
                if (
                    lo <= ref["t01"] < hi
                    and ulo <= ref["speed"] < uhi
                    and events >= MIN_EVENTS
                    and e["ratio"] > 0
                ):
                    ratios.append(e["ratio"])
            out[(si, ti)] = (
                (max(1.0, max(ratios)), max(1.0, 1 / min(ratios)), len(ratios)) if ratios else None
            )
    return out


def print_summary(summary):
    for m, s in summary.items():
        print(f"{m}: n={s['n']} chi2={s['chi2']:.1f} (99% quantile {s['chi2_q99']:.1f}) worst_|z|="
              f"{s['worst_abs_z']:.2f} beyond_3se+3%={s['n_beyond_3se_3pct']} ratio={s['ratio_min']:.3f}-"
              f"{s['ratio_max']:.3f} geomean={s['ratio_geomean']:.3f}")  # fmt: skip


def draw(summary, reference, path):
    """Ratio maps: one row per method, one column per (heading, speed); cells H1/3 × T01 coloured by the geometric
    mean ratio of their entries (1e-3 ≤ P_ref ≤ 0.95), annotated with it and the worst |z|."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    methods = list(summary)
    cells = list(reference.values())
    hs = sorted({c["hs"] for c in cells})
    t01 = sorted({c["t01"] for c in cells})
    cols = sorted({(c["heading_deg"], c["speed"]) for c in cells}, key=lambda x: (-x[0], x[1]))
    fig, axes = plt.subplots(len(methods), len(cols), figsize=(2.0 * len(cols) + 1.6, 1.7 * len(methods) + 1.0),
                             squeeze=False, sharex=True, sharey=True, layout="constrained")  # fmt: skip
    norm = LogNorm(1 / 2, 2)
    for i, m in enumerate(methods):
        by_cell = {}
        for e in summary[m]["entries"]:
            by_cell.setdefault(e["cell"], []).append(e)
        for j, (chi, u) in enumerate(cols):
            ax = axes[i, j]
            grid = np.full((len(hs), len(t01)), np.nan)
            for key, es in by_cell.items():
                c = reference[key]
                if (c["heading_deg"], c["speed"]) != (chi, u):
                    continue
                r = float(np.exp(np.mean(np.log([max(e["ratio"], 1e-3) for e in es]))))
                zmax = max(abs(e["z"]) for e in es)
                a, b = hs.index(c["hs"]), t01.index(c["t01"])
                grid[a, b] = r
                ax.text(b, a, f"×{r:.2f}\n|z|≤{zmax:.1f}", ha="center", va="center", fontsize=6.5,
                        color="k" if 0.7 < r < 1.4 else "w")  # fmt: skip
            im = ax.imshow(grid, origin="lower", cmap="RdBu_r", norm=norm, aspect="auto")
            ax.set_xticks(range(len(t01)), [f"{t:g}" for t in t01])
            ax.set_yticks(range(len(hs)), [f"{h:g}" for h in hs])
            if i == 0:
                name = {180.0: "head", 0.0: "following"}.get(chi, f"χ {chi:g}°")
                ax.set_title(f"{name}, {u:g} m/s", fontsize=9)
            if j == 0:
                ax.set_ylabel(f"{m}\nH1/3 [m]", fontsize=8)
            if i == len(methods) - 1:
                ax.set_xlabel("T01 [s]", fontsize=8)
    bar = fig.colorbar(im, ax=axes, shrink=0.8, label="P / P_exact\n(geometric mean, 25–45°, 1 h and 3 h)")
    bar.ax.minorticks_off()
    bar.set_ticks([0.5, 0.8, 1.0, 1.25, 2.0], labels=["0.5", "0.8", "1", "1.25", "2"])
    fig.suptitle("P(roll > angle within the exposure) against an exact-spectrum sea, default ship (C11 representative)"
                 "\nblank: P_exact outside 1e-3–0.95 everywhere, or not run", fontsize=9)  # fmt: skip
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--methods", default=",".join(ALL_METHODS))
    parser.add_argument("--trials", type=int, default=20000, help="Monte Carlo trials a cell")
    parser.add_argument("--splitting-trials", type=int, default=1000)
    parser.add_argument(
        "--split-below", type=float, default=0.05, help="splitting where every P_ref is below"
    )
    parser.add_argument("--seed", type=int, default=42)
    parser.add_argument("--reference", default=REFERENCE)
    parser.add_argument("--json", default=OUT_JSON)
    parser.add_argument("--figure", default=FIGURE)
    parser.add_argument(
        "--from-json", default=None, help="summarise and draw stored results (comma-separated files: merged)"
    )
    parser.add_argument("--cells", default=None, help="comma-separated cell keys (default: every live cell)")
    args = parser.parse_args(argv)
    with open(args.reference) as f:
        ref = json.load(f)
    reference = ref["cells"]
    exposures = ref["protocol"]["exposures_h"]
    angles = ref["protocol"]["angles_deg"]
    if args.from_json:
        results = {}
        for path in args.from_json.split(","):  # runs of different methods, merged
            with open(path) as f:
                for m, cells in json.load(f)["results"].items():
                    results.setdefault(m, {}).update(cells)
    else:
        import jaxroll as jxr

        jxr.configure()
        jxr.enable_compilation_cache()
        results = {}
        if os.path.exists(args.json):
            with open(args.json) as f:
                results = json.load(f).get("results", {})
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
        live = [k for k, c in reference.items() if c["exceedances"]["3"]["25"] > 0]
        keys = args.cells.split(",") if args.cells else live
        for key in keys:
            cell = {k: reference[key][k] for k in ("hs", "t01", "heading_deg", "speed")}
            t = time.perf_counter()
            for m in methods:
                if key in results.get(m, {}):  # resumed: computed by an earlier run
                    continue
                if m in MC_METHODS:
                    results.setdefault(m, {})[key] = mc_probabilities(
                        cell, MC_METHODS[m], args.trials, args.seed, exposures, angles
                    )
                elif m == "splitting":
                    p_ref_max = max(c / reference[key]["trials"] for v in reference[key]["exceedances"].values()
                                    for c in v.values())  # fmt: skip
                    if p_ref_max < args.split_below:
                        results.setdefault(m, {})[key] = splitting_probabilities(
                            cell, args.splitting_trials, args.seed, exposures, angles
                        )
            if any(
                (m == "passage" or m.startswith("pstar-")) and key not in results.get(m, {}) for m in methods
            ):
                for m, v in theory_probabilities(cell, exposures, angles).items():
                    if m in methods:
                        results.setdefault(m, {})[key] = v
            print(f"{key} ({time.perf_counter() - t:.1f} s)", flush=True)
            tmp = args.json + ".tmp"
            with open(tmp, "w") as f:
                json.dump({"results": results, "command": "python benchmarks/validation_map.py " +
                           " ".join(argv or sys.argv[1:])}, f, indent=1)  # fmt: skip
            os.replace(tmp, args.json)
    summary = compare(reference, results)
    print_summary(summary)
    if "passage" in summary:
        for (si, ti), v in allowance(summary, reference).items():
            (ulo, uhi), (lo, hi) = SPEED_CLASSES[si], T01_BANDS[ti]
            text = "no entry" if v is None else f"f_below={v[0]:.3f} f_above={v[1]:.3f} ({v[2]} entries)"
            print(f"passage allowance (speed {ulo:g}-{uhi:g} m/s, T01 {lo:g}-{hi:g} s): {text}")
    if args.json and not args.from_json:
        with open(args.json) as f:
            stored = json.load(f)
        stored["summary"] = {m: {k: v for k, v in s.items() if k != "entries"} for m, s in summary.items()}
        with open(args.json, "w") as f:
            json.dump(stored, f, indent=1)
    draw(summary, reference, args.figure)
    print(f"figure={args.figure}")


if __name__ == "__main__":
    main()
