"""Theoretical amplitude laws for the CLI: one place that calls jaxroll.theory with the CLI's options."""

from __future__ import annotations

import time

import numpy as np

from ._common import CLIError


def first_line(error: Exception) -> str:
    """The user-facing line of an error (the `EquinoxRuntimeError:` text under jit, else the first line)."""
    text = str(error)
    marker = "EquinoxRuntimeError: "
    if marker in text:
        text = text.split(marker, 1)[1]
    return text.strip().splitlines()[0] if text.strip() else type(error).__name__


def compute(problem, args, name: str, *, estimator: str = "envelope"):
    """One theory's amplitude law for the Monte Carlo's own problem (same effective wave, same filter fit):
    Roberts (nonlinear restoring), ESAM, the moment method (order-6 closure, order 4 where 6 has no stable
    fixed point — the closure used is recorded in the law's `details()`), or the envelope Fokker–Planck method
    (coloured-noise averaging; its grid and fitted envelope are recorded in `details()`)."""
    from .. import theory

    ship, wave = problem.ship, problem.wave
    try:
        if name == "roberts":
            return theory.roberts_pdf(ship, wave, restoring="nonlinear", estimator=estimator)
        if name == "esam":
            return theory.esam_pdf(ship, wave, estimator=estimator)
        if name == "moment":
            return theory.moment_pdf_first_stable(
                ship, wave, shaping_filter=problem.filter_fit, filter_order=args.filter_order, estimator=estimator
            )
        if name == "envelope_fpk":
            return theory.envelope_fpk_pdf(ship, wave, estimator=estimator)
    except (ValueError, RuntimeError) as e:
        raise CLIError(f"{name}: {first_line(e)}") from None
    raise CLIError(f"unknown theory {name!r}")


def theory_summaries(problem, args, names, bins_deg) -> dict:
    """Per theory (envelope law): `pdf` per degree on `bins_deg`, the law's summary, its details, timing."""
    out = {}
    for name in names:
        t0 = time.time()
        law = compute(problem, args, name)
        summary = {**law.summary(bins_deg), **law.details()}
        summary["pdf"] = np.asarray(summary.pop("pdf_per_degree"), dtype=float)
        summary.pop("bins_deg", None)
        out[name] = {**summary, "time_s": time.time() - t0}
    return out


def theory_laws(problem, args, names) -> dict:
    """Per theory, its per-half-cycle (zero-crossing) amplitude law: what the maxima and risk formulas need."""
    return {name: compute(problem, args, name, estimator="zero_crossing") for name in names}
