"""Short-term exceedance probabilities by theory, for every cell of a heading class at once.

`_theory_probability(ship, wave, angles, durations)` has the contract of `jaxroll.theory.passage_risk` (issue 34
item 2, the first-passage theory that knows large rolls come in groups). Until it is merged it is the
independent-amplitude route of today: the envelope FPK's zero-crossing law and P = 1 − F(a)^n with n the law's own
number of half cycles in the exposure. INTERIM: replaced by `jaxroll.theory.passage_risk` at merge.

Cells are computed by compiled programs whose inputs are the heading, speed and sea (the effective wave's static
structure — head/following, projected — is the same within a heading class), so a whole assessment compiles a
handful of programs. Two stages: the Lyapunov exponent λ of every cell (one (ρ, θ) solve each, vmapped in batches),
then the theory only where λ > 0. Where λ ≤ 0 the roll dies out: the theory's probability is 0 exactly (its
`exists` is λ > 0), so low seas, and seas whose effective wave misses the roll's parametric resonance, cost one
small solve each. On a CPU the theory runs one sea state per program call, the calls dispatched in turn to every
CPU device (each core is one, `import jaxroll`): the block-tridiagonal solve of one cell runs on one core, and a
vmapped batch of them ran slower per cell than one at a time (measured: 1.5 s per cell alone, 2.1–4.9 s per cell
in batches of 2–8, on the loaded 2-core machine); on GPUs, vmapped batches of `THEORY_BATCH` cells.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._compiled import SOLVER_PROGRAM, cached_program
from ..sea import ITTC, EffectiveWave
from ..theory import envelope_fpk_pdf, envelope_lyapunov_exponent

#: Sea states per compiled batch: the Lyapunov screen (one (ρ, θ) solve each) and, on GPUs, the theory (a
#: block-tridiagonal solve over the amplitude slices, ~100 MB of factors each with the default grid).
SCREEN_BATCH = 64
THEORY_BATCH = 8


class PassageRisk(eqx.Module):
    """Short-term risk by theory (the fields of `jaxroll.theory.passage_risk`'s result).

    `probability` [-], shape (angles, durations): P(max |φ| > angle within the exposure), capsize included;
    `capsize_probability` [-], shape (durations,); `exists`: λ > 0 (where False the probabilities are 0).
    """

    probability: Float[Array, "angles durations"]
    capsize_probability: Float[Array, " durations"]
    exists: Bool[Array, ""]


def _theory_probability(ship, wave, angles, durations) -> PassageRisk:
    """INTERIM adapter, replaced by `jaxroll.theory.passage_risk(ship, wave, angles, durations)` at merge.

    Independent amplitudes: the envelope FPK's zero-crossing (per half cycle) law F, n = (ω_l/π)·T half cycles in
    the exposure T [s] (ω_l the law's linearised roll frequency: its own half-cycle rate, the mean of the detuning
    ψ̇ left out), P = 1 − F(a)^n at each angle a [rad]. The capsize probability is that of the law's top cell (the
    range up to the vanishing angle, where the finite-volume law has its reflecting boundary): 1 − (1 − m_top)^n.
    Overestimates the exposure risk where large rolls come in groups (×2 at 6 m, 40°, 1 h: issue 34).

    **Arguments:** `ship`; `wave` (`EffectiveWave`); `angles` [rad], shape (angles,); `durations` [s], shape
    (durations,). **Returns:** `PassageRisk`. jit-able and vmappable (no host callback).
    """
    law = envelope_fpk_pdf(ship, wave, estimator="zero_crossing", throw=False)
    n = law.excitation.omega / jnp.pi * jnp.asarray(durations, dtype=float)
    logcdf = law.logcdf(jnp.asarray(angles, dtype=float))
    p = -jnp.expm1(logcdf[:, None] * n[None, :])
    cap = -jnp.expm1(jnp.log1p(-law.mass[-1]) * n)
    ok = law.exists & jnp.all(jnp.isfinite(p)) & jnp.all(jnp.isfinite(cap))
    return PassageRisk(jnp.where(ok, p, 0.0), jnp.where(ok, cap, 0.0), law.exists)


def _wave(template: EffectiveWave, sea) -> EffectiveWave:
    return eqx.tree_at(lambda w: w.sea, template, sea)


@cached_program(compiler_options=SOLVER_PROGRAM)
def _screen_batch(ship, seas, template):
    """(λ [1/s], fitted envelope decay γ [1/s]) of each sea state of the batch `seas` (an `ITTC` with arrays)."""

    def one(sea):
        lam, exc = envelope_lyapunov_exponent(ship, _wave(template, sea))
        return lam, exc.gamma

    return jax.vmap(one)(seas)


@cached_program(compiler_options=SOLVER_PROGRAM)
def _theory_batch(ship, seas, template, angles, durations):
    """`PassageRisk` fields of each sea state of the batch `seas` (vmapped: for GPUs)."""

    def one(sea):
        r = _theory_probability(ship, _wave(template, sea), angles, durations)
        return r.probability, r.capsize_probability, r.exists

    return jax.vmap(one)(seas)


@cached_program(compiler_options=SOLVER_PROGRAM)
def _theory_cell(ship, sea, template, angles, durations):
    """`PassageRisk` fields of one sea state `sea` (for CPUs)."""
    r = _theory_probability(ship, _wave(template, sea), angles, durations)
    return r.probability, r.capsize_probability, r.exists


def _seas(hs: np.ndarray, t01: np.ndarray) -> ITTC:
    """One `ITTC` whose fields hold the arrays `hs` [m] and `t01` [s] (checked here, > 0 and finite): the batch."""
    if not (np.all(np.isfinite(hs)) and np.all(hs > 0) and np.all(np.isfinite(t01)) and np.all(t01 > 0)):
        raise ValueError("sea states need finite H_s > 0 and T01 > 0.")
    return eqx.tree_at(lambda s: (s.hs, s.t01), ITTC(1.0, 10.0), (jnp.asarray(hs, float), jnp.asarray(t01, float)))


def _batches(n: int, size: int):
    """Index arrays of fixed-size batches over range(n), the last padded with index 0 (results dropped)."""
    for start in range(0, n, size):
        idx = np.arange(start, start + size)
        yield idx, np.where(idx < n, idx, 0), min(size, n - start)


def class_template(ship, speed: float, heading_deg: float) -> EffectiveWave:
    """The effective wave of a heading class at `speed` [m/s] (its sea is replaced per cell)."""
    return EffectiveWave(ITTC(1.0, 10.0), ship.lpp, speed, math.radians(heading_deg))


def class_theory(ship, template: EffectiveWave, hs, t01, angles, exposure: float, progress=None) -> dict:
    """Theory for the cells (`hs` [m], `t01` [s], 1-D) of one heading class and speed (`template`).

    **Returns:** dict of host arrays per cell: `lyapunov_exponent` [1/s], `envelope_gamma` [1/s], `probability`
    [-] (cells, angles), `capsize_probability` [-], `exists`. `progress(n)` is called with the cells done.
    """
    hs, t01 = np.asarray(hs, float), np.asarray(t01, float)
    n = hs.size
    angles = jnp.asarray(angles, float)
    durations = jnp.asarray([exposure], float)
    lam, gamma = np.zeros(n), np.zeros(n)
    for idx, take, m in _batches(n, SCREEN_BATCH):
        out = _screen_batch(ship, _seas(hs[take], t01[take]), template)
        lam[idx[:m]], gamma[idx[:m]] = (np.asarray(x)[:m] for x in out)
    prob = np.zeros((n, angles.size))
    cap = np.zeros(n)
    exists = np.zeros(n, bool)
    live = np.flatnonzero(lam > 0)  # λ ≤ 0: the theory's probability is 0 (its `exists` is λ > 0)
    done = n - live.size
    if progress is not None and done:
        progress(done)
    devices = jax.local_devices()
    if devices[0].platform == "cpu":  # one sea state per call, the calls spread over the CPU devices
        fixed = [jax.device_put((ship, template, angles, durations), d) for d in devices]
        pending = []
        for n_, c in enumerate(live):
            d = n_ % len(devices)
            sh, tm, an, du = fixed[d]
            sea = jax.device_put(ITTC(float(hs[c]), float(t01[c])), devices[d])
            pending.append((c, _theory_cell(sh, sea, tm, an, du)))
        for c, (p, cp, e) in pending:
            prob[c], cap[c], exists[c] = np.asarray(p)[:, 0], np.asarray(cp)[0], bool(e)
            if progress is not None:
                progress(1)
    else:
        for idx, take, m in _batches(live.size, THEORY_BATCH):
            cells = live[take]
            p, c, e = _theory_batch(ship, _seas(hs[cells], t01[cells]), template, angles, durations)
            keep = live[idx[:m]]
            prob[keep] = np.asarray(p)[:m, :, 0]
            cap[keep] = np.asarray(c)[:m, 0]
            exists[keep] = np.asarray(e)[:m]
            if progress is not None:
                progress(m)
    return {"lyapunov_exponent": lam, "envelope_gamma": gamma, "probability": prob, "capsize_probability": cap,
            "exists": exists}
