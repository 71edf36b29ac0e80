"""Exposure risk when large rolls come in groups: the envelope FPK model followed through the exposure.

P(max |φ| over an exposure T > a), capsize included. Independent amplitudes (`exceedance_probability`, P* with
N0 = rate·T) overstate it where exceedances come in clusters; here the averaged model of `_envelope_fpk` (the
Markov process X = (s = ln A, ρ, θ) with the wave's envelope as a state) is followed through time, so a group of
large rolls counts once.

**What is observed.** The roll is seen at its peaks: |φ| exceeds a when a peak does, and the averaged model has
no fast phase to time them, so the peaks are a Poisson stream at the model's own half-cycle rate r(X) =
(ω + ψ̇)/π (the rate that weights the zero-crossing law). The survival u(x, t) = P_x(no peak above a before t)
solves the backward equation ∂u/∂t = 𝓛u − r(x) 1[A > a] u (Feynman–Kac); in the forward (finite-volume) form,
mass above a is removed at the rate r. Where the envelope decorrelates within a half cycle this is the
independent-amplitude Poisson form 1 − exp(−rate F̄ T); the clusters come from the memory of A and of the
wave envelope. (Watching the envelope itself — absorbing at A = a, `observe="continuous"` — counts excursions
between two peaks too: ×1.5–1.8 above the Monte Carlo on the default ship.)

**Survival.** With the forward operator A_a (killing above a; the vanishing angle absorbing: capsize) and the
start law p0, S(T) = 1ᵀ exp(A_a T) p0 = Σ_k c_k e^{−λ_k T}. The moments M_n = 1ᵀ(−A_a)^{−n} p0 = Σ_k c_k/λ_k^n come
from n solves with one block-tridiagonal factorisation (inverse iteration): λ_1 = lim M_n/M_{n+1} (groups of
large rolls per second once the start is forgotten), c_1 = lim M_n λ_1^n. The other modes relax within the roll's
relaxation time (minutes); they are lumped into one exponential that keeps M_0 and M_1 (the mean time to the
first passage, ∫S dT) exact:

    S(T) ≈ c_1 e^{−λ_1 T} + (M_0 − c_1) e^{−T/τ_2},   τ_2 = (M_1 − c_1/λ_1) / (M_0 − c_1).

**Start.** The exposure starts in the quasi-stationary law: the slowest mode of the capsize problem (no killing),
i.e. the stationary law of a roll that has not capsized — what a Monte Carlo holds after discarding its first
minutes. Its rate is the capsize rate: P(capsize within T) = 1 − e^{−λ_c T}.

**Discretisation.** First-order upwind fluxes in s: its operator keeps mass positive, so the nearly singular
systems of rare passages (λ_1 down to 1e-12 1/s) solve exactly; the second-order defect correction of the
stationary law does not converge there (its sweeps amplify the slowest mode by λ_1(A₂)/λ_1(A₁) − 1). Its O(Δs)
error in the log of a tail quantity is removed by Richardson extrapolation over Δs and Δs/2. Each level is a cell
face (the nearest one moved onto it). Below the lowest level every system has the same rows, so the
block-Thomas factors there are computed once. Derivation, validation against the Monte Carlo and limits:
docs/theory.md, "Exposure risk when large rolls come in groups".
"""

from __future__ import annotations

import dataclasses
import inspect
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._compiled import SOLVER_PROGRAM, cached_program, filter_jit, is_concrete
from .._config import require_float64, single_threaded_blas
from ..ship._restoring import vanishing_angle
from ..ship._ship import Ship
from ._envelope_fpk import (
    _build_model,
    _factorise_slices,
    _Grid,
    _grid,
    _linear_frequency,
    _lyapunov,
    _phase_velocity,
    _solve,
    fit_envelope,
)
from ._envelope_fpk_law import EnvelopeExcitation
from ._linear import refuse_wave_moment


class PassageRisk(eqx.Module):
    """Exposure risk from the envelope FPK model followed through the exposure (`passage_risk`). Angles [rad],
    times [s].

    **Fields:**

    - `angles` [rad] (`n_a`), `durations` [s] (`n_T`): the levels and exposures asked for.
    - `probability` [-] (`n_a`, `n_T`): P(max |φ| > angle within the exposure), capsize included (a capsizing
      roll passes every angle first).
    - `capsize_probability` [-] (`n_T`): P(the amplitude reaches the vanishing angle within the exposure).
    - `cluster_rate` [1/s] (`n_a`): λ_1, the rate of first passages once the start is forgotten (one per group
      of large rolls); `mean_passage_time` [s] (`n_a`): M_1/M_0, the mean time to the first peak above the angle
      from the start law below it; `start_exceedance` [-] (`n_a`): the probability that the amplitude is already
      above the angle when the exposure starts.
    - `amplitude_rate` [1/s]: zero-crossing amplitudes per second (the model's half-cycle rate);
      `exceedance_per_cycle` [-] (`n_a`): F̄(angle) of the model's zero-crossing law; `independent_probability`
      [-] (`n_a`, `n_T`): 1 − (1 − F̄)^{rate·T}, the same model's amplitudes taken as independent (what
      `exceedance_probability` gives); `extremal_index` [-] (`n_a`): θ = λ_1 / (rate · F̄), 1/θ the mean number of
      amplitudes above the angle per cluster.
    - `lyapunov_exponent` λ [1/s] and `exists` (λ > 0): where the roll dies out (λ ≤ 0) every probability is 0.
    - `hazard` [-] (`n_a`, `n_T`) and `capsize_hazard` [-] (`n_T`): −ln S(T) of the solution, before the λ ≤ 0
      mask (what `passage_risk(coarse=…)` extrapolates from).
    - `excitation`: the fitted envelope; `grid`: the numerical settings.
    """

    angles: Float[Array, " n_a"]
    durations: Float[Array, " n_T"]
    probability: Float[Array, "n_a n_T"]
    capsize_probability: Float[Array, " n_T"]
    cluster_rate: Float[Array, " n_a"]
    mean_passage_time: Float[Array, " n_a"]
    start_exceedance: Float[Array, " n_a"]
    amplitude_rate: Float[Array, ""]
    exceedance_per_cycle: Float[Array, " n_a"]
    independent_probability: Float[Array, "n_a n_T"]
    extremal_index: Float[Array, " n_a"]
    lyapunov_exponent: Float[Array, ""]
    exists: Bool[Array, ""]
    hazard: Float[Array, "n_a n_T"]
    capsize_hazard: Float[Array, " n_T"]
    excitation: EnvelopeExcitation
    grid: tuple = eqx.field(static=True)

    @property
    def angles_deg(self) -> Float[Array, " n_a"]:
        """`angles` [deg]."""
        return jnp.rad2deg(self.angles)


_CONTINUOUS = 1e3  # [1/s]: a killing rate that absorbs within milliseconds ("observe='continuous'")


def _peak_rate(md):
    """(ω + ψ̇)/π [1/s] in every cell [ns, m]: the rate of roll peaks (zero-crossing amplitudes, two per cycle),
    ψ̇ = ν(a, ρ) + w(ρ) cos θ/(4ω) the averaged phase velocity (as the zero-crossing law weights its cells)."""
    return (md.omega + _phase_velocity(md)) / jnp.pi


def _survival_moments(md, factors, p, num_iterations: int):
    """((M_0, M_1, λ_1, c_1), mode): the survival's moments from the start cells' probabilities p [ns, m]
    (module docstring), and the last iterate: the slowest mode's cell probabilities (the quasi-stationary law)."""
    m0 = jnp.sum(p)

    def iterate(n, carry):
        u, log_ratios = carry
        # (−A)⁻¹u: the operator acts on densities per unit s, u holds cell probabilities
        x = _solve(md, factors, -u / md.ds[:, None]) * md.ds[:, None]
        r = jnp.sum(x)
        return x / r, log_ratios.at[n].set(jnp.log(r))

    mode, log_ratios = jax.lax.fori_loop(0, num_iterations, iterate, (p / m0, jnp.zeros(num_iterations)))
    rate = jnp.exp(-log_ratios[-1])  # λ_1 = M_n / M_{n+1}
    c1 = m0 * jnp.exp(jnp.sum(log_ratios - log_ratios[-1]))  # c_1 = M_N λ_1^N
    return (m0, m0 * jnp.exp(log_ratios[0]), rate, c1), mode


def _survival(m0, m1, rate, c1, durations):
    """S(T) [n_T] from the slowest mode plus one lumped fast mode with M_0 and M_1 exact (module docstring)."""
    c1 = jnp.minimum(c1, m0)
    fast = m0 - c1
    tau2 = (m1 - c1 / rate) / jnp.where(fast > 0, fast, 1.0)
    ok = (fast > 1e-12 * m0) & (tau2 > 0)
    lumped = jnp.where(ok, fast, 0.0) * jnp.exp(-durations / jnp.where(ok, tau2, 1.0))
    return c1 * jnp.exp(-rate * durations) + lumped


def _concat(*trees):
    return jax.tree.map(lambda *xs: jnp.concatenate(xs), *trees)


def _model(ship, wave, excitation, grid: _Grid, levels: tuple):
    """The averaged model with the vanishing angle absorbing (capsize) on `grid`, its fine edges moved onto the
    `levels`, and the fitted envelope."""
    scale, h, omega = _linear_frequency(ship, wave)
    exc = fit_envelope(wave, omega) if excitation is None else excitation
    snap = tuple((index, math.log(angle)) for index, angle in levels)
    return _build_model(ship, scale, h, omega, exc, wave, grid, absorbing_top=True, snap=snap), exc


def _passage_body(
    ship, wave, excitation, grid: _Grid, levels: tuple, durations, num_iterations: int, observe: str
):
    """One grid's first-order solution. `levels`: static (fine-edge index, angle [rad]) pairs in increasing angle,
    the grid's edge moved onto each."""
    md, exc = _model(ship, wave, excitation, grid, levels)
    ns = md.sc.shape[0]
    peaks = _peak_rate(md)
    killing = peaks if observe == "peaks" else jnp.full_like(peaks, _CONTINUOUS)

    # The capsize problem (no killing) factorised once. A level's system differs from it only above the level's
    # face: below the lowest face the factors are shared, above it each level continues the elimination with its
    # own killing.
    faces = jnp.asarray([grid.num_s_coarse + index for index, _ in levels])
    lowest = grid.num_s_coarse + levels[0][0]
    g, below = _factorise_slices(md, 0.0, False, None, 0, lowest, jnp.zeros((md.m, md.m)))
    _, upper = _factorise_slices(md, 0.0, False, None, lowest, ns, g)
    # Its slowest mode is the quasi-stationary law (the stationary law of the roll that has not capsized): the
    # state when the exposure starts. Inverse iteration from any positive start converges at the ratio of the
    # capsize rate to the relaxation rate (< 1e-3 wherever capsize is rarer than once a few hours).
    guess = jnp.ones((ns, md.m)) * md.ds[:, None]
    (_, _, capsize_rate, _), p = _survival_moments(
        md, _concat(below, upper), guess / jnp.sum(guess), num_iterations
    )
    amplitude_rate = jnp.sum(p * peaks)

    # one level after another (lax.map): one program whatever their number, no batched LAPACK
    def level(face):
        above = (jnp.arange(ns) >= face)[:, None]
        _, tail = _factorise_slices(md, 0.0, False, jnp.where(above, killing, 0.0), lowest, ns, g)
        moments, _ = _survival_moments(md, _concat(below, tail), p, num_iterations)
        return (*moments, jnp.sum(jnp.where(above, p, 0.0)), jnp.sum(jnp.where(above, p * peaks, 0.0)))

    m0, m1, rate, c1, start_above, peaks_above = jax.lax.map(level, faces)
    survival = jax.vmap(_survival, in_axes=(0, 0, 0, 0, None))(m0, m1, rate, c1, durations)
    return dict(
        hazard=-jnp.log(survival),  # −ln S(T) [levels, n_T]
        capsize_hazard=capsize_rate * durations,
        cluster_rate=rate,
        mean_passage_time=m1 / m0,
        start_exceedance=start_above,
        exceedance_per_cycle=peaks_above / amplitude_rate,  # F̄ of the zero-crossing law
        amplitude_rate=amplitude_rate,
        lyapunov_exponent=_lyapunov(md),
        excitation=exc,
    )


def _extrapolated(coarse: dict, fine: dict) -> dict:
    """Richardson extrapolation of two first-order solutions, Δs and Δs/2, in the logarithm of each rate or
    probability (first-order upwind in s errs by O(Δs) in the log of a tail quantity): log x = 2 log x_fine −
    log x_coarse. Zeros (no sustained roll) stay zero."""
    out = dict(fine)
    for name in (
        "hazard",
        "capsize_hazard",
        "cluster_rate",
        "mean_passage_time",
        "start_exceedance",
        "exceedance_per_cycle",
    ):
        c, f = coarse[name], fine[name]
        ok = (c > 0) & (f > 0) & jnp.isfinite(c) & jnp.isfinite(f)
        out[name] = jnp.where(
            ok, jnp.exp(2 * jnp.log(jnp.where(ok, f, 1.0)) - jnp.log(jnp.where(ok, c, 1.0))), f
        )
    return out


_GRID_DOC = """
    - `excitation` and the grid: as `envelope_fpk_pdf`; coarser in (ρ, θ) by default (8 × 12: the probabilities
      move by up to 20 % at 12 × 20 where they are ~1e-3, less elsewhere; 7× faster).
    - `num_iterations`: inverse-iteration solves per level (5: the slowest mode converges geometrically at the
      ratio of the passage rate to the relaxation rate, ×0.3 a solve at 6 m; against 10 solves the probabilities
      at 6 m, 25–40°, 1 h and 3 h move by 6e-4 relative with 3, 2e-4 with 4, 6e-5 with 5, 1e-6 with 8).
    - `observe`: `"peaks"` (the roll's peaks, what a record shows) or `"continuous"` (the envelope watched
      continuously: every excursion above the angle counts; an upper bound).
    - `extrapolate`: Richardson extrapolation over `num_s` and 2 `num_s` fine cells (3× the work of one grid).
    - `coarse`: this call's own one-grid result (`extrapolate=False`, the same ship, wave and arguments), reused as
      the extrapolation's `num_s` grid: only the 2 `num_s` grid is solved (2× the work of one grid; the same
      result). `jaxroll longterm`'s two passes use it."""


def passage_risk(
    ship: Ship,
    wave,
    angles,
    durations,
    *,
    excitation: EnvelopeExcitation | None = None,
    num_s: int = 60,
    num_s_coarse: int = 10,
    num_rho: int = 8,
    num_theta: int = 12,
    rho_max: float = 5.5,
    a_fine: float = math.radians(0.5),
    a_min: float = math.radians(1e-4),
    num_iterations: int = 5,
    observe: str = "peaks",
    extrapolate: bool = True,
    coarse: PassageRisk | None = None,
) -> PassageRisk:
    """Probability that the roll exceeds each angle within each exposure, with large rolls in groups: the envelope
    Fokker–Planck model followed through the exposure (module docstring; docs/theory.md, "Exposure risk when large
    rolls come in groups"). Against an exact-spectrum sea over H1/3 4–8 m × T01 8–12 s × 0 and 5 m/s (default ship,
    25–45°, 1 h and 3 h): ×0.48–1.23 at zero speed, ×0.28–1.42 at 5 m/s (docs/validation.md); the
    independent-amplitude formula is ×1.2–2.4 high.

    **Arguments:**

    - `ship`: the roll model, concrete or traced by `jax.grad` alone (its vanishing angle, the amplitude grid's
      top, places the levels' faces); `wave`: anything with `.spectrum(ω)`, the one-sided spectrum of ζ_G
      [m² s/rad] in encounter frequency (a `jaxroll.EffectiveWave`, e.g. `problem.wave`).
    - `angles` [rad]: threshold roll angles, 1-D, concrete (they place the grid's faces), each in (`a_fine`,
      vanishing angle) and more than one amplitude cell apart.
    - `durations` [s]: exposure times, 1-D, > 0 (e.g. 3600.0 for one hour). The exposure starts in the roll's
      quasi-stationary state (as a Monte Carlo that discards its first minutes).{grid}

    **Returns:** `PassageRisk`. jit-able with a concrete ship, vmappable over sea states (`eqx.filter_vmap` over
    waves of the same heading class; `passage_risk_batch` solves several in one call without batching LAPACK calls,
    which under vmap jaxlib runs on XLA's thread pool, where one such program hung with 2 CPU devices) and
    differentiable in the ship's and the sea's parameters (`jax.grad`). Where the roll dies out (λ ≤ 0, `exists` False) the
    probabilities are 0. Called with concrete arguments it runs with one BLAS/LAPACK thread
    (`jaxroll.single_threaded_blas`) and returns when the result is computed.

    **Raises:** `ValueError` for angles outside (a_fine, vanishing angle) or within one cell of each other,
    non-positive durations, an unknown `observe` (concrete inputs), or a ship traced by `jax.jit` or `jax.vmap`
    (its vanishing angle unknown while tracing: vmap over sea states with the ship fixed, or
    `passage_risk_batch`).
    """
    refuse_wave_moment(ship, wave, "passage_risk")
    require_float64("jaxroll.theory.passage_risk")
    grid, angles, durations, order, grids, reuse = _checked(
        ship,
        angles,
        durations,
        (num_s, num_s_coarse, num_rho, num_theta, rho_max, a_fine, a_min),
        num_iterations,
        observe,
        extrapolate,
        coarse,
        "passage_risk",
    )
    args = (
        ship,
        wave,
        excitation,
        coarse if reuse else None,
        durations,
        tuple(grids),
        tuple(float(a) for a in angles),
        tuple(int(i) for i in order),
        grid,
        int(num_iterations),
        observe,
        bool(extrapolate),
    )
    if not is_concrete(args):  # traced into the caller's program
        return _passage_risk(*args)
    with single_threaded_blas():  # run (and waited for) with one BLAS thread: 0.45 → 0.11 s a sea at load 1
        return jax.block_until_ready(_passage_risk(*args))


passage_risk.__doc__ = passage_risk.__doc__.replace("{grid}", _GRID_DOC)

#: `passage_risk`'s grid defaults in `grid_args` order (num_s, num_s_coarse, num_rho, num_theta, rho_max [-],
#: a_fine [rad], a_min [rad]), read off its signature: what `jaxroll longterm` solves on.
GRID_DEFAULTS = tuple(
    inspect.signature(passage_risk).parameters[k].default
    for k in ("num_s", "num_s_coarse", "num_rho", "num_theta", "rho_max", "a_fine", "a_min")
)


def passage_risk_batch(
    ship: Ship,
    waves,
    angles,
    durations,
    *,
    excitations=None,
    num_s: int = 60,
    num_s_coarse: int = 10,
    num_rho: int = 8,
    num_theta: int = 12,
    rho_max: float = 5.5,
    a_fine: float = math.radians(0.5),
    a_min: float = math.radians(1e-4),
    num_iterations: int = 5,
    observe: str = "peaks",
    extrapolate: bool = True,
    coarse: PassageRisk | None = None,
    device=None,
) -> PassageRisk:
    """`passage_risk` of several sea states for one ship in one call: one stored, compiled program per batch size
    (the seas one after another in it), run with one BLAS/LAPACK thread (`jaxroll.single_threaded_blas`). Each
    sea's numbers are `passage_risk`'s (to ~1e-10 relative). What `jaxroll longterm` runs, 4 seas a call per CPU
    device.

    **Arguments:**

    - `ship`: the roll model, concrete (its vanishing angle places the levels' faces).
    - `waves`: a sequence of waves of one kind (the same type and static settings, e.g. `jaxroll.EffectiveWave`s
      of one heading class whose seas differ); leaves that differ between them are batched, the others shared.
    - `angles` [rad], `durations` [s]: as `passage_risk`, the same for every sea.
    - `excitations`: None (each wave's envelope fitted), or the fitted envelopes, a sequence of
      `EnvelopeExcitation` or one with a leading axis of the waves' number.
    - `coarse`: this call's own one-grid result (`passage_risk_batch(..., extrapolate=False)` for the same waves),
      reused as the extrapolation's `num_s` grid.
    - `device`: the JAX device to run on (default: JAX's default placement).
    - the grid, `num_iterations`, `observe`, `extrapolate`: as `passage_risk`.

    **Returns:** `PassageRisk` whose every array has a leading axis over the waves (`r.probability[i]` the i-th
    sea's (angle, duration) table).

    **Raises:** `ValueError` as `passage_risk`, for an empty `waves`, or waves of different kinds.
    """
    for w in waves if isinstance(waves, list | tuple) else (waves,):
        refuse_wave_moment(ship, w, "passage_risk")
    require_float64("jaxroll.theory.passage_risk_batch")
    with single_threaded_blas():
        return jax.block_until_ready(
            _batch_dispatch(
                ship,
                waves,
                angles,
                durations,
                excitations=excitations,
                grid_args=(num_s, num_s_coarse, num_rho, num_theta, rho_max, a_fine, a_min),
                num_iterations=num_iterations,
                observe=observe,
                extrapolate=extrapolate,
                coarse=coarse,
                device=device,
            )
        )


def _stacked(trees: list, name: str):
    """One pytree from `trees` (same structure): leaves that are not all the same object stacked on a leading axis
    (at least one). **Returns:** (tree, a tuple of bools per leaf: stacked)."""
    try:
        flats = [jax.tree.flatten(t) for t in trees]
    except Exception as e:  # pragma: no cover
        raise ValueError(f"`{name}`: {e}") from e
    treedef = flats[0][1]
    if any(f[1] != treedef for f in flats[1:]):
        raise ValueError(
            f"`{name}` must be of one kind (the same type and static settings); got {treedef} and others."
        )
    columns = list(zip(*(f[0] for f in flats), strict=True))
    batched = [any(x is not col[0] for x in col) for col in columns]
    if not any(batched):  # one sea repeated: the map needs one batched input
        batched[next(i for i, col in enumerate(columns) if eqx.is_array(col[0]))] = True
    # concrete waves stacked on the host: an eager stack would run on the default device, behind its queue
    xp = jnp if any(isinstance(x, jax.core.Tracer) for col in columns for x in col) else np
    leaves = [xp.stack([xp.asarray(x) for x in col]) if b else col[0] for col, b in zip(columns, batched)]
    return jax.tree.unflatten(treedef, leaves), tuple(batched)


def _batch_dispatch(
    ship,
    waves,
    angles,
    durations,
    *,
    excitations,
    grid_args,
    num_iterations,
    observe,
    extrapolate,
    coarse,
    device,
    valid=None,
    top=None,
) -> PassageRisk:
    """`passage_risk_batch` without the thread limit and without waiting: the program is dispatched and its
    (future) result returned at once, so that calls on several devices overlap (`jaxroll longterm`). `valid`:
    None, or a bool per wave, False for a padding wave that is skipped (its results are zeros); `top`: the ship's
    vanishing angle [rad] where known (`_concrete_top`: computed on the default device, it would wait for it)."""
    waves = list(waves)
    if not waves:
        raise ValueError("`waves` must hold at least one wave.")
    grid, angles, durations, order, grids, reuse = _checked(
        ship,
        angles,
        durations,
        grid_args,
        num_iterations,
        observe,
        extrapolate,
        coarse,
        "passage_risk_batch",
        top,
    )
    stacked, batched = _stacked(waves, "waves")
    if isinstance(excitations, (list, tuple)):
        excitations, _ = _stacked(list(excitations), "excitations")
    args = (ship, stacked, excitations, coarse if reuse else None, durations, valid)
    if device is not None:
        args = jax.device_put(args, device)
    return _batch_program(
        *args,
        batched,
        tuple(grids),
        tuple(float(a) for a in angles),
        tuple(int(i) for i in order),
        grid,
        int(num_iterations),
        observe,
        bool(extrapolate),
    )


def _risk_body(
    ship,
    wave,
    excitation,
    coarse,
    durations,
    grids,
    angles,
    order,
    grid,
    num_iterations,
    observe,
    extrapolate,
) -> PassageRisk:
    """One sea state's `PassageRisk`: its grids solved (the first taken from `coarse` where given), extrapolated and
    assembled, in one program (`grids`, `angles`, `order` static)."""
    order = np.asarray(order)
    solved = [
        _unsolved(coarse, order)
        if coarse is not None and n == 0
        else _passage_body(ship, wave, excitation, g, levels, durations, num_iterations, observe)
        for n, (g, levels) in enumerate(grids)
    ]
    return _assembled(
        solved, np.asarray(angles), durations, order, grid, num_iterations, observe, extrapolate
    )


# one program per call: the solves, the extrapolation and the assembly (no chain of small eager programs queued
# behind the solve)
_passage_risk = filter_jit(_risk_body)


@cached_program(compiler_options=SOLVER_PROGRAM)
def _batch_program(
    ship,
    waves,
    excitations,
    coarse,
    durations,
    valid,
    batched,
    grids,
    angles,
    order,
    grid,
    num_iterations,
    observe,
    extrapolate,
):
    """The batch's program: `passage_risk` mapped over the waves' `batched` leaves (and the excitations and
    `coarse`, where given); where `valid` (bool, one per sea) is given, the seas it marks False are skipped."""
    flat, treedef = jax.tree.flatten(waves)

    def one(wave_leaves, excitation, crs):
        leaves = list(flat)
        for i, x in zip([i for i, b in enumerate(batched) if b], wave_leaves):
            leaves[i] = x
        wave = jax.tree.unflatten(treedef, leaves)
        return _risk_body(
            ship,
            wave,
            excitation,
            crs,
            durations,
            grids,
            angles,
            order,
            grid,
            num_iterations,
            observe,
            extrapolate,
        )

    def solved_or_skipped(x):
        if valid is None:
            return one(*x[:3])
        shapes = jax.eval_shape(lambda: one(*x[:3]))
        return jax.lax.cond(  # a padding sea (`valid` False) costs nothing: zeros, dropped by the caller
            x[3], lambda: one(*x[:3]), lambda: jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), shapes)
        )

    # one sea after another (lax.map, not vmap): a vmapped LAPACK call runs its batch on XLA's thread pool, where
    # it hung (a lost wake-up, seen in gdb, 2 CPU devices); a sequential map keeps every LAPACK call unbatched
    return jax.lax.map(
        solved_or_skipped, ([x for x, b in zip(flat, batched) if b], excitations, coarse, valid)
    )


def _checked(
    ship, angles, durations, grid_args, num_iterations, observe, extrapolate, coarse, name, top=None
):
    """The checked arguments of `passage_risk` and `passage_risk_batch`: (grid, angles (host), durations, the
    order by increasing angle, [(grid, levels)] per grid solved, whether `coarse` is reused)."""
    grid = _grid(*grid_args, 0)
    angles = np.atleast_1d(np.asarray(angles, dtype=float))
    # concrete durations checked on the host: a device computation here would wait for the device's queue
    durations = (
        jnp.atleast_1d(jnp.asarray(durations, dtype=float))
        if isinstance(durations, jax.core.Tracer)
        else np.atleast_1d(np.asarray(durations, dtype=float))
    )
    if angles.ndim != 1 or durations.ndim != 1:
        raise ValueError(
            f"`angles` and `durations` must be 1-D; got shapes {angles.shape} and {durations.shape}."
        )
    if int(num_iterations) < 2:
        raise ValueError(f"`num_iterations` must be >= 2; got {num_iterations!r}.")
    if not isinstance(durations, jax.core.Tracer) and not bool(np.all(durations > 0)):
        raise ValueError(f"`durations` must be > 0 [s]; got {durations.tolist()}.")
    if observe not in ("peaks", "continuous"):
        raise ValueError(f"`observe` must be 'peaks' or 'continuous'; got {observe!r}.")
    order = np.argsort(angles, kind="stable")
    grids = [grid, dataclasses.replace(grid, num_s=2 * grid.num_s)] if extrapolate else [grid]
    reuse = coarse is not None and extrapolate
    if reuse and (
        dict(coarse.grid).get("extrapolate", True)
        or coarse.grid[:-1] != grid.record()[:-1] + (("num_iterations", num_iterations), ("observe", observe))
        or not np.array_equal(np.asarray(coarse.angles).reshape(-1, angles.size)[0], angles)
        or coarse.probability.shape[-2:] != (angles.size, durations.size)
    ):
        raise ValueError(
            f"`coarse` must be this call's one-grid result: {name}(..., extrapolate=False) with "
            "the same grid, angles and durations."
        )
    top = _concrete_top(ship, name) if top is None else top
    return (
        grid,
        angles,
        durations,
        order,
        [(g, _levels(top, g, [float(a) for a in angles])) for g in grids],
        reuse,
    )


def _assembled(solved, angles, durations, order, grid, num_iterations, observe, extrapolate) -> PassageRisk:
    """The `PassageRisk` from the solved grids (`_passage`'s dicts, levels by increasing angle)."""
    r = _extrapolated(*solved) if extrapolate else solved[0]
    exists = r["lyapunov_exponent"] > 0

    def unless_dies_out(x, value=0.0):
        return jnp.where(exists, x, value)

    probability = -jnp.expm1(-r["hazard"])
    sf = r["exceedance_per_cycle"]
    back = np.argsort(order)  # from increasing angle to the caller's order
    return PassageRisk(
        angles=jnp.asarray(angles),
        durations=durations,
        probability=unless_dies_out(probability)[back],
        capsize_probability=unless_dies_out(-jnp.expm1(-r["capsize_hazard"])),
        cluster_rate=unless_dies_out(r["cluster_rate"])[back],
        mean_passage_time=unless_dies_out(r["mean_passage_time"], jnp.inf)[back],
        start_exceedance=unless_dies_out(r["start_exceedance"])[back],
        amplitude_rate=r["amplitude_rate"],
        exceedance_per_cycle=unless_dies_out(sf)[back],
        independent_probability=unless_dies_out(
            -jnp.expm1((r["amplitude_rate"] * durations)[None, :] * jnp.log1p(-sf)[:, None])
        )[back],
        extremal_index=(r["cluster_rate"] / (r["amplitude_rate"] * sf))[back],
        lyapunov_exponent=r["lyapunov_exponent"],
        exists=exists,
        hazard=r["hazard"][back],
        capsize_hazard=r["capsize_hazard"],
        excitation=r["excitation"],
        grid=grid.record()[:-1]
        + (("num_iterations", num_iterations), ("observe", observe), ("extrapolate", extrapolate)),
    )


def _unsolved(coarse: PassageRisk, order) -> dict:
    """A one-grid `PassageRisk` as `_passage`'s dict (levels by increasing angle, `order`) for `_extrapolated`:
    the quantities it extrapolates (those masked where λ ≤ 0 are 0 or ∞ there, which it passes over as it does
    a zero)."""
    return dict(
        hazard=coarse.hazard[order],
        capsize_hazard=coarse.capsize_hazard,
        cluster_rate=coarse.cluster_rate[order],
        mean_passage_time=coarse.mean_passage_time[order],
        start_exceedance=coarse.start_exceedance[order],
        exceedance_per_cycle=coarse.exceedance_per_cycle[order],
    )


def _primal(x):
    """The concrete value under `jax.grad`'s (or `jax.jvp`'s) tracers; a tracer of `jit` or `vmap` stays one."""
    while isinstance(x, jax.core.Tracer) and hasattr(x, "primal"):
        x = x.primal
    return x


def _concrete_top(ship, name: str) -> float:
    """The vanishing angle [rad] from the ship's concrete values (the primal values under `jax.grad`)."""
    plain = jax.tree.map(_primal, ship)
    if any(isinstance(x, jax.core.Tracer) for x in jax.tree.leaves(plain)):
        raise ValueError(
            f"jaxroll.theory.{name}: the ship is traced (under jax.jit or jax.vmap): its vanishing angle, the top "
            "of the amplitude grid that places the angles' faces, must be known before tracing. Keep the ship "
            "fixed (a concrete value closed over) and vmap over sea states, or solve several sea states in one "
            "call with jaxroll.theory.passage_risk_batch; jax.grad with respect to the ship works as it is."
        )
    with jax.ensure_compile_time_eval():
        return float(vanishing_angle(plain))


def _levels(top: float, grid: _Grid, angles: list[float]) -> tuple:
    """Static (fine-edge index, angle) pairs, by increasing angle: each angle [rad] takes the nearest interior edge
    of the uniform fine grid in s = ln a up to the vanishing angle `top` [rad] (moved by at most half a cell)."""
    bad = [a for a in angles if not (grid.a_fine < a < top) or not math.isfinite(a)]
    if bad:
        raise ValueError(
            f"`angles` must lie in ({math.degrees(grid.a_fine):.2g}°, {math.degrees(top):.1f}°) (above the fine "
            f"amplitude grid's bottom, below the vanishing angle), in radians; got {[math.degrees(a) for a in bad]} "
            "deg. The capsize probability is `capsize_probability`."
        )
    width = (math.log(top) - math.log(grid.a_fine)) / grid.num_s
    levels = sorted(
        (min(max(round((math.log(a) - math.log(grid.a_fine)) / width), 1), grid.num_s - 1), a) for a in angles
    )
    for (i, a), (j, b) in zip(levels, levels[1:]):
        if i == j:
            raise ValueError(
                f"angles {math.degrees(a):.4g}° and {math.degrees(b):.4g}° fall on the same amplitude cell (width "
                f"{100 * math.expm1(width):.1f} % in amplitude): give them in separate calls or raise `num_s`."
            )
    return tuple(levels)
