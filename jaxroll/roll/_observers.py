"""Observers: what a Monte Carlo keeps of each realization, reduced on the fly (like diffrax's `SaveAt(fn=…)`).

One loop (`jaxroll.monte_carlo`) integrates every realization; an observer decides what it records:

- `AmplitudeHistogram`: zero-crossing and envelope amplitude histograms and exact per-realization sums (PDFs);
- `FirstMaxima`: the largest of the first N0 zero-crossing amplitudes per trial (the paper's maxima protocol);
- `MaxRoll`: the largest |φ| per trial and the count of trials beyond an angle (risk, sweeps).

An observer is an `eqx.Module` of Python settings (hashable, so the compiled chunk is reused). Its methods:
`init(problem, key)` → per-realization state (`key`: the realization's key, for observers that draw noise); `observe(problem, state, k, y, alive)` → (state, per-step output or
None) after each step k (1-based); `record_every(problem)` → r: the outputs after steps r, 2r, … are kept (1: every
step); `reduce(problem, states, outputs, end, valid)` → (summed, per_realization) over a chunk
(leading axis: realizations; `summed` entries must be integer-valued so any device order adds them exactly);
`result(summed, per, config)` → the host result.
"""

from __future__ import annotations

import abc
import math
import warnings
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._amplitudes import (
    ZeroCrossingState,
    bin_counts,
    envelope_rfft,
    integer_counts,
    row_sums,
    zero_crossing_init,
    zero_crossing_update,
)
from ._equation import computed_once, runtime_one
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

    # `consistency(summed, per) -> list[str]`: what does not add up between the totals over realizations and the
    # per-realization arrays of a checkpoint (host numpy; `run_chunks` refuses a checkpoint with any). None: no check.
    consistency = None

    def record_every(self, problem) -> int:
        """r: the per-step outputs after the steps r, 2r, … are kept, the others are not computed (r divides the
        problem's `excitation.substeps`). Default 1: every step."""
        return 1

    def bytes_per_realization(self, num_records: int) -> int:
        """Peak working memory of one realization of a compiled chunk [bytes] that keeps `num_records` per-step
        outputs (the steps divided by `record_every`), used to size chunks to a memory budget. The default assumes
        the whole record is kept (64 B per record: the histogram observer's measured peak, 32 B, with a factor 2);
        observers that reduce step by step override it."""
        return 64 * num_records + 65_536


#: The histogram observer records φ at least this often per natural roll period (`envelope_record_every`).
RECORDS_PER_ROLL_PERIOD = 12


def envelope_record_every(problem) -> int:
    """The record interval of `AmplitudeHistogram` for `problem` [time steps]: the largest divisor r of the
    excitation's substeps m with r·dt ≤ Tφ/12 (Tφ the natural roll period; 1 if none), so the Hilbert envelope is
    taken of φ sampled at least 12 times per roll period. For the paper's protocol (dt 0.5 s, m 4, Tφ 24.4 s):
    r = 4, φ every 2 s. The envelope PDF is time-weighted, so sampling it every r steps estimates the same law; on
    the paper protocol the 10⁴-trial envelope histogram moves by a KS distance of 5e-5 and its mean by 2e-5
    (0.01 standard errors) against r = 1 (docs/numerics.md), for 1.9× the speed and a quarter of the memory.
    Needs concrete ship parameters (it is called outside `jit`)."""
    m, dt = problem.excitation.substeps, problem.dt
    longest = float(problem.ship.roll_period) / RECORDS_PER_ROLL_PERIOD
    return max([r for r in range(1, m + 1) if m % r == 0 and r * dt <= longest * (1 + 1e-9)], default=1)


class _HistogramState(eqx.Module):
    zc: ZeroCrossingState
    pending: jnp.ndarray  # the zero-crossing amplitude that ended since the last record [rad] (0: none)
    n: jnp.ndarray  # zero-crossing amplitudes after the discard
    s1: jnp.ndarray  # their sum [rad]
    s2: jnp.ndarray  # and sum of squares [rad²]


class AmplitudeHistogram(AbstractObserver):
    """Zero-crossing (per half cycle) and envelope (per record) amplitude histograms after `discard` [s], on a
    fine grid of `bin_width_deg` up to `max_deg` [deg] (amplitudes beyond it are counted in the last bin), with
    exact per-realization sums for means and E[φ²], E[φ⁴]. Result: `AmplitudeStatistics`.

    The zero-crossing detector sees every time step. φ is recorded every `record_every` steps (a divisor of the
    excitation's substeps; `monte_carlo_amplitudes` passes `envelope_record_every(problem)`, φ at least 12 times per
    roll period) and the Hilbert envelope, E[φ²] and E[φ⁴] are taken of that record; each zero-crossing amplitude
    is kept as a histogram bin in the record interval where its half cycle ended."""

    discard: float = 0.0
    bin_width_deg: float = 0.05
    max_deg: float = 90.0
    every: int = 1

    @property
    def num_bins(self) -> int:
        """Number of fine histogram bins [-] (`max_deg` / `bin_width_deg`)."""
        return int(round(self.max_deg / self.bin_width_deg))

    @property
    def _bin_type(self):
        return jnp.int16 if self.num_bins < 2**15 else jnp.int32

    def record_every(self, problem) -> int:
        """`every` [time steps]."""
        return self.every

    def _bins(self, amplitude):
        """Histogram bins of zero-crossing amplitudes [rad] (> 0), -1 where there is none (0)."""
        index = jnp.clip(jnp.floor(amplitude * (180 / math.pi / self.bin_width_deg)), 0, self.num_bins - 1)
        return jnp.where(amplitude > 0, index, -1).astype(self._bin_type)

    def init(self, problem, key):
        zero = jnp.zeros(())
        return _HistogramState(zero_crossing_init(problem.phi0), zero, jnp.array(0, jnp.int32), zero, zero)

    def observe(self, problem, state, k, y, alive):
        # Recorded: the roll (for the envelope) and the histogram bin of the zero-crossing amplitude that ended in
        # the record interval (-1: none; the bin is computed for the records only); the amplitudes' count and sums
        # run in the state, exactly (those overwritten in a record interval are counted in `reduce`).
        zc, amp = zero_crossing_update(state.zc, y[0])
        # kept, not recomputed in each of its five uses (φ is finite): the Monte Carlo 0.48 → 0.45 s
        amp = computed_once(amp, runtime_one(y[0]))
        on = (amp > 0) & (k > _steps(self.discard, problem.dt))
        kept = jnp.where(on, amp, 0)
        ended = jnp.where(on, amp, state.pending)
        pending = jnp.where(k % self.every == 0, 0, ended)  # recorded: start afresh
        new = _HistogramState(
            zc, pending, state.n + on.astype(state.n.dtype), state.s1 + kept, state.s2 + kept * kept
        )
        return new, (y[0], self._bins(ended))

    def reduce(self, problem, states, outputs, end, valid):
        # The envelope (rfft) and its histogram bins in the run's dtype (float32 in the Monte Carlo: each row's FFT
        # is independent of the others, so the counts do not depend on the chunk); the sums over time in float64.
        phi, zc_bin = outputs
        start = _steps(self.discard, problem.dt) // self.every  # the first record after the discard
        keep = valid & ~end.capsized
        phi, zc_bin = phi[:, start:], zc_bin[:, start:]
        env = envelope_rfft(phi)
        deg = 180 / math.pi
        # Every amplitude after the discard is in a kept record, in the state's `pending` (it ended after the last
        # record) or was overwritten by a later one in its record interval (merged): so merged = n − the others.
        in_histogram = jnp.sum(zc_bin >= 0, 1, dtype=jnp.int32) + (states.pending > 0).astype(jnp.int32)
        summed = {
            "counts_zero_crossing": bin_counts(zc_bin, keep[:, None] & (zc_bin >= 0), self.num_bins)
            + bin_counts(self._bins(states.pending), keep & (states.pending > 0), self.num_bins),
            "zero_crossing_merged": jnp.sum(jnp.where(keep, states.n - in_histogram, 0), dtype=jnp.int64),
            "counts_envelope": integer_counts(
                env * deg, jnp.broadcast_to(keep[:, None], env.shape), self.bin_width_deg, self.num_bins
            ),
        }
        kf = keep.astype(jnp.float64)
        n = phi.shape[1]
        first_half = jnp.arange(n) < n // 2
        phi2 = phi.astype(jnp.float64) ** 2
        sum_env, sum_env_first_half, sumsq_env, sum_phi2, sum_phi4 = row_sums(
            env, jnp.where(first_half, env, 0), env.astype(jnp.float64) ** 2, phi2, phi2 * phi2
        )
        per = {
            "capsized": end.capsized & valid,
            "capsize_time": end.capsize_time,
            "n_zc": kf * states.n.astype(jnp.float64),
            "sum_zc": kf * states.s1.astype(jnp.float64),
            "sumsq_zc": kf * states.s2.astype(jnp.float64),
            "n_env": kf * n,
            "sum_env": kf * sum_env,
            # the first half of the kept window (its n_env // 2 samples) alone: the second half's by difference
            "sum_env_first_half": kf * sum_env_first_half,
            "sumsq_env": kf * sumsq_env,
            "n_samples": kf * n,
            "sum_phi2": kf * sum_phi2,
            "sum_phi4": kf * sum_phi4,
            # the largest envelope amplitude after the discard [rad] (NaN: capsized): the trial's largest roll
            "max_env": jnp.where(keep, jnp.max(env, 1, initial=0.0).astype(jnp.float64), jnp.nan),
        }
        return summed, per

    def consistency(self, summed, per) -> list[str]:
        """The histograms' totals against the per-realization counts: every zero-crossing amplitude of a realization
        that did not capsize is in the histogram or merged, every envelope record is in the histogram."""
        out = []
        if any(np.any(np.asarray(summed[k]) < 0) for k in ("counts_zero_crossing", "counts_envelope")):
            out.append("a histogram holds negative counts")
        zc = float(np.sum(summed["counts_zero_crossing"])) + float(summed["zero_crossing_merged"])
        if zc != float(np.sum(per["n_zc"])):
            out.append(
                f"the zero-crossing histogram holds {zc:.0f} amplitudes (merged included), the realizations "
                f"{float(np.sum(per['n_zc'])):.0f}"
            )
        env = float(np.sum(summed["counts_envelope"]))
        if env != float(np.sum(per["n_env"])):
            out.append(
                f"the envelope histogram holds {env:.0f} samples, the realizations {float(np.sum(per['n_env'])):.0f}"
            )
        if np.any(np.asarray(per["capsized"]) & (np.asarray(per["n_zc"]) != 0)):
            out.append("a capsized realization has amplitudes")
        return out

    def result(self, summed, per, config):
        capsized = per.pop("capsized")
        capsize_time = per.pop("capsize_time")
        merged = int(summed["zero_crossing_merged"])
        if merged:
            warnings.warn(
                f"{merged} zero-crossing amplitudes ended in the same record interval ({self.every} time steps) as "
                f"the next one: the roll has half cycles that short, and only the later amplitude of each such pair "
                f"is in the zero-crossing histogram (the counts, means and E[A²] are exact). Record every step: "
                f"jaxroll.monte_carlo(problem, key, jaxroll.AmplitudeHistogram(discard, every=1), ...).",
                stacklevel=3,
            )
        return AmplitudeStatistics(
            edges_deg=np.arange(self.num_bins + 1) * self.bin_width_deg,
            counts_zero_crossing=summed["counts_zero_crossing"],
            counts_envelope=summed["counts_envelope"],
            capsized=capsized,
            capsize_time=capsize_time,
            per_realization=per,
            config={**config, "discard_s": self.discard, "record_interval_s": self.every * config["dt_s"]},
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
            zero_crossing_init(problem.phi0),
            jnp.array(0),
            jnp.array(0.0),
            tuple(jnp.array(-1.0) for _ in self.n0),
        )

    def observe(self, problem, state, k, y, alive):
        n_max = max(self.n0)
        zc, amp = zero_crossing_update(state.zc, y[0])
        counted = (amp > 0) & (k > _steps(self.discard, problem.dt)) & (state.count < n_max) & alive
        count = state.count + counted.astype(state.count.dtype)
        running = jnp.where(counted, jnp.maximum(state.running_max, amp), state.running_max)
        maxima = tuple(
            jnp.where(counted & (count == n), running, m) for n, m in zip(self.n0, state.maxima, strict=True)
        )
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

    def consistency(self, summed, per) -> list[str]:
        """Counts within [0, max N0], a maximum exactly where its N0 amplitudes were counted, and the maxima of a
        trial non-decreasing in N0."""
        maxima, count = np.asarray(per["maxima"]), np.asarray(per["count"])
        out = []
        if np.any((count < 0) | (count > max(self.n0))):
            out.append(f"an amplitude count is outside [0, {max(self.n0)}]")
        if np.any((maxima >= 0) != (count[:, None] >= np.asarray(self.n0)[None, :])):
            out.append(
                "a maximum is recorded where fewer amplitudes were counted, or missing where enough were"
            )
        order = np.argsort(self.n0)
        m = np.where(maxima >= 0, maxima, np.inf)[:, order]
        if np.any(np.diff(m, axis=1) < 0):
            out.append("a trial's maximum of more amplitudes is below its maximum of fewer")
        return out

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
        per = {
            "max_abs_phi": jnp.where(valid, states, 0.0),
            "capsized": capsized,
            "capsize_time": end.capsize_time,
        }
        return summed, per

    def consistency(self, summed, per) -> list[str]:
        """The totals against the trials: capsizes counted once each, exceedances those capsized or beyond the
        angle (compared in the trials' own float type, as on the device)."""
        capsized, peak = np.asarray(per["capsized"]), np.asarray(per["max_abs_phi"])
        exceeded = capsized | (peak > peak.dtype.type(math.radians(self.angle_deg)))
        out = []
        if int(summed["n_capsized"]) != int(capsized.sum()):
            out.append(f"n_capsized = {int(summed['n_capsized'])}, but {int(capsized.sum())} trials capsized")
        if int(summed["n_exceeded"]) != int(exceeded.sum()):
            out.append(
                f"n_exceeded = {int(summed['n_exceeded'])}, but {int(exceeded.sum())} trials exceeded the angle"
            )
        return out

    def result(self, summed, per, config):
        return MaxRollStatistics(
            max_abs_phi_deg=np.rad2deg(per["max_abs_phi"]),
            capsized=per["capsized"],
            capsize_time=per["capsize_time"],
            angle_deg=float(self.angle_deg),
            n_exceeded=int(summed["n_exceeded"]),
            config={**config, "discard_s": self.discard},
        )
