"""Time of each theoretical amplitude PDF: the `jaxroll theory` command cold and warm, in-process calls, and a
vmapped sweep of the moment method over sea states; then the Monte Carlo of the same case.

Default ship, ITTC H1/3 = 7 m, T01 = 10 s. Targets on the 2-core CPU (issue 14): `jaxroll theory` ≤ 10 s cold
and ≤ 3 s warm per theory; a vmapped sweep of 50 sea states costing little more than one. "cold" is a new
process with an empty compilation cache (JAXROLL_CACHE_DIR a fresh folder), "warm" a second new process with the
cache the first one filled. Before issue 14 the moment method took 28 s cold and 34 s warm (`jaxroll theory
--theory moment`, same machine, idle; measured at the start of the work, the old code path no longer exists).
The Monte Carlo line is the paper's 10⁴ × 3600 s protocol (`--quick`: 10³ × 1800 s; `--skip-mc`: none).

Usage: python benchmarks/theory.py [--quick] [--skip-mc] [--skip-cli] [--sweep N] [--sweep-order 4]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll
from jaxroll import theory


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


def cli_times(name: str) -> tuple[float, float]:
    """Wall time of `jaxroll theory --theory NAME` in a new process: cold (empty cache), then warm."""
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "JAXROLL_CACHE_DIR": os.path.join(tmp, "xla")}
        out = []
        for i in range(2):
            cmd = [
                sys.executable,
                "-c",
                "import sys; from jaxroll._cli import main; sys.exit(main())",
                "theory",
                "--theory",
                name,
                "--out",
                os.path.join(tmp, f"o{i}"),
            ]
            t0 = time.perf_counter()
            subprocess.run(cmd, env=env, check=True, capture_output=True)
            out.append(time.perf_counter() - t0)
    return out[0], out[1]


def sweep_times(ship, n: int, order: int) -> tuple[float, float, float]:
    """Moment method E[φ²] for one sea state and for `n` (H1/3 from 6.5 to 8 m) in one vmapped call [s]:
    (one, n vmapped, one again after compilation); compile included in neither of the last two."""
    hs = np.linspace(6.5, 8.0, n)
    filters = [
        jaxroll.fit_filter(jaxroll.EffectiveWave(jaxroll.ITTC(float(h), 10.0), ship.lpp), order=4,
                           match_frequency=2 * ship.omega0).filter
        for h in hs
    ]  # fmt: skip
    stacked = jax.tree.map(lambda *x: jnp.stack(x), *filters)

    @jax.jit
    def e_phi2(f):
        sol = theory.roll_moments(ship, None, shaping_filter=f, closure_order=order, throw=False)
        return sol.moment((2,) + (0,) * (sol.equations.tables.dim - 1))

    batched = jax.jit(jax.vmap(e_phi2))
    one = jax.tree.map(lambda x: x[:1], stacked)
    _, _, t_one = timed(lambda: batched(one), repeat=2)
    _, _, t_n = timed(lambda: batched(stacked), repeat=1)
    return t_one, t_n, n


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--skip-mc", action="store_true")
    parser.add_argument("--skip-cli", action="store_true")
    parser.add_argument("--sweep", type=int, default=50)
    parser.add_argument("--sweep-order", type=int, default=4)
    args = parser.parse_args()
    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    wave = jaxroll.EffectiveWave(sea, ship.lpp)
    print(f"device={jax.devices()[0].device_kind}, cores={os.cpu_count()}, case: default ship, H1/3 = 7 m, "
          f"T01 = 10 s; load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    if not args.skip_cli:
        for name in ("roberts", "esam", "moment"):
            cold, warm = cli_times(name)
            print(f"cli_{name}_cold_s={cold:.1f} cli_{name}_warm_s={warm:.1f}")
    cases = {
        "roberts": lambda: theory.roberts_pdf(ship, wave, restoring="nonlinear").log_density,
        "esam": lambda: theory.esam_pdf(ship, wave).log_density,
        "moment": lambda: theory.moment_pdf(ship, wave, closure_order=6).e_phi2,
    }
    for name, fn in cases.items():
        _, first, run = timed(fn, repeat=3)
        print(f"{name}_first_call_s={first:.2f} {name}_run_s={run:.3f}")
    if args.sweep > 0:
        t_one, t_n, n = sweep_times(ship, args.sweep, args.sweep_order)
        print(f"moment_sweep_order{args.sweep_order}: one sea state {t_one:.2f} s, {n} vmapped {t_n:.2f} s "
              f"(x{t_n / t_one:.1f} for x{n} the work)")  # fmt: skip
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
    main()
