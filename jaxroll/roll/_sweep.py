"""Capsize and angle-exceedance probabilities per trial, mapped over sea states (H1/3, T01, speed, heading).

Per trial (realization) the Monte Carlo keeps only the largest |φ| after the discard and the capsize
outcome, so memory per realization is a few numbers whatever the duration: `monte_carlo_max_roll` runs
through `run_chunks` (sharded over devices, checkpointable) and `sweep_sea_states` repeats it over a grid
of sea states, each problem built by `make_problem`. Probabilities come with Wilson score intervals
(binomial; unlike the normal approximation, sound near p = 0 or 1).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ..extremes import _maxima as _extremes
from ._equation import RollProblem, simulate
from ._monte_carlo import CapsizeCounts, make_problem, run_chunks
from ..ship._ship import Ship
from ..sea._spectra import ITTC

HEADINGS = ("head", "following")


def wilson_interval(successes, trials, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """`jaxroll.extremes._maxima.wilson_interval` as numpy arrays: `(lower, upper)` of a binomial proportion."""
    lo, hi = _extremes.wilson_interval(successes, trials, confidence)
    return np.asarray(lo), np.asarray(hi)


def _chunk_max_roll(problem, key, indices, valid, num_steps, discard_steps, angle):
    """Largest |φ| [rad] after `discard_steps` per realization, capsizes, and the counts reduced on device."""

    def one(i):
        def observe(peak, k, y, alive):
            return jnp.where(k > discard_steps, jnp.maximum(peak, jnp.abs(y[0])), peak), None

        peak, _, end = simulate(problem, jr.fold_in(key, i), num_steps, observe, jnp.zeros(()))
        return peak, end

    peak, end = jax.vmap(one)(indices)
    capsized = end.capsized & valid
    exceeded = valid & (end.capsized | (peak > angle))
    # Integer counts: exact whatever the order in which XLA adds them across devices.
    summed = {
        "n_capsized": jnp.sum(capsized, dtype=jnp.int64),
        "n_exceeded": jnp.sum(exceeded, dtype=jnp.int64),
    }
    per = {"max_abs_phi": jnp.where(valid, peak, 0.0), "capsized": capsized, "capsize_time": end.capsize_time}
    return summed, per


@dataclass
class MaxRollStatistics(CapsizeCounts):
    """Per-trial largest roll and capsizes (host numpy arrays; realization order).

    `max_abs_phi_deg` is the largest |φ| after the discard (for a capsized trial, up to its capsize). A trial
    exceeds an angle when that maximum is larger or when it capsized.
    """

    max_abs_phi_deg: np.ndarray
    capsized: np.ndarray
    capsize_time: np.ndarray
    angle_deg: float
    n_exceeded: int
    config: dict = field(default_factory=dict)

    def exceedances(self, angle_deg: float | None = None) -> int:
        """Trials with max |φ| > `angle_deg` [deg] (default: the run's angle) or capsized."""
        if angle_deg is None:
            return self.n_exceeded
        return int(np.sum(self.capsized | (self.max_abs_phi_deg > angle_deg)))

    def exceedance_probability(self, angle_deg: float | None = None) -> float:
        """P(max |φ| > angle within the duration) per trial."""
        return self.exceedances(angle_deg) / self.n_realizations

    def capsize_interval(self, confidence: float = 0.95) -> tuple[float, float]:
        lo, hi = wilson_interval(self.n_capsized, self.n_realizations, confidence)
        return float(lo), float(hi)

    def exceedance_interval(
        self, angle_deg: float | None = None, confidence: float = 0.95
    ) -> tuple[float, float]:
        lo, hi = wilson_interval(self.exceedances(angle_deg), self.n_realizations, confidence)
        return float(lo), float(hi)


def monte_carlo_max_roll(
    problem: RollProblem,
    key,
    *,
    angle_deg: float,
    num_realizations: int = 1000,
    duration: float = 1800.0,
    discard: float = 0.0,
    chunk_size: int = 1000,
    progress: Callable[[int], None] | None = None,
    devices=None,
    checkpoint: str | os.PathLike | None = None,
    checkpoint_every: int | None = None,
) -> MaxRollStatistics:
    """Per-trial maximum |φ| and capsizes of `problem`, and the probability of exceeding `angle_deg`.

    **Arguments:**

    - `problem`: from `make_problem`; `key`: JAX PRNG key (realization i uses `fold_in(key, i)`, the same
      trials as `monte_carlo_amplitudes`).
    - `angle_deg`: the angle [deg] whose exceedance is counted on device (any other:
      `exceedance_probability(a)`); must be below the angle of vanishing stability.
    - `num_realizations`: trials; `duration`: simulated time per trial [s]; `discard`: initial time left
      out of the maximum [s] (a capsize counts whenever it happens).
    - `chunk_size`, `progress`, `devices`, `checkpoint`, `checkpoint_every`: as in `run_chunks`.

    **Returns:** `MaxRollStatistics`.
    """
    if not (isinstance(num_realizations, int) and num_realizations > 0):
        raise ValueError(f"`num_realizations` must be a positive integer; got {num_realizations!r}.")
    if not (isinstance(chunk_size, int) and chunk_size > 0):
        raise ValueError(f"`chunk_size` must be a positive integer; got {chunk_size!r}.")
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"`duration` must be > 0 [s]; got {duration!r}.")
    if not (0 <= discard < duration):
        raise ValueError(f"`discard` must be in [0, duration) = [0, {duration}) s; got {discard!r}.")
    capsize_deg = float(np.rad2deg(problem.capsize_angle))
    if not (0 < angle_deg < capsize_deg):
        raise ValueError(
            f"`angle_deg` must be in (0, {capsize_deg:.1f}) deg (the angle of vanishing stability); "
            f"got {angle_deg!r}."
        )
    dt = problem.dt
    num_steps = int(round(duration / dt))
    discard_steps = int(round(discard / dt))
    summed, per = run_chunks(
        _chunk_max_roll,
        problem,
        key,
        num_realizations,
        chunk_size,
        (num_steps, discard_steps, float(np.deg2rad(angle_deg))),
        progress,
        devices=devices,
        checkpoint=checkpoint,
        checkpoint_every=checkpoint_every,
    )
    return MaxRollStatistics(
        max_abs_phi_deg=np.rad2deg(per["max_abs_phi"]),
        capsized=per["capsized"],
        capsize_time=per["capsize_time"],
        angle_deg=float(angle_deg),
        n_exceeded=int(summed["n_exceeded"]),
        config={
            "num_realizations": num_realizations,
            "duration_s": duration,
            "discard_s": discard,
            "dt_s": dt,
        },
    )


@dataclass
class SweepResult:
    """Probabilities on the grid, arrays shaped (heading, speed, H1/3, T01) in the order of `grid`'s axes."""

    grid: dict
    n_realizations: int
    angle_deg: float
    confidence: float
    n_capsized: np.ndarray
    n_exceeded: np.ndarray

    @property
    def capsize_probability(self) -> np.ndarray:
        return self.n_capsized / self.n_realizations

    @property
    def exceedance_probability(self) -> np.ndarray:
        return self.n_exceeded / self.n_realizations

    def capsize_interval(self) -> np.ndarray:
        """Wilson interval, shape (..., 2)."""
        return np.stack(wilson_interval(self.n_capsized, self.n_realizations, self.confidence), -1)

    def exceedance_interval(self) -> np.ndarray:
        """Wilson interval, shape (..., 2)."""
        return np.stack(wilson_interval(self.n_exceeded, self.n_realizations, self.confidence), -1)


def point_label(heading: str, speed: float, hs: float, t01: float) -> str:
    """Folder name of one grid point's checkpoint."""
    return f"{heading}_U{speed:g}_H{hs:g}_T{t01:g}"


def sweep_sea_states(
    ship: Ship,
    key,
    *,
    hs: Sequence[float],
    t01: Sequence[float],
    speed: Sequence[float] = (0.0,),
    heading: Sequence[str] = ("head",),
    angle_deg: float = 30.0,
    confidence: float = 0.95,
    num_realizations: int = 200,
    duration: float = 1800.0,
    discard: float = 0.0,
    method: str = "filter",
    dt: float = 0.5,
    filter_order: int = 4,
    phi0_deg: float = 5.0,
    chunk_size: int = 1000,
    devices=None,
    checkpoint: str | os.PathLike | None = None,
    progress: Callable[[int], None] | None = None,
) -> SweepResult:
    """Capsize and exceedance probabilities of `ship` in ITTC seas over the grid hs × t01 × speed × heading.

    Every grid point uses the same key (common random numbers: the same trial indices, hence smoother maps and
    sharper differences between neighbours) and its own problem from `make_problem`.

    **Arguments:** `ship`; `key`; `hs` [m], `t01` [s], `speed` [m/s] and `heading` ("head" | "following"):
    the grid; `angle_deg` [deg] and `confidence`: the exceedance angle and the interval level; the rest as in
    `monte_carlo_max_roll` and `make_problem`. `checkpoint`: a directory holding one sub-directory per grid
    point (`point_label`), so an interrupted sweep resumes at the point and chunk where it stopped.
    `progress` is called with the realizations done over the whole sweep.

    **Returns:** `SweepResult`.
    """
    axes = {
        "heading": [str(h) for h in heading],
        "speed_m_s": [float(u) for u in speed],
        "hs_m": [float(h) for h in hs],
        "t01_s": [float(t) for t in t01],
    }
    for name, values in axes.items():
        if not values:
            raise ValueError(f"the sweep needs at least one value of `{name}`.")
        if len(set(values)) != len(values):
            raise ValueError(f"`{name}` has repeated values: {values}.")
    wilson_interval(0, 1, confidence)  # validates `confidence` before any work
    bad = sorted(set(axes["heading"]) - set(HEADINGS))
    if bad:
        raise ValueError(f"`heading` must be among {HEADINGS}; got {bad}.")
    shape = tuple(len(v) for v in axes.values())
    n_capsized = np.zeros(shape, np.int64)
    n_exceeded = np.zeros(shape, np.int64)
    done = 0
    for index in np.ndindex(*shape):
        h, u, height, period = (values[i] for values, i in zip(axes.values(), index, strict=True))
        problem, _ = make_problem(
            ship,
            ITTC(height, period),
            speed=u,
            heading=h,
            method=method,
            dt=dt,
            filter_order=filter_order,
            phi0_deg=phi0_deg,
        )
        offset = done
        stats = monte_carlo_max_roll(
            problem,
            key,
            angle_deg=angle_deg,
            num_realizations=num_realizations,
            duration=duration,
            discard=discard,
            chunk_size=chunk_size,
            devices=devices,
            checkpoint=None if checkpoint is None else Path(checkpoint) / point_label(h, u, height, period),
            progress=None if progress is None else (lambda n, offset=offset: progress(offset + n)),
        )
        n_capsized[index] = stats.n_capsized
        n_exceeded[index] = stats.n_exceeded
        done += num_realizations
    return SweepResult(axes, num_realizations, float(angle_deg), confidence, n_capsized, n_exceeded)
