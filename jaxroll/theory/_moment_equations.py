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
φ̇|φ̇| ≈ √(2/π) (σ_v φ̇ + φ̇³/(3σ_v)), σ_v² = E[φ̇²] (the moment state itself), the choice (docs/theory.md) that
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

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._compiled import filter_jit
from .._config import require_float64
from ..sea._filters import ShapingFilter, lyapunov
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
        """State dimension [-]."""
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


def _compositions(k: int, n: int):
    """All exponent tuples of length n with sum k."""
    if n == 1:
        yield (k,)
        return
    for first in range(k, -1, -1):
        for rest in _compositions(k - first, n - 1):
            yield (first, *rest)


def roll_sde(ship: Ship, shaping_filter: ShapingFilter, *, damping: str = "cubic") -> PolynomialSDE:
    r"""The roll + Method-2 filter Itô system X = (φ, φ̇, z_1 … z_n) of docs/conventions.md and docs/theory.md as a `PolynomialSDE`.

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
    return _roll_sde(ship, shaping_filter, damping, zero_pattern(ship, shaping_filter))


def zero_pattern(ship: Ship, shaping_filter: ShapingFilter) -> tuple:
    """Which coefficients of `roll_sde` are a concrete zero (its terms are dropped): (b1, b2, b3), (a1 … a9),
    ΔGM's (C0 …), the filter's c, A (rows) and b; a traced value is never zero. Read on the host (no compiled
    program), hashable: a compiled program that builds the SDE from a traced ship takes it as static data, so
    that its system has the terms `roll_sde` of the concrete ship has."""

    def zeros(x):
        try:
            return tuple(bool(v) for v in np.ravel(np.asarray(x) == 0))
        except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError, TypeError):
            return (False,) * int(np.size(x))

    try:
        a1_zero = bool((2 * np.pi / np.asarray(ship.roll_period)) ** 2 == 0)  # a1 = ω0² = (2π/Tφ)²
    except (jax.errors.TracerArrayConversionError, jax.errors.ConcretizationTypeError, TypeError):
        a1_zero = False
    return (
        zeros(ship.damping),
        (a1_zero, *zeros(ship.restoring)),
        zeros(ship.delta_gm),
        zeros(shaping_filter.c),
        zeros(shaping_filter.a),
        zeros(shaping_filter.b),
    )


def _roll_sde(ship: Ship, shaping_filter: ShapingFilter, damping: str, pattern: tuple) -> PolynomialSDE:
    """`roll_sde` with the terms whose coefficients `pattern` (`zero_pattern`) marks as zero dropped."""
    if damping not in ("cubic", "linear"):
        raise ValueError(f"`damping` must be 'cubic' or 'linear'; got {damping!r}.")
    z_b, z_a, z_dgm, z_c, z_fa, z_fb = pattern
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
    if not z_b[0]:
        add(1, e(1), -b1)
    if not z_b[1]:
        if damping == "cubic":
            add(1, e(1), -b2 * math.sqrt(2 / math.pi), 0.5)
            add(1, e(1, 3), -b2 * math.sqrt(2 / math.pi) / 3, -0.5)
        else:
            add(1, e(1), -b2 * math.sqrt(8 / math.pi), 0.5)
    if not z_b[2]:
        add(1, e(1, 3), -b3)
    a = ship.restoring_coefficients
    for i, power in enumerate((1, 3, 5, 7, 9)):
        if not z_a[i]:
            add(1, e(0, power), -a[i])
    kappa = ship.gm_correction * ship.omega0**2 / ship.gm0
    c = shaping_filter.c
    c_zero = z_c
    for k in range(ship.delta_gm.shape[0]):
        ck = ship.delta_gm[k]
        if z_dgm[k]:
            continue
        for alpha in _compositions(k, n):
            if any(alpha[i] and c_zero[i] for i in range(n)):
                continue
            multinomial = math.factorial(k) // math.prod(math.factorial(x) for x in alpha)
            cz = math.prod([c[i] ** alpha[i] for i in range(n) if alpha[i]], start=jnp.ones(()))
            add(1, (1, 0, *alpha), -kappa * ck * (-1) ** k * multinomial * cz)
    for i in range(n):
        for j in range(n):
            if not z_fa[i * n + j]:
                add(2 + i, e(2 + j), shaping_filter.a[i, j])
    noise_terms, noise_values = [], []
    for i in range(n):
        if not z_fb[i]:
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


class _TableArrays(eqx.Module):
    """The numeric tables of `_Tables` (NumPy arrays), passed to compiled programs as *arguments*, not constants.

    As arguments they keep the traced program small (its size does not grow with the number of terms), so it
    compiles in seconds, is shared by every structure with the same table shapes, and goes into JAX's
    persistent compilation cache.
    """

    levels: tuple[tuple[np.ndarray, ...], ...]  # per group of orders: (idx, tgt, kap, mom, coef)
    kind: np.ndarray
    unknowns: np.ndarray
    gauss_cov_idx: np.ndarray
    gauss_pairs: np.ndarray
    rhs_tgt: np.ndarray
    rhs_cid: np.ndarray
    rhs_mult: np.ndarray
    rhs_src: np.ndarray
    drift_powers: np.ndarray
    noise_pairs: np.ndarray


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
    levels: tuple[_Levels, ...]  # the orders, padded to a common width (one group: one scan)
    gauss_cov_idx: np.ndarray  # table index of z_a z_b for the Gaussian block (a ≤ b), and (a, b)
    gauss_pairs: np.ndarray
    rhs_tgt: np.ndarray  # generator terms: unknown index, coefficient id, multiplier, source table index
    rhs_cid: np.ndarray
    rhs_mult: np.ndarray
    rhs_src: np.ndarray
    drift_powers: np.ndarray
    noise_pairs: np.ndarray  # (n_pairs, 2) noise-term indices with the same Wiener process
    scale_index: int  # table index of x_s²
    key: tuple = ()  # (structure, order, extra): the arguments of `_build_tables` that generated these tables

    @functools.cached_property
    def arrays(self) -> _TableArrays:
        """The numeric tables, to pass into a compiled program as an argument. Indices are unsigned: indexing with
        them needs no wrap-around of negative indices (a signed index array costs 3x the operations in the
        compiled program, which then compiles slower)."""

        def u(x):
            return np.asarray(x).astype(np.uint32)

        return _TableArrays(
            levels=tuple((u(lv.idx), u(lv.tgt), u(lv.kap), u(lv.mom), lv.coef) for lv in self.levels),
            kind=self.kind,
            unknowns=u(self.unknowns),
            gauss_cov_idx=u(self.gauss_cov_idx),
            gauss_pairs=u(self.gauss_pairs),
            rhs_tgt=u(self.rhs_tgt),
            rhs_cid=u(self.rhs_cid),
            rhs_mult=self.rhs_mult,
            rhs_src=u(self.rhs_src),
            drift_powers=self.drift_powers,
            noise_pairs=u(self.noise_pairs),
        )


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

    # split the orders into ≤ 2 consecutive groups (one scan each) minimising the padded work: each scan body
    # costs compile time (3 groups compiled ~2.6x slower than 1), padding costs run time (1 group: 2.3x the
    # work of 3 at order 6, 2 groups: 1.2x)
    sizes = [max(len(r[1]), 1) + len(r[0]) for r in rows]
    n_rows = len(rows)
    splits = min(
        ([(0, a), (a, n_rows)] if 0 < a < n_rows else [(0, n_rows)] for a in range(n_rows)),
        key=lambda parts: sum((j - i) * max(sizes[i:j]) for i, j in parts) + 2000 * len(parts),
    )
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
        key=(structure, order, extra),
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


def _complete(tables: _Tables, arr: _TableArrays, m_given, k_given, moment_given):
    """All table moments and cumulants from given moments (where `moment_given`), given cumulants elsewhere.

    Level by level in total order (a `lax.scan`): S = Σ_{γ≠β} C κ_γ m_{β−γ}; then κ_β = m_β − S (moment given)
    or m_β = κ_β + S (cumulant given). `arr` is `tables.arrays` (passed as an argument of the compiled
    program).
    """
    given = jnp.concatenate([jnp.asarray(moment_given, dtype=bool), jnp.zeros(1, bool)])
    m = jnp.concatenate([m_given, jnp.zeros(1)])
    k = jnp.concatenate([k_given, jnp.zeros(1)])
    for rows in arr.levels:
        width = rows[0].shape[1]

        def body(carry, row, width=width):
            m, k = carry
            idx, tgt, kap, mom, coef = row
            s = jax.ops.segment_sum(coef * k[kap] * m[mom], tgt, num_segments=width + 1)[:width]
            g = given[idx]
            mk = jnp.where(g, m[idx], k[idx] + s)
            kk = jnp.where(g, m[idx] - s, k[idx])
            return (m.at[idx].set(mk), k.at[idx].set(kk)), None

        (m, k), _ = jax.lax.scan(body, (m, k), rows)
    return m[:-1], k[:-1]


def _base_cumulants(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE):
    """Known cumulants: the Gaussian block's covariance at its second-order monomials, zero elsewhere."""
    k = jnp.zeros(len(tables.monomials))
    if tables.gauss_cov_idx.size:
        cov = _gaussian_covariance(sde)
        k = k.at[arr.gauss_cov_idx].set(cov[arr.gauss_pairs[:, 0], arr.gauss_pairs[:, 1]])
    return k


def _full_moments(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, unknown_values, base_kappa=None):
    if base_kappa is None:
        base_kappa = _base_cumulants(tables, arr, sde)
    m = jnp.zeros(len(tables.monomials)).at[0].set(1.0).at[arr.unknowns].set(unknown_values)
    return _complete(tables, arr, m, base_kappa, arr.kind == 1)


def _rhs(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, unknown_values, base_kappa):
    m, _ = _full_moments(tables, arr, sde, unknown_values, base_kappa)
    s2 = jnp.maximum(m[tables.scale_index], 1e-300)
    theta_d = sde.drift_coefficients * s2 ** jnp.asarray(arr.drift_powers)
    if tables.noise_pairs.size:
        theta_n = (
            sde.noise_coefficients[arr.noise_pairs[:, 0]] * sde.noise_coefficients[arr.noise_pairs[:, 1]]
        )
        theta = jnp.concatenate([theta_d, theta_n])
    else:
        theta = theta_d
    contrib = arr.rhs_mult * theta[arr.rhs_cid] * m[arr.rhs_src]
    return jax.ops.segment_sum(contrib, arr.rhs_tgt, num_segments=tables.unknowns.size)


class MomentEquations(eqx.Module):
    """The generated moment equations dm/dt = F(m) of a `PolynomialSDE` at closure order N.

    `unknowns` lists the exponent tuples of the unknown moments m (order ≤ N, even under the declared
    symmetry, not pure-Gaussian-block); `rhs(sde, m)` evaluates F in JAX (moments of order > N by cumulant
    neglect).
    """

    tables: _Tables = eqx.field(static=True)

    def __reduce__(self):
        # pickled by the tables' key (a few kB instead of megabytes): unpickling looks the tables up in the tables
        # cache (memory, disk) or generates them again; they are a pure function of the key
        return _equations_from_key, self.tables.key

    def __jaxroll_cache_key__(self):
        # the same in a stored program's output skeleton (`jaxroll._cache_files`): the tables' key, not the tables
        return self.tables.key

    @classmethod
    def __jaxroll_from_cache_key__(cls, key) -> MomentEquations:
        structure, order, extra = key
        return _equations_from_key(structure, int(order), extra)

    @property
    def order(self) -> int:
        """The closure order [-]."""
        return self.tables.order

    @property
    def symmetric(self) -> tuple[int, ...]:
        """The variables that change sign under a symmetry of the system (moments odd in them vanish)."""
        return self.tables.symmetric

    @property
    def unknowns(self) -> list[Monomial]:
        """The unknown moments (monomials) the equations solve for."""
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
        return _rhs_jit(self.tables, self.tables.arrays, sde, m)

    def complete(self, sde: PolynomialSDE, m: Float[Array, " unknowns"]) -> dict[Monomial, Array]:
        """Every tabulated moment (unknowns, Gaussian block, closure) from the unknowns `m`."""
        full = _full_jit(self.tables, self.tables.arrays, sde, m)
        return {b: full[i] for i, b in enumerate(self.tables.monomials)}


def _equations_from_key(structure, order: int, extra) -> MomentEquations:
    from ._moment_cache import cached_tables

    return MomentEquations(cached_tables(structure, order, extra))


@filter_jit
def _rhs_jit(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, m):
    return _rhs(tables, arr, sde, m, _base_cumulants(tables, arr, sde))


@filter_jit
def _full_jit(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, m):
    return _full_moments(tables, arr, sde, m)[0]


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
    require_float64("jaxroll.theory.moment_equations")
    if not (isinstance(closure_order, int) and closure_order >= 2):
        raise ValueError(f"`closure_order` must be an integer >= 2; got {closure_order!r}.")
    from ._moment_cache import cached_tables  # the tables, generated once (memory, then disk when cached)

    extra = _extra_monomials(sde.dim, sde.symmetric)
    return MomentEquations(cached_tables(sde._structure(), closure_order, extra))


# ============================================================================================================
# Stationary moments: relax (diffrax Tsit5), polish (optimistix Newton), check
# ============================================================================================================
