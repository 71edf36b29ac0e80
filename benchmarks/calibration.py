"""Benchmark: time-domain calibration of one free-running roll record, multiple shooting vs the Kalman filter.

The record is tests/test_time_domain.py's: the default ship with r = 0.8, ITTC H1/3 = 7 m, T01 = 10 s, 120 s model
(1200 s full scale) at 20 Hz, roll noise 0.05°, probe noise 0.1 mm, seed 2; (b1, b2, r) fitted from the ship's
values. Each estimator's first call (tracing and compilation included) and its later calls are timed separately,
with the estimates, so that a change in speed can be checked not to change the numbers (docs/calibration.md, "Which
estimator when").

With `--decay [--baseline-tree DIR]`: `jaxroll calibrate decay` end to end as a user waits (fresh processes, one
cache: the first run cold, the next ones warm) on a 100 Hz, 200 s model-scale decay record (KVLCC2-like, 1:68,
Tφ 21 s, b = (0.002, 0.045, 0)): a clean one released at t = 0 (a jaxroll record, which the code before issue 43
also reads) and, for the current tree only, the realistic lab file (9 s at rest, 0.3° offset, noise, drift, radians
with a units file). `--baseline-tree DIR` times the same command with PYTHONPATH=DIR (e.g. `git worktree add
/tmp/base acdbadf`), alternated with the current tree run by run. Wall and CPU seconds (user + system of the
child: on a shared host, the CPU time is the steadier figure). Target (issue 43): warm <= 3 s.

Run: `python benchmarks/calibration.py [--repeat 2]`. Output: `name=value` lines.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp

import jaxroll as jxr
from jaxroll.calibration import fit_roll_kalman, fit_roll_time_domain, virtual_roll_record

PARAMS = ("b1", "b2", "gm_correction")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="timed calls after the first (2)")
    parser.add_argument("--decay", action="store_true", help="time `jaxroll calibrate decay` instead")
    parser.add_argument(
        "--baseline-tree", default=None, help="--decay: a tree of the code before, side by side"
    )
    args = parser.parse_args()
    if args.decay:
        return decay_cli(args)

    ship = jxr.c11_representative()
    truth = eqx.tree_at(lambda s: s.gm_correction, ship, jnp.asarray(0.8))
    record, _ = virtual_roll_record(
        truth, jxr.ITTC(7.0, 10.0), seed=2, duration_model_s=120.0, roll_noise_deg=0.05, wave_noise_mm=0.1
    )
    for name, fit in (("shooting", fit_roll_time_domain), ("kalman", fit_roll_kalman)):
        times = []
        for _ in range(1 + args.repeat):
            t0 = time.perf_counter()
            result = fit(ship, record, params=PARAMS)
            times.append(time.perf_counter() - t0)
        print(f"{name}_first_call_s={times[0]:.2f}")
        print(f"{name}_fit_s={min(times[1:]):.2f}")
        for k in PARAMS:
            e = result.estimates[k]
            print(f"{name}_{k}={e.value:.6g}")
            print(f"{name}_{k}_std_error={e.std_error:.2g}")


def _decay_records(folder: Path) -> tuple[Path, Path]:
    from jaxroll.calibration import virtual_decay_record, write_lab_file
    from jaxroll.io import save_record

    ship = eqx.tree_at(
        lambda s: (s.roll_period, s.damping),
        jxr.c11_representative(),
        (jnp.asarray(21.0), jnp.asarray([0.002, 0.045, 0.0])),
    )
    common = dict(initial_roll_deg=9.0, scale=68.0, sampling_hz=100.0, roll_noise_deg=0.01, max_dt=0.05)
    clean = save_record(virtual_decay_record(ship, duration_model_s=200.0, **common), folder / "clean.csv")
    lab = virtual_decay_record(
        ship, duration_model_s=189.5, rest_model_s=9.0, roll_offset_deg=0.3, drift_deg_per_min=0.01, **common
    )
    return clean, write_lab_file(lab, folder / "lab.csv")[0]


def _timed(cmd, env, cwd) -> tuple[float, float, subprocess.CompletedProcess]:
    """(wall seconds, CPU seconds of the child: user + system, the completed process). Run in `cwd`, away from any
    tree: `python -m` puts the working directory first on the path, before PYTHONPATH (the baseline measured before
    issue 43's fix was the current tree's code when run from the repository)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), done


def decay_cli(args) -> None:
    folder = Path(tempfile.mkdtemp(prefix="jaxroll-bench-decay-"))
    clean, lab = _decay_records(folder)
    here = str(Path(__file__).resolve().parents[1])
    trees = {"current": here, **({"baseline": args.baseline_tree} if args.baseline_tree else {})}
    cases = {"clean": [str(clean)], "lab": [str(lab), "--time", "time", "--roll", "phi", "--scale", "68",
                                           "--units-file", str(lab.with_name("lab_units.csv"))]}  # fmt: skip
    runs = [
        (t, c) for c in cases for t in trees if not (t == "baseline" and c == "lab")
    ]  # before: no release found
    times: dict = {run: [] for run in runs}
    print(f"load_average_before={os.getloadavg()[0]:.2f}")
    for _ in range(
        1 + args.repeat
    ):  # the trees alternated, so that both see the same minutes of a shared host
        for tree_name, case in runs:
            if times[tree_name, case] is None:
                continue
            env = {
                **os.environ,
                "PYTHONPATH": trees[tree_name],
                "JAXROLL_CACHE_DIR": str(folder / f"cache-{tree_name}"),
            }
            cmd = [
                sys.executable,
                "-m",
                "jaxroll",
                "calibrate",
                "decay",
                *cases[case],
                "--out",
                str(folder / "out"),
            ]
            wall, cpu, done = _timed(cmd, env, folder)
            if done.returncode:
                print(f"{tree_name}_{case}_error={done.stderr.strip().splitlines()[-1]}")
                times[tree_name, case] = None
                continue
            times[tree_name, case].append((wall, cpu))
    for (tree_name, case), t in times.items():
        if not t:
            continue
        print(f"{tree_name}_{case}_cold_s={t[0][0]:.2f} cpu_s={t[0][1]:.2f}")
        if len(t) > 1:
            warm = min(t[1:])
            print(f"{tree_name}_{case}_warm_s={warm[0]:.2f} cpu_s={min(c for _, c in t[1:]):.2f}")
    print(f"load_average_after={os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
