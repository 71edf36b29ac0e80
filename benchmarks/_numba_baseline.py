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
    def one(
        g,
        i,
        n,
        m,
        r,
        n_steps,
        start,
        h,
        phid,
        chol,
        schol,
        c,
        wa,
        wb,
        a,
        b,
        pc,
        cap,
        phi0,
        width,
        phi_out,
        zbuf,
        hist,
        zsum,
        capsized,
    ):
        nbins = hist.size
        nr = chol.shape[1]
        z = np.empty(n, phid.dtype)
        e = np.empty(n, phid.dtype)
        zn = np.empty(n, phid.dtype)
        p = np.empty(2 * m + 1, phid.dtype)
        for q in range(n):
            e[q] = g.standard_normal()
        for q in range(n):
            s = 0.0
            for u in range(n):
                s += schol[q, u] * e[u]
            z[q] = s
        x0 = 0.0
        for q in range(n):
            x0 += c[q] * z[q]
        p[2 * m] = pexc(pc, x0)
        phi, dphi = phi0, phi0 * 0
        alive = True
        positive = phi >= 0
        started = False
        peak = abs(phi)
        nz = 0
        total = 0.0
        k = 0
        while k < n_steps:
            # one filter step of m time steps: exact transition, then the bridge at the 2m − 1 stage times
            for q in range(nr):  # the step's noise: its nr principal directions (jaxroll's `noise_rank`)
                e[q] = g.standard_normal()
            for q in range(n):
                s = 0.0
                for u in range(n):
                    s += phid[q, u] * z[u]
                for u in range(nr):
                    s += chol[q, u] * e[u]
                zn[q] = s
            p[0] = p[2 * m]
            for j in range(2 * m - 1):
                x = 0.0
                for q in range(n):
                    x += wa[j, q] * z[q] + wb[j, q] * zn[q]
                p[j + 1] = pexc(pc, x)
            x = 0.0
            for q in range(n):
                z[q] = zn[q]
                x += c[q] * z[q]
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
                k += 1
                # zero-crossing amplitude (as jaxroll.zero_crossing_update): its bin, after the discard
                pos = phi >= 0
                crossed = pos != positive
                if crossed and started and k > start:
                    zbuf[nz] = min(int(peak * DEG / width), nbins - 1)
                    nz += 1
                    total += peak
                peak = abs(phi) if crossed else max(peak, abs(phi))
                started = started or crossed
                positive = pos
                if k % r == 0:  # φ recorded every r steps, as jaxroll's histogram observer
                    phi_out[i, k // r - 1] = phi
        if alive:  # a capsized trial is left out of the statistics, as in jaxroll
            for j in range(nz):
                hist[zbuf[j]] += 1
            zsum[i, 0] = nz
            zsum[i, 1] = total

    @nb.njit(parallel=True)
    def run(
        g0,
        g1,
        n_real,
        m,
        r,
        n_steps,
        start,
        h,
        phid,
        chol,
        schol,
        c,
        wa,
        wb,
        a,
        b,
        pc,
        cap,
        phi0,
        width,
        phi_out,
        hist,
        zsum,
        capsized,
    ):
        n = c.size
        for lane in nb.prange(2):  # one PCG64 generator (ziggurat normals) per lane = per core
            g = g0 if lane == 0 else g1
            zbuf = np.empty(n_steps, np.int32)
            for i in range(lane, n_real, 2):
                one(
                    g,
                    i,
                    n,
                    m,
                    r,
                    n_steps,
                    start,
                    h,
                    phid,
                    chol,
                    schol,
                    c,
                    wa,
                    wb,
                    a,
                    b,
                    pc,
                    cap,
                    phi0,
                    width,
                    phi_out,
                    zbuf,
                    hist[lane],
                    zsum,
                    capsized,
                )

    _NUMBA["k"] = run
    return run


def numba_monte_carlo(
    problem, n_real, n_steps, discard=500.0, chunk=1000, seed=0, width=0.05, nbins=1800, dtype=np.float32
):
    """jaxroll's statistics by the numba kernel, as `jaxroll.monte_carlo_amplitudes(..., discard)`: zero-crossing
    amplitudes binned in the kernel (every step), φ recorded every r steps (`jaxroll.envelope_record_every`) and the
    envelope histogram of its record after the discard; capsized trials left out.

    `dtype`: the integration's floating type (float32 as jaxroll's Monte Carlo; float64 to compare). Random
    numbers: one PCG64 generator per core (numpy's ziggurat normals, 8x faster in numba than the legacy
    np.random), so a realization depends on the chunking (a concession to the baseline's speed).

    Envelope by scipy.fft (2 workers) on each chunk, its histogram by np.bincount.
    """
    import jaxroll

    exc = problem.excitation
    r = jaxroll.envelope_record_every(problem)
    start = int(round(discard / exc.dt))
    a, b, pc, cap = ship_constants(problem)
    mats = [
        np.asarray(x, dtype=dtype)
        for x in (exc.phi, exc.chol, exc.stationary_chol, exc.c, exc.bridge[0], exc.bridge[1])
    ]
    a, b, pc = (np.asarray(x, dtype=dtype) for x in (a, b, pc))
    run = _numba_kernel()
    hist_zc = np.zeros((2, nbins), np.int64)
    he = np.zeros(nbins)
    sums = dict(n_zc=0.0, sum_zc=0.0, n_env=0.0, sum_env=0.0, capsized=0)
    for first in range(0, n_real, chunk):
        k = min(chunk, n_real - first)
        phi = np.empty((k, n_steps // r), dtype)
        caps = np.zeros(k, dtype=np.bool_)
        zsum = np.zeros((k, 2))
        g0, g1 = (np.random.default_rng([seed, first, lane]) for lane in (0, 1))
        run(
            g0,
            g1,
            k,
            exc.substeps,
            r,
            n_steps,
            start,
            dtype(exc.dt),
            *mats,
            a,
            b,
            pc,
            dtype(cap),
            dtype(problem.phi0),
            width,
            phi,
            hist_zc,
            zsum,
            caps,
        )
        kept = phi[~caps, start // r :]
        nt = kept.shape[1]
        spec = scipy.fft.rfft(kept, axis=-1, workers=2)
        kk = np.arange(spec.shape[-1])
        spec[:, (kk == 0) | (kk >= (nt + 1) // 2)] = 0
        env = np.sqrt(kept**2 + scipy.fft.irfft(-1j * spec, n=nt, axis=-1, workers=2) ** 2)
        he += np.bincount(
            np.clip((env * DEG / width).astype(np.int64), 0, nbins - 1).ravel(), minlength=nbins
        )
        sums["n_env"] += env.size
        sums["sum_env"] += env.astype(np.float64).sum()
        sums["capsized"] += int(caps.sum())
        sums["n_zc"] += zsum[:, 0].sum()
        sums["sum_zc"] += zsum[:, 1].sum()
    return hist_zc.sum(0).astype(float), he, sums
