"""The theories' design sensitivities: `jax.jacfwd` of Roberts', ESAM's, the moment method's and the envelope
FPK's roll statistics with respect to ship and sea parameters, beside the Monte Carlo's
(`jaxroll.monte_carlo_sensitivity`, docs/sensitivity.md)."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence

import jax
import jax.numpy as jnp

from .._compiled import SOLVER_PROGRAM, compiled_with
from .._config import require_float64
from ..laws._checks import error_line
from ._averaging import esam_pdf, roberts_pdf
from ._envelope_fpk import envelope_fpk_pdf
from ._moments import moment_pdf, moment_pdf_first_stable

SENSITIVITY_THEORIES = ("roberts", "esam", "moment", "envelope_fpk")


def _theory_statistics(law_env, law_zc, stats, e_phi2):
    """The theory's value of each statistic (radians), from its envelope and zero-crossing laws."""
    out = []
    for s in stats:
        if s == "E_phi2":
            out.append(e_phi2)
        elif s == "mean_envelope":
            out.append(law_env.mean())
        elif s == "mean_zero_crossing":
            out.append(law_zc.mean())
        else:
            zc = s.startswith("P_exceed_zc_")
            a = float(s[len("P_exceed_zc_" if zc else "P_exceed_") : -len("deg")])
            out.append((law_zc if zc else law_env).sf(jnp.deg2rad(a)))
    return jnp.stack(out)


def _moment_fit(problem, order: int):
    """The Monte Carlo's filter fit when it has the moment method's `order`, else None (the moment method fits its
    own: an `"auto"` Monte Carlo filter may be of order 6 or 8, a closure of 3–9× the moments)."""
    fit = problem.filter_fit
    return fit if fit is not None and fit.filter.order == order else None


def theory_sensitivities(
    problem_fn: Callable[[Mapping], object],
    params: Mapping[str, float],
    *,
    wrt: Sequence[str],
    statistics: Sequence[str],
    theories: Sequence[str] = SENSITIVITY_THEORIES,
    filter_order: int = 4,
) -> dict[str, dict]:
    """The theories' values of roll statistics and their derivatives with respect to parameters, by `jax.jacfwd`
    of each theory's amplitude laws at `problem_fn(params)` (the same wave and filter fit as the Monte Carlo's).

    **Arguments:**

    - `problem_fn`, `params`: as for `jaxroll.monte_carlo_sensitivity` (`jaxroll.sensitivity_problem` makes them):
      `problem_fn(q)` is a `RollProblem` built differentiably from the parameters `q`.
    - `wrt`: the parameters to differentiate with respect to (names of `params`).
    - `statistics`: "E_phi2" [rad²], "mean_envelope", "mean_zero_crossing" [rad], "P_exceed_<a>deg" (envelope
      law's `sf` at a°), "P_exceed_zc_<a>deg" (the zero-crossing law's) [-]. For the theories E[φ²] = E[A²]/2 of
      the envelope law (the moment method's own E[φ²]; the envelope FPK's ∫ a F̄(a) da by the trapezoid rule).
    - `theories`: any of "roberts" (nonlinear restoring), "esam", "moment", "envelope_fpk".
    - `filter_order`: the moment method's shaping filter (when `problem_fn` gives none). Its closure order is
      chosen once at the nominal parameters (the first stable of 6, 4) and held fixed while differentiating.

    **Returns:** per theory, `{"values": [per statistic], "gradients": [per statistic][per parameter],
    "details": {..., "time_s"}}` in the statistics' units (per unit of each parameter), or `{"error": message}`
    where the theory has no law at the nominal parameters.
    """
    require_float64("jaxroll.theory.theory_sensitivities")
    unknown = [n for n in theories if n not in SENSITIVITY_THEORIES]
    if unknown:
        raise ValueError(f"`theories`: unknown {unknown}; choose from {', '.join(SENSITIVITY_THEORIES)}.")
    need_zc = any(s == "mean_zero_crossing" or s.startswith("P_exceed_zc_") for s in statistics)
    out = {}
    for name in theories:
        t0 = time.time()
        details = {}
        try:
            if name == "moment":
                nominal = problem_fn(params)
                sol = moment_pdf_first_stable(
                    nominal.ship,
                    nominal.wave,
                    shaping_filter=_moment_fit(nominal, filter_order),
                    filter_order=filter_order,
                )
                details["closure_order"] = sol.closure_order

            def law(ship, wave, estimator, name=name, throw=False):
                if name == "envelope_fpk":
                    return envelope_fpk_pdf(ship, wave, estimator=estimator, throw=throw)
                if name == "roberts":
                    return roberts_pdf(ship, wave, estimator=estimator, restoring="nonlinear", throw=throw)
                return esam_pdf(ship, wave, estimator=estimator, throw=throw)

            def values(x, name=name):
                """(statistics, whether the laws exist) at parameters x. Roberts, ESAM and the envelope FPK are
                differentiated with throw=False (their existence returned and checked below: a traced check is a
                host callback, which keeps the program out of JAX's disk cache)."""
                q = {**params, **{p: x[i] for i, p in enumerate(wrt)}}
                prob = problem_fn(q)
                ship, wave = prob.ship, prob.wave
                if name == "moment":
                    kw = dict(shaping_filter=_moment_fit(prob, filter_order), filter_order=filter_order,
                              closure_order=details["closure_order"])  # fmt: skip
                    env = moment_pdf(ship, wave, estimator="envelope", **kw)
                    zc = moment_pdf(ship, wave, estimator="zero_crossing", **kw) if need_zc else env
                    return _theory_statistics(env, zc, statistics, env.e_phi2), jnp.array(True)
                env = law(ship, wave, "envelope")
                zc = law(ship, wave, "zero_crossing") if need_zc else env
                if name == "envelope_fpk":
                    lo, hi = env.support()
                    a = jnp.linspace(lo, hi, 4001)[:-1]  # F̄ = 0 at and beyond the top edge
                    e_phi2 = jnp.trapezoid(a * env.sf(a), a)  # E[A²]/2 = ∫ a F̄(a) da (φ = A cos ψ)
                else:
                    e_phi2 = env.moment(2.0) / 2  # φ = A cos ψ, ψ uniform
                return _theory_statistics(env, zc, statistics, e_phi2), env.exists & zc.exists

            x0 = jnp.asarray([params[p] for p in wrt])
            gradient = jax.jacfwd(lambda x: (lambda r: (r[0], r))(values(x)), has_aux=True)
            jac, (vals, exists) = compiled_with(gradient, (x0,), SOLVER_PROGRAM)(
                x0
            )  # run once: the solvers' options
            if not bool(exists):  # the law's own error, from a concrete call at the nominal parameters
                nominal = problem_fn(params)
                law(nominal.ship, nominal.wave, "envelope", throw=True)
                law(nominal.ship, nominal.wave, "zero_crossing", throw=True)
                raise ValueError(f"{name}: no amplitude law at the nominal parameters.")
            out[name] = {
                "values": [float(v) for v in vals],
                "gradients": [[float(jac[i, j]) for j in range(len(wrt))] for i in range(len(statistics))],
                "details": {**details, "time_s": time.time() - t0},
            }
        except (ValueError, RuntimeError) as e:
            out[name] = {"error": error_line(e)}
    return out
