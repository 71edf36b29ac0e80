"""The theories by name, each in one compiled program: its amplitude law and the numbers of its summary.

`theory_law`, `theory_summary` and `iter_theory_summaries` (several theories at once, run concurrently) are what
the command line calls (`jaxroll theory`, `pdf`, `maxima`, `risk`): the theory's whole numeric work for one sea
state — the law and, for a summary, its mean, quantiles and CDF on the bins — is one program
(`jaxroll._compiled.cached_program`). With JAX's persistent compilation cache on (the
`jaxroll` command turns it on) a new process loads that program from disk instead of tracing and lowering the
dozens of jitted functions behind it (Roberts and ESAM asked for together are one program: `_averaging_program`).
The laws are those of the named public functions, with the same numbers:

- `"roberts"`: `roberts_pdf(ship, wave, restoring="nonlinear")`;
- `"esam"`: `esam_pdf(ship, wave)`;
- `"moment"`: `moment_pdf_first_stable(ship, wave, shaping_filter=…, filter_order=…)` (closure order 6, order 4
  where 6 has no stable fixed point, with its warning; the order is recorded in `details()`);
- `"envelope_fpk"`: `envelope_fpk_pdf(ship, wave)`.

They raise the same errors as those functions when no law exists.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import functools
import threading
from collections.abc import Callable, Iterator

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike

from .._compiled import SMALL_PROGRAM, SOLVER_PROGRAM, cached_program, is_concrete
from .._config import require_float64
from ..laws._abstract import (
    QUANTILE_LEVELS,
    SAMPLING,
    AbstractAmplitudeLaw,
    _bracket_targets,
    _expected_in,
    _solve_levels,
    check_estimator,
)
from ..sea._filters import FilterFit, ShapingFilter, fitted_form
from ..ship._restoring_surface import restoring_surface_refusal
from ..ship._ship import Ship
from ..ship._validity import warn_outside_validity
from ._averaging import _finish, esam_pdf, roberts_pdf
from ._envelope_fpk import dies_out_error, envelope_fpk_pdf
from ._linear import moment_joins, refuse_wave_moment, wave_moment_refusal
from ._moment_equations import _roll_sde, moment_equations, zero_pattern
from ._moment_solver import RESULTS, succeeded, tables_as_inputs
from ._moments import (
    GAUSSIAN_START_DEG,
    _moment_pdf,
    _shaping_filter,
    closure_sequence,
    moment_pdf_first_stable,
    roll_not_sustained_error,
    sustained_roll_exponent,
    warn_closure_fallback,
    with_requested_order,
)

THEORIES = ("roberts", "esam", "moment", "envelope_fpk")
MOMENT_CLOSURE_ORDERS = (
    6,
    4,
)  # the moment method's closure orders, tried in turn (`moment_pdf_first_stable`)


def _law(name, ship, wave, sde, filter_order, estimator, closure_order, lift_relax):
    """Theory `name`'s law, never raising (the existence checks are made on the host by `_check`). `sde`: the
    moment method's roll SDE (with the concrete ship's structure, `_program`)."""
    if name == "roberts":
        return roberts_pdf(ship, wave, restoring="nonlinear", estimator=estimator, throw=False)
    if name == "esam":
        return esam_pdf(ship, wave, estimator=estimator, throw=False)
    if name == "moment":
        return _moment_pdf(
            ship, wave, None, estimator, filter_order, closure_order, "cubic", "phase_averaged", GAUSSIAN_START_DEG,
            False,
            lift_relax=lift_relax, sde=sde,
        )  # fmt: skip
    return envelope_fpk_pdf(ship, wave, estimator=estimator, throw=False)


def _program(name, ship, wave, moment, estimator, closure_order, lift_relax, arrays, edges, levels):
    """The law and, with `edges` [rad], (mean [rad], quantiles at `levels` [rad], CDF at `edges`, F̄(edges[-1])):
    the numbers `AbstractAmplitudeLaw.summary` computes, in the same program as the law. Moment method:
    `moment = (shaping filter, zero_pattern(ship, filter), filter order)`, `arrays` the arrays of the moment
    equations' tables for the orders `closure_sequence(closure_order)` (inputs, not constants)."""
    sde, tables = None, []
    if moment is not None:
        sde = _roll_sde(ship, moment[0], "cubic", moment[1])
        tables = [moment_equations(sde, k).tables for k in closure_sequence(closure_order)]
    with tables_as_inputs(tables, arrays):
        law = _law(
            name, ship, wave, sde, 0 if moment is None else moment[2], estimator, closure_order, lift_relax
        )
    if edges is None:
        return law, None
    return law, _summary_numbers(law, edges, levels)


_solver_program = cached_program(compiler_options=SOLVER_PROGRAM)(_program)  # moment method, envelope FPK
_small_program = cached_program(compiler_options=SMALL_PROGRAM)(_program)  # Roberts, ESAM: milliseconds
_SMALL = ("roberts", "esam")


@cached_program(compiler_options=SMALL_PROGRAM)
def _averaging_program(ship, wave, estimator, edges, levels):
    """Roberts' and ESAM's laws and their summary numbers (stacked: [2, …], in `_SMALL`'s order) in one program,
    for a caller that asks for both (`jaxroll theory`, `jaxroll pdf`): both are `AveragedAmplitudeLaw` tables of one
    shape, so the summary is traced once and vmapped over the two — one program to trace and compile on a cold run
    instead of two (≈ 0.8 s of CPU), with the numbers of `_program` (tests/test_averaging.py)."""
    laws = tuple(_law(name, ship, wave, None, 0, estimator, 0, True) for name in _SMALL)
    tables = [
        dataclasses.replace(law, parameters={}, method="") for law in laws
    ]  # the summary needs the table only
    stacked = jax.tree.map(lambda *x: jnp.stack(x), *tables)
    return laws, jax.vmap(lambda law: _summary_numbers(law, edges, levels))(stacked)


def _summary_numbers(law, edges, levels):
    """(mean [rad], quantiles at `levels` [rad], CDF at `edges`, F̄(edges[-1])): `law.mean()`, `law.quantile`,
    `law.cdf`, `law.sf`, with the levels the mean's integral is bracketed by and the quantile levels solved in
    one vectorised root search (the same numbers, one copy of the search in the compiled program instead of
    two: a smaller program, faster to compile and to load)."""
    q = jnp.asarray(levels, dtype=float)  # checked on the host (`law.quantile` would check it in the program)
    log_c, log_s = jnp.log(q), jnp.log1p(-q)
    if (
        type(law).mean is AbstractAmplitudeLaw.mean
    ):  # `_expected_maximum(law, 1, 256)`, its bracket solved here
        one = jnp.asarray(1.0)
        bracket_c, bracket_s = _bracket_targets(one)
        x = _solve_levels(
            law, jnp.concatenate([bracket_c[2:], log_c]), jnp.concatenate([bracket_s[2:], log_s])
        )
        mean, quantiles = _expected_in(law, one, x[0], x[1], 256), x[2:]
    else:  # a law with its own mean (the envelope FPK's, exact)
        mean, quantiles = law.mean(), _solve_levels(law, log_c, log_s)
    return mean, quantiles, law.cdf(edges), law.sf(edges[-1])


def _check(name: str, law) -> None:
    """Raise the error of the named public function when `law` does not exist (concrete laws)."""
    if name in ("roberts", "esam"):
        _finish(law, True)
    elif name == "envelope_fpk":
        if not bool(law.exists):
            raise dies_out_error(law.lyapunov_exponent, law.excitation)
    elif not succeeded(law.result):
        raise eqx.EquinoxRuntimeError(RESULTS[law.result])


def _filter(shaping_filter) -> ShapingFilter | concurrent.futures.Future | None:
    if isinstance(shaping_filter, FilterFit):
        return shaping_filter.filter
    if shaping_filter is not None and not isinstance(
        shaping_filter, (ShapingFilter, concurrent.futures.Future)
    ):
        raise TypeError(
            f"`shaping_filter` must be a ShapingFilter or FilterFit; got {type(shaping_filter).__name__}."
        )
    return shaping_filter


def _start(
    name, ship, wave, shaping_filter, filter_order, estimator, edges, levels, warn=True, traced=None
) -> Callable:
    """Dispatch theory `name`'s program (JAX runs it asynchronously) and return `finish() -> (law, numbers)`, which
    waits for it and makes the checks of the named public function (the moment method: Newton only, from the
    Gaussian start at order 4 and the lifted order-4 solution at order 6; its fallbacks, each a program of its own:
    the relaxation's variant where that fails, then order 4 the same way)."""
    if name != "moment":
        program = _small_program if name in _SMALL else _solver_program
        law, numbers = program(name, ship, wave, None, estimator, 0, True, (), edges, levels)

        def finish():
            _check(name, law)
            return law, numbers

        return finish
    # The λ gate's program (a small one) is traced and compiled beside the law's, not after it.
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="jaxroll-theory-gate")
    if isinstance(shaping_filter, concurrent.futures.Future):
        # The fit is being made elsewhere: meanwhile, trace and compile the first program and the gate's for the
        # form every fit of this order has (`fitted_form`: the fit's shapes and zero coefficients), which the
        # fitted filter's calls then run. `traced` is set once the tracing (which holds the GIL) is done.
        try:
            form = fitted_form(filter_order)
            args = _moment_arguments(ship, wave, form, filter_order, estimator, edges, levels)(
                MOMENT_CLOSURE_ORDERS[0], False)  # fmt: skip
            _solver_program.prepare(*args, compile=False)
        finally:
            if traced is not None:
                traced.set()
        pool.submit(_sustained_program.prepare, ship, form)
        _solver_program.prepare(*args)
        shaping_filter = _filter(shaping_filter.result())
    filt = _shaping_filter(ship, wave, shaping_filter, filter_order)
    arguments = _moment_arguments(ship, wave, filt, filter_order, estimator, edges, levels)

    def run(order, lift_relax):
        return _solver_program(*arguments(order, lift_relax))

    gate = pool.submit(_sustained_program, ship, filt)
    pool.shutdown(wait=False)
    first = run(MOMENT_CLOSURE_ORDERS[0], False)

    def finish():
        error = None
        for i, order in enumerate(MOMENT_CLOSURE_ORDERS):
            law, numbers = first if i == 0 else run(order, False)
            if not succeeded(law.result):  # Newton from the Gaussian or the lifted start failed: relax
                law, numbers = run(order, True)
            if succeeded(law.result):
                law = with_requested_order(law, MOMENT_CLOSURE_ORDERS[0], error)
                lam = gate.result()  # as `moment_pdf_first_stable`: no law where the roll dies out
                if not float(lam) > 0:
                    raise roll_not_sustained_error(lam, law)
                if i > 0 and warn:
                    warn_closure_fallback(MOMENT_CLOSURE_ORDERS[0], error, order, stacklevel=3)
                return law, numbers
            error = eqx.EquinoxRuntimeError(RESULTS[law.result])
        raise error

    return finish


def _start_averaging(ship, wave, estimator, edges, levels) -> dict[str, Callable]:
    """`_start` for Roberts and ESAM together (`_averaging_program`): `{name: finish}`."""
    laws, numbers = _averaging_program(ship, wave, estimator, edges, levels)

    def finish(i):
        _check(_SMALL[i], laws[i])
        return laws[i], tuple(np.asarray(x)[i] for x in numbers)

    return {name: functools.partial(finish, i) for i, name in enumerate(_SMALL)}


def _moment_arguments(ship, wave, filt, filter_order, estimator, edges, levels) -> Callable:
    """`arguments(closure_order, lift_relax)`: the moment method's `_program` arguments for the filter `filt`. The
    program builds the SDE with the terms `roll_sde` keeps for the concrete ship and filter (traced ones would keep
    the zero terms too: a larger system); its structure is known here without computing it (`eval_shape`)."""
    moment = (filt, zero_pattern(ship, filt), int(filter_order))
    sde = jax.eval_shape(lambda s, f: _roll_sde(s, f, "cubic", moment[1]), ship, filt)

    def arguments(order, lift_relax):
        arrays = tuple(moment_equations(sde, k).tables.arrays for k in closure_sequence(order))
        return "moment", ship, wave, moment, estimator, order, lift_relax, arrays, edges, levels

    return arguments


@cached_program(compiler_options=SMALL_PROGRAM)
def _sustained_program(ship, shaping_filter):
    """`sustained_roll_exponent(ship, None, shaping_filter)` [1/s] as a stored program."""
    return sustained_roll_exponent(ship, None, shaping_filter)


def _check_name(name: str) -> None:
    if name not in THEORIES:
        raise ValueError(f"unknown theory {name!r}; choose from {', '.join(THEORIES)}.")


def theory_law(
    name: str,
    ship: Ship,
    wave,
    *,
    shaping_filter: ShapingFilter | FilterFit | None = None,
    filter_order: int = 4,
    estimator: str = "envelope",
    warn: bool = True,
) -> AbstractAmplitudeLaw:
    """The amplitude law [rad] of theory `name` (one of `THEORIES`) for `ship` in `wave`, in one compiled program.

    **Arguments:** `ship`; `wave`: Grim's effective wave (`problem.wave`); `shaping_filter` (moment method only):
    the Monte Carlo's filter (`problem.filter_fit`), else `wave` is fitted with `filter_order` at 2ω0;
    `estimator`: `"envelope"` (time-sampled) or `"zero_crossing"` (per half cycle, for maxima and risk);
    `warn=False`: no `UserWarning` for the moment method's closure fallback (`law.details()` records it).

    **Returns:** the law of the named public function (module docstring), with the same numbers.

    **Raises:** that function's error when no law exists (`ValueError`, or `EquinoxRuntimeError` for the moment
    method); a `UserWarning` when the moment method falls back to closure order 4 (unless `warn=False`). Under
    `jax.jit`, `grad` or `vmap` the public function itself is called (it is the same computation).
    """
    refuse_wave_moment(ship, wave, name)
    require_float64("jaxroll.theory.theory_law")
    _check_name(name)
    check_estimator(estimator)
    shaping_filter = _filter(shaping_filter)
    if not is_concrete((ship, wave, shaping_filter)):
        return _traced(name, ship, wave, shaping_filter, filter_order, estimator)
    warn_outside_validity(ship, wave, (name,))
    return _start(name, ship, wave, shaping_filter, filter_order, estimator, None, (), warn=warn)()[0]


def _traced(name, ship, wave, shaping_filter, filter_order, estimator):
    if name == "roberts":
        return roberts_pdf(ship, wave, restoring="nonlinear", estimator=estimator)
    if name == "esam":
        return esam_pdf(ship, wave, estimator=estimator)
    if name == "moment":
        return moment_pdf_first_stable(
            ship, wave, shaping_filter=shaping_filter, filter_order=filter_order, estimator=estimator
        )
    return envelope_fpk_pdf(ship, wave, estimator=estimator)


def theory_summary(
    name: str,
    ship: Ship,
    wave,
    bins_deg: ArrayLike,
    *,
    shaping_filter: ShapingFilter | FilterFit | None = None,
    filter_order: int = 4,
    estimator: str = "envelope",
    levels=QUANTILE_LEVELS,
) -> tuple[AbstractAmplitudeLaw, dict]:
    """`(law, law.summary(bins_deg, levels))` of theory `name` (arguments as `theory_law`), law and summary in one
    compiled program: the summary's numbers are those `law.summary` computes (mean, quantiles at `levels`, the PDF
    per degree on the bin edges `bins_deg` [deg], the mass beyond the last edge; angles in degrees). Concrete
    inputs only."""
    require_float64("jaxroll.theory.theory_summary")
    ((_, result),) = iter_theory_summaries(
        (name,), ship, wave, bins_deg, shaping_filter=shaping_filter, filter_order=filter_order,
        estimator=estimator, levels=levels,
    )  # fmt: skip
    return result


def iter_theory_summaries(
    names,
    ship: Ship,
    wave,
    bins_deg: ArrayLike,
    *,
    shaping_filter: ShapingFilter | FilterFit | concurrent.futures.Future | None = None,
    filter_order: int = 4,
    estimator: str = "envelope",
    levels=QUANTILE_LEVELS,
    return_exceptions: bool = False,
    warn: bool = True,
) -> Iterator[tuple[str, tuple[AbstractAmplitudeLaw, dict] | Exception]]:
    """Start every theory's program now and return an iterator of `(name, (law, summary))`, for each of `names` in
    turn, as `theory_summary` gives it; iterating waits for each result.

    The programs are dispatched when this is called (the moment method's first: it runs longest) and JAX runs them
    in the background, so that their computation overlaps whatever the caller does until it iterates (loading
    the other theories' programs; `jaxroll pdf`: the Monte Carlo). Arguments as `theory_summary`, and
    `shaping_filter` may be a `concurrent.futures.Future` of the `FilterFit` (or None) that the caller is still
    making with `fit_filter(wave, order=filter_order, match_frequency=2ω0)`: the moment method's programs are then
    traced (before the others start) and compiled for that fit's form (`fitted_form`) meanwhile, and a fit that
    fails (the future's exception) is the moment method's error;
    with `return_exceptions=True` a theory that has no law gets its error in place of `(law, summary)` (as
    `asyncio.gather`), otherwise the first such error (in the order of `names`) is raised. `warn=False` leaves out
    the `UserWarning` of the moment method's closure fallback (its law records it: `details()["closure_fallback"]`).
    Concrete inputs only.
    """
    require_float64("jaxroll.theory.iter_theory_summaries")
    names = tuple(names)
    for name in names:
        _check_name(name)
    check_estimator(estimator)
    shaping_filter = _filter(shaping_filter)
    if not is_concrete((ship, wave, shaping_filter)):
        raise ValueError(
            "`theory_summary` needs concrete inputs (use `theory_law(...).summary(...)` when traced)."
        )
    bins = np.asarray(bins_deg, dtype=float)
    levels = tuple(float(q) for q in np.ravel(np.asarray(levels, dtype=float)))
    if not all(0 < q < 1 for q in levels):
        raise ValueError(f"`levels` must lie strictly between 0 and 1; got {levels!r}.")
    edges = np.deg2rad(bins)
    if ship.restoring_surface is not None or moment_joins(ship, wave):  # `refuse_wave_moment`, every name
        refusal = restoring_surface_refusal if ship.restoring_surface is not None else wave_moment_refusal
        errors = [(name, ValueError(refusal(name))) for name in names]
        if not return_exceptions and errors:
            raise errors[0][1]
        return iter(errors)
    warn_outside_validity(ship, wave, names)
    # Each theory's program is traced (or loaded) and compiled in a thread of its own: XLA compiles without the
    # GIL, so one theory's compilation overlaps another's tracing and the caller's own work (`jaxroll pdf`: the
    # Monte Carlo's).
    pool = concurrent.futures.ThreadPoolExecutor(
        max_workers=max(len(names), 1), thread_name_prefix="jaxroll-theory"
    )
    pending = {}
    if "moment" in names:
        traced = threading.Event() if isinstance(shaping_filter, concurrent.futures.Future) else None
        pending["moment"] = pool.submit(
            _start, "moment", ship, wave, shaping_filter, filter_order, estimator, edges, levels, warn, traced
        ).result
        if (
            traced is not None
        ):  # the longest chain (trace, then the longest compilation) first, alone on the GIL
            traced.wait()
    if all(name in names for name in _SMALL):  # Roberts and ESAM: one program
        both = pool.submit(_start_averaging, ship, wave, estimator, edges, levels)
        pending.update({name: (lambda name=name: both.result()[name]) for name in _SMALL})
    for name in names:
        if name not in pending:
            pending[name] = pool.submit(_start, name, ship, wave, None, filter_order, estimator, edges, levels,
                                        warn).result  # fmt: skip
    pool.shutdown(wait=False)
    return _results(names, pending, bins, levels, return_exceptions)


def _results(names, pending, bins, levels, return_exceptions):
    """`pending[name]()`: waits for theory `name`'s program to be dispatched and returns its `finish`."""
    for name in names:
        try:
            law, numbers = pending[name]()()
        except (ValueError, RuntimeError) as e:
            if not return_exceptions:
                raise
            yield name, e
            continue
        yield name, (law, _summary(law, numbers, bins, levels))


def _summary(law, numbers, bins, levels) -> dict:
    """The dict of `AbstractAmplitudeLaw.summary` from the program's numbers (tests/test_moments.py checks that
    both are equal)."""
    mean, quantiles, cdf, sf_top = (np.asarray(x) for x in numbers)
    return {
        "estimator": law.estimator,
        "amplitude_sampling": SAMPLING[law.estimator],
        "mean_amplitude_deg": float(np.rad2deg(mean)),
        "quantiles_deg": {
            f"{round(q * 100):d}": float(np.rad2deg(v)) for q, v in zip(levels, quantiles, strict=True)
        },
        "bins_deg": bins,
        "pdf_per_degree": np.diff(cdf) / np.diff(bins),
        "mass_beyond_grid": float(sf_top),
    }
