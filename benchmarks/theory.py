"""Time of each theoretical amplitude PDF: the `jaxroll theory` command cold and warm, in-process calls, and a
vmapped sweep of the moment method over sea states; then the Monte Carlo of the same case.

Default ship, ITTC H1/3 = 7 m, T01 = 10 s. Targets on the 2-core CPU (issue 14): `jaxroll theory` ≤ 10 s cold
and ≤ 3 s warm for the paper's three theories (Roberts, ESAM, moment method); a vmapped sweep of 50 sea states
costing little more than one. "cold" is a new process with an empty compilation cache (JAXROLL_CACHE_DIR a fresh
folder), "warm" a second new process with the cache the first one filled; both are wall times of the whole
command (import, set-up, theories, figures, JSON), with the process's CPU time and the load average beside them
(the machine is shared: compare CPU times when the load is high). Before issue 14 the moment method took 28 s cold
and 34 s warm (`jaxroll theory --theory moment`, same machine, idle).

`--sweep N` times `jax.vmap` of the moment method's E[φ²] (order `--sweep-order`, default 4) over N sea states
(H1/3 `--sweep-hs`, default 6.5–8 m) against the same vmapped program on one sea state and against one
unbatched call, after compilation and as a user waits (the first call: compilation and run), and counts the sea states that needed the relaxation (the batch then runs it once for all).
The Monte Carlo line is the paper's 10⁴ × 3600 s protocol (`--quick`: 10³ × 1800 s; `--skip-mc`: none).

Usage: python benchmarks/theory.py [--quick] [--skip-mc] [--skip-cli] [--cli-sets roberts,esam,moment;...]
                                   [--sweep N] [--sweep-order 4] [--sweep-hs 6.5,8.0]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll
from jaxroll import theory

CLI_SETS = (
    "roberts,esam,moment",
    "roberts,esam,moment,envelope_fpk",
    "roberts",
    "esam",
    "moment",
    "envelope_fpk",
)


def timed(fn, repeat: int = 3):
    t0 = time.perf_counter()
    out = jax.block_until_ready(fn())
    first = time.perf_counter() - t0
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn())
        runs.append(time.perf_counter() - t0)
    return out, first, min(runs)


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def cli_times(names: str, warm_runs: int = 2) -> dict:
    """Wall and CPU time of `jaxroll theory --theory NAMES` in new processes: cold (empty cache), then warm
    (`warm_runs` times, the least kept)."""
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "JAXROLL_CACHE_DIR": os.path.join(tmp, "xla")}
        out = []
        for i in range(1 + warm_runs):
            cmd = [
                sys.executable,
                "-m",
                "jaxroll",
                "theory",
                "--theory",
                names,
                "--out",
                os.path.join(tmp, f"o{i}"),
            ]
            t0, c0 = time.perf_counter(), _child_cpu()
            subprocess.run(cmd, env=env, check=True, capture_output=True)
            out.append((time.perf_counter() - t0, _child_cpu() - c0))
    warm = min(out[1:])
    return {"cold_s": out[0][0], "cold_cpu_s": out[0][1], "warm_s": warm[0], "warm_cpu_s": warm[1]}


def sweep_times(ship, n: int, order: int, hs_range=(6.5, 8.0)) -> dict:
    """Moment method E[φ²] for `n` sea states (H1/3 over `hs_range` [m]) in one vmapped call, the same vmapped
    program on one sea state, and one unbatched jitted call [s], after compilation; and how many of the `n` needed
    the relaxation (Newton from the Gaussian start failed): the batch runs it once if any member needs it."""
    hs = np.linspace(*hs_range, n)
    filters = [
        jaxroll.fit_filter(jaxroll.EffectiveWave(jaxroll.ITTC(float(h), 10.0), ship.lpp), order=4,
                           match_frequency=2 * ship.omega0).filter
        for h in hs
    ]  # fmt: skip
    stacked = jax.tree.map(lambda *x: jnp.stack(x), *filters)

    def e_phi2(f):
        sol = theory.roll_moments(ship, None, shaping_filter=f, closure_order=order, throw=False)
        return sol.moment((2,) + (0,) * (sol.equations.tables.dim - 1))

    def relaxed(f):
        return (
            theory.roll_moments(ship, None, shaping_filter=f, closure_order=order, throw=False).relax_steps
            > 0
        )

    single = jax.jit(e_phi2)
    batched = jax.jit(jax.vmap(e_phi2))
    one = jax.tree.map(lambda x: x[:1], stacked)
    _, first_single, t_single = timed(lambda: single(filters[0]), repeat=3)
    _, _, t_one = timed(lambda: batched(one), repeat=3)
    values, first_n, t_n = timed(lambda: batched(stacked), repeat=2)
    loop = np.array([float(single(f)) for f in filters[:: max(1, n // 5)]])
    np.testing.assert_allclose(np.asarray(values)[:: max(1, n // 5)], loop, rtol=1e-10)
    n_relaxed = int(np.sum(jax.jit(jax.vmap(relaxed))(stacked)))
    return {
        "single_s": t_single,
        "vmap_one_s": t_one,
        "vmap_n_s": t_n,
        "n": n,
        "n_relaxed": n_relaxed,
        "single_first_s": first_single,
        "vmap_n_first_s": first_n,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--skip-mc", action="store_true")
    parser.add_argument("--skip-cli", action="store_true")
    parser.add_argument(
        "--cli-sets",
        default=";".join(CLI_SETS[:2]),
        help="';'-separated --theory values to time (default: the paper's three; all four)",
    )
    parser.add_argument("--sweep", type=int, default=50)
    parser.add_argument("--sweep-order", type=int, default=4)
    parser.add_argument("--sweep-hs", default="6.5,8.0", help="H1/3 range of the sweep [m] (6.5,8.0)")
    args = parser.parse_args()
    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    wave = jaxroll.EffectiveWave(sea, ship.lpp)
    print(f"device={jax.devices()[0].device_kind}, cores={os.cpu_count()}, case: default ship, H1/3 = 7 m, "
          f"T01 = 10 s; load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    if not args.skip_cli:
        for names in args.cli_sets.split(";"):
            t = cli_times(names)
            print(f"cli[{names}] cold {t['cold_s']:.1f} s (CPU {t['cold_cpu_s']:.1f} s), warm {t['warm_s']:.1f} s "
                  f"(CPU {t['warm_cpu_s']:.1f} s); load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    cases = {
        "roberts": lambda: theory.roberts_pdf(ship, wave, restoring="nonlinear").log_density,
        "esam": lambda: theory.esam_pdf(ship, wave).log_density,
        "moment": lambda: theory.moment_pdf(ship, wave, closure_order=6).e_phi2,
        "envelope_fpk": lambda: theory.envelope_fpk_pdf(ship, wave).mass,
    }
    for name, fn in cases.items():
        _, first, run = timed(fn, repeat=3)
        print(f"{name}_first_call_s={first:.2f} {name}_run_s={run:.3f}")
    if args.sweep > 0:
        hs_range = tuple(float(x) for x in args.sweep_hs.split(","))
        t = sweep_times(ship, args.sweep, args.sweep_order, hs_range)
        print(f"moment_sweep_order{args.sweep_order} H1/3 {hs_range[0]:g}-{hs_range[1]:g} m: one sea state "
              f"{t['single_s']:.3f} s (vmapped program on one: {t['vmap_one_s']:.3f} s), {t['n']} vmapped "
              f"{t['vmap_n_s']:.2f} s = x{t['vmap_n_s'] / t['single_s']:.1f} one call (a loop: x{t['n']}); "
              f"{t['n_relaxed']} of {t['n']} needed the relaxation; load average {os.getloadavg()[0]:.1f}")  # fmt: skip
        print(f"moment_sweep_order{args.sweep_order} as a user waits (first call: compile + run): one sea state "
              f"{t['single_first_s']:.2f} s, {t['n']} vmapped {t['vmap_n_first_s']:.2f} s = "
              f"x{t['vmap_n_first_s'] / t['single_first_s']:.2f}")  # fmt: skip
    if args.skip_mc:
        return
    n, duration = (1000, 1800.0) if args.quick else (10_000, 3600.0)
    problem = jaxroll.RollProblem.from_sea(ship, sea, dt=0.5)
    jaxroll.monte_carlo_amplitudes(
        problem, jax.random.key(0), num_realizations=min(n, 1000), duration=duration
    )
    t0 = time.perf_counter()
    stats = jaxroll.monte_carlo_amplitudes(problem, jax.random.key(0), num_realizations=n, duration=duration)
    mc = time.perf_counter() - t0
    print(
        f"monte_carlo_run_s={mc:.2f} ({n} x {duration:g} s), mean envelope amplitude "
        f"{np.rad2deg(stats.mean('envelope')):.2f} deg, E[phi^2] {stats.phi_moments()['E_phi2']:.4f} rad^2"
    )


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
