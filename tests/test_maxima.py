"""The Monte Carlo maxima protocol: exact nesting, reproducibility, capsize and completeness bookkeeping."""

import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
from helpers import default_problem

import jaxroll


@pytest.fixture(scope="module")
def problem():
    return default_problem(7.0)


def test_maxima_nested_reproducible_and_chunk_invariant(problem):
    kw = dict(n0=(5, 20, 40), num_realizations=6, discard=100.0)
    a = jaxroll.monte_carlo_maxima(problem, jr.key(3), chunk_size=6, **kw)
    b = jaxroll.monte_carlo_maxima(problem, jr.key(3), chunk_size=4, **kw)
    np.testing.assert_allclose(a.maxima_deg, b.maxima_deg, rtol=1e-13, atol=0, equal_nan=True)
    np.testing.assert_array_equal(a.count, b.count)
    ok = np.all(np.isfinite(a.maxima_deg), axis=1)
    assert ok.sum() >= 5
    m = a.maxima_deg[ok]
    # The maximum over the first 20 amplitudes of a trial can only grow when 20 more are added.
    assert np.all(np.diff(m, axis=1) >= 0)
    assert np.all(a.count <= 40)


class _RunToTheEnd(jaxroll.FirstMaxima):
    finished = None  # no early stop: every trial runs the whole duration


def test_early_stop_changes_nothing(problem):
    """A trial stops once it has its max(n0) amplitudes: its maxima and counts are those of the full run."""
    kw = dict(num_realizations=5, duration=3000.0, chunk_size=5)
    obs = dict(n0=(10, 60), discard=100.0)
    early = jaxroll.monte_carlo(problem, jr.key(4), jaxroll.FirstMaxima(**obs), **kw)
    full = jaxroll.monte_carlo(problem, jr.key(4), _RunToTheEnd(**obs), **kw)
    assert np.all(early.count == 60)
    np.testing.assert_array_equal(early.maxima_deg, full.maxima_deg)
    np.testing.assert_array_equal(early.count, full.count)


def test_maxima_equal_the_largest_of_the_first_n0_zero_crossing_amplitudes(problem):
    """Cross-check of the streaming reduction with the stored-series route on the same realization."""
    key = jr.key(11)
    discard, n0 = 100.0, (10, 25)
    stats = jaxroll.monte_carlo_maxima(
        problem, key, n0=n0, num_realizations=1, discard=discard, duration=1400.0
    )
    phi, _, end = jaxroll.roll_time_series(problem, jr.fold_in(key, 0), 1400.0, dtype=jnp.float32)
    assert not bool(end.capsized)
    amps = np.asarray(jaxroll.zero_crossing_amplitudes(phi))
    t = np.arange(phi.size) * problem.dt
    amps = amps[(amps > 0) & (t > discard + 1e-9)]
    for j, n in enumerate(n0):
        # the Monte Carlo integrates in float32 like this series, but compiled vmapped: equal to float32 round-off
        # accumulated over 2 800 steps (2.9e-5 with the order-8 filter of the default, 1e-5 with order 4)
        np.testing.assert_allclose(stats.maxima_deg[0, j], np.rad2deg(amps[:n].max()), rtol=1e-4, atol=0)


def test_incomplete_trials_are_reported_not_hidden(problem):
    stats = jaxroll.monte_carlo_maxima(
        problem, jr.key(0), n0=(10, 1000), num_realizations=3, duration=600.0, discard=100.0
    )
    assert stats.n_incomplete(1) + stats.n_capsized_before(1) == 3  # 500 s cannot hold 1000 amplitudes
    assert np.all(np.isnan(stats.maxima_deg[:, 1]))
    assert stats.n_incomplete(0) + stats.n_capsized_before(0) < 3


def test_maxima_errors(problem):
    with pytest.raises(ValueError, match="`n0` must be a non-empty list of integers >= 1"):
        jaxroll.monte_carlo_maxima(problem, jr.key(0), n0=(0,))
    with pytest.raises(ValueError, match="`duration` must be > discard"):
        jaxroll.monte_carlo_maxima(problem, jr.key(0), n0=(5,), duration=100.0, discard=500.0)
    with pytest.raises(ValueError, match="`num_realizations` must be a positive integer"):
        jaxroll.monte_carlo_maxima(problem, jr.key(0), n0=(5,), num_realizations=0)


def test_maxima_checkpoint_resume_equals_uninterrupted(problem, tmp_path):
    kw = dict(n0=(5, 15), num_realizations=5, discard=100.0, chunk_size=2)
    ref = jaxroll.monte_carlo_maxima(problem, jr.key(4), **kw)

    def interrupt(done):
        if done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        jaxroll.monte_carlo_maxima(
            problem, jr.key(4), checkpoint=tmp_path, checkpoint_every=1, progress=interrupt, **kw
        )
    resumed = jaxroll.monte_carlo_maxima(problem, jr.key(4), checkpoint=tmp_path, **kw)
    np.testing.assert_array_equal(resumed.maxima_deg, ref.maxima_deg)


def test_maxima_statistics_are_a_defective_distribution():
    """A trial that capsized before N0 is a maximum beyond the vanishing angle (issue 13 case 4): counted in the
    probabilities and the quantiles (as +inf), never dropped; incomplete trials are unknown and left out."""
    from jaxroll.roll._statistics import MaximaStatistics

    maxima = np.array([[10.0], [20.0], [30.0], [np.nan], [np.nan], [40.0], [np.nan], [15.0], [25.0], [35.0]])
    capsized = np.array([False, False, False, True, True, False, False, False, False, False])
    stats = MaximaStatistics(
        n0=(20,), maxima_deg=maxima, capsized=capsized, capsize_time=np.zeros(10), count=np.full(10, 20)
    )
    assert (stats.n_capsized_before(0), stats.n_incomplete(0), stats.n_known(0)) == (2, 1, 9)
    # P(max > 22°) = (25, 30, 35, 40 and the two capsizes) / 9 known trials
    assert stats.exceedance_probability(0, 22.0) == pytest.approx(6 / 9)
    bins = np.arange(0.0, 91.0, 5.0)
    s = stats.summary(0, bins)
    assert s["capsize_probability"] == pytest.approx(2 / 9)
    assert np.sum(np.asarray(s["histogram_pdf_per_deg"]) * np.diff(bins)) == pytest.approx(7 / 9)
    assert s["mean_deg"] is None and s["mean_deg_given_no_capsize"] == pytest.approx(25.0)
    # numpy's linear quantile of [10, 15, 20, 25, 30, 35, 40, inf, inf]: the median is 30; 0.9 falls among the
    # capsizes -> null with a reason
    assert s["quantiles_deg"]["50"] == pytest.approx(30.0)
    assert s["quantiles_deg"]["90"] is None and "vanishing stability" in s["quantiles_reason"]["90"]
    lo, hi = s["capsize_probability_ci95"]
    assert lo < 2 / 9 < hi
