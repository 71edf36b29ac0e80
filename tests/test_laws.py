"""Every amplitude law the library returns implements one abstraction, consistently (∫pdf = 1, sf = 1 − cdf,
mean = ∫ sf), and says what it is a law of; the maxima and risk formulas refuse a law of the wrong kind."""

import math

import jax
import numpy as np
import pytest
from helpers import default_problem

import jaxroll as jxr

SHIP = jxr.c11_representative()


@pytest.fixture(scope="module")
def problem():
    return default_problem(7.0)


@pytest.fixture(scope="module")
def laws(problem):
    stats = jxr.monte_carlo_amplitudes(
        problem, jax.random.key(0), num_realizations=64, duration=1200.0, discard=200.0
    )
    out = {
        "rayleigh": jxr.RayleighLaw(0.15),
        "roberts_closed_form": jxr.RobertsLaw(0.6, 8.0, estimator="envelope"),
        "tabulated": jxr.TabulatedAmplitudeLaw.from_pdf(
            np.linspace(0, 1.0, 401), np.linspace(0, 1.0, 401) * np.exp(-30 * np.linspace(0, 1.0, 401) ** 2)
        ),
        "mc_zero_crossing": stats.law("zero_crossing"),
        "mc_envelope": stats.law("envelope", pool=20),
    }
    for est in ("envelope", "zero_crossing"):
        out[f"roberts_{est}"] = jxr.theory.roberts_pdf(
            SHIP, problem.wave, restoring="nonlinear", estimator=est
        )
        out[f"esam_{est}"] = jxr.theory.esam_pdf(SHIP, problem.wave, estimator=est)
        out[f"moment_{est}"] = jxr.theory.moment_pdf(
            SHIP, problem.wave, shaping_filter=problem.filter_fit, closure_order=6, estimator=est
        )
    return out


NAMES = [
    "rayleigh",
    "roberts_closed_form",
    "tabulated",
    "mc_zero_crossing",
    "mc_envelope",
    "roberts_envelope",
    "roberts_zero_crossing",
    "esam_envelope",
    "esam_zero_crossing",
    "moment_envelope",
    "moment_zero_crossing",
]


@pytest.mark.parametrize("name", NAMES)
def test_every_law_is_consistent(laws, name):
    law = laws[name]
    assert isinstance(law, jxr.AbstractAmplitudeLaw)
    assert law.estimator in ("zero_crossing", "envelope")
    hi = float(law.support()[1])
    top = hi if math.isfinite(hi) else float(law.isf(1e-14))
    a = np.linspace(0.0, top, 20001)  # below the support's lower end the pdf is 0 and sf is 1
    p = np.asarray(law.pdf(a))
    # ∫ pdf = 1 (trapezoid; the tabulated laws are piecewise linear in A or in ln A)
    assert abs(np.trapezoid(p, a) - 1.0) < 2e-3, name
    # sf = 1 − cdf, to round-off
    np.testing.assert_allclose(np.asarray(law.sf(a)) + np.asarray(law.cdf(a)), 1.0, atol=1e-9)
    # mean = ∫ sf
    mean_sf = np.trapezoid(np.asarray(law.sf(a)), a)
    assert abs(float(law.mean()) - mean_sf) < 2e-3 * mean_sf, name
    # quantile inverts cdf
    q = np.array([0.1, 0.5, 0.9, 0.99])
    np.testing.assert_allclose(np.asarray(law.cdf(law.quantile(q))), q, atol=2e-4)
    s = law.summary(np.arange(0.0, 61.0, 1.0))
    assert set(s["quantiles_deg"]) == {"50", "90", "99"}
    assert s["amplitude_sampling"] in ("per half cycle", "per time sample")


def test_maxima_refuse_envelope_laws(laws):
    for name in ("mc_envelope", "roberts_envelope", "esam_envelope", "moment_envelope"):
        with pytest.raises(ValueError, match="zero-crossing amplitudes"):
            jxr.max_pdf(laws[name], 0.3, 100)
        with pytest.raises(ValueError, match="zero-crossing amplitudes"):
            jxr.exposure_risk(laws[name], 0.5, rate=0.1, duration=3600.0)
    assert np.isfinite(float(jxr.max_pdf(laws["moment_zero_crossing"], 0.3, 100)))


def test_per_cycle_law_weights_large_amplitudes_less(laws):
    # Ω(A) falls with A on the softening GZ curve: fewer half cycles per second at large amplitude, so the
    # per-cycle law has a lighter tail than the time-sampled one (Roberts, ESAM and the moment method alike).
    for theory in ("roberts", "esam", "moment"):
        env, zc = laws[f"{theory}_envelope"], laws[f"{theory}_zero_crossing"]
        assert float(zc.sf(math.radians(30))) < float(env.sf(math.radians(30))), theory


def test_moment_method_refuses_a_bare_spectrum():
    with pytest.raises(TypeError, match="effective wave"):
        jxr.theory.moment_pdf(SHIP, jxr.ITTC(7.0, 10.0))


def test_law_kind_checked_at_construction():
    with pytest.raises(ValueError, match="estimator"):
        jxr.RayleighLaw(0.1, estimator="per_sample")
    with pytest.raises(ValueError, match="empty"):
        jxr.laws.law_from_histogram(np.zeros(10), np.linspace(0, 1, 11), estimator="envelope")
