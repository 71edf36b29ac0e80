"""Design sensitivities of Monte Carlo statistics: d(statistic)/d(parameter) of ship and sea parameters.

`monte_carlo_sensitivity(problem_fn, params, key, ...)` differentiates smooth Monte Carlo statistics — E[φ²], the
mean envelope amplitude, the mean zero-crossing amplitude and Gaussian-smoothed exceedance probabilities — with
respect to any parameters that `problem_fn(params) -> RollProblem` depends on differentiably
(`sensitivity_problem` builds one for the ship's GM0, damping, r = σobs/σthr, ΔGM coefficients and the sea's
H1/3, T01 and speed).

**Estimator (docs/sensitivity.md).** The plain pathwise derivative (forward-mode autodiff through a whole
3600 s realization) is unbiased but has an infinite-variance tail on long runs: when the roll nearly dies out and
regrows, the regrown roll depends on how the tiny residual roll projects on the growing direction of the
parametric instability, and the tangent is amplified by ~1/(that projection), a Cauchy-like ratio (Hill index
≈ 1). The default estimator is *windowed*: the run is cut into scored segments of `window` seconds; for each, the
tangent ∂(φ, φ̇)/∂θ is restarted at zero `burn_in` seconds before the segment (the roll state there is held
fixed) and propagated through the segment, so no tangent lives longer than `burn_in + window` (600 s by default,
where the tail is still light). The excitation's tangent (filter or superposition wave, a stable linear process)
is exact over the whole run. Every statistic S(φ_1 … φ_N) is linearised on the primal path, dS = Σ_n w_n dφ_n
with w = ∇_φ S (one reverse pass: the Hilbert envelope is global, its linearisation is not), and the estimate is
Σ_k Σ_{n ∈ segment k} w_n v^(k)_n. Holding the state fixed drops the memory of earlier parameter changes: a bias
that decays geometrically with the burn-in (−4…−8 % at 300 s on the default ship); it is extrapolated away
(Aitken's Δ²) from the estimates at burn-ins B/3, 2B/3 and B, leaving −0.4…−3 % (measured against finite
differences, docs/sensitivity.md). `method="finite_difference"` gives central differences with common random
numbers of the same statistics, for comparison.

Realization i uses `fold_in(key, i)` exactly as `jaxroll.monte_carlo` does, so the values are those of its
`AmplitudeHistogram(discard, every=1)` on the same trials (φ every step; `monte_carlo_amplitudes` records it every
`envelope_record_every` steps, which moves the envelope statistics by ~1e-5 relative). Capsized realizations are left out (their count is reported; the
derivative of the capsize probability is not part of the estimate).
"""

from __future__ import annotations

import functools
import math
import re
import warnings
from collections.abc import Callable, Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jax.scipy.stats import norm

from .._compiled import MONTE_CARLO_PROGRAM, SMALL_PROGRAM, cached_program, compiled_with
from .._config import require_float64
from .._display import progress_bar
from ..sea._spectra import ITTC
from ..ship._ship import Ship
from ._amplitudes import hilbert_envelope, zero_crossing_init, zero_crossing_update
from ._equation import RollProblem, forcing_series, rk4_step
from ._excitation import FilterExcitation
from ._sensitivity_result import DEFAULT_SENSITIVITY_STATISTICS, SensitivityResult

_EXCEED = re.compile(r"^P_exceed(_zc)?_([0-9]+(?:\.[0-9]*)?)deg$")
# GZ(φ) changes by δGM0·sin φ when G moves vertically: the Taylor coefficients of sin φ beyond φ
_SIN_TAYLOR = (-1.0 / 6, 1.0 / 120, -1.0 / 5040, 1.0 / 362880)


# ----------------------------------------------------------------------------------------------------------------
# Statistics
# ----------------------------------------------------------------------------------------------------------------


class _Stat(eqx.Module):
    name: str
    kind: str  # "phi2" | "envelope" | "zero_crossing" | "exceed_envelope" | "exceed_zero_crossing"
    threshold: float = 0.0  # [rad], exceedances only


def parse_statistic(name: str) -> _Stat:
    """The statistic called `name`: "E_phi2" [rad²], "mean_envelope", "mean_zero_crossing" [rad],
    "P_exceed_<a>deg" (fraction of time the envelope exceeds a°), "P_exceed_zc_<a>deg" (fraction of
    zero-crossing amplitudes above a°)."""
    if name == "E_phi2":
        return _Stat(name, "phi2")
    if name == "mean_envelope":
        return _Stat(name, "envelope")
    if name == "mean_zero_crossing":
        return _Stat(name, "zero_crossing")
    m = _EXCEED.match(name) if isinstance(name, str) else None
    if m and 0 < float(m.group(2)) < 90:
        kind = "exceed_zero_crossing" if m.group(1) else "exceed_envelope"
        return _Stat(name, kind, math.radians(float(m.group(2))))
    raise ValueError(
        f"unknown statistic {name!r}; choose from 'E_phi2', 'mean_envelope', 'mean_zero_crossing', "
        "'P_exceed_<a>deg' (envelope exceedance, e.g. 'P_exceed_20deg') or 'P_exceed_zc_<a>deg' "
        "(zero-crossing amplitudes), 0 < a < 90."
    )


def _statistics(phi, phi0, start: int, stats: tuple[_Stat, ...], smoothing: float):
    """Per-realization (numerator, denominator, unsmoothed numerator) of each statistic from the roll φ after
    steps 1 … N [rad]; the statistic over realizations is Σ numerators / Σ denominators."""
    kept = phi[start:]
    n = kept.size
    env = hilbert_envelope(kept)
    _, amps = jax.lax.scan(lambda s, v: zero_crossing_update(s, v), zero_crossing_init(phi0), phi)
    amps = amps[start:]
    mask = amps > 0
    count = jnp.sum(mask).astype(float)
    nums, dens, raws = [], [], []
    for s in stats:
        if s.kind == "phi2":
            num, den, raw = jnp.sum(kept**2) / n, 1.0, None
        elif s.kind == "envelope":
            num, den, raw = jnp.sum(env) / n, 1.0, None
        elif s.kind == "zero_crossing":
            num, den, raw = jnp.sum(jnp.where(mask, amps, 0.0)), count, None
        elif s.kind == "exceed_envelope":
            num = jnp.sum(norm.cdf((env - s.threshold) / smoothing)) / n
            den, raw = 1.0, jnp.sum(env > s.threshold) / n
        else:
            num = jnp.sum(jnp.where(mask, norm.cdf((amps - s.threshold) / smoothing), 0.0))
            den, raw = count, jnp.sum(mask & (amps > s.threshold)).astype(float)
        nums.append(num)
        dens.append(jnp.asarray(den, dtype=float))
        raws.append(num if raw is None else raw)
    return jnp.stack(nums), jnp.stack(dens), jnp.stack(raws)


# ----------------------------------------------------------------------------------------------------------------
# One realization: forcing, roll, windows
# ----------------------------------------------------------------------------------------------------------------


class _Parts(eqx.Module):
    """What one realization needs from a `RollProblem` (the differentiable part: no wave, no filter fit)."""

    ship: Ship
    excitation: object
    moment_excitation: object
    y0: jax.Array
    capsize_angle: jax.Array


def _parts(problem: RollProblem) -> _Parts:
    return _Parts(
        problem.ship,
        problem.excitation,
        problem.moment_excitation,
        jnp.stack([problem.phi0, problem.dphi0]),
        problem.capsize_angle,
    )


def _forcing(parts: _Parts, key, num_steps: int, dt: float):
    """P [1/s²] and M_w [rad/s²] at (start, middle, end) of each of `num_steps` steps, exactly as `simulate`
    forms them (`forcing_series`: same keys, same blocks, same bridge and Hermite midpoints), in float64."""
    return forcing_series(parts, key, num_steps)


def _roll(parts: _Parts, p, m, dt: float):
    """The roll (φ, φ̇) after each step, frozen after a capsize, and whether the realization survived."""

    def step(carry, pm):
        y, alive = carry
        y1 = rk4_step(parts.ship, y, pm[0], pm[1], dt)
        ok = jnp.all(jnp.isfinite(y1)) & (jnp.abs(y1[0]) < parts.capsize_angle)
        alive = alive & ok
        y1 = jnp.where(alive, y1, y)
        return (y1, alive), y1

    (_, alive), ys = jax.lax.scan(step, (parts.y0, jnp.array(True)), (p, m))
    return ys, alive


class _Config(eqx.Module):
    stats: tuple[_Stat, ...]
    num_steps: int
    start: int
    segment: int  # scored steps per window
    burns: tuple[int, ...]  # steps of tangent burn-in before each segment (one estimate per entry)
    dt: float
    smoothing: float  # [rad]

    @property
    def num_windows(self) -> int:
        return -(-self.num_steps // self.segment)

    @property
    def length(self) -> int:
        return self.segment + max(self.burns)


def _padded(p, m, weights, cfg: _Config):
    pad = cfg.length
    return (
        jnp.pad(p, ((0, pad), (0, 0))),
        jnp.pad(m, ((0, pad), (0, 0))),
        jnp.pad(weights, ((0, 0), (0, pad))),
    )


def _window_functional(parts: _Parts, key, ys, weights, cfg: _Config):
    """For each burn-in B of `cfg.burns`: Σ_k Σ_{n ∈ segment k} w_n φ^(k)_n, the roll of window k re-integrated
    from the primal state B seconds before segment k (held fixed: `ys` is a constant here) with the forcing of
    `parts`. Its JVP in `parts` is the windowed estimate of dS/dθ with burn-in B. Shape (len(burns), 2, S): the
    windows that start at t = 0 for the longest burn-in (exact: no state is held) and the others."""
    n, seg = cfg.num_steps, cfg.segment
    p, m = _forcing(parts, key, n, cfg.dt)
    p, m, w = _padded(p, m, weights, cfg)
    # the state after t steps: the true initial condition (with its own derivative) at t = 0, else the primal state
    states = jnp.concatenate([parts.y0[None], ys])

    def one_window(k, burn):
        s_k = k * seg
        t_k = jnp.maximum(s_k - burn, 0)

        def step(carry, j):
            y, acc = carry
            i = t_k + j  # φ after step i + 1 is φ_out[i]
            y1 = rk4_step(parts.ship, y, p[i], m[i], cfg.dt)
            scored = (i >= s_k) & (i < s_k + seg) & (i < n)
            acc = acc + jnp.where(scored, w[:, i], 0.0) * y1[0]
            return (y1, acc), None

        (_, acc), _ = jax.lax.scan(step, (states[t_k], jnp.zeros(w.shape[0])), jnp.arange(seg + burn))
        return acc

    windows = jnp.arange(cfg.num_windows)
    late = (windows * seg > max(cfg.burns))[:, None]  # every burn-in holds a state (none starts at t = 0)
    out = []
    for b in cfg.burns:
        acc = jax.vmap(lambda k, b=b: one_window(k, b))(windows)
        out.append(jnp.stack([jnp.sum(jnp.where(late, 0.0, acc), 0), jnp.sum(jnp.where(late, acc, 0.0), 0)]))
    return jnp.stack(out)


def _memory_growth(parts: _Parts, p, m, ys, cfg: _Config):
    """Σ over the windows that end inside the run of log(|δy(t_k + L)| / |δy(t_k)|) for a perturbation of the
    roll state at the window's start (|δy|² = δφ² + (δφ̇/ω0)², wave fixed), and their count: the finite-time
    Lyapunov exponent of the roll (reported as a diagnostic: the typical path forgets a held state at this rate;
    the mean response, which sets the burn-in bias, forgets more slowly — docs/sensitivity.md)."""
    n, seg, length = cfg.num_steps, cfg.segment, cfg.length
    p, m, _ = _padded(p, m, jnp.zeros((1, n)), cfg)
    states = jnp.concatenate([parts.y0[None], ys])
    omega0 = parts.ship.omega0

    def one_window(k):
        t_k = jnp.maximum(k * seg - max(cfg.burns), 0)

        def roll_from(y):
            def step(y, j):
                return rk4_step(parts.ship, y, p[t_k + j], m[t_k + j], cfg.dt), None

            return jax.lax.scan(step, y, jnp.arange(length))[0]

        _, v = jax.jvp(roll_from, (states[t_k],), (jnp.array([1.0, 0.0]),))
        valid = t_k + length <= n
        return jnp.where(valid, jnp.log(jnp.hypot(v[0], v[1] / omega0)), 0.0), valid.astype(float)

    growth, valid = jax.vmap(one_window)(jnp.arange(cfg.num_windows))
    return jnp.sum(growth), jnp.sum(valid)


def _realization(parts: _Parts, dparts, key, cfg: _Config, with_tangents: bool):
    p, m = _forcing(parts, key, cfg.num_steps, cfg.dt)
    ys, alive = _roll(parts, p, m, cfg.dt)
    phi = ys[:, 0]
    phi0 = parts.y0[0]

    def stat_nums(phi):
        return _statistics(phi, phi0, cfg.start, cfg.stats, cfg.smoothing)[0]

    nums, dens, raws = _statistics(phi, phi0, cfg.start, cfg.stats, cfg.smoothing)
    if not with_tangents:
        return nums, dens, raws, alive
    weights = jax.jacrev(stat_nums)(phi)  # (S, N)
    weights = jnp.where(alive, weights, 0.0)

    def tangent(dp):
        return jax.jvp(lambda q: _window_functional(q, key, ys, weights, cfg), (parts,), (dp,))[1]

    dnums = jnp.where(alive, jax.vmap(tangent)(dparts), 0.0)  # (P, len(burns), 2, S)
    if len(cfg.burns) > 1:
        growth, count = _memory_growth(parts, p, m, ys, cfg)
        growth, count = jnp.where(alive, growth, 0.0), jnp.where(alive, count, 0.0)
    else:
        growth, count = jnp.zeros(()), jnp.zeros(())
    return nums, dens, raws, alive, dnums, growth, count


# ----------------------------------------------------------------------------------------------------------------
# Parameters
# ----------------------------------------------------------------------------------------------------------------


#: The shaping filter's order of `sensitivity_problem` under "auto" (its fit converges: its derivative is exact).
SENSITIVITY_FILTER_ORDER = 4


def sensitivity_problem(
    ship: Ship,
    *,
    hs: float,
    t01: float,
    speed: float = 0.0,
    heading: str = "head",
    excitation: str = "filter",
    dt: float = 0.5,
    filter_order: int | str = "auto",
    phi0: float = math.radians(5.0),
    dphi0: float = 0.0,
) -> tuple[Callable[[Mapping], RollProblem], dict[str, float]]:
    """`(problem_fn, params)` for `monte_carlo_sensitivity`: `problem_fn(params)` is
    `RollProblem.from_sea(ship, ITTC(hs, t01), speed=…)` rebuilt from the named parameters, differentiably
    (the Method-2 filter is refitted inside; its derivative is the implicit function theorem's at the fit's
    optimum); `params` holds their nominal values. Names (SI units, radians):

    - `gm0` [m]: GM0 as a vertical shift of G at fixed displacement and inertia: a1 = ω0² ∝ GM0, the GZ curve
      moves by δGM0·sin φ (a3 … a9 follow its Taylor terms), ΔGM(ζ) and ω0²/GM0 in P(t) are unchanged;
    - `b1` [1/s], `b2` [1/rad], `b3` [s/rad²]: damping; `gm_correction`: r = σobs/σthr;
    - `c0` … `c6`: the ΔGM(ζ) polynomial [m^(1−k)];
    - `hs` [m], `t01` [s]: the ITTC sea; `speed` [m/s].

    The nominal problem is checked by `RollProblem.from_sea` (time step, initial roll, filter fit). Derivatives in
    the sea parameters are tested with `excitation="filter"` (the default); with "superposition" they go through
    √S_G of the FFT synthesis, which has no derivative where S_G = 0 — not supported.

    `filter_order="auto"` is the paper's order 4 here, not the Monte Carlo's band rule (docs/numerics.md, "The
    filter's order"): the derivative through the fit is the implicit function theorem's *at its optimum*, which
    order 4's Levenberg–Marquardt reaches and order 8's does not (it stops at its step limit, and a traced refit then
    differs from the nominal one by 2e-4 of a statistic). The order-4 filter's tail bias matters little for the means
    and variances differentiated here; its band warning is not repeated.
    """
    if filter_order == "auto":
        filter_order = SENSITIVITY_FILTER_ORDER
    options = dict(
        heading=heading, excitation=excitation, dt=dt, filter_order=filter_order, phi0=phi0, dphi0=dphi0
    )
    sea = ITTC(hs, t01)
    with warnings.catch_warnings():
        warnings.filterwarnings(
            "ignore", message=".*shaping filter's spectrum is .* off the effective wave's"
        )
        nominal = RollProblem.from_sea(
            ship, sea, speed=speed, **options
        )  # every check of the nominal problem
    if excitation == "filter":  # the traced problems step the filter as the nominal one (same random stream)
        options["substeps"] = nominal.excitation.substeps
        options["noise_rank"] = nominal.excitation.noise_rank
    gm0_nominal = float(ship.gm0)
    kappa = float(ship.omega0) ** 2 / gm0_nominal  # a1/GM0 = gΔ/I44, held fixed
    params = {
        "gm0": gm0_nominal,
        "b1": float(ship.damping[0]),
        "b2": float(ship.damping[1]),
        "b3": float(ship.damping[2]),
        "gm_correction": float(ship.gm_correction),
        **{f"c{k}": float(ship.delta_gm[k]) for k in range(7)},
        "hs": float(hs),
        "t01": float(t01),
        "speed": float(speed),
    }

    def problem_fn(q: Mapping) -> RollProblem:
        q = {**params, **q}
        gm0 = jnp.asarray(q["gm0"], dtype=float)
        a1 = kappa * gm0
        shift = kappa * (gm0 - gm0_nominal)
        restoring = ship.restoring + shift * jnp.asarray(_SIN_TAYLOR)
        new = Ship(
            lpp=ship.lpp, breadth=ship.breadth, depth=ship.depth, draught=ship.draught,
            displacement=ship.displacement, block_coefficient=ship.block_coefficient, gm0=gm0,
            roll_period=2 * jnp.pi / jnp.sqrt(a1), restoring=restoring,
            damping=jnp.stack([jnp.asarray(q[b], dtype=float) for b in ("b1", "b2", "b3")]),
            delta_gm=jnp.stack([jnp.asarray(q[f"c{k}"], dtype=float) for k in range(7)]),
            gm_correction=q["gm_correction"], name=ship.name, provenance=ship.provenance,
        )  # fmt: skip
        # The nominal sea with H1/3 and T01 replaced, unchecked like the rest: checks of traced values would be
        # host callbacks, and a program with one is never kept in JAX's disk cache.
        hs_q, t01_q = (jnp.asarray(q[k], dtype=float) for k in ("hs", "t01"))
        new_sea = eqx.tree_at(lambda s: (s.hs, s.t01), sea, (hs_q, t01_q))
        return RollProblem.from_sea(new, new_sea, speed=q["speed"], validate=False, **options)

    return problem_fn, params


def _ratio(num, den):
    """Σnum/Σden and its per-realization influence (mean = the ratio) and standard error (delta method)."""
    value = num.sum(0) / den.sum(0)
    mean_den = den.mean(0)
    infl = (num - value * den) / np.where(mean_den > 0, mean_den, 1.0) + value
    n = num.shape[0]
    se = infl.std(0, ddof=1) / math.sqrt(n) if n > 1 else np.full_like(value, np.nan)
    return value, infl, se


# ----------------------------------------------------------------------------------------------------------------
# The public function
# ----------------------------------------------------------------------------------------------------------------


def _check_seconds(name, value, *, allow_zero=False):
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(
            f"`{name}` must be a finite number {'>= 0' if allow_zero else '> 0'} [s]; got {value!r}."
        )


_PROBLEM_JVP: dict = {}  # problem_fn -> its compiled `_problem_jvp` program (the latest few problem functions)


def _problem_jvp(problem_fn, q, tangent):
    """The problem's parts at `q` and their derivative along `tangent` (one compilation serves every direction,
    and the finite differences' shifted problems). It runs for milliseconds, once per parameter: compiled as a
    small program (`SMALL_PROGRAM`: 2.2 s instead of 5.0 s for the default problem, its values equal to 1e-10)."""
    program = _PROBLEM_JVP.pop(problem_fn, None)
    if program is None:
        program = compiled_with(
            lambda q, t: jax.jvp(lambda q: _parts(problem_fn(q)), (q,), (t,)), (q, tangent), SMALL_PROGRAM
        )
    _PROBLEM_JVP[problem_fn] = program  # the most recent last; the oldest go beyond 8
    for old in list(_PROBLEM_JVP)[:-8]:
        del _PROBLEM_JVP[old]
    return program(q, tangent)


def _problem_tangents(problem_fn, q, wrt):
    """The problem's parts and their derivatives along each parameter of `wrt` (stacked on a leading axis)."""
    outs = [_problem_jvp(problem_fn, q, {k: jnp.asarray(float(k == p)) for k in q}) for p in wrt]
    return outs[0][0], jax.tree_util.tree_map(lambda *d: jnp.stack(d), *[o[1] for o in outs])


def _problem_parts(problem_fn, q):
    return _problem_jvp(problem_fn, q, {k: jnp.zeros(()) for k in q})[0]


def _align_square_roots(parts: _Parts, ref: _Parts) -> _Parts:
    """Flip the columns of the filter's noise square roots to the signs of `ref`'s: `psd_sqrt` (eigh) may flip an
    eigenvector's sign under a tiny change of the filter, which would change the realization discontinuously and
    spoil a finite difference with common random numbers (the law is the same either way)."""
    exc = parts.excitation
    if not isinstance(exc, FilterExcitation) or not isinstance(ref.excitation, FilterExcitation):
        return parts

    def align(m, r):
        return m * jnp.where(jnp.sum(m * r, axis=0) < 0, -1.0, 1.0)

    exc = eqx.tree_at(
        lambda e: (e.chol, e.stationary_chol),
        exc,
        (align(exc.chol, ref.excitation.chol), align(exc.stationary_chol, ref.excitation.stationary_chol)),
    )
    return eqx.tree_at(lambda p: p.excitation, parts, exc)


# Stored programs (no tracing in a warm process), compiled as the Monte Carlo's chunk is.
@functools.partial(cached_program, compiler_options=MONTE_CARLO_PROGRAM)
def _value_chunk(parts, key, indices, cfg):
    keys = jax.vmap(lambda i: jr.fold_in(key, i))(indices)
    return jax.vmap(lambda k: _realization(parts, None, k, cfg, False))(keys)


@functools.partial(cached_program, compiler_options=MONTE_CARLO_PROGRAM)
def _tangent_chunk(parts, dparts, key, indices, cfg):
    keys = jax.vmap(lambda i: jr.fold_in(key, i))(indices)
    return jax.vmap(lambda k: _realization(parts, dparts, k, cfg, True))(keys)


def _chunks(fn, num_realizations, chunk_size, progress):
    with progress_bar(progress, num_realizations, "sensitivity Monte Carlo") as report:
        return _chunks_reported(fn, num_realizations, chunk_size, report)


def _chunks_reported(fn, num_realizations, chunk_size, progress):
    outs = []
    for lo in range(0, num_realizations, chunk_size):
        idx = np.arange(lo, lo + chunk_size)
        valid = idx < num_realizations
        idx = np.where(valid, idx, num_realizations - 1)
        out = jax.device_get(fn(jnp.asarray(idx)))
        outs.append(jax.tree_util.tree_map(lambda a, v=valid: np.asarray(a)[v], out))
        if progress is not None:
            progress(min(lo + chunk_size, num_realizations))
    return jax.tree_util.tree_map(lambda *a: np.concatenate(a), *outs)


def monte_carlo_sensitivity(
    problem_fn: Callable[[Mapping], RollProblem],
    params: Mapping[str, float],
    key,
    *,
    wrt: Sequence[str] | None = None,
    statistics: Sequence[str] = DEFAULT_SENSITIVITY_STATISTICS,
    num_realizations: int = 1000,
    duration: float = 3600.0,
    discard: float = 0.0,
    window: float | None = 300.0,
    burn_in: float = 300.0,
    extrapolate: bool = True,
    smoothing_deg: float = 1.0,
    method: str = "windowed",
    fd_step: Mapping[str, float] | float = 0.02,
    chunk_size: int = 100,
    progress: Callable[[int], None] | bool | None = None,
) -> SensitivityResult:
    """Monte Carlo statistics of `problem_fn(params)` and their derivatives with respect to `wrt`.

    **Arguments:**

    - `problem_fn`: `params -> RollProblem`, differentiable in the parameters (e.g. from `sensitivity_problem`).
    - `params`: the nominal values by name (a dict of floats); `wrt`: the names to differentiate (default all).
    - `key`: JAX PRNG key; realization i uses `fold_in(key, i)` (the trials of `jaxroll.monte_carlo`).
    - `statistics`: names (see `parse_statistic`): "E_phi2", "mean_envelope", "mean_zero_crossing",
      "P_exceed_<a>deg", "P_exceed_zc_<a>deg".
    - `num_realizations`, `duration` [s], `discard` [s]: the Monte Carlo protocol (as `monte_carlo_amplitudes`).
    - `window` [s]: scored segment of the windowed estimator; `burn_in` [s]: how long each segment's tangent
      runs before it is scored. `window=None`: one window, the plain pathwise derivative of the whole run
      (unbiased, but heavy-tailed over long runs: docs/sensitivity.md).
    - `extrapolate`: also estimate with burn-ins B/3 and 2B/3 and remove the memory bias by its geometric
      decay (Aitken's Δ²): g = g_B + ρ/(1 − ρ)·(g_B − g_2B/3), ρ the pooled ratio of successive differences
      (default True; False: the plain windowed estimate g_B, biased low by the memory it drops).
    - `smoothing_deg`: the exceedance indicator 1{A > a} is replaced by Φ((A − a)/s), s = `smoothing_deg`; the
      value and gradient are those of the smoothed statistic (its bias: docs/sensitivity.md).
    - `method`: "windowed" (default) or "finite_difference": central differences with common random numbers
      at steps `fd_step` × |value| (× 1 for a parameter at 0) — a float, or a dict by name. The filter's noise
      square roots are sign-aligned with the nominal's, so the shifted problems see the same trials.
    - `chunk_size`: realizations per compiled batch; `progress`: called with the number done (`True`: a tqdm
      bar, as in `monte_carlo`).

    **Returns:** `SensitivityResult` (values, gradients, standard errors, per-realization contributions).

    **Raises:** `ValueError` for an unknown parameter or statistic, a window or burn-in that does not fit the
    run, or bad counts.
    """
    require_float64("jaxroll.monte_carlo_sensitivity")
    params = {str(k): float(v) for k, v in dict(params).items()}
    for k, v in params.items():
        if not math.isfinite(v):
            raise ValueError(f"parameter {k!r} = {v!r} must be finite.")
    wrt = tuple(params) if wrt is None else tuple(wrt)
    unknown = [p for p in wrt if p not in params]
    if unknown:
        raise ValueError(f"unknown parameter(s) {unknown}; `params` has {sorted(params)}.")
    if len(set(wrt)) != len(wrt):
        raise ValueError(f"`wrt` names a parameter twice: {list(wrt)}.")
    stats = tuple(parse_statistic(s) for s in statistics)
    if not stats:
        raise ValueError("`statistics` is empty.")
    if len({s.name for s in stats}) != len(stats):
        raise ValueError(f"`statistics` names a statistic twice: {list(statistics)}.")
    for name, value in (("num_realizations", num_realizations), ("chunk_size", chunk_size)):
        if not (isinstance(value, int) and not isinstance(value, bool) and value > 0):
            raise ValueError(f"`{name}` must be a positive integer; got {value!r}.")
    if method not in ("windowed", "finite_difference"):
        raise ValueError(f"`method` must be 'windowed' or 'finite_difference'; got {method!r}.")
    _check_seconds("duration", duration)
    _check_seconds("discard", discard, allow_zero=True)
    _check_seconds("burn_in", burn_in, allow_zero=True)
    if not (isinstance(smoothing_deg, int | float) and math.isfinite(smoothing_deg) and smoothing_deg > 0):
        raise ValueError(f"`smoothing_deg` must be a finite number > 0 [deg]; got {smoothing_deg!r}.")
    if discard >= duration:
        raise ValueError(f"`discard` = {discard} s must be below `duration` = {duration} s.")

    problem = jax.eval_shape(problem_fn, {k: jnp.asarray(v) for k, v in params.items()})
    if not isinstance(problem, RollProblem):
        raise TypeError(f"`problem_fn` must return a RollProblem; got {type(problem).__name__}.")
    dt = problem.dt
    num_steps = int(round(duration / dt))
    start = int(round(discard / dt))
    windowed = method == "windowed" and window is not None
    if method == "windowed" and window is not None:
        _check_seconds("window", window)
        if window > duration:
            raise ValueError(
                f"`window` = {window} s is longer than the run (`duration` = {duration} s); use window=None for "
                "the plain pathwise derivative of the whole run."
            )
        segment = max(1, int(round(window / dt)))
        burn = int(round(burn_in / dt))
        if burn + segment > num_steps:
            raise ValueError(
                f"`burn_in` + `window` = {burn_in + window} s is longer than the run (`duration` = {duration} s)."
            )
        spacing = burn // 3
        burns = (burn - 2 * spacing, burn - spacing, burn) if extrapolate and spacing >= 1 else (burn,)
    else:
        segment, burns = num_steps, (0,)
    cfg = _Config(stats, num_steps, start, segment, burns, dt, math.radians(smoothing_deg))
    base = {k: jnp.asarray(v) for k, v in params.items()}
    n_stats = len(stats)
    if method == "windowed" and wrt:
        parts, dparts = _problem_tangents(problem_fn, base, wrt)
        nums, dens, raws, alive, dnums, growth, count = _chunks(
            lambda idx: _tangent_chunk(parts, dparts, key, idx, cfg), num_realizations, chunk_size, progress
        )
    else:
        parts = _problem_parts(problem_fn, base)
        nums, dens, raws, alive = _chunks(
            lambda idx: _value_chunk(parts, key, idx, cfg), num_realizations, chunk_size, progress
        )
        dnums = np.zeros((num_realizations, len(wrt), 1, 2, n_stats))
        growth, count = np.zeros(num_realizations), np.zeros(num_realizations)
    keep = alive.copy()
    fd_values = []
    if method == "finite_difference":
        steps = fd_step if isinstance(fd_step, Mapping) else {p: float(fd_step) for p in wrt}
        for p in wrt:
            h = float(steps[p]) * (abs(params[p]) if params[p] != 0 else 1.0)
            pair = []
            for sign in (1.0, -1.0):
                q = {**base, p: jnp.asarray(params[p] + sign * h)}
                shifted = _align_square_roots(_problem_parts(problem_fn, q), parts)
                pair.append(
                    _chunks(
                        lambda idx: _value_chunk(shifted, key, idx, cfg), num_realizations, chunk_size, None
                    )
                )
                keep &= pair[-1][3]
            fd_values.append((h, pair))
    n_kept = int(keep.sum())
    if n_kept < 2:
        raise ValueError(f"only {n_kept} realization(s) survived; the statistics need at least 2.")
    nums, dens, raws, dnums = nums[keep], dens[keep], raws[keep], dnums[keep]
    value, _, value_se = _ratio(nums, dens)
    unsmoothed = raws.sum(0) / dens.sum(0)

    def windowed_influence(d):
        den = dens if d.ndim == 2 else dens[:, None, :]
        g = d.sum(0) / den.sum(0)
        return (d - g * den) / den.mean(0) + g

    # the burn-in extrapolation. The memory of a held state decays geometrically: on the windows that hold one,
    # g(B) − g(B − Δ) = ρ·(g(B − Δ) − g(B − 2Δ)), so g = g(B) + ρ/(1 − ρ)·(g(B) − g(B − Δ)). ρ (one memory for
    # every statistic and parameter) is the inverse-variance weighted least-squares ratio of those differences
    # (Aitken's Δ², pooled). The finite-time Lyapunov exponent λ of the roll is reported beside it.
    rate, rho, factor = None, None, 0.0
    if len(burns) > 1:
        rate = float(growth[keep].sum() / max(count[keep].sum(), 1.0) / (cfg.length * dt))
        late = np.stack([windowed_influence(dnums[:, :, b, 1]) for b in range(len(burns))])  # (3, n, P, S)
        d1, d2 = late[1] - late[0], late[2] - late[1]
        m1, m2 = d1.mean(0).ravel(), d2.mean(0).ravel()
        ok = np.abs(m1) > 0
        if ok.any():
            rho = float(np.median(m2[ok] / m1[ok]))
            var = np.maximum((d2 - rho * d1).var(0).ravel(), 1e-300)
            w = ok / var
            rho = float(np.sum(w * m1 * m2) / np.sum(w * m1 * m1))
        if not (rho is not None and math.isfinite(rho) and 0 < rho < 0.95):
            # too noisy to see the decay (e.g. only parameters with noisy derivatives): fall back on the typical
            # path's memory, exp(λΔ), which under-corrects somewhat (docs/sensitivity.md)
            fallback = (
                math.exp(rate * (burns[1] - burns[0]) * dt) if math.isfinite(rate) and rate < 0 else None
            )
            warnings.warn(
                f"the windowed estimates do not show a geometric decay with the burn-in (ratio {rho}): the burn-in "
                + (
                    f"bias is extrapolated with ρ = exp(λΔ) = {fallback:.3g} from the finite-time Lyapunov exponent "
                    f"λ = {rate:.3g} 1/s, which under-corrects it a little."
                    if fallback is not None
                    else f"bias is not extrapolated (Lyapunov exponent {rate:.3g} 1/s)."
                )
                + " Compare with method='finite_difference'.",
                stacklevel=2,
            )
            rho = fallback
        if rho is not None:
            factor = rho / (1 - rho)

    gradient, std_error, influence, raw_gradient, raw_std_error = {}, {}, {}, {}, {}
    by_burn_in = {}
    for j, p in enumerate(wrt):
        if method == "finite_difference":
            h, ((nu_p, de_p, ra_p, _), (nu_m, de_m, ra_m, _)) = fd_values[j]
            rp, ip, _ = _ratio(nu_p[keep], de_p[keep])
            rm, im, _ = _ratio(nu_m[keep], de_m[keep])
            infl = (ip - im) / (2 * h)
            rp, ip, _ = _ratio(ra_p[keep], de_p[keep])
            rm, im, _ = _ratio(ra_m[keep], de_m[keep])
            raw_infl = (ip - im) / (2 * h)
            for s, stat in enumerate(stats):
                raw_gradient.setdefault(stat.name, {})[p] = float(raw_infl[:, s].mean())
                raw_std_error.setdefault(stat.name, {})[p] = float(
                    raw_infl[:, s].std(ddof=1) / math.sqrt(n_kept)
                )
        else:
            per_burn = [windowed_influence(dnums[:, j, b].sum(1)) for b in range(dnums.shape[2])]
            late = [windowed_influence(dnums[:, j, b, 1]) for b in range(dnums.shape[2])]
            infl = per_burn[-1] + factor * (late[-1] - late[-2]) if len(per_burn) > 1 else per_burn[-1]
            if windowed:
                for b, x in zip(burns, per_burn, strict=True):
                    by_burn_in.setdefault(b * dt, {}).update(
                        {(stat.name, p): float(x[:, s].mean()) for s, stat in enumerate(stats)}
                    )
        se = infl.std(0, ddof=1) / math.sqrt(n_kept)
        for s, stat in enumerate(stats):
            gradient.setdefault(stat.name, {})[p] = float(infl[:, s].mean())
            std_error.setdefault(stat.name, {})[p] = float(se[s])
            influence.setdefault(stat.name, {})[p] = infl[:, s]
    config = {
        "method": "windowed" if windowed else ("pathwise" if method == "windowed" else method),
        "num_realizations": num_realizations,
        "duration_s": float(duration),
        "discard_s": float(discard),
        "dt_s": dt,
        "window_s": segment * dt if windowed else None,
        "burn_in_s": [b * dt for b in burns] if windowed else None,
        "extrapolated": bool(factor > 0),
        "lyapunov_exponent_per_s": rate,
        "memory_ratio": rho,
        "extrapolation_factor": factor,
        "smoothing_deg": float(smoothing_deg),
        "fd_step": None if method != "finite_difference" else {p: h for p, (h, _) in zip(wrt, fd_values)},
    }
    return SensitivityResult(
        statistics=tuple(s.name for s in stats),
        parameters=wrt,
        params=params,
        value={s.name: float(value[i]) for i, s in enumerate(stats)},
        value_std_error={s.name: float(value_se[i]) for i, s in enumerate(stats)},
        unsmoothed={s.name: float(unsmoothed[i]) for i, s in enumerate(stats)},
        gradient=gradient,
        std_error=std_error,
        influence=influence,
        unsmoothed_gradient=raw_gradient,
        unsmoothed_std_error=raw_std_error,
        by_burn_in={
            b: {s.name: {p: d[(s.name, p)] for p in wrt} for s in stats} for b, d in by_burn_in.items()
        },
        kept=keep,
        n_realizations=num_realizations,
        n_capsized=int(num_realizations - alive.sum()),
        config=config,
    )
