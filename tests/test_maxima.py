"""The Monte Carlo maxima protocol: exact nesting, reproducibility, capsize and completeness bookkeeping."""

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


def test_maxima_equal_the_largest_of_the_first_n0_zero_crossing_amplitudes(problem):
    """Cross-check of the streaming reduction with the stored-series route on the same realization."""
    key = jr.key(11)
    discard, n0 = 100.0, (10, 25)
    stats = jaxroll.monte_carlo_maxima(problem, key, n0=n0, num_realizations=1, discard=discard, duration=1400.0)
    phi, _, end = jaxroll.roll_time_series(problem, jr.fold_in(key, 0), 1400.0)
    assert not bool(end.capsized)
    amps = np.asarray(jaxroll.zero_crossing_amplitudes(phi))
    t = np.arange(phi.size) * problem.dt
    amps = amps[(amps > 0) & (t > discard + 1e-9)]
    for j, n in enumerate(n0):
        np.testing.assert_allclose(stats.maxima_deg[0, j], np.rad2deg(amps[:n].max()), rtol=1e-12, atol=0)


def test_incomplete_trials_are_reported_not_hidden(problem):
    stats = jaxroll.monte_carlo_maxima(problem, jr.key(0), n0=(10, 1000), num_realizations=3, duration=600.0,
                                       discard=100.0)
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
        jaxroll.monte_carlo_maxima(problem, jr.key(4), checkpoint=tmp_path, checkpoint_every=1, progress=interrupt,
                                   **kw)
    resumed = jaxroll.monte_carlo_maxima(problem, jr.key(4), checkpoint=tmp_path, **kw)
    np.testing.assert_array_equal(resumed.maxima_deg, ref.maxima_deg)
