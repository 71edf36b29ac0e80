"""Yaw: the heading as an Ornstein–Uhlenbeck process along a run (issue 44, item 4; docs/yaw.md).

The ship's heading wanders about its course: χ(t) = χ0 + ψ(t), ψ an Ornstein–Uhlenbeck process of standard deviation
σ_ψ and correlation time τ (E[ψ(t)ψ(t+s)] = σ_ψ² e^{−|s|/τ}), sampled exactly on the half steps of the run
(ψ_{n+1} = a ψ_n + σ_ψ √(1 − a²) ξ_n, a = e^{−h/τ}, ψ_0 from the stationary law). At zero speed the encounter
frequency of a wave component does not depend on the heading, so a component keeps its phase and only its weight
changes with χ(t): Grim's transfer G(k|cos χ(t)|) for ζ_G and the hull's moment F(ω, χ(t))/I44 for M_w:

    ζ_G(t) = Re Σ_j a_j G(k_j |cos χ(t)|) e^{iω_j t},   M_w(t) = Re Σ_j a_j F(ω_j, χ(t))/I44 e^{iω_j t}.

Each weight is interpolated in the heading, w(ω, χ) ≈ Σ_n ℓ_n(χ) w(ω, χ_n), so that each sum is Σ_n ℓ_n(χ(t)) Z_n(t)
with Z_n the superposition at the fixed node χ_n: one inverse FFT per node, combined sample by sample:

- Grim's weight: Lagrange interpolation in c = |cos χ| at Chebyshev nodes spanning the c that χ0 ± R reaches
  (R = min(6σ_ψ, π); ψ is clipped at ±R for the weights, a 2e-9 probability per sample), as many nodes as make the
  rms error of ζ_G at any heading in reach below 1e-3 σ_G (at most 24 nodes) (`grim_yaw_nodes`);
- the moment: the table's own linear interpolation in χ (`WaveMoment.at_heading`), exactly, its headings mirrored
  beyond 0 and π (F(−χ) = −F(χ), waves from starboard) as the nodes (`moment_yaw_nodes`).

The nodes' processes are synthesised on the time steps with their derivatives, brought to the half steps by the same
cubic Hermite interpolation as `SuperpositionExcitation` (smooth: error O(dt⁴)), and multiplied there by the weights
of ψ at the half steps: the excitation's values at the RK4 stage times (ψ is not differentiable, so no derivative of
the product is needed). At forward speed the encounter frequency would follow χ(t) too (ω_e = ω − kU cos χ): not
modelled, refused (`check_yaw_speed`).
"""

from __future__ import annotations

import math
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Complex, Float

from ..sea._grim import grim_transfer
from ..sea._spectra import GRAVITY

#: ψ of a realization keyed k draws its normals from fold_in(k, YAW_KEY) (`COMPONENTS_KEY` − 1).
YAW_KEY = 0x7FFFFFFD
#: The largest yaw standard deviation accepted [deg]: beyond it the heading is no longer a disturbance of a course.
MAX_YAW_STD_DEG = 45.0
#: ψ is clipped at ±`YAW_RANGE_STDS`·σ_ψ (and ±π) for the weights.
YAW_RANGE_STDS = 6.0
#: The rms error of ζ_G that interpolating Grim's weight in the heading leaves, relative to σ_G (at most).
GRIM_TOLERANCE = 1e-3
MAX_GRIM_NODES = 24
#: A warning when the nodes leave more than this rms error of ζ_G relative to σ_G.
GRIM_WARNING = 1e-2


class Yaw(eqx.Module):
    """An Ornstein–Uhlenbeck yaw ψ(t) about the course: standard deviation `std` σ_ψ [rad] and correlation time
    `correlation_time` τ [s] (E[ψ(t)ψ(t+s)] = σ_ψ² e^{−|s|/τ}). Give it to `RollProblem.from_sea(..., yaw=)`."""

    std: float = eqx.field(static=True)
    correlation_time: float = eqx.field(static=True)

    def __init__(self, std: float, correlation_time: float):
        """**Arguments:** `std`: σ_ψ [rad], 0 ≤ σ_ψ ≤ 45° (0: no yaw); `correlation_time`: τ [s] > 0.

        **Raises:** `ValueError` for a negative, non-finite or absurd (> 45°) σ_ψ, or a τ that is not > 0."""
        std, tau = float(std), float(correlation_time)
        if not (math.isfinite(std) and 0 <= std <= math.radians(MAX_YAW_STD_DEG)):
            raise ValueError(
                f"the yaw's standard deviation must be between 0 and {MAX_YAW_STD_DEG:g}° (a disturbance of the "
                f"course); got {math.degrees(std):.4g}° ({std!r} rad)."
            )
        if not (math.isfinite(tau) and tau > 0):
            raise ValueError(f"the yaw's correlation time must be a finite number > 0 [s]; got {tau!r}.")
        self.std, self.correlation_time = std, tau

    @property
    def range(self) -> float:
        """R [rad]: ψ is clipped at ±R = ±min(6σ_ψ, π) for the weights."""
        return min(YAW_RANGE_STDS * self.std, math.pi)


def check_yaw_speed(yaw: Yaw | None, speed: float) -> None:
    """Refuse yaw at forward speed (the encounter frequency would follow the heading: not modelled)."""
    if yaw is not None and yaw.std > 0 and float(speed) != 0.0:
        raise ValueError(
            f"yaw at forward speed (U = {float(speed):g} m/s) is not modelled: the encounter frequency would "
            "follow the heading (ω_e = ω − kU cos χ(t)); run yaw at speed 0, or without yaw (docs/yaw.md)."
        )


def yaw_path(yaw: Yaw, key, num: int, h: float) -> Float[Array, " num"]:
    """ψ [rad] (float64) on t = 0, h, …, (num − 1)h for the realization keyed `key`: ψ_0 ~ N(0, σ_ψ²), then
    ψ_{n+1} = a ψ_n + σ_ψ √(1 − a²) ξ_n, a = e^{−h/τ} (exact), by a parallel prefix scan."""
    from ._excitation import block_normals

    xi = block_normals(key, YAW_KEY, (num,)).astype(jnp.float64)
    a = math.exp(-h / yaw.correlation_time)
    b = jnp.concatenate([xi[:1] * yaw.std, xi[1:] * (yaw.std * math.sqrt(1 - a * a))])
    coef = jnp.full((num,), a).at[0].set(0.0)

    def compose(left, right):  # x ↦ a_r (a_l x + b_l) + b_r
        return left[0] * right[0], right[0] * left[1] + right[1]

    return jax.lax.associative_scan(compose, (coef, b))[1]


def _chebyshev(lo: float, hi: float, count: int) -> np.ndarray:
    k = np.arange(count)
    return (lo + hi) / 2 + (hi - lo) / 2 * np.cos((2 * k + 1) * np.pi / (2 * count))


def lagrange_weights(x, nodes: tuple, xp=jnp) -> Float[Array, "p ..."]:
    """ℓ_n(x), the Lagrange basis of `nodes` (a tuple of distinct floats) at x: Σ_n ℓ_n(x) f(x_n) interpolates f
    (`xp`: `jnp`, or `np` on the host)."""
    out = []
    for n, xn in enumerate(nodes):
        w = xp.ones_like(x)
        for mth, xm in enumerate(nodes):
            if mth != n:
                w = w * (x - xm) / (xn - xm)
        out.append(w)
    return xp.stack(out)


def _cos_range(chi0: float, r: float) -> tuple[float, float]:
    chi = chi0 + np.linspace(-r, r, 4001)
    c = np.abs(np.cos(np.concatenate([chi, [chi0 - r, chi0 + r]])))
    lo, hi = float(c.min()), float(c.max())
    if chi0 - r <= math.pi / 2 <= chi0 + r or chi0 - r <= 3 * math.pi / 2 <= chi0 + r:
        lo = 0.0
    if chi0 - r <= math.pi <= chi0 + r or chi0 - r <= 0.0 <= chi0 + r:
        hi = 1.0
    return lo, hi


class YawNodes(eqx.Module):
    """A source's weight interpolated in the heading under yaw (module docstring): the `yaw`, the course χ0 [rad],
    the nodes (|cos χ| for Grim's weight, χ [rad] for the moment's) and, for the moment, its transfer at each node
    [rad/s² per m] on the table's frequencies."""

    yaw: Yaw
    chi0: float = eqx.field(static=True)
    nodes: tuple = eqx.field(static=True)
    kind: str = eqx.field(static=True)  # "grim" | "moment"
    transfers: Complex[Array, "p n"] | None = None
    error: float = eqx.field(static=True, default=0.0)  # Grim's: the rms error of ζ_G left, relative to σ_G
    bounds: tuple = eqx.field(static=True, default=(0.0, 1.0))  # Grim's: the range of |cos χ| in reach

    def weights(self, psi) -> Float[Array, "p ..."]:
        """ℓ_n(χ0 + ψ) of each node, ψ [rad] clipped at ±R."""
        chi = self.chi0 + jnp.clip(psi, -self.yaw.range, self.yaw.range)
        if self.kind == "grim":
            c = jnp.clip(jnp.abs(jnp.cos(chi)), *self.bounds)
            if len(self.nodes) == 1:
                return jnp.ones_like(c)[None]
            return lagrange_weights(c, self.nodes)
        grid = np.asarray(self.nodes)
        return jnp.stack([jnp.interp(chi, grid, np.eye(grid.size)[n]) for n in range(grid.size)])


def grim_yaw_nodes(wave, yaw: Yaw) -> YawNodes:
    """Chebyshev nodes in c = |cos χ| over what χ0 ± R reaches, as few as leave an rms error of ζ_G below
    `GRIM_TOLERANCE` of the largest σ_G at any c in reach: (Σ S(ω)|G̃ − G|²)^½ over 1200 frequencies to 6 rad/s,
    G̃ the interpolated weight (host side, concrete wave)."""
    chi0, r = float(wave.heading), yaw.range
    lo, hi = _cos_range(chi0, r)
    omega = np.linspace(0.005, 6.0, 1200)
    s = np.asarray(wave.sea(jnp.asarray(omega)))[:, None]
    k = omega**2 / GRAVITY
    length = float(wave.length)
    dense = np.linspace(lo, hi, 401)
    exact = np.asarray(grim_transfer(k[:, None] * dense[None], length))
    variance = np.sum(s * exact**2, axis=0)  # of ζ_G at each c (the grid's step cancels)
    if hi - lo < 1e-12:
        return YawNodes(yaw, chi0, (hi,), "grim")
    nodes, error = (), 0.0
    for count in range(2, MAX_GRIM_NODES + 1):
        nodes = tuple(float(x) for x in _chebyshev(lo, hi, count))
        at_nodes = np.asarray(grim_transfer(k[:, None] * np.asarray(nodes)[None], length))
        interp = at_nodes @ lagrange_weights(dense, nodes, np)
        error = float(np.sqrt(np.sum(s * (interp - exact) ** 2, axis=0).max() / max(variance.max(), 1e-300)))
        if error <= GRIM_TOLERANCE:
            break
    if error > GRIM_WARNING:
        warnings.warn(
            f"yaw: Grim's weight interpolated in the heading at {len(nodes)} nodes leaves an rms error of "
            f"{100 * error:.2g} % of σ_G in ζ_G (the short waves' weight changes fast with the heading); this warning "
            f"appears above {100 * GRIM_WARNING:g} % (docs/yaw.md).",
            stacklevel=3,
        )
    return YawNodes(yaw, chi0, nodes, "grim", error=error, bounds=(lo, hi))


def moment_yaw_nodes(table, chi0: float, yaw: Yaw) -> YawNodes:
    """The wave-moment table's headings, mirrored beyond 0 (F(−χ) = −F(χ)) and π (F(2π − χ) = −F(χ)), that
    bracket χ0 ± R, and the table's rows there (per unit inertia, signed): the table's linear interpolation in χ,
    exactly (host side)."""
    h = np.asarray(table.headings, dtype=float)
    rows = table.values
    if not (h[0] <= 1e-12 and h[-1] >= math.pi - 1e-12):
        raise ValueError(
            "yaw with a wave moment needs the moment tabulated over every heading 0–180° (its headings here: "
            f"{math.degrees(h[0]):.4g}–{math.degrees(h[-1]):.4g}°): tabulate it there (`wave_moment(..., headings=...)`)."
        )
    inner = h > 1e-12
    upper = h < math.pi - 1e-12
    ext = np.concatenate([-h[inner][::-1], h, 2 * math.pi - h[upper][::-1]])
    idx = np.concatenate([np.nonzero(inner)[0][::-1], np.arange(h.size), np.nonzero(upper)[0][::-1]])
    sign = np.concatenate([-np.ones(inner.sum()), np.ones(h.size), -np.ones(upper.sum())])
    r = yaw.range
    first = max(int(np.searchsorted(ext, chi0 - r, side="right")) - 1, 0)
    last = min(int(np.searchsorted(ext, chi0 + r, side="left")), ext.size - 1)
    sel = np.arange(first, last + 1)
    transfers = rows[idx[sel]] * jnp.asarray(sign[sel])[:, None].astype(rows.dtype)
    return YawNodes(yaw, float(chi0), tuple(float(x) for x in ext[sel]), "moment", transfers)


def half_step_series(x, dx, dt) -> Float[Array, " n"]:
    """A process on the half steps t = 0, dt/2, dt, … from its samples and derivatives on the time steps (the
    midpoints by cubic Hermite interpolation, as `SuperpositionExcitation`)."""
    mid = (x[:-1] + x[1:]) / 2 + dt * (dx[:-1] - dx[1:]) / 8
    return jnp.concatenate([jnp.stack([x[:-1], mid], -1).reshape(-1), x[-1:]])


def yaw_block_values(series, index, m: int):
    """The 2m half-step values of each of the `BLOCK` source steps of block `index` [BLOCK, 2m]."""
    from ._excitation import BLOCK

    n = 2 * BLOCK * m
    return jax.lax.dynamic_slice_in_dim(series, index * n + 1, n).reshape(BLOCK, 2 * m)


def yaw_init(zeta_source, moment_source, key, num_steps: int, m: int, dtype) -> list:
    """`init` of the yawed sources given (ζ_G's, M_w's or both; None for one not run) for the realization keyed
    `key`: the realization's wave components (`encounter_components`), one inverse FFT per node of each source, the
    nodes' half-step series weighted by ψ's (`yaw_path`, the same for both). **Returns:** `[(state, value at t = 0)]`
    per source given, each state the source's half-step series (float64 until cast to `dtype`)."""
    from ..sea._grim import superposition_length
    from ._excitation import _check_length, _padded_length, _synthesise, encounter_components

    sources = [s for s in (zeta_source, moment_source) if s is not None]
    n = _padded_length(num_steps, m)
    _check_length(n)
    size = superposition_length(n)
    dt = sources[0].dt
    if moment_source is not None:
        sea, speed, following = moment_source.sea, moment_source.speed, moment_source.following
    else:
        wave = zeta_source.wave
        sea, speed, following = wave.sea, wave.speed * jnp.abs(wave.cos_heading), wave.following
    omega_e, omegas, amps = encounter_components(sea, speed, following, key, size, dt)
    coefs = jnp.concatenate([s.node_coefficients(omegas, amps) for s in sources])
    series = _synthesise(coefs, omega_e, size, n, jnp.float64)
    psi = yaw_path(sources[0].yaw.yaw, key, 2 * n - 1, dt / 2)
    out, start = [], 0
    for s in sources:
        count = len(s.yaw.nodes)
        weights = s.yaw.weights(psi)
        value = sum(weights[i] * half_step_series(*series[start + i], dt) for i in range(count))
        start += count
        value = value.astype(dtype)
        out.append(((value,), value[0]))
    return out


def yaw_bytes_per_realization(problem, num_steps: int) -> int:
    """The memory [bytes] a yawed problem's synthesis adds per realization of `num_steps` time steps (0 without
    yaw), counted from its arrays: per node, the FFT coefficients of the process and its derivative (complex128),
    the inverse FFT's output, and on the half steps the series, its weight and their product (float64)."""
    from ..sea._grim import superposition_length
    from ._excitation import _padded_length

    sources = [
        s for s in (problem.excitation, problem.moment_excitation) if getattr(s, "yaw", None) is not None
    ]
    if not sources:
        return 0
    n = _padded_length(num_steps, problem.excitation.substeps)
    size = superposition_length(n)
    per_node = 2 * (size // 2 + 1) * 16 + 2 * size * 8 + 3 * (2 * n) * 8
    return sum(len(s.yaw.nodes) for s in sources) * per_node
