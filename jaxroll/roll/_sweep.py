"""Capsize and angle-exceedance probabilities per trial, mapped over sea states (H1/3, T01, speed, heading).

Per trial (realization) the Monte Carlo keeps only the largest |φ| after the discard and the capsize
outcome, so memory per realization is a few numbers whatever the duration: `monte_carlo_max_roll` runs
through `run_chunks` (sharded over devices, checkpointable) and `sweep_sea_states` repeats it over a grid
of sea states, each problem built by `RollProblem.from_sea`. Probabilities come with Wilson score intervals
(binomial; unlike the normal approximation, sound near p = 0 or 1).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .._config import require_float64
from .._display import progress_bar
from ..sea._spectra import ITTC, heading_angle
from ..sea._spreading import Spreading
from ..ship._ship import Ship
from ._equation import RollProblem
from ._monte_carlo import monte_carlo_max_roll
from ._statistics import SweepResult, wilson_interval

HEADINGS = ("head", "following")


def heading_label(heading: str | float) -> str:
    """Name of a heading on the sweep's grid: "head" (χ = π), "following" (χ = 0), else e.g. "135deg".

    **Raises:** `ValueError` for a heading `heading_angle` refuses.
    """
    chi = heading_angle(heading)
    if chi == math.pi:
        return "head"
    if chi == 0.0:
        return "following"
    return f"{math.degrees(chi):g}deg"


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
    heading: Sequence[str | float] = ("head",),
    angle_deg: float = 30.0,
    confidence: float = 0.95,
    num_realizations: int = 200,
    duration: float = 1800.0,
    discard: float = 0.0,
    excitation: str = "auto",
    dt: float = 0.5,
    filter_order: int | str = "auto",
    phi0: float = math.radians(5.0),
    spreading: Spreading | None = None,
    chunk_size: int | None = None,
    devices=None,
    checkpoint: str | os.PathLike | None = None,
    progress: Callable[[int], None] | bool | None = None,
) -> SweepResult:
    """Capsize and exceedance probabilities of `ship` in ITTC seas over the grid hs × t01 × speed × heading.

    Every grid point uses the same key (common random numbers: the same trial indices, hence smoother maps and
    sharper differences between neighbours) and its own problem from `RollProblem.from_sea`.

    **Arguments:** `ship`; `key`; `hs` [m], `t01` [s], `speed` [m/s] and `heading` ("head" | "following" |
    χ [rad] in [0, π]: 0 following, π/2 beam, π head): the grid (the heading axis holds `heading_label`s); `angle_deg` [deg] and `confidence`: the exceedance angle and the interval level; the rest as in
    `monte_carlo_max_roll` and `RollProblem.from_sea` (`spreading`: one directional spreading for every point, None
    long-crested). `checkpoint`: a directory holding one sub-directory per grid
    point (`point_label`), so an interrupted sweep resumes at the point and chunk where it stopped.
    `progress` is called with the realizations done over the whole sweep (`True`: a tqdm bar, as in `monte_carlo`).

    **Returns:** `SweepResult`.
    """
    require_float64("jaxroll.sweep_sea_states")
    headings = {heading_label(h): h for h in heading}  # validates; the API value behind each label
    axes = {
        "heading": [heading_label(h) for h in heading],
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
    shape = tuple(len(v) for v in axes.values())
    n_capsized = np.zeros(shape, np.int64)
    n_exceeded = np.zeros(shape, np.int64)
    # Every grid point's problem (time-step check, filter fit and its gate) before any simulation, so that a sea
    # state the model cannot represent stops the sweep at once, named.
    problems = {}
    for index in np.ndindex(*shape):
        h, u, height, period = (values[i] for values, i in zip(axes.values(), index, strict=True))
        try:
            problems[index] = RollProblem.from_sea(
                ship,
                ITTC(height, period),
                speed=u,
                heading=headings[h],
                excitation=excitation,
                dt=dt,
                filter_order=filter_order,
                phi0=phi0,
                spreading=spreading,
            )
        except ValueError as e:
            where = f"heading {h}, U {u:g} m/s, H1/3 {height:g} m, T01 {period:g} s"
            raise ValueError(f"sea state ({where}): {e}") from e
    with progress_bar(progress, num_realizations * len(problems), "sweep") as report:
        _run_sweep(
            problems,
            axes,
            shape,
            key,
            angle_deg,
            num_realizations,
            duration,
            discard,
            chunk_size,
            devices,
            checkpoint,
            report,
            n_capsized,
            n_exceeded,
        )
    return SweepResult(axes, num_realizations, float(angle_deg), confidence, n_capsized, n_exceeded)


def _run_sweep(
    problems,
    axes,
    shape,
    key,
    angle_deg,
    num_realizations,
    duration,
    discard,
    chunk_size,
    devices,
    checkpoint,
    progress,
    n_capsized,
    n_exceeded,
) -> None:
    """The Monte Carlo at each grid point in turn, its counts into `n_capsized`, `n_exceeded`."""
    done = 0
    for index in np.ndindex(*shape):
        h, u, height, period = (values[i] for values, i in zip(axes.values(), index, strict=True))
        problem = problems[index]
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
