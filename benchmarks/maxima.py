"""The paper's largest maxima protocol: N0 = 10⁴ amplitudes per trial, N = 5·10³ trials (≈ 6·10⁸ s simulated).

Amplitudes are reduced on the fly (no time series kept), so memory is bounded by the chunk size, and a trial stops
once it has its N0 amplitudes (the chunk runs until its last trial has them). Prints the compile time, run time,
realization-steps per second of the nominal duration (1.6 N0 half periods: an upper bound on the steps simulated)
and peak memory; `--quick` runs N0 = 10³, N = 500.

Usage: python benchmarks/maxima.py [--quick]
"""

from __future__ import annotations

import argparse
import resource
import time

import jax
import numpy as np

import jaxroll
from jaxroll import default_duration, monte_carlo_maxima


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    n0, n_trials = ((1000,), 500) if args.quick else ((10_000,), 5000)
    ship = jaxroll.c11_representative()
    problem = jaxroll.RollProblem.from_sea(ship, jaxroll.ITTC(7.0, 10.0), dt=0.5)
    duration = default_duration(problem, n0, 500.0)
    steps = n_trials * duration / problem.dt
    print(
        f"device={jax.devices()[0].device_kind}, N0={n0[0]}, trials={n_trials}, duration_s={duration:.0f}, "
        f"nominal simulated_s={n_trials * duration:.3e}, realization_steps={steps:.3e}"
    )
    t0 = time.perf_counter()
    monte_carlo_maxima(problem, jax.random.key(1), n0=n0, num_realizations=8, chunk_size=8, duration=2000.0)
    print(f"compile_s={time.perf_counter() - t0:.2f}  (small problem, same kernel)")
    t0 = time.perf_counter()
    stats = monte_carlo_maxima(problem, jax.random.key(0), n0=n0, num_realizations=n_trials)
    run = time.perf_counter() - t0
    x = stats.maxima_deg[stats.valid(0), 0]
    print(f"run_s={run:.1f}")
    print(f"nominal_realization_steps_per_s={steps / run:.3e}")
    print(f"peak_rss_mb={resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")
    print(
        f"mean_max_deg={np.mean(x):.2f} q99_deg={np.quantile(x, 0.99):.2f} valid={x.size} "
        f"capsized_before_N0={stats.n_capsized_before(0)} incomplete={stats.n_incomplete(0)}"
    )


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
