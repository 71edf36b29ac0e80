"""Design sensitivities from the Monte Carlo (`jaxroll.monte_carlo_sensitivity`, docs/sensitivity.md).

The windowed pathwise estimator against central finite differences with common random numbers (same trials,
same keys), within 3 combined standard errors; the plain pathwise derivative against a tiny-step difference
realization by realization; the bias of the exceedance smoothing against the unsmoothed difference; bad input.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import SHIP, assert_within_se

import jaxroll as jxr

STATS = ("E_phi2", "mean_envelope", "P_exceed_20deg")
WRT = ("gm_correction", "b1", "hs")


@pytest.fixture(scope="module")
def problem():
    return jxr.sensitivity_problem(SHIP, hs=7.0, t01=10.0)


@pytest.fixture(scope="module")
def reduced(problem):
    """The reduced protocol: 400 realizations × 1200 s, default window (300 s) and burn-in (100/200/300 s)."""
    problem_fn, params = problem
    kw = dict(wrt=WRT, statistics=STATS, num_realizations=400, duration=1200.0, chunk_size=200)
    key = jax.random.key(7)
    windowed = jxr.monte_carlo_sensitivity(problem_fn, params, key, **kw)
    fd = jxr.monte_carlo_sensitivity(problem_fn, params, key, method="finite_difference", fd_step=0.02, **kw)
    return windowed, fd


@pytest.mark.parametrize(
    "stat, param", [("mean_envelope", "gm_correction"), ("E_phi2", "b1"), ("mean_envelope", "hs")]
)
def test_windowed_matches_crn_finite_differences(reduced, stat, param):
    windowed, fd = reduced
    se = math.hypot(windowed.std_error[stat][param], fd.std_error[stat][param])
    assert_within_se(windowed.gradient[stat][param], fd.gradient[stat][param], se, what=f"d{stat}/d{param}")
    # the estimate is not trivially noisy: it resolves the derivative
    assert abs(fd.gradient[stat][param]) > 5 * se
    assert windowed.config["extrapolated"] and 0 < windowed.config["memory_ratio"] < 0.95


def test_values_are_the_monte_carlo_of_the_same_trials(problem, reduced):
    """Realization i is fold_in(key, i), as in `monte_carlo_amplitudes`: the values are that Monte Carlo's with φ
    recorded every step (in float64, as the sensitivities integrate), over the realizations each estimator keeps
    (finite differences keep the survivors of every shifted run too)."""
    windowed, fd = reduced
    with pytest.warns(UserWarning, match="shaping filter's spectrum is .* off the effective wave's"):
        prob = jxr.RollProblem.from_sea(
            SHIP, jxr.ITTC(7.0, 10.0), filter_order=4
        )  # sensitivity_problem's order
    stats = jxr.monte_carlo(
        prob,
        jax.random.key(7),
        jxr.AmplitudeHistogram(every=1),
        num_realizations=400,
        duration=1200.0,
        dtype=jnp.float64,
    )
    per = stats.per_realization
    np.testing.assert_array_equal(windowed.kept, ~stats.capsized)
    assert not np.any(fd.kept & stats.capsized)
    for res in (windowed, fd):
        keep = res.kept
        np.testing.assert_allclose(
            res.value["mean_envelope"], per["sum_env"][keep].sum() / per["n_env"][keep].sum(), rtol=1e-9
        )
        np.testing.assert_allclose(
            res.value["E_phi2"], per["sum_phi2"][keep].sum() / per["n_samples"][keep].sum(), rtol=1e-9
        )


def test_plain_pathwise_is_the_derivative_of_each_realization(problem):
    """Over a short run the whole-run tangent (window=None) equals a tiny central difference trial by trial
    (GM0 and H1/3 go through the refitted shaping filter)."""
    problem_fn, params = problem
    kw = dict(wrt=("gm0", "hs", "b2"), statistics=("mean_envelope", "mean_zero_crossing"), num_realizations=4,
              duration=200.0, chunk_size=4)  # fmt: skip
    key = jax.random.key(3)
    ad = jxr.monte_carlo_sensitivity(problem_fn, params, key, window=None, **kw)
    fd = jxr.monte_carlo_sensitivity(problem_fn, params, key, method="finite_difference", fd_step=1e-5, **kw)
    assert ad.config["method"] == "pathwise"
    for p in kw["wrt"]:
        a, b = ad.influence["mean_envelope"][p], fd.influence["mean_envelope"][p]
        np.testing.assert_allclose(a, b, rtol=2e-3, atol=2e-3 * np.max(np.abs(b)))


def test_exceedance_smoothing_bias(reduced):
    """Φ((A − a)/s) for 1{A > a}, s = 1°: the value is biased up by about s²/2·|f'(a)| in the tail (a few per
    cent), the derivative much less; both measured against the unsmoothed statistic of the same trials."""
    windowed, fd = reduced
    s = "P_exceed_20deg"
    smooth, plain = fd.value[s], fd.unsmoothed[s]
    assert 0 < smooth - plain < 0.05 * plain
    for p in WRT:
        g, g0, se0 = fd.gradient[s][p], fd.unsmoothed_gradient[s][p], fd.unsmoothed_std_error[s][p]
        assert abs(g - g0) <= 0.03 * abs(g0) + 3 * se0, (p, g, g0, se0)
        se = math.hypot(windowed.std_error[s][p], se0)
        assert_within_se(windowed.gradient[s][p], g0, se, k=3.0, what=f"smoothed d{s}/d{p} vs unsmoothed FD")


def test_bad_input(problem):
    problem_fn, params = problem
    key = jax.random.key(0)
    with pytest.raises(ValueError, match="unknown parameter"):
        jxr.monte_carlo_sensitivity(problem_fn, params, key, wrt=("gm_corection",))
    with pytest.raises(ValueError, match="longer than the run"):
        jxr.monte_carlo_sensitivity(problem_fn, params, key, wrt=("b1",), duration=200.0, window=300.0)
    with pytest.raises(ValueError, match="longer than the run"):
        jxr.monte_carlo_sensitivity(problem_fn, params, key, wrt=("b1",), duration=500.0, burn_in=300.0)
    with pytest.raises(ValueError, match="unknown statistic"):
        jxr.monte_carlo_sensitivity(problem_fn, params, key, wrt=("b1",), statistics=("P_exceed_20",))
    with pytest.raises(ValueError, match="discard"):
        jxr.monte_carlo_sensitivity(problem_fn, params, key, wrt=("b1",), duration=100.0, discard=100.0)
    with pytest.raises(ValueError, match="must be finite"):
        jxr.monte_carlo_sensitivity(problem_fn, {**params, "b1": float("nan")}, key)
    with pytest.raises(ValueError, match="beyond the angle of vanishing stability"):
        jxr.sensitivity_problem(SHIP, hs=7.0, t01=10.0, phi0=math.radians(80.0))
    assert set(params) == set(jxr.SENSITIVITY_PARAMETERS)
    # the problem function is differentiable in reverse mode too: d(filter gain)/d(H1/3) = gain/H1/3 (S_G ∝ H², see
    # below; jitted: one compilation, 5 s instead of 8.5 s op by op); and its program has no host callback (no
    # traced check, no lineax check in the filter fit's implicit derivative), so JAX can keep it in its disk cache
    gain = jax.value_and_grad(lambda hs: jnp.sum(problem_fn({**params, "hs": hs}).excitation.c))
    traced = jax.jit(gain).trace(7.0)
    assert "callback" not in str(traced.jaxpr)
    value, g = traced.lower().compile()(7.0)
    np.testing.assert_allclose(float(g), float(value) / 7.0, rtol=1e-9)


def test_problem_derivative_in_the_wave_height_is_exact(problem):
    """S_G ∝ H1/3², so the refitted filter keeps its shape and only its gain c scales: dc/dH = c/H, the bridge
    weights (linear in c) likewise, and Φ, L and the stationary root do not move — exactly, through the whole
    problem as the sensitivities compute it (`_problem_tangents`, compiled as a small program). The fit's
    numerator is defined only up to its scale; before the derivative solved around that singular direction, other
    rounding gave dc/dH 2 % wrong here."""
    from jaxroll.roll._sensitivity import _problem_tangents

    problem_fn, params = problem
    parts, d = _problem_tangents(problem_fn, {k: jnp.asarray(v) for k, v in params.items()}, ("hs",))
    exc, d_exc = parts.excitation, d.excitation
    for name in ("c", "bridge"):
        value = np.asarray(getattr(exc, name))
        np.testing.assert_allclose(
            np.asarray(getattr(d_exc, name))[0], value / 7.0, rtol=1e-7, atol=1e-12 * np.abs(value).max()
        )
    for name in ("phi", "chol", "stationary_chol"):
        assert (
            np.abs(np.asarray(getattr(d_exc, name))).max()
            < 1e-12 * np.abs(np.asarray(getattr(exc, name))).max()
        )


@pytest.mark.slow
def test_protocol_10k_by_3600s(problem):
    """The paper protocol (10⁴ × 3600 s from φ0 = 5°): the default estimator against finite differences."""
    problem_fn, params = problem
    kw = dict(wrt=WRT, statistics=("E_phi2", "mean_envelope"), num_realizations=10_000, duration=3600.0,
              chunk_size=500)  # fmt: skip
    key = jax.random.key(20251)
    windowed = jxr.monte_carlo_sensitivity(problem_fn, params, key, **kw)
    fd = jxr.monte_carlo_sensitivity(problem_fn, params, key, method="finite_difference", fd_step=0.02, **kw)
    for stat, param in (("mean_envelope", "gm_correction"), ("E_phi2", "b1"), ("mean_envelope", "hs")):
        se = math.hypot(windowed.std_error[stat][param], fd.std_error[stat][param])
        assert_within_se(
            windowed.gradient[stat][param], fd.gradient[stat][param], se, what=f"d{stat}/d{param}"
        )
        # informative: the estimator's standard error on this protocol is 0.4–4 % of the value (heavy-tailed
        # per-trial contributions, Hill index ~2: docs/sensitivity.md); 5 % bounds it with the stream's luck
        assert windowed.std_error[stat][param] < 0.05 * abs(fd.gradient[stat][param])
