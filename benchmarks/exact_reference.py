"""An exact-spectrum reference for P(max roll > angle within an exposure), built without jaxroll's numerics.

What jaxroll's tail probabilities are validated against (issue 42; `benchmarks/validation_map.py` compares every
method with it). Nothing here calls jaxroll's sea, effective wave, excitation or integrator; jaxroll is used only to
read the ship's coefficients (a ship file's numbers). Built from the formulas of CONVENTIONS.md / THEORY.md:

- **Sea**: the ITTC spectrum with the exact constants, S(ω) = A ω⁻⁵ exp(−B ω⁻⁴), on a fine grid of wave
  frequencies (`NUM_OMEGA` points over 0.05–4 rad/s, midpoint rule).
- **Effective wave, exactly Gaussian**: each wave component of number k = ω²/g keeps its own encounter frequency
  ω_e = ω − k U cos χ (χ = 0 following, 180° head) and Grim's amplitude factor F(k |cos χ|). Its variance
  F² S Δω is added to the bin of |ω_e| on the FFT grid of the trial (spacing 2π/(M dt) < 2π/trial length, so
  nothing repeats within a trial), and every bin gets a complex Gaussian amplitude: the effective wave is an exactly
  Gaussian process whose spectrum is the sea's, component by component. No encounter Jacobian, no branch
  bookkeeping for following seas, no shaping filter: a different route to S_G than jaxroll's.
- **Roll**: φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1φ + … + a9φ⁹ + P(t) φ = 0, P = r (ω0²/GM0) ΔGM(−ζ_G), integrated by
  Heun's method (explicit trapezoidal, second order; jaxroll uses RK4 with a bridged filter) at `dt` = 0.05 s
  (0.1 s checked against it: `--dt-check`), written in numba (parallel over trials).
- **Protocol** (jaxroll's): φ(0) = 5°, φ̇(0) = 0, the first 500 s discarded, a trial exceeds an angle when its
  largest |φ| in the exposure is larger or when it capsizes (|φ| past the vanishing angle, computed here from the
  polynomial's roots) before the exposure ends; 1 h and 3 h from the same trials.

Usage:
    python benchmarks/exact_reference.py --cells map --trials 4000 --json benchmarks/data/exact_reference.json
    python benchmarks/exact_reference.py --hs 5 --t01 9 --trials 20000          # one cell, printed
    python benchmarks/exact_reference.py --dt-check                               # dt 0.1 vs 0.05, same waves
Needs numba (`pip install ".[bench]"`). Cells are appended to the JSON as they finish (a run can be resumed).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import sys
import time

import numpy as np

GRAVITY = 9.80665
NUM_OMEGA = 400_000
DISCARD_S = 500.0
EXPOSURES_H = (1.0, 3.0)
ANGLES_DEG = (25.0, 30.0, 35.0, 40.0, 45.0)
#: The validation map of issue 42: H1/3 × T01 × heading × speed.
MAP = {
    "hs": (4.0, 6.0, 8.0),
    "t01": (8.0, 10.0, 12.0),
    "heading_deg": (180.0, 150.0, 0.0),
    "speed": (0.0, 5.0),
}


def ittc(omega, hs, t01):
    """One-sided ITTC spectrum [m² s/rad] with the exact constants (B = (2π/Γ(3/4))⁴/T01⁴, A = B H²/4)."""
    b = (2 * math.pi / math.gamma(0.75)) ** 4 / t01**4
    return b * hs**2 / 4 * omega**-5.0 * np.exp(-b * omega**-4.0)


def grim_factor(k, length):
    """F(k) = (kL) sin(kL/2) / (π² − (kL/2)²), its limit 1 at kL/2 = π."""
    x = k * length / 2
    den = math.pi**2 - x**2
    near = np.abs(den) < 1e-9
    return np.where(near, 1.0, 2 * x * np.sin(x) / np.where(near, 1.0, den))


def binned_effective_spectrum(hs, t01, heading_deg, speed, length, m, dt):
    """Variance [m²] of ζ_G in each bin j·2π/(m dt), j = 0 … m/2, from wave components on a fine ω grid."""
    edges = np.linspace(0.05, 4.0, NUM_OMEGA + 1)
    omega = (edges[1:] + edges[:-1]) / 2
    domega = np.diff(edges)
    k = omega**2 / GRAVITY
    cos_chi = math.cos(math.radians(heading_deg))
    cos_chi = 0.0 if abs(cos_chi) < 1e-12 else cos_chi
    omega_e = np.abs(omega - k * speed * cos_chi)
    var = grim_factor(k * abs(cos_chi), length) ** 2 * ittc(omega, hs, t01) * domega
    spacing = 2 * math.pi / (m * dt)
    j = np.rint(omega_e / spacing).astype(np.int64)
    keep = (j >= 1) & (j < m // 2)
    return np.bincount(j[keep], weights=var[keep], minlength=m // 2 + 1)


def fast_length(n):
    """Smallest 2^a 3^b 5^c ≥ n."""
    best = 1 << (n - 1).bit_length()
    for a5 in range(0, 20):
        for a3 in range(0, 30):
            base = 5**a5 * 3**a3
            if base > 2 * n:
                break
            x = base
            while x < n:
                x *= 2
            best = min(best, x)
    return best


def vanishing_angle(a):
    """First φ > 0 where GZ/φ = a1 + a3φ² + … + a9φ⁸ vanishes (roots in x = φ²), or π."""
    x = np.polynomial.polynomial.polyroots(np.trim_zeros(np.asarray(a, float), "b"))
    real = [math.sqrt(r.real) for r in np.atleast_1d(x) if abs(r.imag) < 1e-12 and r.real > 0]
    return min(real + [math.pi])


def ship_numbers(ship_file=None):
    """The roll model's numbers from a jaxroll ship (the default C11 representative, or a ship file)."""
    import jaxroll

    ship = jaxroll.c11_representative() if ship_file is None else jaxroll.load_ship(ship_file)
    omega0 = 2 * math.pi / float(ship.roll_period)
    a = np.concatenate([[omega0**2], np.asarray(ship.restoring, float)])
    return {
        "a": a,
        "b": np.asarray(ship.damping, float),
        "c": np.asarray(ship.delta_gm, float),
        "kappa": float(ship.gm_correction) * omega0**2 / float(ship.gm0),
        "lpp": float(ship.lpp),
        "capsize": vanishing_angle(a),
        "name": ship.name,
    }


def _kernel():
    import numba

    @numba.njit(fastmath=False, cache=True)
    def accel(phi, dphi, p, a, b):
        p2 = phi * phi
        rest = phi * (a[0] + p2 * (a[1] + p2 * (a[2] + p2 * (a[3] + p2 * a[4]))))
        return -dphi * (b[0] + b[1] * abs(dphi) + b[2] * dphi * dphi) - rest - p * phi

    @numba.njit(parallel=True, fastmath=False, cache=True)
    def run(zeta, dt, a, b, c, kappa, capsize, phi0, start, ends, out_max, out_capsize_step):
        n_trials, n = zeta.shape
        for i in numba.prange(n_trials):
            phi, dphi = phi0, 0.0
            zm = -zeta[i, 0]
            p = kappa * (
                c[0] + zm * (c[1] + zm * (c[2] + zm * (c[3] + zm * (c[4] + zm * (c[5] + zm * c[6])))))
            )
            biggest = 0.0
            e = 0
            cap = -1
            for s in range(1, n):
                zm = -zeta[i, s]
                p1 = kappa * (
                    c[0] + zm * (c[1] + zm * (c[2] + zm * (c[3] + zm * (c[4] + zm * (c[5] + zm * c[6])))))
                )
                k1 = accel(phi, dphi, p, a, b)
                phi_e, dphi_e = phi + dt * dphi, dphi + dt * k1
                k2 = accel(phi_e, dphi_e, p1, a, b)
                phi = phi + dt / 2 * (dphi + dphi_e)
                dphi = dphi + dt / 2 * (k1 + k2)
                p = p1
                if not (abs(phi) < capsize):
                    cap = s
                    break
                if s > start and abs(phi) > biggest:
                    biggest = abs(phi)
                while e < ends.size and s == ends[e]:
                    out_max[i, e] = biggest
                    e += 1
            while e < ends.size:
                out_max[i, e] = biggest
                e += 1
            out_capsize_step[i] = cap

    return run


#: Period of the synthesised wave [s]: longer than any trial (500 s + 3 h), the same for every dt (so runs at
#: different dt share their waves: `--dt-check`), and 2^a 3^b 5^c times every dt offered.
PERIOD_S = 11_520.0
OMEGA_MAX = 4.0  # [rad/s]: components above carry < 1e-9 of σ_G² here; bins above get no amplitude


def simulate_cell(cell, ship, trials, seed, dt=0.05, batch=64, progress=False):
    """Largest |φ| [deg] per trial over each exposure, each trial's capsize time [s] (inf if none), and σ_G [m]."""
    import scipy.fft

    run = _kernel()
    total_s = DISCARD_S + 3600.0 * max(EXPOSURES_H)
    n = int(round(total_s / dt)) + 1
    m = int(round(PERIOD_S / dt))
    if m < n or abs(m * dt - PERIOD_S) > 1e-9 or fast_length(m) != m:
        raise SystemExit(
            f"dt = {dt} s does not divide the wave's period {PERIOD_S} s into a fast FFT length."
        )
    var = binned_effective_spectrum(
        cell["hs"], cell["t01"], cell["heading_deg"], cell["speed"], ship["lpp"], m, dt
    )
    num_bins = int(OMEGA_MAX * PERIOD_S / (2 * math.pi)) + 2
    scale = (
        np.sqrt(var[:num_bins]) * m / 2
    )  # irfft: ζ(t) = Σ_j 2 Re(X_j e^{iω_j t})/m, so Var = 4|s|²/m² a bin
    start = int(round(DISCARD_S / dt))
    ends = np.array([start + int(round(3600.0 * h / dt)) for h in EXPOSURES_H], np.int64)
    maxima = np.zeros((trials, len(EXPOSURES_H)))
    capsize_step = np.zeros(trials, np.int64)
    rng = np.random.default_rng(seed)
    coef = np.zeros((batch, m // 2 + 1), complex)
    for lo in range(0, trials, batch):
        k = min(batch, trials - lo)
        coef[:k, :num_bins] = scale * (
            rng.standard_normal((k, num_bins)) + 1j * rng.standard_normal((k, num_bins))
        )
        zeta = scipy.fft.irfft(coef[:k], n=m, axis=-1, workers=-1)[:, :n]
        out_max = np.zeros((k, len(EXPOSURES_H)))
        out_cap = np.zeros(k, np.int64)
        run(np.ascontiguousarray(zeta), dt, ship["a"], ship["b"], ship["c"], ship["kappa"], ship["capsize"],
            math.radians(5.0), start, ends, out_max, out_cap)  # fmt: skip
        maxima[lo : lo + k], capsize_step[lo : lo + k] = out_max, out_cap
        if progress:
            print(f"  {lo + k}/{trials}", end="\r", file=sys.stderr, flush=True)
    capsize_time = np.where(capsize_step >= 0, capsize_step * dt, np.inf)
    return np.degrees(maxima), capsize_time, float(np.sqrt(var.sum()))


def exceedances(maxima_deg, capsize_time):
    """{exposure_h: {angle_deg: count}} of trials beyond each angle or capsized before the exposure's end."""
    out = {}
    for e, h in enumerate(EXPOSURES_H):
        capsized = capsize_time <= DISCARD_S + 3600.0 * h
        out[f"{h:g}"] = {f"{a:g}": int(np.sum(capsized | (maxima_deg[:, e] > a))) for a in ANGLES_DEG}
    return out


def cells_of(name):
    if name == "map":
        keys = list(MAP)
        return [dict(zip(keys, v, strict=True)) for v in itertools.product(*(MAP[k] for k in keys))]
    raise SystemExit(f"unknown --cells {name!r}: 'map'")


def cell_key(cell):
    return f"hs{cell['hs']:g}_t{cell['t01']:g}_chi{cell['heading_deg']:g}_u{cell['speed']:g}"


def main(argv=None):
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--cells", help="'map': the validation map of issue 42 (MAP)")
    parser.add_argument("--hs", type=float, default=5.0)
    parser.add_argument("--t01", type=float, default=9.0)
    parser.add_argument("--heading", type=float, default=180.0, help="χ [deg], 180 head")
    parser.add_argument("--speed", type=float, default=0.0, help="[m/s]")
    parser.add_argument("--trials", type=int, default=4000)
    parser.add_argument(
        "--dt",
        type=float,
        default=0.1,
        help="[s] (0.1: within 0.03 %% of 0.05 on the mean largest roll, --dt-check)",
    )
    parser.add_argument(
        "--live-only", action="store_true", help="extend only cells with an exceedance of 25° in 3 h"
    )
    parser.add_argument("--seed", type=int, default=20261207)
    parser.add_argument("--ship", default=None, help="ship file (default: C11 representative)")
    parser.add_argument("--json", default=None, help="append cells to this JSON file (resumable)")
    parser.add_argument(
        "--dt-check", action="store_true", help="dt 0.1 vs 0.05 s on the same waves, one cell"
    )
    args = parser.parse_args(argv)
    ship = ship_numbers(args.ship)
    print(f"ship={ship['name']} capsize_deg={math.degrees(ship['capsize']):.3f}", flush=True)
    if args.dt_check:
        cell = {"hs": args.hs, "t01": args.t01, "heading_deg": args.heading, "speed": args.speed}
        for dt in (0.05, 0.1, 0.2):
            t = time.perf_counter()
            mx, cap, sg = simulate_cell(cell, ship, args.trials, args.seed, dt=dt)
            print(f"dt={dt} sigma_G={sg:.4f} mean_max_1h_deg={np.mean(mx[:, 0]):.4f} mean_max_3h_deg="
                  f"{np.mean(mx[:, 1]):.4f} capsized={int(np.sum(np.isfinite(cap)))} {exceedances(mx, cap)} "
                  f"({time.perf_counter() - t:.1f} s)", flush=True)  # fmt: skip
        return
    cells = cells_of(args.cells) if args.cells else [
        {"hs": args.hs, "t01": args.t01, "heading_deg": args.heading, "speed": args.speed}
    ]  # fmt: skip
    done = {}
    if args.json and os.path.exists(args.json):
        with open(args.json) as f:
            done = json.load(f)
    results = done.setdefault("cells", {})
    done["protocol"] = {
        "ship": ship["name"], "discard_s": DISCARD_S, "exposures_h": list(EXPOSURES_H), "angles_deg": list(ANGLES_DEG),
        "dt_s": args.dt, "integrator": "Heun (numba)", "sea": "ITTC, exact Gaussian, binned components",
        "phi0_deg": 5.0, "command": "python benchmarks/exact_reference.py " + " ".join(argv or sys.argv[1:]),
    }  # fmt: skip
    for i, cell in enumerate(cells):
        key = cell_key(cell)
        old = results.get(key)
        have = old["trials"] if old else 0
        if have >= args.trials or (args.live_only and old and old["exceedances"]["3"]["25"] == 0):
            continue
        t = time.perf_counter()
        more = args.trials - have  # a cell is extended with new trials (another seed), its counts added
        mx, cap, sg = simulate_cell(cell, ship, more, args.seed + 7919 * i + have, dt=args.dt)
        counts = exceedances(mx, cap)
        if old:
            counts = {h: {a: c + old["exceedances"][h][a] for a, c in v.items()} for h, v in counts.items()}
        results[key] = {**cell, "trials": args.trials, "sigma_g_m": sg, "exceedances": counts,
                        "capsized": int(np.sum(np.isfinite(cap))) + (old["capsized"] if old else 0),
                        "seconds": time.perf_counter() - t + (old["seconds"] if old else 0.0)}  # fmt: skip
        p = {h: {a: round(c / args.trials, 5) for a, c in v.items()} for h, v in counts.items()}
        print(f"{key} sigma_G={sg:.3f} P={p} ({time.perf_counter() - t:.1f} s)", flush=True)
        if args.json:
            tmp = args.json + ".tmp"
            with open(tmp, "w") as f:
                json.dump(done, f, indent=1)
            os.replace(tmp, args.json)


if __name__ == "__main__":
    main()
