"""Benchmark: time-domain calibration of one free-running roll record, multiple shooting vs the Kalman filter.

The record is tests/test_time_domain.py's: the default ship with r = 0.8, ITTC H1/3 = 7 m, T01 = 10 s, 120 s model
(1200 s full scale) at 20 Hz, roll noise 0.05°, probe noise 0.1 mm, seed 2; (b1, b2, r) fitted from the ship's
values. Each estimator's first call (tracing and compilation included) and its later calls are timed separately,
with the estimates, so that a change in speed can be checked not to change the numbers (docs/calibration.md, "Which
estimator when").

Run: `python benchmarks/calibration.py [--repeat 2]`. Output: `name=value` lines.
"""

from __future__ import annotations

import argparse
import time

import equinox as eqx
import jax.numpy as jnp

import jaxroll as jxr
from jaxroll.calibration import fit_roll_kalman, fit_roll_time_domain, virtual_roll_record

PARAMS = ("b1", "b2", "gm_correction")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2, help="timed calls after the first (2)")
    args = parser.parse_args()

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


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
