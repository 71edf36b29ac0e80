"""Observers: what a Monte Carlo keeps of each realization, reduced on the fly (like diffrax's `SaveAt(fn=…)`).

One loop (`jaxroll.monte_carlo`) integrates every realization; an observer decides what it records:

- `AmplitudeHistogram`: zero-crossing and envelope amplitude histograms and exact per-realization sums (PDFs);
- `FirstMaxima`: the largest of the first N0 zero-crossing amplitudes per trial (the paper's maxima protocol);
- `MaxRoll`: the largest |φ| per trial and the count of trials beyond an angle (risk, sweeps).

An observer is an `eqx.Module` of Python settings (hashable, so the compiled chunk is reused). Its methods:
`init(problem, key)` → per-realization state (`key`: the realization's key, for observers that draw noise); `observe(problem, state, k, y, alive)` → (state, per-step output or
None) after each step k (1-based); `reduce(problem, states, outputs, end, valid)` → (summed, per_realization) over a chunk
(leading axis: realizations; `summed` entries must be integer-valued so any device order adds them exactly);
`result(summed, per, config)` → the host result.
"""

from __future__ import annotations

import abc
import math
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._amplitudes import (
    ZeroCrossingState,
    bin_counts,
    envelope_rfft,
    integer_counts,
    zero_crossing_init,
    zero_crossing_update,
)
from ._statistics import AmplitudeStatistics, MaximaStatistics, MaxRollStatistics


def _steps(seconds: float, dt: float) -> int:
    return int(round(seconds / dt))


class AbstractObserver(eqx.Module):
    """What one Monte Carlo realization records, and how a chunk of them is reduced (see the module docstring)."""

    @abc.abstractmethod
    def init(self, problem, key):
        """Per-realization observer state before the first step (`key`: the realization's PRNG key)."""

    @abc.abstractmethod
    def observe(self, problem, state, k, y, alive):
        """After step k (1-based) with y = (φ, φ̇) [rad, rad/s]: `(state, output)`; outputs are stacked."""

    @abc.abstractmethod
    def reduce(self, problem, states, outputs, end, valid) -> tuple[dict, dict]:
        """`(summed, per_realization)` of a chunk; `valid` marks real (not padding) realizations."""

    @abc.abstractmethod
    def result(self, summed: dict, per: dict, config: dict):
        """The host-side result (numpy) from the totals over all chunks."""

    # Whether a realization's per-step history is kept until the chunk is reduced (its memory grows with the
    # duration); streaming observers set False (a wider default chunk: `default_chunk_size`).
    keeps_history: ClassVar[bool] = True

    # `finished(problem, state) -> bool`: the realization has recorded all it needs and its run may stop (observers
    # without per-step outputs only; `simulate`). None: every realization runs its whole duration.
    finished = None

    def bytes_per_realization(self, num_steps: int) -> int:
        """Peak working memory of one realization of a compiled chunk [bytes] for `num_steps` steps, used to size
        chunks to a memory budget. The default assumes the whole time series is kept (64 B per step: the
        histogram observer's measured peak, 32 B, with a factor 2); observers that reduce step by step override it."""
        return 64 * num_steps + 65_536


class _HistogramState(eqx.Module):
    zc: ZeroCrossingState
    n: jnp.ndarray  # zero-crossing amplitudes after the discard
    s1: jnp.ndarray  # their sum [rad]
    s2: jnp.ndarray  # and sum of squares [rad²]


class AmplitudeHistogram(AbstractObserver):
    """Zero-crossing (per half cycle) and envelope (per time sample) amplitude histograms after `discard` [s], on
    a fine grid of `bin_width_deg` up to `max_deg` [deg] (amplitudes beyond it are counted in the last bin), with
    exact per-realization sums for means and E[φ²], E[φ⁴]. Result: `AmplitudeStatistics`."""

    discard: float = 0.0
    bin_width_deg: float = 0.05
    max_deg: float = 90.0

    @property
    def num_bins(self) -> int:
        return int(round(self.max_deg / self.bin_width_deg))

    def init(self, problem, key):
        zero = jnp.zeros(())
        return _HistogramState(zero_crossing_init(problem.phi0), jnp.array(0), zero, zero)

    def observe(self, problem, state, k, y, alive):
        # Per step only the roll (for the envelope) and the zero-crossing amplitude's histogram bin (-1: none) are
        # kept; the amplitudes' count and sums run in the state.
        zc, amp = zero_crossing_update(state.zc, y[0])
        on = (amp > 0) & (k > _steps(self.discard, problem.dt))
        itype = jnp.int16 if self.num_bins < 2**15 else jnp.int32
        index = jnp.clip(jnp.floor(amp * (180 / math.pi / self.bin_width_deg)), 0, self.num_bins - 1)
        kept = jnp.where(on, amp, 0)
        new = _HistogramState(zc, state.n + on.astype(state.n.dtype), state.s1 + kept, state.s2 + kept * kept)
        return new, (y[0], jnp.where(on, index, -1).astype(itype))

    def reduce(self, problem, states, outputs, end, valid):
        # The envelope (rfft) and its histogram bins in the run's dtype (float32 in the Monte Carlo: each row's FFT
        # is independent of the others, so the counts do not depend on the chunk); the sums over time in float64.
        phi, zc_bin = outputs
        start = _steps(self.discard, problem.dt)
        keep = valid & ~end.capsized
        phi, zc_bin = phi[:, start:], zc_bin[:, start:]
        env = envelope_rfft(phi)
        deg = 180 / math.pi
        summed = {
            "counts_zero_crossing": bin_counts(zc_bin, keep[:, None] & (zc_bin >= 0), self.num_bins),
            "counts_envelope": integer_counts(
                env * deg, jnp.broadcast_to(keep[:, None], env.shape), self.bin_width_deg, self.num_bins
            ),
        }
        kf = keep.astype(jnp.float64)
        phi, env = (x.astype(jnp.float64) for x in (phi, env))
        phi2 = phi * phi
        per = {
            "capsized": end.capsized & valid,
            "capsize_time": end.capsize_time,
            "n_zc": kf * states.n.astype(jnp.float64),
            "sum_zc": kf * states.s1.astype(jnp.float64),
            "sumsq_zc": kf * states.s2.astype(jnp.float64),
            "n_env": kf * phi.shape[1],
            "sum_env": kf * jnp.sum(env, 1),
            # the first half of the kept window (its n_env // 2 samples) alone: the second half's by difference
            "sum_env_first_half": kf * jnp.sum(env[:, : phi.shape[1] // 2], 1),
            "sumsq_env": kf * jnp.sum(env * env, 1),
            "n_samples": kf * phi.shape[1],
            "sum_phi2": kf * jnp.sum(phi2, 1),
            "sum_phi4": kf * jnp.sum(phi2 * phi2, 1),
        }
        return summed, per

    def result(self, summed, per, config):
        capsized = per.pop("capsized")
        capsize_time = per.pop("capsize_time")
        return AmplitudeStatistics(
            edges_deg=np.arange(self.num_bins + 1) * self.bin_width_deg,
            counts_zero_crossing=summed["counts_zero_crossing"],
            counts_envelope=summed["counts_envelope"],
            capsized=capsized,
            capsize_time=capsize_time,
            per_realization=per,
            config={**config, "discard_s": self.discard},
        )


class _MaximaState(eqx.Module):
    zc: ZeroCrossingState
    count: jnp.ndarray
    running_max: jnp.ndarray
    maxima: tuple  # one scalar per N0 (not an [N0] array: vmapped, each stays one contiguous vector)


class FirstMaxima(AbstractObserver):
    """Per trial, the largest of its first N0 zero-crossing amplitudes after `discard` [s], for every N0 in `n0`
    (all from the same trials). Nothing per step is kept: memory is bounded by the chunk, not by N0.
    Result: `MaximaStatistics`."""

    n0: tuple[int, ...] = (20, 50, 100, 1000)
    discard: float = 500.0
    keeps_history: ClassVar[bool] = False

    def bytes_per_realization(self, num_steps: int) -> int:
        """Streaming: ~53 kB per realization measured at 72 000 steps (0.74 B per step), whatever the length;
        bounded here by 2 B per step + 64 kB [bytes]."""
        return 2 * num_steps + 65_536

    def init(self, problem, key):
        return _MaximaState(
            zero_crossing_init(problem.phi0), jnp.array(0), jnp.array(0.0), tuple(jnp.array(-1.0) for _ in self.n0)
        )

    def observe(self, problem, state, k, y, alive):
        n_max = max(self.n0)
        zc, amp = zero_crossing_update(state.zc, y[0])
        counted = (amp > 0) & (k > _steps(self.discard, problem.dt)) & (state.count < n_max) & alive
        count = state.count + counted.astype(state.count.dtype)
        running = jnp.where(counted, jnp.maximum(state.running_max, amp), state.running_max)
        maxima = tuple(jnp.where(counted & (count == n), running, m) for n, m in zip(self.n0, state.maxima, strict=True))
        return _MaximaState(zc, count, running, maxima), None

    def finished(self, problem, state):
        """All max(n0) amplitudes recorded: the trial stops (a later capsize would not change its maxima)."""
        return state.count >= max(self.n0)

    def reduce(self, problem, states, outputs, end, valid):
        per = {
            "maxima": jnp.where(valid[:, None], jnp.stack(states.maxima, -1).astype(jnp.float64), -1.0),
            "count": jnp.where(valid, states.count, 0),
            "capsized": end.capsized & valid,
            "capsize_time": end.capsize_time,
        }
        return {}, per

    def result(self, summed, per, config):
        return MaximaStatistics(
            n0=self.n0,
            maxima_deg=np.where(per["maxima"] >= 0, np.rad2deg(per["maxima"]), np.nan),
            capsized=per["capsized"],
            capsize_time=per["capsize_time"],
            count=per["count"],
            config={**config, "discard_s": self.discard},
        )


class MaxRoll(AbstractObserver):
    """Per trial, the largest |φ| after `discard` [s] and whether it capsized; the trials beyond `angle_deg`
    [deg] (or capsized) are counted on the device. Result: `MaxRollStatistics`."""

    angle_deg: float = 30.0
    discard: float = 0.0
    keeps_history: ClassVar[bool] = False

    def bytes_per_realization(self, num_steps: int) -> int:
        """Streaming: ~53 kB per realization measured at 72 000 steps (0.74 B per step), whatever the length;
        bounded here by 2 B per step + 64 kB [bytes]."""
        return 2 * num_steps + 65_536

    def init(self, problem, key):
        return jnp.zeros(())

    def observe(self, problem, state, k, y, alive):
        later = k > _steps(self.discard, problem.dt)
        return jnp.where(later, jnp.maximum(state, jnp.abs(y[0])), state), None

    def reduce(self, problem, states, outputs, end, valid):
        capsized = end.capsized & valid
        exceeded = valid & (end.capsized | (states > math.radians(self.angle_deg)))
        summed = {
            "n_capsized": jnp.sum(capsized, dtype=jnp.int64),
            "n_exceeded": jnp.sum(exceeded, dtype=jnp.int64),
        }
        per = {"max_abs_phi": jnp.where(valid, states, 0.0), "capsized": capsized, "capsize_time": end.capsize_time}
        return summed, per

    def result(self, summed, per, config):
        return MaxRollStatistics(
            max_abs_phi_deg=np.rad2deg(per["max_abs_phi"]),
            capsized=per["capsized"],
            capsize_time=per["capsize_time"],
            angle_deg=float(self.angle_deg),
            n_exceeded=int(summed["n_exceeded"]),
            config={**config, "discard_s": self.discard},
        )
