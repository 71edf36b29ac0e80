"""Monte Carlo throughput: jaxroll vs a plain vectorized NumPy Euler–Maruyama implementation of the same model.

The paper protocol: default ship, ITTC H1/3 = 7 m, T01 = 10 s, 10⁴ realizations × 3600 s, Method-2 filter.

The baseline integrates the augmented SDE (order-4 filter states + roll) with Euler–Maruyama (symplectic for
the roll, the variant that is stable for an oscillator) at the dt it needs for the same accuracy as jaxroll's
default dt = 0.5 s. That dt is found in this run: the largest dt (halving from 0.4 s) at which both
(a) the stationary filter variance of the EM recursion (exact discrete Lyapunov equation) is within 1 % of σ_G²,
and (b) a deterministic parametric-resonance response over 600 s is within 1 % of a converged reference.
The baseline is timed on a slice of the run and extrapolated linearly (its cost is exactly linear in steps).

A third baseline, when numba is installed (`pip install ".[bench]"`): jaxroll's own algorithm written in numba
(benchmarks/_numba_baseline.py: the filter every m steps with the bridge, RK4, the same statistics, realizations
in parallel over the cores; float32 and float64, the faster counts); it prints `speedup_vs_numba=<x>` just
before the last line. A fourth: a plain `lax.scan` symplectic-Euler integration driven by FFT-synthesised forcing
at the dt it needs (`speedup_vs_scan_symplectic`).

Usage: python benchmarks/mcs.py [--quick]   (the last line is `speedup_vs_numpy=<x>`)
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import jax
import jax.numpy as jnp
import numpy as np

import jaxroll

DEG = 180 / np.pi


def numpy_em_step(state, ship_np, filt, dt, rng):
    """One Euler–Maruyama step of the augmented system for all realizations (state: dict of arrays)."""
    z, phi, dphi = state["z"], state["phi"], state["dphi"]
    a1, a3, a5, a7, a9 = ship_np["a"]
    b1, b2, b3 = ship_np["b"]
    c = ship_np["c"]
    zeta_mid = -(z @ filt["c"])
    dgm = c[0] + zeta_mid * (
        c[1] + zeta_mid * (c[2] + zeta_mid * (c[3] + zeta_mid * (c[4] + zeta_mid * (c[5] + zeta_mid * c[6]))))
    )
    p = ship_np["kappa"] * dgm
    phi2 = phi * phi
    restoring = phi * (a1 + phi2 * (a3 + phi2 * (a5 + phi2 * (a7 + phi2 * a9))))
    acc = -dphi * (b1 + b2 * np.abs(dphi) + b3 * dphi * dphi) - restoring - p * phi
    dphi = dphi + acc * dt
    phi = phi + dphi * dt
    z = z + (z @ filt["a"].T) * dt + np.sqrt(dt) * rng.standard_normal((z.shape[0], 1)) * filt["b"]
    return {"z": z, "phi": phi, "dphi": dphi}


def numpy_rk4_run_steps(problem, n_real, n_steps, rng):
    """The same algorithm as jaxroll (the filter stepped exactly every m steps with the bridge in between, RK4 at
    dt) in vectorized NumPy float64, for `n_steps` steps (a multiple of m)."""
    exc = problem.excitation
    m = exc.substeps
    phi_h, chol, c = np.asarray(exc.phi), np.asarray(exc.chol), np.asarray(exc.c)
    wa, wb = np.asarray(exc.bridge[0]), np.asarray(exc.bridge[1])
    ship = problem.ship
    a = np.asarray(ship.restoring_coefficients)
    b1, b2, b3 = np.asarray(ship.damping)
    cc = np.asarray(ship.delta_gm) * float(ship.gm_correction)
    kappa = float(ship.omega0**2 / ship.gm0)
    h = exc.dt

    def pexc(zeta):
        zm = -zeta
        return kappa * (
            cc[0] + zm * (cc[1] + zm * (cc[2] + zm * (cc[3] + zm * (cc[4] + zm * (cc[5] + zm * cc[6])))))
        )

    def f(phi, dphi, p):
        phi2 = phi * phi
        rest = phi * (a[0] + phi2 * (a[1] + phi2 * (a[2] + phi2 * (a[3] + phi2 * a[4]))))
        return dphi, -dphi * (b1 + b2 * np.abs(dphi) + b3 * dphi * dphi) - rest - p * phi

    z = rng.standard_normal((n_real, c.size)) @ np.asarray(exc.stationary_chol).T
    phi, dphi = np.full(n_real, 0.087), np.zeros(n_real)
    p_end = pexc(z @ c)
    for _ in range(n_steps // m):
        z1 = z @ phi_h.T + rng.standard_normal((n_real, chol.shape[1])) @ chol.T
        ps = [p_end, *(pexc(z @ wa[j] + z1 @ wb[j]) for j in range(2 * m - 1)), pexc(z1 @ c)]
        for s_ in range(m):
            p0, pm, p1 = ps[2 * s_], ps[2 * s_ + 1], ps[2 * s_ + 2]
            k1 = f(phi, dphi, p0)
            k2 = f(phi + h / 2 * k1[0], dphi + h / 2 * k1[1], pm)
            k3 = f(phi + h / 2 * k2[0], dphi + h / 2 * k2[1], pm)
            k4 = f(phi + h * k3[0], dphi + h * k3[1], p1)
            phi = phi + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            dphi = dphi + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        z, p_end = z1, ps[-1]
    return phi


def _scan_symplectic(problem, duration, dt):
    """One realization of the plain `lax.scan` symplectic-Euler integration (float64) driven by P(t) from Method-1
    FFT synthesis (`jaxroll.superpose`) on its own grid of step `dt`: the straightforward JAX implementation.
    The synthesis's frequency grid is 2π/(M dt) with M·dt fixed by the duration, so halving dt with the same key
    gives the same sea, sampled twice as finely (common random numbers for the dt search)."""
    ship, wave = problem.ship, problem.wave
    n = int(round(duration / dt))

    def one(key):
        zeta, _ = jaxroll.superpose(wave, key, n, dt)
        p = jaxroll.parametric_excitation(ship, zeta)

        def step(y, pk):
            phi, dphi = y
            dphi = dphi + dt * jaxroll.roll_acceleration(ship, phi, dphi, pk)
            phi = phi + dt * dphi
            return (phi, dphi), jnp.abs(phi)

        _, absphi = jax.lax.scan(step, (problem.phi0, problem.dphi0), p)
        return jnp.mean(absphi)

    return jax.jit(jax.vmap(one))


def scan_symplectic_dt(problem, duration, n_check=64, tol=0.01):
    """The largest dt = 0.4 s / 2^k at which halving dt changes the mean |φ| by less than `tol` on the same seas —
    the criterion jaxroll's own dt = 0.5 s passes (tests/test_dynamics.py). **Returns:** (dt, relative change)."""
    keys = jax.random.split(jax.random.key(2), n_check)
    dt = 0.4
    while dt > 1e-3:
        coarse = np.asarray(_scan_symplectic(problem, duration, dt)(keys))
        fine = np.asarray(_scan_symplectic(problem, duration, dt / 2)(keys))
        ok = np.isfinite(coarse) & np.isfinite(fine)
        change = abs(coarse[ok].mean() / fine[ok].mean() - 1)
        if change < tol:
            return dt, change
        dt /= 2
    return dt, change


def scan_symplectic_baseline(problem, n_real, duration, dt, chunk=100):
    """`_scan_symplectic` timed on one chunk after compilation and extrapolated linearly to `n_real` (its cost is
    exactly linear in realizations). **Returns:** (seconds for n_real, mean |φ| [deg])."""
    run = _scan_symplectic(problem, duration, dt)
    keys = jax.random.split(jax.random.key(1), chunk)
    jax.block_until_ready(run(keys))
    t0 = time.perf_counter()
    out = jax.block_until_ready(run(keys))
    per_chunk = time.perf_counter() - t0
    return per_chunk * n_real / chunk, float(np.rad2deg(np.nanmean(np.asarray(out))))


def em_filter_variance(filt, dt):
    """Exact stationary output variance of the EM recursion z' = (I + A dt) z + b √dt ε."""
    n = filt["a"].shape[0]
    f = np.eye(n) + filt["a"] * dt
    q = np.outer(filt["b"], filt["b"]) * dt
    sigma = np.linalg.solve(np.eye(n * n) - np.kron(f, f), q.reshape(-1)).reshape(n, n)
    return filt["c"] @ sigma @ filt["c"]


def deterministic_error(ship, dt, ship_np, t_end=600.0):
    """Relative error of the largest |φ| over t_end of φ̈ + … + ε ω0² cos(2ω0 t) φ = 0 with symplectic Euler."""
    w0 = float(ship.omega0)
    eps = 0.3

    def run(dt):
        n = int(round(t_end / dt))
        phi, dphi, peak = 0.05, 0.0, 0.0
        a = ship_np["a"]
        b1, b2, _ = ship_np["b"]
        for k in range(n):
            t = k * dt
            p = eps * w0**2 * np.cos(2 * w0 * t)
            phi2 = phi * phi
            acc = -dphi * (b1 + b2 * abs(dphi)) - phi * (a[0] + phi2 * (a[1] + phi2 * a[2])) - p * phi
            dphi += acc * dt
            phi += dphi * dt
            peak = max(peak, abs(phi))
        return peak

    if t_end not in _REFERENCE:
        _REFERENCE[t_end] = run(0.002)
    return abs(run(dt) / _REFERENCE[t_end] - 1)


_REFERENCE: dict[float, float] = {}


def frontier(n_real: int, duration: float, dt: float = 0.5) -> None:
    """Issue 42's accuracy–cost frontier: the paper protocol's time with each excitation (order-4/6/8 filters, the
    default `auto`, superposition; the same run, best of two after compilation), beside each one's tail error over
    the validation map (pooled χ², geometric-mean ratio to the exact-spectrum sea) where the map has it."""
    import json
    import os
    import warnings

    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    variants = {
        "filter4": {"excitation": "filter", "filter_order": 4},
        "filter6": {"excitation": "filter", "filter_order": 6},
        "filter8": {"excitation": "filter", "filter_order": 8},
        "default": {},
        "superposition": {"excitation": "superposition"},
    }
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "validation_map.json")
    summary = json.load(open(path)).get("summary", {}) if os.path.exists(path) else {}
    times = {}
    for name, kw in variants.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem = jaxroll.RollProblem.from_sea(ship, sea, dt=dt, **kw)
        key = jax.random.key(0)
        jaxroll.monte_carlo_amplitudes(problem, key, num_realizations=min(1000, n_real), duration=duration)
        best = math.inf
        for _ in range(2):
            t0 = time.perf_counter()
            jaxroll.monte_carlo_amplitudes(problem, key, num_realizations=n_real, duration=duration)
            best = min(best, time.perf_counter() - t0)
        times[name] = best
        order = problem.filter_fit.filter.order if problem.filter_fit is not None else "-"
        tail = summary.get(f"mc-{name}")
        tail_text = (
            f" map_chi2={tail['chi2']:.1f}/{tail['n']} (99%: {tail['chi2_q99']:.1f}) map_ratio_geomean="
            f"{tail['ratio_geomean']:.3f} ratio_range={tail['ratio_min']:.2f}-{tail['ratio_max']:.2f}"
            if tail
            else ""
        )
        print(
            f"frontier {name}: order={order} run_s={best:.2f} throughput_vs_filter4="
            f"{times['filter4'] / best:.2f}{tail_text}",
            flush=True,
        )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="10³ realizations × 1800 s (under a minute)")
    parser.add_argument(
        "--frontier",
        action="store_true",
        help="only the accuracy-cost frontier: each excitation's time for the protocol beside its tail error "
        "against the exact-spectrum sea (benchmarks/data/validation_map.json)",
    )
    args = parser.parse_args()
    if args.frontier:
        frontier(*((1000, 1800.0) if args.quick else (10_000, 3600.0)))
        return
    n_real, duration = (1000, 1800.0) if args.quick else (10_000, 3600.0)
    dt = 0.5

    ship = jaxroll.c11_representative()
    sea = jaxroll.ITTC(7.0, 10.0)
    problem = jaxroll.RollProblem.from_sea(ship, sea, dt=dt)
    print(
        f"device={jax.devices()[0].device_kind} ({jax.default_backend()}), integration float32 (sums float64)"
    )
    print(
        f"protocol: {n_real} realizations x {duration:g} s, dt={dt} s, steps/realization={int(duration / dt)}"
    )

    key = jax.random.key(0)
    t0 = time.perf_counter()
    jaxroll.monte_carlo_amplitudes(
        problem, key, num_realizations=min(1000, n_real), duration=duration, chunk_size=1000
    )
    compile_and_first = time.perf_counter() - t0
    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        stats = jaxroll.monte_carlo_amplitudes(
            problem, key, num_realizations=n_real, duration=duration, chunk_size=1000
        )
        times.append(time.perf_counter() - t0)
    run_time = min(times)
    steps = n_real * duration / dt
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"jaxroll_first_call_s={compile_and_first:.2f}  (compile + {min(1000, n_real)} realizations)")
    print(f"jaxroll_run_s={run_time:.2f}")
    print(f"jaxroll_realization_steps_per_s={steps / run_time:.3e}")
    print(f"peak_rss_mb={peak_mb:.0f}")
    mean_deg = {e: float(np.rad2deg(stats.mean(e))) for e in ("zero_crossing", "envelope")}
    print(
        f"mean_amplitude_deg zero_crossing={mean_deg['zero_crossing']:.3f} envelope={mean_deg['envelope']:.3f}"
        f"  capsized={stats.n_capsized}"
    )

    # ---- numba running jaxroll's own algorithm (optional dependency) ----
    numba_total = None
    try:
        import numba  # noqa: F401
    except ImportError:
        print("numba_run_s=skipped  (pip install numba, or the [bench] extra)")
    else:
        from _numba_baseline import numba_monte_carlo

        n_steps = int(duration / dt)
        timings = {}
        for dtype in (np.float32, np.float64):  # the baseline gets the faster of the two
            numba_monte_carlo(problem, 4, 64, discard=0.0, chunk=4, dtype=dtype)  # compile
            t0 = time.perf_counter()
            hz, he, sums = numba_monte_carlo(problem, n_real, n_steps, discard=0.0, chunk=1000, dtype=dtype)
            timings[dtype.__name__] = (time.perf_counter() - t0, sums)
            print(f"numba_{dtype.__name__}_run_s={timings[dtype.__name__][0]:.2f}")
        best = min(timings, key=lambda k: timings[k][0])
        numba_total, sums = timings[best]
        print(
            f"numba_run_s={numba_total:.2f}  ({best}; prange over 2 lanes; PCG64 normals; envelope by scipy.fft)"
        )
        print(f"numba_realization_steps_per_s={steps / numba_total:.3e}")
        print(
            f"numba_mean_amplitude_deg zero_crossing={sums['sum_zc'] / sums['n_zc'] * DEG:.3f} "
            f"envelope={sums['sum_env'] / sums['n_env'] * DEG:.3f}  capsized={sums['capsized']}"
        )

    # ---- NumPy Euler–Maruyama baseline at the dt it needs for the same accuracy ----
    f = problem.filter_fit.filter
    filt = {"a": np.asarray(f.a), "b": np.asarray(f.b), "c": np.asarray(f.c)}
    a = np.asarray(ship.restoring_coefficients)
    ship_np = {
        "a": a,
        "b": np.asarray(ship.damping),
        "c": np.asarray(ship.delta_gm) * float(ship.gm_correction),
        "kappa": float(ship.omega0**2 / ship.gm0),
    }
    var_target = float(f.variance())
    dt_np = 0.4
    while dt_np > 1e-3:
        var_err = abs(em_filter_variance(filt, dt_np) / var_target - 1)
        det_err = deterministic_error(ship, dt_np, ship_np)
        if var_err < 0.01 and det_err < 0.01:
            break
        dt_np /= 2
    print(
        f"numpy_em_dt_s={dt_np:.4g}  (filter variance error {var_err:.2%}, deterministic error {det_err:.2%})"
    )
    # FFT synthesis is exact at any step, so the symplectic-Euler scan needs only the integrator's accuracy: the dt
    # at which halving it moves the mean |φ| by < 1 % on the same seas, as jaxroll's dt = 0.5 s does
    dt_se, change = scan_symplectic_dt(problem, duration)
    scan_total, scan_mean = scan_symplectic_baseline(
        problem, n_real, duration, dt_se, chunk=20 if args.quick else 100
    )
    print(f"scan_symplectic_dt_s={dt_se:.4g}  (halving it moves the mean |φ| by {change:.2%})")
    print(
        f"scan_symplectic_run_s_extrapolated={scan_total:.1f}  (lax.scan, FFT-synthesised forcing; mean |φ| "
        f"{scan_mean:.2f}°)"
    )

    rng = np.random.default_rng(0)
    n_timed_steps = 400 if args.quick else 200
    state = {
        "z": rng.standard_normal((n_real, f.order)) * 0.0,
        "phi": np.full(n_real, np.deg2rad(5.0)),
        "dphi": np.zeros(n_real),
    }
    t0 = time.perf_counter()
    for _ in range(n_timed_steps):
        state = numpy_em_step(state, ship_np, filt, dt_np, rng)
    per_step = (time.perf_counter() - t0) / n_timed_steps
    numpy_total = per_step * duration / dt_np
    print(
        f"numpy_time_per_step_s={per_step:.3e}  (all {n_real} realizations, timed over {n_timed_steps} steps)"
    )
    print(f"numpy_run_s_extrapolated={numpy_total:.1f}")
    print(f"numpy_realization_steps_per_s={n_real / per_step:.3e}")
    t0 = time.perf_counter()
    numpy_rk4_run_steps(problem, n_real, 100, rng)
    per_step_rk4 = (time.perf_counter() - t0) / 100
    rk4_total = per_step_rk4 * duration / dt
    print(
        f"numpy_same_algorithm_run_s_extrapolated={rk4_total:.1f}  (exact filter + RK4 at dt={dt} s, as jaxroll)"
    )
    print(f"speedup_vs_numpy_same_algorithm={rk4_total / run_time:.1f}")
    print(f"speedup_vs_scan_symplectic={scan_total / run_time:.1f}")
    if numba_total is not None:
        print(f"speedup_vs_numba={numba_total / run_time:.2f}")
    print(f"speedup_vs_numpy={numpy_total / run_time:.1f}")


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    _ = jnp.zeros(())
    main()
