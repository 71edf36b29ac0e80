"""Benchmark: the full GZ(ζ_mid, φ) / ΔGM(ζ_mid) table of the shipped C11-like hull.

Measures `jaxroll.hull_hydrostatics` on the representative C11-like hull (46 stations × 31
waterlines) for 13 amplitudes × 15 heels: 195 free-trim balances for the table, plus the calm GZ curve, the 13
upright balances and GM slopes, the calm particulars and both polynomial fits. Compile time (first call) and
run time (best of repeats) are reported separately, plus the gradient of the fitted ΔGM coefficient C1 with
respect to a breadth scale factor. Target: seconds on a laptop CPU. Wall and CPU (process) times are both
printed: on a shared machine the wall time of the compilation mostly measures the other users.

Mesh hulls (issue 36): `--mesh` also times `jaxroll hydrostatics` end to end on a generated frigate-like STL
of about 3 500 triangles (tests/hull_meshes.py), each run a fresh process, cold (empty compilation cache) then warm
(the cache the cold run filled; `--warm-rounds` runs of each variant, taken in turn), for the exact surface (the
default) beside the sliced 61 × 41 offsets of jaxroll 0.1 (`--sliced`) and `jaxroll hydrostatics c11`, with wall
and CPU time and the load average (the machine is shared: compare CPU times and ratios within one run);
`--baseline-tree DIR` adds the exact surface run by another source tree (the code before a change:
`git archive COMMIT | tar -x -C DIR`); and the calm GZ of both against the exact answer at 0–70°. Each process
imports jaxroll from bytecode, as an installed jaxroll does (pip compiles it; here the
`__pycache__` folders beside each tree's sources, compiled before the cold runs, also where PYTHONDONTWRITEBYTECODE
is set, as on this project's machines): `--no-bytecode` removes them and compiles jaxroll's sources in every
process instead (≈ 0.2–0.5 s more a run).

Run: `python benchmarks/hydrostatics.py [--n-zeta 13] [--n-heel 15] [--repeat 10] [--mesh] [--mesh-only]
[--warm-rounds 3] [--baseline-tree DIR] [--no-bytecode]`.
Output: `name=value` lines.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll  # noqa: F401  (float64)
from jaxroll import c11_hull, hull_hydrostatics, loading_condition
from jaxroll.ship._fits import default_heel_grid, default_zeta_grid
from jaxroll.ship._hull import scale_hull
from jaxroll.ship._hydrostatics import c11_hull_loading


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-zeta", type=int, default=13)
    parser.add_argument("--n-heel", type=int, default=15)
    parser.add_argument("--repeat", type=int, default=10)
    parser.add_argument("--mesh", action="store_true", help="also the STL end-to-end comparison")
    parser.add_argument("--mesh-only", action="store_true", help="only the STL end-to-end comparison")
    parser.add_argument("--warm-rounds", type=int, default=3, help="warm runs of each CLI variant, in turn")
    parser.add_argument(
        "--baseline-tree",
        metavar="DIR",
        help="also time the exact surface with the jaxroll source tree in DIR (e.g. the code before a change)",
    )
    parser.add_argument(
        "--no-bytecode",
        action="store_true",
        help="compile jaxroll's sources in every process (its __pycache__ folders removed, none written)",
    )
    args = parser.parse_args()
    if args.mesh or args.mesh_only:
        mesh_benchmark(args.warm_rounds, args.baseline_tree, bytecode=not args.no_bytecode)
    if args.mesh_only:
        return

    hull = c11_hull()
    loading = c11_hull_loading()
    zeta = jnp.asarray(default_zeta_grid(6.0, args.n_zeta))
    heels = jnp.asarray(default_heel_grid(np.radians(70.0), args.n_heel))
    run = lambda: jax.block_until_ready(hull_hydrostatics(hull, loading, zeta_mid=zeta, heels=heels))

    t0, c0 = time.perf_counter(), time.process_time()
    sol = run()
    first, first_cpu = time.perf_counter() - t0, time.process_time() - c0
    best = min(timeit.repeat(run, number=1, repeat=args.repeat))
    balances = args.n_zeta * args.n_heel + args.n_heel + args.n_zeta + 1

    def c1(breadth):
        h = scale_hull(hull, breadth=breadth)
        ld = loading_condition(h, kg=loading.kg, draught=11.5)
        return hull_hydrostatics(h, ld, zeta_mid=zeta, heels=heels).delta_gm_coefficients[1]

    grad = jax.jit(jax.grad(c1))
    t0, c0 = time.perf_counter(), time.process_time()
    g = jax.block_until_ready(grad(jnp.asarray(1.0)))
    grad_first, grad_first_cpu = time.perf_counter() - t0, time.process_time() - c0
    grad_best = min(timeit.repeat(lambda: jax.block_until_ready(grad(jnp.asarray(1.0))), number=1, repeat=3))

    print(f"device={jax.devices()[0].platform}:{jax.devices()[0].device_kind}")
    print(f"dtype={sol.gz.dtype}")
    print(f"hull_stations={hull.stations.shape[0]}")
    print(f"hull_waterlines={hull.waterlines.shape[0]}")
    print(f"n_zeta={args.n_zeta}")
    print(f"n_heel={args.n_heel}")
    print(f"balances_per_call={balances}")
    print(f"table_compile_plus_first_run_s={first:.3f}")
    print(f"table_compile_plus_first_run_cpu_s={first_cpu:.3f}")
    print(f"table_run_s={best:.4f}")
    print(f"balances_per_s={balances / best:.0f}")
    print(f"all_converged={bool(jnp.all(sol.converged))}")
    print(f"max_relative_volume_error={float(sol.max_volume_error):.3e}")
    print(f"max_lcb_minus_lcg_m={float(sol.max_lcb_error):.3e}")
    print(f"gm0_m={float(sol.gm0):.5f}")
    for k, c in enumerate(np.asarray(sol.delta_gm_coefficients)):
        print(f"delta_gm_c{k}={c:.6g}")
    print(f"delta_gm_fit_rms_m={float(sol.delta_gm_fit_rms):.3e}")
    print(f"grad_c1_wrt_breadth={float(g):.6g}")
    print(f"grad_compile_plus_first_run_s={grad_first:.3f}")
    print(f"grad_compile_plus_first_run_cpu_s={grad_first_cpu:.3f}")
    print(f"grad_run_s={grad_best:.4f}")


def _cli_run(argv, env, cwd=None) -> tuple[float, float]:
    """(wall, CPU) seconds of one `jaxroll` process (CPU: user + system of the child, all its threads)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(argv, env=env, capture_output=True, text=True, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode:
        raise SystemExit(res.stderr[-2000:])
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def mesh_benchmark(warm_rounds: int = 3, baseline_tree: str | None = None, bytecode: bool = True) -> None:
    """`jaxroll hydrostatics` on the frigate STL, each run a fresh process: the exact surface, the sliced offsets
    (`--sliced`) and `jaxroll hydrostatics c11`, and optionally the exact surface of another source tree (e.g. the
    code before a change, `git archive COMMIT | tar -x -C DIR`), each with its own compilation cache: cold once, then
    `warm_rounds` warm runs taken in turn (so that every variant sees the same machine load). Prints wall and CPU
    time (user + system of the process) and the load average. `bytecode`: the processes import jaxroll from
    bytecode compiled before the cold runs (as pip leaves an installed package), in each tree's `__pycache__`."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import hull_meshes

    from jaxroll import gz_curve, io

    with tempfile.TemporaryDirectory() as tmp:
        stl = io.write_stl(Path(tmp) / "frigate.stl", hull_meshes.frigate(dome=3.0))
        print(f"mesh_triangles={io.read_stl(stl).shape[0]}")
        argv = [sys.executable, "-m", "jaxroll", "hydrostatics", str(stl), "--lpp", "142", "--x-ap", "0",
                "--draught", "6.15", "--kg", "7.555", "--roll-period", "12"]  # fmt: skip
        c11 = [sys.executable, "-m", "jaxroll", "hydrostatics", "c11"]
        variants = {"exact": (argv, None), "sliced": ([*argv, "--sliced"], None), "c11": (c11, None)}
        if baseline_tree is not None:
            variants["baseline_exact"] = (argv, str(Path(baseline_tree).resolve()))
        envs, cwds = {}, {}
        here = str(Path(__file__).resolve().parents[1])
        print(
            f"bytecode={'compiled before the runs' if bytecode else 'none (sources compiled in every run)'}"
        )
        for label, (cmd, tree) in variants.items():
            env = {**os.environ, "JAXROLL_CACHE_DIR": str(Path(tmp) / f"cache-{label}")}
            # `python -m` imports from the working folder first: run each tree's jaxroll from its own root
            env["PYTHONPATH"] = tree or here
            if (
                bytecode
            ):  # as installed: jaxroll's bytecode beside its sources (__pycache__), compiled before the runs
                env.pop("PYTHONDONTWRITEBYTECODE", None)
                env.pop("PYTHONPYCACHEPREFIX", None)  # (a prefix would also miss the libraries' own bytecode)
                subprocess.run([sys.executable, "-m", "compileall", "-q", str(Path(tree or here) / "jaxroll")],
                               env=env, check=True, capture_output=True)  # fmt: skip
            else:  # the sources compiled in every process: no bytecode of jaxroll to read, none written
                env["PYTHONDONTWRITEBYTECODE"] = "1"
                for cache in (Path(tree or here) / "jaxroll").rglob("__pycache__"):
                    shutil.rmtree(cache)
            envs[label], cwds[label] = env, tree or here
            wall, cpu = _cli_run([*cmd, "--out", str(Path(tmp) / f"out-{label}")], env, cwds[label])
            print(f"cli_{label}_cold_s={wall:.2f} cpu={cpu:.2f} load={os.getloadavg()[0]:.1f}")
        for k in range(warm_rounds):
            for label, (cmd, _) in variants.items():
                wall, cpu = _cli_run(
                    [*cmd, "--out", str(Path(tmp) / f"out-{label}")], envs[label], cwds[label]
                )
                print(f"cli_{label}_warm{k}_s={wall:.2f} cpu={cpu:.2f} load={os.getloadavg()[0]:.1f}")
        # calm GZ of the sliced offsets and of the exact surface, KG = 7.555 m at d = 6.15 m
        phi = jnp.radians(jnp.arange(0.0, 75.0, 5.0))
        curves = {}
        for label, exact in (("sliced", False), ("exact", True)):
            h = io.read_stl_hull(stl, lpp=142.0, x_ap=0.0, exact=exact)
            curves[label] = np.asarray(gz_curve(h, loading_condition(h, kg=7.555, draught=6.15), phi))
        err = curves["sliced"] - curves["exact"]
        print("gz_heel_deg=" + ",".join(f"{v:g}" for v in np.degrees(np.asarray(phi))))
        print("gz_exact_m=" + ",".join(f"{v:.4f}" for v in curves["exact"]))
        print("gz_sliced_minus_exact_mm=" + ",".join(f"{1000 * v:.1f}" for v in err))


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
