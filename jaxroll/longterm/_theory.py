"""Short-term exceedance probabilities by theory for the cells of one (ship, heading class, speed): the envelope
FPK model followed through the exposure (`jaxroll.theory.passage_risk`, which knows that large rolls come in
groups; within ×0.85–1.17 of the direct Monte Carlo at H1/3 5–8 m, 25–40°, 1 h and 3 h: docs/theory.md §7).

One `passage_risk` costs ~0.5–1 s per sea state on a CPU core. The Lyapunov exponent λ of every cell comes
first, one (ρ, θ) solve on `passage_risk`'s own (ρ, θ) grid, vmapped in batches: where λ ≤ 0 the roll dies out
and `passage_risk`'s probabilities are 0 exactly (its `exists` is λ > 0), so low seas, and seas whose effective
wave misses the roll's parametric resonance, cost one small solve each; `passage_risk` runs only where λ > 0.
(Bracketing the cells of a scatter column in H_s between solved ones was tried and dropped: P is not monotone
in H_s here — between solved cells of one column it fell by up to 0.999 with rising H_s (Rec. 34 rows 4.5–9.5 m,
T_z 7.5–10.5 s, headings 0/150/180°, 0 and 4 m/s; probably the mean GM rising with the sea, ΔGM's even terms,
detuning the resonance), and at a 2 % tolerance it saved 6 of 105 solves.)
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._compiled import SOLVER_PROGRAM, cached_program
from ..sea import ITTC, EffectiveWave
from ..theory import envelope_lyapunov_exponent, passage_risk

#: Sea states per compiled batch of the Lyapunov screen (one (ρ, θ) solve each).
SCREEN_BATCH = 64
#: `passage_risk`'s (ρ, θ) grid (its defaults): the screen's λ is the one `passage_risk` tests for `exists`.
NUM_RHO, NUM_THETA = 8, 12


@cached_program(compiler_options=SOLVER_PROGRAM)
def _screen_batch(ship, seas, template):
    """(λ [1/s], fitted envelope decay γ [1/s]) of each sea state of the batch `seas` (an `ITTC` with arrays)."""

    def one(sea):
        lam, exc = envelope_lyapunov_exponent(ship, eqx.tree_at(lambda w: w.sea, template, sea), num_rho=NUM_RHO,
                                              num_theta=NUM_THETA)
        return lam, exc.gamma

    return jax.vmap(one)(seas)


def _seas(hs: np.ndarray, t01: np.ndarray) -> ITTC:
    """One `ITTC` whose fields hold the arrays `hs` [m] and `t01` [s] (checked here, > 0 and finite): the batch."""
    if not (np.all(np.isfinite(hs)) and np.all(hs > 0) and np.all(np.isfinite(t01)) and np.all(t01 > 0)):
        raise ValueError("sea states need finite H_s > 0 and T01 > 0.")
    return eqx.tree_at(lambda s: (s.hs, s.t01), ITTC(1.0, 10.0), (jnp.asarray(hs, float), jnp.asarray(t01, float)))


def class_template(ship, speed: float, heading_deg: float) -> EffectiveWave:
    """The effective wave of a heading class at `speed` [m/s] (its sea is replaced per cell)."""
    return EffectiveWave(ITTC(1.0, 10.0), ship.lpp, speed, math.radians(heading_deg))


def _solve(ship, template, hs, t01, cells, angles, durations, devices) -> dict:
    """`passage_risk` of the cells `cells` (indices into `hs`, `t01`), dispatched in turn to the devices (one
    sea state per call: a vmapped batch ran slower per cell on a CPU). **Returns:** {cell: (P per angle, capsize
    P)}."""
    fixed = [jax.device_put((ship, template), d) for d in devices]
    pending = []
    for n, c in enumerate(cells):
        d = n % len(devices)
        sh, tm = fixed[d]
        sea = eqx.tree_at(lambda s: (s.hs, s.t01), ITTC(1.0, 10.0), (jnp.asarray(hs[c]), jnp.asarray(t01[c])))
        wave = eqx.tree_at(lambda w: w.sea, tm, jax.device_put(sea, devices[d]))
        pending.append((c, passage_risk(sh, wave, angles, durations)))
    return {c: (np.asarray(r.probability)[:, 0], float(np.asarray(r.capsize_probability)[0])) for c, r in pending}


def class_theory(ship, template: EffectiveWave, hs, t01, angles, exposure: float, progress=None) -> dict:
    """Theory for the cells (`hs` [m], `t01` [s], 1-D) of one heading class and speed (`template`).

    **Returns:** dict of host arrays per cell: `lyapunov_exponent` [1/s], `envelope_gamma` [1/s], `probability`
    [-] (cells, angles), `capsize_probability` [-]. `progress(n)` is called with the cells done.
    """
    hs, t01 = np.asarray(hs, float), np.asarray(t01, float)
    n = hs.size
    angles = jnp.asarray(angles, float)
    durations = jnp.asarray([exposure], float)
    lam, gamma = np.zeros(n), np.zeros(n)
    for start in range(0, n, SCREEN_BATCH):
        idx = np.arange(start, start + SCREEN_BATCH)
        take = np.where(idx < n, idx, 0)  # the last batch padded with cell 0 (its results dropped)
        m = min(SCREEN_BATCH, n - start)
        out = _screen_batch(ship, _seas(hs[take], t01[take]), template)
        lam[idx[:m]], gamma[idx[:m]] = (np.asarray(x)[:m] for x in out)
    prob, cap = np.zeros((n, int(angles.size))), np.zeros(n)
    live = np.flatnonzero(lam > 0)  # λ ≤ 0: the theory's probability is 0 exactly (its `exists` is λ > 0)
    if progress is not None and n - live.size:
        progress(n - live.size)
    for c, (p, cp) in _solve(ship, template, hs, t01, live, angles, durations, jax.local_devices()).items():
        prob[c], cap[c] = p, cp
    if progress is not None and live.size:
        progress(int(live.size))
    return {"lyapunov_exponent": lam, "envelope_gamma": gamma, "probability": prob, "capsize_probability": cap}
