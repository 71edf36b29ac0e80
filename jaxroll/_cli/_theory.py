"""Theoretical amplitude PDFs for the CLI: one place that calls jaxroll.theory with the CLI's options."""

from __future__ import annotations

import time

import numpy as np

from ._common import CLIError


def _wave(ship, sea, args):
    from .. import EffectiveWave

    return EffectiveWave(sea, ship.lpp, args.speed, args.heading)


def compute(ship, sea, args, name: str, *, estimator: str = "envelope"):
    """One theory's result object: Roberts (nonlinear restoring), ESAM, or the moment method (order-6 closure)."""
    from .. import theory

    wave = _wave(ship, sea, args)
    try:
        if name == "roberts":
            return theory.roberts_pdf(ship, wave, restoring="nonlinear", estimator=estimator)
        if name == "esam":
            return theory.esam_pdf(ship, wave, estimator=estimator)
        if name == "moment":
            return theory.moment_pdf_first_stable(ship, wave, filter_order=args.filter_order)
    except (ValueError, RuntimeError) as e:
        from ..theory._moments import _first_message

        raise CLIError(f"{name}: {_first_message(e)}") from None
    raise CLIError(f"unknown theory {name!r}")


def _normalise_quantiles(q: dict) -> dict:
    return {k.rstrip("%"): v for k, v in q.items()}


def theory_summaries(ship, sea, args, names, bins_deg) -> dict:
    """Per theory: `pdf` per degree on `bins_deg`, `mean_amplitude_deg`, `quantiles_deg`, parameters, timing."""
    out = {}
    for name in names:
        t0 = time.time()
        result = compute(ship, sea, args, name)
        pdf = np.asarray(result.pdf_per_degree(bins_deg), dtype=float)
        summary = result.summary()
        summary.pop("bins_deg", None)
        summary.pop("pdf_per_degree", None)
        summary["quantiles_deg"] = _normalise_quantiles(summary["quantiles_deg"])
        summary.setdefault("estimator", "envelope")
        out[name] = {"pdf": pdf, **summary, "time_s": time.time() - t0}
    return out


def theory_distributions(ship, sea, args, names) -> dict:
    """Per-cycle amplitude distributions (`jaxroll.extremes._maxima.AmplitudeDistribution`) of each theory, for maxima."""
    from ..extremes._maxima import AmplitudeDistribution

    out = {}
    for name in names:
        estimator = "zero_crossing" if name in ("roberts", "esam") else "envelope"
        result = compute(ship, sea, args, name, estimator=estimator)
        a = np.linspace(1e-4, np.deg2rad(89.0), 4000)
        out[name] = AmplitudeDistribution.from_pdf(a, np.asarray(result.pdf(a), dtype=float))
    return out
