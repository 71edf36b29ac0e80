"""Sources of Grim's effective wave ζ_G(t) for one realization: shaping filter, superposition, or a record; and
the direct wave roll moment M_w(t) (`WaveMomentExcitation`).

The integrator (`jaxroll.simulate`) advances in *source steps* of m time steps (m = `excitation.substeps`): the
shaping filter is stepped exactly once per source step of H = m·dt, and every source delivers ζ_G [m] at the 2m
half steps t + j·dt/2, j = 1 … 2m, of each source step (the RK4 stage times), a block of `BLOCK` source steps at
a time. `block_inputs` draws or slices a block's inputs before the block's scan; `advance` consumes one source
step's inputs. Noise for block j of a realization keyed `key` comes from `fold_in(key, j)`, so a realization is
the same whatever the chunking, the device count or the number of steps simulated after it.
"""

from __future__ import annotations

import abc
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, Complex, Float, PRNGKeyArray

from .._compiled import cached_program
from ..sea._filters import ShapingFilter, psd_sqrt
from ..sea._grim import EffectiveWave, direction_cosines, grim_transfer, superpose, superposition_length
from ..sea._spectra import GRAVITY, AbstractWaveSpectrum, encounter_branches, heading_angle, heading_cosine
from ..sea._spreading import Spreading
from ..ship._wave_moment import WaveMoment
from ._yaw import Yaw, YawNodes, grim_yaw_nodes, moment_yaw_nodes, yaw_block_values, yaw_init

BLOCK = 128  # source steps per noise block (block j of a realization keyed k draws from fold_in(k, j))
START_KEY = 0x7FFFFFFF  # the filter's stationary start draws from fold_in(k, START_KEY)


class AbstractExcitation(eqx.Module):
    """Source of Grim's effective wave ζ_G [m] for the integrator, one source step (m time steps) at a time."""

    dt: eqx.AbstractVar[float]
    substeps: eqx.AbstractVar[int]

    @abc.abstractmethod
    def init(self, key: PRNGKeyArray, num_steps: int, m: int, dtype):
        """`(state, ζ_G(0))` before the first of `num_steps` time steps of a run in source steps of `m` steps, in
        the run's floating `dtype` (the integrator has cast the source's arrays to it)."""

    @abc.abstractmethod
    def block_inputs(self, key: PRNGKeyArray, state, index, m: int):
        """Inputs of the `BLOCK` source steps of block `index` (leading axis `BLOCK`), drawn or sliced at once."""

    @abc.abstractmethod
    def advance(self, state, inputs, m: int):
        """One source step: `(state, values)`, values a tuple of the 2m scalars ζ_G(t + j·dt/2), j = 1 … 2m, from
        that step's `inputs` (a tuple, not a stacked array: vmapped, each stays one vector)."""


# ----------------------------------------------------------------------------------------------------------------
# Random numbers: jax.random.normal's stream, computed in one fused elementwise pass
# ----------------------------------------------------------------------------------------------------------------


def _rotl(x, r: int):
    return (x << np.uint32(r)) | (x >> np.uint32(32 - r))


def threefry2x32(k0, k1, x0, x1):
    """Threefry-2x32 (20 rounds), unrolled, elementwise on uint32 arrays: `jax.random`'s default hash.

    JAX lowers its own on CPU as a 5-iteration loop over whole arrays; unrolled, XLA fuses it into one pass
    (2.3–2.6× faster) with bit-identical results.
    """
    rot = ((13, 15, 26, 6), (17, 29, 16, 24))
    ks = (k0, k1, k0 ^ k1 ^ np.uint32(0x1BD11BDA))
    x0, x1 = x0 + ks[0], x1 + ks[1]
    for i in range(5):
        for r in rot[i % 2]:
            x0 = x0 + x1
            x1 = _rotl(x1, r) ^ x0
        x0 = x0 + ks[(i + 1) % 3]
        x1 = x1 + ks[(i + 2) % 3] + np.uint32(i + 1)
    return x0, x1


def _bits_to_normal(bits):
    """Standard normal (float32) from 32 random bits exactly as `jax.random.normal`: √2·erf⁻¹(u), u ∈ (−1, 1)."""
    f = jax.lax.bitcast_convert_type((bits >> np.uint32(9)) | np.uint32(0x3F800000), jnp.float32)  # [1, 2)
    lo = np.nextafter(np.float32(-1), np.float32(0))
    u = jnp.maximum((f - np.float32(1)) * (np.float32(1) - lo) + lo, lo)
    return np.float32(math.sqrt(2)) * jax.lax.erf_inv(u)


def block_normals(key: PRNGKeyArray, index, shape) -> Float[Array, "..."]:
    """Standard normals (float32) of shape `shape` for block `index` of the realization keyed `key`.

    Threefry-2x32 (JAX's default hash, 20 rounds) of `fold_in(key, index)` on counters 0, 1, …, both 32-bit output
    words used (two normals per hash: `jax.random` XORs them into one), each mapped to a normal exactly as
    `jax.random.normal` maps its bits (√2·erf⁻¹ of a uniform on (−1, 1)). Unrolled so that XLA fuses it into one
    pass."""
    if jr.key_impl(key) != jr.key_impl(jr.key(0)):  # another PRNG than threefry: its own normals
        return jr.normal(jr.fold_in(key, index), shape, jnp.float32)
    kd = jr.key_data(jr.fold_in(key, index))
    size = math.prod(shape)
    ctr = jnp.arange(-(-size // 2), dtype=jnp.uint32)
    b0, b1 = threefry2x32(kd[0], kd[1], jnp.zeros_like(ctr), ctr)
    bits = jnp.stack([b0, b1], -1).reshape(-1)[:size]
    return _bits_to_normal(bits).reshape(shape)


def block_normals_by_column(key: PRNGKeyArray, index, n: int, first_row=0, rows: int = BLOCK) -> tuple:
    """`block_normals(key, index, (BLOCK, n))` column by column, the same numbers: n arrays of `BLOCK` normals
    (float32), column i holding the normals of filter state i over the block's source steps.

    Each column is hashed from its own counters (normal f of the block, f = s·n + i, is word f mod 2 of counter
    ⌊f/2⌋), so no array of the block is interleaved or transposed per realization and XLA generates each column
    as one vectorized pass (the paper protocol's Monte Carlo 0.51 → 0.45 s, a `MaxRoll` chunk 0.40 → 0.28 s on
    the 2-core CPU). For even n a pair of columns shares its hashes, as in `block_normals`.

    `first_row`, `rows`: only the block's source steps first_row … first_row + rows − 1 (the same numbers as
    those rows of the whole block; `first_row` may be traced), rows past the block's end continuing into block
    `index` + 1 (`rows` ≤ `BLOCK`), for runs that start at any source step (`jaxroll.monte_carlo_splitting`'s
    clones, and its runs continued past the event)."""
    whole = isinstance(first_row, int) and first_row == 0 and rows <= BLOCK
    if jr.key_impl(key) != jr.key_impl(jr.key(0)):  # another PRNG than threefry: its own normals
        z = block_normals(key, index, (BLOCK, n))
        if not whole:
            z = jnp.concatenate([z, block_normals(key, index + 1, (BLOCK, n))])
        z = jax.lax.dynamic_slice_in_dim(z, first_row, rows)
        return tuple(z[:, i] for i in range(n))
    kd = jr.key_data(jr.fold_in(key, index))
    k0, k1 = kd[0], kd[1]
    s = jnp.arange(rows, dtype=jnp.uint32)
    if not whole:
        s = s + jnp.asarray(first_row).astype(jnp.uint32)
        following = jr.key_data(jr.fold_in(key, index + 1))
        beyond = s >= np.uint32(BLOCK)
        s = jnp.where(beyond, s - np.uint32(BLOCK), s)
        k0, k1 = jnp.where(beyond, following[0], k0), jnp.where(beyond, following[1], k1)
    zero = jnp.zeros_like(s)
    words = []
    if n % 2 == 0:
        for j in range(n // 2):
            words += threefry2x32(k0, k1, zero, s * np.uint32(n // 2) + np.uint32(j))
    else:
        for i in range(n):
            f = s * np.uint32(n) + np.uint32(i)
            b0, b1 = threefry2x32(k0, k1, zero, f >> np.uint32(1))
            words.append(jnp.where((f & np.uint32(1)) == 0, b0, b1))
    return tuple(_bits_to_normal(w) for w in words)


# ----------------------------------------------------------------------------------------------------------------
# Method 2: the shaping filter, stepped exactly every H = m·dt, bridged in between
# ----------------------------------------------------------------------------------------------------------------


COARSE_TOLERANCE = 1e-6  # largest bridge interpolation error variance / σ_G² accepted for the filter step


class FilterExcitation(AbstractExcitation):
    """Method 2: exact discretisation of a shaping filter on a step H = m·dt, started from its stationary law.

    Per source step the filter state moves exactly, z(t+H) = Φ z(t) + L ε (Φ = e^{AH}, L Lᵀ = Σ − ΦΣΦᵀ, ε ~ N(0, I);
    L keeps the r principal directions of that nearly singular covariance, r normals per m time steps:
    `choose_noise_rank`), and ζ_G at the 2m − 1 RK4 stage times in between is its conditional mean given
    the filter state at both ends, E[ζ_G(τ) | z(t), z(t+H)] = a·z(t) + b·z(t+H) (the Gaussian bridge, the best
    interpolant: `bridge`). m (`substeps`) is the largest of (4, 2, 1) whose bridge leaves out at most
    `COARSE_TOLERANCE`·σ_G² of the variance at every stage time (m = 4, H = 2 s, for the paper's sea at dt = 0.5 s:
    3.7e-7); pass `substeps` to fix it (e.g. when the filter is traced, inside `jit` or a derivative).
    """

    phi: Float[Array, "n n"]
    chol: Float[Array, "n r"]
    stationary_chol: Float[Array, "n n"]
    c: Float[Array, " n"]
    bridge: Float[Array, "2 s n"]
    dt: float = eqx.field(static=True)
    substeps: int = eqx.field(static=True)

    def __init__(
        self,
        shaping_filter: ShapingFilter,
        dt: float,
        substeps: int | None = None,
        noise_rank: int | None = None,
    ):
        """**Arguments:** `shaping_filter` (e.g. `fit_filter(...).filter`); `dt`: time step [s]; `substeps`: time
        steps per filter step m (None: the largest of 4, 2, 1 within `COARSE_TOLERANCE`; 1 when traced);
        `noise_rank`: normals per filter step r ≤ n (None: the smallest even r within `COARSE_TOLERANCE`,
        `choose_noise_rank`; n when traced)."""
        self.dt = float(dt)
        if substeps is None:
            substeps = choose_substeps(shaping_filter, self.dt)
        if not (isinstance(substeps, int) and not isinstance(substeps, bool) and substeps >= 1):
            raise ValueError(f"`substeps` must be an integer >= 1; got {substeps!r}.")
        n = shaping_filter.c.size
        if noise_rank is None:
            noise_rank = choose_noise_rank(shaping_filter, self.dt, substeps)
        if not (isinstance(noise_rank, int) and not isinstance(noise_rank, bool) and 1 <= noise_rank <= n):
            raise ValueError(
                f"`noise_rank` must be an integer in 1 … {n} (the filter's order); got {noise_rank!r}."
            )
        self.substeps = substeps
        self.phi, chol, self.stationary_chol, self.bridge = filter_grid(shaping_filter, self.dt, substeps)
        self.chol = chol[:, n - noise_rank :]  # (eigh's columns ascend: the r largest directions)
        self.c = shaping_filter.c

    @property
    def noise_rank(self) -> int:
        """Normals drawn per filter step r: the r principal directions of the step's noise covariance."""
        return self.chol.shape[1]

    def init(self, key, num_steps, m, dtype):
        _check_substeps(self, m)
        z = self.stationary_chol @ jr.normal(jr.fold_in(key, START_KEY), self.c.shape).astype(dtype)
        z = tuple(z[i] for i in range(self.c.size))
        return z, _dot(self.c, z)

    def block_inputs(self, key, state, index, m):
        return tuple(e.astype(self.c.dtype) for e in block_normals_by_column(key, index, self.noise_rank))

    def advance(self, z, eps, m):
        # Scalar algebra on the n filter states (not 4×4 matrix products): vmapped over realizations, each line
        # becomes one fused vector operation.
        n = self.c.size
        z1 = tuple(_dot(self.phi[i], z) + _dot(self.chol[i], eps) for i in range(n))
        values = [_dot(self.bridge[0, j], z) + _dot(self.bridge[1, j], z1) for j in range(2 * m - 1)]
        return z1, (*values, _dot(self.c, z1))


def _dot(row, z):
    return sum(row[i] * z[i] for i in range(len(z)))


def _check_substeps(source, m: int) -> None:
    if m != source.substeps:
        raise ValueError(
            f"this {type(source).__name__} steps its filter every {source.substeps} time steps; the run asks "
            f"for {m}. Build every filter of one problem with the same `substeps`."
        )


def _half_powers(half, m: int):
    """[e^{A·j·dt/2} for j = 0 … 2m] from `half` = e^{A dt/2}."""
    powers = [jnp.eye(half.shape[0], dtype=half.dtype)]
    for _ in range(2 * m):
        powers.append(half @ powers[-1])
    return powers


def bridge_weights(half, sigma, c, m: int):
    """(a, b), each [2m − 1, n]: E[ζ_G(τ_j) | z(0), z(H)] = a_j·z(0) + b_j·z(H) at τ_j = j·dt/2, j = 1 … 2m − 1,
    H = m·dt (the Gaussian bridge of the stationary filter: cᵀ[Φ_τ z(0) + Q_τ Φ_{H−τ}ᵀ Q_H⁻¹ (z(H) − Φ_H z(0))],
    Q_τ = Σ − Φ_τ Σ Φ_τᵀ). `half` = e^{A dt/2}, `sigma`: stationary covariance, `c`: output vector. m = 1 has
    one interior point, the step's midpoint."""
    powers = _half_powers(half, m)
    q = [sigma - p @ sigma @ p.T for p in powers]
    phi_h, q_h = powers[2 * m], q[2 * m]
    a, b = [], []
    for j in range(1, 2 * m):
        gain = jnp.linalg.solve(q_h.T, (q[j] @ powers[2 * m - j].T).T).T  # Q_τ Φ_{H−τ}ᵀ Q_H⁻¹
        a.append(c @ (powers[j] - gain @ phi_h))
        b.append(c @ gain)
    return jnp.stack(a), jnp.stack(b)


def interpolation_error_variance(half, sigma, c, m: int, weights=None):
    """Relative error variance E[(ζ̂ − ζ_G)²]/σ_G² at τ_j = j·dt/2, j = 1 … 2m − 1, of the interpolant
    ζ̂ = a_j·z(0) + b_j·z(H) (default: the bridge weights), exact for the stationary filter."""
    powers = _half_powers(half, m)
    phi_h = powers[2 * m]
    k = jnp.block([[sigma, sigma @ phi_h.T], [phi_h @ sigma, sigma]])  # Cov([z(0); z(H)])
    a, b = bridge_weights(half, sigma, c, m) if weights is None else weights
    var = c @ sigma @ c
    out = []
    for j in range(1, 2 * m):
        g = jnp.concatenate([c @ powers[j] @ sigma, c @ (powers[2 * m - j] @ sigma).T])  # Cov(ζ(τ), [z0; z1])
        w = jnp.concatenate([a[j - 1], b[j - 1]])
        out.append((var - 2 * w @ g + w @ k @ w) / var)
    return jnp.stack(out)


SUBSTEP_CANDIDATES = (4, 2, 1)


@cached_program
def _bridge_errors(shaping_filter: ShapingFilter, dt: float):
    """The largest relative bridge interpolation error variance for each m of `SUBSTEP_CANDIDATES` (one program)."""
    half, _ = shaping_filter.discretise(dt / 2)
    sigma = shaping_filter.stationary_covariance()
    return jnp.stack(
        [jnp.max(interpolation_error_variance(half, sigma, shaping_filter.c, m)) for m in SUBSTEP_CANDIDATES]
    )


def choose_substeps(shaping_filter: ShapingFilter, dt: float, tol: float = COARSE_TOLERANCE) -> int:
    """The largest m of `SUBSTEP_CANDIDATES` whose bridge leaves out at most `tol`·σ_G² (host side; 1 when the
    filter is traced). m = 4 (H = 2 s at dt = 0.5 s) for the paper's protocol (3.7e-7)."""
    try:
        errors = np.asarray(_bridge_errors(shaping_filter, float(dt)))
    except jax.errors.TracerArrayConversionError:
        return 1
    for m, err in zip(SUBSTEP_CANDIDATES, errors, strict=True):
        if np.isfinite(err) and err <= tol:
            return m
    return 1


@cached_program
def _noise_rank_errors(shaping_filter: ShapingFilter, dt: float, m: int):
    """For r = 1 … n: the largest relative error of the variance of any linear function of the stationary state,
    max eig Σ^{-1/2}(Σ − Σ_r)Σ^{-1/2}, when the step's noise keeps only its r principal directions (Σ_r: the
    stationary covariance of z' = Φz + L_r ε, by the discrete Lyapunov equation in Kronecker form)."""
    sigma = shaping_filter.stationary_covariance()
    phi, chol, _, _ = filter_grid(shaping_filter, dt, m)
    n = sigma.shape[0]
    w, v = jnp.linalg.eigh(sigma)
    whiten = v / jnp.sqrt(jnp.clip(w, jnp.finfo(w.dtype).tiny, None))  # Σ^{-1/2} up to a rotation
    kron = jnp.eye(n * n) - jnp.kron(phi, phi)
    errors = []
    for r in range(1, n + 1):
        dropped = chol[:, : n - r]
        deficit = jnp.linalg.solve(kron, (dropped @ dropped.T).reshape(-1)).reshape(n, n)
        errors.append(jnp.max(jnp.abs(jnp.linalg.eigvalsh(whiten.T @ deficit @ whiten))))
    return jnp.stack(errors)


def choose_noise_rank(shaping_filter: ShapingFilter, dt: float, m: int, tol: float = COARSE_TOLERANCE) -> int:
    """The smallest even r (or n) whose dropped noise directions change the variance of every linear function of
    the stationary filter state (ζ_G at every stage time among them) by at most `tol` relative (host side; n when
    traced). The step's noise covariance Σ − ΦΣΦᵀ over H = m·dt is nearly singular: its eigenvalues fall by ×10–40
    each (order 8, H = 2 s: r = 4 of 8 within 1e-6), so the Monte Carlo draws r normals per step instead of n."""
    n = shaping_filter.c.size
    try:
        errors = np.asarray(_noise_rank_errors(shaping_filter, float(dt), m))
    except jax.errors.TracerArrayConversionError:
        return n
    for r in range(2, n + 1, 2):
        if np.isfinite(errors[r - 1]) and errors[r - 1] <= tol:
            return r
    return n


@cached_program
def filter_grid(shaping_filter: ShapingFilter, dt: float, m: int):
    """Φ = e^{A m dt} and L (L Lᵀ = Σ − ΦΣΦᵀ), a square root of Σ, and the bridge weights [2, 2m − 1, n]."""
    sigma = shaping_filter.stationary_covariance()
    half, _ = shaping_filter.discretise(dt / 2)
    phi = _half_powers(half, m)[2 * m]
    return (
        phi,
        psd_sqrt(sigma - phi @ sigma @ phi.T),
        psd_sqrt(sigma),
        jnp.stack(bridge_weights(half, sigma, shaping_filter.c, m)),
    )


# ----------------------------------------------------------------------------------------------------------------
# Sources on the time-step grid: a record, or Method 1
# ----------------------------------------------------------------------------------------------------------------


def _padded_length(num_steps: int, m: int) -> int:
    """Samples t_0 … t_K covering whole blocks: K = (number of blocks) · BLOCK · m."""
    return -(-num_steps // (BLOCK * m)) * BLOCK * m + 1


def _half_step_values(zeta, dzeta, index, m: int, dt):
    """ζ at the 2m half steps of each of the BLOCK source steps of block `index`, [BLOCK, 2m], from samples at the
    time steps (the midpoint by cubic Hermite interpolation with the exact derivative, error O(dt⁴))."""
    n = BLOCK * m
    x = jax.lax.dynamic_slice_in_dim(zeta, index * n, n + 1)
    dx = jax.lax.dynamic_slice_in_dim(dzeta, index * n, n + 1)
    mid = (x[:-1] + x[1:]) / 2 + dt * (dx[:-1] - dx[1:]) / 8
    return jnp.stack([mid, x[1:]], -1).reshape(BLOCK, 2 * m)


class SampledExcitation(AbstractExcitation):
    """A given record of ζ_G [m] and dζ_G/dt [m/s] on t_k = k·dt (e.g. a measured or precomputed wave).

    The record must cover the simulated time: at least `num_steps + 1` samples (padded with zeros to whole blocks).
    It serves any number of time steps per source step (`substeps` = 1).
    """

    zeta: Float[Array, " n"]
    dzeta: Float[Array, " n"]
    dt: float = eqx.field(static=True)
    substeps: int = eqx.field(static=True, default=1)

    def __init__(self, zeta, dzeta, dt: float):
        """**Arguments:** `zeta` [m], `dzeta` [m/s]: 1-D records of equal length; `dt`: their sampling step [s]."""
        zeta, dzeta = jnp.asarray(zeta, dtype=float), jnp.asarray(dzeta, dtype=float)
        if zeta.ndim != 1 or zeta.shape != dzeta.shape:
            raise ValueError(
                f"`zeta` and `dzeta` must be 1-D of equal length; got {zeta.shape} and {dzeta.shape}."
            )
        self.zeta, self.dzeta, self.dt = zeta, dzeta, float(dt)

    def init(self, key, num_steps, m, dtype):
        if self.zeta.size < num_steps + 1:
            raise ValueError(
                f"the excitation record has {self.zeta.size} samples; {num_steps + 1} are needed "
                f"({num_steps} steps of {self.dt} s)."
            )
        pad = max(_padded_length(num_steps, m) - self.zeta.size, 0)
        zeta, dzeta = (jnp.pad(x, (0, pad)).astype(dtype) for x in (self.zeta, self.dzeta))
        return (zeta, dzeta), zeta[0]

    def block_inputs(self, key, state, index, m):
        return _half_step_values(*state, index, m, jnp.asarray(self.dt, self.zeta.dtype))

    def advance(self, state, values, m):
        return state, tuple(values[j] for j in range(2 * m))


#: A realization keyed k draws its wave components (`encounter_components`) from fold_in(k, COMPONENTS_KEY).
COMPONENTS_KEY = 0x7FFFFFFE


def encounter_components(
    sea: AbstractWaveSpectrum, projected_speed, following: bool, key, size: int, dt: float
):
    """The wave components of one realization in encounter frequency, per encounter branch: what Grim's effective
    wave and the direct wave moment of that realization are both made of (`SuperpositionExcitation(joint=True)`,
    `WaveMomentExcitation`), so that their cross-correlation is the sea's.

    At ω_e,j = 2πj/(size·dt), each wave frequency ω_b that meets the ship at ω_e,j (one branch in head and beam
    seas, up to three in following seas: `jaxroll.sea.encounter_frequency`) has the complex Gaussian amplitude
    a_jb = √(S(ω_b)/|dω_e/dω| Δω_e) (x + iy)·size/2, x, y standard normals (`block_normals` of block
    COMPONENTS_KEY of the realization keyed `key`): a process with the transfer T(ω) is the irfft of
    Σ_b T(ω_b) a_jb (T conjugated on branch 3, where ω − kU cos χ < 0 and the component turns the other way).
    Zero at ω_e = 0 and at the Nyquist frequency.

    **Arguments:** `sea`: one-sided sea spectrum; `projected_speed`: U|cos χ| [m/s]; `following`: cos χ > 0;
    `size`: the FFT length (`superposition_length`); `dt` [s].

    **Returns:** `(omega_e [size//2 + 1] rad/s, omegas [size//2 + 1, branches] rad/s, amplitudes (same shape,
    complex) [m])`, branches 3 in following seas, else 1.
    """
    domega = 2 * np.pi / (size * dt)
    omega_e = jnp.arange(size // 2 + 1, dtype=float) * domega
    omegas, weights = encounter_branches(omega_e, projected_speed, following)
    branches = 3 if following else 1
    interior = (omega_e > 0) & (omega_e < omega_e[-1])
    xy = block_normals(key, COMPONENTS_KEY, (branches, 2, omega_e.size)).astype(omega_e.dtype)
    amplitudes = []
    for b in range(branches):
        valid = interior & (weights[:, b] > 0)
        var = jnp.where(valid, sea(omegas[:, b]) * weights[:, b] * domega, 1.0)
        amp = jnp.where(valid & (var > 0), jnp.sqrt(jnp.where(var > 0, var, 1.0)) * size / 2, 0.0)
        amplitudes.append(jax.lax.complex(amp * xy[b, 0], amp * xy[b, 1]))
    return omega_e, omegas[:, :branches], jnp.stack(amplitudes, -1)


def _synthesise(coefs, omega_e, size: int, num_samples: int, dtype):
    """The processes and their time derivatives on t = 0, dt, … (`num_samples` each, cast to `dtype`) from their
    one-sided FFT coefficients `coefs` [processes, size//2 + 1] at `omega_e` [rad/s]: one batched inverse FFT.
    **Returns:** `[(x, dx), …]` per process."""
    both = jnp.concatenate([coefs, jax.lax.complex(jnp.zeros_like(omega_e), omega_e) * coefs])
    out = jnp.fft.irfft(both, n=size, axis=-1)[:, :num_samples].astype(dtype)
    k = coefs.shape[0]
    return [(out[i], out[k + i]) for i in range(k)]


class SuperpositionExcitation(AbstractExcitation):
    """Method 1: component superposition synthesised by FFT over the whole trial (see `jaxroll.superpose`).
    The synthesis runs in float64 whatever the run's dtype (the integrator leaves `wave` as it is).

    `joint=True`: ζ_G is made of the realization's wave components per encounter branch
    (`encounter_components`), the same components a `WaveMomentExcitation` of the problem makes M_w of, each
    multiplied by Grim's transfer: the two are then one realization of the sea, correlated as the sea makes them
    (`RollProblem.from_sea` does this for a ship carrying a wave moment; the integrator synthesises both in one
    pass, `joint_init`). The same law as `joint=False`, other random numbers."""

    wave: EffectiveWave
    dt: float = eqx.field(static=True)
    substeps: int = eqx.field(static=True, default=1)
    joint: bool = eqx.field(static=True, default=False)
    yaw: YawNodes | None = None

    def __init__(self, wave: EffectiveWave, dt: float, *, joint: bool = False, yaw: Yaw | None = None):
        """**Arguments:** `wave`: Grim's effective wave; `dt`: time step [s]; `joint`: synthesise from the
        components shared with a `WaveMomentExcitation` (above); `yaw`: a [`Yaw`][jaxroll.Yaw] of the heading
        about `wave`'s (zero speed only; docs/yaw.md), None for none."""
        self.wave = wave
        self.dt = float(dt)
        self.joint = bool(joint)
        self.yaw = None if yaw is None else grim_yaw_nodes(wave, yaw)

    def init(self, key, num_steps, m, dtype):
        if self.yaw is not None:
            return yaw_init(self, None, key, num_steps, m, dtype)[0]
        if self.joint:
            return joint_init(self, None, key, num_steps, m, dtype)[0]
        n = _padded_length(num_steps, m)
        _check_length(n)
        zeta, dzeta = (x.astype(dtype) for x in superpose(self.wave, key, n, self.dt))  # in float64
        return (zeta, dzeta), zeta[0]

    def block_inputs(self, key, state, index, m):
        if self.yaw is not None:
            return yaw_block_values(state[0], index, m)
        return _half_step_values(*state, index, m, jnp.asarray(self.dt, state[0].dtype))

    def advance(self, state, values, m):
        return state, tuple(values[j] for j in range(2 * m))

    def coefficients(self, omegas, amps, direction: int | None = None, projection=None):
        """The FFT coefficients of ζ_G from the realization's components (`encounter_components`):
        Σ_b F_Grim(k_b |cos χ|) a_b, Grim's transfer being real; of a short-crested sea's `direction` q (an index
        into `wave.direction_cosines`) with cos χ_q; `projection`: another |cos χ| (yaw's nodes)."""
        if projection is None and direction is None:
            projection = jnp.abs(self.wave.cos_heading)
        elif projection is None:
            projection = abs(self.wave.direction_cosines[direction])
        g = grim_transfer(omegas**2 / GRAVITY * projection, self.wave.length)
        coef = jnp.zeros(amps.shape[:1], dtype=amps.dtype)
        for b in range(amps.shape[1]):
            coef = coef + amps[:, b] * jax.lax.complex(g[:, b], jnp.zeros_like(g[:, b]))
        return coef

    def node_coefficients(self, omegas, amps):
        """Under yaw: the coefficients at each node |cos χ_n| of `yaw` [nodes, size//2 + 1]."""
        return jnp.stack([self.coefficients(omegas, amps, projection=c) for c in self.yaw.nodes])


def _check_length(n: int) -> None:
    if superposition_length(n) > 2**24:
        raise ValueError(
            f"superposition of {n} samples is too long for one FFT; use the filter method for long trials, or "
            "shorten the trial or lengthen dt."
        )


def joint_init(zeta_source, moment_source, key, num_steps: int, m: int, dtype) -> list:
    """`init` of a joint `SuperpositionExcitation` and (or, when None) its problem's `WaveMomentExcitation` for the
    realization keyed `key`, from one draw of the wave components (`encounter_components`) and one batched inverse
    FFT: `[(state, value at t = 0)]` per source given, as each one's own `init` (the same realization)."""
    sources = [s for s in (zeta_source, moment_source) if s is not None]
    if sources[0].yaw is not None:
        return yaw_init(zeta_source, moment_source, key, num_steps, m, dtype)
    n = _padded_length(num_steps, m)
    _check_length(n)
    size = superposition_length(n)
    directions = spread_directions(zeta_source, moment_source)
    if directions is not None:
        return _joint_init_spread(sources, directions, key, size, n, dtype)
    if moment_source is not None:
        sea, speed, following = moment_source.sea, moment_source.speed, moment_source.following
    else:
        wave = zeta_source.wave
        sea, speed, following = wave.sea, wave.speed * jnp.abs(wave.cos_heading), wave.following
    omega_e, omegas, amps = encounter_components(sea, speed, following, key, size, sources[0].dt)
    coefs = jnp.stack([s.coefficients(omegas, amps) for s in sources])
    return [((x, dx), x[0]) for x, dx in _synthesise(coefs, omega_e, size, n, dtype)]


def spread_directions(zeta_source, moment_source):
    """`(sea, U [m/s], cos χ_q, w_q)` of a short-crested sea's directions (`jaxroll.sea.Spreading`) behind a joint
    pair of sources, or None for a long-crested sea. **Raises:** `ValueError` when the two disagree."""
    if zeta_source is not None and moment_source is not None:
        if zeta_source.wave.direction_cosines != moment_source.direction_cosines:
            raise ValueError(
                "the effective wave and the wave moment of one problem must have the same spreading (both "
                "long-crested, or built with the same `spreading`): `RollProblem.from_sea(..., spreading=)` does this."
            )
    if moment_source is not None:
        if moment_source.direction_cosines is None:
            return None
        return (
            moment_source.sea,
            moment_source.speed,
            moment_source.direction_cosines,
            moment_source.direction_weights,
        )
    wave = zeta_source.wave
    if wave.spreading is None:
        return None
    return wave.sea, wave.speed, wave.direction_cosines, wave.direction_weights


def _joint_init_spread(sources, directions, key, size: int, n: int, dtype) -> list:
    """`joint_init` in a short-crested sea: each direction q has its own wave components (`encounter_components`
    at the projected speed U|cos χ_q|, variance × w_q, normals of the realization keyed fold_in(key, q)), and each
    source sums its coefficients of every direction before one batched inverse FFT."""
    sea, speed, cosines, weights = directions
    coefs = None
    for q, (c, w) in enumerate(zip(cosines, weights, strict=True)):
        omega_e, omegas, amps = encounter_components(
            sea, speed * abs(c), c > 0, jr.fold_in(key, q), size, sources[0].dt
        )
        amps = amps * math.sqrt(w)
        part = jnp.stack([src.coefficients(omegas, amps, q) for src in sources])
        coefs = part if coefs is None else coefs + part
    return [((x, dx), x[0]) for x, dx in _synthesise(coefs, omega_e, size, n, dtype)]


class WaveMomentExcitation(AbstractExcitation):
    """The direct wave roll moment per unit roll inertia M_w(t) [rad/s²] of a long-crested sea (or, with
    `spreading`, a short-crested one: summed over its directions), synthesised by FFT over the whole trial like
    `SuperpositionExcitation`.

    Components sit at encounter frequencies ω_e,j = 2πj/(M dt); each wave frequency ω that meets the ship at ω_e,j
    (one in head and beam seas, up to three in following seas: `jaxroll.sea.encounter_frequency`) adds its
    complex Gaussian amplitude of variance S(ω)Δω_e/|dω_e/dω| (`jaxroll.sea.encounter_components`) times the
    transfer F(ω, χ)/I44 of the `WaveMoment` (conjugated where ω − kU cos χ < 0). M_w(t) is exactly Gaussian with
    the spectrum Σ |F/I44|² S/|dω_e/dω| (`spectrum`). Synthesised in float64 whatever the run's dtype.

    The realization keyed k draws the same components as a `SuperpositionExcitation(wave, dt, joint=True)` keyed
    k: in a `RollProblem` the two make ζ_G and M_w of one realization of the sea (the integrator gives both the
    realization's key).
    """

    sea: AbstractWaveSpectrum
    omega: Float[Array, " n"]
    transfer: Complex[Array, " n"] | Complex[Array, "q n"]  # one row per direction in a short-crested sea
    speed: Float[Array, ""]  # U|cos χ| (the encounter shift) in a long-crested sea; U in a short-crested one
    following: bool = eqx.field(static=True)
    dt: float = eqx.field(static=True)
    substeps: int = eqx.field(static=True, default=1)
    # short-crested (`spreading`): cos χ_q and weights w_q of the directions (`EffectiveWave`); None long-crested
    direction_cosines: tuple[float, ...] | None = eqx.field(static=True, default=None)
    direction_weights: tuple[float, ...] | None = eqx.field(static=True, default=None)
    yaw: YawNodes | None = None

    def __init__(
        self,
        sea: AbstractWaveSpectrum,
        moment: WaveMoment,
        dt: float,
        *,
        speed: float = 0.0,
        heading: str | float = "head",
        spreading: Spreading | None = None,
        yaw: Yaw | None = None,
    ):
        """**Arguments:** `sea`: one-sided sea spectrum; `moment`: the hull's [`WaveMoment`][jaxroll.ship.WaveMoment]
        table (per unit inertia); `dt`: time step [s]; `speed`: U [m/s] ≥ 0; `heading`: `"head"`, `"following"` or
        χ [rad] in [0, π] (0 following, π/2 beam, π head; χ ∈ (0, π): waves from port; the mean direction of a
        short-crested sea); `spreading`: a `jaxroll.sea.Spreading` (short-crested: each direction χ_q = χ + θ_q
        with its own moment F(ω, χ_q), F(−χ) = −F(χ) for waves from starboard, as for a hull symmetric port and
        starboard), or None (long-crested); `yaw`: a [`Yaw`][jaxroll.Yaw] of the heading about χ (zero speed, long-crested only;
        docs/yaw.md), None for none.

        **Raises:** `ValueError` for a heading outside [0, π], a negative speed, or a heading outside the table's."""
        chi, cos_chi = heading_angle(heading), heading_cosine(heading)
        if not (math.isfinite(float(speed)) and float(speed) >= 0):
            raise ValueError(f"`speed` must be a finite number >= 0 [m/s]; got {speed!r}.")
        lo, hi = float(moment.headings[0]), float(moment.headings[-1])
        spread = spreading is not None
        if spread and yaw is not None:
            raise ValueError("yaw in a short-crested sea is not modelled: drop the yaw or the spreading.")
        if spread and not (lo <= 1e-12 and hi >= math.pi - 1e-12):
            raise ValueError(
                f"a short-crested sea needs the wave moment at every heading, 0–180°; the table has "
                f"{math.degrees(lo):.4g}–{math.degrees(hi):.4g}° (`jaxroll.ship.wave_moment(..., headings=...)`)."
            )
        if not lo - 1e-12 <= chi <= hi + 1e-12:
            raise ValueError(
                f"heading χ = {math.degrees(chi):.4g}° is outside the wave-moment table's headings "
                f"({math.degrees(lo):.4g}–{math.degrees(hi):.4g}°): tabulate the moment at this heading "
                "(`jaxroll.ship.wave_moment(..., headings=...)`)."
            )
        self.sea = sea
        self.omega = moment.omega
        self.following = cos_chi > 0
        self.dt = float(dt)
        if not spread:
            self.transfer = moment.at_heading(chi)
            # U|cos χ|: the encounter shift
            self.speed = jnp.asarray(float(speed) * abs(cos_chi), dtype=float)
            self.direction_cosines = self.direction_weights = None
            self.yaw = None if yaw is None else moment_yaw_nodes(moment, chi, yaw)
            return
        theta, weights = spreading.directions()
        self.direction_cosines, self.direction_weights = direction_cosines(chi, spreading)
        rows = []
        for chi_q in chi + theta:
            # χ_q in (−π, 2π): waves from starboard (χ_q < 0 or > π) have F(χ_q) = −F(|χ_q| folded into [0, π])
            folded = math.remainder(chi_q, 2 * math.pi)  # in [−π, π]
            row = moment.at_heading(min(abs(folded), math.pi))
            rows.append(-row if folded < 0 else row)
        self.transfer = jnp.stack(rows)
        self.speed = jnp.asarray(float(speed), dtype=float)
        self.yaw = None

    def transfer_at(self, omega, direction: int | None = None, transfer=None) -> Complex[Array, "..."]:
        """F/I44 [rad/s² per m] at wave frequencies ω [rad/s] (linear between the table's, 0 above it); of a
        short-crested sea's `direction` q; `transfer`: another row of the table than the heading's (yaw's nodes)."""
        if transfer is not None:
            row = transfer
        else:
            row = self.transfer if direction is None else self.transfer[direction]
        re = jnp.interp(omega, self.omega, row.real, right=0.0)
        im = jnp.interp(omega, self.omega, row.imag, right=0.0)
        return jax.lax.complex(re, im)

    def spectrum(self, omega_e) -> Float[Array, "..."]:
        """One-sided spectrum of M_w, S_M(ω_e) = Σ_b |F(ω_b, χ)/I44|² S(ω_b)/|dω_e/dω| [rad²/s⁴ · s/rad], at
        encounter frequencies ω_e [rad/s]; short-crested: Σ_q w_q of the same at χ_q, U|cos χ_q|."""
        omega_e = jnp.asarray(omega_e, dtype=float)
        if self.direction_cosines is None:
            omegas, weights = encounter_branches(omega_e, self.speed, self.following)
            f = self.transfer_at(omegas)
            return jnp.sum(jnp.abs(f) ** 2 * self.sea(omegas) * weights, axis=-1)
        total = jnp.zeros(omega_e.shape)
        for q, (c, w) in enumerate(zip(self.direction_cosines, self.direction_weights, strict=True)):
            omegas, weights = encounter_branches(omega_e, self.speed * abs(c), c > 0)
            f = self.transfer_at(omegas, q)
            total = total + w * jnp.sum(jnp.abs(f) ** 2 * self.sea(omegas) * weights, axis=-1)
        return total

    def coefficients(self, omegas, amps, direction: int | None = None, transfer=None):
        """The FFT coefficients of M_w from the realization's components (`encounter_components`):
        Σ_b F(ω_b, χ)/I44 a_b, F conjugated on branch 3; of a short-crested sea's `direction` q with F(ω, χ_q); `transfer`: another row
        of the table (yaw's nodes)."""
        coef = jnp.zeros(amps.shape[:1], dtype=amps.dtype)
        for b in range(amps.shape[1]):
            f = self.transfer_at(omegas[:, b], direction, transfer)
            if b == 2:  # ω − kU cos χ = −ω_e: the component turns the other way
                f = jnp.conj(f)
            coef = coef + f * amps[:, b]
        return coef

    def node_coefficients(self, omegas, amps):
        """Under yaw: the coefficients at each node heading χ_n of `yaw` [nodes, size//2 + 1]."""
        return jnp.stack([self.coefficients(omegas, amps, transfer=row) for row in self.yaw.transfers])

    def init(self, key, num_steps, m, dtype):
        return joint_init(None, self, key, num_steps, m, dtype)[0]

    def block_inputs(self, key, state, index, m):
        if self.yaw is not None:
            return yaw_block_values(state[0], index, m)
        return _half_step_values(*state, index, m, jnp.asarray(self.dt, state[0].dtype))

    def advance(self, state, values, m):
        return state, tuple(values[j] for j in range(2 * m))
