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

**Two passes** (`refine_delta` δ): pass 1 solves every λ > 0 cell on one grid (`extrapolate=False`, a third of
the work); pass 2 runs the Richardson-extrapolated `passage_risk` (its `num_s` grid reused from pass 1: twice
the work of one grid) only on the smallest set of cells that carries at
least 1 − δ of the unit's Σ_c w_c P1_c for each angle (largest w_c P1_c first, `auto_cells`' rule). The other
cells keep P1 (together at most δ of the pass-1 sum); the long-term interval widens their allowance by the
pass-2/pass-1 ratios measured on the refined cells (`_run._fill`, docs/longterm.md). δ = 0: every λ > 0 cell
by the extrapolated `passage_risk` (one pass).
"""

from __future__ import annotations

import itertools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._compiled import SOLVER_PROGRAM, cached_program
from .._config import single_threaded_blas
from ..sea import ITTC, EffectiveWave
from ..theory import EnvelopeExcitation, envelope_lyapunov_exponent
from ..theory._envelope_fpk_passage import GRID_DEFAULTS, _batch_dispatch, _concrete_top
from ._risk import auto_cells

#: Sea states per compiled batch of the Lyapunov screen (one (ρ, θ) solve each).
SCREEN_BATCH = 64
#: `passage_risk`'s grid (its defaults, `GRID_DEFAULTS` order): num_s, num_s_coarse, num_rho, num_theta, rho_max [-],
#: a_fine [rad], a_min [rad].
GRID = GRID_DEFAULTS
#: Its (ρ, θ) grid: the screen's λ is the one `passage_risk` tests for `exists`.
NUM_RHO, NUM_THETA = GRID[2], GRID[3]
#: Sea states per `passage_risk_batch` call (measured best on a 2-core CPU: 1 → 4 halves the calls' overhead).
SEAS_PER_CALL = 4
#: Inverse iterations per level (`passage_risk`'s default is 5): 3 move a cell's P by ≤ 6e-4 relative (its high-P
#: cells, where the slowest mode converges slowest), the long-term P far less (docs/longterm.md, "Cost"); the
#: iterations are ~15 % of a cell's work, the factorisations the rest.
NUM_ITERATIONS = 3
#: δ: the cells left at pass 1 carry at most this share of a unit's pass-1 Σ w P per angle (module docstring).
REFINE_DELTA = 0.01


@cached_program(compiler_options=SOLVER_PROGRAM)
def _screen_batch(ship, seas, template):
    """(λ [1/s], the fitted envelope) of each sea state of the batch `seas` (an `ITTC` with arrays)."""

    def one(sea):
        return envelope_lyapunov_exponent(
            ship, eqx.tree_at(lambda w: w.sea, template, sea), num_rho=NUM_RHO, num_theta=NUM_THETA
        )

    return jax.vmap(one)(seas)


def _seas(hs: np.ndarray, t01: np.ndarray) -> ITTC:
    """One `ITTC` whose fields hold the arrays `hs` [m] and `t01` [s] (checked here, > 0 and finite): the batch."""
    if not (np.all(np.isfinite(hs)) and np.all(hs > 0) and np.all(np.isfinite(t01)) and np.all(t01 > 0)):
        raise ValueError("sea states need finite H_s > 0 and T01 > 0.")
    return eqx.tree_at(
        lambda s: (s.hs, s.t01), ITTC(1.0, 10.0), (jnp.asarray(hs, float), jnp.asarray(t01, float))
    )


def class_template(ship, speed: float, heading_deg: float, spreading=None) -> EffectiveWave:
    """The effective wave of a heading class at `speed` [m/s] (its sea is replaced per cell), short-crested with a
    `spreading` (`jaxroll.sea.Spreading`)."""
    return EffectiveWave(ITTC(1.0, 10.0), ship.lpp, speed, math.radians(heading_deg), spreading=spreading)


def _solve(
    ship, template, hs, t01, cells, angles, durations, devices, extrapolate: bool, excitations, coarse=None
) -> dict:
    """`passage_risk` of the cells `cells` (indices into `hs`, `t01`) by `passage_risk_batch`, `SEAS_PER_CALL` seas a
    call, the calls dispatched in turn to the devices without waiting (each device an equal share of the cells; one
    compiled program per device, the devices working together), with one BLAS thread (the caller holds
    `single_threaded_blas`). `excitations`: the screen's
    fitted envelopes (host arrays per cell); `coarse`: {cell: its one-grid result, host arrays}, reused by the
    extrapolation. **Returns:** {cell: (P per angle, capsize P, the `PassageRisk` of that cell, host arrays)}."""
    cells = np.asarray(cells, int)
    if cells.size == 0:
        return {}
    fixed = [jax.device_put((ship, template), d) for d in devices]
    # the vanishing angle once: each call's inputs are then placed without waiting
    top = _concrete_top(ship, "passage_risk_batch")
    # each device takes an equal share of the cells (to one sea), in calls of `SEAS_PER_CALL` dispatched in turn;
    # the last call of a share is padded with skipped seas (`valid` False: no work), so both devices finish
    # together
    shares = np.array_split(cells, len(devices))
    calls = [
        [(d, share[start : start + SEAS_PER_CALL]) for start in range(0, share.size, SEAS_PER_CALL)]
        for d, share in enumerate(shares)
    ]
    pending = []
    for d, chunk in (c for round_ in itertools.zip_longest(*calls) for c in round_ if c is not None):
        if chunk.size == 0:
            continue
        take = np.concatenate([chunk, np.repeat(chunk[-1:], SEAS_PER_CALL - chunk.size)])  # padded: one shape
        sh, tm = fixed[d]
        waves = [  # only the sea's H_s and T01 differ (batched); the rest is the class's, shared
            eqx.tree_at(
                lambda w: (w.sea.hs, w.sea.t01), tm, (np.asarray(hs[c], float), np.asarray(t01[c], float))
            )
            for c in take
        ]
        exc = jax.tree.map(lambda x: x[take], excitations)
        crs = None if coarse is None else jax.tree.map(lambda *xs: np.stack(xs), *[coarse[c] for c in take])
        r = _batch_dispatch(
            sh,
            waves,
            angles,
            durations,
            excitations=exc,
            grid_args=GRID,
            num_iterations=NUM_ITERATIONS,
            observe="peaks",
            extrapolate=extrapolate,
            coarse=crs,
            device=devices[d],
            valid=np.arange(SEAS_PER_CALL) < chunk.size,
            top=top,
        )
        pending.append((chunk, r))
    out = {}
    for chunk, r in pending:  # the results, in the order dispatched
        r = jax.tree.map(np.asarray, r)
        for i, c in enumerate(chunk):
            one = jax.tree.map(lambda x, i=i: x[i], r)
            out[int(c)] = (one.probability[:, 0], float(one.capsize_probability[0]), one)
    return out


def screen(ship, template: EffectiveWave, hs, t01) -> tuple[np.ndarray, np.ndarray, EnvelopeExcitation]:
    """(λ [1/s], envelope γ [1/s], the fitted envelopes (host arrays per sea)) of the sea states (`hs` [m], `t01`
    [s], 1-D) of one heading class and speed, vmapped in batches of `SCREEN_BATCH`. The envelopes are those
    `passage_risk` fits (the same ω_l and sea), passed on to it (`excitation`)."""
    hs, t01 = np.asarray(hs, float), np.asarray(t01, float)
    n = hs.size
    lam = np.zeros(n)
    parts = []
    for start in range(0, n, SCREEN_BATCH):
        idx = np.arange(start, start + SCREEN_BATCH)
        take = np.where(idx < n, idx, 0)  # the last batch padded with cell 0 (its results dropped)
        m = min(SCREEN_BATCH, n - start)
        lam_b, exc_b = _screen_batch(ship, _seas(hs[take], t01[take]), template)
        lam[idx[:m]] = np.asarray(lam_b)[:m]
        parts.append(jax.tree.map(lambda x, m=m: np.asarray(x)[:m], exc_b))
    exc = jax.tree.map(lambda *xs: np.concatenate(xs), *parts)
    return lam, exc.gamma, exc


def refine_set(weight, p1, live, delta: float) -> np.ndarray:
    """The cells pass 2 refines: for each angle the smallest set of `live` cells whose w·P1 add up to at least
    1 − `delta` of their sum (largest first); all `live` cells where `delta` is 0. `weight` (cells,), `p1`
    (cells, angles). **Returns:** a mask (cells,)."""
    live = np.asarray(live, bool)
    if delta <= 0:
        return live.copy()
    p1 = np.asarray(p1, float)
    dominant, _ = auto_cells(weight, p1, np.zeros(live.size, bool), live, share=1.0 - delta, tolerance=1.0)
    return dominant & live & np.any(p1 > 0, axis=1)


def class_theory(
    ship,
    template: EffectiveWave,
    hs,
    t01,
    angles,
    exposure: float,
    progress=None,
    weight=None,
    refine_delta: float = REFINE_DELTA,
) -> dict:
    """Theory for the cells (`hs` [m], `t01` [s], 1-D) of one heading class and speed (`template`), in two
    passes (module docstring): `weight` the cells' weights (default equal), `refine_delta` δ.

    **Returns:** dict of host arrays per cell: `lyapunov_exponent` [1/s], `envelope_gamma` [1/s], `probability`
    [-] (cells, angles; pass 2 where refined, else pass 1), `capsize_probability` [-], `pass1_probability`
    (cells, angles) and `pass1_capsize_probability` (NaN where δ = 0: no pass 1), `refined` (bool),
    `pass_ratio`, `pass_capsize_ratio` (the unit's `pass_ratio`, per cell). `progress(n)`
    is called with the cells done (a cell counts when its last pass is done).
    """
    hs, t01 = np.asarray(hs, float), np.asarray(t01, float)
    n = hs.size
    weight = np.ones(n) if weight is None else np.asarray(weight, float)
    angles = np.asarray(angles, float)
    durations = np.asarray([exposure], float)
    lam, gamma, excitations = screen(ship, template, hs, t01)
    n_a = int(angles.size)
    prob, cap = np.zeros((n, n_a)), np.zeros(n)
    live = lam > 0  # λ ≤ 0: the theory's probability is 0 exactly (its `exists` is λ > 0)
    if progress is not None and n - live.sum():
        progress(int(n - live.sum()))
    devices = jax.local_devices()
    p1, c1 = np.full((n, n_a), np.nan), np.full(n, np.nan)
    first = None
    with single_threaded_blas():
        if refine_delta > 0:
            p1[~live], c1[~live] = 0.0, 0.0
            first = _solve(
                ship, template, hs, t01, np.flatnonzero(live), angles, durations, devices, False, excitations
            )
            for c, (p, cp, _) in first.items():
                p1[c], c1[c] = p, cp
            prob[:], cap[:] = p1, c1
            first = {c: r for c, (_, _, r) in first.items()}
        refined = refine_set(weight, np.nan_to_num(p1), live, refine_delta)
        if progress is not None and live.sum() - refined.sum():
            progress(int(live.sum() - refined.sum()))
        for c, (p, cp, _) in _solve(
            ship,
            template,
            hs,
            t01,
            np.flatnonzero(refined),
            angles,
            durations,
            devices,
            True,
            excitations,
            first,
        ).items():
            prob[c], cap[c] = p, cp
    if progress is not None and refined.sum():
        progress(int(refined.sum()))
    ones = np.ones(n)
    return {
        "lyapunov_exponent": lam,
        "envelope_gamma": gamma,
        "probability": prob,
        "capsize_probability": cap,
        "pass1_probability": p1,
        "pass1_capsize_probability": c1,
        "refined": refined,
        "pass_ratio": pass_ratio(prob[refined], p1[refined]) * ones,
        "pass_capsize_ratio": pass_ratio(cap[refined], c1[refined]) * ones,
    }


def pass_ratio(p2, p1) -> float:
    """The largest ratio pass 2 / pass 1 over refined cells where both are > 0 (at least 1; 1 where there are
    none): the factor by which a cell left at pass 1 is allowed to lie above its value."""
    p2, p1 = np.asarray(p2, float).ravel(), np.asarray(p1, float).ravel()
    ok = (p1 > 0) & (p2 > 0) & np.isfinite(p1) & np.isfinite(p2)
    return float(max(1.0, np.max(p2[ok] / p1[ok]))) if ok.any() else 1.0
