"""Peak memory of a Monte Carlo chunk per realization and time step, for each observer.

Two measures side by side: XLA's own estimate of the compiled chunk (`memory_analysis()`: temporaries + outputs +
arguments) and the process's peak resident memory grown by one run (ru_maxrss, so the compile's own memory is
included). Prints `name=value` lines; `bytes_per_step_<observer>` are what `Observer.bytes_per_realization`
must bound (jaxroll/roll/_observers.py).

Usage (from the repository root): python -m benchmarks.memory [--dt 0.05] [--chunk 100]
`histogram` records φ every step, `histogram_recorded` every `envelope_record_every(problem)` steps (what
`monte_carlo_amplitudes` runs); the figures measured are in benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import functools
import subprocess
import sys

import jax
import jax.numpy as jnp

import jaxroll
from jaxroll.roll._monte_carlo import simulate_chunk
from jaxroll.roll._observers import AmplitudeHistogram, FirstMaxima, MaxRoll

OBSERVERS = {  # each built for the problem it runs
    "histogram": lambda p: AmplitudeHistogram(discard=500.0, every=1),  # φ recorded every step
    "histogram_recorded": lambda p: AmplitudeHistogram(discard=500.0, every=jaxroll.envelope_record_every(p)),
    "maxima": lambda p: FirstMaxima(n0=(20, 100), discard=500.0),
    "max_roll": lambda p: MaxRoll(discard=500.0, angle_deg=30.0),
}


@functools.cache
def _problem(dt):  # the filter fit once per dt, not once per observer and measure
    return jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0), dt=dt)


def xla_bytes(name: str, chunk: int, steps: int, dt: float) -> float:
    observer = OBSERVERS[name](_problem(dt))
    f = jax.jit(lambda p, k, i, v: simulate_chunk(p, k, i, v, observer, steps))
    compiled = f.lower(_problem(dt), jax.random.key(0), jnp.arange(chunk), jnp.ones(chunk, bool)).compile()
    m = compiled.memory_analysis()
    return (m.temp_size_in_bytes + m.output_size_in_bytes + m.argument_size_in_bytes) / (chunk * steps)


def rss_bytes(name: str, chunk: int, steps: int, dt: float) -> float:
    """Peak RSS growth of one chunk run [bytes per realization-step], in a fresh process."""
    code = f"""
import resource, jax, jaxroll, jax.numpy as jnp
jaxroll.configure()
from jaxroll.roll._monte_carlo import simulate_chunk
import benchmarks.memory as m
p = m._problem({dt}); obs = m.OBSERVERS[{name!r}](p)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out = jax.jit(lambda p, k, i, v: simulate_chunk(p, k, i, v, obs, {steps}))(
    p, jax.random.key(0), jnp.arange({chunk}), jnp.ones({chunk}, bool))
jax.block_until_ready(out)
print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) * 1024 / ({chunk} * {steps}))
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(res.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--dt", type=float, default=0.05, help="time step [s] (0.05: 72 000 steps per hour)")
    parser.add_argument("--chunk", type=int, default=100, help="realizations per chunk (100)")
    parser.add_argument("--duration", type=float, default=3600.0, help="simulated time [s] (3600)")
    args = parser.parse_args()
    steps = int(round(args.duration / args.dt))
    for name in OBSERVERS:
        x = xla_bytes(name, args.chunk, steps, args.dt)
        r = rss_bytes(name, args.chunk, steps, args.dt)
        problem = _problem(args.dt)
        observer = OBSERVERS[name](problem)
        bound = observer.bytes_per_realization(steps // observer.record_every(problem)) / steps
        print(f"bytes_per_step_{name}_xla={x:.1f}")
        print(f"bytes_per_step_{name}_rss={r:.1f}")
        print(f"bytes_per_step_{name}_assumed={bound:.1f}")
        assert r <= bound * 1.05 and x <= bound, f"{name}: the assumed bound is below the measured peak"


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
