"""Moment method, stage 2: the stationary moments — relaxation in time (diffrax) then Newton (optimistix).

See `_moment_equations.py` for the equations and the closure."""

from __future__ import annotations

import contextlib
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from .._compiled import SOLVER_PROGRAM, cached_program, is_concrete
from .._config import require_float64
from ._moment_equations import (
    MomentEquations,
    PolynomialSDE,
    _base_cumulants,
    _complete,
    _full_moments,
    _TableArrays,
    _Tables,
    moment_equations,
)
from ._moment_jacobian import rhs_with_fast_jacobian


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
    roll_not_sustained = (
        "no stationary law: the roll dies out (the linearised roll under the coloured excitation has a Lyapunov "
        "exponent <= 0, so A → 0 almost surely; a non-trivial fixed point of the closed moment equations there is "
        "the closure's artefact). Increase H1/3 or r, or reduce b1."
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
        """Whether the solve succeeded."""
        return self.result == RESULTS.successful


def _gaussian_start(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, variances):
    """Unknown moments of independent zero-mean Gaussians of `variances` (× the Gaussian block's own law)."""
    k = _base_cumulants(tables, arr, sde)
    for i in range(tables.dim):
        if i in sde.gaussian:
            continue
        mono = tuple(2 if j == i else 0 for j in range(tables.dim))
        if mono in tables.index:
            k = k.at[tables.index[mono]].set(variances[i])
    m = jnp.zeros(len(tables.monomials)).at[0].set(1.0)
    full, _ = _complete(tables, arr, m, k, np.zeros(len(tables.monomials), bool))
    return full[arr.unknowns]


def _lift(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, low: _Tables, low_full):
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
    full, _ = _complete(tables, arr, m, _base_cumulants(tables, arr, sde), given)
    return full[arr.unknowns]


def _scales(tables: _Tables, arr: _TableArrays, sde: PolynomialSDE, m_start):
    """Per-unknown magnitude Π σ_i^{β_i} (σ_i² = the start's E[x_i²] or the Gaussian block's variance)."""
    full, _ = _full_moments(tables, arr, sde, m_start)
    sig = []
    for i in range(tables.dim):
        mono = tuple(2 if j == i else 0 for j in range(tables.dim))
        sig.append(jnp.sqrt(jnp.abs(full[tables.index[mono]])) if mono in tables.index else jnp.ones(()))
    sig = jnp.stack(sig)
    expo = np.array([tables.monomials[i] for i in tables.unknowns], float)
    return jnp.exp(expo @ jnp.log(jnp.maximum(sig, 1e-300)))


def _newton_start_ok(result, y1, y0, jac, lead_pos):
    """Newton from a start converged to a usable point: finite, bounded, non-trivial (E[x0²] kept), and on the
    stable side of a fold (sign det J = (−1)^n, which every stable fixed point has)."""
    sign, _ = jnp.linalg.slogdet(jac)
    return (
        (result == optx.RESULTS.successful)
        & jnp.all(jnp.isfinite(y1))
        & (jnp.max(jnp.abs(y1)) < 1e6)
        & (jnp.abs(y1[lead_pos]) > 1e-8 * jnp.abs(y0[lead_pos]))
        & (sign == (-1.0) ** y1.size)
    )


def _solve_impl(
    tables: _Tables,
    arr: _TableArrays,
    sde: PolynomialSDE,
    start,
    time_scale,
    relax_periods: float,
    lead: int,
    tol_relax: float,
    relax_fallback: bool = True,
):
    """Relax (diffrax Tsit5) → Newton (optimistix) → checks, all in one compiled program per structure."""
    kind, data = start
    sde_c = jax.lax.stop_gradient(sde)
    if kind == "gaussian":
        m_start = _gaussian_start(tables, arr, sde_c, jax.lax.stop_gradient(data))
    elif kind == "guess":  # the unknowns themselves (continuation along a branch)
        m_start = jax.lax.stop_gradient(data)
    else:
        low_tables, low_full = data
        m_start = _lift(tables, arr, sde_c, low_tables, jax.lax.stop_gradient(low_full))
    base_kappa = _base_cumulants(tables, arr, sde)
    kappa_c = jax.lax.stop_gradient(base_kappa)
    scale = _scales(tables, arr, sde_c, m_start)
    y0 = m_start / scale
    tau = time_scale

    rhs = rhs_with_fast_jacobian(tables)

    def fn(y, args):
        s, kap = args
        return rhs(y * scale, s, kap, arr) / scale * tau

    def steady(t, y, args, **kwargs):
        return jnp.max(jnp.abs(fn(y, args))) < tol_relax * jnp.maximum(jnp.max(jnp.abs(y)), 1e-30)

    def blowup(t, y, args, **kwargs):
        return ~(jnp.max(jnp.abs(y)) < 1e6)

    lead_pos = _unknown_pos(tables, tuple(2 if j == lead else 0 for j in range(tables.dim)))

    def decayed(t, y, args, **kwargs):  # E[x0²] fell by 10⁶ (15° r.m.s. → 0.015°): the roll dies out
        return jnp.abs(y[lead_pos]) < 1e-6 * jnp.abs(y0[lead_pos])

    def relax(y_start):
        import diffrax as dfx  # imported here: a stored program (the `jaxroll` command) never needs it

        sol = dfx.diffeqsolve(
            dfx.ODETerm(lambda t, y, args: fn(y, args)),
            dfx.Tsit5(),
            0.0,
            relax_periods,  # a Python float: a traced end time would put a host callback in the program
            0.05,
            y_start,
            args=(sde_c, kappa_c),
            # dtmin stops a finite-time blow-up of the closed equations instead of shrinking steps for ever
            stepsize_controller=dfx.PIDController(rtol=1e-6, atol=1e-9, dtmin=1e-5),
            event=dfx.Event((steady, blowup, decayed)),
            saveat=dfx.SaveAt(t1=True),
            max_steps=20_000,
            throw=False,
        )
        y = sol.ys[0]
        # reaching t1, a (steady-state or blow-up) event or max_steps is fine if the state is finite and
        # bounded; dt_min_reached (finite-time blow-up) or non-finite values are not
        ok = (
            (
                (sol.result == dfx.RESULTS.successful)
                | (sol.result == dfx.RESULTS.event_occurred)
                | (sol.result == dfx.RESULTS.max_steps_reached)
            )
            & jnp.all(jnp.isfinite(y))
            & (jnp.max(jnp.abs(y)) < 1e6)
        )
        return jnp.where(ok, y, y_start), ok, jnp.asarray(sol.stats["num_steps"]).astype(jnp.array(0).dtype)

    newton = optx.Newton(rtol=1e-11, atol=1e-13, linear_solver=lx.LU())
    jac = None
    if not relax_fallback:
        # Newton from the start only (a lower order's solution lifted, the neighbouring point of a branch, or the
        # Gaussian start, from which Newton finds the relaxation's fixed point in 19 of 21 points of the default
        # ship's map, the two without a stationary law excepted: `GAUSSIAN_START_DEG`, docs/theory.md): one root
        # find, whose value must also pass the start checks below; where it fails the caller runs the relaxation's
        # program.
        root = optx.root_find(fn, newton, y0, args=(sde, base_kappa), max_steps=30, throw=False)
        y1 = jax.lax.stop_gradient(root.value)
        jac = jax.jacfwd(fn)(y1, (sde_c, kappa_c))
        first_ok = _newton_start_ok(root.result, y1, y0, jac, lead_pos)
        y_relaxed, relaxed_ok, n_relax = jnp.where(first_ok, y1, y0), first_ok, jnp.array(0)
    else:
        # Newton straight from the start (lifted, Gaussian or a guess); the relaxation runs only if that fails or
        # lands on the unstable side of a fold (the sign of det J flips where one real eigenvalue crosses zero).
        # Same fixed point, ~100x less work at order 6.
        first = optx.root_find(fn, newton, y0, args=(sde_c, kappa_c), max_steps=30, throw=False)
        y1 = first.value
        first_ok = _newton_start_ok(first.result, y1, y0, jax.jacfwd(fn)(y1, (sde_c, kappa_c)), lead_pos)

        # The relaxation as a loop that runs at most once, while it is needed, rather than a `lax.cond`: vmapped
        # (a sweep over sea states or ships), a cond runs both branches for every member, so every member paid
        # for the relaxation; a loop runs it only when some member's Newton failed (unbatched, the two are the
        # same). It relaxes the loop's own carry, not `y0` directly: XLA hoists loop-invariant work out of a loop,
        # and would then run the relaxation before it, always. The start is a start only (the derivative comes
        # from the root find below), so reverse mode passes the loop.
        def relax_once(carry):
            return (jnp.array(False), *relax(carry[1]))

        _, y_loop, relaxed_ok, n_relax = jax.lax.while_loop(
            lambda carry: carry[0], relax_once, (~first_ok, y0, jnp.array(True), jnp.array(0))
        )
        y_relaxed = jnp.where(first_ok, jax.lax.stop_gradient(y1), y_loop)
        root = optx.root_find(fn, newton, y_relaxed, args=(sde, base_kappa), max_steps=60, throw=False)
    values = root.value * scale
    full, _ = _full_moments(tables, arr, sde, values, base_kappa)
    y_c = jax.lax.stop_gradient(root.value)
    residual = jnp.max(jnp.abs(fn(y_c, (sde_c, kappa_c))))
    if jac is None:
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
    # The roll dies out in the moment equations where they relax to the trivial state, or where Newton lands on it
    # and it is stable; Newton on an unstable trivial state (the roll grows, e.g. with no quadratic or cubic
    # damping to bound it) is no stationary solution, not a dying roll: the closure failed.
    dies = ((jnp.abs(values[lead_pos]) / start_lead < 1e-8) & (max_re < 0)) | (
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
    return values, full, residual, max_re, n_relax, root.stats["num_steps"], result


_INPUT_TABLES: dict[int, tuple[_Tables, _TableArrays]] = {}


@contextlib.contextmanager
def tables_as_inputs(tables: Sequence[_Tables], arrays: Sequence[_TableArrays]):
    """While a program that takes `arrays` (the `tables`' arrays, traced) as inputs is traced: solve with them
    instead of the tables' own NumPy arrays, which would be embedded in the program as constants (megabytes)."""
    saved = dict(_INPUT_TABLES)
    _INPUT_TABLES.update({id(t): (t, a) for t, a in zip(tables, arrays, strict=True)})
    try:
        yield
    finally:
        _INPUT_TABLES.clear()
        _INPUT_TABLES.update(saved)


def _table_arrays(tables: _Tables) -> _TableArrays:
    hit = _INPUT_TABLES.get(id(tables))
    return hit[1] if hit is not None and hit[0] is tables else tables.arrays


# One compiled program per structure; with JAX's persistent cache on (the `jaxroll` command), a concrete call runs
# the program stored on disk by `cached_program` (no Python tracing in a new process); traced calls are jitted. The
# same XLA options as the named theories' solver program (`jaxroll.theory._named`).
_solve = cached_program(compiler_options=SOLVER_PROGRAM)(_solve_impl)


def raise_if_failed(result, x):
    """`x`, or raise `EquinoxRuntimeError` with the result's message when `result` is not successful.

    Concrete results are checked in Python (an eager `error_if` compiles a host-callback kernel that JAX cannot
    cache on disk: ~2 s per call in a new process); traced ones through `error_if` as usual.
    """
    if is_concrete(result):
        if not succeeded(result):
            raise eqx.EquinoxRuntimeError(RESULTS[result])
        return x
    return result.error_if(x, result != RESULTS.successful)


def succeeded(result) -> bool:
    """True when the concrete `RESULTS` item `result` is `successful` (read on the host: no compiled comparison)."""
    return RESULTS[result] == RESULTS[RESULTS.successful]


def _concrete_ratio(relax_time, time_scale) -> float:
    """relax_time / time_scale as a Python float (the relaxation's end time is static)."""
    try:
        return float(jnp.asarray(relax_time, dtype=float) / jax.lax.stop_gradient(time_scale))
    except jax.errors.ConcretizationTypeError:
        raise ValueError(
            "`relax_time` and `time_scale` must be concrete numbers when `relax_time` is given."
        ) from None


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

    Optimistix Newton straight from the start first (concrete calls: a program without the relaxation); where
    that fails, the moment ODEs are relaxed in time with diffrax (Tsit5, adaptive) from the non-trivial start
    until the relative rate of change per `time_scale` drops below `tol_relax` (or `relax_time` passes), then
    polished with Newton to a residual ~1e-13 (from the Gaussian start Newton alone reaches the relaxation's
    fixed point in 19 of 21 points of the default ship's map, docs/theory.md). The fixed point must
    have every Jacobian eigenvalue in the left half plane and E[x_i²] > 0, E[x_i⁴] ≥ E[x_i²]² for every
    non-Gaussian-block variable.

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
    require_float64("jaxroll.theory.stationary_moments")
    eqs = moment_equations(sde, closure_order)
    tables = eqs.tables
    if isinstance(initial, tuple) and initial[0] == "guess":  # continuation: Newton from these unknowns only
        start, relax_fallback = initial, False
    elif isinstance(initial, tuple) and initial[0] == "lift-newton":  # Newton from the lifted start only
        low = initial[1]
        if low.equations.tables.dim != sde.dim:
            raise ValueError("`initial` belongs to a system of another dimension.")
        start, relax_fallback = ("lift", (low.equations.tables, low.full)), False
    elif (
        isinstance(initial, tuple) and initial[0] == "gaussian-newton"
    ):  # Newton from the Gaussian start only
        v = jnp.asarray(initial[1], dtype=float)
        start, relax_fallback = ("gaussian", v), False
    elif initial is not None:
        if initial.equations.tables.dim != sde.dim:
            raise ValueError("`initial` belongs to a system of another dimension.")
        start, relax_fallback = ("lift", (initial.equations.tables, initial.full)), True
    else:
        if initial_variances is None:
            raise ValueError(
                "give `initial` (a lower-order solution) or `initial_variances` (one per variable)."
            )
        v = jnp.asarray(initial_variances, dtype=float)
        if v.shape != (sde.dim,):
            raise ValueError(f"`initial_variances` must have shape ({sde.dim},); got {v.shape}.")
        start, relax_fallback = ("gaussian", v), True
    time_scale = jnp.asarray(time_scale, dtype=float)
    relax_periods = 400.0 if relax_time is None else _concrete_ratio(relax_time, time_scale)
    lead = next(i for i in range(sde.dim) if i not in sde.gaussian)
    config = (relax_periods, lead, float(tol_relax))
    if start[0] in ("lift", "gaussian") and relax_fallback and is_concrete((sde, start, time_scale)):
        # Newton from the start in a program without the relaxation (smaller: faster to compile and to load);
        # the relaxation only where that fails: the same numbers as the single program (traced calls), which
        # takes its relaxation branch only when that Newton fails.
        solved = _solve(tables, tables.arrays, sde, start, time_scale, *config, False)
        if not succeeded(solved[-1]):
            solved = _solve(tables, tables.arrays, sde, start, time_scale, *config, True)
    else:
        solved = _solve(tables, _table_arrays(tables), sde, start, time_scale, *config, relax_fallback)
    values, full, residual, max_re, n_relax, n_newton, result = solved
    if throw:
        values = raise_if_failed(result, values)
    return StationaryMoments(values, full, residual, max_re, n_relax, n_newton, result, eqs)


def continue_moments(
    sde: PolynomialSDE, guess: Float[Array, " unknowns"], *, closure_order: int, time_scale
) -> StationaryMoments:
    """Newton (no relaxation) from `guess`, the unknown moments of a neighbouring point of the same branch.

    For continuation along a branch of fixed points (`moment_branch`): the result is not successful when Newton
    fails, lands on the unstable side of a fold, or the fixed point is unstable or non-physical. Never raises.
    """
    return stationary_moments(
        sde,
        closure_order=closure_order,
        initial=("guess", jnp.asarray(guess, dtype=float)),
        time_scale=time_scale,
        throw=False,
    )
