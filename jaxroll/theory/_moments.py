"""Moment method: moment equations of the roll + Method-2 filter, cumulant-neglect closure, amplitude PDF.

The state X = (φ, φ̇, z_1 … z_n) obeys the Itô system (noise only in the filter: no Wong–Zakai terms)

    dφ = φ̇ dt,
    dφ̇ = [−b1 φ̇ − b2 φ̇|φ̇| − b3 φ̇³ − Σ a_{2k−1} φ^{2k−1} − r κ ΔGM(−cᵀz) φ] dt,   κ = ω0²/GM0,
    dz = A z dt + b dW.

Everything below works for any *polynomial* Itô system `PolynomialSDE` (drift and noise matrix polynomial in
X). For a monomial f = X^β the generator L = f·∇ + ½ B Bᵀ : ∇² maps f to a polynomial; the moment equations

    dE[X^β]/dt = Σ_terms (coefficient) · E[X^β′]

are generated *by code* at build time (exponent tuples → coefficients, pure Python), producing index tables
that are evaluated in JAX. Moments of order > N (the closure order) are rebuilt from the joint cumulants of
order ≤ N (cumulant neglect: all cumulants of order > N set to zero), through the multivariate
moment–cumulant recursion

    E[X^β] = Σ_{γ ≤ β, γ_l ≥ 1} Π_i C(β_i − δ_il, γ_i − δ_il) κ_γ E[X^{β−γ}]       (any pivot l with β_l ≥ 1),

which is the partition formula E[x1…xr] = Σ_partitions Π κ_B summed over the partitions that share the block
containing the pivot (derived from ∂_l M = M ∂_l K for the moment and cumulant generating functions); it costs
Π(β_i + 1) terms instead of a Bell number. The same recursion, read backwards, turns the unknown moments into
cumulants.

Symmetry: (φ, φ̇) → −(φ, φ̇) with z fixed maps the roll system onto itself (every drift term of φ̇ is odd in
(φ, φ̇): P φ is odd in φ, ΔGM(−cᵀz) does not involve φ), so moments odd in (φ, φ̇) vanish and are never
unknowns. The filter block is linear with additive noise: its moments are exactly Gaussian with the Lyapunov
covariance, so pure-z moments are known, not unknowns (checked: the generated filter-only equations reproduce
the Lyapunov covariance, tests/test_moments.py).

φ̇|φ̇| is not polynomial. It is replaced by the Gaussian least-squares equivalent cubic
φ̇|φ̇| ≈ √(2/π) (σ_v φ̇ + φ̇³/(3σ_v)), σ_v² = E[φ̇²] (the moment state itself), the choice of THEORY §6 that
keeps a stable non-trivial fixed point; the equivalent-linear form √(8/π) σ_v φ̇ is available
(`damping="linear"`) but under-damps this strongly non-Gaussian φ̇ and the moment equations blow up
(docs/theory.md, "Moment method").
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
from collections.abc import Sequence

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ..laws._abstract import AbstractAmplitudeLaw, check_estimator
from ..laws._tabulated import TabulatedAmplitudeLaw
from ..sea._filters import FilterFit, ShapingFilter, fit_filter, lyapunov
from ..sea._grim import EffectiveWave
from ..ship._ship import Ship

Monomial = tuple[int, ...]

# ============================================================================================================
# Polynomial Itô systems
# ============================================================================================================


class PolynomialSDE(eqx.Module):
    r"""A polynomial Itô system $dX = f(X)\,dt + B(X)\,dW$ in `dim` variables, for the moment method.

    The drift is $f_l(X) = \sum_t \theta_t\, E[x_s^2]^{p_t}\, X^{\gamma_t}$ over the drift terms $t$ with
    component $l_t$; the factor $E[x_s^2]^{p_t}$ (statistical linearisation of a non-polynomial term, e.g.
    the equivalent cubic of $\dot\phi|\dot\phi|$) is 1 when $p_t = 0$. The noise matrix is $B_{lk}(X) =
    \sum_t \eta_t X^{\gamma_t}$ over the noise terms $t$ with component $l_t$ and (unit-intensity,
    independent) Wiener process $k_t$.

    The structure (exponents, components, powers) is static Python data, the coefficients are arrays:
    everything downstream is differentiable with respect to `drift_coefficients` and `noise_coefficients`.
    """

    drift_coefficients: Float[Array, " drift_terms"]
    noise_coefficients: Float[Array, " noise_terms"]
    names: tuple[str, ...] = eqx.field(static=True)
    drift_terms: tuple[tuple[int, Monomial, float], ...] = eqx.field(static=True)
    noise_terms: tuple[tuple[int, int, Monomial], ...] = eqx.field(static=True)
    symmetric: tuple[int, ...] = eqx.field(static=True)
    gaussian: tuple[int, ...] = eqx.field(static=True)
    scale_variable: int = eqx.field(static=True)

    def __init__(
        self,
        names: Sequence[str],
        drift_terms: Sequence[tuple[int, Sequence[int], float]],
        drift_coefficients: ArrayLike,
        noise_terms: Sequence[tuple[int, int, Sequence[int]]],
        noise_coefficients: ArrayLike,
        *,
        symmetric: Sequence[int] = (),
        gaussian: Sequence[int] = (),
        scale_variable: int = 0,
    ):
        """**Arguments:**

        - `names`: variable names (their number is the dimension).
        - `drift_terms`: `(component l, exponents γ, power p)` per drift term; `drift_coefficients` their θ.
        - `noise_terms`: `(component l, Wiener index k, exponents γ)` per noise term;
          `noise_coefficients` their η.
        - `symmetric`: variables that change sign under a symmetry of the system (moments odd in them vanish).
        - `gaussian`: an autonomous linear block with additive noise (e.g. a shaping filter): its moments are
          computed exactly (Gaussian, Lyapunov covariance) instead of being unknowns.
        - `scale_variable`: the variable s of the factors E[x_s²]^p.

        Raises `ValueError` if the structure is inconsistent (wrong lengths, a drift or noise term that
        breaks the declared symmetry, a `gaussian` block that is not linear and autonomous).
        """
        dim = len(names)
        self.names = tuple(str(n) for n in names)
        self.drift_terms = tuple((int(l), tuple(int(e) for e in g), float(p)) for l, g, p in drift_terms)
        self.noise_terms = tuple((int(l), int(k), tuple(int(e) for e in g)) for l, k, g in noise_terms)
        self.symmetric = tuple(sorted(int(i) for i in symmetric))
        self.gaussian = tuple(sorted(int(i) for i in gaussian))
        self.scale_variable = int(scale_variable)
        dc = jnp.asarray(drift_coefficients, dtype=float)
        nc = jnp.asarray(noise_coefficients, dtype=float)
        if dc.shape != (len(self.drift_terms),):
            raise ValueError(
                f"`drift_coefficients` must have shape ({len(self.drift_terms)},); got {dc.shape}."
            )
        if nc.shape != (len(self.noise_terms),):
            raise ValueError(
                f"`noise_coefficients` must have shape ({len(self.noise_terms)},); got {nc.shape}."
            )
        self.drift_coefficients = dc
        self.noise_coefficients = nc
        for l, g, _ in self.drift_terms:
            if not (0 <= l < dim and len(g) == dim and min(g) >= 0):
                raise ValueError(f"drift term ({l}, {g}) does not fit a system of dimension {dim}.")
        for l, _, g in self.noise_terms:
            if not (0 <= l < dim and len(g) == dim and min(g) >= 0):
                raise ValueError(f"noise term ({l}, {g}) does not fit a system of dimension {dim}.")
        if not 0 <= self.scale_variable < dim:
            raise ValueError(f"`scale_variable` must be in [0, {dim}); got {scale_variable}.")
        sym = set(self.symmetric)

        def odd(g):
            return sum(g[i] for i in sym) % 2

        for l, g, _ in self.drift_terms:
            if odd(g) != (l in sym):
                raise ValueError(
                    f"drift term of {self.names[l]} with exponents {g} breaks the declared symmetry "
                    f"{[self.names[i] for i in self.symmetric]}: drop it from `symmetric` or fix the term."
                )
        noise_parity: dict[int, int] = {}
        for l, k, g in self.noise_terms:
            parity = (odd(g) + (l in sym)) % 2
            if noise_parity.setdefault(k, parity) != parity:
                raise ValueError(f"noise terms of Wiener process {k} break the declared symmetry.")
        gs = set(self.gaussian)
        for l, g, p in self.drift_terms:
            if l in gs and (p != 0 or sum(g) != 1 or any(g[i] for i in range(dim) if i not in gs)):
                raise ValueError(
                    f"`gaussian` block {self.gaussian} is not linear and autonomous: the drift of "
                    f"{self.names[l]} has a term with exponents {g}."
                )
        for l, _, g in self.noise_terms:
            if l in gs and sum(g) != 0:
                raise ValueError(
                    f"`gaussian` block must have additive noise; {self.names[l]} has exponents {g}."
                )
        if gs & sym:
            raise ValueError("a variable cannot be both `gaussian` and `symmetric`.")

    @property
    def dim(self) -> int:
        return len(self.names)

    def _structure(self):
        return (
            self.dim,
            self.drift_terms,
            self.noise_terms,
            self.symmetric,
            self.gaussian,
            self.scale_variable,
        )


def _is_zero(x) -> bool:
    """True only for a concrete value equal to 0 (a traced value is never known to be zero)."""
    try:
        return bool(np.asarray(x) == 0)
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError, TypeError):
        return False


def _compositions(k: int, n: int):
    """All exponent tuples of length n with sum k."""
    if n == 1:
        yield (k,)
        return
    for first in range(k, -1, -1):
        for rest in _compositions(k - first, n - 1):
            yield (first, *rest)


def roll_sde(ship: Ship, shaping_filter: ShapingFilter, *, damping: str = "cubic") -> PolynomialSDE:
    r"""The roll + Method-2 filter Itô system X = (φ, φ̇, z_1 … z_n) of THEORY §1/§6 as a `PolynomialSDE`.

    $d\dot\phi = [-b_1\dot\phi - b_2\,\dot\phi|\dot\phi| - b_3\dot\phi^3 - \sum a_{2k-1}\phi^{2k-1}
    - r\kappa\,\Delta GM(-c^Tz)\,\phi]\,dt$, κ = ω0²/GM0, ζ_mid = −ζ_G = −cᵀz; dz = A z dt + b dW.

    **Arguments:**

    - `ship`: roll-model parameters (SI, radians).
    - `shaping_filter`: Method-2 filter of Grim's effective wave ζ_G [m] (`fit_filter(...).filter`).
    - `damping`: treatment of φ̇|φ̇|: `"cubic"` (default; Gaussian least-squares equivalent cubic
      √(2/π)(σ_v φ̇ + φ̇³/(3σ_v)), σ_v² = E[φ̇²]) or `"linear"` (equivalent linear √(8/π) σ_v φ̇).

    Terms whose coefficient is a concrete zero (a7 = a9 = 0, C4 = C5 = C6 = 0 on the default ship) are
    dropped; traced coefficients (under `jax.grad`) are always kept, so derivatives are complete.
    """
    if damping not in ("cubic", "linear"):
        raise ValueError(f"`damping` must be 'cubic' or 'linear'; got {damping!r}.")
    n = shaping_filter.order
    dim = n + 2

    def e(i, k=1):
        return tuple(k if j == i else 0 for j in range(dim))

    terms: list[tuple[int, Monomial, float]] = []
    values: list = []

    def add(component, mono, value, power=0.0):
        terms.append((component, mono, power))
        values.append(jnp.asarray(value, dtype=float))

    add(0, e(1), 1.0)
    b1, b2, b3 = ship.damping[0], ship.damping[1], ship.damping[2]
    if not _is_zero(b1):
        add(1, e(1), -b1)
    if not _is_zero(b2):
        if damping == "cubic":
            add(1, e(1), -b2 * math.sqrt(2 / math.pi), 0.5)
            add(1, e(1, 3), -b2 * math.sqrt(2 / math.pi) / 3, -0.5)
        else:
            add(1, e(1), -b2 * math.sqrt(8 / math.pi), 0.5)
    if not _is_zero(b3):
        add(1, e(1, 3), -b3)
    a = ship.restoring_coefficients
    for i, power in enumerate((1, 3, 5, 7, 9)):
        if not _is_zero(a[i]):
            add(1, e(0, power), -a[i])
    kappa = ship.gm_correction * ship.omega0**2 / ship.gm0
    c = shaping_filter.c
    c_zero = [_is_zero(c[i]) for i in range(n)]
    for k in range(ship.delta_gm.shape[0]):
        ck = ship.delta_gm[k]
        if _is_zero(ck):
            continue
        for alpha in _compositions(k, n):
            if any(alpha[i] and c_zero[i] for i in range(n)):
                continue
            multinomial = math.factorial(k) // math.prod(math.factorial(x) for x in alpha)
            cz = math.prod([c[i] ** alpha[i] for i in range(n) if alpha[i]], start=jnp.ones(()))
            add(1, (1, 0, *alpha), -kappa * ck * (-1) ** k * multinomial * cz)
    for i in range(n):
        for j in range(n):
            if not _is_zero(shaping_filter.a[i, j]):
                add(2 + i, e(2 + j), shaping_filter.a[i, j])
    noise_terms, noise_values = [], []
    for i in range(n):
        if not _is_zero(shaping_filter.b[i]):
            noise_terms.append((2 + i, 0, (0,) * dim))
            noise_values.append(shaping_filter.b[i])
    names = ("phi", "dphi", *(f"z{i + 1}" for i in range(n)))
    return PolynomialSDE(
        names,
        terms,
        jnp.stack(values),
        noise_terms,
        jnp.stack([jnp.asarray(v, dtype=float) for v in noise_values]),
        symmetric=(0, 1),
        gaussian=tuple(range(2, dim)),
        scale_variable=1,
    )


# ============================================================================================================
# Moment equations: built by code (Python, once per structure), evaluated in JAX
# ============================================================================================================


@dataclasses.dataclass(frozen=True, eq=False)
class _Levels:
    """The moment–cumulant recursion, one row per total order, padded to a common width (scanned in JAX).

    Padding points at the dummy slot T (one past the table) for targets, and at the constant monomial with a
    zero coefficient for terms, so that one `lax.scan` body serves every order: small programs, fast
    compilation.
    """

    idx: np.ndarray  # (L, width): table indices of this order's monomials (T = padding)
    tgt: np.ndarray  # (L, terms): local target (width = padding), cumulant index, moment index, coefficient
    kap: np.ndarray
    mom: np.ndarray
    coef: np.ndarray


@dataclasses.dataclass(frozen=True, eq=False)
class _Tables:
    """Index tables of the moment equations of one SDE structure and closure order (hashed by identity)."""

    dim: int
    order: int
    symmetric: tuple[int, ...]
    gaussian: tuple[int, ...]
    monomials: tuple[Monomial, ...]  # the table, sorted by total order; index 0 is the constant 1
    index: dict
    unknowns: np.ndarray  # table indices of the unknown moments
    kind: np.ndarray  # 0 constant, 1 unknown, 2 Gaussian block, 3 closure (order > N)
    levels: tuple[_Levels, ...]  # consecutive groups of orders, each padded to its own width
    gauss_cov_idx: np.ndarray  # table index of z_a z_b for the Gaussian block (a ≤ b), and (a, b)
    gauss_pairs: np.ndarray
    rhs_tgt: np.ndarray  # generator terms: unknown index, coefficient id, multiplier, source table index
    rhs_cid: np.ndarray
    rhs_mult: np.ndarray
    rhs_src: np.ndarray
    drift_powers: np.ndarray
    noise_pairs: np.ndarray  # (n_pairs, 2) noise-term indices with the same Wiener process
    scale_index: int  # table index of x_s²


def _recursion_terms(beta: Monomial, order: int, even, gauss_only):
    """Terms (γ, β−γ, coefficient) of E[X^β] = Σ C κ_γ E[X^{β−γ}] with γ ≠ β, κ_γ not known to vanish."""
    pos = [i for i, b in enumerate(beta) if b > 0]
    pivot = min(pos, key=lambda i: (beta[i], i))
    ranges = [range(1, beta[i] + 1) if i == pivot else range(0, beta[i] + 1) for i in range(len(beta))]
    out = []
    total = sum(beta)
    for gamma in itertools.product(*ranges):
        g = sum(gamma)
        if g > order or g == total or not even(gamma):
            continue
        if gauss_only(gamma) and g != 2:
            continue
        coef = 1
        for i in range(len(beta)):
            d = 1 if i == pivot else 0
            coef *= math.comb(beta[i] - d, gamma[i] - d)
        out.append((gamma, tuple(b - c for b, c in zip(beta, gamma)), coef))
    return out


@functools.lru_cache(maxsize=64)
def _build_tables(structure, order: int, extra: tuple[Monomial, ...]) -> _Tables:
    dim, drift_terms, noise_terms, symmetric, gaussian, scale_variable = structure
    sym, gs = set(symmetric), set(gaussian)

    def even(b):
        return sum(b[i] for i in sym) % 2 == 0

    def gauss_only(b):
        return sum(b) > 0 and all(b[i] == 0 for i in range(dim) if i not in gs)

    base = [b for k in range(order + 1) for b in sorted(_compositions(k, dim), reverse=True) if even(b)]
    unknown_list = [b for b in base if sum(b) > 0 and not gauss_only(b)]
    uidx = {b: i for i, b in enumerate(unknown_list)}
    pairs = [
        (t1, t2)
        for t1, (_, k1, _) in enumerate(noise_terms)
        for t2, (_, k2, _) in enumerate(noise_terms)
        if k1 == k2
    ]
    n_drift = len(drift_terms)
    rhs: dict[tuple[int, int, Monomial], float] = {}

    def sub(b, *es):
        b = list(b)
        for i in es:
            b[i] -= 1
            if b[i] < 0:
                return None
        return tuple(b)

    for beta in unknown_list:
        u = uidx[beta]
        for t, (l, g, _) in enumerate(drift_terms):
            if beta[l] == 0:
                continue
            src = tuple(x + y for x, y in zip(sub(beta, l), g))
            if even(src):
                key = (u, t, src)
                rhs[key] = rhs.get(key, 0.0) + beta[l]
        for p, (t1, t2) in enumerate(pairs):
            l, m = noise_terms[t1][0], noise_terms[t2][0]
            fac = beta[l] * (beta[m] - (l == m))
            if fac <= 0:
                continue
            s = sub(beta, l, m)
            src = tuple(x + y + z for x, y, z in zip(s, noise_terms[t1][2], noise_terms[t2][2]))
            if even(src):
                key = (u, n_drift + p, src)
                rhs[key] = rhs.get(key, 0.0) + 0.5 * fac
    base_set = set(base)
    needed = {src for (_, _, src) in rhs} | {b for b in extra if even(b)}
    if scale_variable is not None:
        needed.add(tuple(2 if i == scale_variable else 0 for i in range(dim)))
    closure = set()
    stack = [b for b in needed if b not in base_set]
    rec_cache = {}
    while stack:
        b = stack.pop()
        if b in closure:
            continue
        closure.add(b)
        terms = _recursion_terms(b, order, even, gauss_only)
        rec_cache[b] = terms
        for _, rest, _ in terms:
            if rest not in base_set and rest not in closure:
                stack.append(rest)
    monomials = tuple(sorted(base_set | closure, key=lambda b: (sum(b), tuple(-x for x in b))))
    index = {b: i for i, b in enumerate(monomials)}
    kind = np.array(
        [0 if sum(b) == 0 else 1 if b in uidx else 2 if gauss_only(b) else 3 for b in monomials],
        dtype=np.int32,
    )
    rows = []
    max_order = sum(monomials[-1])
    for k in range(1, max_order + 1):
        idx = [i for i, b in enumerate(monomials) if sum(b) == k]
        if not idx:
            continue
        tgt, kap, mom, coef = [], [], [], []
        for local, i in enumerate(idx):
            b = monomials[i]
            terms = rec_cache.get(b) or _recursion_terms(b, order, even, gauss_only)
            for gamma, rest, c in terms:
                tgt.append(local)
                kap.append(index[gamma])
                mom.append(index[rest])
                coef.append(c)
        rows.append((idx, tgt, kap, mom, coef))
    n_table = len(monomials)

    def pad(x, n, fill, dtype):
        return np.array(list(x) + [fill] * (n - len(x)), dtype)

    def group(rs):
        width = max(len(r[0]) for r in rs)
        n_terms = max(max(len(r[1]) for r in rs), 1)
        return _Levels(
            idx=np.stack([pad(r[0], width, n_table, np.int32) for r in rs]),
            tgt=np.stack([pad(r[1], n_terms, width, np.int32) for r in rs]),
            kap=np.stack([pad(r[2], n_terms, 0, np.int32) for r in rs]),
            mom=np.stack([pad(r[3], n_terms, 0, np.int32) for r in rs]),
            coef=np.stack([pad(r[4], n_terms, 0.0, float) for r in rs]),
        )

    # split the orders into ≤ 3 consecutive groups (one scan each) minimising the padded work
    sizes = [max(len(r[1]), 1) + len(r[0]) for r in rows]
    best, splits = None, None
    n_rows = len(rows)
    for a in range(1, n_rows + 1):
        for b in range(a, n_rows + 1):
            parts = [(0, a), (a, b), (b, n_rows)]
            used = [(i, j) for i, j in parts if j > i]
            cost = sum((j - i) * max(sizes[i:j]) for i, j in used) + 2000 * len(used)
            if best is None or cost < best:
                best, splits = cost, used
    levels = tuple(group(rows[i:j]) for i, j in splits)
    gl = list(gaussian)
    gpairs = [(a, b) for a in range(len(gl)) for b in range(a, len(gl))]
    gidx = []
    for a, b in gpairs:
        mono = [0] * dim
        mono[gl[a]] += 1
        mono[gl[b]] += 1
        gidx.append(index[tuple(mono)])
    keys = sorted(rhs)
    scale_mono = tuple(2 if i == scale_variable else 0 for i in range(dim))
    return _Tables(
        dim=dim,
        order=order,
        symmetric=tuple(symmetric),
        gaussian=tuple(gaussian),
        monomials=monomials,
        index=index,
        unknowns=np.array([index[b] for b in unknown_list], np.int32),
        kind=kind,
        levels=levels,
        gauss_cov_idx=np.array(gidx, np.int32),
        gauss_pairs=np.array(gpairs, np.int32).reshape(-1, 2),
        rhs_tgt=np.array([k[0] for k in keys], np.int32),
        rhs_cid=np.array([k[1] for k in keys], np.int32),
        rhs_mult=np.array([rhs[k] for k in keys], float),
        rhs_src=np.array([index[k[2]] for k in keys], np.int32),
        drift_powers=np.array([p for _, _, p in drift_terms], float),
        noise_pairs=np.array(pairs, np.int32).reshape(-1, 2),
        scale_index=index[scale_mono],
    )


def _gaussian_covariance(sde: PolynomialSDE) -> Float[Array, "g g"]:
    """Stationary covariance of the `gaussian` block (Lyapunov equation of its drift and additive noise)."""
    gl = list(sde.gaussian)
    pos = {v: i for i, v in enumerate(gl)}
    ng = len(gl)
    a = jnp.zeros((ng, ng))
    for t, (l, g, _) in enumerate(sde.drift_terms):
        if l in pos:
            a = a.at[pos[l], pos[g.index(1)]].add(sde.drift_coefficients[t])
    n_noise = 1 + max((k for _, k, _ in sde.noise_terms), default=0)
    b = jnp.zeros((ng, n_noise))
    for t, (l, k, _) in enumerate(sde.noise_terms):
        if l in pos:
            b = b.at[pos[l], k].add(sde.noise_coefficients[t])
    return lyapunov(a, b @ b.T)


def _complete(tables: _Tables, m_given, k_given, moment_given):
    """All table moments and cumulants from given moments (where `moment_given`), given cumulants elsewhere.

    Level by level in total order (a `lax.scan`): S = Σ_{γ≠β} C κ_γ m_{β−γ}; then κ_β = m_β − S (moment given)
    or m_β = κ_β + S (cumulant given).
    """
    given = jnp.concatenate([jnp.asarray(moment_given, dtype=bool), jnp.zeros(1, bool)])
    m = jnp.concatenate([m_given, jnp.zeros(1)])
    k = jnp.concatenate([k_given, jnp.zeros(1)])
    for lv in tables.levels:
        width = lv.idx.shape[1]

        def body(carry, row, width=width):
            m, k = carry
            idx, tgt, kap, mom, coef = row
            s = jax.ops.segment_sum(coef * k[kap] * m[mom], tgt, num_segments=width + 1)[:width]
            g = given[idx]
            mk = jnp.where(g, m[idx], k[idx] + s)
            kk = jnp.where(g, m[idx] - s, k[idx])
            return (m.at[idx].set(mk), k.at[idx].set(kk)), None

        rows = (lv.idx, lv.tgt, lv.kap, lv.mom, lv.coef)
        (m, k), _ = jax.lax.scan(body, (m, k), rows)
    return m[:-1], k[:-1]


def _base_cumulants(tables: _Tables, sde: PolynomialSDE):
    """Known cumulants: the Gaussian block's covariance at its second-order monomials, zero elsewhere."""
    k = jnp.zeros(len(tables.monomials))
    if tables.gauss_cov_idx.size:
        cov = _gaussian_covariance(sde)
        k = k.at[tables.gauss_cov_idx].set(cov[tables.gauss_pairs[:, 0], tables.gauss_pairs[:, 1]])
    return k


def _full_moments(tables: _Tables, sde: PolynomialSDE, unknown_values, base_kappa=None):
    if base_kappa is None:
        base_kappa = _base_cumulants(tables, sde)
    m = jnp.zeros(len(tables.monomials)).at[0].set(1.0).at[tables.unknowns].set(unknown_values)
    return _complete(tables, m, base_kappa, tables.kind == 1)


def _rhs(tables: _Tables, sde: PolynomialSDE, unknown_values, base_kappa):
    m, _ = _full_moments(tables, sde, unknown_values, base_kappa)
    s2 = jnp.maximum(m[tables.scale_index], 1e-300)
    theta_d = sde.drift_coefficients * s2 ** jnp.asarray(tables.drift_powers)
    if tables.noise_pairs.size:
        theta_n = (
            sde.noise_coefficients[tables.noise_pairs[:, 0]]
            * sde.noise_coefficients[tables.noise_pairs[:, 1]]
        )
        theta = jnp.concatenate([theta_d, theta_n])
    else:
        theta = theta_d
    contrib = tables.rhs_mult * theta[tables.rhs_cid] * m[tables.rhs_src]
    return jax.ops.segment_sum(contrib, tables.rhs_tgt, num_segments=tables.unknowns.size)


class MomentEquations(eqx.Module):
    """The generated moment equations dm/dt = F(m) of a `PolynomialSDE` at closure order N.

    `unknowns` lists the exponent tuples of the unknown moments m (order ≤ N, even under the declared
    symmetry, not pure-Gaussian-block); `rhs(sde, m)` evaluates F in JAX (moments of order > N by cumulant
    neglect).
    """

    tables: _Tables = eqx.field(static=True)

    @property
    def order(self) -> int:
        return self.tables.order

    @property
    def symmetric(self) -> tuple[int, ...]:
        return self.tables.symmetric

    @property
    def unknowns(self) -> list[Monomial]:
        return [self.tables.monomials[i] for i in self.tables.unknowns]

    @property
    def num_terms(self) -> int:
        """Number of generator terms (sparse entries of the linear-plus-closure structure)."""
        return int(self.tables.rhs_tgt.size)

    def position(self, exponents: Sequence[int]) -> int:
        """Index of the monomial `exponents` in the unknown vector."""
        i = self.tables.index.get(tuple(exponents))
        hits = np.flatnonzero(self.tables.unknowns == i) if i is not None else []
        if len(hits) == 0:
            raise KeyError(f"{tuple(exponents)} is not an unknown moment of this system.")
        return int(hits[0])

    def rhs(self, sde: PolynomialSDE, m: Float[Array, " unknowns"]) -> Float[Array, " unknowns"]:
        """dm/dt for the unknown moments `m` (in the order of `unknowns`)."""
        return _rhs_jit(self.tables, sde, m)

    def complete(self, sde: PolynomialSDE, m: Float[Array, " unknowns"]) -> dict[Monomial, Array]:
        """Every tabulated moment (unknowns, Gaussian block, closure) from the unknowns `m`."""
        full = _full_jit(self.tables, sde, m)
        return {b: full[i] for i, b in enumerate(self.tables.monomials)}


@eqx.filter_jit
def _rhs_jit(tables: _Tables, sde: PolynomialSDE, m):
    return _rhs(tables, sde, m, _base_cumulants(tables, sde))


@eqx.filter_jit
def _full_jit(tables: _Tables, sde: PolynomialSDE, m):
    return _full_moments(tables, sde, m)[0]


def _extra_monomials(dim: int, symmetric: tuple[int, ...]) -> tuple[Monomial, ...]:
    """Even monomials of the symmetric pair up to order 6 (E[φ^i φ̇^j] for the envelope moments)."""
    if len(symmetric) < 2:
        return ()
    p, v = symmetric[0], symmetric[1]
    out = []
    for total in (2, 4, 6):
        for i in range(total + 1):
            b = [0] * dim
            b[p], b[v] = i, total - i
            out.append(tuple(b))
    return tuple(out)


def moment_equations(sde: PolynomialSDE, closure_order: int) -> MomentEquations:
    """Generate the moment equations of `sde` with cumulant-neglect closure of order `closure_order` (≥ 2)."""
    if not (isinstance(closure_order, int) and closure_order >= 2):
        raise ValueError(f"`closure_order` must be an integer >= 2; got {closure_order!r}.")
    extra = _extra_monomials(sde.dim, sde.symmetric)
    return MomentEquations(_build_tables(sde._structure(), closure_order, extra))


# ============================================================================================================
# Stationary moments: relax (diffrax Tsit5), polish (optimistix Newton), check
# ============================================================================================================


class RESULTS(eqx.Enumeration):
    """Outcome of a stationary-moment solve."""

    successful = ""
    roll_dies_out = (
        "no stationary non-trivial solution: the roll dies out (E[x0²] decays to 0 in the moment equations: "
        "the trivial state is stable, so this sea state excites no parametric roll)."
    )
    closure_failed = (
        "no stationary non-trivial solution: the closure failed (the moment equations diverged, or the fixed "
        "point is unstable or non-physical: a negative variance or E[x⁴]/E[x²]² < 1). Try closure_order=4, "
        "damping='cubic', or a milder sea state."
    )
    newton_failed = (
        "Newton's method did not converge from the relaxed moments to a stationary point; increase "
        "`relax_time` or try closure_order=4."
    )
    fit_failed = (
        "the amplitude family p(A) = C A^ν exp(−c2 A − c3 A²) cannot reproduce E[A²], E[A⁴], E[A⁶] "
        "(least-squares residual too large); the moments may be outside the family's range."
    )


class StationaryMoments(eqx.Module):
    """Stationary moments of a `PolynomialSDE` under cumulant-neglect closure, with diagnostics.

    - `values`: the unknown moments, in the order of `equations.unknowns`.
    - `full`: every tabulated moment (index with `moment(exponents)`).
    - `residual`: max |dm/dt| / scale at the solution (dimensionless, per `time_scale`).
    - `max_real_eigenvalue`: largest real part of the Jacobian eigenvalues [1/s] (< 0: stable fixed point).
    - `relax_steps`, `newton_steps`: work done; `result`: a `RESULTS` item.
    """

    values: Float[Array, " unknowns"]
    full: Float[Array, " table"]
    residual: Float[Array, ""]
    max_real_eigenvalue: Float[Array, ""]
    relax_steps: Array
    newton_steps: Array
    result: RESULTS
    equations: MomentEquations

    def moment(self, exponents: Sequence[int]) -> Float[Array, ""]:
        """E[X^exponents] (0 for moments odd under the symmetry; closure value for tabulated orders > N)."""
        t = self.equations.tables
        b = tuple(int(e) for e in exponents)
        if b in t.index:
            return self.full[t.index[b]]
        if sum(b[i] for i in self.equations.symmetric) % 2:
            return jnp.zeros(())
        raise KeyError(
            f"E[X^{b}] is not tabulated (closure order {t.order}; tabulated orders reach "
            f"{sum(t.monomials[-1])})."
        )

    @property
    def converged(self) -> Array:
        return self.result == RESULTS.successful


def _gaussian_start(tables: _Tables, sde: PolynomialSDE, variances):
    """Unknown moments of independent zero-mean Gaussians of `variances` (× the Gaussian block's own law)."""
    k = _base_cumulants(tables, sde)
    for i in range(tables.dim):
        if i in sde.gaussian:
            continue
        mono = tuple(2 if j == i else 0 for j in range(tables.dim))
        if mono in tables.index:
            k = k.at[tables.index[mono]].set(variances[i])
    m = jnp.zeros(len(tables.monomials)).at[0].set(1.0)
    full, _ = _complete(tables, m, k, np.zeros(len(tables.monomials), bool))
    return full[tables.unknowns]


def _lift(tables: _Tables, sde: PolynomialSDE, low: _Tables, low_full):
    """Unknown moments of an order-N system from an order-N′ < N solution (cumulants above N′ set to zero)."""
    given = np.zeros(len(tables.monomials), bool)
    src, dst = [], []
    for i in tables.unknowns:
        b = tables.monomials[i]
        if sum(b) <= low.order and b in low.index:
            src.append(low.index[b])
            dst.append(i)
    given[dst] = True
    m = jnp.zeros(len(tables.monomials)).at[0].set(1.0).at[np.array(dst)].set(low_full[np.array(src)])
    full, _ = _complete(tables, m, _base_cumulants(tables, sde), given)
    return full[tables.unknowns]


def _scales(tables: _Tables, sde: PolynomialSDE, m_start):
    """Per-unknown magnitude Π σ_i^{β_i} (σ_i² = the start's E[x_i²] or the Gaussian block's variance)."""
    full, _ = _full_moments(tables, sde, m_start)
    sig = []
    for i in range(tables.dim):
        mono = tuple(2 if j == i else 0 for j in range(tables.dim))
        sig.append(jnp.sqrt(jnp.abs(full[tables.index[mono]])) if mono in tables.index else jnp.ones(()))
    sig = jnp.stack(sig)
    expo = np.array([tables.monomials[i] for i in tables.unknowns], float)
    return jnp.exp(expo @ jnp.log(jnp.maximum(sig, 1e-300)))


@eqx.filter_jit
def _solve(tables: _Tables, sde: PolynomialSDE, start, time_scale, relax_time, lead: int, tol_relax: float):
    """Relax (diffrax Tsit5) → Newton (optimistix) → checks, all in one compiled program per structure."""
    kind, data = start
    sde_c = jax.lax.stop_gradient(sde)
    if kind == "gaussian":
        m_start = _gaussian_start(tables, sde_c, jax.lax.stop_gradient(data))
    else:
        low_tables, low_full = data
        m_start = _lift(tables, sde_c, low_tables, jax.lax.stop_gradient(low_full))
    base_kappa = _base_cumulants(tables, sde)
    kappa_c = jax.lax.stop_gradient(base_kappa)
    scale = _scales(tables, sde_c, m_start)
    y0 = m_start / scale
    tau = time_scale

    def fn(y, args):
        s, kap = args
        return _rhs(tables, s, y * scale, kap) / scale * tau

    def steady(t, y, args, **kwargs):
        return jnp.max(jnp.abs(fn(y, args))) < tol_relax * jnp.maximum(jnp.max(jnp.abs(y)), 1e-30)

    def blowup(t, y, args, **kwargs):
        return ~(jnp.max(jnp.abs(y)) < 1e6)

    lead_pos = _unknown_pos(tables, tuple(2 if j == lead else 0 for j in range(tables.dim)))

    def decayed(t, y, args, **kwargs):  # E[x0²] fell by 10⁶ (10° r.m.s. → 0.01°): the roll dies out
        return jnp.abs(y[lead_pos]) < 1e-6 * jnp.abs(y0[lead_pos])

    sol = dfx.diffeqsolve(
        dfx.ODETerm(lambda t, y, args: fn(y, args)),
        dfx.Tsit5(),
        0.0,
        relax_time / tau,
        0.05,
        y0,
        args=(sde_c, kappa_c),
        # dtmin stops a finite-time blow-up of the closed equations instead of shrinking steps for ever
        stepsize_controller=dfx.PIDController(rtol=1e-6, atol=1e-9, dtmin=1e-5),
        event=dfx.Event((steady, blowup, decayed)),
        saveat=dfx.SaveAt(t1=True),
        max_steps=20_000,
        throw=False,
    )
    y_relaxed = sol.ys[0]
    # reaching t1, a (steady-state or blow-up) event or max_steps is fine if the state is finite and bounded;
    # dt_min_reached (finite-time blow-up) or non-finite values are not
    relaxed_ok = (
        (
            (sol.result == dfx.RESULTS.successful)
            | (sol.result == dfx.RESULTS.event_occurred)
            | (sol.result == dfx.RESULTS.max_steps_reached)
        )
        & jnp.all(jnp.isfinite(y_relaxed))
        & (jnp.max(jnp.abs(y_relaxed)) < 1e6)
    )
    y_relaxed = jnp.where(relaxed_ok, y_relaxed, y0)
    root = optx.root_find(
        fn,
        optx.Newton(rtol=1e-11, atol=1e-13, linear_solver=lx.LU()),
        y_relaxed,
        args=(sde, base_kappa),
        max_steps=60,
        throw=False,
    )
    values = root.value * scale
    full, _ = _full_moments(tables, sde, values, base_kappa)
    y_c = jax.lax.stop_gradient(root.value)
    residual = jnp.max(jnp.abs(fn(y_c, (sde_c, kappa_c))))
    jac = jax.jacfwd(fn)(y_c, (sde_c, kappa_c))
    jac_ok = jnp.all(jnp.isfinite(jac))
    eigs = jnp.linalg.eigvals(jnp.where(jac_ok, jac, 0.0))
    max_re = jnp.where(jac_ok, jnp.max(eigs.real), jnp.inf) / tau
    # physical checks on the variables outside the Gaussian block
    phys = jnp.array(True)
    t = tables
    for i in range(t.dim):
        if i in t.gaussian:
            continue
        m2 = tuple(2 if j == i else 0 for j in range(t.dim))
        m4 = tuple(4 if j == i else 0 for j in range(t.dim))
        if m2 in t.index:
            v2 = full[t.index[m2]]
            phys = phys & (v2 > 0)
            if m4 in t.index and t.order >= 4:
                v4 = full[t.index[m4]]
                phys = phys & (v4 > 0) & (v4 >= v2**2 * (1 - 1e-9))
    start_lead = jnp.maximum(jnp.abs(m_start[lead_pos]), 1e-300)
    dies = (jnp.abs(values[lead_pos]) / start_lead < 1e-8) | (
        relaxed_ok & (jnp.abs(y_relaxed[lead_pos]) < 1e-6 * jnp.abs(y0[lead_pos]))
    )
    newton_ok = (root.result == optx.RESULTS.successful) & (residual < 1e-8) & jnp.all(jnp.isfinite(values))
    result = RESULTS.where(
        dies,
        RESULTS.roll_dies_out,
        RESULTS.where(
            ~relaxed_ok,
            RESULTS.closure_failed,
            RESULTS.where(
                ~newton_ok,
                RESULTS.newton_failed,
                RESULTS.where(phys & (max_re < 0), RESULTS.successful, RESULTS.closure_failed),
            ),
        ),
    )
    return values, full, residual, max_re, sol.stats["num_steps"], root.stats["num_steps"], result


def _unknown_pos(tables: _Tables, mono) -> int:
    return int(np.flatnonzero(tables.unknowns == tables.index[mono])[0])


def stationary_moments(
    sde: PolynomialSDE,
    *,
    closure_order: int = 4,
    initial: StationaryMoments | None = None,
    initial_variances: ArrayLike | None = None,
    time_scale: float = 1.0,
    relax_time: float | None = None,
    tol_relax: float = 1e-4,
    throw: bool = True,
) -> StationaryMoments:
    """Stationary moments of `sde` under cumulant neglect of order `closure_order`.

    The moment ODEs are relaxed in time with diffrax (Tsit5, adaptive) from a non-trivial start until the
    relative rate of change per `time_scale` drops below `tol_relax` (or `relax_time` passes), then polished
    with optimistix Newton to a residual ~1e-13; the fixed point must have every Jacobian eigenvalue in the
    left half plane and E[x_i²] > 0, E[x_i⁴] ≥ E[x_i²]² for every non-Gaussian-block variable.

    **Arguments:**

    - `sde`: the polynomial Itô system (e.g. `roll_sde`).
    - `closure_order`: N ≥ 2; cumulants above N are neglected.
    - `initial`: a solution at a lower closure order to start from (its cumulants, higher ones set to zero);
      otherwise independent Gaussians with `initial_variances` (one per variable; the Gaussian block's own law
      is always used for it). E[x²] = 0 is always a fixed point of the homogeneous roll equations: start away.
    - `time_scale`: the system's time unit [s] (the roll period for the roll), for the relaxation criteria.
    - `relax_time`: longest relaxation [s] (default 400 `time_scale`s).
    - `throw`: raise (`EquinoxRuntimeError`) if no valid stationary solution is found; otherwise inspect
      `result`.

    **Returns:** `StationaryMoments`. Differentiable with respect to the SDE's coefficients (implicit function
    theorem through the Newton root, `optimistix.ImplicitAdjoint`); the relaxation only supplies the start.
    """
    eqs = moment_equations(sde, closure_order)
    tables = eqs.tables
    if initial is not None:
        if initial.equations.tables.dim != sde.dim:
            raise ValueError("`initial` belongs to a system of another dimension.")
        start = ("lift", (initial.equations.tables, initial.full))
    else:
        if initial_variances is None:
            raise ValueError(
                "give `initial` (a lower-order solution) or `initial_variances` (one per variable)."
            )
        v = jnp.asarray(initial_variances, dtype=float)
        if v.shape != (sde.dim,):
            raise ValueError(f"`initial_variances` must have shape ({sde.dim},); got {v.shape}.")
        start = ("gaussian", v)
    time_scale = jnp.asarray(time_scale, dtype=float)
    relax_time = 400.0 * time_scale if relax_time is None else jnp.asarray(relax_time, dtype=float)
    lead = next(i for i in range(sde.dim) if i not in sde.gaussian)
    values, full, residual, max_re, n_relax, n_newton, result = _solve(
        tables, sde, start, time_scale, relax_time, lead, float(tol_relax)
    )
    if throw:
        values = result.error_if(values, result != RESULTS.successful)
    return StationaryMoments(values, full, residual, max_re, n_relax, n_newton, result, eqs)


# ============================================================================================================
# Amplitude family p(A) = C A^ν exp(−c2 A − c3 A²): quadrature, fit, statistics
# ============================================================================================================

# tanh-sinh nodes on (0, 1): w = logistic(π sinh t); the left tail decays double-exponentially even for ν →
# −1.
_TS_T = np.linspace(-12.0, 6.0, 1201)
_TS_H = float(_TS_T[1] - _TS_T[0])
_A_MAX_NORMALISED = 40.0  # upper limit of the normalised amplitude a = A/√E[A²] (the tail beyond is < e^-100)


def _ts_log_terms(x, log_g_of_a, power):
    """log of the tanh-sinh terms of ∫_0^x a^power g(a) da (trapezoid in t); broadcasts with x[..., None]."""
    t = jnp.asarray(_TS_T)
    ps = jnp.pi * jnp.sinh(t)
    log_w = -jax.nn.softplus(-ps)
    log_1mw = -jax.nn.softplus(ps)
    x = jnp.asarray(x)[..., None]
    power = jnp.asarray(power)[..., None]
    a = x * jnp.exp(log_w)
    log_jac = log_w + log_1mw + jnp.log(jnp.pi * jnp.cosh(t)) + jnp.log(x)
    return power * (jnp.log(x) + log_w) + log_g_of_a(a) + log_jac + math.log(_TS_H)


class AmplitudeFamily(eqx.Module):
    r"""The 3-parameter amplitude law $p(A) = C A^\nu e^{-c_2 A - c_3 A^2}$, A [rad] ≥ 0 (Roberts' family).

    `nu` [-] > −1, `c2` [1/rad], `c3` [1/rad²] > 0; `log_norm` = log C. Integrals by tanh-sinh quadrature in
    JAX (relative accuracy ~1e-12, also for ν close to −1).
    """

    nu: Float[Array, ""]
    c2: Float[Array, ""]
    c3: Float[Array, ""]
    scale: Float[Array, ""]  # √E[A²] of the fit [rad]: the quadrature runs on a = A/scale

    def _log_g(self, a):
        # normalised exponent in a = A/scale
        return -self.c2 * self.scale * a - self.c3 * self.scale**2 * a**2

    def _log_integral(self, power, upper=_A_MAX_NORMALISED):
        return jax.nn.logsumexp(_ts_log_terms(upper, self._log_g, power), axis=-1)

    @property
    def log_norm(self) -> Float[Array, ""]:
        """log C (p in 1/rad)."""
        return -self._log_integral(self.nu) - (self.nu + 1) * jnp.log(self.scale)

    def moment(self, r) -> Float[Array, "..."]:
        """E[A^r] [rad^r]."""
        r = jnp.asarray(r, dtype=float)
        return jnp.exp(self._log_integral(self.nu + r) - self._log_integral(self.nu)) * self.scale**r

    def pdf(self, amplitude) -> Float[Array, "..."]:
        """p(A) [1/rad] at `amplitude` [rad] > 0."""
        amplitude = jnp.asarray(amplitude, dtype=float)
        safe = jnp.where(amplitude > 0, amplitude, 1.0)
        logp = self.log_norm + self.nu * jnp.log(safe) - self.c2 * safe - self.c3 * safe**2
        return jnp.where(amplitude > 0, jnp.exp(logp), 0.0)

    def cdf(self, amplitude) -> Float[Array, "..."]:
        """P(A ≤ amplitude), `amplitude` [rad] ≥ 0."""
        amplitude = jnp.asarray(amplitude, dtype=float)
        x = jnp.clip(amplitude / self.scale, 1e-300, _A_MAX_NORMALISED)
        out = jnp.exp(
            jax.nn.logsumexp(_ts_log_terms(x, self._log_g, self.nu), axis=-1) - self._log_integral(self.nu)
        )
        return jnp.where(amplitude > 0, jnp.minimum(out, 1.0), 0.0)

    def sf(self, amplitude) -> Float[Array, "..."]:
        """P(A > amplitude), `amplitude` [rad]."""
        return 1.0 - self.cdf(amplitude)

    def mean(self) -> Float[Array, ""]:
        """E[A] [rad]."""
        return self.moment(1.0)

    def quantile(self, level) -> Float[Array, "..."]:
        """A [rad] with P(A ≤ A_q) = `level` (optimistix bisection; implicit derivative)."""
        level = jnp.asarray(level, dtype=float)
        return _family_quantiles(self, level.reshape(-1)).reshape(level.shape)


@eqx.filter_jit
def _family_quantiles(family: AmplitudeFamily, levels):
    ok = (
        jnp.isfinite(family.nu)
        & jnp.isfinite(family.c2)
        & jnp.isfinite(family.c3)
        & jnp.isfinite(family.scale)
    )
    ok = ok & (family.c3 > 0) & (family.scale > 0) & (family.nu > -1)
    safe = AmplitudeFamily(
        *(
            jnp.where(ok, x, d)
            for x, d in zip((family.nu, family.c2, family.c3, family.scale), (1.0, 0.0, 1.0, 1.0))
        )
    )
    return jnp.where(ok, _bisect_quantiles(safe, levels), jnp.nan)


def _bisect_quantiles(family: AmplitudeFamily, levels):
    def one(q):
        sol = optx.root_find(
            lambda a, args: family.cdf(a * family.scale) - q,
            optx.Bisection(rtol=1e-13, atol=1e-13),
            jnp.asarray(1.0),
            options={"lower": 1e-12, "upper": _A_MAX_NORMALISED},
            max_steps=300,
            throw=False,
        )
        return sol.value * family.scale

    return jax.vmap(one)(levels)


@eqx.filter_jit
def fit_amplitude_family(
    amplitude_moments: ArrayLike,
) -> tuple[AmplitudeFamily, Float[Array, ""], optx.RESULTS]:
    """Fit p(A) = C A^ν e^{−c2A−c3A²} to (E[A²], E[A⁴], E[A⁶]) [rad², rad⁴, rad⁶].

    Better conditioned than matching the raw moments: on the normalised amplitude a = A/√E[A²] the residuals
    are log E[a^{2k}]_fit − log E[a^{2k}]_target, k = 1, 2, 3, in the parameters (log(ν+1), c2, log c3) (so
    ν > −1, c3 > 0 always), solved with optimistix Levenberg–Marquardt from the Rayleigh law. Differentiable
    (implicit).

    **Returns:** `(family, max_abs_log_residual, optimistix result)`.
    """
    mom = jnp.asarray(amplitude_moments, dtype=float)
    scale = jnp.sqrt(mom[0])
    target = jnp.log(mom / scale ** jnp.array([2.0, 4.0, 6.0]))

    def family(q):
        return AmplitudeFamily(jnp.exp(q[0]) - 1.0, q[1] / scale, jnp.exp(q[2]) / scale**2, scale)

    def residuals(q, args):
        tgt = args
        f = AmplitudeFamily(jnp.exp(q[0]) - 1.0, q[1], jnp.exp(q[2]), jnp.ones(()))
        li = f._log_integral(f.nu + jnp.array([0.0, 2.0, 4.0, 6.0]))
        return li[1:] - li[0] - tgt

    sol = optx.least_squares(
        residuals,
        optx.LevenbergMarquardt(rtol=1e-12, atol=1e-14),
        jnp.array([math.log(2.0), 0.0, 0.0]),
        args=target,
        max_steps=400,
        throw=False,
    )
    res = jnp.max(jnp.abs(residuals(sol.value, target)))
    return family(sol.value), res, sol.result


# ============================================================================================================
# The roll: moments → envelope moments → amplitude PDF
# ============================================================================================================

ENVELOPES = ("phase_averaged", "omega0", "mean_square_frequency")


def envelope_moments(
    moments: StationaryMoments, omega0, envelope: str = "phase_averaged"
) -> Float[Array, " 3"]:
    """(E[A²], E[A⁴], E[A⁶]) of the roll envelope from the stationary moments of (φ, φ̇) [rad^2k].

    - `"omega0"`: A² = φ² + φ̇²/ω0² (THEORY §6), exact moments of that energy-type envelope.
    - `"mean_square_frequency"`: the same with Ω² = E[φ̇²]/E[φ²] in place of ω0² (so E[A²] = 2E[φ²]).
    - `"phase_averaged"` (default): φ = A cos Θ with Θ uniform and independent of A, so
      E[A^{2k}] = E[φ^{2k}]·4ᵏ k!²/(2k)! (E[A²] = 2E[φ²], E[A⁴] = 8/3 E[φ⁴], E[A⁶] = 16/5 E[φ⁶]); the Hilbert
      envelope of a stationary process has E[A²] = 2E[φ²] exactly.
    """
    if envelope not in ENVELOPES:
        raise ValueError(f"`envelope` must be one of {ENVELOPES}; got {envelope!r}.")
    dim = moments.equations.tables.dim

    def e(i, j):
        return moments.moment((i, j) + (0,) * (dim - 2))

    if envelope == "phase_averaged":
        return jnp.stack([2.0 * e(2, 0), 8.0 / 3.0 * e(4, 0), 16.0 / 5.0 * e(6, 0)])
    w2 = omega0**2 if envelope == "omega0" else e(0, 2) / e(2, 0)
    a2 = e(2, 0) + e(0, 2) / w2
    a4 = e(4, 0) + 2 * e(2, 2) / w2 + e(0, 4) / w2**2
    a6 = e(6, 0) + 3 * e(4, 2) / w2 + 3 * e(2, 4) / w2**2 + e(0, 6) / w2**3
    return jnp.stack([a2, a4, a6])


class MomentSolution(AbstractAmplitudeLaw):
    """The moment method's amplitude law for one ship in one sea state, with the moments behind it.

    An amplitude law (`AbstractAmplitudeLaw`, radians): `pdf`, `cdf`, `sf`, `quantile`, `mean`, `summary`.
    `estimator="envelope"` is the method's own law (time-sampled, envelope-type: compare with Monte Carlo
    envelope amplitudes); `estimator="zero_crossing"` is the per-half-cycle law derived from it by weighting
    each amplitude with the rate of half cycles at that amplitude, Ω(A)/π (harmonic balance on the ship's
    restoring, as for Roberts' and ESAM's per-cycle laws): the law the maxima formulas need.

    - `moments`: the `StationaryMoments` (E[φ²] = `moments.moment((2, 0, 0, …))` etc.).
    - `amplitude_moments`: the (E[A²], E[A⁴], E[A⁶]) [rad^2k] the family was fitted to.
    - `family`: the fitted `AmplitudeFamily` (ν, c2 [1/rad], c3 [1/rad²]) of the envelope law.
    - `law`: the tabulated law of `estimator` that the methods evaluate.
    - `fit_residual`: max |log-moment mismatch| of the fit; `result`: a `RESULTS` item.
    """

    moments: StationaryMoments
    amplitude_moments: Float[Array, " 3"]
    family: AmplitudeFamily
    law: TabulatedAmplitudeLaw
    fit_residual: Float[Array, ""]
    result: RESULTS
    closure_order: int = eqx.field(static=True)
    filter_order: int = eqx.field(static=True)
    damping: str = eqx.field(static=True)
    envelope: str = eqx.field(static=True)
    estimator: str = eqx.field(static=True)

    def _logpdf(self, a):
        return self.law._logpdf(a)

    def _logsf(self, a):
        return self.law._logsf(a)

    def _logcdf(self, a):
        return self.law._logcdf(a)

    def support(self):
        return self.law.support()

    def scale(self):
        return self.family.scale

    def _phi(self, i, j):
        dim = self.moments.equations.tables.dim
        return self.moments.moment((i, j) + (0,) * (dim - 2))

    @property
    def e_phi2(self) -> Float[Array, ""]:
        """E[φ²] [rad²]."""
        return self._phi(2, 0)

    @property
    def e_phi4(self) -> Float[Array, ""]:
        """E[φ⁴] [rad⁴]."""
        return self._phi(4, 0)

    @property
    def e_dphi2(self) -> Float[Array, ""]:
        """E[φ̇²] [rad²/s²]."""
        return self._phi(0, 2)

    def details(self) -> dict:
        """The method's own numbers for JSON (closure, moments, fitted family; radians)."""
        return {
            "method": "moment method (cumulant neglect)",
            "closure_order": self.closure_order,
            "filter_order": self.filter_order,
            "damping_closure": self.damping,
            "envelope": self.envelope,
            "converged": bool(self.result == RESULTS.successful),
            "message": RESULTS[self.result] if not bool(self.result == RESULTS.successful) else "",
            "E_phi2_rad2": float(self.e_phi2),
            "E_phi4_rad4": float(self.e_phi4),
            "E_dphi2_rad2_s2": float(self.e_dphi2),
            "E_A2_rad2": float(self.amplitude_moments[0]),
            "E_A4_rad4": float(self.amplitude_moments[1]),
            "E_A6_rad6": float(self.amplitude_moments[2]),
            "nu": float(self.family.nu),
            "c2_per_rad": float(self.family.c2),
            "c3_per_rad2": float(self.family.c3),
            "fit_residual": float(self.fit_residual),
            "max_real_eigenvalue_per_s": float(self.moments.max_real_eigenvalue),
        }


_LAW_POINTS = 1601
_LAW_TOP = 12.0  # the tabulated law reaches 12 √E[A²] (the family's tail there is < e^-100 of its scale)


def _harmonic_frequency(ship: Ship, amplitude):
    """Ω(A) [rad/s] of the undamped roll by harmonic balance on the GZ polynomial (floored at 1e-3 ω0)."""
    a = ship.restoring_coefficients
    x2 = amplitude * amplitude
    w2 = a[0] + x2 * (0.75 * a[1] + x2 * (0.625 * a[2] + x2 * (35 / 64 * a[3] + x2 * 63 / 128 * a[4])))
    return jnp.sqrt(jnp.maximum(w2, 1e-6 * a[0]))


def _tabulated_law(family: AmplitudeFamily, ship: Ship, estimator: str) -> TabulatedAmplitudeLaw:
    grid = family.scale * jnp.linspace(0.0, _LAW_TOP, _LAW_POINTS)[1:]
    safe = jnp.maximum(grid, 1e-300)
    log_pdf = family.nu * jnp.log(safe) - family.c2 * safe - family.c3 * safe**2
    if estimator == "zero_crossing":
        log_pdf = log_pdf + jnp.log(_harmonic_frequency(ship, grid))
    return TabulatedAmplitudeLaw.from_logpdf(grid, log_pdf - jnp.max(log_pdf), estimator=estimator)


def _shaping_filter(ship: Ship, wave, shaping_filter, filter_order: int) -> ShapingFilter:
    """The filter the moment equations use: `shaping_filter` when given (the Monte Carlo's, e.g.
    `problem.filter_fit.filter`), else the fit of `wave` at 2ω0 that `RollProblem.from_sea` makes."""
    if shaping_filter is not None:
        if isinstance(shaping_filter, FilterFit):
            shaping_filter = shaping_filter.filter
        if not isinstance(shaping_filter, ShapingFilter):
            raise TypeError(f"`shaping_filter` must be a ShapingFilter or FilterFit; got {type(shaping_filter).__name__}.")
        return shaping_filter
    if not isinstance(wave, EffectiveWave):
        raise TypeError(
            f"`wave` must be Grim's effective wave (`jaxroll.EffectiveWave(sea, lpp, speed, heading)`, or "
            f"`problem.wave`); got {type(wave).__name__}. A bare sea spectrum has no speed or heading."
        )
    return fit_filter(wave, order=filter_order, match_frequency=2 * ship.omega0).filter


def roll_moments(
    ship: Ship,
    wave: EffectiveWave | None,
    *,
    shaping_filter: ShapingFilter | FilterFit | None = None,
    filter_order: int = 4,
    closure_order: int = 6,
    damping: str = "cubic",
    initial_roll_deg: float = 10.0,
    throw: bool = True,
) -> StationaryMoments:
    """Stationary moments of the roll + filter system of `ship` in `wave` (see `moment_pdf`).

    Order N > 4 is reached by continuation: order 4 from a Gaussian start (σ_φ = `initial_roll_deg`,
    σ_φ̇ = ω0 σ_φ), then each higher even order from the one below (THEORY §6: order 6 from a deterministic
    small-roll start blew up).
    """
    sde = roll_sde(ship, _shaping_filter(ship, wave, shaping_filter, filter_order), damping=damping)
    s0 = math.radians(initial_roll_deg)
    w0 = jax.lax.stop_gradient(ship.omega0)
    variances = jnp.zeros(sde.dim).at[0].set(s0**2).at[1].set((w0 * s0) ** 2)
    tau = 2 * jnp.pi / w0
    if closure_order <= 4:
        orders = [closure_order]
    else:
        orders = [4, *range(6, closure_order + 1, 2)]
        if orders[-1] != closure_order:
            orders.append(closure_order)
    sol = None
    for k in orders:
        sol = stationary_moments(
            sde,
            closure_order=k,
            initial=sol,
            initial_variances=variances if sol is None else None,
            time_scale=tau,
            throw=throw and k == closure_order,
        )
    return sol


def moment_pdf(
    ship: Ship,
    wave: EffectiveWave | None,
    *,
    shaping_filter: ShapingFilter | FilterFit | None = None,
    estimator: str = "envelope",
    filter_order: int = 4,
    closure_order: int = 6,
    damping: str = "cubic",
    envelope: str = "phase_averaged",
    initial_roll_deg: float = 10.0,
    throw: bool = True,
) -> MomentSolution:
    """The moment method: stationary roll moments (cumulant neglect) → amplitude PDF C A^ν e^{−c2A−c3A²}.

    **Arguments:**

    - `ship`: the roll model (SI, radians); `wave`: Grim's effective wave (`problem.wave`).
    - `shaping_filter`: the Monte Carlo's filter (`problem.filter_fit`), so theory and simulation share one
      fit; when None, `wave` is fitted with `filter_order` at 2ω0 exactly as `RollProblem.from_sea` does.
    - `estimator`: "envelope" (the method's time-sampled law) or "zero_crossing" (per half cycle, weighted by
      Ω(A); for maxima).
    - `closure_order`: cumulant-neglect order N (4 or 6; ≥ 4).
    - `damping`: φ̇|φ̇| treatment, `"cubic"` (default) or `"linear"` (see `roll_sde`).
    - `envelope`: how amplitude moments follow from (φ, φ̇) moments (see `envelope_moments`).
    - `initial_roll_deg`: r.m.s. roll of the Gaussian start of the relaxation [deg].
    - `throw`: raise if the moment equations have no valid non-trivial fixed point or the fit fails.

    **Returns:** `MomentSolution`, an amplitude law of `estimator`. The envelope law is *time-sampled*: compare it
    with Monte Carlo envelope amplitudes (`stats.law("envelope")`), not with per-cycle
    zero-crossing amplitudes.

    !!! note
        Differentiable with respect to ship and sea parameters (`jax.grad` of e.g. `sf(jnp.deg2rad(20.0))`):
        the filter fit, the Newton root and the PDF fit are differentiated implicitly by optimistix.
    """
    check_estimator(estimator)
    if envelope not in ENVELOPES:
        raise ValueError(f"`envelope` must be one of {ENVELOPES}; got {envelope!r}.")
    if not (isinstance(closure_order, int) and closure_order >= 4):
        raise ValueError(
            f"`closure_order` must be an integer >= 4 (E[φ⁴] is needed for the PDF); got {closure_order!r}."
        )
    mom = roll_moments(
        ship,
        wave,
        shaping_filter=shaping_filter,
        filter_order=filter_order,
        closure_order=closure_order,
        damping=damping,
        initial_roll_deg=initial_roll_deg,
        throw=throw,
    )
    amp, family, res, fit_result = _amplitude_law(mom, ship.omega0, envelope)
    fit_ok = (fit_result == optx.RESULTS.successful) & (res < 1e-6)
    result = RESULTS.where(
        mom.result != RESULTS.successful,
        mom.result,
        RESULTS.where(fit_ok, RESULTS.successful, RESULTS.fit_failed),
    )
    if throw:
        family = result.error_if(family, result != RESULTS.successful)
    law = _tabulated_law(family, ship, estimator)
    return MomentSolution(
        mom, amp, family, law, res, result, closure_order, filter_order, damping, envelope, estimator
    )


@eqx.filter_jit
def _amplitude_law(mom: StationaryMoments, omega0, envelope: str):
    amp = envelope_moments(mom, omega0, envelope)
    family, res, fit_result = fit_amplitude_family(amp)
    return amp, family, res, fit_result


def moment_pdf_first_stable(ship: Ship, wave, *, filter_order: int = 4, closure_orders=(6, 4), **kwargs) -> MomentSolution:
    """`moment_pdf` at the first closure order in `closure_orders` that has a stable non-trivial fixed point.

    Order 6 is the more accurate on the default ship at H1/3 = 7 m, but its branch of fixed points ends near
    H1/3 ≈ 6.3 m (docs/theory.md); order 4 exists there. The order used is `result.closure_order`, and a
    `UserWarning` says when a fallback was taken.

    **Raises:** the last order's error when none of them has a stable solution.
    """
    import warnings

    error = None
    for i, order in enumerate(closure_orders):
        try:
            out = moment_pdf(ship, wave, filter_order=filter_order, closure_order=order, **kwargs)
        except (ValueError, RuntimeError) as e:
            error = e
            continue
        if i > 0:
            warnings.warn(
                f"moment method: closure order {closure_orders[0]} has no stable solution here "
                f"({_first_message(error)}); using order {order}. This warning appears because the "
                "higher-order cumulant closure lost its stable non-trivial fixed point in this sea state.",
                stacklevel=2,
            )
        return out
    raise error


def _first_message(error: Exception) -> str:
    """The user-facing line of an error (the `EquinoxRuntimeError:` text under jit, else the first line)."""
    text = str(error)
    marker = "EquinoxRuntimeError: "
    if marker in text:
        text = text.split(marker, 1)[1]
    return text.strip().splitlines()[0] if text.strip() else type(error).__name__
