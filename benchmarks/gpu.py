"""Monte Carlo throughput on an accelerator: the paper protocol and 10⁶ × 3600 s, with the scaling over N.

Runs the default ship in the paper's 7 m sea (ITTC, T01 = 10 s, dt 0.5 s, order-4 filter) on the first device JAX
sees, for the two Monte Carlos the CLI runs: `amplitudes` (zero-crossing + envelope histograms, what `jaxroll pdf`
does; keeps the roll history of a chunk for the Hilbert envelope) and `max` (largest |φ| per trial, what `jaxroll
sweep`/`risk` do; keeps no history). Compile time is reported apart from run time; the realization-steps per second
is the figure of merit. Prints `name=value` lines.

`--chunk-sweep 25000,200000` then times N = sweep-n (10⁶) again with each further chunk size (both Monte Carlos), and
the library's own choice (`chunk_size=None`: `jaxroll.default_chunk_size`, cut to the memory budget) last.

Usage: JAX_PLATFORMS=cuda python benchmarks/gpu.py [--max-n 1000000] [--chunk 100000] [--chunk-sweep 25000,200000]
       [--quick]
"""

from __future__ import annotations

import argparse
import time

import jax
import numpy as np

import jaxroll


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def peak_memory(dev, chunk, steps) -> str:
    """The device's peak memory so far [GB] and per realization-step of `chunk` [B] (sizes ascending: the peak is
    the last, largest chunk's), or "" where the device keeps no statistics."""
    stats = dev.memory_stats() or {}
    if "peak_bytes_in_use" not in stats or not isinstance(chunk, int):
        return ""
    peak = stats["peak_bytes_in_use"]
    return f" peak_GB={peak / 1e9:.1f} peak_B_per_step={peak / (chunk * steps):.1f}"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--max-n", type=int, default=1_000_000)
    p.add_argument("--chunk", type=int, default=100_000, help="realizations per chunk for `amplitudes`")
    p.add_argument("--chunk-max", type=int, default=250_000, help="realizations per chunk for `max`")
    p.add_argument("--duration", type=float, default=3600.0)
    p.add_argument(
        "--chunk-sweep", default="", help="comma-separated further chunk sizes to time at N = sweep-n"
    )
    p.add_argument("--sweep-n", type=int, default=1_000_000, help="realizations of the chunk-size sweep")
    p.add_argument("--kinds", default="amplitudes,max", help="which Monte Carlos to time")
    p.add_argument("--min-n", type=int, default=1_000, help="the smallest N of the scaling")
    p.add_argument("--quick", action="store_true", help="N ≤ 2000, 600 s (a smoke run on a CPU)")
    args = p.parse_args()
    if args.quick:
        args.max_n, args.chunk, args.chunk_max, args.duration = 2000, 1000, 2000, 600.0
    dev = jax.devices()[0]
    print(f"device={dev.device_kind} platform={dev.platform} jax={jax.__version__}")
    problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0), dt=0.5)
    steps = int(round(args.duration / problem.dt))
    key = jax.random.key(0)
    ns = [n for n in (1_000, 10_000, 100_000, 1_000_000, 10_000_000) if args.min_n <= n <= args.max_n]
    for kind, chunk in (("amplitudes", args.chunk), ("max", args.chunk_max)):
        if kind not in args.kinds.split(","):
            continue

        def run(n, chunk=chunk, kind=kind):  # chunk None: the library's own choice
            c = None if chunk is None else min(chunk, n)
            if kind == "amplitudes":
                return jaxroll.monte_carlo_amplitudes(
                    problem, key, num_realizations=n, duration=args.duration, chunk_size=c
                )
            return jaxroll.monte_carlo_max_roll(
                problem, key, angle_deg=30.0, num_realizations=n, duration=args.duration, chunk_size=c
            )

        # compile on the first chunk shape, then time each N (the chunk shape is the same, so no recompile
        # unless N < chunk)
        _, t_first = timed(lambda: run(min(chunk, ns[-1])))
        print(f"{kind}_first_call_s={t_first:.2f} (compile + one chunk of {min(chunk, ns[-1])})")
        times = []
        for n in ns:
            if n < chunk:  # a chunk of n: a program of its own, compiled by a first call
                _, t_compile = timed(lambda n=n: run(n))
                print(f"{kind}_N={n} first_call_s={t_compile:.2f} (compile + run)")
            stats, t = timed(lambda n=n: run(n))
            times.append(t)
            rate = n * steps / t
            extra = ""
            if kind == "amplitudes":
                extra = f" mean_env_deg={np.rad2deg(stats.mean('envelope')):.3f}"
            print(f"{kind}_N={n} time_s={t:.3f} steps_per_s={rate:.3e} capsized={stats.n_capsized}{extra}")
        if len(ns) >= 3:
            b = np.polyfit(np.log(ns[1:]), np.log(times[1:]), 1)[0]
            print(f"{kind}_time_exponent_N={b:.3f}")
        n = min(args.sweep_n, ns[-1])
        for c in [int(x) for x in args.chunk_sweep.split(",") if x] + [None]:
            if c is not None and c > n:
                continue
            label = "default" if c is None else str(c)
            try:
                _, t_first = timed(lambda c=c: run(n, c))
                stats, t = timed(lambda c=c: run(n, c))
            except Exception as e:  # out of device memory: say so and go on to the next size
                print(f"{kind}_N={n} chunk={label} failed: {type(e).__name__}: {str(e)[:200]}")
                continue
            used = stats.config["chunk_size"]
            print(
                f"{kind}_N={n} chunk={label} (used {used}) first_call_s={t_first:.2f} time_s={t:.3f} "
                f"steps_per_s={n * steps / t:.3e}{peak_memory(dev, used, steps)}"
            )


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
