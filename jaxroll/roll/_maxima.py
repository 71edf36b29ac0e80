"""The paper's maxima protocol by Monte Carlo: the largest of the first N0 zero-crossing amplitudes of each trial.

Protocol (Katsumura et al., §7): φ(0) = 5°, discard the first 500 s, take the first N0 amplitudes of each trial
and record their maximum. Several N0 come from the same trials (the maximum over the first 20 amplitudes is a
by-product of the run for 1000). Amplitudes are reduced on the fly — no time series is kept — so N0 = 10⁴
(≈ 1.3·10⁵ s per trial) runs in memory bounded by the chunk size.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ._amplitudes import ZeroCrossingState, zero_crossing_init, zero_crossing_update
from ._equation import RollProblem, simulate
from ._monte_carlo import CapsizeCounts, run_chunks


class _MaximaObserver(eqx.Module):
    zc: ZeroCrossingState
    count: jnp.ndarray
    running_max: jnp.ndarray
    maxima: jnp.ndarray


def _chunk_maxima(problem, key, indices, valid, num_steps, discard_steps, n0):
    n0_arr = jnp.asarray(n0)
    n_max = max(n0)

    def one(i):
        def observe(obs, k, y, alive):
            zc, amp = zero_crossing_update(obs.zc, y[0])
            counted = (amp > 0) & (k > discard_steps) & (obs.count < n_max) & alive
            count = obs.count + counted
            running = jnp.where(counted, jnp.maximum(obs.running_max, amp), obs.running_max)
            maxima = jnp.where(counted & (count == n0_arr), running, obs.maxima)
            return _MaximaObserver(zc, count, running, maxima), None

        obs0 = _MaximaObserver(
            zero_crossing_init(problem.phi0),
            jnp.array(0),
            jnp.array(0.0),
            jnp.full(len(n0), -1.0),
        )
        obs, _, end = simulate(problem, jr.fold_in(key, i), num_steps, observe, obs0)
        return obs, end

    obs, end = jax.vmap(one)(indices)
    per = {
        "maxima": jnp.where(valid[:, None], obs.maxima, -1.0),
        "count": jnp.where(valid, obs.count, 0),
        "capsized": end.capsized & valid,
        "capsize_time": end.capsize_time,
    }
    return {}, per


@dataclass
class MaximaStatistics(CapsizeCounts):
    """Monte Carlo maxima of the first N0 zero-crossing amplitudes per trial (angles in degrees).

    `maxima_deg[i, j]` is trial i's maximum over its first `n0[j]` amplitudes after the discard, NaN where the
    trial capsized or ended before reaching n0[j] amplitudes (counted in `n_capsized_before`, `n_incomplete`).
    `count` is the number of amplitudes each trial contributed (at most max(n0)).
    """

    n0: tuple[int, ...]
    maxima_deg: np.ndarray
    capsized: np.ndarray
    capsize_time: np.ndarray
    count: np.ndarray
    config: dict = field(default_factory=dict)

    def valid(self, j: int) -> np.ndarray:
        return np.isfinite(self.maxima_deg[:, j])

    def n_capsized_before(self, j: int) -> int:
        """Trials that capsized before their n0[j]-th amplitude."""
        return int(np.sum(self.capsized & ~self.valid(j)))

    def n_incomplete(self, j: int) -> int:
        """Trials that neither capsized nor reached n0[j] amplitudes (increase `duration`)."""
        return int(np.sum(~self.capsized & ~self.valid(j)))


def default_duration(problem: RollProblem, n0: Sequence[int], discard: float) -> float:
    """Simulated time [s] that lets nearly every trial reach max(n0) amplitudes: 1.6 × max(n0) half periods."""
    half_period = float(problem.ship.roll_period) / 2
    return discard + 1.6 * max(n0) * half_period + 4 * half_period


def monte_carlo_maxima(
    problem: RollProblem,
    key,
    *,
    n0: Sequence[int] = (20, 50, 100, 1000),
    num_realizations: int = 10_000,
    discard: float = 500.0,
    duration: float | None = None,
    chunk_size: int = 1000,
    progress: Callable[[int], None] | None = None,
    devices=None,
    checkpoint=None,
    checkpoint_every: int | None = None,
) -> MaximaStatistics:
    """The paper's maxima protocol: per trial, the largest of the first N0 zero-crossing amplitudes after `discard`.

    **Arguments:**

    - `problem`: from `make_problem` (initial roll 5° in the paper).
    - `key`: JAX PRNG key; trial i uses `fold_in(key, i)` (same trials as `monte_carlo_amplitudes`).
    - `n0`: the numbers of amplitudes N0 (each ≥ 1), all taken from the same trials.
    - `num_realizations`: trials N (10⁴; the paper uses 5·10³ for N0 = 10⁴).
    - `discard`: initial time left out [s] (500).
    - `duration`: simulated time per trial [s]; default `default_duration` (1.6 × max(n0) half roll periods).
    - `chunk_size`: trials per compiled batch (memory is bounded by it, not by N0 or N).
    - `progress`, `devices`, `checkpoint`, `checkpoint_every`: as in `jaxroll.roll._monte_carlo.run_chunks` (sharding
      over devices and hosts; interruptible runs that resume from a checkpoint directory).

    **Returns:** `MaximaStatistics`.
    """
    n0 = tuple(int(n) for n in n0)
    if not n0 or min(n0) < 1:
        raise ValueError(f"`n0` must be a non-empty list of integers >= 1; got {n0}.")
    if not (isinstance(num_realizations, int) and num_realizations > 0):
        raise ValueError(f"`num_realizations` must be a positive integer; got {num_realizations!r}.")
    if not (math.isfinite(discard) and discard >= 0):
        raise ValueError(f"`discard` must be >= 0 [s]; got {discard!r}.")
    if duration is None:
        duration = default_duration(problem, n0, discard)
    if not (math.isfinite(duration) and duration > discard):
        raise ValueError(f"`duration` must be > discard = {discard} s; got {duration!r}.")
    dt = problem.dt
    num_steps = int(round(duration / dt))
    _, per = run_chunks(
        _chunk_maxima,
        problem,
        key,
        num_realizations,
        chunk_size,
        (num_steps, int(round(discard / dt)), n0),
        progress,
        devices=devices,
        checkpoint=checkpoint,
        checkpoint_every=checkpoint_every,
    )
    maxima = np.where(per["maxima"] >= 0, np.rad2deg(per["maxima"]), np.nan)
    count = per["count"]
    return MaximaStatistics(
        n0=n0,
        maxima_deg=maxima,
        capsized=per["capsized"],
        capsize_time=per["capsize_time"],
        count=count,
        config={"num_realizations": num_realizations, "discard_s": discard, "duration_s": duration, "dt_s": dt},
    )
