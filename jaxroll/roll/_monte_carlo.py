"""The Monte Carlo: one realization written once (`simulate`), vmapped over chunks, reduced by an observer.

`monte_carlo(problem, key, observer, ...)` is the one loop. `monte_carlo_amplitudes`, `monte_carlo_maxima` and
`monte_carlo_max_roll` are that loop with the `AmplitudeHistogram`, `FirstMaxima` and `MaxRoll` observers.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from .._config import require_float64
from .._display import progress_bar
from ._equation import RollProblem, simulate
from ._observers import AbstractObserver, AmplitudeHistogram, FirstMaxima, MaxRoll, envelope_record_every
from ._sharding import BYTES_PER_REALIZATION_STEP, chunk_size_for_memory, default_chunk_size, run_chunks
from ._statistics import AmplitudeStatistics, MaximaStatistics, MaxRollStatistics
from ._yaw import yaw_bytes_per_realization

#: A ship with a GZ surface runs the amplitude Monte Carlo only (`monte_carlo_amplitudes`, `jaxroll pdf`): the
#: maxima's and the exceedances' time loops (`MaxRoll`, `FirstMaxima`) with the surface took XLA:CPU over 20 GB of
#: memory to compile on one CPU device (issue 44, item 3; a known defect, refused rather than risked).
SURFACE_MAXIMA_REFUSAL = (
    "a ship with a GZ(φ, ζ_mid) surface (ship.restoring_surface) runs the amplitude Monte Carlo only (jaxroll pdf, "
    "monte_carlo_amplitudes) for now: the maxima's and exceedances' Monte Carlo (maxima, risk, longterm) with the "
    "surface needs more compiler memory than is safe. Drop the surface for those (the ship file without "
    "[restoring_surface]) or use jaxroll pdf."
)


def simulate_chunk(
    problem: RollProblem,
    key,
    indices,
    valid,
    observer: AbstractObserver,
    num_steps: int,
    dtype=jnp.float64,
    *,
    remat: bool = False,
):
    """Realizations `indices` (realization i keyed `fold_in(key, i)`) of `problem` for `num_steps` steps, reduced
    by `observer`: returns its `(summed, per_realization)`. Pure and jittable: `simulate` (one realization)
    vmapped, the body of every Monte Carlo and what the calibration evaluates (and differentiates) inside its
    objective. `dtype`: the integration's floating type (float64 here; `monte_carlo` runs float32). `remat=True`
    recomputes each realization in the backward pass instead of storing it (reverse-mode autodiff through long
    runs). Observers get the per-step (state, k, y, alive) of one realization, y in `dtype`."""
    require_float64("jaxroll.simulate_chunk")

    def one(i):
        k = jr.fold_in(key, i)
        return simulate(
            problem,
            k,
            num_steps,
            lambda state, step, y, alive: observer.observe(problem, state, step, y, alive),
            observer.init(problem, k),
            dtype=dtype,
            finished=None if observer.finished is None else lambda state: observer.finished(problem, state),
            record_every=observer.record_every(problem),
        )

    states, outputs, end = jax.vmap(jax.checkpoint(one) if remat else one)(indices)
    summed, per = observer.reduce(problem, states, outputs, end, valid)
    if problem.ship.restoring_surface is not None:  # which ended by leaving it (`monte_carlo` counts them)
        per = {**per, LEFT_SURFACE: end.left_range & valid}
    return summed, per


LEFT_SURFACE = "left_gz_surface_range"
"""The per-realization flag `simulate_chunk` adds for a ship with a GZ surface: the realization ended by leaving the
surface's range (counted with the capsizes); `monte_carlo` records their number as `config["n_left_gz_surface_range"]`
and warns."""


def _count_left_surface(problem: RollProblem, per: dict, config: dict) -> None:
    """Move the left-the-surface flags out of `per` into `config` (their count), with a warning when any left."""
    if LEFT_SURFACE not in per:
        return
    n = int(np.sum(np.asarray(per.pop(LEFT_SURFACE))))
    config["n_left_gz_surface_range"] = n
    if n:
        s = problem.ship.restoring_surface
        warnings.warn(
            f"{n} of {config['num_realizations']} realizations left the ship's GZ surface (|φ| <= "
            f"{math.degrees(float(s.heel_max)):.4g}°, ζ_mid in [{float(s.zeta_min):.3g}, {float(s.zeta_max):.3g}] m) "
            "and ended there, counted with the capsizes (never extrapolated): widen the surface (jaxroll "
            "hydrostatics --gz-surface with a larger --heel-max-deg or --zeta-max) for their fate.",
            stacklevel=3,
        )


def _check_count(name: str, value) -> None:
    if not (isinstance(value, int) and not isinstance(value, bool) and value > 0):
        raise ValueError(f"`{name}` must be a positive integer; got {value!r}.")


def monte_carlo(
    problem: RollProblem,
    key,
    observer: AbstractObserver,
    *,
    num_realizations: int = 10_000,
    duration: float = 3600.0,
    chunk_size: int | None = None,
    progress: Callable[[int], None] | bool | None = None,
    devices=None,
    checkpoint: str | os.PathLike | None = None,
    checkpoint_every: int | None = None,
    memory_budget: float | None = None,
    dtype=jnp.float32,
):
    """Run `num_realizations` realizations of `problem` for `duration` [s] and return what `observer` records.

    **Arguments:**

    - `problem`: a `RollProblem` (e.g. `RollProblem.from_sea(ship, sea)`).
    - `key`: a JAX PRNG key (`jax.random.key(seed)`); realization i uses `fold_in(key, i)`, whatever the
      observer, so different observers see the same trials.
    - `observer`: `AmplitudeHistogram(...)`, `FirstMaxima(...)`, `MaxRoll(...)` or your own `AbstractObserver`.
    - `num_realizations`: trials; `duration`: simulated time per trial [s].
    - `chunk_size`: realizations per compiled batch; None: `default_chunk_size` (per device: 500 per CPU core
      for every observer, 1000 on a 2-core CPU; on GPUs/TPUs 10⁵ for observers that keep each realization's
      history and 2.5·10⁵ for streaming ones, to fill them).
    - `memory_budget`: bytes a chunk may use (None: `default_memory_budget`, a quarter of the host's available
      memory on a CPU, 0.9 of the devices' free memory on GPUs/TPUs); the chunk is cut to fit it (to three
      significant binary digits, so it keeps its shape), so a small `dt` cannot exhaust memory. Results do not
      depend on the chunk.
    - `progress`: called with the number of realizations done after each chunk (and once after a checkpoint of
      this run has been read, with the realizations it holds); `True`: a tqdm progress bar (the notebook widget
      in Jupyter, a text bar on stderr elsewhere; needs tqdm, in the `notebook` extra).
    - `devices`: None (every device of every process), an int n (the first n) or a sequence of devices: the
      realization axis is sharded over them (`docs/scaling.md`).
    - `checkpoint`: a directory; the run saves its state there and resumes from it (`checkpoint_every` chunks,
      or every 60 s). Results are identical whatever the devices, the chunking or the interruptions.
    - `dtype`: the integration's floating type. float32 (default) is ~1.6× faster on a CPU; the statistics equal
      float64's on the same noise to ~1e-5 deg (tests/test_dynamics.py, docs/numerics.md). Sums are float64.

    **Returns:** `observer.result(...)` (e.g. `AmplitudeStatistics`), with `config` recording the run.
    """
    require_float64("jaxroll.monte_carlo")
    _check_count("num_realizations", num_realizations)
    if chunk_size is None:
        chunk_size = default_chunk_size(observer.keeps_history, devices)
    _check_count("chunk_size", chunk_size)
    if not isinstance(observer, AbstractObserver):
        raise TypeError(
            f"`observer` must be an AbstractObserver (e.g. AmplitudeHistogram()); got {observer!r}."
        )
    _check_duration(duration)
    if problem.ship.restoring_surface is not None and not isinstance(observer, AmplitudeHistogram):
        raise ValueError(SURFACE_MAXIMA_REFUSAL)
    num_steps = int(round(duration / problem.dt))
    per_realization = observer.bytes_per_realization(num_steps // observer.record_every(problem))
    if yaw_bytes := yaw_bytes_per_realization(problem, num_steps):  # the yawed synthesis' nodes (docs/yaw.md)
        per_realization = (per_realization or max(num_steps, 1) * BYTES_PER_REALIZATION_STEP) + yaw_bytes
    chunk_size = chunk_size_for_memory(chunk_size, num_steps, memory_budget, per_realization, devices)
    with progress_bar(progress, num_realizations, "Monte Carlo") as report:
        summed, per = run_chunks(
            simulate_chunk,
            problem,
            key,
            num_realizations,
            chunk_size,
            (observer, num_steps, dtype),
            report,
            devices=devices,
            checkpoint=checkpoint,
            checkpoint_every=checkpoint_every,
            consistency=observer.consistency,
        )
    config = {
        "num_realizations": num_realizations,
        "duration_s": float(duration),
        "dt_s": problem.dt,
        "chunk_size": chunk_size,
    }
    _count_left_surface(problem, per, config)
    return observer.result(summed, per, config)


def _check_duration(duration) -> None:
    if not (isinstance(duration, int | float) and math.isfinite(duration) and duration > 0):
        raise ValueError(f"`duration` must be a finite number > 0 [s]; got {duration!r}.")


def _check_discard(discard, duration, dt, min_steps: int = 16) -> None:
    """`duration` [s] valid, and `discard` [s] in [0, duration) leaving at least `min_steps` steps of `dt`."""
    _check_duration(duration)
    if not (isinstance(discard, int | float) and math.isfinite(discard) and 0 <= discard < duration):
        raise ValueError(f"`discard` must be in [0, duration) = [0, {duration}) s; got {discard!r}.")
    if (duration - discard) / dt < min_steps:
        raise ValueError(
            f"duration − discard = {duration - discard} s leaves fewer than {min_steps} time steps of {dt} s."
        )


def monte_carlo_amplitudes(
    problem: RollProblem,
    key,
    *,
    num_realizations: int = 10_000,
    duration: float = 3600.0,
    discard: float = 0.0,
    chunk_size: int | None = None,
    bin_width_deg: float = 0.05,
    max_deg: float = 90.0,
    **run_options,
) -> AmplitudeStatistics:
    """Monte Carlo amplitude statistics of `problem` (the paper's MCS protocol by default): `monte_carlo` with
    an `AmplitudeHistogram(discard, bin_width_deg, max_deg)` observer.

    **Arguments:** `discard`: initial transient left out of the statistics [s]; `bin_width_deg`, `max_deg`: the
    fine histogram grid [deg] behind every PDF and quantile; the rest (`progress`, `devices`, `checkpoint`,
    `checkpoint_every`) as in `monte_carlo`.

    **Returns:** `AmplitudeStatistics` (zero-crossing amplitudes per half cycle, envelope amplitudes per sample).
    """
    require_float64("jaxroll.monte_carlo_amplitudes")
    _check_discard(discard, duration, problem.dt)
    observer = AmplitudeHistogram(
        float(discard), float(bin_width_deg), float(max_deg), envelope_record_every(problem)
    )
    return monte_carlo(
        problem,
        key,
        observer,
        num_realizations=num_realizations,
        duration=duration,
        chunk_size=chunk_size,
        **run_options,
    )


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
    chunk_size: int | None = None,
    **run_options,
) -> MaximaStatistics:
    """The paper's maxima protocol: per trial, the largest of the first N0 zero-crossing amplitudes after `discard`
    [s] (500), for each N0 in `n0`, from the same trials: `monte_carlo` with a `FirstMaxima` observer.

    `duration` [s] defaults to `default_duration` (1.6 × max(n0) half roll periods); the rest as in `monte_carlo`
    (`chunk_size` None: 500 per CPU core — nothing per step is kept, and a chunk stops once its last trial is
    done).

    **Returns:** `MaximaStatistics`.
    """
    require_float64("jaxroll.monte_carlo_maxima")
    n0 = tuple(int(n) for n in n0)
    if not n0 or min(n0) < 1:
        raise ValueError(f"`n0` must be a non-empty list of integers >= 1; got {n0}.")
    if not (isinstance(discard, int | float) and math.isfinite(discard) and discard >= 0):
        raise ValueError(f"`discard` must be >= 0 [s]; got {discard!r}.")
    if duration is None:
        duration = default_duration(problem, n0, discard)
    if not (math.isfinite(duration) and duration > discard):
        raise ValueError(f"`duration` must be > discard = {discard} s; got {duration!r}.")
    return monte_carlo(
        problem,
        key,
        FirstMaxima(n0, float(discard)),
        num_realizations=num_realizations,
        duration=duration,
        chunk_size=chunk_size,
        **run_options,
    )


def monte_carlo_max_roll(
    problem: RollProblem,
    key,
    *,
    angle_deg: float,
    num_realizations: int = 1000,
    duration: float = 1800.0,
    discard: float = 0.0,
    chunk_size: int | None = None,
    **run_options,
) -> MaxRollStatistics:
    """Per-trial maximum |φ| after `discard` [s] and capsizes of `problem`, and the trials beyond `angle_deg`
    [deg] (which must be below the angle of vanishing stability): `monte_carlo` with a `MaxRoll` observer.

    **Returns:** `MaxRollStatistics`.
    """
    require_float64("jaxroll.monte_carlo_max_roll")
    _check_discard(discard, duration, problem.dt, min_steps=1)
    capsize_deg = math.degrees(float(problem.capsize_angle))
    if not (0 < angle_deg < capsize_deg):
        raise ValueError(
            f"`angle_deg` must be in (0, {capsize_deg:.1f}) deg (the angle of vanishing stability); "
            f"got {angle_deg!r}."
        )
    return monte_carlo(
        problem,
        key,
        MaxRoll(float(angle_deg), float(discard)),
        num_realizations=num_realizations,
        duration=duration,
        chunk_size=chunk_size,
        **run_options,
    )
