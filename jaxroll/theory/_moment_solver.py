"""Moment method, stage 2: the stationary moments — relaxation in time (diffrax) then Newton (optimistix).

See `_moment_equations.py` for the equations and the closure."""

from __future__ import annotations

from collections.abc import Sequence

import diffrax as dfx
import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ._moment_equations import (
    MomentEquations,
    PolynomialSDE,
    _base_cumulants,
    _complete,
    _full_moments,
    _rhs,
    _Tables,
    moment_equations,
)


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


