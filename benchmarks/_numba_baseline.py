"""A numba implementation of jaxroll's own Monte Carlo algorithm, the baseline of `benchmarks/mcs.py` (issue 15).

The same model and algorithm as `jaxroll.monte_carlo_amplitudes` on a `FilterExcitation`: the shaping filter
stepped exactly every m time steps (m = `substeps`, 4 for the paper's protocol) with ζ_G at the RK4 stage times in
between from the same bridge weights, RK4 at dt, capsize at the vanishing angle, zero-crossing amplitudes as
`jaxroll`'s detector, the Hilbert envelope by FFT and 0.05° histograms, in the same floating type. Realizations run
in parallel over the cores (`numba.prange`). numba is an optional benchmark dependency (`pip install ".[bench]"`);
the benchmark skips this baseline without it.
"""

from __future__ import annotations

import math

import jax
import numpy as np
import scipy.fft

DEG = 180 / math.pi


def ship_constants(problem):
    """Plain-float model constants: restoring (a1…a9), damping (b1, b2, b3), P(ζ_G) coefficients, capsize angle."""
    ship = problem.ship
    with jax.ensure_compile_time_eval():
        a = np.asarray(ship.restoring_coefficients, dtype=np.float64)
        b = np.asarray(ship.damping, dtype=np.float64)
        kappa = float(ship.gm_correction * ship.omega0**2 / ship.gm0)
        pc = kappa * np.asarray(ship.delta_gm) * (-1.0) ** np.arange(7)  # P = Σ pc_k ζ_Gᵏ
        return a, b, pc, float(problem.capsize_angle)


# ----------------------------------------------------------------------------------------------------------------
# numba: jaxroll's own algorithm (filter every m steps + bridge, RK4 at dt), prange over realizations
# ----------------------------------------------------------------------------------------------------------------

_NUMBA = {}


def _numba_kernel():
    if "k" in _NUMBA:
        return _NUMBA["k"]
    import numba as nb

    @nb.njit(inline="always")
    def pexc(pc, z):
        return pc[0] + z * (pc[1] + z * (pc[2] + z * (pc[3] + z * (pc[4] + z * (pc[5] + z * pc[6])))))

    @nb.njit(inline="always")
    def acc(a, b, phi, dphi, p):
        phi2 = phi * phi
        rest = a[0] + p + phi2 * (a[1] + phi2 * (a[2] + phi2 * (a[3] + phi2 * a[4])))
        return -dphi * (b[0] + b[1] * abs(dphi) + b[2] * dphi * dphi) - phi * rest

    @nb.njit
    def one(g, i, n, m, n_steps, h, phid, chol, schol, c, wa, wb, a, b, pc, cap, phi0, phi_out, amp_out, capsized):
        z = np.empty(n, phid.dtype)
        e = np.empty(n, phid.dtype)
        zn = np.empty(n, phid.dtype)
        p = np.empty(2 * m + 1, phid.dtype)
        for r in range(n):
            e[r] = g.standard_normal()
        for r in range(n):
            s = 0.0
            for q in range(n):
                s += schol[r, q] * e[q]
            z[r] = s
        x0 = 0.0
        for r in range(n):
            x0 += c[r] * z[r]
        p[2 * m] = pexc(pc, x0)
        phi, dphi = phi0, phi0 * 0
        alive = True
        positive = phi >= 0
        started = False
        peak = abs(phi)
        k = 0
        while k < n_steps:
            # one filter step of m time steps: exact transition, then the bridge at the 2m − 1 stage times
            for r in range(n):
                e[r] = g.standard_normal()
            for r in range(n):
                s = 0.0
                for q in range(n):
                    s += phid[r, q] * z[q] + chol[r, q] * e[q]
                zn[r] = s
            p[0] = p[2 * m]
            for j in range(2 * m - 1):
                x = 0.0
                for r in range(n):
                    x += wa[j, r] * z[r] + wb[j, r] * zn[r]
                p[j + 1] = pexc(pc, x)
            x = 0.0
            for r in range(n):
                z[r] = zn[r]
                x += c[r] * z[r]
            p[2 * m] = pexc(pc, x)
            for sub in range(m):
                if k >= n_steps:
                    break
                p0, pm, p1 = p[2 * sub], p[2 * sub + 1], p[2 * sub + 2]
                if alive:
                    k1p = dphi
                    k1v = acc(a, b, phi, dphi, p0)
                    k2p = dphi + h / 2 * k1v
                    k2v = acc(a, b, phi + h / 2 * k1p, dphi + h / 2 * k1v, pm)
                    k3p = dphi + h / 2 * k2v
                    k3v = acc(a, b, phi + h / 2 * k2p, dphi + h / 2 * k2v, pm)
                    k4p = dphi + h * k3v
                    k4v = acc(a, b, phi + h * k3p, dphi + h * k3v, p1)
                    nphi = phi + h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p)
                    ndphi = dphi + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
                    if np.isfinite(nphi) and np.isfinite(ndphi) and abs(nphi) < cap:
                        phi, dphi = nphi, ndphi
                    else:
                        alive = False
                        capsized[i] = True
                # zero-crossing amplitude (as jaxroll.zero_crossing_update)
                v = abs(phi)
                pos = phi >= 0
                crossed = pos != positive
                amp_out[i, k] = peak if (crossed and started) else 0.0
                peak = v if crossed else max(peak, v)
                started = started or crossed
                positive = pos
                phi_out[i, k] = phi
                k += 1

    @nb.njit(parallel=True)
    def run(g0, g1, n_real, m, n_steps, h, phid, chol, schol, c, wa, wb, a, b, pc, cap, phi0, phi_out, amp_out,
            capsized):
        n = c.size
        for lane in nb.prange(2):  # one PCG64 generator (ziggurat normals) per lane = per core
            g = g0 if lane == 0 else g1
            for i in range(lane, n_real, 2):
                one(g, i, n, m, n_steps, h, phid, chol, schol, c, wa, wb, a, b, pc, cap, phi0, phi_out, amp_out,
                    capsized)

    _NUMBA["k"] = run
    return run


def numba_monte_carlo(problem, n_real, n_steps, chunk=1000, seed=0, width=0.05, nbins=1800, dtype=np.float32):
    """jaxroll's statistics by the numba kernel: zero-crossing and envelope histograms, per-realization sums.

    `dtype`: the integration's floating type (float32 as jaxroll's Monte Carlo; float64 to compare). Random
    numbers: one PCG64 generator per core (numpy's ziggurat normals, 8x faster in numba than the legacy
    np.random), so a realization depends on the chunking (a concession to the baseline's speed).

    Envelope by scipy.fft (2 workers) on each chunk, histograms by np.bincount.
    """
    exc = problem.excitation
    a, b, pc, cap = ship_constants(problem)
    mats = [np.asarray(x, dtype=dtype) for x in (exc.phi, exc.chol, exc.stationary_chol, exc.c, exc.bridge[0],
                                                   exc.bridge[1])]
    a, b, pc = (np.asarray(x, dtype=dtype) for x in (a, b, pc))
    run = _numba_kernel()
    hz = np.zeros(nbins)
    he = np.zeros(nbins)
    sums = dict(n_zc=0.0, sum_zc=0.0, n_env=0.0, sum_env=0.0, capsized=0)
    for start in range(0, n_real, chunk):
        k = min(chunk, n_real - start)
        phi = np.empty((k, n_steps), dtype)
        amp = np.empty((k, n_steps), dtype)
        caps = np.zeros(k, dtype=np.bool_)
        g0, g1 = (np.random.default_rng([seed, start, lane]) for lane in (0, 1))
        run(g0, g1, k, exc.substeps, n_steps, dtype(exc.dt), *mats, a, b, pc, dtype(cap), dtype(problem.phi0), phi,
            amp, caps)
        keep = ~caps
        nt = n_steps
        spec = scipy.fft.rfft(phi[keep], axis=-1, workers=2)
        kk = np.arange(spec.shape[-1])
        spec[:, (kk == 0) | (kk >= (nt + 1) // 2)] = 0
        env = np.sqrt(phi[keep] ** 2 + scipy.fft.irfft(-1j * spec, n=nt, axis=-1, workers=2) ** 2)
        ak = amp[keep]
        sel = ak > 0
        hz += np.bincount(np.clip((ak[sel] * DEG / width).astype(np.int64), 0, nbins - 1), minlength=nbins)
        he += np.bincount(np.clip((env * DEG / width).astype(np.int64), 0, nbins - 1).ravel(), minlength=nbins)
        sums["n_zc"] += sel.sum()
        sums["sum_zc"] += ak[sel].astype(np.float64).sum()
        sums["n_env"] += env.size
        sums["sum_env"] += env.astype(np.float64).sum()
        sums["capsized"] += int(caps.sum())
    return hz, he, sums
