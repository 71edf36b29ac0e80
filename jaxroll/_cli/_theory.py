"""Theoretical amplitude laws for the CLI: one place that calls jaxroll.theory with the CLI's options."""

from __future__ import annotations

import concurrent.futures
import time

import numpy as np

from ._common import CLIError
from ._sea import TheoryInputs, has_yaw, moment_filter, moment_filter_order


def first_line(error: Exception) -> str:
    """The user-facing line of an error (the `EquinoxRuntimeError:` text under jit, else the first line)."""
    text = str(error)
    marker = "EquinoxRuntimeError: "
    if marker in text:
        text = text.split(marker, 1)[1]
    return text.strip().splitlines()[0] if text.strip() else type(error).__name__


def _call(name: str, fn):
    try:
        return fn()
    except (ValueError, RuntimeError) as e:
        raise CLIError(f"{name}: {first_line(e)}") from None


def compute(problem, args, name: str, *, estimator: str = "envelope"):
    """One theory's amplitude law for the Monte Carlo's own problem (same effective wave, same filter fit):
    Roberts (nonlinear restoring), ESAM, the moment method (order-6 closure, order 4 where 6 has no stable
    fixed point — the closure used is recorded in the law's `details()`, and said on the terminal by the caller
    with `closure_note`, not as a Python warning), or the envelope Fokker–Planck method (coloured-noise
    averaging; its grid and fitted envelope are recorded in `details()`). One compiled program per theory,
    loaded from the cache on a warm run (`jaxroll.theory.theory_law`)."""
    from .. import theory

    if name not in theory.THEORIES:
        raise CLIError(f"unknown theory {name!r}")
    if has_yaw(problem):
        raise CLIError(theory.yaw_refusal(name))
    return _call(name, lambda: theory.theory_law(
        name, problem.ship, problem.wave, shaping_filter=moment_filter(problem, args),
        filter_order=moment_filter_order(args), estimator=estimator, warn=False))  # fmt: skip


def start_theory_summaries(problem, args, names, bins_deg, *, skip_failed: bool = False, warn: bool = True):
    """Dispatch the theories' programs now (JAX runs them in the background) and return `finish() -> dict`: per
    theory (envelope law) `pdf` per degree on `bins_deg`, the law's summary, its details, and `time_s`, the wall
    time it cost this command (dispatching it, and waiting for its result after the previous one's). Each theory
    is one compiled program (`jaxroll.theory.iter_theory_summaries`). `bins_deg` may be a function that returns
    them, called once the filter fit has started. A theory that has no law is an error
    (`CLIError`), or with `skip_failed` is left out and `finish()` returns `(summaries, {name: reason})`;
    `warn=False`: no `UserWarning` for the moment method's closure fallback (its details record it)."""
    from .. import theory

    for name in names:
        if name not in theory.THEORIES:
            raise CLIError(f"unknown theory {name!r}")
    t0 = time.time()
    # The fit (`TheoryInputs.filter_fit`: made on first reading, and only for the moment method, which alone uses
    # it) is made in a thread of its own while the theories' programs trace and compile, the moment method's for
    # the fit's form (`iter_theory_summaries` with a future filter). A fit that is not usable is the moment
    # method's error: with `skip_failed` it is left out with that reason, and the other theories are shown.
    fit = moment_filter(problem, args) if not isinstance(problem, TheoryInputs) else None
    if isinstance(problem, TheoryInputs) and "moment" in names:
        pool = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="jaxroll-fit")
        fit = pool.submit(lambda: problem.filter_fit)
        pool.shutdown(wait=False)
    if callable(
        bins_deg
    ):  # after the fit has started (`jaxroll theory`'s bins need the vanishing angle's program)
        bins_deg = bins_deg()
    if has_yaw(problem):  # the theories' sea has one heading
        results = [(name, ValueError(theory.yaw_refusal(name))) for name in names]
    else:
        results = theory.iter_theory_summaries(
            names, problem.ship, problem.wave, bins_deg, shaping_filter=fit, filter_order=moment_filter_order(args),
            return_exceptions=True, warn=warn,
        )  # fmt: skip
    dispatch = time.time() - t0

    def finish():
        out, failed = {}, {}
        t1 = time.time()
        for name, result in results:
            if isinstance(result, Exception):
                if not skip_failed:
                    raise CLIError(f"{name}: {first_line(result)}")
                failed[name] = first_line(result)
                continue
            law, summary = result
            summary = {**summary, **law.details()}
            summary["pdf"] = np.asarray(summary.pop("pdf_per_degree"), dtype=float)
            summary.pop("bins_deg", None)
            out[name] = {**summary, "time_s": dispatch + time.time() - t1}
        return (out, failed) if skip_failed else out

    return finish


def closure_note(summary: dict) -> str:
    """ ", closure order 4: order 6 has no stable fixed point here" (or "order 6's moments fit no law of the method's
    amplitude family here", where its fixed point exists but the PDF family cannot reproduce its moments) for a
    theory summary whose moment closure fell back to a lower order (`closure_fallback` and
    `closure_fallback_cause` in its details), else "": the terminal's line for what the JSON records."""
    if not summary.get("closure_fallback"):
        return ""
    head = f", closure order {summary['closure_order']}: order {summary['requested_closure_order']}"
    if summary.get("closure_fallback_cause") == "amplitude_family":
        return f"{head}'s moments fit no law of the method's amplitude family here"
    return f"{head} has no stable fixed point here"


def theory_summaries(problem, args, names, bins_deg) -> dict:
    """`start_theory_summaries(...)()`: the theories' summaries now (a theory that has no law is an error)."""
    return start_theory_summaries(problem, args, names, bins_deg)()


def theory_laws(problem, args, names) -> dict:
    """Per theory, its per-half-cycle (zero-crossing) amplitude law: what the maxima and risk formulas need."""
    return {name: compute(problem, args, name, estimator="zero_crossing") for name in names}
