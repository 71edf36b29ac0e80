"""Least-squares machinery shared by the calibration fits (optimistix Levenberg–Marquardt).

Results (`Estimate`, `LeastSquaresInfo`), the solve itself (`_least_squares`, also step by step for rough
Monte Carlo objectives), the covariances (Gauss–Newton s²(JᵀJ)⁻¹ and the cluster-robust sandwich; formulas:
docs/calibration.md), and the ship parameters a fit can set by name (`_PARAMS`, `_get_param`,
`_set_params`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from .._compiled import SOLVER_PROGRAM, cached_program, filter_jit
from ..laws._checks import error_line
from ..ship._ship import Ship

# ------------------------------------------------------------------------------------------------------------
# Results
# ------------------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Estimate:
    """A fitted value with its standard error (normal 95 % interval = value ± 1.96·SE), in SI units."""

    value: float
    std_error: float
    unit: str = "-"

    @property
    def ci95(self) -> tuple[float, float]:
        """The normal 95 % interval, value ± 1.96·SE (the value's unit)."""
        return (self.value - 1.959964 * self.std_error, self.value + 1.959964 * self.std_error)

    def to_dict(self) -> dict[str, Any]:
        """value, std_error, ci95 and unit as JSON-ready values."""
        return {"value": self.value, "std_error": self.std_error, "ci95": list(self.ci95), "unit": self.unit}


def _estimates(names, values, cov, units) -> dict[str, Estimate]:
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    return {n: Estimate(float(v), float(s), u) for n, v, s, u in zip(names, values, se, units)}


@dataclasses.dataclass(frozen=True)
class LeastSquaresInfo:
    """Diagnostics of one optimistix least-squares solve."""

    n_obs: int
    n_params: int
    rss: float
    sigma: float  # residual standard deviation s = √(RSS/(n − p)) in the residual's units
    num_steps: int
    result: str  # optimistix result message ("" when successful)
    condition_number: float

    @property
    def converged(self) -> bool:
        """Whether the solver reported success."""
        return self.result == ""

    def to_dict(self) -> dict[str, Any]:
        """The diagnostics as JSON-ready values."""
        return {**dataclasses.asdict(self), "converged": self.converged}


def estimates_dataset(
    estimates: dict,
    covariance=None,
    *,
    info: LeastSquaresInfo | None = None,
    residual_unit: str = "1",
    extra: dict | None = None,
    attrs: dict | None = None,
):
    """Fitted parameters as an `xarray.Dataset` on the dimension `parameter` (SI units, each in the coordinate
    `unit`): `estimate`, `std_error`, `ci95` (on `bound`), `covariance` on (`parameter`, `parameter_2`), the
    solver's diagnostics (`info`; `rss` and `sigma` in `residual_unit`²/`residual_unit`), and `extra` variables
    (`{name: (dims, values, units, long_name)}`)."""
    from .._labels import labelled_values

    names = list(estimates)
    e = [estimates[n] for n in names]
    p, pp = ("parameter",), ("parameter", "parameter_2")
    mixed = "mixed: the parameter's unit (unit)"
    out = {
        "estimate": (p, [x.value for x in e], mixed, "fitted value"),
        "std_error": (p, [x.std_error for x in e], mixed, "standard error"),
        "ci95": ((*p, "bound"), [list(x.ci95) for x in e], mixed, "95 % interval"),
    }
    if covariance is not None:
        out["covariance"] = (
            pp,
            np.asarray(covariance, dtype=float).reshape(len(names), len(names)),
            "mixed: the product of the two parameters' units (unit)",
            "covariance of the estimates",
        )
    if info is not None:
        for k, unit, long in (
            ("n_obs", "1", "residuals"),
            ("n_params", "1", "fitted parameters"),
            ("rss", _squared(residual_unit), "sum of squared residuals"),
            ("sigma", residual_unit, "residual standard deviation √(RSS/(n − p))"),
            ("num_steps", "1", "solver steps"),
            ("condition_number", "1", "condition number"),
            ("converged", "1", "whether the solver converged"),
        ):
            out[f"diagnostics_{k}"] = ((), getattr(info, k), unit, long)
    out.update(extra or {})
    coords = {
        "parameter": (p, names, None, "fitted parameter"),
        "parameter_2": (("parameter_2",), names, None, "fitted parameter (covariance column)"),
        "bound": (("bound",), ["lower", "upper"], None, "interval bound"),
        "unit": (p, [x.unit for x in e], None, "SI unit of the parameter"),
    }
    return labelled_values(out, coords=coords, attrs=attrs)


# ------------------------------------------------------------------------------------------------------------
# Levenberg–Marquardt and covariances
# ------------------------------------------------------------------------------------------------------------


def _residual_and_jacobian_impl(fn, theta, args):
    return fn(theta, args), jax.jacfwd(fn)(theta, args)


def _solve_impl(fn, theta0, args, max_steps, rtol, atol):
    """The solve, and at its end the residuals and their Jacobian: one program (one to load, not two)."""
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol = optx.least_squares(
        fn, solver, theta0, args, max_steps=max_steps, throw=False, options={"jac": "fwd"}
    )
    return sol.value, sol.result, sol.stats["num_steps"], *_residual_and_jacobian_impl(fn, sol.value, args)


_solve, _residual_and_jacobian = filter_jit(_solve_impl), filter_jit(_residual_and_jacobian_impl)
#: The solve kept between runs (`_least_squares(stored=True)`): a warm process loads it instead of tracing and
#: lowering it (the decay fits: ~2 s of a warm `jaxroll calibrate decay`).
_solve_stored = cached_program(compiler_options=SOLVER_PROGRAM)(_solve_impl)


class _WithAux(eqx.Module):
    fn: Any

    def __call__(self, y, args):
        return self.fn(y, args), None


_OPTIONS = {"jac": "fwd"}


@filter_jit
def _lm_init(solver, fn, y, args):
    f_struct, aux_struct = eqx.filter_eval_shape(fn, y, args)
    return solver.init(fn, y, args, _OPTIONS, f_struct, aux_struct, frozenset())


@filter_jit
def _lm_step(solver, fn, y, args, state):
    y, state, _ = solver.step(fn, y, args, _OPTIONS, state, frozenset())
    return y, state


def _solve_stepwise(fn, theta0, args, max_steps, rtol, atol, stall_steps):
    """Levenberg–Marquardt step by step (optimistix's own `step`), stopping also after `stall_steps` rejected
    proposals in a row: a Monte Carlo objective with common random numbers is rough below the scale of its
    statistical error, so near the optimum every proposal can look worse and the trust region shrinks
    forever."""
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    fn = _WithAux(fn)
    y = theta0
    state = _lm_init(solver, fn, y, args)
    message = "the maximum number of steps was reached; increase `max_steps`"
    steps = 0
    for steps in range(1, max_steps + 1):
        y, state = _lm_step(solver, fn, y, args, state)
        if bool(state.terminate):
            message = "" if state.result == optx.RESULTS.successful else str(optx.RESULTS[state.result])
            break
        if int(state.num_steps_since_acceptance) >= stall_steps:
            message = ""  # converged to the resolution of the objective
            break
    return y, message, steps


class FitFailure(ValueError):
    """A fit whose model could not be evaluated (its ODE solver failed): the message says what to check."""


#: What to check when the roll equation fails inside a fit.
SOLVER_HINT = (
    "Usually the record is not what the model can reproduce: check the roll unit (degrees labelled rad?), that "
    "the roll stays well below the ship's angle of vanishing stability, and the ship's roll period; or start "
    "the fit closer (initial damping)."
)


def _least_squares(
    fn,
    theta0,
    args,
    *,
    max_steps=200,
    rtol=1e-8,
    atol=1e-10,
    stall_steps=None,
    hint=SOLVER_HINT,
    stored=False,
):
    """Levenberg–Marquardt (optimistix, forward-mode Jacobian); returns θ̂, J(θ̂), residuals, info.

    **Raises:** `FitFailure` (a `ValueError`, so the command line prints it and exits 2) when the model's ODE
    solver fails during the fit (an `EquinoxRuntimeError`, or residuals that are not finite where the fit ends),
    with `hint` saying what to check.

    `fn(theta, args)` should be a module-level function (or an `eqx.Module`) so that its compilation is reused
    between calls. With `stall_steps`, the solve also stops after that many rejected steps in a row. `stored`:
    the solve (and the final Jacobian) runs as a stored program (`_compiled.cached_program`), for an `fn` without
    host callbacks whose static arguments (non-array leaves of `args`) do not change from one data set to the
    next (they key the program: pass numbers that vary as arrays)."""
    theta0 = jnp.asarray(theta0, dtype=float)
    try:
        if stall_steps is None:
            solve = _solve_stored if stored else _solve
            theta, result, steps, res, jac = solve(fn, theta0, args, max_steps, rtol, atol)
            msg = "" if result == optx.RESULTS.successful else str(optx.RESULTS[result])
        else:
            theta, msg, steps = _solve_stepwise(fn, theta0, args, max_steps, rtol, atol, stall_steps)
            res, jac = _residual_and_jacobian(fn, theta, args)
    except eqx.EquinoxRuntimeError as e:
        raise FitFailure(
            f"the roll equation could not be integrated during the fit ({error_line(e)}). {hint}"
        ) from None
    r = np.asarray(res, dtype=float)
    j = np.asarray(jac, dtype=float).reshape(r.size, -1)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(j))):  # a model that returns NaN where it fails
        raise FitFailure(
            "the roll equation could not be integrated during the fit (its residuals are not finite where the "
            f"fit ends). {hint}"
        )
    n, p = j.shape
    rss = float(r @ r)
    sv = np.linalg.svd(j, compute_uv=False)
    info = LeastSquaresInfo(
        n,
        p,
        rss,
        math.sqrt(rss / max(n - p, 1)),
        int(steps),
        msg,
        float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf"),
    )
    return np.asarray(theta, dtype=float), j, r, info


def _gauss_newton_covariance(j: np.ndarray, sigma: float) -> np.ndarray:
    return sigma**2 * np.linalg.pinv(j.T @ j)


def _sandwich(j: np.ndarray, r: np.ndarray, clusters: np.ndarray) -> np.ndarray:
    """Cluster-robust covariance (JᵀJ)⁻¹ [Σ_c (J_cᵀ r_c)(J_cᵀ r_c)ᵀ] (JᵀJ)⁻¹ · G/(G − 1)."""
    bread = np.linalg.pinv(j.T @ j)
    ids = np.unique(clusters)
    scores = np.stack([j[clusters == c].T @ r[clusters == c] for c in ids])
    g = ids.size
    return bread @ (scores.T @ scores) @ bread * (g / max(g - 1, 1))


# ------------------------------------------------------------------------------------------------------------
# Ship parameters a fit can set, by name
# ------------------------------------------------------------------------------------------------------------

_PARAMS = {
    "gm_correction": ("gm_correction", None, "-"),
    "b1": ("damping", 0, "1/s"),
    "b2": ("damping", 1, "1/rad"),
    "b3": ("damping", 2, "s/rad^2"),
}


def _get_param(ship: Ship, name: str):
    attr, idx, _ = _PARAMS[name]
    v = getattr(ship, attr)
    return v if idx is None else v[idx]


def _set_params(ship: Ship, names: Sequence[str], values) -> Ship:
    for name, v in zip(names, values):
        attr, idx, _ = _PARAMS[name]
        if idx is None:
            ship = eqx.tree_at(lambda s: getattr(s, attr), ship, jnp.asarray(v, dtype=float))
        else:
            ship = eqx.tree_at(lambda s: getattr(s, attr), ship, getattr(ship, attr).at[idx].set(v))
    return ship


def _squared(unit: str) -> str:
    """A UDUNITS unit squared (`"rad"` → `"rad2"`, `"1"` → `"1"`)."""
    return "1" if unit == "1" else " ".join(f"{u}2" if u.isalpha() else u for u in unit.split())
