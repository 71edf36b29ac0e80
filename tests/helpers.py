"""Shared test helpers: the default ship and problems (built once per session, so their filter fits and compiled
kernels are shared across test files), relative errors, and standard-error tolerances."""

import functools
import math

import numpy as np

import jaxroll as jxr

SHIP = jxr.c11_representative()


@functools.lru_cache(maxsize=16)
def default_problem(hs: float = 7.0, t01: float = 10.0, *, excitation: str = "filter", dt: float = 0.5):
    """`RollProblem.from_sea` of the default ship in ITTC(hs, t01), head seas, zero speed (cached)."""
    return jxr.RollProblem.from_sea(SHIP, jxr.ITTC(hs, t01), excitation=excitation, dt=dt)


def rel(a, b) -> float:
    """Relative difference a/b − 1 of two scalars."""
    return float(a) / float(b) - 1.0


def standard_error_of_mean(sums, counts) -> float:
    """Standard error of a ratio estimator Σsums/Σcounts over independent realizations (delta method)."""
    sums, counts = np.asarray(sums, float), np.asarray(counts, float)
    keep = counts > 0
    sums, counts = sums[keep], counts[keep]
    m = sums.sum() / counts.sum()
    resid = sums - m * counts
    n = counts.size
    return math.sqrt(n / (n - 1) * np.sum(resid**2)) / counts.sum()


def assert_within_se(value, reference, se, k: float = 3.0, what: str = "") -> None:
    """|value − reference| ≤ k·se, with a message that shows the numbers."""
    assert abs(float(value) - float(reference)) <= k * float(se), (
        f"{what}: {float(value):.6g} vs {float(reference):.6g}, |Δ| = {abs(float(value) - float(reference)):.3g} "
        f"> {k} × SE {float(se):.3g}"
    )
