"""Monte Carlo cost against the number of realizations N and the simulated duration: is it linear?

Runs the amplitude Monte Carlo (`--kind amplitudes`, the `jaxroll pdf` work) or the per-trial maximum
(`--kind max`, the `jaxroll sweep` work) of the default ship in the paper's 7 m sea (ITTC, T01 = 10 s)
for N = 1e3, 3e3, 1e4, ... up to `--max-n`, then for durations 600 ... 3600 s at fixed N, on every device
JAX sees (sharded over them by `jaxroll.roll._sharding.run_chunks`). Compile time (first call of each shape) is reported apart from
run time. The N scan stops before a run whose predicted time would overrun `--budget-s`.

Prints `name=value` lines, ending with the fitted exponents b of time ~ N^b and time ~ duration^b
(1 = linear).

Usage: python benchmarks/scaling.py [--quick] [--max-n 1000000] [--kind amplitudes|max] [--budget-s 480]
       JAX_PLATFORMS=cuda python benchmarks/scaling.py --chunk-size 100000     (on a GPU)
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

import jaxroll
from jaxroll import monte_carlo_max_roll


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--quick", action="store_true", help="N ≤ 10⁴, durations 600–1800 s at N = 1000 (~1 min)"
    )
    parser.add_argument("--max-n", type=int, default=1_000_000, help="largest N of the N scan (10⁶)")
    parser.add_argument(
        "--kind", choices=("amplitudes", "max"), default="amplitudes", help="which Monte Carlo"
    )
    parser.add_argument("--chunk-size", type=int, default=1000, help="realizations per compiled chunk (1000)")
    parser.add_argument("--duration", type=float, default=600.0, help="duration of the N scan [s] (600)")
    parser.add_argument("--budget-s", type=float, default=480.0, help="wall-time budget of the whole run [s]")
    parser.add_argument("--devices", type=int, default=None, help="use the first N devices (default: all)")
    args = parser.parse_args()
    t_start = time.perf_counter()

    problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0), dt=0.5)
    key = jax.random.key(0)
    dt = problem.dt

    def run(n: int, duration: float) -> float:
        t0 = time.perf_counter()
        if args.kind == "amplitudes":
            jaxroll.monte_carlo_amplitudes(
                problem,
                key,
                num_realizations=n,
                duration=duration,
                chunk_size=args.chunk_size,
                devices=args.devices,
            )
        else:
            monte_carlo_max_roll(
                problem,
                key,
                angle_deg=30.0,
                num_realizations=n,
                duration=duration,
                chunk_size=args.chunk_size,
                devices=args.devices,
            )
        return time.perf_counter() - t0  # results come back as host arrays: the work is done

    def timed(n: int, duration: float) -> float:
        """Run time [s]: the best of 3 for runs under 3 s (a loaded machine adds noise), else one run."""
        seconds = run(n, duration)
        return min([seconds, run(n, duration), run(n, duration)]) if seconds < 3.0 else seconds

    devices = jax.devices()[: args.devices] if args.devices else jax.devices()
    print(f"device={devices[0].device_kind}")
    print(f"backend={jax.default_backend()}")
    print(f"devices={len(devices)}")
    print(f"processes={jax.process_count()}")
    print("dtype=float64")
    print(f"kind={args.kind}")
    print(f"chunk_size={args.chunk_size}")
    print(f"dt_s={dt}")

    def report(tag: str, n: int, duration: float, seconds: float) -> None:
        steps = int(round(duration / dt))
        print(
            f"{tag} n={n} duration_s={duration:g} steps={steps} time_s={seconds:.3f} "
            f"realization_steps_per_s={n * steps / seconds:.3e}"
        )

    # ---- N scan (compile once at the chunk shape) ----
    warm_n = min(args.chunk_size, 1000)
    first = run(warm_n, args.duration)
    print(f"compile_and_first_call_s={first:.2f}  (n={warm_n}, duration_s={args.duration:g})")
    max_n = min(args.max_n, 10_000) if args.quick else args.max_n
    candidates = [n for e in range(3, 8) for n in (10**e, 3 * 10**e) if n <= max_n]
    ns, times = [], []
    for n in candidates:
        if times:
            predicted = times[-1] * n / ns[-1]
            left = args.budget_s - (time.perf_counter() - t_start)
            if predicted > 0.5 * left:  # keep half the budget for the duration scan
                print(f"skipped n={n}: predicted {predicted:.0f} s, {left:.0f} s of the budget left")
                break
        seconds = timed(n, args.duration)
        ns.append(n)
        times.append(seconds)
        report("n_scan", n, args.duration, seconds)

    # ---- duration scan (each duration is a new shape: compile first) ----
    n_dur = 1000 if args.quick else min(10_000, max(ns))
    durations = (600.0, 1200.0, 1800.0) if args.quick else (600.0, 1200.0, 1800.0, 3600.0)
    dts = []
    for duration in durations:
        compile_s = run(min(args.chunk_size, n_dur), duration)
        seconds = timed(n_dur, duration)
        dts.append(seconds)
        report("duration_scan", n_dur, duration, seconds)
        print(f"duration_scan_compile_and_first_call_s={compile_s:.2f}  (duration_s={duration:g})")

    def exponent(x, y) -> float:
        return float(np.polyfit(np.log(x), np.log(y), 1)[0])

    # Below one chunk per device, time is not yet proportional to N (a chunk costs the same however full).
    fit = [(n, t) for n, t in zip(ns, times, strict=True) if n >= args.chunk_size]
    if len(fit) >= 2:
        print(f"exponent_time_vs_n={exponent(*zip(*fit, strict=True)):.3f}  (1 = linear; n >= chunk_size)")
    print(f"exponent_time_vs_duration={exponent(durations, dts):.3f}  (1 = linear)")
    if ns:
        print(f"realization_steps_per_s_at_largest_n={ns[-1] * round(args.duration / dt) / times[-1]:.3e}")
    print(f"total_wall_s={time.perf_counter() - t_start:.1f}")


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
