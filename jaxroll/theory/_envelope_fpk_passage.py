"""Exposure risk when large rolls come in groups: first passage of the envelope FPK model's amplitude.

P(max |φ| over an exposure T > a) = 1 − P(τ_a > T), τ_a the first time the amplitude A of the averaged model
(module `_envelope_fpk`: the Markov process (s = ln A, ρ, θ) with the wave's envelope as a state) reaches a.
Independent amplitudes (`exceedance_probability`, P* with N0 = rate·T) overstate it where exceedances come in
clusters; the first passage counts each cluster once, because the process is followed through time.

With the forward operator A_a of the finite-volume model absorbing at A = a (the face at ln a lets mass out;
rows above it removed) and the start density p0 (the stationary law of the reflecting model below a; its mass
above a exceeds at t = 0), the survival is S(T) = 1ᵀ exp(A_a T) p0 = Σ_k c_k e^{−λ_k T}. The moments
M_n = 1ᵀ(−A_a)^{−n} p0 = Σ_k c_k / λ_k^n come from n solves with one block-tridiagonal factorisation (inverse
iteration): λ_1 = lim M_n / M_{n+1} (the rate of the slowest mode: clusters of exceedances per second once the
start has been forgotten), c_1 = lim M_n λ_1^n. The other modes relax within the roll's relaxation time (≈ 1/δ,
a few hundred seconds); they are lumped into one exponential that keeps M_0 (the mass below a at the start) and
M_1 (the mean time to the first passage, ∫S dt) exact:

    S(T) ≈ c_1 e^{−λ_1 T} + (M_0 − c_1) e^{−T/τ_2},   τ_2 = (M_1 − c_1/λ_1) / (M_0 − c_1).

Exact at T = 0 and in ∫₀^∞ S dT; for T well beyond the relaxation time (hours against minutes) only the first
term is left. The operator is the second-order one of the stationary law (defect corrections in s applied inside
every solve), so the start law is stationary for the very operator that moves it. Levels between two cell faces:
ln(−ln S) interpolated linearly in s = ln a (smooth: ≈ ln λ_1(a) + ln T). Capsize: the same at the vanishing
angle (the top face). Derivation, validation against the Monte Carlo and limits: docs/theory.md, "Exposure risk".
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._compiled import filter_jit
from ..ship._restoring import vanishing_angle
from ..ship._ship import Ship
from ._envelope_fpk import (
    _build_model,
    _defect,
    _detune,
    _factorise_slices,
    _Grid,
    _grid,
    _linear_frequency,
    _lyapunov,
    _solve,
    _stationary,
    fit_envelope,
)
from ._envelope_fpk_law import EnvelopeExcitation


class PassageRisk(eqx.Module):
    """Exposure risk from the first passage of the envelope FPK model (`passage_risk`). Angles [rad], times [s].

    **Fields:**

    - `angles` [rad] (`n_a`), `durations` [s] (`n_T`): the levels and exposures asked for.
    - `probability` [-] (`n_a`, `n_T`): P(max |φ| > angle within the exposure), capsize included (a capsizing
      roll passes every angle first).
    - `capsize_probability` [-] (`n_T`): P(the amplitude reaches the vanishing angle within the exposure).
    - `cluster_rate` [1/s] (`n_a`): λ_1, the rate of first passages once the start is forgotten (one per cluster
      of large rolls); `mean_passage_time` [s] (`n_a`): M_1/M_0, the mean time to the first passage from the
      stationary start below the angle; `start_exceedance` [-] (`n_a`): the stationary probability that the
      amplitude is already above the angle when the exposure starts.
    - `amplitude_rate` [1/s]: zero-crossing amplitudes per second (the model's half-cycle rate);
      `exceedance_per_cycle` [-] (`n_a`): F̄(angle) of the model's zero-crossing law; `independent_probability`
      [-] (`n_a`, `n_T`): 1 − (1 − F̄)^{rate·T}, the same model's amplitudes taken as independent (what
      `exceedance_probability` gives); `extremal_index` [-] (`n_a`): θ = λ_1 / (rate · F̄), 1/θ the mean number of
      amplitudes above the angle per cluster.
    - `lyapunov_exponent` λ [1/s] and `exists` (λ > 0): where the roll dies out (λ ≤ 0) every probability is 0.
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
    psi = md.ps_dev[:, None] / (2 * md.omega) + md.wr[:, None] * jnp.cos(md.th)[None, :] / (4 * md.omega)
    detune = _detune(md.restoring, md.omega, jnp.exp(md.sc))[:, None]
    return (md.omega + detune + psi.reshape(1, -1)) / jnp.pi


def _solve_second_order(md, factors, rhs):
    """Solve the second-order (defect-corrected) system A₂ q = rhs by q ← A₁⁻¹(rhs − (A₂ − A₁) q), A₁ factorised."""
    q = _solve(md, factors, rhs)
    return jax.lax.fori_loop(
        0, md.grid.num_corrections, lambda _, q: _solve(md, factors, rhs - _defect(md, q)), q
    )


def _survival_moments(md, factors, p, num_iterations: int):
    """(M_0, M_1, λ_1, c_1) of the survival from the start cells' probabilities p [ns, m] (module docstring)."""
    m0 = jnp.sum(p)

    def iterate(n, carry):
        u, log_ratios = carry
        # (−A)⁻¹u: the operator acts on densities per unit s, u holds cell probabilities
        x = _solve_second_order(md, factors, -u / md.ds[:, None]) * md.ds[:, None]
        r = jnp.sum(x)
        return x / r, log_ratios.at[n].set(jnp.log(r))

    _, log_ratios = jax.lax.fori_loop(0, num_iterations, iterate, (p / m0, jnp.zeros(num_iterations)))
    rate = jnp.exp(-log_ratios[-1])  # λ_1 = M_n / M_{n+1}
    c1 = m0 * jnp.exp(jnp.sum(log_ratios - log_ratios[-1]))  # c_1 = M_N λ_1^N
    return m0, m0 * jnp.exp(log_ratios[0]), rate, c1


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


def _setup(ship, wave, excitation, grid: _Grid, levels: tuple):
    """The reflecting model, the absorbing one (capsize: mass leaves at the vanishing angle), the stationary law's
    cell probabilities p [ns, m] (the state when the exposure starts), the peak rate [ns, m] and the envelope,
    on `grid` with its fine edges moved onto the `levels` (static (fine-edge index, angle [rad]) pairs)."""
    scale, h, omega = _linear_frequency(ship, wave)
    exc = fit_envelope(wave, omega) if excitation is None else excitation
    snap = tuple((index, math.log(angle)) for index, angle in levels)
    md = _build_model(ship, scale, h, omega, exc, grid, snap=snap)
    md_out = _build_model(ship, scale, h, omega, exc, grid, absorbing_top=True, snap=snap)
    q = jnp.maximum(_stationary(md), 0.0) * md.ds[:, None]
    return md, md_out, q / jnp.sum(q), _peak_rate(md), exc


@filter_jit
def _passage(ship, wave, excitation, grid: _Grid, levels: tuple, durations, num_iterations: int, observe: str):
    """`levels`: static (fine-edge index, angle [rad]) pairs in increasing angle: the grid's edge moved onto it."""
    md, md_out, p, peaks, exc = _setup(ship, wave, excitation, grid, levels)
    ns = md.sc.shape[0]
    lyap = _lyapunov(md)
    amplitude_rate = jnp.sum(p * peaks)
    killing = peaks if observe == "peaks" else jnp.full_like(peaks, _CONTINUOUS)

    # The absorbing system without killing (the capsize problem) factorised once. A level's system differs from it
    # only above the level's face: below the lowest face the factors are shared, above it each level continues
    # the elimination with its own killing (vmapped over the levels: one program whatever their number).
    faces = jnp.asarray([grid.num_s_coarse + index for index, _ in levels])
    lowest = grid.num_s_coarse + levels[0][0]
    g, below = _factorise_slices(md_out, 0.0, False, None, 0, lowest, jnp.zeros((md.m, md.m)))
    _, upper = _factorise_slices(md_out, 0.0, False, None, lowest, ns, g)
    capsize = _survival(*_survival_moments(md_out, _concat(below, upper), p, num_iterations), durations)

    def level(face):
        above = (jnp.arange(ns) >= face)[:, None]
        _, tail = _factorise_slices(md_out, 0.0, False, jnp.where(above, killing, 0.0), lowest, ns, g)
        moments = _survival_moments(md_out, _concat(below, tail), p, num_iterations)
        return (*moments, jnp.sum(jnp.where(above, p, 0.0)), jnp.sum(jnp.where(above, p * peaks, 0.0)))

    m0, m1, rate, c1, start_above, peaks_above = jax.vmap(level)(faces)
    survival = jax.vmap(_survival, in_axes=(0, 0, 0, 0, None))(m0, m1, rate, c1, durations)
    sf = peaks_above / amplitude_rate  # F̄ of the zero-crossing law
    independent = -jnp.expm1((amplitude_rate * durations)[None, :] * jnp.log1p(-sf)[:, None])
    exists = lyap > 0

    def unless_dies_out(x, value=0.0):
        return jnp.where(exists, x, value)

    return PassageRisk(
        angles=jnp.asarray([angle for _, angle in levels]),
        durations=durations,
        probability=unless_dies_out(1.0 - survival),
        capsize_probability=unless_dies_out(1.0 - capsize),
        cluster_rate=unless_dies_out(rate),
        mean_passage_time=unless_dies_out(m1 / m0, jnp.inf),
        start_exceedance=unless_dies_out(start_above),
        amplitude_rate=amplitude_rate,
        exceedance_per_cycle=unless_dies_out(sf),
        independent_probability=unless_dies_out(independent),
        extremal_index=rate / (amplitude_rate * sf),
        lyapunov_exponent=lyap,
        exists=exists,
        excitation=exc,
        grid=grid.record() + (("num_iterations", num_iterations), ("observe", observe)),
    )


def passage_risk(
    ship: Ship,
    wave,
    angles,
    durations,
    *,
    excitation: EnvelopeExcitation | None = None,
    num_s: int = 60,
    num_s_coarse: int = 10,
    num_rho: int = 12,
    num_theta: int = 20,
    rho_max: float = 5.5,
    a_fine: float = math.radians(0.5),
    a_min: float = math.radians(1e-4),
    num_corrections: int = 4,
    num_iterations: int = 8,
    observe: str = "peaks",
) -> PassageRisk:
    """Probability that the roll exceeds each angle within each exposure, from the first passage of the envelope
    Fokker–Planck model (module docstring; docs/theory.md, "Exposure risk"): large rolls come in groups, and a
    group counts once.

    **Arguments:**

    - `ship`: the roll model; `wave`: anything with `.spectrum(ω)`, the one-sided spectrum of ζ_G [m² s/rad] in
      encounter frequency (a `jaxroll.EffectiveWave`, e.g. `problem.wave`).
    - `angles` [rad]: threshold roll angles, 1-D, each in (a_fine, vanishing angle).
    - `durations` [s]: exposure times, 1-D, > 0 (e.g. 3600.0 for one hour). The exposure starts in the
      stationary state (as a Monte Carlo that discards the first minutes).
    - `excitation` and the grid (`num_s` … `num_corrections`): as `envelope_fpk_pdf`.
    - `num_iterations`: inverse-iteration solves per level (8: the slowest mode to ~1e-6 wherever the passage
      is rarer than the roll's relaxation; each is one block-tridiagonal back-substitution).

    **Returns:** `PassageRisk`. jit-able, vmappable over sea states (`eqx.filter_vmap` over waves of the same
    heading class) and differentiable in the ship's and the sea's parameters. Where the roll dies out
    (λ ≤ 0, `exists` False) the probabilities are 0.

    **Raises:** `ValueError` for angles outside (a_fine, vanishing angle) or non-positive durations (concrete
    inputs).
    """
    grid = _grid(num_s, num_s_coarse, num_rho, num_theta, rho_max, a_fine, a_min, num_corrections)
    angles = np.atleast_1d(np.asarray(angles, dtype=float))
    durations = jnp.atleast_1d(jnp.asarray(durations, dtype=float))
    if angles.ndim != 1 or durations.ndim != 1:
        raise ValueError(f"`angles` and `durations` must be 1-D; got shapes {angles.shape} and {durations.shape}.")
    if int(num_iterations) < 2:
        raise ValueError(f"`num_iterations` must be >= 2; got {num_iterations!r}.")
    levels = _levels(ship, grid, [float(a) for a in np.asarray(angles)])
    if not isinstance(durations, jax.core.Tracer) and not bool(jnp.all(durations > 0)):
        raise ValueError(f"`durations` must be > 0 [s]; got {durations.tolist()}.")
    if observe not in ("peaks", "continuous"):
        raise ValueError(f"`observe` must be 'peaks' or 'continuous'; got {observe!r}.")
    order = np.argsort(angles)
    risk = _passage(ship, wave, excitation, grid, levels, durations, int(num_iterations), observe)
    if np.all(order == np.arange(len(order))):
        return risk
    back = np.argsort(order)  # the caller's order
    per_level = ("angles", "probability", "cluster_rate", "mean_passage_time", "start_exceedance",
                 "exceedance_per_cycle", "independent_probability", "extremal_index")
    return eqx.tree_at(lambda r: [getattr(r, f) for f in per_level], risk, [getattr(risk, f)[back] for f in per_level])


def _levels(ship, grid: _Grid, angles: list[float]) -> tuple:
    """Static (fine-edge index, angle) pairs, by increasing angle: each angle [rad] takes the nearest interior edge
    of the uniform fine grid in s = ln a (moved by at most half a cell). The grid's top is the vanishing angle
    (a nominal 70° where the ship is traced)."""
    top = vanishing_angle(ship)
    top = math.radians(70.0) if isinstance(top, jax.core.Tracer) else float(top)
    bad = [a for a in angles if not (grid.a_fine < a < top) or not math.isfinite(a)]
    if bad:
        raise ValueError(
            f"`angles` must lie in ({math.degrees(grid.a_fine):.2g}°, {math.degrees(top):.1f}°) (above the fine "
            f"amplitude grid's bottom, below the vanishing angle), in radians; got {[math.degrees(a) for a in bad]} "
            "deg. The capsize probability is `capsize_probability`."
        )
    width = (math.log(top) - math.log(grid.a_fine)) / grid.num_s
    levels = sorted((min(max(round((math.log(a) - math.log(grid.a_fine)) / width), 1), grid.num_s - 1), a)
                    for a in angles)
    for (i, a), (j, b) in zip(levels, levels[1:]):
        if i == j:
            raise ValueError(
                f"angles {math.degrees(a):.4g}° and {math.degrees(b):.4g}° fall on the same amplitude cell (width "
                f"{100 * math.expm1(width):.1f} % in amplitude): give them in separate calls or raise `num_s`."
            )
    return tuple(levels)

